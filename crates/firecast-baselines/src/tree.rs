//! CART trees grown exactly as scikit-learn 1.9.1 grows them (`DepthFirstTreeBuilder` with
//! the dense `BestSplitter`), shared by the decision tree, the random forest and gradient
//! boosting. For the same `random_state`, hyper-parameters and `float32` data the trees are
//! scikit-learn's: same split features, thresholds and node values, bit for bit.
//!
//! What is reproduced, and from where (`sklearn/tree/_splitter.pyx`, `_partitioner.pyx`,
//! `_criterion.pyx`, `_tree.pyx`, `sklearn/utils/_sorting.pyx`, `_random.pxd`):
//! - **the random stream**: the splitter's state is `RandomState(random_state)
//!   .randint(0, 2³¹ − 1)` (see [`crate::nprandom`]) and every feature draw is
//!   `low + xorshift32() % (high − low)`;
//! - **the feature draws**: Fisher-Yates over a `features` array that persists from node to
//!   node, with the known-constant prefix inherited from the parent, newly found constant
//!   features (max − min ≤ 1e-7 in `f32`) moved aside, and the search stopping after
//!   `max_features` visits unless all visited features so far were constant;
//! - **the sample order**: one `samples` array of the positively weighted rows; each
//!   visited feature sorts the node's slice by value with scikit-learn's introsort
//!   (median-of-3 pivot, 3-way partition, heapsort below depth `2·⌊log₂ n⌋`, insertion
//!   sort up to 16 values), and the chosen split partitions it in place by swapping from
//!   the end — so ties come out in scikit-learn's order, which fixes every floating-point
//!   sum below;
//! - **the criterion** (`Gini`, `MSE`): running sums updated from the nearer end
//!   (forward from the last position, or backwards from the node's end), the proxy
//!   `−w_R·gini_R − w_L·gini_L` or `s_L²/w_L + s_R²/w_R`, only a strictly better proxy
//!   replacing the best (first feature visited and lowest threshold win ties), threshold
//!   `v[p−1]/2 + v[p]/2` in `f64`, children impurities and the weighted improvement
//!   computed as scikit-learn does after partitioning;
//! - **the builder**: a depth-first stack (right child pushed first), a node is a leaf
//!   when `depth ≥ max_depth`, it has fewer than `min_samples_split` or
//!   `2·min_samples_leaf` samples, its impurity is ≤ ε, no split keeps `min_samples_leaf`
//!   samples per side, or `improvement + ε < 0`; sample weights (bootstrap counts) weigh
//!   the criterion, sample counts the size rules.
//!
//! The fitted [`Tree`] stores children next to each other; [`Tree::preorder`] lists the
//! nodes in scikit-learn's numbering (depth-first, left first), so `tree_.feature`,
//! `tree_.threshold` and `tree_.value` can be compared entry by entry.

use serde::{Deserialize, Serialize};

use crate::codec;
use crate::nprandom::{RAND_R_MAX, RandomState, rand_int};

/// scikit-learn's `FEATURE_THRESHOLD` (an `f32`).
const FEATURE_THRESHOLD: f32 = 1e-7;
/// Marks a leaf in [`Tree::feature`].
pub(crate) const LEAF: u32 = u32::MAX;
/// No parent (the root).
const NONE: usize = usize::MAX;

/// Split quality.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Criterion {
    /// Binary Gini; the target is the class, 0 or 1.
    Gini,
    /// Squared error (scikit-learn's `squared_error`, which `friedman_mse` now maps to).
    Mse,
}

/// Growth limits, resolved from a spec.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TreeConfig {
    pub criterion: Criterion,
    /// `usize::MAX` when unlimited.
    pub max_depth: usize,
    pub min_samples_split: usize,
    pub min_samples_leaf: usize,
    /// Features drawn per node, already resolved (1..=n_features).
    pub max_features: usize,
}

/// Per-sample weight and target. `weight: None` is scikit-learn's `sample_weight=None`
/// (every weight 1); a weight of 0 leaves the sample out (out of bag).
pub(crate) struct Targets<'a> {
    pub weight: Option<&'a [f64]>,
    pub target: &'a [f64],
}

