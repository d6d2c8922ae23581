//! Shared test helpers: a seeded synthetic dataset, a tiny NPY writer, the venv's Python.

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// splitmix64: small, seeded, good enough for synthetic data.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A `rows x cols` row-major dataset with a nonlinear signal in the first few columns,
/// noise columns after them, ~2% missing values (NaN) and Bernoulli labels.
pub struct Dataset {
    pub x: Vec<f32>,
    pub y: Vec<bool>,
    pub rows: usize,
    pub cols: usize,
}

pub fn synthetic(rows: usize, cols: usize, seed: u64) -> Dataset {
    assert!(cols >= 6);
    let mut rng = Rng::new(seed);
    let mut x = Vec::with_capacity(rows * cols);
    let mut y = Vec::with_capacity(rows);
    for _ in 0..rows {
        let row: Vec<f64> = (0..cols).map(|_| rng.normal()).collect();
        let logit = 1.5 * (2.0 * row[0]).sin() + row[1] * row[2] - 0.8 * row[3] * row[3]
            + if row[4] > 0.3 { 1.2 } else { -0.4 }
            + 0.5 * row[5].abs()
            + 0.3;
        let p = 1.0 / (1.0 + (-logit).exp());
        y.push(rng.uniform() < p);
        for v in row {
            // Missing values everywhere except in a couple of columns.
            let missing = rng.uniform() < 0.02;
            x.push(if missing { f32::NAN } else { v as f32 });
        }
    }
    Dataset { x, y, rows, cols }
}

/// Writes a little-endian float32 NPY v1.0 file with the given shape.
pub fn write_npy_f32(path: &Path, data: &[f32], shape: &[usize]) {
    assert_eq!(shape.iter().product::<usize>(), data.len());
    let shape_txt = match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")
        ),
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape_txt}, }}");
    // magic (6) + version (2) + header length (2) + header + '\n' is a multiple of 64.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + data.len() * 4);
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend_from_slice(&u16::try_from(header.len()).expect("header").to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let mut f = std::fs::File::create(path).expect("create npy");
    f.write_all(&bytes).expect("write npy");
}

/// The venv's Python with xgboost: the agreement test must not be skipped.
pub fn venv_python() -> PathBuf {
    firecast_testkit::python_with(&["xgboost"])
}

/// `tests/tools/xgb_reference.py`.
pub fn reference_script() -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/tools/xgb_reference.py")
}

/// The largest absolute difference between two equally long vectors.
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}
