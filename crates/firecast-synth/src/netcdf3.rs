//! A small streaming writer for the NetCDF classic formats: CDF-1 (`CDF\x01`, "classic") and
//! CDF-2 (`CDF\x02`, "64-bit offset").
//!
//! Written from the NetCDF classic format specification (Unidata, "File Format
//! Specifications", appendix B of the netCDF users' guide):
//!
//! ```text
//! netcdf_file = header data
//! header      = magic numrecs dim_list gatt_list var_list
//! magic       = 'C' 'D' 'F' VERSION            VERSION = \x01 (classic) | \x02 (64-bit offset)
//! numrecs     = NON_NEG                         (4 bytes in both versions)
//! dim_list    = ABSENT | NC_DIMENSION nelems [dim ...]
//! gatt_list   = att_list,  vatt_list = att_list
//! att_list    = ABSENT | NC_ATTRIBUTE nelems [attr ...]
//! var_list    = ABSENT | NC_VARIABLE nelems [var ...]
//! ABSENT      = ZERO ZERO                       (8 zero bytes)
//! dim         = name dim_length
//! attr        = name nc_type nelems [values ...] (values padded to 4 bytes with zeros)
//! var         = name nelems [dimid ...] vatt_list nc_type vsize begin
//! name        = nelems namestring               (padded to 4 bytes with zeros)
//! begin       = OFFSET                          (4 bytes for CDF-1, 8 bytes for CDF-2)
//! NC_DIMENSION = \x00\x00\x00\x0A, NC_VARIABLE = \x00\x00\x00\x0B, NC_ATTRIBUTE = \x00\x00\x00\x0C
//! nc_type: NC_BYTE 1, NC_CHAR 2, NC_SHORT 3, NC_INT 4, NC_FLOAT 5, NC_DOUBLE 6
//! ```
//!
//! Everything is big-endian. Only fixed-size variables are supported (no record dimension;
//! `numrecs` is 0), which is all GRIDMET-style yearly files need. Each variable's data starts
//! at its `begin` offset, in definition order, and is padded to a multiple of 4 bytes.
//!
//! Size limits (spec "Note on vsize" and the classic-format limitations): in CDF-1 every
//! `begin` must fit a signed 32-bit integer, so the file may not exceed 2 GiB; in CDF-2 the
//! offsets are 64-bit, every variable but the last must be smaller than 4 GiB, and the last
//! one may be larger (its `vsize` is then written as 2^32 − 1, the spec's marker). With
//! [`Version::Auto`] CDF-1 is chosen when the whole file fits in 2 GiB, CDF-2 otherwise.
//!
//! The writer streams: [`ClassicWriter::new`] writes the header, then the values of each
//! variable are appended in definition order (any number of calls per variable), so a
//! variable larger than memory can be written one slab at a time.

use std::io::{self, Write};

/// Errors from planning or writing a classic file.
#[derive(Debug, thiserror::Error)]
pub enum NcWriteError {
    /// The schema cannot be written (bad name, unknown dimension, too large for the version).
    #[error("invalid NetCDF classic schema: {0}")]
    Invalid(String),
    /// Values were written out of order or in the wrong amount or type.
    #[error("NetCDF classic write out of sequence: {0}")]
    Sequence(String),
    /// The underlying writer failed.
    #[error("I/O error while writing NetCDF: {0}")]
    Io(#[from] io::Error),
}

/// Result alias for this module.
pub type Result<T> = std::result::Result<T, NcWriteError>;

/// Classic external data types (the ones this writer supports).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcType {
    /// 8-bit signed integer.
    Byte,
    /// 8-bit character (text).
    Char,
    /// 16-bit signed integer.
    Short,
    /// 32-bit signed integer.
    Int,
    /// 32-bit IEEE float.
    Float,
    /// 64-bit IEEE float.
    Double,
}

impl NcType {
    /// The `nc_type` code of the format specification.
    pub fn code(self) -> u32 {
        match self {
            Self::Byte => 1,
            Self::Char => 2,
            Self::Short => 3,
            Self::Int => 4,
            Self::Float => 5,
            Self::Double => 6,
        }
    }

    /// Size of one value in bytes.
    pub fn size(self) -> usize {
        match self {
            Self::Byte | Self::Char => 1,
            Self::Short => 2,
            Self::Int | Self::Float => 4,
            Self::Double => 8,
        }
    }
}

