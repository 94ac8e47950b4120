//! VTK legacy POLYDATA: the reader and the writer. What each reads and
//! writes is described on `VtkReader` and `VtkWriter`.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::spool::Spool;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, Format, IoError, Metadata};

/// Longest keyword, number or name token; binary garbage fails fast.
const MAX_TOKEN: usize = 1024;
/// Longest raw text line (header lines, METADATA blocks).
const MAX_LINE: usize = 1 << 16;
/// Largest number of components an attribute array may announce.
const MAX_COMPONENTS: u64 = 1024;

// ---------------------------------------------------------------------------
// Data types

/// The numeric VTK data types; all are read as big-endian in BINARY files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum DType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

/// What a type name in the file stands for.
#[derive(Debug, PartialEq, Eq)]
enum TypeName {
    Num(DType),
    /// A VTK type this reader cannot size without decoding (`bit`,
    /// `string`, `utf8_string`, `variant`).
    Unsupported,
    Unknown,
}

impl DType {
    fn parse(name: &[u8]) -> TypeName {
        let n = String::from_utf8_lossy(name).to_ascii_lowercase();
        TypeName::Num(match n.as_str() {
            "char" | "signed_char" | "vtktypeint8" => DType::I8,
            "unsigned_char" | "vtktypeuint8" => DType::U8,
            "short" | "vtktypeint16" => DType::I16,
            "unsigned_short" | "vtktypeuint16" => DType::U16,
            // Legacy files write vtkIdType as 32-bit int.
            "int" | "vtkidtype" | "vtktypeint32" => DType::I32,
            "unsigned_int" | "vtktypeuint32" => DType::U32,
            // `long` is 8 bytes in BINARY files written on LP64 systems (what
            // VTK on Linux and macOS reads); VTK no longer writes it.
            "long" | "vtktypeint64" => DType::I64,
            "unsigned_long" | "vtktypeuint64" => DType::U64,
            "float" | "vtktypefloat32" => DType::F32,
            "double" | "vtktypefloat64" => DType::F64,
            "bit" | "string" | "utf8_string" | "variant" => return TypeName::Unsupported,
            _ => return TypeName::Unknown,
        })
    }

    /// The name this writer uses (what VTK itself writes).
    fn vtk_name(self) -> &'static str {
        match self {
            DType::I8 => "char",
            DType::U8 => "unsigned_char",
            DType::I16 => "short",
            DType::U16 => "unsigned_short",
            DType::I32 => "int",
            DType::U32 => "unsigned_int",
            DType::I64 => "vtktypeint64",
            DType::U64 => "vtktypeuint64",
            DType::F32 => "float",
            DType::F64 => "double",
        }
    }

    fn size(self) -> usize {
        match self {
            DType::I8 | DType::U8 => 1,
            DType::I16 | DType::U16 => 2,
            DType::I32 | DType::U32 | DType::F32 => 4,
            DType::I64 | DType::U64 | DType::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, DType::F32 | DType::F64)
    }

    /// Integer range, for choosing an output type that every value fits.
    fn int_range(self) -> Option<(f64, f64)> {
        Some(match self {
            DType::I8 => (i8::MIN as f64, i8::MAX as f64),
            DType::U8 => (0.0, u8::MAX as f64),
            DType::I16 => (i16::MIN as f64, i16::MAX as f64),
            DType::U16 => (0.0, u16::MAX as f64),
            DType::I32 => (i32::MIN as f64, i32::MAX as f64),
            DType::U32 => (0.0, u32::MAX as f64),
            // f32 values: the bounds only need to be below 2^63 / 2^64.
            DType::I64 => (-9.2e18, 9.2e18),
            DType::U64 => (0.0, 1.8e19),
            DType::F32 | DType::F64 => return None,
        })
    }

    /// A big-endian value as f64 (`b` is `size()` bytes).
    fn f64_be(self, b: &[u8]) -> f64 {
        match self {
            DType::I8 => be::<1>(b)[0] as i8 as f64,
            DType::U8 => be::<1>(b)[0] as f64,
            DType::I16 => i16::from_be_bytes(be(b)) as f64,
            DType::U16 => u16::from_be_bytes(be(b)) as f64,
            DType::I32 => i32::from_be_bytes(be(b)) as f64,
            DType::U32 => u32::from_be_bytes(be(b)) as f64,
            DType::I64 => i64::from_be_bytes(be(b)) as f64,
            DType::U64 => u64::from_be_bytes(be(b)) as f64,
            DType::F32 => f32::from_be_bytes(be(b)) as f64,
            DType::F64 => f64::from_be_bytes(be(b)),
        }
    }

    /// A big-endian value as f32, exactly for `float`.
    fn f32_be(self, b: &[u8]) -> f32 {
        match self {
            DType::F32 => f32::from_be_bytes(be(b)),
            _ => self.f64_be(b) as f32,
        }
    }

    /// A big-endian integer (an index or offset); `None` for float types and
    /// values beyond i64.
    fn int_be(self, b: &[u8]) -> Option<i64> {
        Some(match self {
            DType::I8 => be::<1>(b)[0] as i8 as i64,
            DType::U8 => be::<1>(b)[0] as i64,
            DType::I16 => i16::from_be_bytes(be(b)) as i64,
            DType::U16 => u16::from_be_bytes(be(b)) as i64,
            DType::I32 => i32::from_be_bytes(be(b)) as i64,
            DType::U32 => u32::from_be_bytes(be(b)) as i64,
            DType::I64 => i64::from_be_bytes(be(b)),
            DType::U64 => i64::try_from(u64::from_be_bytes(be(b))).ok()?,
            DType::F32 | DType::F64 => return None,
        })
    }

    /// `v` (known to fit) as big-endian bytes of this type.
    fn put_be(self, v: f32, out: &mut Vec<u8>) {
        let i = v as i64;
        match self {
            DType::I8 => out.push(i as i8 as u8),
            DType::U8 => out.push(i as u8),
            DType::I16 => out.extend_from_slice(&(i as i16).to_be_bytes()),
            DType::U16 => out.extend_from_slice(&(i as u16).to_be_bytes()),
            DType::I32 => out.extend_from_slice(&(i as i32).to_be_bytes()),
            DType::U32 => out.extend_from_slice(&(i as u32).to_be_bytes()),
            DType::I64 => out.extend_from_slice(&i.to_be_bytes()),
            DType::U64 => out.extend_from_slice(&(v as u64).to_be_bytes()),
            DType::F32 => out.extend_from_slice(&v.to_be_bytes()),
            DType::F64 => out.extend_from_slice(&(v as f64).to_be_bytes()),
        }
    }
}

/// The first `N` bytes of `b` (zero-padded; callers pass exactly `N`).
fn be<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0u8; N];
    let n = N.min(b.len());
    a[..n].copy_from_slice(&b[..n]);
    a
}