/// A fitted binary tree. Node 0 is the root; an inner node `i` sends `x[feature[i]] ≤
/// threshold[i]` to `left[i]` and the rest to `left[i] + 1`. `value` is the class-1
/// fraction (classification) or the leaf output (boosting).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Tree {
    #[serde(with = "codec::b64")]
    pub feature: Vec<u32>,
    #[serde(with = "codec::b64")]
    pub threshold: Vec<f64>,
    #[serde(with = "codec::b64")]
    pub left: Vec<u32>,
    #[serde(with = "codec::b64")]
    pub value: Vec<f64>,
}

impl Tree {
    fn new() -> Self {
        Tree {
            feature: Vec::new(),
            threshold: Vec::new(),
            left: Vec::new(),
            value: Vec::new(),
        }
    }

    fn push_leaf(&mut self, value: f64) -> usize {
        self.feature.push(LEAF);
        self.threshold.push(0.0);
        self.left.push(0);
        self.value.push(value);
        self.feature.len() - 1
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.feature.len()
    }

    /// Leaf index reached by `row`.
    #[inline]
    pub fn apply(&self, row: &[f32]) -> usize {
        let mut i = 0usize;
        loop {
            let f = self.feature[i];
            if f == LEAF {
                return i;
            }
            let l = self.left[i] as usize;
            i = if f64::from(row[f as usize]) <= self.threshold[i] {
                l
            } else {
                l + 1
            };
        }
    }

    /// Leaf value reached by `row`.
    #[inline]
    pub fn predict(&self, row: &[f32]) -> f64 {
        self.value[self.apply(row)]
    }

    /// Node indices in scikit-learn's order: depth first, left child first.
    pub fn preorder(&self) -> Vec<usize> {
        let mut out = Vec::with_capacity(self.len());
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            out.push(i);
            if self.feature[i] != LEAF {
                let l = self.left[i] as usize;
                stack.push(l + 1);
                stack.push(l);
            }
        }
        out
    }

    /// Structural checks after loading: equal lengths, children after their parent and in
    /// range (so `apply` terminates), features below `n_features`.
    pub fn validate(&self, n_features: usize) -> Result<(), String> {
        let n = self.feature.len();
        if n == 0 || self.threshold.len() != n || self.left.len() != n || self.value.len() != n {
            return Err(format!(
                "tree arrays have lengths {}, {}, {}, {}",
                n,
                self.threshold.len(),
                self.left.len(),
                self.value.len()
            ));
        }
        for i in 0..n {
            if self.feature[i] == LEAF {
                continue;
            }
            let (f, l) = (self.feature[i] as usize, self.left[i] as usize);
            if f >= n_features {
                return Err(format!("node {i} splits on feature {f} of {n_features}"));
            }
            if l <= i || l + 1 >= n {
                return Err(format!(
                    "node {i} has children {l}, {} out of order or range",
                    l + 1
                ));
            }
        }
        Ok(())
    }
}

/// The splitter's initial xorshift state for a tree whose `random_state` is `seed`.
pub(crate) fn rand_r_seed(rng: &mut RandomState) -> u32 {
    rng.randint(0, u64::from(RAND_R_MAX)) as u32
}

// ---------------------------------------------------------------------------------------
// scikit-learn's simultaneous introsort (3-way partition), on values and sample indices.

fn sort_samples(v: &mut [f32], s: &mut [u32]) {
    let n = v.len();
    if n == 0 {
        return;
    }
    let maxd = 2 * ((n as f64).log2() as isize);
    introsort_3way(v, s, maxd);
}

fn introsort_3way(mut v: &mut [f32], mut s: &mut [u32], mut maxd: isize) {
    while v.len() > 15 {
        if maxd <= 0 {
            heapsort(v, s);
            return;
        }
        maxd -= 1;
        let n = v.len();
        let pivot = median3(v);
        let (mut i, mut l, mut r) = (0usize, 0usize, n);
        while i < r {
            if v[i] < pivot {
                v.swap(i, l);
                s.swap(i, l);
                i += 1;
                l += 1;
            } else if v[i] > pivot {
                r -= 1;
                v.swap(i, r);
                s.swap(i, r);
            } else {
                i += 1;
            }
        }
        let (vl, vr) = std::mem::take(&mut v).split_at_mut(r);
        let (sl, sr) = std::mem::take(&mut s).split_at_mut(r);
        introsort_3way(&mut vl[..l], &mut sl[..l], maxd);
        v = vr;
        s = sr;
    }
    insertion_sort(v, s);
}

