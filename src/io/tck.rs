//! MRtrix `.tck` tractograms: the reader and the writer. The format and
//! what the reader makes of it are described on `open` (`io::open_tck`),
//! what the writer writes on `create` (`io::create_tck`).

use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::bytes::{ByteSource, Endian};
use super::format::Format;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, IoError, Metadata};

const MAGIC: &str = "mrtrix tracks";
/// Longest header line accepted (MRtrix `command_history` lines are long,
/// but not this long); a binary file fails here fast.
const MAX_LINE: usize = 1 << 20;
/// Triplets per buffered read.
const CHUNK_TRIPLETS: usize = 4096;
/// Digits of the `count` field the writer patches at the end.
const COUNT_DIGITS: usize = 10;

/// The four `datatype`s MRtrix writes for tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct DataType {
    wide: bool,
    endian: Endian,
}

impl DataType {
    const DEFAULT: DataType = DataType {
        wide: false,
        endian: Endian::Little,
    };

    fn parse(s: &str) -> Option<DataType> {
        let (wide, endian) = match s {
            "Float32LE" => (false, Endian::Little),
            "Float32BE" => (false, Endian::Big),
            "Float64LE" => (true, Endian::Little),
            "Float64BE" => (true, Endian::Big),
            _ => return None,
        };
        Some(DataType { wide, endian })
    }

    fn name(self) -> &'static str {
        match (self.wide, self.endian) {
            (false, Endian::Little) => "Float32LE",
            (false, Endian::Big) => "Float32BE",
            (true, Endian::Little) => "Float64LE",
            (true, Endian::Big) => "Float64BE",
        }
    }

    fn triplet_bytes(self) -> usize {
        if self.wide {
            24
        } else {
            12
        }
    }

    /// One triplet from exactly `triplet_bytes()` bytes.
    fn decode(self, b: &[u8]) -> [f64; 3] {
        let mut v = [0.0; 3];
        if self.wide {
            for (v, c) in v.iter_mut().zip(b.chunks_exact(8)) {
                let a = [c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]];
                *v = match self.endian {
                    Endian::Little => f64::from_le_bytes(a),
                    Endian::Big => f64::from_be_bytes(a),
                };
            }
        } else {
            for (v, c) in v.iter_mut().zip(b.chunks_exact(4)) {
                let a = [c[0], c[1], c[2], c[3]];
                *v = f64::from(match self.endian {
                    Endian::Little => f32::from_le_bytes(a),
                    Endian::Big => f32::from_be_bytes(a),
                });
            }
        }
        v
    }

    /// Append a triplet; `None` if a value does not fit the type (f32
    /// overflow), so the caller can say which point.
    fn encode(self, v: [f64; 3], out: &mut Vec<u8>) -> Option<()> {
        for x in v {
            if self.wide {
                out.extend_from_slice(&match self.endian {
                    Endian::Little => x.to_le_bytes(),
                    Endian::Big => x.to_be_bytes(),
                });
            } else {
                let f = x as f32;
                if f.is_infinite() && !x.is_infinite() {
                    return None;
                }
                out.extend_from_slice(&match self.endian {
                    Endian::Little => f.to_le_bytes(),
                    Endian::Big => f.to_be_bytes(),
                });
            }
        }
        Some(())
    }
}

/// At most `n` characters of a header line, for error messages.
fn snippet(s: &str) -> String {
    const N: usize = 60;
    if s.chars().count() <= N {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(N).collect::<String>())
    }
}

/// Open a `.tck` file: the header is read and checked now, the streamlines
/// as the iterator is driven.
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_tck;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-tck-open-{}.tck", std::process::id()));
/// std::fs::write(&path, "not a tck\n").unwrap();
/// let err = open_tck(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((err.path, err.at.as_deref()), (path, Some("byte 0")));
/// assert!(err.reason.starts_with("not an MRtrix .tck file"));
/// ```
///
/// # Format
///
/// MRtrix `.tck` tractograms: a text header (`mrtrix tracks`, `key: value`
/// lines, `END`), then coordinate triplets from the byte offset named in
/// `file: . OFFSET`. A NaN triplet ends each streamline and an Inf triplet
/// ends the data. Coordinates are RAS+ millimetres already, so they pass
/// through unchanged.
///
/// Where the format leaves room, the reader decides:
/// - `datatype` and `file` are required (MRtrix requires them; nibabel
///   guesses); `count` is optional, and when present the streamlines found
///   must match it, so a truncated or spliced file is an error, not a short
///   read.
/// - Data that end cleanly after a NaN separator but without the Inf
///   terminator (a writer that died before its last write) are accepted when
///   the number of streamlines agrees with `count` (or there is no `count`);
///   otherwise the error says the terminator is missing.
/// - Bytes after the Inf terminator are ignored, as MRtrix does.
/// - A streamline with no points (two NaN triplets in a row) comes out as an
///   empty [`Curve`], so that counts match the header; nibabel drops them.
/// - A triplet mixing NaN or Inf with numbers is an error, not a separator.
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Ok(Box::new(TckReader::open(path)?))
}

