//! Split protocols: which samples train, which choose thresholds and stop training, which
//! are only ever used once, for the reported numbers.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::ForecastError;
use crate::data::Windows;
use crate::spec::Split;

/// Sample indices of each side of a split.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SplitIndices {
    pub train: Vec<usize>,
    pub val: Vec<usize>,
    pub test: Vec<usize>,
    /// Samples left out so that nothing leaks (temporal: windows of a cell that overlap the
    /// test period).
    pub dropped: Vec<usize>,
    /// One line saying what was done, for tables and cards.
    pub description: String,
}

fn shuffle(items: &mut [usize], rng: &mut ChaCha8Rng) {
    for i in (1..items.len()).rev() {
        let j = rng.random_range(0..=i);
        items.swap(i, j);
    }
}

/// Stratified draw of `share` of `members` (by label), like sklearn's `train_test_split`
/// with `stratify=y` (per-class rounding; our own seeded shuffle, not NumPy's).
fn stratified_take(
    members: &[usize],
    labels: &dyn Fn(usize) -> bool,
    share: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec<usize>, Vec<usize>) {
    let mut taken = Vec::new();
    let mut rest = Vec::new();
    for class in [true, false] {
        let mut group: Vec<usize> = members.iter().copied().filter(|&m| labels(m) == class).collect();
        shuffle(&mut group, rng);
        let n = (group.len() as f64 * share).round() as usize;
        taken.extend_from_slice(&group[..n]);
        rest.extend_from_slice(&group[n..]);
    }
    taken.sort_unstable();
    rest.sort_unstable();
    (taken, rest)
}

/// Groups of samples of one GRIDMET cell whose day ranges (inputs and predicted day)
/// overlap: they share weather, so a group never straddles two sides.
pub fn overlap_groups(w: &Windows, days: (i32, i32)) -> Vec<usize> {
    let span = (days.1.max(0) - days.0.min(0)) as i64;
    let mut order: Vec<usize> = (0..w.len()).collect();
    order.sort_by_key(|&s| (w.meta[s].cell, w.meta[s].event_day, w.meta[s].sample_id));
    let mut group = vec![0usize; w.len()];
    let mut next = 0usize;
    let mut prev: Option<usize> = None;
    for &s in &order {
        let joins = prev.is_some_and(|p| {
            w.meta[p].cell == w.meta[s].cell && (w.meta[s].event_day - w.meta[p].event_day) as i64 <= span
        });
        if !joins {
            next += 1;
        }
        group[s] = next - 1;
        prev = Some(s);
    }
    group
}

/// Split by groups: every member of a group goes where the group goes.
fn split_groups(
    w: &Windows,
    group: &[usize],
    candidates: &[usize],
    share: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec<usize>, Vec<usize>) {
    let mut members: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &s in candidates {
        members.entry(group[s]).or_default().push(s);
    }
    let ids: Vec<usize> = members.keys().copied().collect();
    let positive = |g: usize| members[&g].iter().any(|&s| w.labels[s]);
    let (taken_groups, _) = stratified_take(&ids, &positive, share, rng);
    let taken: std::collections::BTreeSet<usize> = taken_groups.into_iter().collect();
    let mut a = Vec::new();
    let mut b = Vec::new();
    for (g, list) in members {
        if taken.contains(&g) {
            a.extend(list);
        } else {
            b.extend(list);
        }
    }
    a.sort_unstable();
    b.sort_unstable();
    (a, b)
}