#[inline]
fn median3(v: &[f32]) -> f32 {
    let n = v.len();
    let (a, b, c) = (v[0], v[n / 2], v[n - 1]);
    if a < b {
        if b < c {
            b
        } else if a < c {
            c
        } else {
            a
        }
    } else if b < c {
        if a < c { a } else { c }
    } else {
        b
    }
}

fn heapsort(v: &mut [f32], s: &mut [u32]) {
    let n = v.len();
    let mut start = (n - 2) / 2;
    loop {
        sift_down(v, s, start, n);
        if start == 0 {
            break;
        }
        start -= 1;
    }
    let mut end = n - 1;
    while end > 0 {
        v.swap(0, end);
        s.swap(0, end);
        sift_down(v, s, 0, end);
        end -= 1;
    }
}

fn sift_down(v: &mut [f32], s: &mut [u32], start: usize, end: usize) {
    let mut root = start;
    loop {
        let child = root * 2 + 1;
        let mut maxind = root;
        if child < end && v[maxind] < v[child] {
            maxind = child;
        }
        if child + 1 < end && v[maxind] < v[child + 1] {
            maxind = child + 1;
        }
        if maxind == root {
            break;
        }
        v.swap(root, maxind);
        s.swap(root, maxind);
        root = maxind;
    }
}

fn insertion_sort(v: &mut [f32], s: &mut [u32]) {
    for i in 1..v.len() {
        let (tv, ts) = (v[i], s[i]);
        let mut j = i;
        while j > 0 && v[j - 1] > tv {
            v[j] = v[j - 1];
            s[j] = s[j - 1];
            j -= 1;
        }
        v[j] = tv;
        s[j] = ts;
    }
}

// ---------------------------------------------------------------------------------------
// The criterion: scikit-learn's running sums over `samples[start..end]`.

struct Crit<'a> {
    kind: Criterion,
    y: &'a [f64],
    w: Option<&'a [f64]>,
    weighted_n_samples: f64,
    start: usize,
    end: usize,
    pos: usize,
    /// Gini: weighted count per class; MSE: `[Σ w·y, unused]`.
    sum_total: [f64; 2],
    sum_left: [f64; 2],
    sum_right: [f64; 2],
    sq_sum_total: f64,
    wn: f64,
    wl: f64,
    wr: f64,
}