/// An attribute value: text or a vector of numbers of one type.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    /// `NC_CHAR` text.
    Text(String),
    /// `NC_BYTE` values.
    Byte(Vec<i8>),
    /// `NC_SHORT` values.
    Short(Vec<i16>),
    /// `NC_INT` values.
    Int(Vec<i32>),
    /// `NC_FLOAT` values.
    Float(Vec<f32>),
    /// `NC_DOUBLE` values.
    Double(Vec<f64>),
}

impl AttrValue {
    fn nc_type(&self) -> NcType {
        match self {
            Self::Text(_) => NcType::Char,
            Self::Byte(_) => NcType::Byte,
            Self::Short(_) => NcType::Short,
            Self::Int(_) => NcType::Int,
            Self::Float(_) => NcType::Float,
            Self::Double(_) => NcType::Double,
        }
    }

    fn len(&self) -> usize {
        match self {
            Self::Text(s) => s.len(),
            Self::Byte(v) => v.len(),
            Self::Short(v) => v.len(),
            Self::Int(v) => v.len(),
            Self::Float(v) => v.len(),
            Self::Double(v) => v.len(),
        }
    }

    fn encode(&self, out: &mut Vec<u8>) {
        match self {
            Self::Text(s) => out.extend_from_slice(s.as_bytes()),
            Self::Byte(v) => out.extend(v.iter().map(|&b| b as u8)),
            Self::Short(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Self::Int(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Self::Float(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Self::Double(v) => v.iter().for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
        }
    }
}

/// A named attribute.
#[derive(Debug, Clone, PartialEq)]
pub struct Attr {
    /// Attribute name.
    pub name: String,
    /// Its value.
    pub value: AttrValue,
}

impl Attr {
    /// A text attribute.
    pub fn text(name: &str, value: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            value: AttrValue::Text(value.into()),
        }
    }

    /// A scalar `short` attribute.
    pub fn short(name: &str, value: i16) -> Self {
        Self {
            name: name.into(),
            value: AttrValue::Short(vec![value]),
        }
    }

    /// A scalar `int` attribute.
    pub fn int(name: &str, value: i32) -> Self {
        Self {
            name: name.into(),
            value: AttrValue::Int(vec![value]),
        }
    }

    /// A scalar `float` attribute.
    pub fn float(name: &str, value: f32) -> Self {
        Self {
            name: name.into(),
            value: AttrValue::Float(vec![value]),
        }
    }

    /// A scalar `double` attribute.
    pub fn double(name: &str, value: f64) -> Self {
        Self {
            name: name.into(),
            value: AttrValue::Double(vec![value]),
        }
    }
}

/// A fixed-size dimension.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Dim {
    /// Dimension name.
    pub name: String,
    /// Its length (at least 1: length 0 would mark the record dimension).
    pub len: usize,
}

/// A variable: its dimensions are indices into [`Schema::dims`] (slowest-varying first).
#[derive(Debug, Clone, PartialEq)]
pub struct Var {
    /// Variable name.
    pub name: String,
    /// Dimension indices, outermost first; empty for a scalar.
    pub dims: Vec<usize>,
    /// Storage type.
    pub dtype: NcType,
    /// Variable attributes.
    pub attrs: Vec<Attr>,
}

/// Everything in a classic header.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Schema {
    /// Dimensions.
    pub dims: Vec<Dim>,
    /// Global attributes.
    pub attrs: Vec<Attr>,
    /// Variables, in the order their data are stored.
    pub vars: Vec<Var>,
}

impl Schema {
    /// Adds a dimension and returns its index.
    pub fn add_dim(&mut self, name: &str, len: usize) -> usize {
        self.dims.push(Dim {
            name: name.into(),
            len,
        });
        self.dims.len() - 1
    }

    /// Adds a variable and returns its index.
    pub fn add_var(&mut self, name: &str, dtype: NcType, dims: &[usize], attrs: Vec<Attr>) -> usize {
        self.vars.push(Var {
            name: name.into(),
            dims: dims.to_vec(),
            dtype,
            attrs,
        });
        self.vars.len() - 1
    }

