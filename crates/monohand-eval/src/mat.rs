//! A minimal reader (and writer) for MATLAB v5 `.mat` files.
//!
//! Supported: the 128-byte header (either byte order), data-element tags in
//! both the normal and the *small data element* format, `miCOMPRESSED`
//! elements (zlib, as written by MATLAB `-v7`, the default), and `miMATRIX`
//! elements of the numeric classes (double, single, and 8- to 64-bit signed
//! and unsigned integers, logical included). Numbers are converted to `f64`
//! whatever their storage type. Complex arrays are returned with their real
//! part only ([`MatArray::complex`] says so).
//!
//! Not supported (skipped, their names listed in [`MatFile::unsupported`]):
//! cell arrays, structs, objects, sparse and char arrays. MATLAB v7.3 files are
//! HDF5 and are rejected with an explicit message.
//!
//! Arrays keep MATLAB's **column-major** layout: element `(i0, i1, i2, ...)` of
//! an array with dimensions `(d0, d1, d2, ...)` is at
//! `i0 + d0 * (i1 + d1 * (i2 + ...))`; [`MatArray::get`] does the arithmetic.
//!
//! ```
//! use monohand_eval::mat::{MatArray, MatFile};
//! let a = MatArray::new("handPara", vec![3, 2], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
//! let bytes = monohand_eval::mat::to_bytes(&[a]);
//! let file = MatFile::from_bytes(&bytes, "<memory>").unwrap();
//! let back = file.require("handPara").unwrap();
//! assert_eq!(back.dims, vec![3, 2]);
//! assert_eq!(back.get(&[2, 1]), Some(6.0)); // row 2, column 1
//! ```

use monohand_io::error::{name_of, read_bytes};
use monohand_io::{IoError, IoResult};
use std::io::Read;
use std::path::Path;

/// Largest decompressed size accepted for a file's `miCOMPRESSED` elements, all
/// together, nested ones included (a guard against corrupt or malicious input: a
/// few kilobytes of zlib can inflate to gigabytes). 256 MiB; STB's label files
/// inflate to under 1 MiB.
pub const MAX_DECOMPRESSED_BYTES: u64 = 1 << 28;

const HEADER_LEN: usize = 128;
const MAX_DEPTH: usize = 8;

// Data types (miXXX).
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

/// The MATLAB class of an array (`mxXXX_CLASS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatClass {
    /// `double`.
    Double,
    /// `single`.
    Single,
    /// `int8`.
    Int8,
    /// `uint8` (also `logical`, see [`MatArray::logical`]).
    Uint8,
    /// `int16`.
    Int16,
    /// `uint16`.
    Uint16,
    /// `int32`.
    Int32,
    /// `uint32`.
    Uint32,
    /// `int64`.
    Int64,
    /// `uint64`.
    Uint64,
}

impl MatClass {
    fn from_code(code: u8) -> Option<MatClass> {
        Some(match code {
            6 => MatClass::Double,
            7 => MatClass::Single,
            8 => MatClass::Int8,
            9 => MatClass::Uint8,
            10 => MatClass::Int16,
            11 => MatClass::Uint16,
            12 => MatClass::Int32,
            13 => MatClass::Uint32,
            14 => MatClass::Int64,
            15 => MatClass::Uint64,
            _ => return None,
        })
    }
}

fn class_name(code: u8) -> &'static str {
    match code {
        1 => "cell",
        2 => "struct",
        3 => "object",
        4 => "char",
        5 => "sparse",
        6..=15 => "numeric",
        16 => "function handle",
        17 => "opaque object",
        _ => "unknown",
    }
}

/// One named numeric array, converted to `f64`, in column-major order.
#[derive(Debug, Clone, PartialEq)]
pub struct MatArray {
    /// The variable name.
    pub name: String,
    /// Dimensions (at least two, as MATLAB stores them).
    pub dims: Vec<usize>,
    /// The (real parts of the) values, column-major, `dims.iter().product()` of them.
    pub data: Vec<f64>,
    /// The MATLAB class the values were stored as.
    pub class: MatClass,
    /// True if the array was complex (only its real part is in [`MatArray::data`]).
    pub complex: bool,
    /// True if the array was a MATLAB `logical`.
    pub logical: bool,
}

