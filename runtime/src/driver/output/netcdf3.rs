//! A minimal netCDF-3 "64-bit offset" (CDF-2) file layout: the header (dimensions, one of
//! them unlimited, global and variable attributes, fixed and record variables) encoded and
//! decoded per the netCDF classic format specification, big-endian (XDR), every name,
//! attribute value and fixed variable padded to a multiple of 4 bytes.
//!
//! The layout is fixed once the header is: each variable's `begin` offset and the record
//! size follow from the header alone ([`Schema::finish`]), so any writer can place any
//! slice of any variable with a positional write at [`Schema::offset`], and a reader finds
//! it the same way. The record count (`numrecs`, bytes 4..8) is the only header field that
//! changes while a file is written ([`NUMRECS_OFFSET`]). Positional reads and writes
//! ([`read_at`], [`write_at`]) place the bytes.

use std::fs::File;

/// Write `buf` at `offset` of `file`.
pub(crate) fn write_at(file: &File, buf: &[u8], offset: u64) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::os::unix::fs::FileExt::write_all_at(file, buf, offset)
    }
    #[cfg(windows)]
    {
        let (mut buf, mut offset) = (buf, offset);
        while !buf.is_empty() {
            let n = std::os::windows::fs::FileExt::seek_write(file, buf, offset)?;
            if n == 0 {
                return Err(std::io::ErrorKind::WriteZero.into());
            }
            buf = &buf[n..];
            offset += n as u64;
        }
        Ok(())
    }
    #[cfg(not(any(unix, windows)))]
    {
        use std::io::{Seek, SeekFrom, Write};
        let mut f = file;
        f.seek(SeekFrom::Start(offset))?;
        f.write_all(buf)
    }
}

/// Read exactly `buf.len()` bytes at `offset` of `file`.
pub(crate) fn read_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
    }
    #[cfg(windows)]
    {
        let (mut buf, mut offset) = (buf, offset);
        while !buf.is_empty() {
            let n = std::os::windows::fs::FileExt::seek_read(file, buf, offset)?;
            if n == 0 {
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            }
            buf = &mut buf[n..];
            offset += n as u64;
        }
        Ok(())
    }
    #[cfg(not(any(unix, windows)))]
    {
        use std::io::{Read, Seek, SeekFrom};
        let mut f = file;
        f.seek(SeekFrom::Start(offset))?;
        f.read_exact(buf)
    }
}

/// Byte offset of `numrecs` in the file.
pub(crate) const NUMRECS_OFFSET: u64 = 4;

const MAGIC: &[u8; 4] = b"CDF\x02";
const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;

/// The external types used here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NcType {
    /// 8-bit characters.
    Char,
    /// 32-bit signed integers.
    Int,
    /// 32-bit IEEE floats.
    Float,
    /// 64-bit IEEE floats.
    Double,
}

impl NcType {
    fn code(self) -> u32 {
        match self {
            NcType::Char => 2,
            NcType::Int => 4,
            NcType::Float => 5,
            NcType::Double => 6,
        }
    }

    fn from_code(c: u32) -> Option<NcType> {
        Some(match c {
            2 => NcType::Char,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub(crate) fn size(self) -> u64 {
        match self {
            NcType::Char => 1,
            NcType::Int | NcType::Float => 4,
            NcType::Double => 8,
        }
    }
}

/// An attribute's values.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum AttrValue {
    /// Text (`NC_CHAR`).
    Text(String),
    /// `NC_INT` values.
    Int(Vec<i32>),
    /// `NC_FLOAT` values.
    Float(Vec<f32>),
    /// `NC_DOUBLE` values.
    Double(Vec<f64>),
}

/// A named attribute.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Attr {
    /// Name.
    pub(crate) name: String,
    /// Values.
    pub(crate) value: AttrValue,
}

/// A dimension; length 0 is the unlimited (record) dimension.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Dim {
    /// Name.
    pub(crate) name: String,
    /// Length (0: unlimited).
    pub(crate) len: u64,
}

/// A variable and where its data is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Var {
    /// Name.
    pub(crate) name: String,
    /// Dimension ids, slowest first (the record dimension, if any, first).
    pub(crate) dims: Vec<usize>,
    /// Attributes.
    pub(crate) attrs: Vec<Attr>,
    /// Type.
    pub(crate) ty: NcType,
    /// Bytes of the variable (of one record of it, for a record variable), padded to 4.
    pub(crate) vsize: u64,
    /// Offset of its data (of its part of record 0, for a record variable).
    pub(crate) begin: u64,
}