/// VTK's name decoding: `%XX` is the byte 0xXX (names cannot hold spaces).
fn decode_name(raw: &[u8]) -> String {
    let mut out = Vec::with_capacity(raw.len());
    let mut i = 0;
    while i < raw.len() {
        if raw[i] == b'%' && i + 2 < raw.len() {
            let hex = std::str::from_utf8(&raw[i + 1..i + 3]).ok();
            if let Some(b) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(b);
                i += 3;
                continue;
            }
        }
        out.push(raw[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// VTK's name encoding: whitespace, control bytes, `%`, `"` and non-ASCII
/// bytes as `%XX`, so that a name is one token.
fn encode_name(name: &str) -> String {
    if name.is_empty() {
        return "unnamed".into();
    }
    let mut out = String::with_capacity(name.len());
    for &b in name.as_bytes() {
        if b <= b' ' || b > b'~' || b == b'%' || b == b'"' {
            out.push_str(&format!("%{b:02X}"));
        } else {
            out.push(b as char);
        }
    }
    out
}

/// Shortest text that reads back to the same f32: plain decimals for the
/// usual magnitudes, exponent form for tiny and huge ones.
fn fmt_f32(v: f32, out: &mut String) {
    use std::fmt::Write as _;
    let a = v.abs();
    let _ = if a == 0.0 || (1e-5..1e9).contains(&a) || !a.is_finite() {
        write!(out, "{v}")
    } else {
        write!(out, "{v:e}")
    };
}

fn fmt_f64(v: f64, out: &mut String) {
    use std::fmt::Write as _;
    let a = v.abs();
    let _ = if a == 0.0 || (1e-5..1e15).contains(&a) || !a.is_finite() {
        write!(out, "{v}")
    } else {
        write!(out, "{v:e}")
    };
}

/// A token for messages: lossy, and cut short.
fn shown(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

// ---------------------------------------------------------------------------
// The byte/token source

/// A buffered file read as whitespace-separated tokens (keywords, ASCII
/// values) and raw bytes (BINARY payloads), knowing its byte offset and line.
struct Src {
    path: PathBuf,
    inner: BufReader<File>,
    pos: u64,
    len: u64,
    /// 1-based line of the current position (meaningful until the first
    /// binary payload).
    line: u64,
    binary: bool,
    tok: Vec<u8>,
    scratch: Vec<u8>,
}

impl Src {
    fn open(path: &Path) -> Result<Self, IoError> {
        let file = File::open(path).map_err(|e| IoError::os(path, "cannot open", e))?;
        let len = file
            .metadata()
            .map_err(|e| IoError::os(path, "cannot stat", e))?
            .len();
        Ok(Src {
            path: path.to_path_buf(),
            inner: BufReader::with_capacity(1 << 20, file),
            pos: 0,
            len,
            line: 1,
            binary: false,
            tok: Vec::new(),
            scratch: Vec::new(),
        })
    }

    /// Where we are: a line in ASCII files, a byte offset in BINARY ones.
    fn here(&self) -> String {
        if self.binary {
            format!("byte {}", self.pos)
        } else {
            format!("line {}", self.line)
        }
    }

    fn err(&self, reason: impl Into<String>) -> IoError {
        IoError::new(&self.path, reason).at(self.here())
    }

    fn os(&self, e: std::io::Error) -> IoError {
        IoError::os(&self.path, "cannot read", e).at(self.here())
    }

    fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }

    /// Skip whitespace; `false` at the end of the file.
    fn skip_ws(&mut self) -> Result<bool, IoError> {
        loop {
            let buf = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) => return Err(self.os(e)),
            };
            if buf.is_empty() {
                return Ok(false);
            }
            let mut i = 0;
            let mut nl = 0;
            while i < buf.len() && buf[i].is_ascii_whitespace() {
                nl += (buf[i] == b'\n') as u64;
                i += 1;
            }
            let more = i < buf.len();
            self.inner.consume(i);
            self.pos += i as u64;
            self.line += nl;
            if more {
                return Ok(true);
            }
        }
    }

    /// The next token into `self.tok`; `false` at the end of the file.
    fn next_token(&mut self) -> Result<bool, IoError> {
        self.tok.clear();
        if !self.skip_ws()? {
            return Ok(false);
        }
        loop {
            let buf = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) => return Err(self.os(e)),
            };
            if buf.is_empty() {
                break;
            }
            let n = buf
                .iter()
                .position(|b| b.is_ascii_whitespace())
                .unwrap_or(buf.len());
            let done = n < buf.len();
            if self.tok.len() + n > MAX_TOKEN {
                return Err(self.err(format!(
                    "a token longer than {MAX_TOKEN} bytes (binary data where text was expected?)"
                )));
            }
            self.tok.extend_from_slice(&buf[..n]);
            self.inner.consume(n);
            self.pos += n as u64;
            if done {
                break;
            }
        }
        Ok(true)
    }

    /// The next token, which must exist: `what` names it for the error.
    fn expect_token(&mut self, what: &str) -> Result<(), IoError> {
        if self.next_token()? {
            Ok(())
        } else {
            Err(self.err(format!("file truncated: it ends where {what} should be")))
        }
    }

    fn tok_is(&self, kw: &str) -> bool {
        self.tok.eq_ignore_ascii_case(kw.as_bytes())
    }

    fn parse<T: std::str::FromStr>(&self) -> Option<T> {
        std::str::from_utf8(&self.tok).ok()?.parse().ok()
    }

    /// A non-negative count.
    fn count(&mut self, what: &str) -> Result<u64, IoError> {
        self.expect_token(what)?;
        self.parse::<u64>().ok_or_else(|| {
            self.err(format!(
                "{what}: expected a non-negative integer, found `{}`",
                shown(&self.tok)
            ))
        })
    }

    /// A data type name.
    fn dtype(&mut self, what: &str) -> Result<TypeName, IoError> {
        self.expect_token(what)?;
        Ok(DType::parse(&self.tok))
    }

    /// Consume the rest of the current line, through its `\n`: a BINARY
    /// payload starts on the line after its keyword.
    fn skip_line(&mut self) -> Result<(), IoError> {
        loop {
            let buf = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) => return Err(self.os(e)),
            };
            if buf.is_empty() {
                return Ok(());
            }
            match buf.iter().position(|&b| b == b'\n') {
                Some(i) => {
                    self.inner.consume(i + 1);
                    self.pos += i as u64 + 1;
                    self.line += 1;
                    return Ok(());
                }
                None => {
                    let n = buf.len();
                    self.inner.consume(n);
                    self.pos += n as u64;
                }
            }
        }
    }

    /// One raw line without its ending; `None` at the end of the file.
    fn raw_line(&mut self) -> Result<Option<Vec<u8>>, IoError> {
        let mut out = Vec::new();
        loop {
            let buf = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) => return Err(self.os(e)),
            };
            if buf.is_empty() {
                if out.is_empty() {
                    return Ok(None);
                }
                break;
            }
            let (take, done) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (buf.len(), false),
            };
            if out.len() + take > MAX_LINE {
                return Err(self.err(format!("a text line longer than {MAX_LINE} bytes")));
            }
            out.extend_from_slice(&buf[..take]);
            self.inner.consume(take);
            self.pos += take as u64;
            if done {
                self.line += 1;
                break;
            }
        }
        while matches!(out.last(), Some(b'\n' | b'\r')) {
            out.pop();
        }
        Ok(Some(out))
    }

    fn read_exact(&mut self, n: usize, what: &str) -> Result<(), IoError> {
        self.scratch.resize(n, 0);
        match self.inner.read_exact(&mut self.scratch) {
            Ok(()) => {
                self.pos += n as u64;
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(self.err(format!(
                "file truncated: it ends inside {what} ({n} bytes wanted, {} left)",
                self.remaining()
            ))),
            Err(e) => Err(self.os(e)),
        }
    }

    fn seek(&mut self, pos: u64, line: u64) -> Result<(), IoError> {
        self.inner
            .seek(SeekFrom::Start(pos))
            .map_err(|e| IoError::os(&self.path, "cannot seek", e))?;
        self.pos = pos;
        self.line = line;
        Ok(())
    }

    /// Whether the next token is `kw`, without consuming anything (a binary
    /// payload may follow, so nothing here may fail).
    fn peek_is(&mut self, kw: &str) -> Result<bool, IoError> {
        let (pos, line) = (self.pos, self.line);
        let hit = matches!(self.next_token(), Ok(true)) && self.tok_is(kw);
        self.seek(pos, line)?;
        Ok(hit)
    }

    /// Check that `n` values of `size` bytes (BINARY) or `n` tokens (ASCII)
    /// can fit in what is left of the file, before anything is sized by `n`.
    fn check_room(&self, n: u64, size: usize, what: &str) -> Result<(), IoError> {
        if self.binary {
            let need = n.checked_mul(size as u64);
            if need.is_none_or(|b| b > self.remaining()) {
                return Err(self.err(format!(
                    "{what}: {n} values of {size} bytes do not fit in the {} bytes left in the file",
                    self.remaining()
                )));
            }
        } else if n > self.remaining() / 2 + 1 {
            // Each ASCII value takes at least a digit and a separator.
            return Err(self.err(format!(
                "{what}: {n} values cannot fit in the {} bytes left in the file",
                self.remaining()
            )));
        }
        Ok(())
    }

    /// Read `n` values of `dtype` (BINARY or ASCII) into `out`, converting
    /// binary ones with `bin` and text ones with `txt` (`None`: a bad value).
    fn values<T>(
        &mut self,
        n: u64,
        dtype: DType,
        what: &str,
        out: &mut Vec<T>,
        bin: impl Fn(&[u8]) -> Option<T>,
        txt: impl Fn(&str) -> Option<T>,
    ) -> Result<(), IoError> {
        self.check_room(n, dtype.size(), what)?;
        // BINARY: the bytes are there, so `n` is bounded by the file size.
        // ASCII: only loosely bounded (2 bytes a value), so let it grow.
        out.reserve(if self.binary { n } else { n.min(1 << 16) } as usize);
        if self.binary {
            let size = dtype.size();
            let per_chunk = ((1 << 16) / size) as u64;
            let mut left = n;
            while left > 0 {
                let k = left.min(per_chunk);
                let start = self.pos;
                self.read_exact(k as usize * size, what)?;
                for (j, b) in self.scratch.chunks_exact(size).enumerate() {
                    match bin(b) {
                        Some(v) => out.push(v),
                        None => {
                            let at = start + (j * size) as u64;
                            return Err(IoError::new(
                                &self.path,
                                format!("{what}: {} is too large for an index", dtype.f64_be(b)),
                            )
                            .at(format!("byte {at}")));
                        }
                    }
                }
                left -= k;
            }
        } else {
            for _ in 0..n {
                self.expect_token(what)?;
                match std::str::from_utf8(&self.tok).ok().and_then(&txt) {
                    Some(v) => out.push(v),
                    None => {
                        return Err(self.err(format!(
                            "{what}: `{}` is not a {} value",
                            shown(&self.tok),
                            dtype.vtk_name()
                        )))
                    }
                }
            }
        }
        Ok(())
    }

    /// `n` values as f32 (exact for `float`).
    fn f32s(
        &mut self,
        n: u64,
        dtype: DType,
        what: &str,
        out: &mut Vec<f32>,
    ) -> Result<(), IoError> {
        if dtype == DType::F32 && self.binary {
            // The bulk of most files (POINTS): decoded a chunk at a time.
            self.check_room(n, 4, what)?;
            out.reserve(n as usize);
            let mut left = n;
            while left > 0 {
                let k = left.min(1 << 14);
                self.read_exact(4 * k as usize, what)?;
                out.extend(
                    self.scratch
                        .chunks_exact(4)
                        .map(|b| f32::from_be_bytes([b[0], b[1], b[2], b[3]])),
                );
                left -= k;
            }
            Ok(())
        } else if dtype == DType::F32 {
            self.values(
                n,
                dtype,
                what,
                out,
                |b| Some(dtype.f32_be(b)),
                |s| s.parse().ok(),
            )
        } else {
            self.values(
                n,
                dtype,
                what,
                out,
                |b| Some(dtype.f32_be(b)),
                |s| s.parse::<f64>().ok().map(|v| v as f32),
            )
        }
    }

    /// `n` integers (indices, offsets).
    fn ints(
        &mut self,
        n: u64,
        dtype: DType,
        what: &str,
        out: &mut Vec<i64>,
    ) -> Result<(), IoError> {
        if dtype.is_float() {
            return Err(self.err(format!(
                "{what}: type `{}` is not an integer type",
                dtype.vtk_name()
            )));
        }
        self.values(n, dtype, what, out, |b| dtype.int_be(b), |s| s.parse().ok())
    }

    /// Skip `n` values (no allocation: a seek in BINARY files).
    fn skip_values(&mut self, n: u64, dtype: DType, what: &str) -> Result<(), IoError> {
        self.check_room(n, dtype.size(), what)?;
        if self.binary {
            let to = self.pos + n * dtype.size() as u64;
            let line = self.line;
            self.seek(to, line)
        } else {
            for _ in 0..n {
                self.expect_token(what)?;
            }
            Ok(())
        }
    }

    /// Skip a `METADATA` block (after its keyword): lines up to a blank one.
    fn skip_metadata(&mut self) -> Result<(), IoError> {
        self.skip_line()?;
        while let Some(l) = self.raw_line()? {
            if l.iter().all(|b| b.is_ascii_whitespace()) {
                break;
            }
        }
        Ok(())
    }

    /// The next keyword, skipping `METADATA` blocks; `false` at the end.
    fn keyword(&mut self) -> Result<bool, IoError> {
        loop {
            if !self.next_token()? {
                return Ok(false);
            }
            if !self.tok_is("METADATA") {
                return Ok(true);
            }
            self.skip_metadata()?;
        }
    }

    /// Before a BINARY payload: the rest of the keyword line.
    fn begin_payload(&mut self) -> Result<(), IoError> {
        if self.binary {
            self.skip_line()?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Reader

/// Point coordinates as stored.
enum Points {
    F32(Vec<f32>),
    F64(Vec<f64>),
}

impl Points {
    fn count(&self) -> u64 {
        (match self {
            Points::F32(v) => v.len(),
            Points::F64(v) => v.len(),
        } / 3) as u64
    }

    fn get(&self, i: usize) -> Option<DVec3> {
        let j = i.checked_mul(3)?;
        Some(match self {
            Points::F32(v) => {
                let p = v.get(j..j + 3)?;
                DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
            }
            Points::F64(v) => {
                let p = v.get(j..j + 3)?;
                DVec3::new(p[0], p[1], p[2])
            }
        })
    }
}

/// A carried attribute array: `ncomp` values per tuple.
struct Array {
    names: Vec<String>,
    ncomp: usize,
    values: Vec<f32>,
}

/// Which attribute section we are in.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Assoc {
    Dataset,
    Point,
    Cell,
}

impl Assoc {
    fn label(self) -> &'static str {
        match self {
            Assoc::Dataset => "dataset",
            Assoc::Point => "POINT_DATA",
            Assoc::Cell => "CELL_DATA",
        }
    }
}

/// How the line section is laid out, and where its stream starts.
enum Lines {
    /// `LINES n size`: per line a count, then that many int32 indices.
    Classic { size: u64, used: u64 },
    /// 5.1: `n + 1` offsets (in memory) into a `CONNECTIVITY` array.
    Offsets { offsets: Vec<u64>, dtype: DType },
}

/// What one pass over the file found.
struct Scan {
    version: String,
    title: String,
    points: Option<Points>,
    points_type: Option<DType>,
    /// Cells per section: vertices, lines, polygons, strips.
    cells: [u64; 4],
    lines: Option<(Lines, u64, u64)>,
    /// Tuple counts of the attribute sections, and where they were.
    point_data: Option<(u64, String)>,
    cell_data: Option<(u64, String)>,
    point_arrays: Vec<Array>,
    cell_arrays: Vec<Array>,
    dtypes: Vec<(String, DType)>,
    dropped: Vec<String>,
    /// A section this reader cannot size ended the scan.
    stopped: bool,
}

/// Reader of legacy VTK polydata files (`.vtk`, ASCII or binary).
///
/// The files are VTK legacy POLYDATA (`# vtk DataFile Version x.y`), ASCII
/// or BINARY (big-endian), with the curves in `LINES`: the classic layout
/// (per line a count, then point indices) and the 5.1 layout (`OFFSETS` and
/// `CONNECTIVITY` arrays).
///
/// # Reading
///
/// A line may use any point of the `POINTS` array, which comes first, so the
/// points are held in memory as stored (f32 or f64: 12 or 24 bytes a point)
/// and the lines are streamed, one curve built at a time from its indices.
/// `CELL_DATA` follows the lines, so [`open`](Self::open) makes one pass
/// over the file (skipping the line section: a seek in BINARY files, a token
/// scan in ASCII ones), keeps the attribute arrays it can carry (4 bytes a value), then
/// seeks back to the lines. Header counts are checked against the bytes left
/// before anything is allocated by them.
///
/// Carried, as f32 (integers beyond 2^24 and doubles are rounded), under
/// their names in [`Metadata::point_data_names`] / `curve_data_names`: the
/// numeric arrays of `POINT_DATA` and `CELL_DATA` (`SCALARS`, `VECTORS`,
/// `NORMALS`, `TENSORS`, `TENSORS6`, `TEXTURE_COORDINATES`, `GLOBAL_IDS`,
/// `PEDIGREE_IDS`, `EDGE_FLAGS`, and `FIELD` arrays with one tuple per point
/// or cell). An array of k > 1 components becomes k names `name_0`, ….
/// VTK numbers cells vertices first, then lines, polygons and strips, so the
/// curve data of line i is cell `n_vertices + i`. The stored type of each
/// carried array is kept in `extra` as `vtk.dtype.<name>`.
///
/// Dropped, and named in `extra` under `vtk.dropped`: `COLOR_SCALARS`,
/// `LOOKUP_TABLE`s, dataset-level `FIELD` data, `FIELD` arrays of another
/// tuple count, arrays whose names repeat, and arrays of type `bit`,
/// `string`, `utf8_string` or `variant`; the last ones also end the scan,
/// because their size cannot be known without decoding them, so everything
/// after them is dropped too (the geometry before is complete). `METADATA`
/// blocks and the `VERTICES`, `POLYGONS` and `TRIANGLE_STRIPS` cells are
/// skipped.
pub struct VtkReader {
    src: Src,
    meta: Metadata,
    points: Points,
    point_arrays: Vec<Array>,
    cell_arrays: Vec<Array>,
    first_cell: u64,
    lines: Lines,
    n_lines: u64,
    next: u64,
    done: bool,
    idx: Vec<i64>,
}

/// Open a VTK legacy POLYDATA file for streaming its `LINES` as curves (see
/// [`VtkReader`] for what is read).
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_vtk;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-vtk-open-{}.vtk", std::process::id()));
/// std::fs::write(&path, "# vtk DataFile Version 3.0\n").unwrap();
/// let err = open_vtk(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((err.path, err.at.as_deref()), (path, Some("line 2")));
/// assert!(err.reason.starts_with("file truncated"));
/// ```
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Ok(Box::new(VtkReader::open(path)?))
}

