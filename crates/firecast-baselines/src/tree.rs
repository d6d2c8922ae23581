//! CART trees as scikit-learn's `BestSplitter` grows them, shared by the decision tree,
//! the random forest and gradient boosting.
//!
//! What matches scikit-learn (`sklearn/tree/_splitter.pyx`, `_criterion.pyx`, `_tree.pyx`):
//! - candidate thresholds sit between consecutive sorted values of a node, skipping
//!   gaps `v[p] ≤ v[p−1] + 1e-7` (its `FEATURE_THRESHOLD`, in `f32`), at
//!   `v[p−1]/2 + v[p]/2` in `f64`; a sample goes left when `x ≤ threshold`;
//! - a split is scored by the criterion's proxy (Gini: `−w_R·gini_R − w_L·gini_L`,
//!   squared error: `s_L²/w_L + s_R²/w_R`) and only a strictly better proxy replaces the
//!   best one, so among exact ties the first feature visited wins;
//! - features are visited in a random order; with `max_features < n_features` the search
//!   stops after `max_features` draws, constant features included, unless all drawn
//!   features so far were constant;
//! - a node is a leaf when `depth ≥ max_depth`, it has fewer than `min_samples_split`
//!   or `2·min_samples_leaf` samples, its impurity is ≤ `f64::EPSILON`, no split keeps
//!   `min_samples_leaf` samples on both sides, or the improvement is below `−EPSILON`;
//! - sample weights (bootstrap counts) weigh the criterion, sample counts the size rules.
//!
//! The random order differs from scikit-learn's (its own `rand_r` stream), which changes
//! a tree only where two splits tie exactly.
//!
//! Two builders produce the same kind of tree: [`grow_sorting`] sorts the node's values of
//! each drawn feature (like scikit-learn; best when few features are drawn per node), and
//! [`grow_presorted`] sorts every feature once and then scans all features level by level
//! in parallel (exact too, and far faster when every feature is examined, as in
//! gradient boosting and the default decision tree).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::codec;
use crate::matrix::Matrix;

/// scikit-learn's `FEATURE_THRESHOLD` (an `f32`).
const FEATURE_THRESHOLD: f32 = 1e-7;
/// Marks a leaf in [`Tree::feature`].
pub(crate) const LEAF: u32 = u32::MAX;
/// Marks an out-of-bag (weight 0) or finished sample.
const NONE: u32 = u32::MAX;

/// Split quality.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Criterion {
    /// Binary Gini; the target is 0/1, `s` the weighted count of class 1.
    Gini,
    /// Squared error (scikit-learn's `squared_error`, which `friedman_mse` now maps to).
    Mse,
}

impl Criterion {
    /// scikit-learn's `proxy_impurity_improvement` from left/right weight and target sums.
    #[inline]
    fn proxy(self, wl: f64, sl: f64, wr: f64, sr: f64) -> f64 {
        match self {
            Criterion::Gini => {
                let (c0l, c0r) = (wl - sl, wr - sr);
                let gl = 1.0 - (c0l * c0l + sl * sl) / (wl * wl);
                let gr = 1.0 - (c0r * c0r + sr * sr) / (wr * wr);
                -wr * gr - wl * gl
            }
            Criterion::Mse => sl * sl / wl + sr * sr / wr,
        }
    }

    /// Node impurity from weight `w`, target sum `s` and target square sum `q`.
    fn impurity(self, w: f64, s: f64, q: f64) -> f64 {
        match self {
            Criterion::Gini => {
                let c0 = w - s;
                1.0 - (c0 * c0 + s * s) / (w * w)
            }
            Criterion::Mse => {
                let m = s / w;
                q / w - m * m
            }
        }
    }
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

/// Per-sample weight and target: `w = 0` leaves the sample out (out of bag).
pub(crate) struct Targets<'a> {
    pub weight: &'a [f64],
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

    fn push_leaf(&mut self) -> usize {
        self.feature.push(LEAF);
        self.threshold.push(0.0);
        self.left.push(0);
        self.value.push(0.0);
        self.feature.len() - 1
    }

