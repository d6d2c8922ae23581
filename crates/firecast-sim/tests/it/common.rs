//! Fixture loading and tolerance bookkeeping shared by the oracle tests.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use firecast_sim::FuelModel;

/// Path of a fixture under `tests/fixtures/` (the shared oracle folder is never read at test time).
pub fn fixture(name: &str) -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures")
    .join(name)
}

/// A parsed CSV fixture. Values are kept as text so tolerances can follow printed precision.
pub struct Table {
    pub name: String,
    columns: HashMap<String, usize>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn load(name: &str) -> Self {
        let text = std::fs::read_to_string(fixture(name)).unwrap();
        Self::parse(name, &text)
    }

    pub fn parse(name: &str, text: &str) -> Self {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = split(lines.next().unwrap());
        let columns = header.iter().enumerate().map(|(i, h)| (h.clone(), i)).collect();
        let rows: Vec<Vec<String>> = lines.map(split).collect();
        for row in &rows {
            assert_eq!(row.len(), header.len(), "{name}: ragged row {row:?}");
        }
        Self {
            name: name.to_owned(),
            columns,
            rows,
        }
    }

    pub fn header_has(&self, column: &str) -> bool {
        self.columns.contains_key(column)
    }

    pub fn text<'a>(&self, row: &'a [String], column: &str) -> &'a str {
        let idx = *self
            .columns
            .get(column)
            .unwrap_or_else(|| panic!("{}: no column {column}", self.name));
        &row[idx]
    }

    pub fn num(&self, row: &[String], column: &str) -> f64 {
        let text = self.text(row, column);
        text.parse()
            .unwrap_or_else(|_| panic!("{}: {column} = {text:?}", self.name))
    }

    /// The standard fuel model of a row, by its `fm` number.
    pub fn model(&self, row: &[String]) -> &'static FuelModel {
        let fm = self.text(row, "fm");
        FuelModel::lookup(fm).unwrap_or_else(|_| panic!("{}: fuel model {fm}", self.name))
    }
}

/// Quote-aware split of one CSV line (fixtures have no multi-line fields).
fn split(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                fields.last_mut().unwrap().push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(String::new()),
            _ => fields.last_mut().unwrap().push(c),
        }
    }
    fields
}

/// Half a unit in the last printed decimal of `text` (0 for integers / exponent forms).
pub fn print_half_ulp(text: &str) -> f64 {
    match text.split_once('.') {
        Some((_, frac)) if !frac.contains(['e', 'E']) => 0.5 * 10f64.powi(-(frac.len() as i32)),
        _ => 0.0,
    }
}

pub fn rel_err(actual: f64, expected: f64) -> f64 {
    if expected == 0.0 {
        actual.abs()
    } else {
        ((actual - expected) / expected).abs()
    }
}

/// Collects comparisons for one fixture: the worst relative error per column, and failures.
pub struct Checker {
    file: String,
    worst: Vec<(String, f64, String)>,
    failures: Vec<String>,
    pub compared: usize,
}

impl Checker {
    pub fn new(file: &str) -> Self {
        Self {
            file: file.to_owned(),
            worst: Vec::new(),
            failures: Vec::new(),
            compared: 0,
        }
    }

    /// Checks |actual − expected| ≤ rel·|expected| + abs.
    pub fn check(&mut self, column: &str, context: &str, actual: f64, expected: f64, rel: f64, abs: f64) {
        let ok = actual.is_finite() && (actual - expected).abs() <= rel * expected.abs() + abs;
        self.record(column, context, actual, expected, ok);
    }

    /// Records a comparison whose verdict was decided by the caller.
    pub fn record(&mut self, column: &str, context: &str, actual: f64, expected: f64, ok: bool) {
        self.compared += 1;
        let err = rel_err(actual, expected);
        match self.worst.iter_mut().find(|(c, _, _)| c == column) {
            Some(entry) if err > entry.1 => {
                entry.1 = err;
                entry.2 = context.to_owned();
            }
            Some(_) => {}
            None => self.worst.push((column.to_owned(), err, context.to_owned())),
        }
        if !ok {
            self.failures.push(format!(
                "{context} {column}: got {actual:.10e}, expected {expected:.10e} (rel err {err:.3e})"
            ));
        }
    }

    /// Oracle value printed as `text`: rel tolerance plus half a unit of the printed last digit,
    /// so that values printed with few significant digits are not held to more than they carry.
    pub fn check_printed(&mut self, column: &str, context: &str, actual: f64, text: &str, rel: f64) {
        let expected: f64 = text.parse().unwrap();
        self.check(column, context, actual, expected, rel, print_half_ulp(text));
    }

    /// Exact equality (used for exact zeros).
    pub fn check_exact(&mut self, column: &str, context: &str, actual: f64, expected: f64) {
        self.check(column, context, actual, expected, 0.0, 0.0);
    }

    /// Worst relative error over all columns except angle differences (those are in degrees).
    pub fn worst_overall(&self) -> f64 {
        self.worst
            .iter()
            .filter(|w| !w.0.ends_with("_deg"))
            .map(|w| w.1)
            .fold(0.0, f64::max)
    }

    pub fn summary(&self) -> String {
        let mut s = format!(
            "{}: {} comparisons, worst relative error {:.3e}; per column (angles: absolute degrees):",
            self.file,
            self.compared,
            self.worst_overall()
        );
        for (column, err, at) in &self.worst {
            let _ = write!(s, " {column}={err:.2e} [{at}]");
        }
        s
    }

    /// Asserts no failures; the message carries the worst relative error per column.
    pub fn finish(self) {
        println!("{}", self.summary());
        assert!(self.compared > 0, "{}: nothing compared", self.file);
        assert!(
            self.failures.is_empty(),
            "{}\n{} failures, first ones:\n{}",
            self.summary(),
            self.failures.len(),
            self.failures
                .iter()
                .take(15)
                .cloned()
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
}
