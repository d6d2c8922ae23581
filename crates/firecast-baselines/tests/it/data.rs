//! Test fixtures: a seeded weather-window dataset, NPY files, a rank AUROC.

use std::path::Path;

use firecast_baselines::Matrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A train/test split.
pub struct Split {
    pub x_train: Matrix,
    pub y_train: Vec<bool>,
    pub x_test: Matrix,
    pub y_test: Vec<bool>,
}

/// Standard normal by Box-Muller.
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

const VARIABLES: usize = 15;

/// Flattened weather windows like the paper's inputs: 15 GRIDMET-like variables × `days`
/// days (day-major: day 0's 15 values, then day 1's, ...). Every sample has a season, a
/// region and three correlated latent regimes (heat/dryness, wind, moisture) that drive
/// AR(1) daily series with their own units and noise; precipitation is zero-inflated,
/// humidity rounded to 0.1 % and wind direction to whole degrees (exact ties, as real
/// data has). Ignition odds rise with recent heat, dryness, wind and a dry-and-windy
/// interaction, fall with recent rain; the intercept gives about 40 % positives.
pub fn weather_windows(rows: usize, days: usize, seed: u64) -> (Matrix, Vec<bool>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = VARIABLES * days;
    let mut data = Vec::with_capacity(rows * d);
    let mut labels = Vec::with_capacity(rows);
    let mut v = [0.0f64; VARIABLES];
    for _ in 0..rows {
        let season = rng.random::<f64>();
        let region = rng.random_range(0..6usize) as f64;
        let warm = (2.0 * std::f64::consts::PI * (season - 0.3)).sin();
        let heat = normal(&mut rng);
        let wind = 0.3 * heat + 0.95 * normal(&mut rng);
        let moist = -0.5 * heat + 0.85 * normal(&mut rng);
        let mut recent = [0.0f64; 4]; // heat, dryness, wind, rain over the last 3 days
        for day in 0..days {
            // Regimes build towards the last day.
            let ramp = 0.4 + 0.6 * (day as f64 + 1.0) / days as f64;
            let h = heat * ramp + 0.6 * normal(&mut rng);
            let w = wind * ramp + 0.7 * normal(&mut rng);
            let m = moist * ramp + 0.7 * normal(&mut rng);
            let base = [
                295.0 + 10.0 * warm + 1.5 * region + 5.0 * h,  // tmmx (K)
                281.0 + 9.0 * warm + 1.0 * region + 3.5 * h,   // tmmn (K)
                (75.0 - 8.0 * h + 10.0 * m).clamp(5.0, 100.0), // rmax (%)
                (30.0 - 9.0 * h + 8.0 * m).clamp(1.0, 100.0),  // rmin (%)
                (3.0 + 1.2 * w).max(0.2) + 0.8 * w.abs(),      // vs (m/s)
                0.0,                                           // pr (mm), set below
                0.006 + 0.002 * warm + 0.001 * m,              // sph (kg/kg)
                (1.2 + 0.5 * h - 0.3 * m).max(0.0),            // vpd (kPa)
                45.0 + 12.0 * h - 8.0 * m + 5.0 * warm,        // erc
                40.0 + 10.0 * h + 8.0 * w - 6.0 * m,           // bi
                (14.0 - 3.0 * h + 3.0 * m).max(2.0),           // fm100 (%)
                (16.0 - 2.5 * h + 2.5 * m).max(3.0),           // fm1000 (%)
                220.0 + 80.0 * warm + 20.0 * h - 15.0 * m,     // srad (W/m²)
                5.0 + 2.0 * warm + 1.2 * h + 0.5 * w,          // etr (mm)
                180.0 + 60.0 * w + 40.0 * region,              // th (deg)
            ];
            for (j, b) in base.iter().enumerate() {
                let noise = 0.25 * normal(&mut rng) * (1.0 + b.abs().sqrt() * 0.1);
                v[j] = if day == 0 {
                    *b + noise
                } else {
                    0.6 * v[j] + 0.4 * b + noise
                };
            }
            let rain = if rng.random::<f64>() < 1.0 / (1.0 + (-(m - 0.8)).exp()) {
                (-rng.random::<f64>().max(1e-12).ln() * (2.0 + 3.0 * m.max(0.0))).min(80.0)
            } else {
                0.0
            };
            v[5] = rain;
            v[2] = (v[2].clamp(5.0, 100.0) * 10.0).round() / 10.0;
            v[3] = (v[3].clamp(1.0, 100.0) * 10.0).round() / 10.0;
            v[14] = v[14].rem_euclid(360.0).round();
            if day + 3 >= days {
                recent[0] += h / 3.0;
                recent[1] += (30.0 - v[3]) / 30.0;
                recent[2] += w / 3.0;
                recent[3] += rain;
            }
            data.extend(v.iter().map(|&x| x as f32));
        }
        let score = -0.25 + 0.9 * recent[0] + 0.35 * recent[1] + 0.6 * recent[2] - 0.08 * recent[3]
            + 0.6 * f64::from(u8::from(recent[0] > 0.5 && recent[2] > 0.3))
            + 0.4 * warm
            + 0.8 * normal(&mut rng);
        labels.push(score > 0.0);
    }
    (Matrix::new(rows, d, data).unwrap(), labels)
}

/// A seeded split of [`weather_windows`].
pub fn split(train: usize, test: usize, days: usize, seed: u64) -> Split {
    let (x, y) = weather_windows(train + test, days, seed);
    let d = x.cols;
    Split {
        x_train: Matrix::new(train, d, x.data[..train * d].to_vec()).unwrap(),
        y_train: y[..train].to_vec(),
        x_test: Matrix::new(test, d, x.data[train * d..].to_vec()).unwrap(),
        y_test: y[train..].to_vec(),
    }
}