    /// Number of values of variable `var`.
    pub fn var_len(&self, var: usize) -> u64 {
        self.vars[var]
            .dims
            .iter()
            .map(|&d| self.dims.get(d).map_or(0, |d| d.len as u64))
            .product()
    }
}

/// Which classic format version to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Version {
    /// CDF-1 when the file fits in 2 GiB, CDF-2 otherwise.
    #[default]
    Auto,
    /// `CDF\x01` (classic; 32-bit offsets).
    Cdf1,
    /// `CDF\x02` (64-bit offsets).
    Cdf2,
}

/// Where everything goes, computed from a schema before anything is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// 1 for CDF-1, 2 for CDF-2.
    pub version: u8,
    /// Bytes in the header (the first variable's data starts here).
    pub header_len: u64,
    /// Data offset (`begin`) of each variable.
    pub begins: Vec<u64>,
    /// Unpadded data bytes of each variable.
    pub data_bytes: Vec<u64>,
    /// Total file length in bytes.
    pub file_len: u64,
}

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;
/// The largest `begin` a CDF-1 file can hold (a signed 32-bit offset).
const CDF1_MAX_OFFSET: u64 = i32::MAX as u64;
/// The largest `vsize` of a variable that is not the last one in CDF-2.
const CDF2_MAX_VSIZE: u64 = (1 << 32) - 4;

fn pad4(n: u64) -> u64 {
    n.div_ceil(4) * 4
}

fn check_name(kind: &str, name: &str) -> Result<()> {
    let ok_first = name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_');
    // A subset of the specification's name rules: printable ASCII without '/' or spaces.
    let ok_rest = name.chars().all(|c| c.is_ascii_graphic() && c != '/');
    if !ok_first || !ok_rest {
        return Err(NcWriteError::Invalid(format!(
            "{kind} name {name:?} is not a valid NetCDF name"
        )));
    }
    Ok(())
}

fn validate(schema: &Schema) -> Result<()> {
    for d in &schema.dims {
        check_name("dimension", &d.name)?;
        if d.len == 0 {
            return Err(NcWriteError::Invalid(format!(
                "dimension {:?} has length 0 (record dimensions are not supported)",
                d.name
            )));
        }
    }
    let mut names: Vec<&str> = schema.dims.iter().map(|d| d.name.as_str()).collect();
    names.sort_unstable();
    if names.windows(2).any(|w| w[0] == w[1]) {
        return Err(NcWriteError::Invalid("duplicate dimension name".into()));
    }
    let mut var_names: Vec<&str> = schema.vars.iter().map(|v| v.name.as_str()).collect();
    var_names.sort_unstable();
    if var_names.windows(2).any(|w| w[0] == w[1]) {
        return Err(NcWriteError::Invalid("duplicate variable name".into()));
    }
    let check_attrs = |owner: &str, attrs: &[Attr]| -> Result<()> {
        let mut seen: Vec<&str> = Vec::with_capacity(attrs.len());
        for a in attrs {
            check_name("attribute", &a.name)?;
            if seen.contains(&a.name.as_str()) {
                return Err(NcWriteError::Invalid(format!(
                    "duplicate attribute {:?} on {owner}",
                    a.name
                )));
            }
            seen.push(&a.name);
        }
        Ok(())
    };
    check_attrs("the file", &schema.attrs)?;
    for v in &schema.vars {
        check_name("variable", &v.name)?;
        check_attrs(&v.name, &v.attrs)?;
        if let Some(&bad) = v.dims.iter().find(|&&d| d >= schema.dims.len()) {
            return Err(NcWriteError::Invalid(format!(
                "variable {:?} uses dimension index {bad}, but the schema has {} dimensions",
                v.name,
                schema.dims.len()
            )));
        }
    }
    Ok(())
}

/// Bytes of an encoded name (count + padded string).
fn name_len(name: &str) -> u64 {
    4 + pad4(name.len() as u64)
}

fn att_list_len(attrs: &[Attr]) -> u64 {
    8 + attrs
        .iter()
        .map(|a| name_len(&a.name) + 8 + pad4((a.value.len() * a.value.nc_type().size()) as u64))
        .sum::<u64>()
}