/// A streaming `.tck` reader: the header, and one buffered chunk of
/// triplets.
struct TckReader {
    src: ByteSource,
    meta: Metadata,
    dtype: DataType,
    /// Bytes read but not yet decoded start at `buf[cur]`; `buf[0]` is at
    /// file offset `buf_at`.
    buf: Vec<u8>,
    cur: usize,
    buf_at: u64,
    /// Index of the next streamline.
    index: u64,
    done: bool,
    /// The streamline being read, kept between streamlines (it keeps the
    /// longest one's capacity): each curve handed out is a copy allocated
    /// once, at its length, where each grew by doubling, which touched
    /// fresh memory the kernel had to zero.
    points: Vec<DVec3>,
}

impl TckReader {
    fn open(path: &Path) -> Result<Self, IoError> {
        let mut src = ByteSource::open(path)?;
        let not_tck = |why: String| {
            IoError::new(
                path,
                format!(
                    "not an MRtrix .tck file: it does not start with an `{MAGIC}` line ({why})"
                ),
            )
            .at("byte 0")
        };
        match src.line(64) {
            Ok(Some(l)) if l.trim_end() == MAGIC => {}
            Ok(Some(l)) => return Err(not_tck(format!("first line {:?}", snippet(&l)))),
            Ok(None) => return Err(not_tck("the file is empty".into())),
            Err(e) => return Err(not_tck(e.reason)),
        }

        let mut extra = Vec::new();
        let mut count: Option<u64> = None;
        let mut dtype: Option<DataType> = None;
        let mut data_at: Option<u64> = None;
        loop {
            let line_at = src.pos();
            let Some(line) = src.line(MAX_LINE)? else {
                return Err(src.error("the header ends without an `END` line"));
            };
            let line = line.trim();
            if line == "END" {
                break;
            }
            if line.is_empty() {
                continue;
            }
            let Some((key, value)) = line.split_once(':') else {
                return Err(IoError::new(
                    path,
                    format!("header line {:?} is not `key: value`", snippet(line)),
                )
                .at(format!("byte {line_at}")));
            };
            let (key, value) = (key.trim(), value.trim());
            let field =
                |reason: String| IoError::new(path, reason).at(format!("header field `{key}`"));
            let twice = || field(format!("`{key}` appears twice in the header"));
            match key {
                "count" => {
                    if count.is_some() {
                        return Err(twice());
                    }
                    let n = value.parse::<u64>().map_err(|_| {
                        field(format!(
                            "`count` is {:?}, not a whole number",
                            snippet(value)
                        ))
                    })?;
                    count = Some(n);
                }
                "datatype" => {
                    if dtype.is_some() {
                        return Err(twice());
                    }
                    dtype = Some(DataType::parse(value).ok_or_else(|| {
                        field(format!(
                            "unknown datatype {:?}; tracks are Float32LE, Float32BE, Float64LE or Float64BE",
                            snippet(value)
                        ))
                    })?);
                    extra.push((key.to_string(), value.to_string()));
                }
                "file" => {
                    if data_at.is_some() {
                        return Err(twice());
                    }
                    let mut parts = value.split_whitespace();
                    data_at = Some(match (parts.next(), parts.next(), parts.next()) {
                        (Some("."), Some(n), None) => n.parse::<u64>().map_err(|_| {
                            field(format!("`file: . {}`: the offset is not a whole number", snippet(n)))
                        })?,
                        (Some(name), _, _) if name != "." => {
                            return Err(field(format!(
                                "the data are in a separate file ({}); only `file: . OFFSET` (data in this file) is supported",
                                snippet(name)
                            )))
                        }
                        _ => {
                            return Err(field(format!(
                                "`file: {}` is not `file: . OFFSET`",
                                snippet(value)
                            )))
                        }
                    });
                }
                _ => extra.push((key.to_string(), value.to_string())),
            }
        }
        let header_end = src.pos();
        let missing =
            |f: &str| IoError::new(path, format!("the header has no `{f}` line")).at("header");
        let dtype = dtype.ok_or_else(|| missing("datatype"))?;
        let data_at = data_at.ok_or_else(|| missing("file"))?;
        let file_field = |reason: String| IoError::new(path, reason).at("header field `file`");
        if data_at < header_end {
            return Err(file_field(format!(
                "the data offset {data_at} lies inside the header, which ends at byte {header_end}"
            )));
        }
        if data_at > src.len() {
            return Err(file_field(format!(
                "the data offset {data_at} lies beyond the end of the file ({} bytes)",
                src.len()
            )));
        }
        src.seek_to(data_at, "the streamline data")?;

        // Every streamline needs at least its NaN separator.
        if let Some(n) = count {
            let tb = dtype.triplet_bytes() as u64;
            let have = src.remaining();
            if n.checked_mul(tb).is_none_or(|need| need > have) {
                return Err(IoError::new(
                    path,
                    format!(
                        "absurd count {n}: that many streamlines need at least {n} × {tb} bytes, \
                         but only {have} bytes of data follow the header (count corrupted or file truncated)"
                    ),
                )
                .at("header field `count`"));
            }
        }

        let mut meta = Metadata::new(Format::Tck);
        meta.count = count;
        meta.units = Some("mm".into());
        meta.extra = extra;
        Ok(TckReader {
            src,
            meta,
            dtype,
            buf: Vec::new(),
            cur: 0,
            buf_at: data_at,
            index: 0,
            done: false,
            points: Vec::new(),
        })
    }