    /// Turns `node` into a split and appends its two children (as leaves for now).
    fn split(&mut self, node: usize, feature: usize, threshold: f64) -> usize {
        let left = self.push_leaf();
        self.push_leaf();
        self.feature[node] = feature as u32;
        self.threshold[node] = threshold;
        self.left[node] = left as u32;
        left
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

/// Per-node sums of the samples in it.
#[derive(Clone, Copy, Debug, Default)]
struct Stats {
    n: usize,
    w: f64,
    s: f64,
    q: f64,
}

impl Stats {
    #[inline]
    fn add(&mut self, w: f64, t: f64) {
        self.n += 1;
        self.w += w;
        self.s += w * t;
        self.q += w * t * t;
    }
}

/// Whether a node of these stats at this depth must stay a leaf before any search.
fn stops(cfg: &TreeConfig, st: &Stats, depth: usize, impurity: f64) -> bool {
    depth >= cfg.max_depth
        || st.n < cfg.min_samples_split
        || st.n < 2 * cfg.min_samples_leaf
        || impurity <= f64::EPSILON
}

/// scikit-learn's `impurity_improvement` sign test with `min_impurity_decrease = 0`.
fn improves(cfg: &TreeConfig, parent: &Stats, parent_impurity: f64, l: &Stats, r: &Stats) -> bool {
    let il = cfg.criterion.impurity(l.w, l.s, l.q);
    let ir = cfg.criterion.impurity(r.w, r.s, r.q);
    let improvement = parent_impurity - r.w / parent.w * ir - l.w / parent.w * il;
    improvement + f64::EPSILON >= 0.0
}

/// Order-preserving `u32` key of an `f32` (for sorting values with their sample index).
#[inline]
fn key(v: f32) -> u32 {
    let b = v.to_bits();
    if b & 0x8000_0000 != 0 { !b } else { b | 0x8000_0000 }
}

#[inline]
fn unkey(k: u32) -> f32 {
    f32::from_bits(if k & 0x8000_0000 != 0 { k & 0x7FFF_FFFF } else { !k })
}

/// The best split found so far for a node.
#[derive(Clone, Copy, Debug)]
struct Best {
    proxy: f64,
    /// Visiting rank of the feature in this node: lower wins exact ties.
    rank: (u64, u32),
    feature: u32,
    threshold: f64,
}

impl Best {
    const NONE: Best = Best {
        proxy: f64::NEG_INFINITY,
        rank: (u64::MAX, u32::MAX),
        feature: LEAF,
        threshold: 0.0,
    };

    #[inline]
    fn beats(&self, other: &Best) -> bool {
        self.proxy > other.proxy || (self.proxy == other.proxy && self.rank < other.rank)
    }
}

/// Grows a tree by sorting each drawn feature's node values (scikit-learn's way).
/// `cols` is the column-major copy of the training matrix (`n` rows). Returns the tree
/// and, per sample, the leaf it landed in (`u32::MAX` for weight-0 samples).
pub(crate) fn grow_sorting(
    cols: &[f32],
    n: usize,
    d: usize,
    targets: &Targets<'_>,
    cfg: &TreeConfig,
    rng: &mut ChaCha8Rng,
) -> (Tree, Vec<u32>) {
    let (wv, tv) = (targets.weight, targets.target);
    let mut samples: Vec<u32> = (0..n as u32).filter(|&i| wv[i as usize] > 0.0).collect();
    let mut leaf_of = vec![NONE; n];
    let mut features: Vec<usize> = (0..d).collect();
    let mut buf: Vec<u64> = Vec::with_capacity(samples.len());
    let mut tree = Tree::new();

    let mut root = Stats::default();
    for &s in &samples {
        root.add(wv[s as usize], tv[s as usize]);
    }
    let root_node = tree.push_leaf();
    let root_imp = cfg.criterion.impurity(root.w, root.s, root.q);
    // (start, end, depth, node, stats, impurity)
    let mut stack = vec![(0usize, samples.len(), 0usize, root_node, root, root_imp)];

    while let Some((start, end, depth, node, st, imp)) = stack.pop() {
        tree.value[node] = st.s / st.w;
        let mut split = None;
        if !stops(cfg, &st, depth, imp) {
            split = best_split_sorted(
                cols,
                n,
                &samples[start..end],
                targets,
                &st,
                cfg,
                &mut features,
                &mut buf,
                rng,
            );
        }
        let Some(best) = split else {
            for &s in &samples[start..end] {
                leaf_of[s as usize] = node as u32;
            }
            continue;
        };
        let (f, thr) = (best.feature as usize, best.threshold);
        let col = &cols[f * n..(f + 1) * n];
        let part = &mut samples[start..end];
        // In-place partition: left block first.
        let mut mid = 0;
        for i in 0..part.len() {
            if f64::from(col[part[i] as usize]) <= thr {
                part.swap(i, mid);
                mid += 1;
            }
        }
        let (mut ls, mut rs) = (Stats::default(), Stats::default());
        for &s in &part[..mid] {
            ls.add(wv[s as usize], tv[s as usize]);
        }
        for &s in &part[mid..] {
            rs.add(wv[s as usize], tv[s as usize]);
        }
        if !improves(cfg, &st, imp, &ls, &rs) {
            for &s in part.iter() {
                leaf_of[s as usize] = node as u32;
            }
            continue;
        }
        let left = tree.split(node, f, thr);
        let il = cfg.criterion.impurity(ls.w, ls.s, ls.q);
        let ir = cfg.criterion.impurity(rs.w, rs.s, rs.q);
        // Right pushed first so the left child is grown first, like scikit-learn's stack.
        stack.push((start + mid, end, depth + 1, left + 1, rs, ir));
        stack.push((start, start + mid, depth + 1, left, ls, il));
    }
    (tree, leaf_of)
}

/// scikit-learn's `node_split_best` on one node with our own random feature draws.
#[allow(clippy::too_many_arguments)]
fn best_split_sorted(
    cols: &[f32],
    n: usize,
    node: &[u32],
    targets: &Targets<'_>,
    st: &Stats,
    cfg: &TreeConfig,
    features: &mut [usize],
    buf: &mut Vec<u64>,
    rng: &mut ChaCha8Rng,
) -> Option<Best> {
    let (wv, tv) = (targets.weight, targets.target);
    let m = node.len();
    let mut best = Best::NONE;
    let mut f_i = features.len();
    let (mut visited, mut constant) = (0usize, 0usize);
    while f_i > 0 && (visited < cfg.max_features || visited <= constant) {
        visited += 1;
        // Fisher-Yates draw without replacement; drawn features move to the tail.
        let j = rng.random_range(0..f_i);
        f_i -= 1;
        features.swap(j, f_i);
        let f = features[f_i];
        let col = &cols[f * n..(f + 1) * n];
        buf.clear();
        buf.extend(
            node.iter()
                .map(|&s| (u64::from(key(col[s as usize])) << 32) | u64::from(s)),
        );
        buf.sort_unstable();
        let val = |k: u64| unkey((k >> 32) as u32);
        if val(buf[m - 1]) <= val(buf[0]) + FEATURE_THRESHOLD {
            constant += 1;
            continue;
        }
        let (mut wl, mut sl) = (0.0f64, 0.0f64);
        let mut prev = val(buf[0]);
        for p in 1..m {
            let s = (buf[p - 1] & 0xFFFF_FFFF) as usize;
            wl += wv[s];
            sl += wv[s] * tv[s];
            let v = val(buf[p]);
            let last = prev;
            prev = v;
            if v <= last + FEATURE_THRESHOLD {
                continue;
            }
            if p < cfg.min_samples_leaf || m - p < cfg.min_samples_leaf {
                continue;
            }
            let proxy = cfg.criterion.proxy(wl, sl, st.w - wl, st.s - sl);
            if proxy > best.proxy {
                best = Best {
                    proxy,
                    rank: (visited as u64, 0),
                    feature: f as u32,
                    threshold: f64::from(last) / 2.0 + f64::from(v) / 2.0,
                };
            }
        }
    }
    (best.feature != LEAF).then_some(best)
}

/// Every feature's samples sorted by value, once, for [`grow_presorted`].
pub(crate) struct Presorted {
    n: usize,
    d: usize,
    /// `d` blocks of `n` sample indices, each sorted by that feature's value.
    order: Vec<u32>,
    /// The values in the same order.
    vals: Vec<f32>,
}

impl Presorted {
    /// Sorts every column of `x` (in parallel over columns).
    pub fn new(x: &Matrix) -> Self {
        let (n, d) = (x.rows, x.cols);
        let cols = x.columns();
        let mut order = vec![0u32; n * d];
        let mut vals = vec![0.0f32; n * d];
        if n > 0 {
            order
                .par_chunks_mut(n)
                .zip(vals.par_chunks_mut(n))
                .enumerate()
                .for_each(|(f, (o, v))| {
                    let col = &cols[f * n..(f + 1) * n];
                    let mut keys: Vec<u64> = col
                        .iter()
                        .enumerate()
                        .map(|(s, &x)| (u64::from(key(x)) << 32) | s as u64)
                        .collect();
                    keys.sort_unstable();
                    for (i, k) in keys.iter().enumerate() {
                        o[i] = (k & 0xFFFF_FFFF) as u32;
                        v[i] = unkey((k >> 32) as u32);
                    }
                });
        }
        Presorted { n, d, order, vals }
    }
}

/// Random rank of feature `f` in node `node` of the tree seeded `seed` (SplitMix64).
#[inline]
fn rank(seed: u64, node: usize, f: u32) -> (u64, u32) {
    let mut z = seed
        ^ (node as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ u64::from(f).wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31), f)
}

/// Per-node scan state while sweeping one feature.
#[derive(Clone, Copy)]
struct Sweep {
    nl: u32,
    wl: f64,
    sl: f64,
    last: f32,
}

const SWEEP0: Sweep = Sweep {
    nl: 0,
    wl: 0.0,
    sl: 0.0,
    last: 0.0,
};

/// A node still being grown (one per "slot" of the current level).
struct Open {
    node: usize,
    depth: usize,
    st: Stats,
    impurity: f64,
}

/// One level of [`grow_presorted`]: the sorted lists and the open nodes' totals.
struct Level<'a> {
    order: &'a [u32],
    vals: &'a [f32],
    len: usize,
    slot_of: &'a [u32],
    wt: &'a [[f64; 2]],
    node_n: Vec<u32>,
    node_w: Vec<f64>,
    node_s: Vec<f64>,
    node_id: Vec<usize>,
    crit: Criterion,
    min_leaf: u32,
    seed: u64,
}