fn header_len(schema: &Schema, version: u8) -> u64 {
    let offset_len = if version == 1 { 4 } else { 8 };
    let dims = 8 + schema.dims.iter().map(|d| name_len(&d.name) + 4).sum::<u64>();
    let vars = 8 + schema
        .vars
        .iter()
        .map(|v| name_len(&v.name) + 4 + 4 * v.dims.len() as u64 + att_list_len(&v.attrs) + 8 + offset_len)
        .sum::<u64>();
    4 + 4 + dims + att_list_len(&schema.attrs) + vars
}

fn layout_for(schema: &Schema, version: u8) -> Layout {
    let header = header_len(schema, version);
    let mut begins = Vec::with_capacity(schema.vars.len());
    let mut data_bytes = Vec::with_capacity(schema.vars.len());
    let mut at = header;
    for (k, v) in schema.vars.iter().enumerate() {
        let bytes = schema.var_len(k).saturating_mul(v.dtype.size() as u64);
        begins.push(at);
        data_bytes.push(bytes);
        at = at.saturating_add(pad4(bytes));
    }
    Layout {
        version,
        header_len: header,
        begins,
        data_bytes,
        file_len: at,
    }
}

fn fits(layout: &Layout) -> std::result::Result<(), String> {
    let n = layout.begins.len();
    match layout.version {
        1 => {
            // Every offset must fit a signed 32-bit integer, and so must the file's end.
            if layout.file_len > CDF1_MAX_OFFSET {
                return Err(format!(
                    "{} bytes do not fit the 2 GiB limit of the CDF-1 format",
                    layout.file_len
                ));
            }
            Ok(())
        }
        _ => {
            for k in 0..n.saturating_sub(1) {
                if pad4(layout.data_bytes[k]) > CDF2_MAX_VSIZE {
                    return Err(format!(
                        "variable {k} has {} bytes; only the last variable of a CDF-2 file may \
                         exceed 4 GiB",
                        layout.data_bytes[k]
                    ));
                }
            }
            Ok(())
        }
    }
}

/// Computes the layout for `version` (resolving [`Version::Auto`]), or says why the schema
/// cannot be written.
pub fn plan(schema: &Schema, version: Version) -> Result<Layout> {
    validate(schema)?;
    let layout = match version {
        Version::Cdf1 => layout_for(schema, 1),
        Version::Cdf2 => layout_for(schema, 2),
        Version::Auto => {
            let v1 = layout_for(schema, 1);
            if fits(&v1).is_ok() {
                v1
            } else {
                layout_for(schema, 2)
            }
        }
    };
    fits(&layout).map_err(NcWriteError::Invalid)?;
    Ok(layout)
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_be_bytes());
}

fn put_name(out: &mut Vec<u8>, name: &str) {
    put_u32(out, name.len() as u32);
    out.extend_from_slice(name.as_bytes());
    pad_zero(out);
}

fn pad_zero(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
}

fn put_att_list(out: &mut Vec<u8>, attrs: &[Attr]) {
    if attrs.is_empty() {
        put_u32(out, 0);
        put_u32(out, 0);
        return;
    }
    put_u32(out, NC_ATTRIBUTE);
    put_u32(out, attrs.len() as u32);
    for a in attrs {
        put_name(out, &a.name);
        put_u32(out, a.value.nc_type().code());
        put_u32(out, a.value.len() as u32);
        a.value.encode(out);
        pad_zero(out);
    }
}