impl MatArray {
    /// A `double` array; fails if `data.len()` is not the product of `dims`.
    pub fn new(name: &str, dims: Vec<usize>, data: Vec<f64>) -> IoResult<MatArray> {
        let n = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
        if n != Some(data.len()) {
            return Err(IoError::field(
                "<memory>",
                name,
                format!("dimensions {dims:?} do not match {} values", data.len()),
            ));
        }
        Ok(MatArray {
            name: name.to_string(),
            dims,
            data,
            class: MatClass::Double,
            complex: false,
            logical: false,
        })
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True if the array has no elements.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Column-major linear index of a multi-index; missing trailing indices are
    /// 0, extra ones must be 0. `None` if out of range.
    pub fn linear_index(&self, idx: &[usize]) -> Option<usize> {
        let mut lin = 0usize;
        let mut stride = 1usize;
        for (k, &i) in idx.iter().enumerate() {
            let d = self.dims.get(k).copied().unwrap_or(1);
            if i >= d {
                return None;
            }
            lin += i * stride;
            stride *= d;
        }
        (lin < self.data.len()).then_some(lin)
    }

    /// The element at a multi-index (column-major), `None` if out of range.
    pub fn get(&self, idx: &[usize]) -> Option<f64> {
        self.linear_index(idx).map(|i| self.data[i])
    }
}

/// The numeric arrays of a `.mat` file.
#[derive(Debug, Clone, PartialEq)]
pub struct MatFile {
    /// The descriptive text of the header (trailing blanks removed).
    pub header_text: String,
    /// The numeric arrays, in file order.
    pub arrays: Vec<MatArray>,
    /// Names and kinds of the variables that were skipped (cells, structs, ...).
    pub unsupported: Vec<(String, &'static str)>,
}

impl MatFile {
    /// Reads a `.mat` file.
    pub fn open(path: impl AsRef<Path>) -> IoResult<MatFile> {
        let path = path.as_ref();
        let bytes = read_bytes(path)?;
        MatFile::from_bytes(&bytes, &name_of(path))
    }

    /// Parses the bytes of a `.mat` file; `file` is the name used in errors.
    pub fn from_bytes(bytes: &[u8], file: &str) -> IoResult<MatFile> {
        MatFile::parse(bytes, file, MAX_DECOMPRESSED_BYTES)
    }

    /// [`MatFile::from_bytes`] with compressed elements allowed to inflate to
    /// `inflate_budget` bytes in all.
    fn parse(bytes: &[u8], file: &str, inflate_budget: u64) -> IoResult<MatFile> {
        if bytes.len() < HEADER_LEN {
            return Err(IoError::format(
                file,
                format!(
                    "not a MATLAB v5 .mat file: {} bytes, shorter than the 128-byte header",
                    bytes.len()
                ),
            ));
        }
        let text = String::from_utf8_lossy(&bytes[..116])
            .trim_end_matches(['\0', ' '])
            .to_string();
        if bytes.starts_with(b"MATLAB 7.3") || bytes[..8] == *b"\x89HDF\r\n\x1a\n" {
            return Err(IoError::format(
                file,
                "MATLAB v7.3 (HDF5) files are not supported; re-save with save(..., '-v7')",
            ));
        }
        let big = match &bytes[126..128] {
            b"IM" => false,
            b"MI" => true,
            other => {
                return Err(IoError::format(
                    file,
                    format!(
                    "not a MATLAB v5 .mat file: endian indicator {:?} is neither \"IM\" nor \"MI\"",
                    String::from_utf8_lossy(other)
                ),
                ))
            }
        };
        if !text.starts_with("MATLAB") {
            return Err(IoError::format(
                file,
                "not a MATLAB v5 .mat file: header text does not start with \"MATLAB\"",
            ));
        }
        let mut out = MatFile {
            header_text: text,
            arrays: Vec::new(),
            unsupported: Vec::new(),
        };
        let p = Parser {
            file,
            big,
            inflate_budget: std::cell::Cell::new(inflate_budget),
            inflate_limit: inflate_budget,
        };
        p.parse_top(&bytes[HEADER_LEN..], HEADER_LEN, &mut out, 0)?;
        Ok(out)
    }