impl VtkReader {
    /// Open a `.vtk` file and read its header.
    ///
    /// Two lines of an ASCII file (its encoding is kept in `extra`), and a
    /// file whose `LINES` point past its points:
    ///
    /// ```
    /// use strandfit::io::{CurveReader, VtkReader};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("two.vtk");
    /// let head = "# vtk DataFile Version 3.0\ntwo lines\nASCII\nDATASET POLYDATA\n\
    ///             POINTS 5 float\n0 0 0  1 0 0  2 0 0  0 1 0  0 2 0\n";
    /// std::fs::write(&path, format!("{head}LINES 2 7\n3 0 1 2\n2 3 4\n")).unwrap();
    /// let reader = VtkReader::open(&path).unwrap();
    /// assert_eq!(reader.metadata().count, Some(2));
    /// assert_eq!(reader.metadata().extra("vtk.encoding"), Some("ASCII"));
    /// let curves: Vec<_> = reader.map(|c| c.unwrap().points).collect();
    /// assert_eq!(curves[1], [DVec3::Y, 2.0 * DVec3::Y]);
    /// // Point 5 of 5 points is not there.
    /// std::fs::write(&path, format!("{head}LINES 1 3\n2 4 5\n")).unwrap();
    /// let first = VtkReader::open(&path).and_then(|mut r| r.next().unwrap());
    /// assert!(first.is_err());
    /// ```
    pub fn open(path: &Path) -> Result<Self, IoError> {
        let mut src = Src::open(path)?;
        let scan = scan(&mut src)?;

        let n_points = scan.points.as_ref().map_or(0, Points::count);
        if let Some((n, at)) = &scan.point_data {
            if *n != n_points {
                return Err(IoError::new(
                    path,
                    format!("POINT_DATA {n} does not match the {n_points} points"),
                )
                .at(at.clone()));
            }
        }
        let total_cells = scan.cells.iter().sum::<u64>();
        if let Some((n, at)) = &scan.cell_data {
            if *n != total_cells {
                return Err(IoError::new(
                    path,
                    format!(
                        "CELL_DATA {n} does not match the {total_cells} cells \
                         ({} vertices, {} lines, {} polygons, {} strips)",
                        scan.cells[0], scan.cells[1], scan.cells[2], scan.cells[3]
                    ),
                )
                .at(at.clone()));
            }
        }

        let mut meta = Metadata::new(Format::Vtk);
        meta.count = Some(scan.cells[1]);
        meta.point_data_names = scan
            .point_arrays
            .iter()
            .flat_map(|a| a.names.clone())
            .collect();
        meta.curve_data_names = scan
            .cell_arrays
            .iter()
            .flat_map(|a| a.names.clone())
            .collect();
        meta.extra.push(("vtk.title".into(), scan.title.clone()));
        meta.extra
            .push(("vtk.version".into(), scan.version.clone()));
        let enc = if src.binary { "BINARY" } else { "ASCII" };
        meta.extra.push(("vtk.encoding".into(), enc.into()));
        if let Some(t) = scan.points_type {
            meta.extra
                .push(("vtk.points_type".into(), t.vtk_name().into()));
        }
        let layout = match &scan.lines {
            Some((Lines::Offsets { .. }, _, _)) => "5.1",
            _ => "classic",
        };
        meta.extra.push(("vtk.layout".into(), layout.into()));
        for (name, t) in &scan.dtypes {
            meta.extra
                .push((format!("vtk.dtype.{name}"), t.vtk_name().into()));
        }
        if !scan.dropped.is_empty() {
            meta.extra
                .push(("vtk.dropped".into(), scan.dropped.join("; ")));
        }

        let (lines, n_lines) = match scan.lines {
            Some((lines, pos, line)) => {
                src.seek(pos, line)?;
                (lines, scan.cells[1])
            }
            None => (Lines::Classic { size: 0, used: 0 }, 0),
        };
        Ok(VtkReader {
            src,
            meta,
            points: scan.points.unwrap_or(Points::F32(Vec::new())),
            point_arrays: scan.point_arrays,
            cell_arrays: scan.cell_arrays,
            first_cell: scan.cells[0],
            lines,
            n_lines,
            next: 0,
            done: false,
            idx: Vec::new(),
        })
    }