/// Encodes the header of `schema` for `layout`.
pub fn encode_header(schema: &Schema, layout: &Layout) -> Vec<u8> {
    let mut out = Vec::with_capacity(layout.header_len as usize);
    out.extend_from_slice(b"CDF");
    out.push(layout.version);
    put_u32(&mut out, 0); // numrecs: no record dimension
    if schema.dims.is_empty() {
        put_u32(&mut out, 0);
        put_u32(&mut out, 0);
    } else {
        put_u32(&mut out, NC_DIMENSION);
        put_u32(&mut out, schema.dims.len() as u32);
        for d in &schema.dims {
            put_name(&mut out, &d.name);
            put_u32(&mut out, d.len as u32);
        }
    }
    put_att_list(&mut out, &schema.attrs);
    if schema.vars.is_empty() {
        put_u32(&mut out, 0);
        put_u32(&mut out, 0);
    } else {
        put_u32(&mut out, NC_VARIABLE);
        put_u32(&mut out, schema.vars.len() as u32);
        for (k, v) in schema.vars.iter().enumerate() {
            put_name(&mut out, &v.name);
            put_u32(&mut out, v.dims.len() as u32);
            for &d in &v.dims {
                put_u32(&mut out, d as u32);
            }
            put_att_list(&mut out, &v.attrs);
            put_u32(&mut out, v.dtype.code());
            let vsize = pad4(layout.data_bytes[k]);
            // A vsize that does not fit 32 bits (only possible for the last variable of a
            // CDF-2 file) is written as 2^32 - 1, as the specification prescribes.
            put_u32(&mut out, u32::try_from(vsize).unwrap_or(u32::MAX));
            if layout.version == 1 {
                // `plan` guarantees the offset fits.
                put_u32(&mut out, layout.begins[k] as u32);
            } else {
                out.extend_from_slice(&layout.begins[k].to_be_bytes());
            }
        }
    }
    debug_assert_eq!(out.len() as u64, layout.header_len);
    out
}

/// Streams one classic file: header first, then every variable's values in definition order.
pub struct ClassicWriter<W: Write> {
    out: W,
    layout: Layout,
    types: Vec<NcType>,
    names: Vec<String>,
    /// Variable currently being written.
    current: usize,
    /// Bytes of `current` written so far.
    written: u64,
    buf: Vec<u8>,
}

impl<W: Write> ClassicWriter<W> {
    /// Plans the layout and writes the header.
    pub fn new(mut out: W, schema: &Schema, version: Version) -> Result<Self> {
        let layout = plan(schema, version)?;
        out.write_all(&encode_header(schema, &layout))?;
        let mut w = Self {
            out,
            layout,
            types: schema.vars.iter().map(|v| v.dtype).collect(),
            names: schema.vars.iter().map(|v| v.name.clone()).collect(),
            current: 0,
            written: 0,
            buf: Vec::new(),
        };
        w.skip_empty()?;
        Ok(w)
    }

    /// The layout being written.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Index of the variable the next values belong to (`None` when all are complete).
    pub fn current_var(&self) -> Option<usize> {
        (self.current < self.types.len()).then_some(self.current)
    }

    /// Moves past complete (or empty) variables, writing their padding.
    fn skip_empty(&mut self) -> Result<()> {
        while self.current < self.types.len() && self.written == self.layout.data_bytes[self.current] {
            let pad = (pad4(self.written) - self.written) as usize;
            self.out.write_all(&[0u8; 4][..pad])?;
            self.current += 1;
            self.written = 0;
        }
        Ok(())
    }

    /// Appends already big-endian encoded values of type `dtype` to the current variable.
    pub fn write_be_bytes(&mut self, dtype: NcType, bytes: &[u8]) -> Result<()> {
        let Some(k) = self.current_var() else {
            return Err(NcWriteError::Sequence(
                "every variable is already complete".into(),
            ));
        };
        if self.types[k] != dtype {
            return Err(NcWriteError::Sequence(format!(
                "variable {:?} is {:?}, got {dtype:?} values",
                self.names[k], self.types[k]
            )));
        }
        if !bytes.len().is_multiple_of(dtype.size()) {
            return Err(NcWriteError::Sequence(format!(
                "{} bytes are not a whole number of {dtype:?} values",
                bytes.len()
            )));
        }
        let left = self.layout.data_bytes[k] - self.written;
        if bytes.len() as u64 > left {
            return Err(NcWriteError::Sequence(format!(
                "{} bytes for variable {:?}, which has only {left} bytes left",
                bytes.len(),
                self.names[k]
            )));
        }
        self.out.write_all(bytes)?;
        self.written += bytes.len() as u64;
        self.skip_empty()
    }

    fn write_with<T: Copy, const N: usize>(
        &mut self,
        dtype: NcType,
        values: &[T],
        enc: impl Fn(T) -> [u8; N],
    ) -> Result<()> {
        let mut buf = std::mem::take(&mut self.buf);
        buf.clear();
        buf.reserve(values.len() * N);
        for &v in values {
            buf.extend_from_slice(&enc(v));
        }
        let r = self.write_be_bytes(dtype, &buf);
        self.buf = buf;
        r
    }