    /// The array with this name, if any.
    pub fn get(&self, name: &str) -> Option<&MatArray> {
        self.arrays.iter().find(|a| a.name == name)
    }

    /// The array with this name, or an error naming the variable (and saying if
    /// it exists with an unsupported type).
    pub fn require(&self, name: &str) -> IoResult<&MatArray> {
        if let Some(a) = self.get(name) {
            return Ok(a);
        }
        let file = "the .mat file";
        if let Some((_, kind)) = self.unsupported.iter().find(|(n, _)| n == name) {
            return Err(IoError::field(
                file,
                name,
                format!("is a {kind} array; only numeric arrays are supported"),
            ));
        }
        let names: Vec<&str> = self.arrays.iter().map(|a| a.name.as_str()).collect();
        Err(IoError::field(
            file,
            name,
            format!("no such variable (numeric variables present: {names:?})"),
        ))
    }
}

/// One data element: its type and its payload.
struct Element<'a> {
    ty: u32,
    data: &'a [u8],
    /// Offset of the element that follows, relative to the buffer parsed.
    next: usize,
}

struct Parser<'f> {
    file: &'f str,
    big: bool,
    /// Bytes that compressed elements may still inflate to.
    inflate_budget: std::cell::Cell<u64>,
    /// The budget at the start, for messages.
    inflate_limit: u64,
}