impl Level<'_> {
    /// Scans feature `f` over all open samples, updating each node's best split.
    /// Kept out of line: inlined into rayon's closures it compiles to slower code.
    #[inline(never)]
    fn sweep(&self, f: usize, best: &mut [Best], sweep: &mut [Sweep]) {
        sweep.fill(SWEEP0);
        let r = f * self.len..(f + 1) * self.len;
        for (&s, &val) in self.order[r.clone()].iter().zip(&self.vals[r]) {
            let k = self.slot_of[s as usize];
            if k == NONE {
                continue;
            }
            let k = k as usize;
            let sw = &mut sweep[k];
            if sw.nl > 0 && val > sw.last + FEATURE_THRESHOLD {
                let nr = self.node_n[k] - sw.nl;
                if sw.nl >= self.min_leaf && nr >= self.min_leaf {
                    let proxy = self
                        .crit
                        .proxy(sw.wl, sw.sl, self.node_w[k] - sw.wl, self.node_s[k] - sw.sl);
                    let b = &mut best[k];
                    if proxy >= b.proxy {
                        let cand = Best {
                            proxy,
                            rank: rank(self.seed, self.node_id[k], f as u32),
                            feature: f as u32,
                            threshold: f64::from(sw.last) / 2.0 + f64::from(val) / 2.0,
                        };
                        if cand.beats(b) {
                            *b = cand;
                        }
                    }
                }
            }
            let [w, ws] = self.wt[s as usize];
            sw.nl += 1;
            sw.wl += w;
            sw.sl += ws;
            sw.last = val;
        }
    }
}

