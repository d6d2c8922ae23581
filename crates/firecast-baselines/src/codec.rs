//! Lossless JSON encodings for fitted models.
//!
//! serde_json's default float parser can be one ulp off (its `float_roundtrip` feature is
//! not enabled in this workspace), so a fitted model written as plain JSON numbers would
//! not predict bit-identically after loading. Floats that predictions depend on are
//! therefore stored either as decimal strings parsed by the correctly rounded
//! `str::parse` (small, human-readable vectors and scalars) or as base64 of their
//! little-endian bytes (bulk arrays: tree nodes, KNN training rows).

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serializer};

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding.
pub(crate) fn base64_encode(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        let sextet = |shift: u32| char::from(ALPHABET[((n >> shift) & 63) as usize]);
        out.push(sextet(18));
        out.push(sextet(12));
        out.push(if chunk.len() > 1 { sextet(6) } else { '=' });
        out.push(if chunk.len() > 2 { sextet(0) } else { '=' });
    }
    out
}

/// Inverse of [`base64_encode`]; rejects anything that is not canonical padded base64.
pub(crate) fn base64_decode(text: &str) -> Result<Vec<u8>, String> {
    let bytes = text.as_bytes();
    if !bytes.len().is_multiple_of(4) {
        return Err(format!("base64 length {} is not a multiple of 4", bytes.len()));
    }
    let value = |c: u8| -> Result<u32, String> {
        match c {
            b'A'..=b'Z' => Ok(u32::from(c - b'A')),
            b'a'..=b'z' => Ok(u32::from(c - b'a') + 26),
            b'0'..=b'9' => Ok(u32::from(c - b'0') + 52),
            b'+' => Ok(62),
            b'/' => Ok(63),
            _ => Err(format!("invalid base64 character {:?}", char::from(c))),
        }
    };
    let mut out = Vec::with_capacity(bytes.len() / 4 * 3);
    let quads = bytes.len() / 4;
    for (i, q) in bytes.chunks(4).enumerate() {
        let pad = q.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 || (pad > 0 && i + 1 != quads) {
            return Err("misplaced base64 padding".into());
        }
        let mut n = 0u32;
        for &c in &q[..4 - pad] {
            n = (n << 6) | value(c)?;
        }
        n <<= 6 * pad as u32;
        let decoded = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&decoded[..3 - pad]);
    }
    Ok(out)
}

/// Little-endian fixed-width values that can travel as base64.
pub(crate) trait LeBytes: Sized + Copy {
    const WIDTH: usize;
    fn put(self, out: &mut Vec<u8>);
    fn get(bytes: &[u8]) -> Self;
}

macro_rules! le_bytes {
    ($($t:ty),*) => {$(
        impl LeBytes for $t {
            const WIDTH: usize = std::mem::size_of::<$t>();
            fn put(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
            fn get(bytes: &[u8]) -> Self {
                let mut a = [0u8; std::mem::size_of::<$t>()];
                a.copy_from_slice(bytes);
                <$t>::from_le_bytes(a)
            }
        }
    )*};
}
le_bytes!(f32, f64, u32);

/// `#[serde(with = "codec::b64")]` for `Vec<f32 | f64 | u32>`: base64 of the LE bytes.
pub(crate) mod b64 {
    use super::*;

    pub(crate) fn serialize<T: LeBytes, S: Serializer>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
        let mut bytes = Vec::with_capacity(v.len() * T::WIDTH);
        for &x in v {
            x.put(&mut bytes);
        }
        s.serialize_str(&base64_encode(&bytes))
    }

    pub(crate) fn deserialize<'de, T: LeBytes, D: Deserializer<'de>>(d: D) -> Result<Vec<T>, D::Error> {
        let text = String::deserialize(d)?;
        let bytes = base64_decode(&text).map_err(D::Error::custom)?;
        if !bytes.len().is_multiple_of(T::WIDTH) {
            return Err(D::Error::custom(format!(
                "{} bytes is not a whole number of {}-byte values",
                bytes.len(),
                T::WIDTH
            )));
        }
        Ok(bytes.chunks_exact(T::WIDTH).map(T::get).collect())
    }
}

/// `#[serde(with = "codec::exact")]` for one `f64`: its shortest round-trip decimal string.
pub(crate) mod exact {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{v:?}"))
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        let text = String::deserialize(d)?;
        text.parse::<f64>()
            .map_err(|e| D::Error::custom(format!("{text:?}: {e}")))
    }
}

/// `#[serde(with = "codec::exact_vec")]` for `Vec<f64>`: decimal strings, one per value.
pub(crate) mod exact_vec {
    use super::*;
    use serde::ser::SerializeSeq;

    pub(crate) fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(v.len()))?;
        for x in v {
            seq.serialize_element(&format!("{x:?}"))?;
        }
        seq.end()
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let texts = Vec::<String>::deserialize(d)?;
        texts
            .iter()
            .map(|t| {
                t.parse::<f64>()
                    .map_err(|e| D::Error::custom(format!("{t:?}: {e}")))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn base64_round_trips_every_tail_length() {
        for len in 0..20usize {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 37 + 11) as u8).collect();
            let text = base64_encode(&bytes);
            assert_eq!(base64_decode(&text).unwrap(), bytes, "len {len}");
        }
        assert_eq!(base64_encode(b"Man"), "TWFu");
        assert_eq!(base64_encode(b"Ma"), "TWE=");
        assert!(base64_decode("TW=u").is_err());
        assert!(base64_decode("TWF").is_err());
        assert!(base64_decode("TW?u").is_err());
    }

    #[test]
    fn exact_strings_round_trip_awkward_doubles() {
        #[derive(serde::Serialize, serde::Deserialize)]
        struct S {
            #[serde(with = "exact")]
            a: f64,
            #[serde(with = "exact_vec")]
            v: Vec<f64>,
            #[serde(with = "b64")]
            w: Vec<f64>,
        }
        let vals = vec![0.1 + 0.2, 1.0 / 3.0, 5e-324, -1.7976931348623157e308, 1e23, -0.0];
        let s = S {
            a: 0.30000000000000004,
            v: vals.clone(),
            w: vals.clone(),
        };
        let back: S = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back.a.to_bits(), s.a.to_bits());
        for (x, y) in back.v.iter().chain(&back.w).zip(vals.iter().chain(&vals)) {
            assert_eq!(x.to_bits(), y.to_bits());
        }
    }
}