impl Parser<'_> {
    fn u32_at(&self, b: &[u8], off: usize) -> Option<u32> {
        let s: [u8; 4] = b.get(off..off + 4)?.try_into().ok()?;
        Some(if self.big {
            u32::from_be_bytes(s)
        } else {
            u32::from_le_bytes(s)
        })
    }

    fn err(&self, offset: usize, msg: impl std::fmt::Display) -> IoError {
        IoError::format(self.file, format!("at byte {offset}: {msg}"))
    }

    /// Reads the element starting at `pos` of `b`; `base` is `b`'s offset in
    /// the file (for messages).
    fn element<'a>(&self, b: &'a [u8], pos: usize, base: usize) -> IoResult<Element<'a>> {
        let w0 = self
            .u32_at(b, pos)
            .ok_or_else(|| self.err(base + pos, "truncated data-element tag"))?;
        if w0 >> 16 != 0 {
            // Small data element: 2 bytes size, 2 bytes type, 4 bytes data.
            let n = (w0 >> 16) as usize;
            let ty = w0 & 0xffff;
            if n > 4 {
                return Err(self.err(
                    base + pos,
                    format!("small data element claims {n} bytes (at most 4)"),
                ));
            }
            let data = b
                .get(pos + 4..pos + 4 + n)
                .ok_or_else(|| self.err(base + pos, "truncated small data element"))?;
            return Ok(Element {
                ty,
                data,
                next: (pos + 8).min(b.len()),
            });
        }
        let n = self
            .u32_at(b, pos + 4)
            .ok_or_else(|| self.err(base + pos, "truncated data-element tag"))?
            as usize;
        let start = pos + 8;
        let data = start
            .checked_add(n)
            .and_then(|end| b.get(start..end))
            .ok_or_else(|| {
                self.err(
                    base + pos,
                    format!(
                        "data element of type {w0} claims {n} bytes but only {} remain (file truncated?)",
                        b.len().saturating_sub(start)
                    ),
                )
            })?;
        let padded = if w0 == MI_COMPRESSED {
            n
        } else {
            n.div_ceil(8) * 8
        };
        Ok(Element {
            ty: w0,
            data,
            next: (start + padded).min(b.len()),
        })
    }

    fn parse_top(&self, b: &[u8], base: usize, out: &mut MatFile, depth: usize) -> IoResult<()> {
        if depth > MAX_DEPTH {
            return Err(self.err(base, "compressed elements nested too deeply"));
        }
        let mut pos = 0;
        while pos < b.len() {
            // Trailing zero padding at the end of a file is harmless.
            if b[pos..].iter().all(|&x| x == 0) {
                break;
            }
            let el = self.element(b, pos, base)?;
            match el.ty {
                MI_COMPRESSED => {
                    let mut inflated = Vec::new();
                    let budget = self.inflate_budget.get();
                    // One byte more than the budget tells an over-large element apart.
                    flate2::read::ZlibDecoder::new(el.data)
                        .take(budget + 1)
                        .read_to_end(&mut inflated)
                        .map_err(|e| {
                            self.err(base + pos, format!("cannot decompress element: {e}"))
                        })?;
                    let used = inflated.len() as u64;
                    if used > budget {
                        return Err(self.err(
                            base + pos,
                            format!(
                                "compressed data inflates to more than the limit of \
                                 {} bytes (MAX_DECOMPRESSED_BYTES)",
                                self.inflate_limit
                            ),
                        ));
                    }
                    self.inflate_budget.set(budget - used);
                    self.parse_top(&inflated, base + pos, out, depth + 1)?;
                }
                MI_MATRIX => self.matrix(el.data, base + pos + 8, out)?,
                _ => {} // Not a variable (should not occur at top level): ignore.
            }
            pos = el.next;
        }
        Ok(())
    }

    fn matrix(&self, b: &[u8], base: usize, out: &mut MatFile) -> IoResult<()> {
        if b.is_empty() {
            return Ok(()); // An empty miMATRIX: nothing stored.
        }
        let flags = self.element(b, 0, base)?;
        if flags.ty != MI_UINT32 || flags.data.len() < 8 {
            return Err(self.err(base, "array flags must be 8 bytes of miUINT32"));
        }
        let f0 = self.u32_at(flags.data, 0).unwrap_or(0);
        let class_code = (f0 & 0xff) as u8;
        let complex = f0 & 0x0800 != 0;
        let logical = f0 & 0x0200 != 0;

        let dims_el = self.element(b, flags.next, base)?;
        if dims_el.ty != MI_INT32 || dims_el.data.len() % 4 != 0 {
            return Err(self.err(base + flags.next, "dimensions must be miINT32"));
        }
        let mut dims = Vec::with_capacity(dims_el.data.len() / 4);
        for k in 0..dims_el.data.len() / 4 {
            let d = self.u32_at(dims_el.data, 4 * k).unwrap_or(0) as i32;
            if d < 0 {
                return Err(self.err(base + flags.next, format!("negative dimension {d}")));
            }
            dims.push(d as usize);
        }
        let name_el = self.element(b, dims_el.next, base)?;
        let name = String::from_utf8_lossy(name_el.data)
            .trim_end_matches('\0')
            .to_string();
        let Some(class) = MatClass::from_code(class_code) else {
            out.unsupported.push((name, class_name(class_code)));
            return Ok(());
        };
        let count = dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .ok_or_else(|| self.err(base, format!("variable {name}: dimensions overflow")))?;
        let data = if count == 0 {
            Vec::new()
        } else {
            let real = self.element(b, name_el.next, base)?;
            self.numbers(&real, base + name_el.next, &name, count)?
        };
        out.arrays.push(MatArray {
            name,
            dims,
            data,
            class,
            complex,
            logical,
        });
        Ok(())
    }

    fn numbers(&self, el: &Element, off: usize, name: &str, count: usize) -> IoResult<Vec<f64>> {
        let size = match el.ty {
            MI_INT8 | MI_UINT8 => 1,
            MI_INT16 | MI_UINT16 => 2,
            MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
            MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
            other => {
                return Err(self.err(
                    off,
                    format!("variable {name}: unsupported numeric storage type {other}"),
                ))
            }
        };
        // `count` fits in usize but `count * size` may not (dimensions forged to ~2^31 each).
        if count.checked_mul(size) != Some(el.data.len()) {
            return Err(self.err(
                off,
                format!(
                    "variable {name}: {} bytes of data for {count} elements of {size} bytes",
                    el.data.len()
                ),
            ));
        }
        let big = self.big;
        let conv = |c: &[u8]| -> f64 {
            macro_rules! get {
                ($t:ty, $n:literal) => {{
                    let mut a = [0u8; $n];
                    a.copy_from_slice(c);
                    if big {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    }
                }};
            }
            match el.ty {
                MI_INT8 => c[0] as i8 as f64,
                MI_UINT8 => c[0] as f64,
                MI_INT16 => get!(i16, 2) as f64,
                MI_UINT16 => get!(u16, 2) as f64,
                MI_INT32 => get!(i32, 4) as f64,
                MI_UINT32 => get!(u32, 4) as f64,
                MI_SINGLE => get!(f32, 4) as f64,
                MI_DOUBLE => get!(f64, 8),
                MI_INT64 => get!(i64, 8) as f64,
                _ => get!(u64, 8) as f64,
            }
        };
        Ok(el.data.chunks_exact(size).map(conv).collect())
    }
}