    fn path(&self) -> PathBuf {
        self.src.path().to_path_buf()
    }

    /// File offset of the next undecoded byte.
    fn offset(&self) -> u64 {
        self.buf_at + self.cur as u64
    }

    /// The next triplet, `None` at a clean end of file; a triplet cut short
    /// by the end of the file is an error.
    fn triplet(&mut self) -> Result<Option<[f64; 3]>, IoError> {
        let tb = self.dtype.triplet_bytes();
        if self.buf.len() - self.cur < tb {
            self.buf.drain(..self.cur);
            self.buf_at += self.cur as u64;
            self.cur = 0;
            let want = (CHUNK_TRIPLETS * tb - self.buf.len())
                .min(usize::try_from(self.src.remaining()).unwrap_or(usize::MAX));
            let old = self.buf.len();
            self.buf.resize(old + want, 0);
            self.src.read_exact(&mut self.buf[old..], "coordinates")?;
            if self.buf.len() < tb {
                if self.buf.is_empty() {
                    return Ok(None);
                }
                return Err(IoError::new(
                    &self.path(),
                    format!(
                        "file truncated: it ends {} bytes into a {tb}-byte coordinate triplet",
                        self.buf.len()
                    ),
                )
                .at(format!("byte {}", self.offset())));
            }
        }
        let v = self.dtype.decode(&self.buf[self.cur..self.cur + tb]);
        self.cur += tb;
        Ok(Some(v))
    }

    /// The end of the data after `found` streamlines: fine unless the
    /// header's `count` says otherwise.
    fn check_count(&self, found: u64, terminated: bool) -> Result<(), IoError> {
        match self.meta.count {
            Some(n) if n != found => Err(IoError::new(
                &self.path(),
                if terminated {
                    format!("the header `count` says {n} streamlines but the data hold {found}")
                } else {
                    format!(
                        "the data end after {found} streamlines without the Inf terminator, \
                         but the header `count` says {n} (file truncated?)"
                    )
                },
            )
            .at(format!("byte {}", self.offset()))),
            _ => Ok(()),
        }
    }

    fn read_curve(&mut self) -> Result<Option<Curve>, IoError> {
        let index = self.index;
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        let r = self.read_points(index, &mut points);
        self.points = points;
        r.map(|done| done.then(|| Curve::from_points(self.points.as_slice().to_vec())))
    }