/// Grows a tree level by level over presorted features, examining every feature at every
/// node (requires `cfg.max_features == n_features`). Within a level each feature is one
/// parallel sweep over all still-open samples; a node's feature order is a seeded random
/// rank, so exact ties resolve as if features were visited in that order, independently of
/// the thread count. Returns the tree and each sample's leaf (`u32::MAX` if weight 0).
pub(crate) fn grow_presorted(
    x: &Matrix,
    pre: &Presorted,
    targets: &Targets<'_>,
    cfg: &TreeConfig,
    seed: u64,
) -> (Tree, Vec<u32>) {
    let (n, d) = (pre.n, pre.d);
    let (wv, tv) = (targets.weight, targets.target);
    let wt: Vec<[f64; 2]> = (0..n).map(|i| [wv[i], wv[i] * tv[i]]).collect();
    let mut tree = Tree::new();
    let mut leaf_of = vec![NONE; n];
    let mut slot_of = vec![NONE; n];

    let mut root = Stats::default();
    for i in 0..n {
        if wv[i] > 0.0 {
            root.add(wv[i], tv[i]);
        }
    }
    let root_node = tree.push_leaf();
    let mut open: Vec<Open> = Vec::new();
    let root_imp = cfg.criterion.impurity(root.w, root.s, root.q);
    tree.value[root_node] = root.s / root.w;
    if stops(cfg, &root, 0, root_imp) {
        for i in 0..n {
            if wv[i] > 0.0 {
                leaf_of[i] = root_node as u32;
            }
        }
        return (tree, leaf_of);
    }
    for i in 0..n {
        if wv[i] > 0.0 {
            slot_of[i] = 0;
        }
    }
    open.push(Open {
        node: root_node,
        depth: 0,
        st: root,
        impurity: root_imp,
    });

    // Sorted lists, compacted to the open samples when they shrink to half.
    let mut own: Option<(Vec<u32>, Vec<f32>)> = None;
    let mut len = n;
    let mut active = root.n;
    if active * 2 <= len {
        own = Some(compact(&pre.order, &pre.vals, len, d, &slot_of, active));
        len = active;
    }

    while !open.is_empty() {
        let (order, vals): (&[u32], &[f32]) = match &own {
            Some((o, v)) => (o, v),
            None => (&pre.order, &pre.vals),
        };
        let n_open = open.len();
        let level = Level {
            order,
            vals,
            len,
            slot_of: &slot_of,
            wt: &wt,
            node_n: open.iter().map(|o| o.st.n as u32).collect(),
            node_w: open.iter().map(|o| o.st.w).collect(),
            node_s: open.iter().map(|o| o.st.s).collect(),
            node_id: open.iter().map(|o| o.node).collect(),
            crit: cfg.criterion,
            min_leaf: cfg.min_samples_leaf as u32,
            seed,
        };
        let best: Vec<Best> = (0..d)
            .into_par_iter()
            .fold(
                || (vec![Best::NONE; n_open], vec![SWEEP0; n_open]),
                |(mut best, mut sweep), f| {
                    level.sweep(f, &mut best, &mut sweep);
                    (best, sweep)
                },
            )
            .map(|(best, _)| best)
            .reduce(
                || vec![Best::NONE; n_open],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(b) {
                        if y.beats(x) {
                            *x = y;
                        }
                    }
                    a
                },
            );
        drop(level);

        // Route every open sample to a child; accumulate child stats in sample order.
        let mut child_stats = vec![[Stats::default(); 2]; n_open];
        let mut side = vec![0u8; n];
        for i in 0..n {
            let k = slot_of[i];
            if k == NONE {
                continue;
            }
            let b = &best[k as usize];
            if b.feature == LEAF {
                continue;
            }
            let go_right = f64::from(x.data[i * d + b.feature as usize]) > b.threshold;
            side[i] = u8::from(go_right);
            child_stats[k as usize][usize::from(go_right)].add(wv[i], tv[i]);
        }

        // Decide each node's fate and number the next level's open nodes.
        let mut next: Vec<Open> = Vec::new();
        // Per slot: NONE = leaf here; else child slots (left, right) with NONE for leaves,
        // and the child node ids.
        let mut fate: Vec<Option<([u32; 2], [usize; 2])>> = Vec::with_capacity(n_open);
        for (k, o) in open.iter().enumerate() {
            let b = &best[k];
            let [ls, rs] = child_stats[k];
            if b.feature == LEAF || !improves(cfg, &o.st, o.impurity, &ls, &rs) {
                fate.push(None);
                continue;
            }
            let left = tree.split(o.node, b.feature as usize, b.threshold);
            let mut slots = [NONE; 2];
            for (c, cs) in [ls, rs].iter().enumerate() {
                let node = left + c;
                tree.value[node] = cs.s / cs.w;
                let imp = cfg.criterion.impurity(cs.w, cs.s, cs.q);
                if !stops(cfg, cs, o.depth + 1, imp) {
                    slots[c] = next.len() as u32;
                    next.push(Open {
                        node,
                        depth: o.depth + 1,
                        st: *cs,
                        impurity: imp,
                    });
                }
            }
            fate.push(Some((slots, [left, left + 1])));
        }
        active = 0;
        for i in 0..n {
            let k = slot_of[i];
            if k == NONE {
                continue;
            }
            match &fate[k as usize] {
                None => {
                    leaf_of[i] = open[k as usize].node as u32;
                    slot_of[i] = NONE;
                }
                Some((slots, nodes)) => {
                    let c = usize::from(side[i]);
                    slot_of[i] = slots[c];
                    if slots[c] == NONE {
                        leaf_of[i] = nodes[c] as u32;
                    } else {
                        active += 1;
                    }
                }
            }
        }
        open = next;
        if !open.is_empty() && active * 2 <= len {
            own = Some(compact(order, vals, len, d, &slot_of, active));
            len = active;
        }
    }
    (tree, leaf_of)
}

