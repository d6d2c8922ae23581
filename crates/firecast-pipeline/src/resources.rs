//! Per-stage cluster resources (`resources:` in a stage), what a remote executor asks its
//! scheduler for when it ships one run of the stage:
//!
//! ```yaml
//! stages:
//!   windows:
//!     uses: data.windows
//!     resources: {cpus: 2, memory: 4GiB, gpus: 0}
//! ```
//!
//! Strict like the rest of the file: an unknown key, a negative count or a memory size
//! without a known unit is an error naming the file, line and key.

use serde::{Deserialize, Deserializer, Serialize};

/// CPUs, memory and GPUs one run of a stage needs. Absent values mean the executor's
/// default (one CPU for Ray).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Resources {
    /// Logical CPUs (fractions allowed, as in Ray).
    #[serde(
        default,
        deserialize_with = "positive",
        skip_serializing_if = "Option::is_none"
    )]
    pub cpus: Option<f64>,
    /// Memory in bytes; written as a byte count or with a unit: `512MiB`, `2GB`, `4GiB`.
    #[serde(default, deserialize_with = "memory", skip_serializing_if = "Option::is_none")]
    pub memory: Option<u64>,
    /// GPUs (fractions allowed).
    #[serde(
        default,
        deserialize_with = "non_negative",
        skip_serializing_if = "Option::is_none"
    )]
    pub gpus: Option<f64>,
}

impl Resources {
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v > 0.0 {
        Ok(Some(v))
    } else {
        Err(serde::de::Error::custom(format!(
            "must be a number above 0, got {v}"
        )))
    }
}

fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v >= 0.0 {
        Ok(Some(v))
    } else {
        Err(serde::de::Error::custom(format!(
            "must be a number of at least 0, got {v}"
        )))
    }
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawMemory {
    Bytes(u64),
    Text(String),
}

fn memory<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    match RawMemory::deserialize(d)? {
        RawMemory::Bytes(0) => Err(serde::de::Error::custom("memory must be above 0 bytes")),
        RawMemory::Bytes(b) => Ok(Some(b)),
        RawMemory::Text(t) => parse_memory(&t).map(Some).map_err(serde::de::Error::custom),
    }
}

/// `512MiB`, `2GB`, `1.5GiB`, `1000` (bytes). Units: B, kB/KB, MB, GB, TB (powers of
/// 1000) and KiB, MiB, GiB, TiB (powers of 1024).
pub fn parse_memory(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("memory `{text}` is not a size like 512MiB, 2GB or a byte count"))?;
    let scale: f64 = match unit.trim() {
        "" | "B" => 1.0,
        "kB" | "KB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        "TB" => 1e12,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        "TiB" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        other => {
            return Err(format!(
                "memory `{text}`: unknown unit `{other}` (use B, KB, MB, GB, TB, KiB, MiB, GiB or TiB)"
            ));
        }
    };
    let bytes = (value * scale).round();
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("memory `{text}` must be above 0 bytes"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn memory_sizes_parse_with_units() {
        assert_eq!(parse_memory("512MiB").unwrap(), 512 * 1024 * 1024);
        assert_eq!(parse_memory("2GB").unwrap(), 2_000_000_000);
        assert_eq!(parse_memory("1.5GiB").unwrap(), 1_610_612_736);
        assert_eq!(parse_memory("1000").unwrap(), 1000);
        assert!(parse_memory("2 gallons").unwrap_err().contains("unknown unit"));
        assert!(parse_memory("lots").is_err());
        assert!(parse_memory("0MB").is_err());
    }

    #[test]
    fn resources_are_strict() {
        let r: Resources = serde_yaml_ng::from_str("{cpus: 2, memory: 1GiB, gpus: 0.5}").unwrap();
        assert_eq!(r.cpus, Some(2.0));
        assert_eq!(r.memory, Some(1 << 30));
        assert_eq!(r.gpus, Some(0.5));
        assert!(serde_yaml_ng::from_str::<Resources>("{cpu: 2}").is_err());
        assert!(serde_yaml_ng::from_str::<Resources>("{cpus: 0}").is_err());
        assert!(serde_yaml_ng::from_str::<Resources>("{gpus: -1}").is_err());
    }
}