    /// The points of streamline `index` into `points`: `true` at its NaN
    /// separator, `false` at the end of the data.
    fn read_points(&mut self, index: u64, points: &mut Vec<DVec3>) -> Result<bool, IoError> {
        loop {
            let at = self.offset();
            let err = |path: &Path, reason: String| {
                IoError::new(path, reason)
                    .curve(index)
                    .at(format!("byte {at}"))
            };
            let Some(t) = self.triplet().map_err(|e| e.curve(index))? else {
                if !points.is_empty() {
                    return Err(err(
                        &self.path(),
                        format!(
                            "file truncated: it ends inside the streamline, after {} points, with no NaN separator",
                            points.len()
                        ),
                    ));
                }
                self.check_count(index, false)?;
                return Ok(false);
            };
            if t.iter().all(|v| v.is_nan()) {
                self.index += 1;
                return Ok(true);
            }
            if t.iter().all(|v| v.is_infinite()) {
                if !points.is_empty() {
                    return Err(err(
                        &self.path(),
                        format!(
                            "the Inf terminator comes inside the streamline, after {} points with no NaN separator",
                            points.len()
                        ),
                    ));
                }
                self.check_count(index, true)?;
                return Ok(false);
            }
            if t.iter().any(|v| !v.is_finite()) {
                return Err(err(
                    &self.path(),
                    format!(
                        "point {} mixes NaN or Inf with numbers ({}, {}, {}); only all-NaN (separator) \
                         and all-Inf (terminator) triplets are allowed",
                        points.len(),
                        t[0],
                        t[1],
                        t[2]
                    ),
                ));
            }
            points.push(DVec3::from_array(t));
        }
    }
}

