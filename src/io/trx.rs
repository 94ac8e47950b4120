//! TRX tractograms: the reader and the writer. The format and what the
//! reader makes of it are described on `open` (`io::open_trx`), what the
//! writer writes on `create` (`io::create_trx`).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};

use super::format::Format;
use super::spool::Spool;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, IoError, Metadata};

/// Largest `header.json` accepted.
const MAX_HEADER: u64 = 1 << 20;
/// Largest `dpg/` entry carried verbatim in [`Metadata::extra`].
const MAX_DPG_ENTRY: u64 = 1 << 20;
/// Prefix of the per-curve values that stand for a TRX group.
pub const GROUP_PREFIX: &str = "group:";
/// Deflate expands at most ~1032:1; an entry claiming more is corrupt.
const MAX_DEFLATE_RATIO: u64 = 1040;

// ---------------------------------------------------------------- dtypes

/// The element types TRX arrays use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum DType {
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    F16,
    F32,
    F64,
}

impl DType {
    const ALL: [DType; 11] = [
        DType::I8,
        DType::I16,
        DType::I32,
        DType::I64,
        DType::U8,
        DType::U16,
        DType::U32,
        DType::U64,
        DType::F16,
        DType::F32,
        DType::F64,
    ];

    fn name(self) -> &'static str {
        match self {
            DType::I8 => "int8",
            DType::I16 => "int16",
            DType::I32 => "int32",
            DType::I64 => "int64",
            DType::U8 => "uint8",
            DType::U16 => "uint16",
            DType::U32 => "uint32",
            DType::U64 => "uint64",
            DType::F16 => "float16",
            DType::F32 => "float32",
            DType::F64 => "float64",
        }
    }

    fn parse(s: &str) -> Option<DType> {
        DType::ALL.into_iter().find(|d| d.name() == s)
    }

    fn size(self) -> usize {
        match self {
            DType::I8 | DType::U8 => 1,
            DType::I16 | DType::U16 | DType::F16 => 2,
            DType::I32 | DType::U32 | DType::F32 => 4,
            DType::I64 | DType::U64 | DType::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, DType::F16 | DType::F32 | DType::F64)
    }

    /// One little-endian value from exactly `size()` bytes.
    fn decode(self, b: &[u8]) -> f64 {
        let a8 = || [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
        match self {
            DType::I8 => f64::from(b[0] as i8),
            DType::U8 => f64::from(b[0]),
            DType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            DType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            DType::F16 => f64::from(f16_to_f32(u16::from_le_bytes([b[0], b[1]]))),
            DType::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DType::I64 => i64::from_le_bytes(a8()) as f64,
            DType::U64 => u64::from_le_bytes(a8()) as f64,
            DType::F64 => f64::from_le_bytes(a8()),
        }
    }

    /// Append `x` in this type; `None` when it does not fit (out of range,
    /// finite overflowing to infinity, an integer type given a fraction or a
    /// NaN), so the caller can say which value.
    fn encode(self, x: f64, out: &mut Vec<u8>) -> Option<()> {
        if !self.is_float() {
            let (lo, hi) = match self {
                DType::I8 => (i8::MIN as f64, i8::MAX as f64),
                DType::I16 => (i16::MIN as f64, i16::MAX as f64),
                DType::I32 => (i32::MIN as f64, i32::MAX as f64),
                DType::I64 => (-(2f64.powi(63)), 2f64.powi(63) - 1024.0),
                DType::U8 => (0.0, u8::MAX as f64),
                DType::U16 => (0.0, u16::MAX as f64),
                DType::U32 => (0.0, u32::MAX as f64),
                _ => (0.0, 2f64.powi(64) - 2048.0),
            };
            if !(x >= lo && x <= hi && x.fract() == 0.0) {
                return None;
            }
        }
        match self {
            DType::I8 => out.push(x as i8 as u8),
            DType::U8 => out.push(x as u8),
            DType::I16 => out.extend_from_slice(&(x as i16).to_le_bytes()),
            DType::U16 => out.extend_from_slice(&(x as u16).to_le_bytes()),
            DType::I32 => out.extend_from_slice(&(x as i32).to_le_bytes()),
            DType::U32 => out.extend_from_slice(&(x as u32).to_le_bytes()),
            DType::I64 => out.extend_from_slice(&(x as i64).to_le_bytes()),
            DType::U64 => out.extend_from_slice(&(x as u64).to_le_bytes()),
            DType::F16 => {
                let h = f64_to_f16(x);
                if f16_to_f32(h).is_infinite() && x.is_finite() {
                    return None;
                }
                out.extend_from_slice(&h.to_le_bytes());
            }
            DType::F32 => {
                let f = x as f32;
                if f.is_infinite() && x.is_finite() {
                    return None;
                }
                out.extend_from_slice(&f.to_le_bytes());
            }
            DType::F64 => out.extend_from_slice(&x.to_le_bytes()),
        }
        Some(())
    }
}

/// IEEE binary16 → f32 (exact).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0f32 } else { 1.0 };
    let exp = (h >> 10) & 0x1f;
    let frac = f32::from(h & 0x3ff);
    match exp {
        0 => sign * frac * 2f32.powi(-24),
        0x1f if frac == 0.0 => sign * f32::INFINITY,
        0x1f => f32::NAN,
        e => sign * (1.0 + frac / 1024.0) * 2f32.powi(i32::from(e) - 15),
    }
}

/// f64 → IEEE binary16, rounding to nearest, ties to even (directly from
/// f64, so there is no double rounding through f32); overflow gives ±Inf.
fn f64_to_f16(x: f64) -> u16 {
    let sign: u16 = if x.is_sign_negative() { 0x8000 } else { 0 };
    let a = x.abs();
    if a.is_nan() {
        return 0x7e00;
    }
    if a.is_infinite() {
        return sign | 0x7c00;
    }
    // Quantum of the binade `a` lies in (subnormals share 2^-24).
    let e = if a < 2f64.powi(-14) {
        -14
    } else {
        a.log2().floor() as i32
    };
    // log2 may be off by one near powers of two; fix it.
    let e = if a >= 2f64.powi(e + 1) {
        e + 1
    } else if a < 2f64.powi(e) && e > -14 {
        e - 1
    } else {
        e
    };
    let q = 2f64.powi(e.max(-14) - 10);
    let m = a / q; // exact: a power-of-two scale
    let mut r = m.round();
    if (m - m.trunc() - 0.5).abs() == 0.0 && r % 2.0 != 0.0 {
        r -= 1.0; // a tie rounds to even
    }
    // r·q is the rounded value; r may have carried into the next binade.
    let v = r * q;
    if v > 65504.0 {
        return sign | 0x7c00;
    }
    if v < 2f64.powi(-14) {
        return sign | (v / 2f64.powi(-24)) as u16; // subnormal or zero
    }
    let e2 = v.log2().floor() as i32;
    let e2 = if v >= 2f64.powi(e2 + 1) {
        e2 + 1
    } else if v < 2f64.powi(e2) {
        e2 - 1
    } else {
        e2
    };
    let frac = (v / 2f64.powi(e2 - 10)) as u16 - 1024;
    sign | (((e2 + 15) as u16) << 10) | frac
}