/// Heavily tied data: `d` features taking `levels` integer values (a few duplicated
/// columns and one constant column, so whole features tie and constant features are
/// met), labels from a noisy rule on the first features.
pub fn coarse(train: usize, test: usize, d: usize, levels: u32, seed: u64) -> Split {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rows = train + test;
    let mut data = Vec::with_capacity(rows * d);
    let mut labels = Vec::with_capacity(rows);
    for _ in 0..rows {
        let mut row: Vec<f32> = (0..d).map(|_| rng.random_range(0..levels) as f32).collect();
        row[d - 1] = 1.0;
        row[d - 2] = row[0];
        row[d - 3] = row[1] * 0.5;
        let score = f64::from(row[0]) - f64::from(row[1]) + 0.5 * f64::from(row[2] * row[3])
            - f64::from(levels) / 2.0
            + 1.5 * normal(&mut rng);
        labels.push(score > 0.0);
        data.extend(row);
    }
    Split {
        x_train: Matrix::new(train, d, data[..train * d].to_vec()).unwrap(),
        y_train: labels[..train].to_vec(),
        x_test: Matrix::new(test, d, data[train * d..].to_vec()).unwrap(),
        y_test: labels[train..].to_vec(),
    }
}

fn npy_header(descr: &str, shape: &str) -> Vec<u8> {
    let dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + dict + padding + '\n' ≡ 0 (mod 64).
    let unpadded = 10 + dict.len() + 1;
    let pad = (64 - unpadded % 64) % 64;
    let header = format!("{dict}{}\n", " ".repeat(pad));
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out
}

/// NPY v1.0, '<f4', C order.
pub fn write_npy_f32(path: &Path, m: &Matrix) -> std::io::Result<()> {
    let mut out = npy_header("<f4", &format!("({}, {})", m.rows, m.cols));
    for v in &m.data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, out)
}

/// NPY v1.0, '|u1' (0/1).
pub fn write_npy_labels(path: &Path, y: &[bool]) -> std::io::Result<()> {
    let mut out = npy_header("|u1", &format!("({},)", y.len()));
    out.extend(y.iter().map(|&b| u8::from(b)));
    std::fs::write(path, out)
}

/// Reads a 2-D '<f4' C-order NPY (v1.0 or v2.0) as written by NumPy.
pub fn read_npy_f32(path: &Path) -> Matrix {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY", "{}: not an NPY file", path.display());
    let (hlen, start) = if bytes[6] == 1 {
        (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10)
    } else {
        (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        )
    };
    let header = std::str::from_utf8(&bytes[start..start + hlen]).unwrap_or_default();
    assert!(
        header.contains("'descr': '<f4'") && header.contains("'fortran_order': False"),
        "{header}"
    );
    let shape = &header[header.find("'shape': (").map_or(0, |i| i + 10)..];
    let shape = &shape[..shape.find(')').unwrap_or(0)];
    let dims: Vec<usize> = shape.split(',').filter_map(|s| s.trim().parse().ok()).collect();
    assert_eq!(dims.len(), 2, "{header}");
    let data: Vec<f32> = bytes[start + hlen..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Matrix::new(dims[0], dims[1], data).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Area under the ROC curve from ranks (ties get their average rank).
pub fn auroc(y: &[bool], score: &[f64]) -> f64 {
    let mut idx: Vec<usize> = (0..y.len()).collect();
    idx.sort_by(|&a, &b| score[a].total_cmp(&score[b]));
    let mut rank = vec![0.0f64; y.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && score[idx[j + 1]] == score[idx[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            rank[k] = avg;
        }
        i = j + 1;
    }
    let pos = y.iter().filter(|&&v| v).count() as f64;
    let neg = y.len() as f64 - pos;
    let sum: f64 = y.iter().zip(&rank).filter(|(v, _)| **v).map(|(_, r)| r).sum();
    (sum - pos * (pos + 1.0) / 2.0) / (pos * neg)
}

/// Share of `p > 0.5` that equals the label (scikit-learn's `predict` rule).
pub fn accuracy(y: &[bool], p: &[f64]) -> f64 {
    y.iter().zip(p).filter(|(y, p)| **y == (**p > 0.5)).count() as f64 / y.len() as f64
}

#[test]
fn auroc_by_hand() {
    assert_eq!(auroc(&[false, true], &[0.1, 0.9]), 1.0);
    assert_eq!(auroc(&[false, true], &[0.9, 0.1]), 0.0);
    assert_eq!(auroc(&[false, true, true], &[0.5, 0.5, 0.9]), 0.75);
}

#[test]
fn npy_round_trip() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("npy-round-trip");
    std::fs::create_dir_all(&dir).unwrap();
    let m = Matrix::new(2, 3, vec![1.0, -2.5, 3.25, 0.0, 1e-8, 7.0]).unwrap();
    let path = dir.join("m.npy");
    write_npy_f32(&path, &m).unwrap();
    assert_eq!(read_npy_f32(&path), m);
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!((bytes.len() - 24) % 64, 0, "header padded to 64");
}

#[test]
fn generator_is_realistic() {
    let (x, y) = weather_windows(2000, 10, 1);
    assert_eq!((x.rows, x.cols), (2000, 150));
    let pos = y.iter().filter(|&&v| v).count() as f64 / 2000.0;
    assert!((0.3..0.5).contains(&pos), "positives {pos}");
    assert!(x.data.iter().all(|v| v.is_finite()));
    // Zero-inflated precipitation (column 5 of each day).
    let zeros = (0..2000).filter(|&r| x.row(r)[5] == 0.0).count();
    assert!(zeros > 600 && zeros < 1900, "dry days {zeros}");
}