/// A file's header: dimensions, attributes, variables and the data layout they imply.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Schema {
    /// Dimensions.
    pub(crate) dims: Vec<Dim>,
    /// Global attributes.
    pub(crate) attrs: Vec<Attr>,
    /// Variables.
    pub(crate) vars: Vec<Var>,
    /// Bytes of one record (all record variables' parts).
    pub(crate) record_size: u64,
    /// Offset of record 0 (the end of the fixed data).
    pub(crate) records_begin: u64,
}

fn pad4(n: u64) -> u64 {
    (n + 3) & !3
}

impl Schema {
    /// Add a dimension; returns its id.
    pub(crate) fn dim(&mut self, name: &str, len: u64) -> usize {
        self.dims.push(Dim {
            name: name.into(),
            len,
        });
        self.dims.len() - 1
    }

    /// The id of the dimension `name`.
    pub(crate) fn dim_id(&self, name: &str) -> Option<usize> {
        self.dims.iter().position(|d| d.name == name)
    }

    /// Add a global attribute.
    pub(crate) fn attr(&mut self, name: &str, value: AttrValue) {
        self.attrs.push(Attr {
            name: name.into(),
            value,
        });
    }

    /// Add a variable; returns its id.
    pub(crate) fn var(&mut self, name: &str, ty: NcType, dims: &[usize]) -> usize {
        self.vars.push(Var {
            name: name.into(),
            dims: dims.to_vec(),
            attrs: Vec::new(),
            ty,
            vsize: 0,
            begin: 0,
        });
        self.vars.len() - 1
    }

    /// The id of the variable `name`.
    pub(crate) fn var_id(&self, name: &str) -> Option<usize> {
        self.vars.iter().position(|v| v.name == name)
    }

    /// Whether variable `v` is a record variable.
    pub(crate) fn is_record(&self, v: usize) -> bool {
        self.vars[v]
            .dims
            .first()
            .is_some_and(|&d| self.dims[d].len == 0)
    }

    /// Values of variable `v` (per record, for a record variable).
    pub(crate) fn values(&self, v: usize) -> u64 {
        let skip = usize::from(self.is_record(v));
        self.vars[v].dims[skip..]
            .iter()
            .map(|&d| self.dims[d].len)
            .product()
    }

    /// Compute every variable's `vsize` and `begin` and the record size: the fixed
    /// variables after the header in definition order, then the records, each holding the
    /// record variables in definition order (the netCDF library's own layout).
    pub(crate) fn finish(&mut self) {
        for v in 0..self.vars.len() {
            let bytes = self.values(v) * self.vars[v].ty.size();
            self.vars[v].vsize = pad4(bytes);
        }
        let records = (0..self.vars.len()).filter(|&v| self.is_record(v)).count();
        let mut at = self.encode(0).len() as u64;
        for v in 0..self.vars.len() {
            if !self.is_record(v) {
                self.vars[v].begin = at;
                at += self.vars[v].vsize;
            }
        }
        self.records_begin = at;
        self.record_size = 0;
        for v in 0..self.vars.len() {
            if self.is_record(v) {
                self.vars[v].begin = at + self.record_size;
                // A lone record variable is not padded (the spec's special case).
                self.record_size += if records == 1 {
                    self.values(v) * self.vars[v].ty.size()
                } else {
                    self.vars[v].vsize
                };
            }
        }
    }

    /// Offset of value `index` of variable `v` in record `rec` (ignored for a fixed one).
    pub(crate) fn offset(&self, v: usize, rec: u64, index: u64) -> u64 {
        let var = &self.vars[v];
        let rec_off = if self.is_record(v) {
            rec * self.record_size
        } else {
            0
        };
        var.begin + rec_off + index * var.ty.size()
    }

    /// The header's bytes with `numrecs` records.
    pub(crate) fn encode(&self, numrecs: u32) -> Vec<u8> {
        let mut b = Vec::with_capacity(1024);
        b.extend_from_slice(MAGIC);
        put_u32(&mut b, numrecs);
        if self.dims.is_empty() {
            b.extend_from_slice(&[0; 8]);
        } else {
            put_u32(&mut b, NC_DIMENSION);
            put_u32(&mut b, self.dims.len() as u32);
            for d in &self.dims {
                put_name(&mut b, &d.name);
                put_u32(&mut b, d.len as u32);
            }
        }
        put_attrs(&mut b, &self.attrs);
        if self.vars.is_empty() {
            b.extend_from_slice(&[0; 8]);
        } else {
            put_u32(&mut b, NC_VARIABLE);
            put_u32(&mut b, self.vars.len() as u32);
            for v in &self.vars {
                put_name(&mut b, &v.name);
                put_u32(&mut b, v.dims.len() as u32);
                for &d in &v.dims {
                    put_u32(&mut b, d as u32);
                }
                put_attrs(&mut b, &v.attrs);
                put_u32(&mut b, v.ty.code());
                put_u32(&mut b, v.vsize.min(u64::from(u32::MAX)) as u32);
                b.extend_from_slice(&v.begin.to_be_bytes());
            }
        }
        b
    }