/// An array entry's name: `dir/`base`.[K.]`dtype.
#[derive(Clone, Debug, PartialEq)]
struct ArrayName {
    base: String,
    ncomp: usize,
    dtype: DType,
    /// The part after the base: `3.uint8`, `float16`.
    suffix: String,
}

/// Split `base.K.dtype` / `base.dtype`; the error says why.
fn parse_array_name(file_name: &str) -> Result<ArrayName, String> {
    let Some((rest, ext)) = file_name.rsplit_once('.') else {
        return Err(format!(
            "`{file_name}` has no `.dtype` extension (e.g. `.float32`)"
        ));
    };
    let dtype = DType::parse(ext).ok_or_else(|| {
        format!(
            "`{file_name}`: unknown dtype `{ext}`; TRX arrays are {}",
            DType::ALL.map(|d| d.name()).join(", ")
        )
    })?;
    let (base, ncomp) = match rest.rsplit_once('.') {
        Some((b, k)) if !k.is_empty() && k.bytes().all(|c| c.is_ascii_digit()) => {
            let n = k
                .parse::<usize>()
                .ok()
                .filter(|&n| (1..=1 << 16).contains(&n))
                .ok_or_else(|| {
                    format!("`{file_name}`: the component count {k} is not between 1 and 65536")
                })?;
            (b, n)
        }
        _ => (rest, 1),
    };
    if base.is_empty() {
        return Err(format!("`{file_name}` has an empty name"));
    }
    Ok(ArrayName {
        base: base.to_string(),
        ncomp,
        dtype,
        suffix: file_name[base.len() + 1..].to_string(),
    })
}

// ---------------------------------------------------------------- sources

/// Where an entry's bytes are.
#[derive(Clone, Debug)]
enum Loc {
    /// A file of the folder.
    File(PathBuf),
    /// Inside the zip: data offset, compressed size, deflated?, CRC-32.
    Zip {
        start: u64,
        csize: u64,
        deflated: bool,
        crc: u32,
    },
}

#[derive(Clone, Debug)]
struct Entry {
    /// Path inside the archive/folder, `/`-separated.
    name: String,
    /// Uncompressed size.
    size: u64,
    loc: Loc,
}

/// The archive or folder: its entries, and how to open one.
struct Source {
    path: PathBuf,
    entries: Vec<Entry>,
}

impl Source {
    fn open(path: &Path) -> Result<Self, IoError> {
        let md = std::fs::metadata(path).map_err(|e| IoError::os(path, "cannot open", e))?;
        let entries = if md.is_dir() {
            Self::folder_entries(path)?
        } else {
            Self::zip_entries(path, md.len())?
        };
        Ok(Source {
            path: path.to_path_buf(),
            entries,
        })
    }

    fn folder_entries(root: &Path) -> Result<Vec<Entry>, IoError> {
        let mut out = Vec::new();
        // header.json, positions, offsets at the top; arrays one level down
        // (dpv, dps, groups) or two (dpg/GROUP/).
        let mut stack = vec![(root.to_path_buf(), String::new(), 0)];
        while let Some((dir, prefix, depth)) = stack.pop() {
            let rd = std::fs::read_dir(&dir).map_err(|e| {
                IoError::os(
                    root,
                    &format!("cannot list the folder {}", dir.display()),
                    e,
                )
            })?;
            for ent in rd {
                let ent = ent.map_err(|e| IoError::os(root, "cannot list the folder", e))?;
                let name = ent.file_name().to_string_lossy().into_owned();
                let p = ent.path();
                let md = std::fs::metadata(&p)
                    .map_err(|e| IoError::os(root, &format!("cannot stat {prefix}{name}"), e))?;
                if md.is_dir() {
                    if depth < 2 {
                        stack.push((p, format!("{prefix}{name}/"), depth + 1));
                    }
                } else {
                    out.push(Entry {
                        name: format!("{prefix}{name}"),
                        size: md.len(),
                        loc: Loc::File(p),
                    });
                }
            }
        }
        Ok(out)
    }

    fn zip_entries(path: &Path, file_len: u64) -> Result<Vec<Entry>, IoError> {
        let file = File::open(path).map_err(|e| IoError::os(path, "cannot open", e))?;
        let mut zip = zip::ZipArchive::new(BufReader::new(file)).map_err(|e| {
            IoError::new(
                path,
                format!("not a TRX file: neither a folder nor a readable zip archive ({e})"),
            )
        })?;
        let mut out = Vec::with_capacity(zip.len().min(1 << 12));
        for i in 0..zip.len() {
            let f = zip.by_index_raw(i).map_err(|e| {
                IoError::new(path, format!("zip entry {i}: {e}")).at("zip central directory")
            })?;
            let name = f.name().to_string();
            if f.is_dir() {
                continue;
            }
            let bad = |why: String| {
                IoError::new(path, format!("zip entry `{name}`: {why}"))
                    .at(format!("byte {}", f.header_start()))
            };
            if f.encrypted() {
                return Err(bad("encrypted entries are not supported".into()));
            }
            let deflated = match f.compression() {
                zip::CompressionMethod::Stored => false,
                zip::CompressionMethod::Deflated => true,
                m => {
                    return Err(bad(format!(
                        "compression {m:?} is not supported (only stored and deflated)"
                    )))
                }
            };
            let (start, csize, size) = (f.data_start(), f.compressed_size(), f.size());
            if start.checked_add(csize).is_none_or(|end| end > file_len) {
                return Err(bad(format!(
                    "its {csize} bytes at byte {start} run past the end of the archive ({file_len} bytes; truncated?)"
                )));
            }
            if !deflated && csize != size {
                return Err(bad(format!(
                    "stored, but its sizes disagree ({csize} compressed, {size} not)"
                )));
            }
            if deflated && size / MAX_DEFLATE_RATIO > csize.max(1) {
                return Err(bad(format!(
                    "{size} bytes cannot inflate from {csize} deflated bytes (corrupt sizes)"
                )));
            }
            out.push(Entry {
                name,
                size,
                loc: Loc::Zip {
                    start,
                    csize,
                    deflated,
                    crc: f.crc32(),
                },
            });
        }
        Ok(out)
    }