fn push_tag(out: &mut Vec<u8>, ty: u32, data: &[u8]) {
    out.extend_from_slice(&ty.to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    while !out.len().is_multiple_of(8) {
        out.push(0);
    }
}

/// Serialises `double` arrays as an uncompressed little-endian MATLAB v5 file
/// (readable by MATLAB, SciPy and [`MatFile::from_bytes`]). Class, complex and
/// logical flags of the arrays are ignored: everything is written as real `double`.
pub fn to_bytes(arrays: &[MatArray]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut header = format!(
        "MATLAB 5.0 MAT-file, Platform: {}, Created by: monohand-io",
        std::env::consts::OS
    )
    .into_bytes();
    header.resize(116, b' ');
    out.extend_from_slice(&header);
    out.extend_from_slice(&[0u8; 8]); // subsystem data offset
    out.extend_from_slice(&0x0100u16.to_le_bytes());
    out.extend_from_slice(b"IM");
    for a in arrays {
        let mut m = Vec::new();
        let mut flags = [0u8; 8];
        flags[0] = 6; // mxDOUBLE_CLASS
        push_tag(&mut m, MI_UINT32, &flags);
        let mut dims: Vec<u8> = Vec::new();
        let mut d = a.dims.clone();
        while d.len() < 2 {
            d.push(1);
        }
        for x in d {
            dims.extend_from_slice(&(x as i32).to_le_bytes());
        }
        push_tag(&mut m, MI_INT32, &dims);
        push_tag(&mut m, MI_INT8, a.name.as_bytes());
        let mut real = Vec::with_capacity(8 * a.data.len());
        for v in &a.data {
            real.extend_from_slice(&v.to_le_bytes());
        }
        push_tag(&mut m, MI_DOUBLE, &real);
        push_tag(&mut out, MI_MATRIX, &m);
    }
    out
}

/// Writes `double` arrays to a `.mat` file (see [`to_bytes`]).
pub fn write_mat(path: impl AsRef<Path>, arrays: &[MatArray]) -> IoResult<()> {
    let path = path.as_ref();
    std::fs::write(path, to_bytes(arrays)).map_err(|source| IoError::Write {
        path: path.to_path_buf(),
        error: source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use std::io::Write;

    fn header(endian: &[u8; 2]) -> Vec<u8> {
        let mut h = b"MATLAB 5.0 MAT-file, test".to_vec();
        h.resize(116, b' ');
        h.extend_from_slice(&[0; 8]);
        h.extend_from_slice(&[0, 1]);
        h.extend_from_slice(endian);
        h
    }

    fn small(ty: u32, data: &[u8]) -> Vec<u8> {
        assert!(data.len() <= 4);
        let mut v = (((data.len() as u32) << 16) | ty).to_le_bytes().to_vec();
        v.extend_from_slice(data);
        v.resize(8, 0);
        v
    }

    fn tag(ty: u32, data: &[u8]) -> Vec<u8> {
        let mut v = Vec::new();
        push_tag(&mut v, ty, data);
        v
    }

    /// A miMATRIX element of the given class, with a small-format name.
    fn matrix(class: u8, dims: &[i32], name: &str, real: Vec<u8>) -> Vec<u8> {
        let mut m = tag(MI_UINT32, &[class, 0, 0, 0, 0, 0, 0, 0]);
        let d: Vec<u8> = dims.iter().flat_map(|x| x.to_le_bytes()).collect();
        m.extend(tag(MI_INT32, &d));
        if name.len() <= 4 {
            m.extend(small(MI_INT8, name.as_bytes()));
        } else {
            m.extend(tag(MI_INT8, name.as_bytes()));
        }
        m.extend(real);
        tag(MI_MATRIX, &m)
    }

    fn compressed(el: &[u8]) -> Vec<u8> {
        let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(el).unwrap();
        let c = z.finish().unwrap();
        let mut v = MI_COMPRESSED.to_le_bytes().to_vec();
        v.extend_from_slice(&(c.len() as u32).to_le_bytes());
        v.extend(c);
        v
    }

    /// Found while writing the fuzz harness: dimensions forged to 2^31 - 1 each make
    /// `elements x element size` overflow (a panic with overflow checks).
    #[test]
    fn forged_dimensions_are_an_error() {
        let mut f = header(b"IM");
        f.extend(matrix(
            6,
            &[i32::MAX, i32::MAX],
            "x",
            tag(MI_DOUBLE, &[0; 8]),
        ));
        let e = MatFile::from_bytes(&f, "t").unwrap_err().to_string();
        assert!(e.contains("bytes of data for"), "{e}");
    }

    /// Compressed elements share one inflation budget: before, each (nested ones
    /// included, 8 levels) could inflate to 2 GiB, silently truncated.
    #[test]
    fn inflation_is_bounded_for_the_whole_file() {
        let x = matrix(6, &[1, 250], "x", tag(MI_DOUBLE, &[0; 2000]));
        let mut one = header(b"IM");
        one.extend(compressed(&x));
        assert!(MatFile::parse(&one, "t", 4096).is_ok());
        let e = MatFile::parse(&one, "t", 1000).unwrap_err().to_string();
        assert!(e.contains("more than the limit of 1000 bytes"), "{e}");
        // Two elements of ~2 kB each: under the budget one at a time, not together.
        let mut two = header(b"IM");
        two.extend(compressed(&x));
        two.extend(compressed(&x));
        assert!(MatFile::parse(&two, "t", 8192).is_ok());
        assert!(MatFile::parse(&two, "t", 4096).is_err());
        // Nested: the outer inflation counts as well as the inner one.
        let mut nested = header(b"IM");
        nested.extend(compressed(&compressed(&x)));
        let inner = compressed(&x).len() as u64;
        assert!(MatFile::parse(&nested, "t", x.len() as u64 + inner).is_ok());
        assert!(MatFile::parse(&nested, "t", x.len() as u64 + inner - 1).is_err());
        assert_eq!(MAX_DECOMPRESSED_BYTES, 256 << 20);
    }

    #[test]
    fn round_trip_doubles() {
        let a = MatArray::new(
            "x",
            vec![2, 3, 2],
            (0..12).map(|i| i as f64 * 0.5).collect(),
        )
        .unwrap();
        let f = MatFile::from_bytes(&to_bytes(std::slice::from_ref(&a)), "t").unwrap();
        assert_eq!(f.arrays, vec![a.clone()]);
        // (1, 2, 1) -> 1 + 2*2 + 6*1 = 11
        assert_eq!(f.require("x").unwrap().get(&[1, 2, 1]), Some(5.5));
        assert_eq!(a.get(&[2, 0, 0]), None);
        assert!(f.require("y").is_err());
    }

    #[test]
    fn compressed_small_elements_and_integer_types() {
        let mut file = header(b"IM");
        // int16 class stored as miINT16 with the small format for the 3x1 int8 array.
        let i16s: Vec<u8> = [-3i16, 7, 300]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        file.extend(compressed(&matrix(
            10,
            &[3, 1],
            "ints",
            tag(MI_INT16, &i16s),
        )));
        // A double array stored as miUINT8 (MATLAB does this when values fit).
        file.extend(compressed(&matrix(
            6,
            &[1, 3],
            "bytes",
            small(MI_UINT8, &[1, 2, 250]),
        )));
        // A single-precision array, uncompressed, long name.
        let f32s: Vec<u8> = [1.5f32, -2.25]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        file.extend(matrix(7, &[2, 1], "singles", tag(MI_SINGLE, &f32s)));
        // A cell array (class 1): skipped and reported.
        file.extend(matrix(1, &[0, 0], "c", Vec::new()));
        let f = MatFile::from_bytes(&file, "t.mat").unwrap();
        assert_eq!(f.require("ints").unwrap().data, vec![-3.0, 7.0, 300.0]);
        assert_eq!(f.require("ints").unwrap().class, MatClass::Int16);
        assert_eq!(f.require("bytes").unwrap().data, vec![1.0, 2.0, 250.0]);
        assert_eq!(f.require("singles").unwrap().data, vec![1.5, -2.25]);
        assert_eq!(f.unsupported, vec![("c".to_string(), "cell")]);
        let e = f.require("c").unwrap_err().to_string();
        assert!(e.contains("cell"), "{e}");
    }

    #[test]
    fn big_endian_file() {
        let mut file = header(b"MI");
        let mut m = Vec::new();
        let be_tag = |ty: u32, d: &[u8]| {
            let mut v = ty.to_be_bytes().to_vec();
            v.extend_from_slice(&(d.len() as u32).to_be_bytes());
            v.extend_from_slice(d);
            while !v.len().is_multiple_of(8) {
                v.push(0);
            }
            v
        };
        m.extend(be_tag(MI_UINT32, &[0, 0, 0, 6, 0, 0, 0, 0]));
        m.extend(be_tag(MI_INT32, &[0, 0, 0, 1, 0, 0, 0, 2]));
        m.extend(be_tag(MI_INT8, b"b"));
        let d: Vec<u8> = [3.25f64, -1.0]
            .iter()
            .flat_map(|x| x.to_be_bytes())
            .collect();
        m.extend(be_tag(MI_DOUBLE, &d));
        file.extend(be_tag(MI_MATRIX, &m));
        let f = MatFile::from_bytes(&file, "be.mat").unwrap();
        assert_eq!(f.require("b").unwrap().data, vec![3.25, -1.0]);
        assert_eq!(f.require("b").unwrap().dims, vec![1, 2]);
    }

    #[test]
    fn bad_files_are_errors_not_panics() {
        assert!(MatFile::from_bytes(b"short", "s.mat")
            .unwrap_err()
            .to_string()
            .contains("s.mat"));
        let mut bad = header(b"XX");
        assert!(MatFile::from_bytes(&bad, "x.mat").is_err());
        bad = header(b"IM");
        let good = to_bytes(&[MatArray::new("x", vec![4, 4], vec![1.0; 16]).unwrap()]);
        // Every truncation of a valid file is an error (or parses fewer arrays), never a panic.
        for cut in HEADER_LEN..good.len() {
            let r = MatFile::from_bytes(&good[..cut], "cut.mat");
            if let Ok(f) = r {
                assert!(f.arrays.is_empty());
            }
        }
        // Garbage after the header.
        bad.extend_from_slice(&[0xff; 40]);
        assert!(MatFile::from_bytes(&bad, "g.mat").is_err());
        // Corrupt zlib stream.
        let mut z = header(b"IM");
        z.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
        z.extend_from_slice(&8u32.to_le_bytes());
        z.extend_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        let e = MatFile::from_bytes(&z, "z.mat").unwrap_err().to_string();
        assert!(e.contains("z.mat") && e.contains("decompress"), "{e}");
        // Missing file.
        let e = MatFile::open("/nonexistent/dir/none.mat")
            .unwrap_err()
            .to_string();
        assert!(e.contains("none.mat"), "{e}");
    }
}