/// Keeps, for every feature, only the sorted entries of still-open samples.
fn compact(
    order: &[u32],
    vals: &[f32],
    len: usize,
    d: usize,
    slot_of: &[u32],
    active: usize,
) -> (Vec<u32>, Vec<f32>) {
    let mut o2 = vec![0u32; active * d];
    let mut v2 = vec![0.0f32; active * d];
    if active == 0 {
        return (o2, v2);
    }
    o2.par_chunks_mut(active)
        .zip(v2.par_chunks_mut(active))
        .enumerate()
        .for_each(|(f, (o, v))| {
            let mut j = 0;
            for (&s, &val) in order[f * len..(f + 1) * len]
                .iter()
                .zip(&vals[f * len..(f + 1) * len])
            {
                if slot_of[s as usize] != NONE {
                    o[j] = s;
                    v[j] = val;
                    j += 1;
                }
            }
        });
    (o2, v2)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use rand::SeedableRng;

    fn cfg(criterion: Criterion, max_features: usize) -> TreeConfig {
        TreeConfig {
            criterion,
            max_depth: usize::MAX,
            min_samples_split: 2,
            min_samples_leaf: 1,
            max_features,
        }
    }

    #[test]
    fn keys_sort_like_floats() {
        let mut v = [3.5f32, -0.0, 0.0, -7.25, 1e-30, -1e-30, f32::MAX, f32::MIN];
        let mut k: Vec<u32> = v.iter().map(|&x| key(x)).collect();
        k.sort_unstable();
        v.sort_by(|a, b| a.total_cmp(b));
        let back: Vec<f32> = k.iter().map(|&x| unkey(x)).collect();
        assert_eq!(
            back.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            v.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn both_builders_split_at_the_midpoint_into_pure_leaves() {
        // One feature: 1, 2 are class 0; 4, 8 class 1 → threshold (2 + 4) / 2 = 3.
        let x = Matrix::from_rows(&[[1.0f32], [2.0], [4.0], [8.0]]).unwrap();
        let w = vec![1.0; 4];
        let t = vec![0.0, 0.0, 1.0, 1.0];
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let (a, leaves) = grow_presorted(&x, &Presorted::new(&x), &targets, &cfg(Criterion::Gini, 1), 7);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (b, leaves_b) = grow_sorting(&x.columns(), 4, 1, &targets, &cfg(Criterion::Gini, 1), &mut rng);
        for tree in [&a, &b] {
            assert_eq!(tree.len(), 3);
            assert_eq!(tree.feature[0], 0);
            assert_eq!(tree.threshold[0], 3.0);
            assert_eq!((tree.value[1], tree.value[2]), (0.0, 1.0));
            assert_eq!(tree.predict(&[2.999]), 0.0);
            assert_eq!(tree.predict(&[3.0]), 0.0);
            assert_eq!(tree.predict(&[3.001]), 1.0);
        }
        assert_eq!(leaves, vec![1, 1, 2, 2]);
        assert_eq!(leaves_b, leaves);
    }

    #[test]
    fn values_within_feature_threshold_are_not_split() {
        // 1.0 and its next float differ by 1.19e-7 ≤ 1e-7 rounded in f32: one value.
        let a = 1.0f32;
        let b = f32::from_bits(a.to_bits() + 1);
        let x = Matrix::from_rows(&[[a], [b]]).unwrap();
        let w = vec![1.0; 2];
        let t = vec![0.0, 1.0];
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let (tree, _) = grow_presorted(&x, &Presorted::new(&x), &targets, &cfg(Criterion::Gini, 1), 1);
        assert_eq!(tree.len(), 1);
        assert_eq!(tree.value[0], 0.5);
    }

    #[test]
    fn weights_and_min_samples_leaf() {
        // Weighted fraction in the leaf; min_samples_leaf = 2 forbids the 1|3 split.
        let x = Matrix::from_rows(&[[0.0f32], [1.0], [2.0], [3.0]]).unwrap();
        let w = vec![3.0, 1.0, 1.0, 0.0];
        let t = vec![1.0, 0.0, 0.0, 1.0];
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let mut c = cfg(Criterion::Gini, 1);
        c.min_samples_leaf = 2;
        let (tree, leaves) = grow_presorted(&x, &Presorted::new(&x), &targets, &c, 1);
        assert_eq!(tree.len(), 1);
        assert_eq!(tree.value[0], 3.0 / 5.0);
        assert_eq!(leaves, vec![0, 0, 0, NONE]);
    }

    #[test]
    fn mse_tree_means() {
        let x = Matrix::from_rows(&[[0.0f32], [1.0], [5.0], [6.0]]).unwrap();
        let w = vec![1.0; 4];
        let t = vec![1.0, 2.0, 10.0, 12.0];
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let mut c = cfg(Criterion::Mse, 1);
        c.max_depth = 1;
        let (tree, _) = grow_presorted(&x, &Presorted::new(&x), &targets, &c, 1);
        assert_eq!(tree.threshold[0], 3.0);
        assert_eq!((tree.value[1], tree.value[2]), (1.5, 11.0));
    }

    #[test]
    fn builders_agree_on_random_data() {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (n, d) = (300, 6);
        let data: Vec<f32> = (0..n * d).map(|_| rng.random::<f32>()).collect();
        let x = Matrix::new(n, d, data).unwrap();
        let w: Vec<f64> = (0..n).map(|i| f64::from((i % 3) as u8)).collect();
        // Continuous targets (no exact ties but 2-sample nodes): same partitions, so the
        // in-bag leaf values agree; out-of-bag rows may differ where any feature separates two.
        let t: Vec<f64> = (0..n)
            .map(|i| f64::from(x.row(i)[0] * 3.0 + x.row(i)[1] * x.row(i)[2]) + rng.random::<f64>())
            .collect();
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let c = cfg(Criterion::Mse, d);
        let (a, la) = grow_presorted(&x, &Presorted::new(&x), &targets, &c, 11);
        let (b, lb) = grow_sorting(
            &x.columns(),
            n,
            d,
            &targets,
            &c,
            &mut ChaCha8Rng::seed_from_u64(5),
        );
        let leaf_values = |t: &Tree, l: &[u32]| -> Vec<f64> {
            l.iter()
                .map(|&l| if l == NONE { -1.0 } else { t.value[l as usize] })
                .collect()
        };
        assert_eq!(leaf_values(&a, &la), leaf_values(&b, &lb));
        assert!(a.validate(d).is_ok() && b.validate(d).is_ok());
        // Gini near the root (ties between features are unlikely there): same predictions.
        let t: Vec<f64> = (0..n)
            .map(|i| {
                f64::from(u8::from(
                    x.row(i)[0] + x.row(i)[1] * x.row(i)[2] > 0.6 || rng.random::<f32>() < 0.1,
                ))
            })
            .collect();
        let targets = Targets {
            weight: &w,
            target: &t,
        };
        let mut c = cfg(Criterion::Gini, d);
        c.max_depth = 3;
        let (a, _) = grow_presorted(&x, &Presorted::new(&x), &targets, &c, 11);
        let (b, _) = grow_sorting(
            &x.columns(),
            n,
            d,
            &targets,
            &c,
            &mut ChaCha8Rng::seed_from_u64(5),
        );
        assert_eq!(a.len(), b.len());
        for i in 0..n {
            assert_eq!(a.predict(x.row(i)), b.predict(x.row(i)));
        }
    }
}