impl Crit<'_> {
    #[inline]
    fn weight(&self, i: usize) -> f64 {
        self.w.map_or(1.0, |w| w[i])
    }

    fn init(&mut self, samples: &[u32], start: usize, end: usize) {
        self.start = start;
        self.end = end;
        self.wn = 0.0;
        self.sum_total = [0.0; 2];
        self.sq_sum_total = 0.0;
        for &s in &samples[start..end] {
            let i = s as usize;
            let w = self.weight(i);
            match self.kind {
                Criterion::Gini => self.sum_total[self.y[i] as usize] += w,
                Criterion::Mse => {
                    let wy = w * self.y[i];
                    self.sum_total[0] += wy;
                    self.sq_sum_total += wy * self.y[i];
                }
            }
            self.wn += w;
        }
        self.reset();
    }

    fn reset(&mut self) {
        self.pos = self.start;
        self.sum_left = [0.0; 2];
        self.sum_right = self.sum_total;
        self.wl = 0.0;
        self.wr = self.wn;
    }

    fn reverse_reset(&mut self) {
        self.pos = self.end;
        self.sum_right = [0.0; 2];
        self.sum_left = self.sum_total;
        self.wr = 0.0;
        self.wl = self.wn;
    }

    /// Moves `samples[pos..new_pos]` to the left child, from whichever end is nearer.
    fn update(&mut self, samples: &[u32], new_pos: usize) {
        let pos = self.pos;
        if new_pos - pos <= self.end - new_pos {
            for &s in &samples[pos..new_pos] {
                let i = s as usize;
                let w = self.weight(i);
                match self.kind {
                    Criterion::Gini => self.sum_left[self.y[i] as usize] += w,
                    Criterion::Mse => self.sum_left[0] += w * self.y[i],
                }
                self.wl += w;
            }
        } else {
            self.reverse_reset();
            for &s in samples[new_pos..self.end].iter().rev() {
                let i = s as usize;
                let w = self.weight(i);
                match self.kind {
                    Criterion::Gini => self.sum_left[self.y[i] as usize] -= w,
                    Criterion::Mse => self.sum_left[0] -= w * self.y[i],
                }
                self.wl -= w;
            }
        }
        self.wr = self.wn - self.wl;
        match self.kind {
            Criterion::Gini => {
                for c in 0..2 {
                    self.sum_right[c] = self.sum_total[c] - self.sum_left[c];
                }
            }
            Criterion::Mse => self.sum_right[0] = self.sum_total[0] - self.sum_left[0],
        }
        self.pos = new_pos;
    }

    #[inline]
    fn gini(counts: &[f64; 2], w: f64) -> f64 {
        let mut sq = 0.0;
        sq += counts[0] * counts[0];
        sq += counts[1] * counts[1];
        1.0 - sq / (w * w)
    }

    fn node_impurity(&self) -> f64 {
        match self.kind {
            Criterion::Gini => Self::gini(&self.sum_total, self.wn),
            Criterion::Mse => {
                let m = self.sum_total[0] / self.wn;
                self.sq_sum_total / self.wn - m * m
            }
        }
    }

    #[inline]
    fn proxy(&self) -> f64 {
        match self.kind {
            Criterion::Gini => {
                let il = Self::gini(&self.sum_left, self.wl);
                let ir = Self::gini(&self.sum_right, self.wr);
                -self.wr * ir - self.wl * il
            }
            Criterion::Mse => {
                let (sl, sr) = (self.sum_left[0], self.sum_right[0]);
                sl * sl / self.wl + sr * sr / self.wr
            }
        }
    }

    fn children_impurity(&self, samples: &[u32]) -> (f64, f64) {
        match self.kind {
            Criterion::Gini => (
                Self::gini(&self.sum_left, self.wl),
                Self::gini(&self.sum_right, self.wr),
            ),
            Criterion::Mse => {
                let mut sq_left = 0.0;
                for &s in &samples[self.start..self.pos] {
                    let i = s as usize;
                    sq_left += self.weight(i) * self.y[i] * self.y[i];
                }
                let sq_right = self.sq_sum_total - sq_left;
                let ml = self.sum_left[0] / self.wl;
                let mr = self.sum_right[0] / self.wr;
                (sq_left / self.wl - ml * ml, sq_right / self.wr - mr * mr)
            }
        }
    }

    fn impurity_improvement(&self, parent: f64, il: f64, ir: f64) -> f64 {
        (self.wn / self.weighted_n_samples) * (parent - self.wr / self.wn * ir - self.wl / self.wn * il)
    }

    /// The node's value: class-1 fraction (Gini) or mean target (MSE).
    fn node_value(&self) -> f64 {
        match self.kind {
            Criterion::Gini => self.sum_total[1] / self.wn,
            Criterion::Mse => self.sum_total[0] / self.wn,
        }
    }
}

/// A split found by [`Builder::node_split`].
struct Split {
    pos: usize,
    feature: usize,
    threshold: f64,
    improvement: f64,
    impurity_left: f64,
    impurity_right: f64,
}

/// One entry of the depth-first stack.
struct Record {
    start: usize,
    end: usize,
    depth: usize,
    parent: usize,
    is_left: bool,
    impurity: f64,
    n_constant_features: usize,
}

/// scikit-learn's splitter and tree builder state for one tree.
struct Builder<'a> {
    /// Column-major training values: feature `f` of sample `i` at `cols[f·n + i]`.
    cols: &'a [f32],
    n: usize,
    cfg: TreeConfig,
    crit: Crit<'a>,
    samples: Vec<u32>,
    feature_values: Vec<f32>,
    features: Vec<usize>,
    constant_features: Vec<usize>,
    rand_r_state: u32,
}

