//! The cases sent to scikit-learn: seeded random scores of many sizes, heavy ties, equal
//! scores, perfect and inverted rankings, tiny and one-class sets, bin-edge and 0/1
//! probabilities, logits, and McNemar's exact/χ² boundary.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};

/// One labelled score vector, plus a second model for the paired tests.
#[derive(Debug, Clone)]
pub struct Case {
    pub name: String,
    pub y: Vec<bool>,
    pub p: Vec<f64>,
    pub threshold: f64,
    /// Whether `p` are probabilities (Brier, log loss, calibration apply).
    pub probabilities: bool,
    pub p_b: Vec<f64>,
    pub threshold_b: f64,
    /// Whether to run the O(n²) DeLong reference (kept to moderate n).
    pub delong: bool,
}

impl Case {
    fn new(name: impl Into<String>, y: Vec<bool>, p: Vec<f64>, threshold: f64) -> Self {
        let n = y.len();
        let probabilities = p.iter().all(|v| (0.0..=1.0).contains(v));
        // A second, weaker model: the first one's ranking shuffled a little.
        let mut rng = ChaCha8Rng::seed_from_u64(n as u64 ^ 0x5eed);
        let p_b = p
            .iter()
            .map(|&v| {
                let w = 0.6 * v + 0.4 * rng.random::<f64>();
                if probabilities { w.clamp(0.0, 1.0) } else { w }
            })
            .collect();
        Self {
            name: name.into(),
            y,
            p,
            threshold,
            probabilities,
            p_b,
            threshold_b: threshold,
            delong: n <= 5000,
        }
    }

    pub fn to_json(&self) -> Value {
        json!({
            "name": self.name,
            "y": self.y.iter().map(|&l| u8::from(l)).collect::<Vec<_>>(),
            "p": self.p,
            "threshold": self.threshold,
            "probabilities": self.probabilities,
            "p_b": self.p_b,
            "threshold_b": self.threshold_b,
            "delong": self.delong,
        })
    }
}

fn round_to(v: f64, decimals: i32) -> f64 {
    let s = 10f64.powi(decimals);
    (v * s).round() / s
}

/// Labels with the given prevalence and informative probabilities.
fn random(rng: &mut ChaCha8Rng, n: usize, prevalence: f64) -> (Vec<bool>, Vec<f64>) {
    let y: Vec<bool> = (0..n).map(|_| rng.random::<f64>() < prevalence).collect();
    let p = y
        .iter()
        .map(|&l| 0.35 * f64::from(u8::from(l)) + 0.65 * rng.random::<f64>())
        .collect();
    (y, p)
}