    fn read_curve(&mut self, i: u64) -> Result<Curve, IoError> {
        self.idx.clear();
        if !self.src.binary {
            // So that `at` names the line the curve's values start on.
            self.src.skip_ws()?;
        }
        let at = self.src.here();
        match &mut self.lines {
            Lines::Classic { size, used } => {
                let left = *size - *used;
                if left == 0 {
                    return Err(self.src.err(format!(
                        "LINES announces {size} values, and the lines before this one used them all"
                    )));
                }
                self.src
                    .ints(1, DType::I32, "a line's point count", &mut self.idx)?;
                let c = self.idx.pop().unwrap_or(0);
                if c < 0 || c as u64 > left - 1 {
                    return Err(IoError::new(
                        &self.src.path,
                        format!(
                            "LINES: a cell of {c} points does not fit in the {} values left of {size}",
                            left - 1
                        ),
                    )
                    .at(at));
                }
                *used += 1 + c as u64;
                self.src
                    .ints(c as u64, DType::I32, "point indices", &mut self.idx)?;
            }
            Lines::Offsets { offsets, dtype } => {
                let (a, b) = match (offsets.get(i as usize), offsets.get(i as usize + 1)) {
                    (Some(&a), Some(&b)) => (a, b),
                    _ => return Err(self.src.err("no offsets for this line")),
                };
                self.src
                    .ints(b - a, *dtype, "CONNECTIVITY", &mut self.idx)?;
            }
        }

        let n = self.points.count();
        let mut curve = Curve {
            id: None,
            points: Vec::with_capacity(self.idx.len()),
            point_data: Vec::with_capacity(self.idx.len() * self.meta.point_data_names.len()),
            curve_data: Vec::with_capacity(self.meta.curve_data_names.len()),
        };
        for (k, &j) in self.idx.iter().enumerate() {
            let p = usize::try_from(j)
                .ok()
                .filter(|&j| (j as u64) < n)
                .and_then(|j| self.points.get(j));
            let p = match p {
                Some(p) => p,
                None => {
                    return Err(IoError::new(
                        &self.src.path,
                        format!("point {k} has index {j}, out of range (the file has {n} points)"),
                    )
                    .at(at));
                }
            };
            if !p.is_finite() {
                return Err(IoError::new(
                    &self.src.path,
                    format!("point {k} (index {j}) is not finite: {p}"),
                )
                .at(at));
            }
            curve.points.push(p);
            for a in &self.point_arrays {
                let s = j as usize * a.ncomp;
                curve
                    .point_data
                    .extend_from_slice(a.values.get(s..s + a.ncomp).unwrap_or(&[]));
            }
        }
        let cell = (self.first_cell + i) as usize;
        for a in &self.cell_arrays {
            let s = cell * a.ncomp;
            curve
                .curve_data
                .extend_from_slice(a.values.get(s..s + a.ncomp).unwrap_or(&[]));
        }
        Ok(curve)
    }
}