    fn find(&self, name: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// A reader over `entry`'s uncompressed bytes, which fails (rather than
    /// ending early or running on) when they are not `entry.size`, and
    /// checks the CRC of zip entries after the last byte.
    fn stream(&self, entry: &Entry) -> Result<EntryReader, IoError> {
        let err = |e| IoError::os(&self.path, &format!("cannot read `{}`", entry.name), e);
        let (inner, crc): (Box<dyn Read + Send>, Option<u32>) = match &entry.loc {
            Loc::File(p) => (Box::new(File::open(p).map_err(err)?), None),
            Loc::Zip {
                start,
                csize,
                deflated,
                crc,
            } => {
                let mut f = File::open(&self.path).map_err(err)?;
                f.seek(SeekFrom::Start(*start)).map_err(err)?;
                let raw = BufReader::with_capacity(1 << 16, f).take(*csize);
                if *deflated {
                    (Box::new(flate2::read::DeflateDecoder::new(raw)), Some(*crc))
                } else {
                    (Box::new(raw), Some(*crc))
                }
            }
        };
        Ok(EntryReader {
            inner: BufReader::with_capacity(1 << 16, inner),
            name: entry.name.clone(),
            size: entry.size,
            done: 0,
            crc,
            hasher: crc32fast::Hasher::new(),
        })
    }
}

/// An entry's bytes, counted and checksummed.
struct EntryReader {
    inner: BufReader<Box<dyn Read + Send>>,
    name: String,
    size: u64,
    done: u64,
    crc: Option<u32>,
    hasher: crc32fast::Hasher,
}

impl EntryReader {
    /// Fill `buf` from the entry; the error says which entry and why.
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), String> {
        let want = buf.len() as u64;
        if self.size - self.done < want {
            return Err(format!(
                "`{}` ends after {} bytes (its announced size), {} short",
                self.name,
                self.size,
                want - (self.size - self.done)
            ));
        }
        let mut got = 0;
        while got < buf.len() {
            match self.inner.read(&mut buf[got..]) {
                Ok(0) => {
                    return Err(format!(
                        "`{}` is truncated: its data end after {} of {} bytes",
                        self.name,
                        self.done + got as u64,
                        self.size
                    ))
                }
                Ok(n) => got += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(format!(
                        "cannot read `{}` (corrupt data?) after {} bytes: {e}",
                        self.name,
                        self.done + got as u64
                    ))
                }
            }
        }
        self.hasher.update(buf);
        self.done += want;
        if self.done == self.size {
            if let Some(crc) = self.crc {
                let h = std::mem::take(&mut self.hasher).finalize();
                if h != crc {
                    return Err(format!(
                        "`{}` fails its CRC-32 check (corrupt data: {h:08x}, expected {crc:08x})",
                        self.name
                    ));
                }
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- reader

/// Open a TRX zip archive or folder: the header, entry list and offsets are
/// read and checked now, the streamlines as the iterator is driven.
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_trx;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-trx-open-{}.trx", std::process::id()));
/// std::fs::write(&path, "PK").unwrap();
/// let err = open_trx(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((err.path, err.at.as_deref()), (path, None));
/// assert!(err.reason.starts_with("not a TRX file"));
/// ```
///
/// # Format
///
/// TRX tractograms (tee-ar-ex, <https://github.com/tee-ar-ex/trx-spec>): a
/// zip archive (entries stored or deflated) or a plain folder holding
/// `header.json` (`VOXEL_TO_RASMM`, `DIMENSIONS`, `NB_VERTICES`,
/// `NB_STREAMLINES`), `positions.3.{float16,float32,float64}` (RAS+ mm,
/// little endian), `offsets.{uint32,uint64}`, and optionally `dpv/NAME.[K.]DTYPE`
/// (data per vertex), `dps/NAME.[K.]DTYPE` (data per streamline), `groups/`
/// and `dpg/` (data per group). An entry's name carries its component count
/// (`K`, 1 when absent) and its dtype.
///
/// Where the format leaves room, the reader decides:
/// - **Offsets**: trx-python (0.6) writes `NB_STREAMLINES + 1` offsets, the
///   last being `NB_VERTICES`, and requires that on load; the spec's text
///   describes `NB_STREAMLINES` start indices. Both are accepted (a sentinel,
///   when present, must equal `NB_VERTICES`). Offsets must start at 0, never
///   decrease and stay within `NB_VERTICES`; an error names the curve.
/// - **Streaming**: the offsets (8 bytes a streamline) are read at open; the
///   positions and each dpv/dps array are then streamed through a reader of
///   their own — for a zip, a separate file handle positioned at the entry's
///   data (found via the central directory), inflated on the fly for deflated
///   entries and CRC-checked when its last byte has been read. Nothing is
///   extracted to disk and memory does not grow with the file.
/// - Every array's size is checked against the header counts before anything
///   is read, and a deflated entry's announced size against the most deflate
///   can expand its compressed bytes, so no header count sizes an allocation.
/// - Points come out as stored (TRX positions are RAS+ mm already);
///   `VOXEL_TO_RASMM` and `DIMENSIONS` go to [`Metadata::vox_to_world`] and
///   [`Metadata::dimensions`]. dpv arrays become [`Curve::point_data`], dps
///   arrays [`Curve::curve_data`] (as f32: 64-bit integers or floats beyond
///   f32's precision lose it), an array of K > 1 components named `NAME_0`…
///   `NAME_{K-1}`, arrays in name order.
/// - [`Metadata::extra`] records the dtypes so that TRX → TRX writes the
///   same ones: `trx.positions_dtype`, `trx.offsets_dtype`, and
///   `trx.dpv.NAME` / `trx.dps.NAME` = the entry's suffix (`3.uint8`,
///   `float16`).
/// - **Groups** (`groups/NAME.DTYPE`, lists of streamline indices) become
///   per-curve values `group:NAME`, 1 for a member and 0 otherwise, after
///   the dps values; the writer turns such columns back into
///   `groups/NAME.uint32` entries, so TRX → TRX keeps them, and formats
///   with per-curve values (`.trk` properties, VTK cell data, JSON, the
///   container) carry the membership. Each group's membership is held as a
///   bit set (`NB_STREAMLINES / 8` bytes).
/// - **Data per group** (`dpg/GROUP/NAME.DTYPE`, a few values each) are
///   kept verbatim, hex-encoded in `extra` under `trx.entry.dpg/…` (at most
///   1 MiB an entry), and written back by the writer. Any other entry
///   outside the layout is not read: `trx.dropped` lists it.
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Ok(Box::new(TrxReader::open(path)?))
}

/// One streamed array (positions, a dpv or a dps array).
struct ArrayStream {
    r: EntryReader,
    dtype: DType,
    ncomp: usize,
    buf: Vec<u8>,
}

impl ArrayStream {
    /// `rows` rows of `ncomp` values, as f64, appended to `out`.
    fn rows(&mut self, rows: usize, out: &mut impl FnMut(f64)) -> Result<(), String> {
        let row = self.ncomp * self.dtype.size();
        // In pieces, so a curve of many points needs no big buffer at once.
        let mut left = rows;
        while left > 0 {
            let n = left.min(4096);
            self.buf.resize(n * row, 0);
            self.r.read_exact(&mut self.buf)?;
            for v in self.buf.chunks_exact(self.dtype.size()) {
                out(self.dtype.decode(v));
            }
            left -= n;
        }
        Ok(())
    }
}

struct TrxReader {
    path: PathBuf,
    meta: Metadata,
    /// `NB_STREAMLINES + 1` offsets, the last `NB_VERTICES`.
    offsets: Vec<u64>,
    positions: Option<ArrayStream>,
    dpv: Vec<ArrayStream>,
    dps: Vec<ArrayStream>,
    /// Membership of each group, a bit per streamline.
    groups: Vec<Vec<u64>>,
    index: u64,
    done: bool,
}

fn header_u64(
    path: &Path,
    h: &serde_json::Map<String, serde_json::Value>,
    key: &str,
) -> Result<u64, IoError> {
    let v = h.get(key).ok_or_else(|| {
        IoError::new(path, format!("header.json has no `{key}`")).at("header.json")
    })?;
    v.as_u64().ok_or_else(|| {
        IoError::new(
            path,
            format!("header.json `{key}` is {v}, not a non-negative whole number"),
        )
        .at(format!("header.json `{key}`"))
    })
}

impl TrxReader {
    fn open(path: &Path) -> Result<Self, IoError> {
        let src = Source::open(path)?;
        let err = |reason: String| IoError::new(path, reason);

        // header.json
        let he = src.find("header.json").ok_or_else(|| {
            err(format!(
                "not a TRX file: no `header.json` among its {} entries",
                src.entries.len()
            ))
        })?;
        if he.size > MAX_HEADER {
            return Err(err(format!(
                "header.json is {} bytes, more than the {MAX_HEADER} accepted",
                he.size
            ))
            .at("header.json"));
        }
        let mut text = vec![0u8; he.size as usize];
        src.stream(he)?
            .read_exact(&mut text)
            .map_err(|e| err(e).at("header.json"))?;
        let header: serde_json::Value = serde_json::from_slice(&text)
            .map_err(|e| err(format!("header.json is not valid JSON: {e}")).at("header.json"))?;
        let h = header
            .as_object()
            .ok_or_else(|| err("header.json is not a JSON object".into()).at("header.json"))?;
        let nb_vertices = header_u64(path, h, "NB_VERTICES")?;
        let nb_streamlines = header_u64(path, h, "NB_STREAMLINES")?;
        let mut meta = Metadata::new(Format::Trx);
        meta.count = Some(nb_streamlines);
        meta.units = Some("mm".into());
        if let Some(v) = h.get("VOXEL_TO_RASMM") {
            let bad = || {
                err(format!(
                    "header.json `VOXEL_TO_RASMM` is not a 4×4 array of numbers: {}",
                    snippet(&v.to_string())
                ))
                .at("header.json `VOXEL_TO_RASMM`")
            };
            let rows = v.as_array().filter(|r| r.len() == 4).ok_or_else(bad)?;
            let mut m = [[0.0f64; 4]; 4]; // m[row][col]
            for (i, r) in rows.iter().enumerate() {
                let r = r.as_array().filter(|r| r.len() == 4).ok_or_else(bad)?;
                for (j, x) in r.iter().enumerate() {
                    m[i][j] = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
                }
            }
            // glam is column-major: column j is (m[0][j], …, m[3][j]).
            meta.vox_to_world = DMat4::from_cols_array_2d(&[
                [m[0][0], m[1][0], m[2][0], m[3][0]],
                [m[0][1], m[1][1], m[2][1], m[3][1]],
                [m[0][2], m[1][2], m[2][2], m[3][2]],
                [m[0][3], m[1][3], m[2][3], m[3][3]],
            ]);
        }
        if let Some(v) = h.get("DIMENSIONS") {
            let bad = || {
                err(format!(
                    "header.json `DIMENSIONS` is not 3 whole numbers: {}",
                    snippet(&v.to_string())
                ))
                .at("header.json `DIMENSIONS`")
            };
            let a = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
            let mut d = [0u32; 3];
            for (d, x) in d.iter_mut().zip(a) {
                *d = x
                    .as_u64()
                    .and_then(|x| u32::try_from(x).ok())
                    .ok_or_else(bad)?;
            }
            meta.dimensions = Some(d);
        }

        // Sort the entries into their roles.
        let mut positions = None;
        let mut offsets = None;
        let mut dpv = Vec::new();
        let mut dps = Vec::new();
        let mut groups = Vec::new();
        let mut dropped = Vec::new();
        let mut entries: Vec<&Entry> = src.entries.iter().collect();
        entries.sort_by(|a, b| a.name.cmp(&b.name));
        for e in entries {
            if e.name == "header.json" {
                continue;
            }
            let (dir, file) = match e.name.rsplit_once('/') {
                Some((d, f)) => (d, f),
                None => ("", e.name.as_str()),
            };
            let role = match dir {
                "" if file.starts_with("positions.") => 'p',
                "" if file.starts_with("offsets.") => 'o',
                "dpv" => 'v',
                "dps" => 's',
                "groups" => 'g',
                d if d.starts_with("dpg/") && e.size <= MAX_DPG_ENTRY => {
                    let mut bytes = vec![0u8; e.size as usize];
                    src.stream(e)?
                        .read_exact(&mut bytes)
                        .map_err(|m| err(m).at(format!("entry `{}`", e.name)))?;
                    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
                    meta.extra.push((format!("trx.entry.{}", e.name), hex));
                    continue;
                }
                _ => {
                    dropped.push(e.name.clone());
                    continue;
                }
            };
            let an =
                parse_array_name(file).map_err(|r| err(r).at(format!("entry `{}`", e.name)))?;
            match role {
                'p' => {
                    if positions.replace((e, an)).is_some() {
                        return Err(err("more than one `positions` array".into()));
                    }
                }
                'o' => {
                    if offsets.replace((e, an)).is_some() {
                        return Err(err("more than one `offsets` array".into()));
                    }
                }
                'v' => dpv.push((e, an)),
                'g' => groups.push((e, an)),
                _ => dps.push((e, an)),
            }
        }

        // Sizes against the header counts, before anything is read.
        let check_size = |e: &Entry, an: &ArrayName, rows: u64, what: &str| {
            let want = rows
                .checked_mul((an.ncomp * an.dtype.size()) as u64)
                .filter(|&w| w == e.size);
            match want {
                Some(_) => Ok(()),
                None => Err(err(format!(
                    "`{}` holds {} bytes, but {rows} {what} × {} × {} bytes ({}) need {}",
                    e.name,
                    e.size,
                    an.ncomp,
                    an.dtype.size(),
                    an.dtype.name(),
                    rows.checked_mul((an.ncomp * an.dtype.size()) as u64)
                        .map_or("more than 2^64".to_string(), |w| w.to_string())
                ))
                .at(format!("entry `{}`", e.name))),
            }
        };

        let (offsets, positions) = match (offsets, positions) {
            (None, None) if nb_streamlines == 0 && nb_vertices == 0 => (vec![0], None),
            (None, _) => return Err(err("no `offsets` array".into())),
            (_, None) => return Err(err("no `positions` array".into())),
            (Some((oe, oa)), Some((pe, pa))) => {
                if pa.ncomp != 3 || !pa.dtype.is_float() {
                    return Err(err(format!(
                        "`{}`: positions must be 3 floats a vertex (positions.3.float16/32/64)",
                        pe.name
                    ))
                    .at(format!("entry `{}`", pe.name)));
                }
                check_size(pe, &pa, nb_vertices, "vertices (NB_VERTICES)")?;
                if oa.ncomp != 1
                    || !matches!(oa.dtype, DType::U32 | DType::U64 | DType::I32 | DType::I64)
                {
                    return Err(err(format!(
                        "`{}`: offsets must be one uint32/uint64 a streamline",
                        oe.name
                    ))
                    .at(format!("entry `{}`", oe.name)));
                }
                let w = oa.dtype.size() as u64;
                let n = if nb_streamlines.checked_add(1).and_then(|n| n.checked_mul(w))
                    == Some(oe.size)
                {
                    nb_streamlines + 1
                } else {
                    check_size(oe, &oa, nb_streamlines, "streamlines (NB_STREAMLINES)").map_err(
                        |e| IoError {
                            reason: format!(
                                "{} (or one more, with the NB_VERTICES sentinel)",
                                e.reason
                            ),
                            ..e
                        },
                    )?;
                    nb_streamlines
                };
                let offsets = read_offsets(&src, oe, oa.dtype, n, nb_streamlines, nb_vertices)?;
                meta.extra
                    .push(("trx.positions_dtype".into(), pa.dtype.name().into()));
                meta.extra
                    .push(("trx.offsets_dtype".into(), oa.dtype.name().into()));
                let ps = ArrayStream {
                    r: src.stream(pe)?,
                    dtype: pa.dtype,
                    ncomp: 3,
                    buf: Vec::new(),
                };
                (offsets, Some(ps))
            }
        };

        let mut streams = |arrays: Vec<(&Entry, ArrayName)>,
                           rows: u64,
                           what: &str,
                           kind: &str,
                           names: &mut Vec<String>|
         -> Result<Vec<ArrayStream>, IoError> {
            let mut out = Vec::new();
            for (e, an) in arrays {
                check_size(e, &an, rows, what)?;
                if an.ncomp == 1 {
                    names.push(an.base.clone());
                } else {
                    names.extend((0..an.ncomp).map(|c| format!("{}_{c}", an.base)));
                }
                meta.extra
                    .push((format!("trx.{kind}.{}", an.base), an.suffix.clone()));
                out.push(ArrayStream {
                    r: src.stream(e)?,
                    dtype: an.dtype,
                    ncomp: an.ncomp,
                    buf: Vec::new(),
                });
            }
            Ok(out)
        };
        let mut pnames = Vec::new();
        let mut cnames = Vec::new();
        let dpv = streams(
            dpv,
            nb_vertices,
            "vertices (NB_VERTICES)",
            "dpv",
            &mut pnames,
        )?;
        let dps = streams(
            dps,
            nb_streamlines,
            "streamlines (NB_STREAMLINES)",
            "dps",
            &mut cnames,
        )?;
        let mut members = Vec::with_capacity(groups.len());
        for (e, an) in groups {
            members.push(read_group(&src, e, &an, nb_streamlines)?);
            cnames.push(format!("{GROUP_PREFIX}{}", an.base));
        }
        meta.point_data_names = pnames;
        meta.curve_data_names = cnames;
        if !dropped.is_empty() {
            meta.extra.push(("trx.dropped".into(), dropped.join(", ")));
        }
        Ok(TrxReader {
            path: path.to_path_buf(),
            meta,
            offsets,
            positions,
            dpv,
            dps,
            groups: members,
            index: 0,
            done: false,
        })
    }

    fn read_curve(&mut self) -> Result<Option<Curve>, IoError> {
        let i = self.index as usize;
        if i + 1 >= self.offsets.len() {
            return Ok(None);
        }
        let err = |r: String| IoError::new(&self.path, r).curve(i as u64);
        let n = (self.offsets[i + 1] - self.offsets[i]) as usize;
        let mut curve = Curve::default();
        if let Some(ps) = &mut self.positions {
            let mut xyz = Vec::with_capacity(3 * n.min(1 << 16));
            ps.rows(n, &mut |x| xyz.push(x)).map_err(err)?;
            curve.points = xyz
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect();
        }
        if !self.dpv.is_empty() {
            // Row-major per point: gather each array, then interleave.
            let width = self.meta.point_data_names.len();
            let mut cols: Vec<Vec<f32>> = Vec::with_capacity(self.dpv.len());
            for s in &mut self.dpv {
                let mut v = Vec::with_capacity(s.ncomp * n.min(1 << 16));
                s.rows(n, &mut |x| v.push(x as f32)).map_err(err)?;
                cols.push(v);
            }
            curve.point_data = Vec::with_capacity(n * width);
            for p in 0..n {
                for (s, c) in self.dpv.iter().zip(&cols) {
                    curve
                        .point_data
                        .extend_from_slice(&c[p * s.ncomp..(p + 1) * s.ncomp]);
                }
            }
        }
        for s in &mut self.dps {
            s.rows(1, &mut |x| curve.curve_data.push(x as f32))
                .map_err(err)?;
        }
        for g in &self.groups {
            let member = g[i / 64] >> (i % 64) & 1 == 1;
            curve.curve_data.push(if member { 1.0 } else { 0.0 });
        }
        self.index += 1;
        Ok(Some(curve))
    }
}

/// A group's members (`groups/NAME.DTYPE`: streamline indices, one integer
/// each) as a bit set over the streamlines.
fn read_group(
    src: &Source,
    e: &Entry,
    an: &ArrayName,
    nb_streamlines: u64,
) -> Result<Vec<u64>, IoError> {
    let bad = |why: String| IoError::new(&src.path, why).at(format!("entry `{}`", e.name));
    if an.ncomp != 1 || an.dtype.is_float() {
        return Err(bad(
            "a group must be one integer (a streamline index) a member".into(),
        ));
    }
    let w = an.dtype.size() as u64;
    if !e.size.is_multiple_of(w) || e.size / w > nb_streamlines {
        return Err(bad(format!(
            "{} bytes are not whole {} indices, or list more members than the {nb_streamlines} streamlines",
            e.size,
            an.dtype.name()
        )));
    }
    let mut bits = vec![0u64; (nb_streamlines as usize).div_ceil(64)];
    let mut r = src.stream(e)?;
    let mut buf = vec![0u8; 8192 * w as usize];
    let mut left = e.size / w;
    while left > 0 {
        let k = left.min(8192) as usize;
        r.read_exact(&mut buf[..k * w as usize]).map_err(bad)?;
        for b in buf[..k * w as usize].chunks_exact(w as usize) {
            let v = an.dtype.decode(b);
            if !(v >= 0.0 && v < nb_streamlines as f64) {
                return Err(bad(format!(
                    "member {v} is not a streamline index (0 to {})",
                    nb_streamlines.saturating_sub(1)
                )));
            }
            let i = v as usize;
            bits[i / 64] |= 1 << (i % 64);
        }
        left -= k as u64;
    }
    Ok(bits)
}

/// Read and check `n` offsets (with the sentinel appended when the file has
/// none): starting at 0, non-decreasing, within `nb_vertices`.
fn read_offsets(
    src: &Source,
    e: &Entry,
    dtype: DType,
    n: u64,
    nb_streamlines: u64,
    nb_vertices: u64,
) -> Result<Vec<u64>, IoError> {
    let path = &src.path;
    let mut r = src.stream(e)?;
    let w = dtype.size();
    let mut out: Vec<u64> = Vec::new();
    let mut buf = vec![0u8; w * 8192];
    let mut left = n;
    while left > 0 {
        let k = left.min(8192) as usize;
        r.read_exact(&mut buf[..k * w])
            .map_err(|m| IoError::new(path, m).at(format!("entry `{}`", e.name)))?;
        for b in buf[..k * w].chunks_exact(w) {
            let i = out.len() as u64;
            let v = match dtype {
                DType::U32 => u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DType::I32 => {
                    let v = i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                    u64::try_from(v).unwrap_or(u64::MAX)
                }
                DType::I64 => {
                    let v = i64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
                    u64::try_from(v).unwrap_or(u64::MAX)
                }
                _ => u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
            };
            // Value i ends curve i - 1 (and starts curve i): a bad value
            // is about the curve it ends, or curve 0 for the first.
            let bad = |why: String| {
                IoError::new(path, why)
                    .at(format!("{} value {i}", e.name))
                    .curve(i.saturating_sub(1).min(nb_streamlines.saturating_sub(1)))
            };
            if i == 0 && v != 0 {
                return Err(bad(format!("the first offset is {v}, not 0")));
            }
            if let Some(&prev) = out.last() {
                if v < prev {
                    return Err(bad(format!(
                        "offsets decrease ({v} after {prev}): the streamline would end before it starts"
                    )));
                }
            }
            if v > nb_vertices {
                return Err(bad(format!(
                    "offset {v} lies past the end of the {nb_vertices} vertices (NB_VERTICES)"
                )));
            }
            if i == nb_streamlines && v != nb_vertices {
                return Err(bad(format!(
                    "the last offset (the sentinel) is {v}, not NB_VERTICES = {nb_vertices}"
                )));
            }
            out.push(v);
        }
        left -= k as u64;
    }
    if out.len() as u64 == nb_streamlines {
        out.push(nb_vertices);
    }
    Ok(out)
}

/// At most 60 characters of `s`, for error messages.
fn snippet(s: &str) -> String {
    const N: usize = 60;
    if s.chars().count() <= N {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(N).collect::<String>())
    }
}

impl Iterator for TrxReader {
    type Item = Result<Curve, IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read_curve();
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for TrxReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

// ---------------------------------------------------------------- writer

/// One dpv/dps array the writer produces: entry name, dtype, components,
/// and the spool of its encoded values.
struct OutArray {
    entry: String,
    dtype: DType,
    ncomp: usize,
    spool: Spool,
}

/// Group `names` into arrays: `X_0…X_{K-1}` become one K-component array
/// `X` when `extra` says `trx.KIND.X` = `K.dtype` (a TRX source); any other
/// name is a one-component array of its recorded dtype, float32 otherwise.
fn plan_arrays(
    path: &Path,
    meta: &Metadata,
    names: &[String],
    kind: &str,
) -> Result<Vec<(String, DType, usize)>, IoError> {
    let recorded = |base: &str| -> Option<ArrayName> {
        if meta.format != Format::Trx {
            return None;
        }
        let suffix = meta.extra(&format!("trx.{kind}.{base}"))?;
        parse_array_name(&format!("{base}.{suffix}")).ok()
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < names.len() {
        let name = &names[i];
        let grouped = name.rsplit_once('_').and_then(|(base, _)| {
            let an = recorded(base)?;
            let k = an.ncomp;
            (k > 1 && i + k <= names.len() && (0..k).all(|c| names[i + c] == format!("{base}_{c}")))
                .then_some(an)
        });
        // `x[0]`, `x[1]`, … (the .trk reader's names for the components of
        // one property) are one array whatever the source.
        let bracketed = name.strip_suffix("[0]").and_then(|base| {
            let k = (0..names.len() - i)
                .take_while(|&c| names[i + c] == format!("{base}[{c}]"))
                .count();
            (k > 1).then(|| (base.to_string(), k))
        });
        let (base, dtype, k) = match (grouped, bracketed) {
            (Some(an), _) => (an.base, an.dtype, an.ncomp),
            (None, Some((base, k))) => (base, DType::F32, k),
            (None, None) => {
                let dtype = recorded(name)
                    .filter(|an| an.ncomp == 1)
                    .map_or(DType::F32, |an| an.dtype);
                (name.clone(), dtype, 1)
            }
        };
        if base.is_empty() || base.contains(['/', '\\', '\0']) || base.starts_with('.') {
            return Err(IoError::new(
                path,
                format!("{kind} name {base:?} cannot be a TRX entry name"),
            ));
        }
        let entry = if k == 1 {
            format!("{kind}/{base}.{}", dtype.name())
        } else {
            format!("{kind}/{base}.{k}.{}", dtype.name())
        };
        if out
            .iter()
            .any(|(e, _, _): &(String, DType, usize)| e == &entry)
        {
            return Err(IoError::new(
                path,
                format!("two {kind} arrays named `{base}`"),
            ));
        }
        out.push((entry, dtype, k));
        i += k;
    }
    Ok(out)
}

/// Create a TRX writer (a stored zip). A TRX source's dtypes are kept (see
/// [Output](create#output)); other sources get float32 throughout.
///
/// Per-point values travel with the points:
///
/// ```
/// use strandfit::io::{create_trx, open_trx, Curve, CurveReader, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-trx-create-{}.trx", std::process::id()));
/// let mut meta = Metadata::new(Format::Tck);
/// meta.point_data_names = vec!["fa".into()];
/// let curve = Curve { point_data: vec![0.25, 0.5], ..Curve::from_points(vec![DVec3::ZERO, DVec3::X]) };
/// let mut w = create_trx(&path, &meta).unwrap();
/// w.write_curve(&curve).unwrap();
/// w.finish().unwrap();
/// let reader = open_trx(&path).unwrap();
/// assert_eq!(reader.metadata().point_data_names, ["fa"]);
/// let curves: Vec<Curve> = reader.collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((curves[0].points[1], &curves[0].point_data[..]), (DVec3::X, &[0.25f32, 0.5][..]));
/// ```
///
/// # Output
///
/// The writer spools positions, lengths and data to unnamed temporary files
/// (counts are known only at the end) and assembles a **stored**
/// (uncompressed) zip in [`finish`](CurveWriter::finish), as trx-python does
/// by default: stored entries can be memory-mapped by other readers. It
/// writes float32 positions (float16/float64 when the source TRX had them),
/// uint32 offsets with the `NB_VERTICES` sentinel (as trx-python does;
/// uint64 when the source had them or the vertices do not fit), and dpv/dps
/// arrays in the source TRX dtypes (float32 otherwise). An empty tractogram
/// is `header.json` alone, as trx-python writes it.
pub fn create(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    let from_trx = meta.format == Format::Trx;
    let recorded = |key: &str| -> Option<String> {
        if from_trx {
            meta.extra(key).map(String::from)
        } else {
            None
        }
    };
    let pos_dtype = match recorded("trx.positions_dtype") {
        Some(s) => DType::parse(&s).filter(|d| d.is_float()).ok_or_else(|| {
            IoError::new(
                path,
                format!("trx.positions_dtype {s:?} is not float16/32/64"),
            )
        })?,
        None => DType::F32,
    };
    let wide_offsets = recorded("trx.offsets_dtype").as_deref() == Some("uint64");
    // Per-curve values named `group:NAME` are groups, the rest dps arrays.
    let (group_cols, dps_cols): (Vec<usize>, Vec<usize>) = (0..meta.curve_data_names.len())
        .partition(|&c| meta.curve_data_names[c].starts_with(GROUP_PREFIX));
    let dps_names: Vec<String> = dps_cols
        .iter()
        .map(|&c| meta.curve_data_names[c].clone())
        .collect();
    let mut groups = Vec::with_capacity(group_cols.len());
    for &c in &group_cols {
        let base = &meta.curve_data_names[c][GROUP_PREFIX.len()..];
        if base.is_empty() || base.contains(['/', '\\', '\0']) || base.starts_with('.') {
            return Err(IoError::new(
                path,
                format!("group name {base:?} cannot be a TRX entry name"),
            ));
        }
        groups.push(OutGroup {
            entry: format!("groups/{base}.uint32"),
            column: c,
            members: Spool::new(path)?,
            count: 0,
        });
    }
    let verbatim: Vec<(String, Vec<u8>)> = meta
        .extra
        .iter()
        .filter_map(|(k, v)| {
            let name = k.strip_prefix("trx.entry.")?;
            let bytes = (0..v.len() / 2)
                .map(|i| u8::from_str_radix(v.get(2 * i..2 * i + 2)?, 16).ok())
                .collect::<Option<Vec<u8>>>()?;
            (name.starts_with("dpg/") && !name.contains("..")).then(|| (name.to_string(), bytes))
        })
        .collect();
    let mut arrays = Vec::new();
    for (kind, names) in [("dpv", &meta.point_data_names), ("dps", &dps_names)] {
        for (entry, dtype, ncomp) in plan_arrays(path, meta, names, kind)? {
            arrays.push((
                kind == "dpv",
                OutArray {
                    entry,
                    dtype,
                    ncomp,
                    spool: Spool::new(path)?,
                },
            ));
        }
    }
    let (dpv, dps) = arrays.into_iter().partition::<Vec<_>, _>(|(v, _)| *v);
    Ok(Box::new(TrxWriter {
        path: path.to_path_buf(),
        vox_to_world: meta.vox_to_world,
        dimensions: meta.dimensions.unwrap_or([1, 1, 1]),
        pos_dtype,
        wide_offsets,
        positions: Spool::new(path)?,
        lengths: Spool::new(path)?,
        dpv: dpv.into_iter().map(|(_, a)| a).collect(),
        dps: dps.into_iter().map(|(_, a)| a).collect(),
        dps_cols,
        groups,
        verbatim,
        n_point_data: meta.point_data_names.len(),
        n_curve_data: meta.curve_data_names.len(),
        count: 0,
        vertices: 0,
        buf: Vec::new(),
    }))
}

/// A group the writer produces from a `group:NAME` per-curve column: the
/// indices of the curves whose value is non-zero, as uint32.
struct OutGroup {
    entry: String,
    column: usize,
    members: Spool,
    count: u64,
}

struct TrxWriter {
    path: PathBuf,
    vox_to_world: DMat4,
    dimensions: [u32; 3],
    pos_dtype: DType,
    wide_offsets: bool,
    positions: Spool,
    /// Streamline lengths, u64 LE.
    lengths: Spool,
    dpv: Vec<OutArray>,
    dps: Vec<OutArray>,
    /// The per-curve columns that feed `dps`, in order.
    dps_cols: Vec<usize>,
    groups: Vec<OutGroup>,
    /// `dpg/` entries carried from a TRX source, written as they were.
    verbatim: Vec<(String, Vec<u8>)>,
    n_point_data: usize,
    n_curve_data: usize,
    count: u64,
    vertices: u64,
    buf: Vec<u8>,
}

impl CurveWriter for TrxWriter {
    fn write_curve(&mut self, curve: &Curve) -> Result<(), IoError> {
        let index = self.count;
        let err = |r: String| IoError::new(&self.path, r).curve(index);
        let n = curve.points.len();
        if curve.point_data.len() != n * self.n_point_data {
            return Err(err(format!(
                "{} per-point values for {n} points × {} names",
                curve.point_data.len(),
                self.n_point_data
            )));
        }
        if curve.curve_data.len() != self.n_curve_data {
            return Err(err(format!(
                "{} per-curve values for {} names",
                curve.curve_data.len(),
                self.n_curve_data
            )));
        }
        self.buf.clear();
        for (j, p) in curve.points.iter().enumerate() {
            for x in p.to_array() {
                if !x.is_finite() {
                    return Err(err(format!("point {j} ({p}) is not finite")));
                }
                self.pos_dtype.encode(x, &mut self.buf).ok_or_else(|| {
                    err(format!(
                        "point {j} ({p}) does not fit in {}",
                        self.pos_dtype.name()
                    ))
                })?;
            }
        }
        self.positions.write(&self.buf)?;
        // Data: column `col` of the row-major values feeds array `a`.
        let mut col = 0;
        for a in &mut self.dpv {
            self.buf.clear();
            for j in 0..n {
                for c in 0..a.ncomp {
                    let x = curve.point_data[j * self.n_point_data + col + c];
                    a.dtype.encode(f64::from(x), &mut self.buf).ok_or_else(|| {
                        IoError::new(
                            &self.path,
                            format!(
                                "point {j}: value {x} of `{}` does not fit its dtype",
                                a.entry
                            ),
                        )
                        .curve(index)
                    })?;
                }
            }
            a.spool.write(&self.buf)?;
            col += a.ncomp;
        }
        let mut col = 0;
        for a in &mut self.dps {
            self.buf.clear();
            for c in 0..a.ncomp {
                let x = curve.curve_data[self.dps_cols[col + c]];
                a.dtype.encode(f64::from(x), &mut self.buf).ok_or_else(|| {
                    IoError::new(
                        &self.path,
                        format!("value {x} of `{}` does not fit its dtype", a.entry),
                    )
                    .curve(index)
                })?;
            }
            a.spool.write(&self.buf)?;
            col += a.ncomp;
        }
        for g in &mut self.groups {
            let v = curve.curve_data[g.column];
            if v != 0.0 && !v.is_nan() {
                let i = u32::try_from(index).map_err(|_| {
                    err(format!(
                        "a member of `{}` beyond the 2^32 streamlines a uint32 group can name",
                        g.entry
                    ))
                })?;
                g.members.write(&i.to_le_bytes())?;
                g.count += 1;
            }
        }
        self.lengths.write(&(n as u64).to_le_bytes())?;
        self.count += 1;
        self.vertices += n as u64;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), IoError> {
        let w = *self;
        let path = w.path.clone();
        let zerr =
            |e: zip::result::ZipError| IoError::new(&path, format!("cannot write the zip: {e}"));
        let m = w.vox_to_world.to_cols_array_2d(); // m[col][row]
        let rows: Vec<Vec<f64>> = (0..4).map(|r| (0..4).map(|c| m[c][r]).collect()).collect();
        let header = serde_json::json!({
            "DIMENSIONS": w.dimensions,
            "VOXEL_TO_RASMM": rows,
            "NB_VERTICES": w.vertices,
            "NB_STREAMLINES": w.count,
        });
        let wide = w.wide_offsets || w.vertices > u64::from(u32::MAX);
        let out = AtomicFile::create(&path)?;
        let mut zip = zip::ZipWriter::new(out);
        let opts = |size: u64| {
            zip::write::SimpleFileOptions::default()
                .compression_method(zip::CompressionMethod::Stored)
                .large_file(size >= u64::from(u32::MAX))
        };
        let head = header.to_string();
        zip.start_file("header.json", opts(head.len() as u64))
            .map_err(zerr)?;
        zip.write_all(head.as_bytes())
            .map_err(|e| IoError::os(&path, "cannot write", e))?;
        if w.count > 0 && w.vertices > 0 {
            let psize = w.vertices * 3 * w.pos_dtype.size() as u64;
            zip.start_file(format!("positions.3.{}", w.pos_dtype.name()), opts(psize))
                .map_err(zerr)?;
            w.positions.copy_into(&mut zip)?;
            let odt = if wide { DType::U64 } else { DType::U32 };
            zip.start_file(
                format!("offsets.{}", odt.name()),
                opts((w.count + 1) * odt.size() as u64),
            )
            .map_err(zerr)?;
            let mut at = 0u64;
            let mut obuf = Vec::new();
            w.lengths.for_each_chunk(8, |c| {
                obuf.clear();
                for b in c.chunks_exact(8) {
                    // Little endian: the low 4 bytes are the uint32 (`wide`
                    // whenever an offset could exceed it).
                    obuf.extend_from_slice(&at.to_le_bytes()[..odt.size()]);
                    at += u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
                }
                zip.write_all(&obuf)
                    .map_err(|e| IoError::os(&path, "cannot write", e))
            })?;
            zip.write_all(&at.to_le_bytes()[..odt.size()])
                .map_err(|e| IoError::os(&path, "cannot write", e))?;
            for (rows, arrays) in [(w.vertices, w.dpv), (w.count, w.dps)] {
                for a in arrays {
                    let size = rows * (a.ncomp * a.dtype.size()) as u64;
                    zip.start_file(a.entry.as_str(), opts(size)).map_err(zerr)?;
                    a.spool.copy_into(&mut zip)?;
                }
            }
            for g in w.groups {
                zip.start_file(g.entry.as_str(), opts(4 * g.count))
                    .map_err(zerr)?;
                g.members.copy_into(&mut zip)?;
            }
            for (name, bytes) in &w.verbatim {
                zip.start_file(name.as_str(), opts(bytes.len() as u64))
                    .map_err(zerr)?;
                zip.write_all(bytes)
                    .map_err(|e| IoError::os(&path, "cannot write", e))?;
            }
        }
        let out = zip.finish().map_err(zerr)?;
        out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_conversions_agree_with_ieee() {
        // Every finite half round-trips exactly.
        for h in 0u16..=0xffff {
            let f = f16_to_f32(h);
            if f.is_nan() {
                continue;
            }
            let back = f64_to_f16(f64::from(f));
            let same = back == h || (f == 0.0 && back & 0x7fff == 0);
            assert!(same, "{h:04x} -> {f} -> {back:04x}");
        }
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_to_f32(0xc000), -2.0);
        // Ties to even: 1 + 2^-11 lies halfway between 1 and 1 + 2^-10.
        assert_eq!(f64_to_f16(1.0 + 2f64.powi(-11)), 0x3c00);
        assert_eq!(f64_to_f16(1.0 + 3.0 * 2f64.powi(-11)), 0x3c02);
        assert_eq!(f64_to_f16(1.0 + 2f64.powi(-11) + 1e-9), 0x3c01);
        assert_eq!(f64_to_f16(65519.0), 0x7bff);
        assert_eq!(f64_to_f16(65520.0), 0x7c00);
        assert_eq!(f64_to_f16(-1e-9), 0x8000);
        assert!(f16_to_f32(f64_to_f16(f64::NAN)).is_nan());
    }

    #[test]
    fn array_names_parse() {
        let a = parse_array_name("color.3.uint8").unwrap();
        assert_eq!((a.base.as_str(), a.ncomp, a.dtype), ("color", 3, DType::U8));
        assert_eq!(a.suffix, "3.uint8");
        let a = parse_array_name("fa.float32").unwrap();
        assert_eq!(
            (a.base.as_str(), a.ncomp, a.suffix.as_str()),
            ("fa", 1, "float32")
        );
        let a = parse_array_name("my.fa.float16").unwrap();
        assert_eq!((a.base.as_str(), a.ncomp), ("my.fa", 1));
        let e = parse_array_name("fa.complex64").unwrap_err();
        assert!(e.contains("unknown dtype `complex64`"), "{e}");
        assert!(parse_array_name("fa").is_err());
        assert!(parse_array_name(".float32").is_err());
        assert!(parse_array_name("x.0.float32").is_err());
    }

    #[test]
    fn dtype_encode_checks_range() {
        let mut v = Vec::new();
        assert!(DType::U8.encode(255.0, &mut v).is_some());
        assert!(DType::U8.encode(256.0, &mut v).is_none());
        assert!(DType::U8.encode(-1.0, &mut v).is_none());
        assert!(DType::I16.encode(1.5, &mut v).is_none());
        assert!(DType::I32.encode(f64::NAN, &mut v).is_none());
        assert!(DType::F16.encode(1e6, &mut v).is_none());
        assert!(DType::F32.encode(1e300, &mut v).is_none());
        for d in DType::ALL {
            let x = if matches!(d, DType::U8 | DType::U16 | DType::U32 | DType::U64) {
                7.0
            } else {
                -3.0
            };
            v.clear();
            d.encode(x, &mut v).unwrap();
            assert_eq!(v.len(), d.size());
            assert_eq!(d.decode(&v), x, "{}", d.name());
        }
    }

    #[test]
    fn plan_groups_recorded_components() {
        let mut meta = Metadata::new(Format::Trx);
        meta.extra.push(("trx.dpv.color".into(), "3.uint8".into()));
        meta.extra.push(("trx.dpv.fa".into(), "float16".into()));
        let names: Vec<String> = ["color_0", "color_1", "color_2", "fa", "other"]
            .map(String::from)
            .to_vec();
        let p = plan_arrays(Path::new("x.trx"), &meta, &names, "dpv").unwrap();
        assert_eq!(
            p,
            vec![
                ("dpv/color.3.uint8".to_string(), DType::U8, 3),
                ("dpv/fa.float16".to_string(), DType::F16, 1),
                ("dpv/other.float32".to_string(), DType::F32, 1),
            ]
        );
        // Not a TRX source: everything float32, one component…
        meta.format = Format::Vtk;
        let p = plan_arrays(Path::new("x.trx"), &meta, &names, "dpv").unwrap();
        assert_eq!(p.len(), 5);
        assert!(p.iter().all(|(_, d, k)| *d == DType::F32 && *k == 1));
        // … except the .trk reader's `x[c]` components.
        let names: Vec<String> = ["c[0]", "c[1]", "c[2]", "d[0]", "e[1]"]
            .map(String::from)
            .to_vec();
        let p = plan_arrays(Path::new("x.trx"), &meta, &names, "dps").unwrap();
        let entries: Vec<&str> = p.iter().map(|(e, _, _)| e.as_str()).collect();
        assert_eq!(
            entries,
            ["dps/c.3.float32", "dps/d[0].float32", "dps/e[1].float32"]
        );
    }
}
