//! serde_json writes a NaN `f64` as `null` but refuses to read `null` back into an `f64`.
//! Fields that may be NaN (an undefined metric) read `null` as NaN with this.

use serde::{Deserialize, Deserializer};

/// `null` → NaN, a number → itself.
pub fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}