pub fn all() -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(20_240_611);
    let mut cases = Vec::new();
    for n in [2usize, 3, 5, 8, 13, 50, 128, 129, 300, 1000, 4000, 20_000] {
        for prevalence in [0.1, 0.5] {
            let (y, p) = random(&mut rng, n, prevalence);
            let tag = format!("n{n}-prev{prevalence}");
            cases.push(Case::new(format!("{tag}-raw"), y.clone(), p.clone(), 0.5));
            cases.push(Case::new(
                format!("{tag}-2dp"),
                y.clone(),
                p.iter().map(|&v| round_to(v, 2)).collect(),
                0.5,
            ));
            // One decimal: scores sit on calibration edges and on the threshold itself.
            cases.push(Case::new(
                format!("{tag}-1dp"),
                y,
                p.iter().map(|&v| round_to(v, 1)).collect(),
                0.3,
            ));
        }
    }
    // Equal scores everywhere.
    let (y, _) = random(&mut rng, 40, 0.3);
    cases.push(Case::new("all-equal-0.5", y.clone(), vec![0.5; 40], 0.5));
    cases.push(Case::new("all-equal-0.5-below", y.clone(), vec![0.5; 40], 0.4));
    cases.push(Case::new("all-zero", y, vec![0.0; 40], 0.5));
    // Perfect and inverted rankings.
    let (y, _) = random(&mut rng, 60, 0.4);
    let perfect: Vec<f64> = y
        .iter()
        .map(|&l| {
            if l {
                0.6 + 0.4 * rng.random::<f64>()
            } else {
                0.4 * rng.random::<f64>()
            }
        })
        .collect();
    cases.push(Case::new("perfect", y.clone(), perfect.clone(), 0.5));
    cases.push(Case::new(
        "inverted",
        y.clone(),
        perfect.iter().map(|v| 1.0 - v).collect(),
        0.5,
    ));
    cases.push(Case::new(
        "perfect-two-levels",
        y.clone(),
        y.iter().map(|&l| if l { 1.0 } else { 0.0 }).collect(),
        0.5,
    ));
    // Tiny sets and missing classes.
    cases.push(Case::new("n1-positive", vec![true], vec![0.3], 0.5));
    cases.push(Case::new("n1-negative", vec![false], vec![0.7], 0.5));
    cases.push(Case::new("n2-tied", vec![true, false], vec![0.5, 0.5], 0.5));
    cases.push(Case::new("n2-wrong", vec![false, true], vec![0.9, 0.2], 0.5));
    cases.push(Case::new("n3", vec![true, false, true], vec![0.2, 0.6, 0.6], 0.5));
    let (_, p) = random(&mut rng, 25, 0.5);
    cases.push(Case::new("all-positive", vec![true; 25], p.clone(), 0.5));
    cases.push(Case::new("all-negative", vec![false; 25], p, 0.5));
    // Probabilities at 0 and 1 (log loss clips), and the float just off the edges.
    let y: Vec<bool> = (0..16).map(|i| i % 3 == 0).collect();
    let extremes = [
        0.0,
        1.0,
        1e-20,
        1.0 - 1e-16,
        f64::EPSILON,
        1.0 - f64::EPSILON,
        0.5,
        1.0,
    ];
    let p: Vec<f64> = (0..16).map(|i| extremes[i % extremes.len()]).collect();
    cases.push(Case::new("extremes", y, p, 0.5));
    // Exactly on the calibration edges, including 3 * 0.1 = 0.30000000000000004.
    let y: Vec<bool> = (0..44).map(|i| i % 4 == 1 || i % 7 == 0).collect();
    let p: Vec<f64> = (0..44)
        .map(|i| {
            if i % 4 == 3 {
                (i % 11) as f64 * 0.1
            } else {
                (i % 11) as f64 / 10.0
            }
        })
        .collect();
    cases.push(Case::new("bin-edges", y, p, 0.5));
    // Logits: ranking and threshold metrics only.
    let (y, p) = random(&mut rng, 500, 0.3);
    let logits: Vec<f64> = p.iter().map(|&v| 8.0 * v - 4.0 + rng.random::<f64>()).collect();
    cases.push(Case::new("logits", y.clone(), logits.clone(), 0.0));
    cases.push(Case::new(
        "logits-1dp",
        y,
        logits.iter().map(|&v| round_to(v, 1)).collect(),
        0.0,
    ));
    // McNemar on both sides of the exact/χ² switch: 24 and 25 discordant pairs.
    for discordant in [24usize, 25] {
        let n = 60;
        let y: Vec<bool> = (0..n).map(|i| i % 2 == 0).collect();
        let right = |i: usize, l: bool| if l { 0.9 } else { 0.1 } + 0.001 * i as f64;
        let wrong = |i: usize, l: bool| if l { 0.1 } else { 0.9 } - 0.001 * i as f64;
        let p_a: Vec<f64> = (0..n)
            .map(|i| {
                if i < 17 {
                    right(i, y[i])
                } else if i < discordant {
                    wrong(i, y[i])
                } else {
                    right(i, y[i])
                }
            })
            .collect();
        // A right and B wrong on the first 17; A wrong and B right up to `discordant`.
        let p_b: Vec<f64> = (0..n)
            .map(|i| if i < 17 { wrong(i, y[i]) } else { right(i, y[i]) })
            .collect();
        let mut case = Case::new(format!("mcnemar-{discordant}"), y, p_a, 0.5);
        case.p_b = p_b;
        cases.push(case);
    }
    cases
}

/// Points where erfc is compared with SciPy, over all three of Cody's intervals.
pub fn erfc_points() -> Vec<f64> {
    let mut xs: Vec<f64> = (-60..=260).map(|i| f64::from(i) * 0.1).collect();
    xs.extend([
        0.46875,
        0.468_75 + 1e-12,
        4.0,
        4.0 + 1e-12,
        1e-10,
        -1e-10,
        1e-17,
        0.0,
        26.0,
        26.5,
    ]);
    xs
}