    /// Appends `short` values.
    pub fn write_i16(&mut self, values: &[i16]) -> Result<()> {
        self.write_with(NcType::Short, values, i16::to_be_bytes)
    }

    /// Appends `int` values.
    pub fn write_i32(&mut self, values: &[i32]) -> Result<()> {
        self.write_with(NcType::Int, values, i32::to_be_bytes)
    }

    /// Appends `float` values.
    pub fn write_f32(&mut self, values: &[f32]) -> Result<()> {
        self.write_with(NcType::Float, values, f32::to_be_bytes)
    }

    /// Appends `double` values.
    pub fn write_f64(&mut self, values: &[f64]) -> Result<()> {
        self.write_with(NcType::Double, values, f64::to_be_bytes)
    }

    /// Checks that every variable is complete, flushes, and returns the inner writer.
    pub fn finish(mut self) -> Result<W> {
        if let Some(k) = self.current_var() {
            return Err(NcWriteError::Sequence(format!(
                "variable {:?} is incomplete ({} of {} bytes written)",
                self.names[k], self.written, self.layout.data_bytes[k]
            )));
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Schema {
        let mut s = Schema::default();
        let x = s.add_dim("x", 3);
        let y = s.add_dim("y", 2);
        s.attrs.push(Attr::text("title", "t"));
        s.add_var("a", NcType::Short, &[x], vec![Attr::short("_FillValue", -1)]);
        s.add_var("b", NcType::Double, &[y, x], vec![]);
        s.add_var("c", NcType::Int, &[], vec![]);
        s
    }

    #[test]
    fn header_length_matches_encoding() {
        let s = small();
        for v in [Version::Cdf1, Version::Cdf2] {
            let l = plan(&s, v).expect("plan");
            assert_eq!(encode_header(&s, &l).len() as u64, l.header_len);
            assert_eq!(l.begins[1], l.begins[0] + 8); // 6 bytes padded to 8
            assert_eq!(l.file_len, l.begins[2] + 4);
        }
    }

    #[test]
    fn auto_picks_cdf2_beyond_2_gib() {
        let mut s = Schema::default();
        let d = s.add_dim("day", 366);
        let la = s.add_dim("lat", 585);
        let lo = s.add_dim("lon", 1386);
        s.add_var("v", NcType::Float, &[d, la, lo], vec![]);
        assert_eq!(plan(&s, Version::Auto).expect("plan").version, 1);
        s.add_var("w", NcType::Double, &[d, la, lo], vec![]);
        let l = plan(&s, Version::Auto).expect("plan");
        assert_eq!(l.version, 2);
        assert!(plan(&s, Version::Cdf1).is_err());
        // A non-last variable above 4 GiB cannot be written even in CDF-2.
        let big = s.add_dim("big", 1000);
        s.vars.insert(0, s.vars[1].clone());
        s.vars[0].name = "z".into();
        s.vars[0].dims.insert(0, big);
        assert!(plan(&s, Version::Auto).is_err());
    }

    #[test]
    fn sequence_is_enforced() {
        let s = small();
        let mut w = ClassicWriter::new(Vec::new(), &s, Version::Cdf1).expect("new");
        assert!(w.write_f64(&[1.0]).is_err());
        w.write_i16(&[1, 2]).expect("a part 1");
        assert!(w.write_i16(&[3, 4]).is_err());
        w.write_i16(&[3]).expect("a part 2");
        w.write_f64(&[0.0; 6]).expect("b");
        let w2 = ClassicWriter::new(Vec::new(), &s, Version::Cdf1).expect("new");
        assert!(w2.finish().is_err());
        w.write_i32(&[7]).expect("c");
        let bytes = w.finish().expect("finish");
        let l = plan(&s, Version::Cdf1).expect("plan");
        assert_eq!(bytes.len() as u64, l.file_len);
        assert_eq!(&bytes[..4], b"CDF\x01");
        assert_eq!(&bytes[bytes.len() - 4..], &7i32.to_be_bytes());
    }

    #[test]
    fn names_are_checked() {
        let mut s = Schema::default();
        s.add_dim("bad/name", 1);
        assert!(plan(&s, Version::Auto).is_err());
        let mut s = Schema::default();
        s.add_dim("x", 0);
        assert!(plan(&s, Version::Auto).is_err());
    }
}