impl Iterator for TckReader {
    type Item = Result<Curve, IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read_curve();
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for TckReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

/// Create a `.tck` writer. A `.tck` source's header lines and datatype are
/// kept; other sources get a minimal Float32LE header. Points are written as
/// given (world space, RAS+ mm); per-point and per-curve values are dropped.
///
/// ```
/// use strandfit::io::{create_tck, open_tck, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-tck-create-{}.tck", std::process::id()));
/// let mut w = create_tck(&path, &Metadata::new(Format::Csv)).unwrap();
/// w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::new(1.0, 2.0, 3.5)])).unwrap();
/// w.finish().unwrap();
/// assert!(std::fs::read(&path).unwrap().starts_with(b"mrtrix tracks\n"));
/// let curves: Vec<Curve> = open_tck(&path).unwrap().collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(curves[0].points, [DVec3::ZERO, DVec3::new(1.0, 2.0, 3.5)]);
/// ```
///
/// # Output
///
/// Header lines other than `count` and `file` (including `datatype`) are kept
/// in [`Metadata::extra`], in order, so `.tck` → `.tck` writes them back. The
/// writer keeps the source's `datatype` (Float32LE for sources that are not
/// `.tck`), writes a zero-padded `count` and fills it in at
/// [`finish`](CurveWriter::finish). `.tck` holds points only: per-point and
/// per-curve values are dropped.
pub fn create(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    let mut dtype = DataType::DEFAULT;
    let mut head = format!("{MAGIC}\n");
    let mut dtype_written = false;
    if meta.format == Format::Tck {
        for (key, value) in &meta.extra {
            let field =
                |reason: String| IoError::new(path, reason).at(format!("header field `{key}`"));
            match key.as_str() {
                "count" | "file" => continue,
                // In its place, so that the header lines keep their order.
                "datatype" if !dtype_written => {
                    dtype = DataType::parse(value).ok_or_else(|| {
                        field(format!(
                            "unknown datatype {:?}; tracks are Float32LE, Float32BE, Float64LE or Float64BE",
                            snippet(value)
                        ))
                    })?;
                    head.push_str(&format!("datatype: {}\n", dtype.name()));
                    dtype_written = true;
                    continue;
                }
                "datatype" => return Err(field("`datatype` appears twice".into())),
                _ => {}
            }
            if key.trim().is_empty()
                || key.contains([':', '\n', '\r'])
                || value.contains(['\n', '\r'])
            {
                return Err(field(
                    "a header key must be non-empty without `:` or line breaks, and a value on one line"
                        .into(),
                ));
            }
            head.push_str(&format!("{key}: {value}\n"));
        }
    }
    if !dtype_written {
        head.push_str(&format!("datatype: {}\n", dtype.name()));
    }
    let count_at = head.len() + "count: ".len();
    head.push_str(&format!("count: {}\n", "0".repeat(COUNT_DIGITS)));
    // `file: . N` names the header's own length, digits included.
    let fixed = head.len() + "file: . ".len() + "\nEND\n".len();
    let mut offset = fixed + 1;
    while fixed + offset.to_string().len() != offset {
        offset = fixed + offset.to_string().len();
    }
    head.push_str(&format!("file: . {offset}\nEND\n"));
    debug_assert_eq!(head.len(), offset);

    let mut out = AtomicFile::create(path)?;
    out.write_all(head.as_bytes()).map_err(|e| out.err(e))?;
    Ok(Box::new(TckWriter {
        out,
        dtype,
        count: 0,
        count_at: count_at as u64,
        buf: Vec::new(),
    }))
}

struct TckWriter {
    out: AtomicFile,
    dtype: DataType,
    count: u64,
    /// Byte offset of the `count` digits.
    count_at: u64,
    buf: Vec<u8>,
}

impl CurveWriter for TckWriter {
    fn write_curve(&mut self, curve: &Curve) -> Result<(), IoError> {
        let index = self.count;
        self.buf.clear();
        self.buf
            .reserve(self.dtype.triplet_bytes() * (curve.points.len() + 1));
        let little_f32 = !self.dtype.wide && self.dtype.endian == Endian::Little;
        for (j, p) in curve.points.iter().enumerate() {
            // Float32 little-endian, the common case, a point at a time
            // where it plainly fits (no NaN, within float32): writing was
            // a tenth of decompressing. Anything else takes the checks.
            if little_f32 && crate::io::fits_f32(*p) {
                let mut b = [0u8; 12];
                b[0..4].copy_from_slice(&(p.x as f32).to_le_bytes());
                b[4..8].copy_from_slice(&(p.y as f32).to_le_bytes());
                b[8..12].copy_from_slice(&(p.z as f32).to_le_bytes());
                self.buf.extend_from_slice(&b);
                continue;
            }
            let bad = |why: &str| {
                IoError::new(self.out.target(), format!("point {j} ({p}) {why}")).curve(index)
            };
            if !p.is_finite() {
                // A NaN would read back as a separator, an Inf as the end.
                return Err(bad("is not finite"));
            }
            self.dtype
                .encode(p.to_array(), &mut self.buf)
                .ok_or_else(|| bad(&format!("does not fit in {}", self.dtype.name())))?;
        }
        let _ = self.dtype.encode([f64::NAN; 3], &mut self.buf);
        self.out
            .write_all(&self.buf)
            .map_err(|e| self.out.err(e).curve(index))?;
        self.count += 1;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), IoError> {
        let mut w = *self;
        let digits = format!("{:0width$}", w.count, width = COUNT_DIGITS);
        if digits.len() != COUNT_DIGITS {
            return Err(IoError::new(
                w.out.target(),
                format!(
                    "{} streamlines do not fit the {COUNT_DIGITS}-digit `count` field",
                    w.count
                ),
            ));
        }
        w.buf.clear();
        let _ = w.dtype.encode([f64::INFINITY; 3], &mut w.buf);
        w.out.write_all(&w.buf).map_err(|e| w.out.err(e))?;
        w.out
            .seek(SeekFrom::Start(w.count_at))
            .and_then(|_| w.out.write_all(digits.as_bytes()))
            .map_err(|e| w.out.err(e))?;
        w.out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, meta: &Metadata, curves: &[Curve]) {
        let mut w = create(path, meta).unwrap();
        for c in curves {
            w.write_curve(c).unwrap();
        }
        w.finish().unwrap();
    }

    fn read(path: &Path) -> Result<(Metadata, Vec<Curve>), IoError> {
        let r = open(path)?;
        let meta = r.metadata().clone();
        Ok((meta, r.collect::<Result<Vec<_>, _>>()?))
    }

