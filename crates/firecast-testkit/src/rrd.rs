//! Rerun recordings read back by the Rerun SDK of the venv, not by FireCast's own writer.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use crate::{describe, python, rerun_cli};

/// Scalar series of a recording: entity path → `(step, value)` rows sorted by step.
pub type Series = BTreeMap<String, Vec<(i64, f64)>>;

/// Every scalar series on the `step` timeline, as Rerun's `RrdReader` reads them.
const READ_SCALARS: &str = r#"
import json, sys
from rerun.experimental import RrdReader
series = {}
for chunk in RrdReader(sys.argv[1]).stream():
    batch = chunk.to_record_batch()
    names = batch.schema.names
    if chunk.is_static or "step" not in names or "Scalars:scalars" not in names:
        continue
    rows = series.setdefault(chunk.entity_path.lstrip("/"), [])
    for step, values in zip(batch.column("step").to_pylist(), batch.column("Scalars:scalars").to_pylist()):
        rows.extend([step, v] for v in values)
for rows in series.values():
    rows.sort()
json.dump(series, sys.stdout)
"#;

/// The scalar series of `path` (static chunks and other components aside).
pub fn read_scalars(path: &Path) -> Series {
    let out = Command::new(python())
        .arg("-c")
        .arg(READ_SCALARS)
        .arg(path)
        .output()
        .expect("running the venv's Python");
    assert!(
        out.status.success(),
        "reading {} with rerun's RrdReader: {}",
        path.display(),
        describe(&out)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", describe(&out)))
}

/// `rerun rrd verify FILE` passes.
pub fn verify_rrd(path: &Path) {
    let out = Command::new(rerun_cli())
        .args(["rrd", "verify"])
        .arg(path)
        .output()
        .expect("running rerun");
    assert!(
        out.status.success(),
        "rerun rrd verify {}: {}",
        path.display(),
        describe(&out)
    );
}