    /// Decode a header from the start of a file; returns it and `numrecs`.
    ///
    /// # Errors
    /// What is wrong, in words (the caller adds the path).
    pub(crate) fn decode(bytes: &[u8]) -> Result<(Schema, u32), String> {
        let mut r = Reader { b: bytes, at: 0 };
        let magic = r.take(4)?;
        if magic != MAGIC {
            return Err(if magic.starts_with(b"CDF") {
                format!(
                    "it is a netCDF file of version {}, not the 64-bit offset format (2)",
                    magic[3]
                )
            } else {
                "it is not a netCDF-3 file (no `CDF` magic)".into()
            });
        }
        let numrecs = r.u32()?;
        let mut s = Schema::default();
        let (tag, n) = (r.u32()?, r.u32()?);
        if tag != NC_DIMENSION && !(tag == 0 && n == 0) {
            return Err(format!("bad dimension list tag {tag:#x}"));
        }
        for _ in 0..n {
            let name = r.name()?;
            let len = u64::from(r.u32()?);
            s.dims.push(Dim { name, len });
        }
        s.attrs = r.attrs()?;
        let (tag, n) = (r.u32()?, r.u32()?);
        if tag != NC_VARIABLE && !(tag == 0 && n == 0) {
            return Err(format!("bad variable list tag {tag:#x}"));
        }
        for _ in 0..n {
            let name = r.name()?;
            let nd = r.u32()? as usize;
            if nd > 1024 {
                return Err(format!("variable `{name}` has {nd} dimensions"));
            }
            let mut dims = Vec::with_capacity(nd);
            for _ in 0..nd {
                let d = r.u32()? as usize;
                if d >= s.dims.len() {
                    return Err(format!("variable `{name}` names dimension {d}"));
                }
                dims.push(d);
            }
            let attrs = r.attrs()?;
            let code = r.u32()?;
            let ty = NcType::from_code(code)
                .ok_or_else(|| format!("variable `{name}` has type {code}, not read here"))?;
            let vsize = u64::from(r.u32()?);
            let begin = u64::from_be_bytes(r.take(8)?.try_into().unwrap_or([0; 8]));
            s.vars.push(Var {
                name,
                dims,
                attrs,
                ty,
                vsize,
                begin,
            });
        }
        let mut fixed_end = r.at as u64;
        let records = (0..s.vars.len()).filter(|&v| s.is_record(v)).count();
        for v in 0..s.vars.len() {
            let size = s.values(v) * s.vars[v].ty.size();
            if s.is_record(v) {
                s.record_size += if records == 1 { size } else { pad4(size) };
            } else {
                fixed_end = fixed_end.max(s.vars[v].begin + pad4(size));
            }
        }
        s.records_begin = (0..s.vars.len())
            .filter(|&v| s.is_record(v))
            .map(|v| s.vars[v].begin)
            .min()
            .unwrap_or(fixed_end);
        Ok((s, numrecs))
    }
}

fn put_u32(b: &mut Vec<u8>, x: u32) {
    b.extend_from_slice(&x.to_be_bytes());
}

fn pad(b: &mut Vec<u8>) {
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
}

fn put_name(b: &mut Vec<u8>, name: &str) {
    put_u32(b, name.len() as u32);
    b.extend_from_slice(name.as_bytes());
    pad(b);
}

fn put_attrs(b: &mut Vec<u8>, attrs: &[Attr]) {
    if attrs.is_empty() {
        b.extend_from_slice(&[0; 8]);
        return;
    }
    put_u32(b, NC_ATTRIBUTE);
    put_u32(b, attrs.len() as u32);
    for a in attrs {
        put_name(b, &a.name);
        match &a.value {
            AttrValue::Text(t) => {
                put_u32(b, NcType::Char.code());
                put_u32(b, t.len() as u32);
                b.extend_from_slice(t.as_bytes());
            }
            AttrValue::Int(v) => {
                put_u32(b, NcType::Int.code());
                put_u32(b, v.len() as u32);
                v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()));
            }
            AttrValue::Float(v) => {
                put_u32(b, NcType::Float.code());
                put_u32(b, v.len() as u32);
                v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()));
            }
            AttrValue::Double(v) => {
                put_u32(b, NcType::Double.code());
                put_u32(b, v.len() as u32);
                v.iter().for_each(|x| b.extend_from_slice(&x.to_be_bytes()));
            }
        }
        pad(b);
    }
}

