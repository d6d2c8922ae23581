//! Choosing the decision threshold on validation scores.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

/// Returned by [`choose_threshold`] when a data-driven rule has nothing to work with.
pub const FALLBACK_THRESHOLD: f64 = 0.5;

/// How to pick the threshold `t` of the rule "predict fire when `p > t`".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThresholdRule {
    /// Maximise F1.
    MaxF1,
    /// Maximise Youden's J = TPR − FPR.
    Youden,
    /// The largest threshold whose recall is at least the given value.
    TargetRecall(f64),
    /// This threshold, whatever the scores.
    Fixed(f64),
}

/// One candidate: predicting `p > threshold` gives `tp` true and `fp` false positives.
struct Candidate {
    threshold: f64,
    tp: u64,
    fp: u64,
}

/// Candidates in increasing threshold order: just below the lowest score (everything
/// positive), then every distinct score s (everything above s positive).
fn candidates(y: &[bool], p: &[f64]) -> Vec<Candidate> {
    let mut order: Vec<usize> = (0..y.len()).collect();
    order.sort_by(|&a, &b| p[a].partial_cmp(&p[b]).unwrap_or(Ordering::Equal));
    let positives = y.iter().filter(|&&l| l).count() as u64;
    let negatives = y.len() as u64 - positives;
    let mut out = Vec::new();
    let (mut tp, mut fp) = (positives, negatives);
    if let Some(&lowest) = order.first() {
        out.push(Candidate {
            threshold: p[lowest].next_down(),
            tp,
            fp,
        });
    }
    for (k, &i) in order.iter().enumerate() {
        // Samples scoring exactly s stop being positive once the threshold reaches s.
        if y[i] {
            tp -= 1;
        } else {
            fp -= 1;
        }
        if order.get(k + 1).is_none_or(|&next| p[next] != p[i]) {
            out.push(Candidate {
                threshold: p[i],
                tp,
                fp,
            });
        }
    }
    out
}

/// The best candidate under `better` (only a strictly better one replaces the current
/// best), so ties go to the smallest threshold.
fn first_best(cands: &[Candidate], better: impl Fn(&Candidate, &Candidate) -> bool) -> Option<&Candidate> {
    let mut best: Option<&Candidate> = None;
    for c in cands {
        if best.is_none_or(|b| better(c, b)) {
            best = Some(c);
        }
    }
    best
}

/// The threshold `t` for "predict fire when `p > t`", chosen on (validation) scores.
///
/// Candidates are every distinct score (predicting everything strictly above it) plus
/// the float just below the lowest score (predicting everything). `MaxF1` and `Youden`
/// keep the candidate with the best value — compared exactly, in integer arithmetic —
/// and on ties the smallest threshold. `TargetRecall(r)` keeps the largest candidate whose
/// recall is ≥ r. `Fixed(t)` returns `t`. The data-driven rules return
/// [`FALLBACK_THRESHOLD`] when lengths differ, `y` is empty, a score is not finite, or
/// the classes they need are absent (positives for `MaxF1` and `TargetRecall`, both
/// classes for `Youden`).
pub fn choose_threshold(y: &[bool], p: &[f64], rule: ThresholdRule) -> f64 {
    if let ThresholdRule::Fixed(t) = rule {
        return t;
    }
    if y.len() != p.len() || y.is_empty() || p.iter().any(|v| !v.is_finite()) {
        return FALLBACK_THRESHOLD;
    }
    let positives = y.iter().filter(|&&l| l).count() as u128;
    let negatives = y.len() as u128 - positives;
    let cands = candidates(y, p);
    let chosen = match rule {
        ThresholdRule::Fixed(t) => return t,
        ThresholdRule::MaxF1 if positives > 0 => {
            // F1 = 2tp / (tp + fp + P); compare a/b > c/d as a·d > c·b.
            let f1 = |c: &Candidate| (2 * u128::from(c.tp), u128::from(c.tp + c.fp) + positives);
            first_best(&cands, |c, b| {
                let ((cn, cd), (bn, bd)) = (f1(c), f1(b));
                cn * bd > bn * cd
            })
        }
        ThresholdRule::Youden if positives > 0 && negatives > 0 => {
            // J·P·N = tp·N − fp·P.
            let j = |c: &Candidate| u128::from(c.tp) * negatives;
            let k = |c: &Candidate| u128::from(c.fp) * positives;
            first_best(&cands, |c, b| j(c) + k(b) > j(b) + k(c))
        }
        ThresholdRule::TargetRecall(r) if positives > 0 => cands
            .iter()
            .rev()
            .find(|c| c.tp as f64 / positives as f64 >= r)
            .or(cands.first()),
        _ => None,
    };
    chosen.map_or(FALLBACK_THRESHOLD, |c| c.threshold)
}