impl Builder<'_> {
    /// `node_split_best` on `samples[start..end]` (dense data, no missing values).
    /// Returns the split (`pos == end` when none) and the node's count of known constant
    /// features for its children.
    fn node_split(
        &mut self,
        start: usize,
        end: usize,
        impurity: f64,
        n_known_constants: usize,
    ) -> (Split, usize) {
        let n_features = self.features.len();
        let mut best = Split {
            pos: end,
            feature: 0,
            threshold: 0.0,
            improvement: f64::NEG_INFINITY,
            impurity_left: f64::INFINITY,
            impurity_right: f64::INFINITY,
        };
        let mut best_proxy = f64::NEG_INFINITY;
        let mut f_i = n_features;
        let mut n_visited = 0usize;
        let mut n_found_constants = 0usize;
        let mut n_drawn_constants = 0usize;
        let mut n_total_constants = n_known_constants;
        let min_leaf = self.cfg.min_samples_leaf;

        while f_i > n_total_constants
            && (n_visited < self.cfg.max_features || n_visited <= n_found_constants + n_drawn_constants)
        {
            n_visited += 1;
            let mut f_j = rand_int(n_drawn_constants, f_i - n_found_constants, &mut self.rand_r_state);
            if f_j < n_known_constants {
                self.features.swap(n_drawn_constants, f_j);
                n_drawn_constants += 1;
                continue;
            }
            f_j += n_found_constants;
            let feature = self.features[f_j];
            let col = &self.cols[feature * self.n..(feature + 1) * self.n];
            let fv = &mut self.feature_values[start..end];
            let sm = &mut self.samples[start..end];
            for (v, &s) in fv.iter_mut().zip(sm.iter()) {
                *v = col[s as usize];
            }
            sort_samples(fv, sm);
            if self.feature_values[end - 1] <= self.feature_values[start] + FEATURE_THRESHOLD {
                self.features.swap(f_j, n_total_constants);
                n_found_constants += 1;
                n_total_constants += 1;
                continue;
            }
            f_i -= 1;
            self.features.swap(f_i, f_j);

            self.crit.reset();
            let fv = &self.feature_values;
            let mut p = start;
            while p < end {
                p += 1;
                while p < end && fv[p] <= fv[p - 1] + FEATURE_THRESHOLD {
                    p += 1;
                }
                let p_prev = p - 1;
                if p == end {
                    continue;
                }
                if p - start < min_leaf || end - p < min_leaf {
                    continue;
                }
                self.crit.update(&self.samples, p);
                let proxy = self.crit.proxy();
                if proxy > best_proxy {
                    best_proxy = proxy;
                    best.pos = p;
                    best.feature = feature;
                    best.threshold = f64::from(fv[p_prev]) / 2.0 + f64::from(fv[p]) / 2.0;
                }
            }
        }

        if best.pos < end {
            // partition_samples_final: keep left values in front, swap right ones to the end.
            let col = &self.cols[best.feature * self.n..(best.feature + 1) * self.n];
            let (mut ps, mut pe) = (start, end);
            while ps < pe {
                if f64::from(col[self.samples[ps] as usize]) <= best.threshold {
                    ps += 1;
                } else {
                    pe -= 1;
                    self.samples.swap(ps, pe);
                }
            }
            self.crit.reset();
            self.crit.update(&self.samples, best.pos);
            let (il, ir) = self.crit.children_impurity(&self.samples);
            best.impurity_left = il;
            best.impurity_right = ir;
            best.improvement = self.crit.impurity_improvement(impurity, il, ir);
        }

        self.features[..n_known_constants].copy_from_slice(&self.constant_features[..n_known_constants]);
        let found = n_known_constants..n_known_constants + n_found_constants;
        self.constant_features[found.clone()].copy_from_slice(&self.features[found]);
        (best, n_total_constants)
    }
}