/// Applies `split` to `w` for inputs covering `days`.
pub fn apply(w: &Windows, split: &Split, days: (i32, i32), key: &str) -> Result<SplitIndices, ForecastError> {
    let all: Vec<usize> = (0..w.len()).collect();
    let labels = |s: usize| w.labels[s];
    let out = match split {
        Split::Dataset => {
            let mut out = SplitIndices {
                description: format!(
                    "the dataset's own split ({})",
                    format!("{:?}", w.manifest.config.split.method).to_lowercase()
                ),
                ..Default::default()
            };
            for (s, m) in w.meta.iter().enumerate() {
                match m.dataset_split.as_deref() {
                    Some("train") => out.train.push(s),
                    Some("val") => out.val.push(s),
                    Some("test") => out.test.push(s),
                    _ => out.dropped.push(s),
                }
            }
            out
        }
        Split::StratifiedRandom {
            test,
            val,
            seed,
            grouped,
        } => {
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            let (test_idx, rest, val_idx, train_idx) = if *grouped {
                let group = overlap_groups(w, days);
                let (t, rest) = split_groups(w, &group, &all, *test, &mut rng);
                let (v, tr) = split_groups(w, &group, &rest, *val, &mut rng);
                (t, rest, v, tr)
            } else {
                let (t, rest) = stratified_take(&all, &labels, *test, &mut rng);
                let (v, tr) = stratified_take(&rest, &labels, *val, &mut rng);
                (t, rest, v, tr)
            };
            let _ = rest;
            SplitIndices {
                train: train_idx,
                val: val_idx,
                test: test_idx,
                dropped: Vec::new(),
                description: format!(
                    "stratified random by {} (test {:.0} %, then val {:.0} % of the rest, seed {seed})",
                    if *grouped { "cell groups" } else { "window" },
                    test * 100.0,
                    val * 100.0
                ),
            }
        }
        Split::Temporal {
            test_from,
            test_months,
            val,
            seed,
        } => {
            let cutoff = match test_from {
                Some(s) => firecast_dataset::time::parse_date(s).ok_or_else(|| ForecastError::Config {
                    key: format!("{key}.split.test_from"),
                    message: format!("`{s}` is not a YYYY-MM-DD date"),
                })?,
                None => {
                    let last = w.meta.iter().map(|m| m.event_day).max().unwrap_or(0);
                    let (y, m, _) = firecast_data::gridmet::day_to_ymd(last);
                    let idx = y * 12 + m as i32 - 1 - (*test_months).max(1) as i32 + 1;
                    firecast_data::gridmet::ymd_to_day(idx.div_euclid(12), idx.rem_euclid(12) as u32 + 1, 1)
                        .unwrap_or(last)
                }
            };
            // A training window must end before the first test day: inputs and the
            // predicted day of training samples stay strictly in the past.
            let reach = days.1.max(0);
            let mut test_idx = Vec::new();
            let mut before = Vec::new();
            let mut dropped = Vec::new();
            for s in 0..w.len() {
                let d = w.meta[s].event_day;
                if d >= cutoff {
                    test_idx.push(s);
                } else if d + reach >= cutoff {
                    dropped.push(s);
                } else {
                    before.push(s);
                }
            }
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            let group = overlap_groups(w, days);
            let (val_idx, train_idx) = split_groups(w, &group, &before, *val, &mut rng);
            SplitIndices {
                train: train_idx,
                val: val_idx,
                test: test_idx,
                dropped,
                description: format!(
                    "temporal: test from {} on, val {:.0} % of earlier cell groups (seed {seed})",
                    firecast_dataset::time::format_date(cutoff),
                    val * 100.0
                ),
            }
        }
        Split::SpatialBlocks {
            block_degrees,
            test,
            val,
            seed,
        } => {
            let block = |s: usize| {
                let m = &w.meta[s];
                (
                    (m.lat / block_degrees).floor() as i64,
                    (m.lon / block_degrees).floor() as i64,
                )
            };
            let mut ids: BTreeMap<(i64, i64), usize> = BTreeMap::new();
            for s in 0..w.len() {
                let n = ids.len();
                ids.entry(block(s)).or_insert(n);
            }
            let group: Vec<usize> = (0..w.len()).map(|s| ids[&block(s)]).collect();
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            let (t, rest) = split_groups(w, &group, &all, *test, &mut rng);
            let (v, tr) = split_groups(w, &group, &rest, *val, &mut rng);
            SplitIndices {
                train: tr,
                val: v,
                test: t,
                dropped: Vec::new(),
                description: format!(
                    "spatial blocks of {block_degrees}° ({} blocks): test {:.0} %, val {:.0} % of blocks (seed {seed})",
                    ids.len(),
                    test * 100.0,
                    val * 100.0
                ),
            }
        }
    };
    for (side, idx) in [("train", &out.train), ("val", &out.val), ("test", &out.test)] {
        let pos = idx.iter().filter(|&&s| w.labels[s]).count();
        if pos == 0 || pos == idx.len() {
            return Err(ForecastError::Config {
                key: format!("{key}.split"),
                message: format!(
                    "the {side} side has {} samples of which {pos} positive: both classes are needed \
                     ({}); use more data or another split",
                    idx.len(),
                    out.description
                ),
            });
        }
    }
    Ok(out)
}