impl Iterator for VtkReader {
    type Item = Result<Curve, IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        if self.next >= self.n_lines {
            self.done = true;
            if let Lines::Classic { size, used } = self.lines {
                if used != size {
                    return Some(Err(self.src.err(format!(
                        "LINES announces {size} values, but its {} lines hold {used}",
                        self.n_lines
                    ))));
                }
            }
            return None;
        }
        let i = self.next;
        let r = self.read_curve(i).map(Some).map_err(|e| e.curve(i));
        if r.is_ok() {
            self.next += 1;
        }
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for VtkReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

/// The one pass over the file: header, points, cell sections (the lines
/// only located), attribute data.
fn scan(src: &mut Src) -> Result<Scan, IoError> {
    let first = src.raw_line()?.unwrap_or_default();
    const MAGIC: &[u8] = b"# vtk DataFile Version";
    if first.len() < MAGIC.len() || !first[..MAGIC.len()].eq_ignore_ascii_case(MAGIC) {
        return Err(IoError::new(
            &src.path,
            format!(
                "not a VTK legacy file: the first line is `{}`, not `# vtk DataFile Version x.y`",
                shown(&first)
            ),
        )
        .at("line 1"));
    }
    let version = String::from_utf8_lossy(&first[MAGIC.len()..])
        .trim()
        .to_string();
    let title = match src.raw_line()? {
        Some(t) => String::from_utf8_lossy(&t).into_owned(),
        None => return Err(src.err("file truncated: it ends before the title line")),
    };
    src.expect_token("ASCII or BINARY")?;
    if src.tok_is("BINARY") {
        src.binary = true;
    } else if !src.tok_is("ASCII") {
        return Err(src.err(format!(
            "the file type is `{}`, not ASCII or BINARY",
            shown(&src.tok)
        )));
    }
    src.expect_token("DATASET")?;
    if !src.tok_is("DATASET") {
        return Err(src.err(format!("expected DATASET, found `{}`", shown(&src.tok))));
    }
    src.expect_token("the dataset type")?;
    if !src.tok_is("POLYDATA") {
        return Err(src.err(format!(
            "the dataset is {}, not POLYDATA (only polylines are read)",
            shown(&src.tok)
        )));
    }

    let mut s = Scan {
        version,
        title,
        points: None,
        points_type: None,
        cells: [0; 4],
        lines: None,
        point_data: None,
        cell_data: None,
        point_arrays: Vec::new(),
        cell_arrays: Vec::new(),
        dtypes: Vec::new(),
        dropped: Vec::new(),
        stopped: false,
    };
    let mut assoc = Assoc::Dataset;
    while !s.stopped && src.keyword()? {
        let kw = src.tok.to_ascii_uppercase();
        let at = src.here();
        match kw.as_slice() {
            b"POINTS" => {
                if s.points.is_some() {
                    return Err(src.err("a second POINTS section"));
                }
                let n = src.count("the POINTS count")?;
                let t = match src.dtype("the POINTS type")? {
                    TypeName::Num(t) => t,
                    _ => {
                        return Err(src.err(format!(
                            "unknown or unsupported data type `{}` for POINTS",
                            shown(&src.tok)
                        )))
                    }
                };
                let nv = n
                    .checked_mul(3)
                    .ok_or_else(|| src.err(format!("POINTS {n} is too many")))?;
                src.begin_payload()?;
                let what = format!("POINTS {n} {}", t.vtk_name());
                let pts = if t == DType::F32 {
                    let mut v = Vec::new();
                    src.f32s(nv, t, &what, &mut v)?;
                    Points::F32(v)
                } else {
                    let mut v = Vec::new();
                    src.values(
                        nv,
                        t,
                        &what,
                        &mut v,
                        |b| Some(t.f64_be(b)),
                        |x| x.parse().ok(),
                    )?;
                    Points::F64(v)
                };
                s.points = Some(pts);
                s.points_type = Some(t);
            }
            b"VERTICES" | b"LINES" | b"POLYGONS" | b"TRIANGLE_STRIPS" => {
                let which = match kw.as_slice() {
                    b"VERTICES" => 0,
                    b"LINES" => 1,
                    b"POLYGONS" => 2,
                    _ => 3,
                };
                let name = String::from_utf8_lossy(&kw).into_owned();
                if which == 1 && s.lines.is_some() {
                    return Err(src.err("a second LINES section"));
                }
                let n = src.count(&format!("the {name} count"))?;
                let size = src.count(&format!("the {name} size"))?;
                if src.peek_is("OFFSETS")? {
                    // 5.1 layout: n offsets (n - 1 cells), size connectivity.
                    src.expect_token("OFFSETS")?;
                    let t = index_type(src, "OFFSETS")?;
                    src.begin_payload()?;
                    let mut off = Vec::new();
                    src.ints(n, t, "OFFSETS", &mut off)?;
                    let offsets = check_offsets(src, &name, &off, size)?;
                    if !src.keyword()? || !src.tok_is("CONNECTIVITY") {
                        return Err(src.err(format!(
                            "{name}: expected CONNECTIVITY after the OFFSETS, found `{}`",
                            shown(&src.tok)
                        )));
                    }
                    let ct = index_type(src, "CONNECTIVITY")?;
                    src.begin_payload()?;
                    let (pos, line) = (src.pos, src.line);
                    src.skip_values(size, ct, "CONNECTIVITY")?;
                    s.cells[which] = n.saturating_sub(1);
                    if which == 1 {
                        s.lines = Some((Lines::Offsets { offsets, dtype: ct }, pos, line));
                    }
                } else {
                    // Classic: n cells in `size` int32 values (count, indices…).
                    if n > size {
                        return Err(src.err(format!(
                            "{name} {n} {size}: {n} cells cannot fit in {size} values"
                        )));
                    }
                    src.begin_payload()?;
                    let (pos, line) = (src.pos, src.line);
                    if src.binary {
                        src.skip_values(size, DType::I32, &name)?;
                    } else {
                        skip_ascii_cells(src, &name, n, size, which == 1)?;
                    }
                    s.cells[which] = n;
                    if which == 1 {
                        s.lines = Some((Lines::Classic { size, used: 0 }, pos, line));
                    }
                }
            }
            // One section of each: a second would re-declare the count
            // that the first section's arrays were checked against.
            b"POINT_DATA" => {
                if s.point_data.is_some() {
                    return Err(src.err("a second POINT_DATA section"));
                }
                s.point_data = Some((src.count("the POINT_DATA count")?, at));
                assoc = Assoc::Point;
            }
            b"CELL_DATA" => {
                if s.cell_data.is_some() {
                    return Err(src.err("a second CELL_DATA section"));
                }
                s.cell_data = Some((src.count("the CELL_DATA count")?, at));
                assoc = Assoc::Cell;
            }
            b"FIELD" => read_field(src, &mut s, assoc)?,
            _ if assoc != Assoc::Dataset => read_attribute(src, &mut s, assoc, &kw)?,
            _ => {
                return Err(src.err(format!(
                    "unknown keyword `{}` (expected POINTS, LINES, POINT_DATA, CELL_DATA, …)",
                    shown(&kw)
                )))
            }
        }
    }
    Ok(s)
}

/// Skip a classic ASCII cell section, checking that its `n` cells (count,
/// then indices) take exactly `size` values, so that a wrong count is
/// reported at its cell rather than as a stray keyword later.
fn skip_ascii_cells(
    src: &mut Src,
    name: &str,
    n: u64,
    size: u64,
    lines: bool,
) -> Result<(), IoError> {
    let mut used = 0u64;
    for cell in 0..n {
        src.expect_token(&format!("{name} cell {cell}"))?;
        let at = src.here();
        let c = src.parse::<i64>().ok_or_else(|| {
            src.err(format!(
                "{name} cell {cell}: expected a point count, found `{}`",
                shown(&src.tok)
            ))
        })?;
        // `used < size` is not guaranteed: earlier cells may have used the
        // whole section (`LINES 2 2` / `1 0` / `1 1`).
        let Some(left) = size.checked_sub(used + 1) else {
            let e = IoError::new(
                &src.path,
                format!(
                    "{name} {n} {size}: cell {cell} starts after the {size} values are used up"
                ),
            )
            .at(at);
            return Err(if lines { e.curve(cell) } else { e });
        };
        if c < 0 || c as u64 > left {
            let e = IoError::new(
                &src.path,
                format!(
                    "{name}: a cell of {c} points does not fit in the {left} values left of {size}"
                ),
            )
            .at(at);
            return Err(if lines { e.curve(cell) } else { e });
        }
        used += 1 + c as u64;
        for _ in 0..c {
            src.expect_token(&format!("{name} cell {cell}"))?;
        }
    }
    if used != size {
        return Err(src.err(format!(
            "{name} {n} {size}: the {n} cells hold {used} values, not {size}"
        )));
    }
    Ok(())
}

/// The integer type of an OFFSETS or CONNECTIVITY array.
fn index_type(src: &mut Src, what: &str) -> Result<DType, IoError> {
    match src.dtype(&format!("the {what} type"))? {
        TypeName::Num(t) if !t.is_float() => Ok(t),
        _ => Err(src.err(format!(
            "{what} has type `{}`, not an integer type",
            shown(&src.tok)
        ))),
    }
}

/// 5.1 offsets: start at 0, never decrease, end at the connectivity size.
fn check_offsets(src: &Src, name: &str, off: &[i64], size: u64) -> Result<Vec<u64>, IoError> {
    let mut out = Vec::with_capacity(off.len());
    let mut prev = 0u64;
    for (i, &o) in off.iter().enumerate() {
        let bad = |why: &str| {
            let e = src.err(format!("{name} OFFSETS[{i}] = {o}: {why}"));
            if i > 0 {
                e.curve(i as u64 - 1)
            } else {
                e
            }
        };
        let o = u64::try_from(o).map_err(|_| bad("negative"))?;
        if i == 0 && o != 0 {
            return Err(bad("the first offset must be 0"));
        }
        if o < prev {
            return Err(bad("offsets must not decrease"));
        }
        if o > size {
            return Err(bad(&format!("beyond the {size} CONNECTIVITY values")));
        }
        prev = o;
        out.push(o);
    }
    if !off.is_empty() && prev != size {
        return Err(src.err(format!(
            "{name}: the last offset is {prev}, but CONNECTIVITY has {size} values"
        )));
    }
    Ok(out)
}

/// Keep `values` (ncomp per tuple) as a carried array, unless a name repeats.
fn carry(s: &mut Scan, assoc: Assoc, name: String, dtype: DType, ncomp: u64, values: Vec<f32>) {
    let names: Vec<String> = if ncomp == 1 {
        vec![name.clone()]
    } else {
        (0..ncomp).map(|c| format!("{name}_{c}")).collect()
    };
    let existing = match assoc {
        Assoc::Point => &s.point_arrays,
        _ => &s.cell_arrays,
    };
    if names
        .iter()
        .any(|n| existing.iter().any(|a| a.names.contains(n)))
    {
        s.dropped
            .push(format!("{} `{name}` (name already used)", assoc.label()));
        return;
    }
    for n in &names {
        s.dtypes.push((n.clone(), dtype));
    }
    let a = Array {
        names,
        ncomp: ncomp as usize,
        values,
    };
    match assoc {
        Assoc::Point => s.point_arrays.push(a),
        _ => s.cell_arrays.push(a),
    }
}

/// Read (or skip, when `keep` is false) `tuples × ncomp` values of type
/// `t`; returns `None` when not kept.
fn array_values(
    src: &mut Src,
    t: DType,
    tuples: u64,
    ncomp: u64,
    what: &str,
    keep: bool,
) -> Result<Option<Vec<f32>>, IoError> {
    let n = tuples
        .checked_mul(ncomp)
        .ok_or_else(|| src.err(format!("{what}: {tuples} × {ncomp} values is too many")))?;
    src.begin_payload()?;
    if keep {
        let mut v = Vec::new();
        src.f32s(n, t, what, &mut v)?;
        Ok(Some(v))
    } else {
        src.skip_values(n, t, what)?;
        Ok(None)
    }
}

/// The data type of an attribute array; `None` (and the scan stopped) for
/// types whose size cannot be known without decoding them.
fn attr_type(
    src: &mut Src,
    s: &mut Scan,
    assoc: Assoc,
    name: &str,
) -> Result<Option<DType>, IoError> {
    match src.dtype(&format!("the type of `{name}`"))? {
        TypeName::Num(t) => Ok(Some(t)),
        TypeName::Unsupported => {
            s.dropped.push(format!(
                "{} `{name}` ({} arrays are not read) and everything after it",
                assoc.label(),
                shown(&src.tok)
            ));
            s.stopped = true;
            Ok(None)
        }
        TypeName::Unknown => Err(src.err(format!(
            "unknown data type `{}` for `{name}`",
            shown(&src.tok)
        ))),
    }
}

/// One attribute of a POINT_DATA or CELL_DATA section (after its keyword).
fn read_attribute(src: &mut Src, s: &mut Scan, assoc: Assoc, kw: &[u8]) -> Result<(), IoError> {
    let tuples = match assoc {
        Assoc::Point => s.point_data.as_ref().map_or(0, |c| c.0),
        _ => s.cell_data.as_ref().map_or(0, |c| c.0),
    };
    let kw_s = String::from_utf8_lossy(kw).into_owned();
    match kw {
        b"SCALARS"
        | b"VECTORS"
        | b"NORMALS"
        | b"TENSORS"
        | b"TENSORS6"
        | b"GLOBAL_IDS"
        | b"PEDIGREE_IDS"
        | b"EDGE_FLAGS"
        | b"TEXTURE_COORDINATES" => {
            src.expect_token(&format!("the {kw_s} name"))?;
            let name = decode_name(&src.tok);
            let mut ncomp = match kw {
                b"VECTORS" | b"NORMALS" => 3,
                b"TENSORS" => 9,
                b"TENSORS6" => 6,
                _ => 1,
            };
            if kw == b"TEXTURE_COORDINATES" {
                ncomp = src.count("the texture coordinate dimension")?;
                if !(1..=3).contains(&ncomp) {
                    return Err(src.err(format!(
                        "TEXTURE_COORDINATES `{name}` has dimension {ncomp}, not 1 to 3"
                    )));
                }
            }
            let Some(t) = attr_type(src, s, assoc, &name)? else {
                return Ok(());
            };
            if kw == b"SCALARS" {
                // `SCALARS name type [ncomp]` then `LOOKUP_TABLE table`.
                src.expect_token("LOOKUP_TABLE")?;
                if !src.tok_is("LOOKUP_TABLE") {
                    ncomp = src.parse::<u64>().filter(|c| (1..=MAX_COMPONENTS).contains(c)).ok_or_else(
                        || {
                            src.err(format!(
                                "SCALARS `{name}`: `{}` is neither a component count (1 to {MAX_COMPONENTS}) nor LOOKUP_TABLE",
                                shown(&src.tok)
                            ))
                        },
                    )?;
                    src.expect_token("LOOKUP_TABLE")?;
                    if !src.tok_is("LOOKUP_TABLE") {
                        return Err(src.err(format!(
                            "SCALARS `{name}` must be followed by LOOKUP_TABLE, found `{}`",
                            shown(&src.tok)
                        )));
                    }
                }
                src.expect_token("the lookup table name")?;
            }
            let what = format!("{} {kw_s} `{name}`", assoc.label());
            if let Some(v) = array_values(src, t, tuples, ncomp, &what, true)? {
                carry(s, assoc, name, t, ncomp, v);
            }
        }
        b"COLOR_SCALARS" => {
            src.expect_token("the COLOR_SCALARS name")?;
            let name = decode_name(&src.tok);
            let ncomp = src.count("the COLOR_SCALARS component count")?;
            if !(1..=MAX_COMPONENTS).contains(&ncomp) {
                return Err(src.err(format!("COLOR_SCALARS `{name}` has {ncomp} components")));
            }
            // Stored as unsigned char in BINARY files, float in ASCII ones.
            let t = if src.binary { DType::U8 } else { DType::F32 };
            let what = format!("{} COLOR_SCALARS `{name}`", assoc.label());
            array_values(src, t, tuples, ncomp, &what, false)?;
            s.dropped.push(what);
        }
        b"LOOKUP_TABLE" => {
            src.expect_token("the LOOKUP_TABLE name")?;
            let name = decode_name(&src.tok);
            let size = src.count("the LOOKUP_TABLE size")?;
            let t = if src.binary { DType::U8 } else { DType::F32 };
            let what = format!("{} LOOKUP_TABLE `{name}`", assoc.label());
            array_values(src, t, size, 4, &what, false)?;
            s.dropped.push(what);
        }
        _ => {
            return Err(src.err(format!(
                "unknown {} attribute `{}`",
                assoc.label(),
                shown(kw)
            )))
        }
    }
    Ok(())
}

/// `FIELD name k` and its k arrays: carried when they have one tuple per
/// point (cell) of the section, dropped otherwise (and at dataset level).
fn read_field(src: &mut Src, s: &mut Scan, assoc: Assoc) -> Result<(), IoError> {
    src.expect_token("the FIELD name")?;
    let field = decode_name(&src.tok);
    let k = src.count("the FIELD array count")?;
    let tuples = match assoc {
        Assoc::Point => s.point_data.as_ref().map(|c| c.0),
        Assoc::Cell => s.cell_data.as_ref().map(|c| c.0),
        Assoc::Dataset => None,
    };
    for _ in 0..k {
        src.expect_token("a FIELD array name")?;
        if src.tok == b"NULL_ARRAY" {
            continue;
        }
        let name = decode_name(&src.tok);
        let ncomp = src.count(&format!("the component count of `{name}`"))?;
        if !(1..=MAX_COMPONENTS).contains(&ncomp) {
            return Err(src.err(format!(
                "FIELD array `{name}` has {ncomp} components (1 to {MAX_COMPONENTS} are read)"
            )));
        }
        let n = src.count(&format!("the tuple count of `{name}`"))?;
        let Some(t) = attr_type(src, s, assoc, &name)? else {
            return Ok(());
        };
        let keep = tuples == Some(n);
        let what = format!("{} FIELD {field} array `{name}`", assoc.label());
        match array_values(src, t, n, ncomp, &what, keep)? {
            Some(v) => carry(s, assoc, name, t, ncomp, v),
            None => s.dropped.push(match tuples {
                Some(m) => format!("{what} ({n} tuples, not {m})"),
                None => what,
            }),
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Writer

/// Create a VTK legacy POLYDATA file (see [`VtkWriter`] for the layout).
///
/// Per-curve values travel with the curves:
///
/// ```
/// use strandfit::io::{create_vtk, open_vtk, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-vtk-create-{}.vtk", std::process::id()));
/// let mut meta = Metadata::new(Format::Json);
/// meta.curve_data_names = vec!["weight".into()];
/// let mut w = create_vtk(&path, &meta).unwrap();
/// for k in 0..3 {
///     let points = vec![DVec3::ZERO, DVec3::splat(k as f64 + 1.0)];
///     w.write_curve(&Curve { curve_data: vec![k as f32], ..Curve::from_points(points) }).unwrap();
/// }
/// w.finish().unwrap();
/// let curves: Vec<Curve> = open_vtk(&path).unwrap().collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(curves.len(), 3);
/// assert_eq!((curves[2].points[1], curves[2].curve_data[0]), (DVec3::splat(3.0), 2.0));
/// ```
pub fn create(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Ok(Box::new(VtkWriter::new(path, meta)?))
}

/// An output array: its values so far and whether they all fit the type the
/// source used.
struct OutArray {
    name: String,
    wanted: Option<DType>,
    fits: bool,
}

impl OutArray {
    fn new(name: &str, meta: &Metadata) -> Self {
        let wanted = meta.extra(&format!("vtk.dtype.{name}")).and_then(|t| {
            match DType::parse(t.as_bytes()) {
                TypeName::Num(t) => Some(t),
                _ => None,
            }
        });
        OutArray {
            name: name.to_string(),
            wanted,
            fits: true,
        }
    }

    fn see(&mut self, v: f32) {
        if let Some((lo, hi)) = self.wanted.and_then(DType::int_range) {
            let v = v as f64;
            self.fits &= v.fract() == 0.0 && v >= lo && v <= hi;
        }
    }

    fn dtype(&self) -> DType {
        match self.wanted {
            Some(t) if self.fits => t,
            _ => DType::F32,
        }
    }
}

/// Writer of legacy VTK polydata files.
///
/// The header needs the point and line counts, so points (and per-point
/// values) are spooled to unnamed scratch files next to the target and the
/// file is assembled at [`CurveWriter::finish`] through an [`AtomicFile`].
/// The output is the classic `LINES n size` layout (version 3.0, readable by
/// every VTK since 2000), BINARY unless `extra` has `vtk.encoding = ASCII`
/// (a VTK source's own encoding is kept that way), float points unless
/// `vtk.points_type = double`. Carried arrays go to `CELL_DATA` /
/// `POINT_DATA`: one array as `SCALARS` (VTK's active scalars), several as
/// one `FIELD` (VTK's reader keeps only the first `SCALARS` of a section), as
/// float unless `vtk.dtype.<name>` names a type every value fits. The title
/// line is `vtk.title` (else `hair.info`, else a default).
pub struct VtkWriter {
    path: PathBuf,
    out: AtomicFile,
    binary: bool,
    double: bool,
    title: String,
    /// `None` only once `finish` has taken it.
    points: Option<Spool>,
    n_points: u64,
    counts: Vec<u32>,
    point_arrays: Vec<OutArray>,
    point_spools: Vec<Spool>,
    curve_arrays: Vec<OutArray>,
    curve_values: Vec<Vec<f32>>,
    text: String,
    bytes: Vec<u8>,
}

impl VtkWriter {
    /// Create a `.vtk` file at `path` for curves described by `meta`
    /// (BINARY unless `meta.extra` has `vtk.encoding = ASCII`).
    ///
    /// ```
    /// use strandfit::io::{Curve, CurveReader, CurveWriter, Format, Metadata, VtkReader, VtkWriter};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("line.vtk");
    /// let mut meta = Metadata::new(Format::Json);
    /// meta.extra.push(("vtk.encoding".into(), "ASCII".into()));
    /// let mut w = Box::new(VtkWriter::new(&path, &meta).unwrap());
    /// let points = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 0.5, 0.0)];
    /// w.write_curve(&Curve::from_points(points.clone())).unwrap();
    /// w.finish().unwrap();
    /// let text = std::fs::read_to_string(&path).unwrap();
    /// assert!(text.starts_with("# vtk DataFile Version") && text.contains("\nASCII\n"));
    /// let mut reader = VtkReader::open(&path).unwrap();
    /// assert_eq!(reader.next().unwrap().unwrap().points, points);
    /// ```
    pub fn new(path: &Path, meta: &Metadata) -> Result<Self, IoError> {
        let out = AtomicFile::create(path)?;
        let binary = !meta
            .extra("vtk.encoding")
            .is_some_and(|e| e.eq_ignore_ascii_case("ascii"));
        let double = meta
            .extra("vtk.points_type")
            .is_some_and(|t| t.eq_ignore_ascii_case("double"));
        let title = meta
            .extra("vtk.title")
            .or(meta.extra("hair.info"))
            .unwrap_or("curves written by strandfit");
        // One line, at most the 256 bytes VTK's reader takes.
        let mut title: String = title
            .chars()
            .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
            .collect();
        while title.len() > 255 {
            title.pop();
        }
        let mut point_spools = Vec::new();
        for _ in &meta.point_data_names {
            point_spools.push(Spool::new(path)?);
        }
        Ok(VtkWriter {
            path: path.to_path_buf(),
            out,
            binary,
            double,
            title,
            points: Some(Spool::new(path)?),
            n_points: 0,
            counts: Vec::new(),
            point_arrays: meta
                .point_data_names
                .iter()
                .map(|n| OutArray::new(n, meta))
                .collect(),
            point_spools,
            curve_arrays: meta
                .curve_data_names
                .iter()
                .map(|n| OutArray::new(n, meta))
                .collect(),
            curve_values: vec![Vec::new(); meta.curve_data_names.len()],
            text: String::new(),
            bytes: Vec::new(),
        })
    }

    fn err(&self, reason: impl Into<String>) -> IoError {
        IoError::new(&self.path, reason)
    }

    /// Write `bytes` or `text`, whichever this encoding uses, and clear it.
    fn emit(
        out: &mut AtomicFile,
        binary: bool,
        bytes: &mut Vec<u8>,
        text: &mut String,
    ) -> Result<(), IoError> {
        let r = if binary {
            out.write_all(bytes)
        } else {
            out.write_all(text.as_bytes())
        };
        bytes.clear();
        text.clear();
        r.map_err(|e| out.err(e))
    }

    /// One array's section: `SCALARS` when it is alone, else a `FIELD` entry.
    fn write_array_header(
        &mut self,
        a_name: &str,
        t: DType,
        n: u64,
        alone: bool,
    ) -> Result<(), IoError> {
        let name = encode_name(a_name);
        let h = if alone {
            format!("SCALARS {name} {} 1\nLOOKUP_TABLE default\n", t.vtk_name())
        } else {
            format!("{name} 1 {n} {}\n", t.vtk_name())
        };
        self.out
            .write_all(h.as_bytes())
            .map_err(|e| self.out.err(e))
    }

    /// Values of type `t`, encoded for this file.
    fn put_value(&mut self, t: DType, v: f32) {
        if self.binary {
            t.put_be(v, &mut self.bytes);
        } else {
            if t.is_float() {
                fmt_f32(v, &mut self.text);
            } else {
                use std::fmt::Write as _;
                let _ = write!(self.text, "{}", v as i64);
            }
            self.text.push('\n');
        }
    }

    fn flush_values(&mut self) -> Result<(), IoError> {
        Self::emit(&mut self.out, self.binary, &mut self.bytes, &mut self.text)
    }

    fn end_payload(&mut self) -> Result<(), IoError> {
        if self.binary {
            self.out.write_all(b"\n").map_err(|e| self.out.err(e))?;
        }
        Ok(())
    }
}

impl CurveWriter for VtkWriter {
    fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
        let i = self.counts.len() as u64;
        let np = self.point_arrays.len();
        if c.point_data.len() != c.points.len() * np {
            return Err(self
                .err(format!(
                    "{} per-point values for {} points and {np} arrays",
                    c.point_data.len(),
                    c.points.len()
                ))
                .curve(i));
        }
        if c.curve_data.len() != self.curve_arrays.len() {
            return Err(self
                .err(format!(
                    "{} per-curve values for {} arrays",
                    c.curve_data.len(),
                    self.curve_arrays.len()
                ))
                .curve(i));
        }
        let total = self.n_points + c.points.len() as u64;
        if total > i32::MAX as u64 || self.counts.len() >= i32::MAX as usize {
            return Err(self
                .err("more than 2^31 - 1 points or lines: the classic VTK layout stores int32 indices")
                .curve(i));
        }
        self.bytes.clear();
        self.text.clear();
        for (k, p) in c.points.iter().enumerate() {
            let bad = if self.double {
                !p.is_finite()
            } else {
                !p.as_vec3().is_finite()
            };
            if bad {
                let what = if p.is_finite() {
                    "does not fit in float32 (write double points)"
                } else {
                    "is not finite"
                };
                return Err(self.err(format!("point {k} {p} {what}")).curve(i));
            }
            for x in p.to_array() {
                if self.binary {
                    if self.double {
                        self.bytes.extend_from_slice(&x.to_be_bytes());
                    } else {
                        self.bytes.extend_from_slice(&(x as f32).to_be_bytes());
                    }
                } else {
                    if self.double {
                        fmt_f64(x, &mut self.text);
                    } else {
                        fmt_f32(x as f32, &mut self.text);
                    }
                    self.text.push(' ');
                }
            }
            if !self.binary {
                self.text.pop();
                self.text.push('\n');
            }
        }
        let spool = match self.points.as_mut() {
            Some(s) => s,
            None => return Err(IoError::new(&self.path, "written after finish").curve(i)),
        };
        if self.binary {
            spool.write(&self.bytes)?;
        } else {
            spool.write(self.text.as_bytes())?;
        }
        for (a, (arr, spool)) in self
            .point_arrays
            .iter_mut()
            .zip(self.point_spools.iter_mut())
            .enumerate()
        {
            self.bytes.clear();
            for row in c.point_data.chunks_exact(np.max(1)) {
                let v = row.get(a).copied().unwrap_or(0.0);
                arr.see(v);
                self.bytes.extend_from_slice(&v.to_le_bytes());
            }
            spool.write(&self.bytes)?;
        }
        for ((arr, vals), &v) in self
            .curve_arrays
            .iter_mut()
            .zip(self.curve_values.iter_mut())
            .zip(&c.curve_data)
        {
            arr.see(v);
            vals.push(v);
        }
        self.n_points = total;
        self.counts.push(c.points.len() as u32);
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<(), IoError> {
        // The scratch buffers may hold the last curve's values.
        self.bytes.clear();
        self.text.clear();
        let n_lines = self.counts.len() as u64;
        let header = format!(
            "# vtk DataFile Version 3.0\n{}\n{}\nDATASET POLYDATA\nPOINTS {} {}\n",
            self.title,
            if self.binary { "BINARY" } else { "ASCII" },
            self.n_points,
            if self.double { "double" } else { "float" },
        );
        self.out
            .write_all(header.as_bytes())
            .map_err(|e| self.out.err(e))?;
        if let Some(points) = self.points.take() {
            points.copy_into(&mut self.out)?;
        }
        self.end_payload()?;

        let lines = format!("LINES {n_lines} {}\n", self.n_points + n_lines);
        self.out
            .write_all(lines.as_bytes())
            .map_err(|e| self.out.err(e))?;
        let mut next = 0u32;
        let counts = std::mem::take(&mut self.counts);
        for &c in &counts {
            if self.binary {
                self.bytes.extend_from_slice(&(c as i32).to_be_bytes());
                for j in next..next + c {
                    self.bytes.extend_from_slice(&(j as i32).to_be_bytes());
                }
            } else {
                use std::fmt::Write as _;
                let _ = write!(self.text, "{c}");
                for j in next..next + c {
                    let _ = write!(self.text, " {j}");
                }
                self.text.push('\n');
            }
            next += c;
            if self.bytes.len() > 1 << 16 || self.text.len() > 1 << 16 {
                self.flush_values()?;
            }
        }
        self.flush_values()?;
        self.end_payload()?;

        // CELL_DATA: the per-curve arrays (held in memory, one f32 a curve).
        let curve_arrays = std::mem::take(&mut self.curve_arrays);
        if !curve_arrays.is_empty() {
            let alone = curve_arrays.len() == 1;
            let mut h = format!("CELL_DATA {n_lines}\n");
            if !alone {
                h.push_str(&format!("FIELD FieldData {}\n", curve_arrays.len()));
            }
            self.out
                .write_all(h.as_bytes())
                .map_err(|e| self.out.err(e))?;
            let values = std::mem::take(&mut self.curve_values);
            for (arr, vals) in curve_arrays.iter().zip(values) {
                let t = arr.dtype();
                self.write_array_header(&arr.name, t, n_lines, alone)?;
                for v in vals {
                    self.put_value(t, v);
                    if self.bytes.len() > 1 << 16 || self.text.len() > 1 << 16 {
                        self.flush_values()?;
                    }
                }
                self.flush_values()?;
                self.end_payload()?;
            }
        }

        // POINT_DATA: one spool per array, f32 little-endian.
        let point_arrays = std::mem::take(&mut self.point_arrays);
        if !point_arrays.is_empty() {
            let alone = point_arrays.len() == 1;
            let mut h = format!("POINT_DATA {}\n", self.n_points);
            if !alone {
                h.push_str(&format!("FIELD FieldData {}\n", point_arrays.len()));
            }
            self.out
                .write_all(h.as_bytes())
                .map_err(|e| self.out.err(e))?;
            let spools = std::mem::take(&mut self.point_spools);
            for (arr, spool) in point_arrays.iter().zip(spools) {
                let t = arr.dtype();
                self.write_array_header(&arr.name, t, self.n_points, alone)?;
                let me = &mut *self;
                spool.for_each_chunk(4, |chunk| {
                    for b in chunk.chunks_exact(4) {
                        me.put_value(t, f32::from_le_bytes(be(b)));
                    }
                    me.flush_values()
                })?;
                self.end_payload()?;
            }
        }
        self.out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names() {
        assert_eq!(DType::parse(b"FLOAT"), TypeName::Num(DType::F32));
        assert_eq!(DType::parse(b"vtkIdType"), TypeName::Num(DType::I32));
        assert_eq!(DType::parse(b"vtktypeint64"), TypeName::Num(DType::I64));
        assert_eq!(DType::parse(b"string"), TypeName::Unsupported);
        assert_eq!(DType::parse(b"quaternion"), TypeName::Unknown);
        assert_eq!(DType::I64.int_be(&[0xff; 8]), Some(-1));
        assert_eq!(DType::U64.int_be(&[0xff; 8]), None);
        assert_eq!(DType::F32.int_be(&[0; 4]), None);
    }

    #[test]
    fn names_round_trip() {
        for n in ["polarity", "a b", "100%", "tab\there", "ü"] {
            let e = encode_name(n);
            assert!(!e.contains(char::is_whitespace), "{e}");
            assert_eq!(decode_name(e.as_bytes()), n);
        }
        // Malformed escapes are kept as they are.
        assert_eq!(decode_name(b"a%zz%4"), "a%zz%4");
    }

    #[test]
    fn float_text_round_trips() {
        let mut s = String::new();
        for v in [
            0.0f32,
            -0.0,
            1.0,
            0.1,
            1e-30,
            3.4e38,
            -7.25e-6,
            123456.79,
            f32::MIN_POSITIVE,
        ] {
            s.clear();
            fmt_f32(v, &mut s);
            assert_eq!(
                s.parse::<f32>().ok().map(f32::to_bits),
                Some(v.to_bits()),
                "{s}"
            );
            assert!(s.len() < 16, "{s}");
        }
    }

    #[test]
    fn integer_output_type_needs_every_value_to_fit() {
        let mut meta = Metadata::new(Format::Vtk);
        meta.extra.push(("vtk.dtype.p".into(), "int".into()));
        let mut a = OutArray::new("p", &meta);
        a.see(-1.0);
        a.see(3.0);
        assert_eq!(a.dtype(), DType::I32);
        a.see(0.5);
        assert_eq!(a.dtype(), DType::F32);
        assert_eq!(OutArray::new("q", &meta).dtype(), DType::F32);
    }
}