/// Grows one tree as scikit-learn's `DepthFirstTreeBuilder` does. `cols` is the
/// column-major copy of the `float32` training matrix (`n` rows, `d` features) and
/// `rand_r_state` the splitter's initial state ([`rand_r_seed`]).
pub(crate) fn grow(
    cols: &[f32],
    n: usize,
    d: usize,
    targets: &Targets<'_>,
    cfg: &TreeConfig,
    rand_r_state: u32,
) -> Tree {
    let weighted_n_samples = match targets.weight {
        Some(w) => w.iter().sum::<f64>(),
        None => n as f64,
    };
    let samples: Vec<u32> = (0..n as u32)
        .filter(|&i| targets.weight.is_none_or(|w| w[i as usize] != 0.0))
        .collect();
    let n_node_samples = samples.len();
    let mut b = Builder {
        cols,
        n,
        cfg: *cfg,
        crit: Crit {
            kind: cfg.criterion,
            y: targets.target,
            w: targets.weight,
            weighted_n_samples,
            start: 0,
            end: 0,
            pos: 0,
            sum_total: [0.0; 2],
            sum_left: [0.0; 2],
            sum_right: [0.0; 2],
            sq_sum_total: 0.0,
            wn: 0.0,
            wl: 0.0,
            wr: 0.0,
        },
        samples,
        feature_values: vec![0.0; n],
        features: (0..d).collect(),
        constant_features: vec![0; d],
        rand_r_state,
    };
    // scikit-learn's node arrays, numbered in creation order.
    let mut sk_feature: Vec<u32> = Vec::new();
    let mut sk_threshold: Vec<f64> = Vec::new();
    let mut sk_children: Vec<[usize; 2]> = Vec::new();
    let mut sk_value: Vec<f64> = Vec::new();
    // A split needs at least 2 samples, whatever min_samples_split says.
    let min_samples_split = cfg.min_samples_split.max(2 * cfg.min_samples_leaf);

    let mut stack = vec![Record {
        start: 0,
        end: n_node_samples,
        depth: 0,
        parent: NONE,
        is_left: false,
        impurity: f64::INFINITY,
        n_constant_features: 0,
    }];
    let mut first = true;
    while let Some(rec) = stack.pop() {
        let (start, end) = (rec.start, rec.end);
        b.crit.init(&b.samples, start, end);
        let n_node = end - start;
        let mut is_leaf =
            rec.depth >= cfg.max_depth || n_node < min_samples_split || n_node < 2 * cfg.min_samples_leaf;
        let mut impurity = rec.impurity;
        if first {
            impurity = b.crit.node_impurity();
            first = false;
        }
        is_leaf = is_leaf || impurity <= f64::EPSILON;
        let mut split = None;
        if !is_leaf {
            let (s, n_constant) = b.node_split(start, end, impurity, rec.n_constant_features);
            is_leaf = s.pos >= end || s.improvement + f64::EPSILON < 0.0;
            split = Some((s, n_constant));
        }
        let id = sk_feature.len();
        if rec.parent != NONE {
            sk_children[rec.parent][usize::from(!rec.is_left)] = id;
        }
        sk_value.push(b.crit.node_value());
        sk_children.push([NONE, NONE]);
        match split {
            Some((s, n_constant)) if !is_leaf => {
                sk_feature.push(s.feature as u32);
                sk_threshold.push(s.threshold);
                stack.push(Record {
                    start: s.pos,
                    end,
                    depth: rec.depth + 1,
                    parent: id,
                    is_left: false,
                    impurity: s.impurity_right,
                    n_constant_features: n_constant,
                });
                stack.push(Record {
                    start,
                    end: s.pos,
                    depth: rec.depth + 1,
                    parent: id,
                    is_left: true,
                    impurity: s.impurity_left,
                    n_constant_features: n_constant,
                });
            }
            _ => {
                sk_feature.push(LEAF);
                sk_threshold.push(0.0);
            }
        }
    }

    // Relabel so that children sit next to each other.
    let mut tree = Tree::new();
    tree.push_leaf(sk_value[0]);
    let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
    while let Some((sk, node)) = queue.pop_front() {
        if sk_feature[sk] == LEAF {
            continue;
        }
        let [l, r] = sk_children[sk];
        let left = tree.push_leaf(sk_value[l]);
        tree.push_leaf(sk_value[r]);
        tree.feature[node] = sk_feature[sk];
        tree.threshold[node] = sk_threshold[sk];
        tree.left[node] = left as u32;
        queue.push_back((l, left));
        queue.push_back((r, left + 1));
    }
    tree
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::matrix::Matrix;

    fn cfg(criterion: Criterion, max_features: usize) -> TreeConfig {
        TreeConfig {
            criterion,
            max_depth: usize::MAX,
            min_samples_split: 2,
            min_samples_leaf: 1,
            max_features,
        }
    }

    fn fit(x: &Matrix, w: Option<&[f64]>, t: &[f64], c: &TreeConfig) -> Tree {
        let targets = Targets { weight: w, target: t };
        grow(&x.columns(), x.rows, x.cols, &targets, c, 12345)
    }

    #[test]
    fn introsort_sorts_and_keeps_pairs() {
        let mut state = 7u32;
        for n in [0usize, 1, 2, 15, 16, 17, 100, 1000, 5000] {
            // Few distinct values (3-way partitions) and many (deep recursion).
            for distinct in [3u32, 1_000_000] {
                let mut v: Vec<f32> = (0..n)
                    .map(|_| (crate::nprandom::rand_r(&mut state) % distinct) as f32)
                    .collect();
                let orig = v.clone();
                let mut s: Vec<u32> = (0..n as u32).collect();
                sort_samples(&mut v, &mut s);
                assert!(v.windows(2).all(|w| w[0] <= w[1]), "n = {n}");
                assert!(s.iter().zip(&v).all(|(&i, &x)| orig[i as usize] == x));
                let mut seen = s.clone();
                seen.sort_unstable();
                assert_eq!(seen, (0..n as u32).collect::<Vec<_>>());
            }
        }
        // Heapsort as well: a depth limit of 0 from the start.
        let mut v: Vec<f32> = (0..100).map(|i| ((i * 37) % 101) as f32).collect();
        let mut s: Vec<u32> = (0..100).collect();
        introsort_3way(&mut v, &mut s, 0);
        assert!(v.windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn splits_at_the_midpoint_into_pure_leaves() {
        // One feature: 1, 2 are class 0; 4, 8 class 1 → threshold (2 + 4) / 2 = 3.
        let x = Matrix::from_rows(&[[1.0f32], [2.0], [4.0], [8.0]]).unwrap();
        let tree = fit(&x, None, &[0.0, 0.0, 1.0, 1.0], &cfg(Criterion::Gini, 1));
        assert_eq!(tree.len(), 3);
        assert_eq!(tree.feature[0], 0);
        assert_eq!(tree.threshold[0], 3.0);
        assert_eq!((tree.value[1], tree.value[2]), (0.0, 1.0));
        assert_eq!(tree.predict(&[2.999]), 0.0);
        assert_eq!(tree.predict(&[3.0]), 0.0);
        assert_eq!(tree.predict(&[3.001]), 1.0);
        assert_eq!(tree.preorder(), vec![0, 1, 2]);
    }

    #[test]
    fn values_within_feature_threshold_are_not_split() {
        // 1.0 and its next float differ by 1.19e-7 ≤ 1e-7 rounded in f32: one value.
        let a = 1.0f32;
        let b = f32::from_bits(a.to_bits() + 1);
        let x = Matrix::from_rows(&[[a], [b]]).unwrap();
        let tree = fit(&x, None, &[0.0, 1.0], &cfg(Criterion::Gini, 1));
        assert_eq!(tree.len(), 1);
        assert_eq!(tree.value[0], 0.5);
    }

    #[test]
    fn weights_and_min_samples_leaf() {
        // Weighted fraction in the leaf; min_samples_leaf = 2 forbids the 1|2 split of the
        // three weighted rows (the weight-0 row is left out).
        let x = Matrix::from_rows(&[[0.0f32], [1.0], [2.0], [3.0]]).unwrap();
        let w = [3.0, 1.0, 1.0, 0.0];
        let mut c = cfg(Criterion::Gini, 1);
        c.min_samples_leaf = 2;
        let tree = fit(&x, Some(&w), &[1.0, 0.0, 0.0, 1.0], &c);
        assert_eq!(tree.len(), 1);
        assert_eq!(tree.value[0], 3.0 / 5.0);
    }

    #[test]
    fn mse_tree_means() {
        let x = Matrix::from_rows(&[[0.0f32], [1.0], [5.0], [6.0]]).unwrap();
        let mut c = cfg(Criterion::Mse, 1);
        c.max_depth = 1;
        let tree = fit(&x, None, &[1.0, 2.0, 10.0, 12.0], &c);
        assert_eq!(tree.threshold[0], 3.0);
        assert_eq!((tree.value[1], tree.value[2]), (1.5, 11.0));
    }

    #[test]
    fn preorder_is_depth_first_left_first() {
        // x = 0..8 with labels making a three-level tree.
        let rows: Vec<[f32; 1]> = (0..8).map(|i| [i as f32]).collect();
        let x = Matrix::from_rows(&rows).unwrap();
        let t = [0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let tree = fit(&x, None, &t, &cfg(Criterion::Gini, 1));
        let order = tree.preorder();
        assert_eq!(order.len(), tree.len());
        assert_eq!(order[0], 0);
        assert_eq!(order[1], tree.left[0] as usize);
        assert!(tree.validate(1).is_ok());
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(tree.predict(row), t[i]);
        }
    }
}