/// A cursor over header bytes.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.b.len())
            .ok_or_else(|| format!("the header ends early (at byte {})", self.b.len()))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_be_bytes(
            self.take(4)?.try_into().unwrap_or([0; 4]),
        ))
    }

    fn skip_pad(&mut self) -> Result<(), String> {
        let p = (4 - self.at % 4) % 4;
        self.take(p).map(drop)
    }

    fn name(&mut self) -> Result<String, String> {
        let n = self.u32()? as usize;
        let s = String::from_utf8_lossy(self.take(n)?).into_owned();
        self.skip_pad()?;
        Ok(s)
    }

    fn attrs(&mut self) -> Result<Vec<Attr>, String> {
        let (tag, n) = (self.u32()?, self.u32()?);
        if tag != NC_ATTRIBUTE && !(tag == 0 && n == 0) {
            return Err(format!("bad attribute list tag {tag:#x}"));
        }
        let mut out = Vec::new();
        for _ in 0..n {
            let name = self.name()?;
            let code = self.u32()?;
            let k = self.u32()? as usize;
            let value = match code {
                1 | 2 => {
                    let t = String::from_utf8_lossy(self.take(k)?).into_owned();
                    AttrValue::Text(t.trim_end_matches('\0').to_string())
                }
                3 => {
                    let v = self.take(k.saturating_mul(2))?;
                    AttrValue::Int(
                        v.chunks_exact(2)
                            .map(|c| i32::from(i16::from_be_bytes([c[0], c[1]])))
                            .collect(),
                    )
                }
                4 => AttrValue::Int(
                    self.take(k.saturating_mul(4))?
                        .chunks_exact(4)
                        .map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                5 => AttrValue::Float(
                    self.take(k.saturating_mul(4))?
                        .chunks_exact(4)
                        .map(|c| f32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                6 => AttrValue::Double(
                    self.take(k.saturating_mul(8))?
                        .chunks_exact(8)
                        .map(|c| f64::from_be_bytes(c.try_into().unwrap_or([0; 8])))
                        .collect(),
                ),
                _ => return Err(format!("attribute `{name}` has type {code}")),
            };
            self.skip_pad()?;
            out.push(Attr { name, value });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_round_trips_and_layout_is_padded() {
        let mut s = Schema::default();
        let t = s.dim("time_step", 0);
        let n = s.dim("num_nodes", 3);
        let l = s.dim("len_name", 5);
        s.attr("title", AttrValue::Text("abc".into()));
        s.attr("version", AttrValue::Float(vec![8.25]));
        let name = s.var("name", NcType::Char, &[l]);
        let x = s.var("x", NcType::Double, &[n]);
        let time = s.var("time_whole", NcType::Double, &[t]);
        let vals = s.var("vals", NcType::Double, &[t, n]);
        s.vars[x].attrs.push(Attr {
            name: "units".into(),
            value: AttrValue::Text("m".into()),
        });
        s.finish();
        let h = s.encode(7);
        assert_eq!(h.len() % 4, 0);
        assert_eq!(s.vars[name].begin, h.len() as u64);
        assert_eq!(s.vars[name].vsize, 8); // 5 chars padded to 8
        assert_eq!(s.vars[x].begin, s.vars[name].begin + 8);
        assert_eq!(s.records_begin, s.vars[x].begin + 24);
        assert_eq!(s.record_size, 8 + 24);
        assert_eq!(s.offset(vals, 2, 1), s.records_begin + 2 * 32 + 8 + 8);
        assert_eq!(s.offset(time, 1, 0), s.records_begin + 32);
        let (d, numrecs) = Schema::decode(&h).unwrap();
        assert_eq!(numrecs, 7);
        assert_eq!(d, s);
    }

    #[test]
    fn bad_headers_are_refused_in_words() {
        assert!(Schema::decode(b"HDF5")
            .unwrap_err()
            .contains("not a netCDF"));
        assert!(Schema::decode(b"CDF\x01\0\0\0\0")
            .unwrap_err()
            .contains("version 1"));
        assert!(Schema::decode(b"CDF\x02\0\0")
            .unwrap_err()
            .contains("ends early"));
    }
}