    fn curves() -> Vec<Curve> {
        vec![
            Curve::from_points(vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-4.5, 0.25, 1e3)]),
            Curve::from_points(vec![]),
            Curve::from_points(vec![DVec3::new(0.1, 0.2, 0.3)]),
        ]
    }

    #[test]
    fn datatype_names_round_trip() {
        for n in ["Float32LE", "Float32BE", "Float64LE", "Float64BE"] {
            assert_eq!(DataType::parse(n).unwrap().name(), n);
        }
        assert!(DataType::parse("Float32").is_none());
        assert!(DataType::parse("Int16LE").is_none());
    }

    #[test]
    fn header_offset_names_its_own_length() {
        let dir = tempfile::tempdir().unwrap();
        // Header lengths around a digit boundary of the offset.
        for pad in 0..120 {
            let p = dir.path().join("h.tck");
            let mut meta = Metadata::new(Format::Tck);
            meta.extra.push(("note".into(), "x".repeat(pad)));
            write(&p, &meta, &[]);
            let (m, c) = read(&p).unwrap();
            assert!(c.is_empty());
            assert_eq!(m.count, Some(0));
            assert_eq!(m.extra("note").unwrap().len(), pad);
        }
    }

    #[test]
    fn every_datatype_round_trips_and_empty_curves_survive() {
        let dir = tempfile::tempdir().unwrap();
        for dt in ["Float32LE", "Float32BE", "Float64LE", "Float64BE"] {
            let p = dir.path().join(format!("{dt}.tck"));
            let mut meta = Metadata::new(Format::Tck);
            meta.extra.push(("datatype".into(), dt.into()));
            meta.extra.push(("timestamp".into(), "12345.5".into()));
            write(&p, &meta, &curves());
            let (m, c) = read(&p).unwrap();
            assert_eq!(m.extra("datatype"), Some(dt));
            assert_eq!(m.extra("timestamp"), Some("12345.5"));
            assert_eq!(m.count, Some(3));
            assert_eq!(c.len(), 3);
            assert!(c[1].points.is_empty());
            let tol = if dt.starts_with("Float64") { 0.0 } else { 1e-4 };
            for (a, b) in c.iter().zip(curves()) {
                assert_eq!(a.points.len(), b.points.len());
                for (p, q) in a.points.iter().zip(&b.points) {
                    assert!((*p - *q).abs().max_element() <= tol, "{dt}: {p} vs {q}");
                }
            }
        }
    }

    #[test]
    fn writer_rejects_non_finite_and_f32_overflow() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.tck");
        let mut w = create(&p, &Metadata::new(Format::Json)).unwrap();
        let e = w
            .write_curve(&Curve::from_points(vec![
                DVec3::ZERO,
                DVec3::new(f64::NAN, 0.0, 0.0),
            ]))
            .unwrap_err();
        assert_eq!(e.curve, Some(0));
        assert!(e.reason.contains("point 1"), "{e}");
        let e = w
            .write_curve(&Curve::from_points(vec![DVec3::new(1e300, 0.0, 0.0)]))
            .unwrap_err();
        assert!(e.reason.contains("Float32LE"), "{e}");
        drop(w);
        assert!(!p.exists(), "a dropped writer leaves nothing behind");
    }

    #[test]
    fn missing_terminator_is_accepted_only_when_count_agrees() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.tck");
        write(&p, &Metadata::new(Format::Tck), &curves());
        let bytes = std::fs::read(&p).unwrap();
        let cut = &bytes[..bytes.len() - 12];
        std::fs::write(&p, cut).unwrap();
        assert_eq!(read(&p).unwrap().1.len(), 3);
        // The same without the last streamline: count disagrees.
        let cut = &bytes[..bytes.len() - 12 - 24];
        std::fs::write(&p, cut).unwrap();
        let e = read(&p).unwrap_err();
        assert!(e.reason.contains("without the Inf terminator"), "{e}");
    }

    #[test]
    fn count_disagreeing_with_data_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.tck");
        write(&p, &Metadata::new(Format::Tck), &curves());
        let mut bytes = std::fs::read(&p).unwrap();
        let at = bytes
            .windows(17)
            .position(|w| w == b"count: 0000000003")
            .unwrap();
        bytes[at + 16] = b'2';
        std::fs::write(&p, &bytes).unwrap();
        let e = read(&p).unwrap_err();
        assert!(
            e.reason.contains("says 2 streamlines but the data hold 3"),
            "{e}"
        );
    }
}
