//! Cem Yuksel's `.hair` format: the reader and the writer. The format and
//! what the reader makes of it are described on `open` (`io::open_hair`),
//! what the writer keeps on `create` (`io::create_hair`).

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::bytes::{ByteSource, Endian};
use super::spool::Spool;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, Format, IoError, Metadata};

const HEADER: u64 = 128;
const INFO: usize = 88;
const SEGMENTS: u32 = 1;
const POINTS: u32 = 2;
const THICKNESS: u32 = 4;
const TRANSPARENCY: u32 = 8;
const COLORS: u32 = 16;

const LE: Endian = Endian::Little;

/// A per-point array: its handle (positioned at the current strand), bytes
/// per point, and how many values it adds to each point's data.
struct PointArray {
    src: ByteSource,
    name: &'static str,
    floats: usize,
}

/// Reader of Cem Yuksel's `.hair` files.
pub struct HairReader {
    meta: Metadata,
    /// Segments per strand, when the file has the array.
    segments: Option<Vec<u16>>,
    default_segments: u32,
    n_strands: u64,
    points: ByteSource,
    arrays: Vec<PointArray>,
    next: u64,
    done: bool,
    buf: Vec<u8>,
}

/// Open a `.hair` file for streaming its strands as curves.
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_hair;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-hair-open-{}.hair", std::process::id()));
/// std::fs::write(&path, "HAIR").unwrap();
/// let err = open_hair(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((err.path, err.at.as_deref()), (path, Some("byte 4")));
/// assert!(err.reason.starts_with("file truncated"));
/// ```
///
/// # Format
///
/// Cem Yuksel's `.hair` format (cyHairFile), little endian: a 128-byte
/// header (`"HAIR"`, strand count, point count, array bits, default
/// segments, thickness, transparency and colour, 88-byte info string), then
/// whole arrays, each present when its bit is set: segments per strand
/// (uint16, bit 0; else every strand has the default), points (3 × float32,
/// bit 1), thickness (float32 per point, bit 2), transparency (bit 3) and
/// colour (3 × float32 per point, bit 4). A strand of s segments has s + 1
/// points.
///
/// ## Reading
///
/// The arrays are laid out by attribute, not by strand, so the reader checks
/// the sizes the header implies against the file length, reads the segments
/// table (2 bytes a strand) to check that it adds up to the point count, and
/// then streams each array through its own buffered handle, all advancing
/// strand by strand: one strand is in memory at a time. Thickness,
/// transparency and colour are carried as per-point data named `thickness`,
/// `transparency`, `color_r`, `color_g`, `color_b`; the header's defaults and
/// info string go to `extra` (`hair.default_*`, `hair.info`). Units are not
/// part of the format: [`Metadata::units`] stays `None`.
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Ok(Box::new(HairReader::open(path)?))
}

impl HairReader {
    /// Open a `.hair` file and read its header.
    ///
    /// The header's counts are checked against the file's length up front:
    ///
    /// ```
    /// use strandfit::io::{create_hair, Curve, CurveReader, Format, HairReader, Metadata};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("two.hair");
    /// let mut w = create_hair(&path, &Metadata::new(Format::Json)).unwrap();
    /// for n in [2, 3] {
    ///     w.write_curve(&Curve::from_points(vec![DVec3::Z; n])).unwrap();
    /// }
    /// w.finish().unwrap();
    /// let reader = HairReader::open(&path).unwrap();
    /// assert_eq!(reader.metadata().count, Some(2));
    /// assert_eq!(reader.map(|c| c.unwrap().points.len()).collect::<Vec<_>>(), [2, 3]);
    /// // The same file cut short by one byte.
    /// let bytes = std::fs::read(&path).unwrap();
    /// std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
    /// assert!(HairReader::open(&path).is_err());
    /// ```
    pub fn open(path: &Path) -> Result<Self, IoError> {
        let mut src = ByteSource::open(path)?;
        let len = src.len();
        let magic = src.array::<4>("the \"HAIR\" signature")?;
        if &magic != b"HAIR" {
            return Err(IoError::new(
                path,
                format!(
                    "not a .hair file: it starts with {:?}, not \"HAIR\"",
                    String::from_utf8_lossy(&magic)
                ),
            )
            .at("byte 0"));
        }
        let n_strands = src.u32(LE, "the strand count")? as u64;
        let n_points = src.u32(LE, "the point count")? as u64;
        let bits = src.u32(LE, "the array bits")?;
        let default_segments = src.u32(LE, "the default segment count")?;
        let default_thickness = src.f32(LE, "the default thickness")?;
        let default_transparency = src.f32(LE, "the default transparency")?;
        let mut default_color = [0f32; 3];
        for c in &mut default_color {
            *c = src.f32(LE, "the default colour")?;
        }
        let mut info = [0u8; INFO];
        src.read_exact(&mut info, "the info string")?;

        if bits & !(SEGMENTS | POINTS | THICKNESS | TRANSPARENCY | COLORS) != 0 {
            return Err(IoError::new(
                path,
                format!("the array bits {bits:#x} have bits above the five the format defines"),
            )
            .at("byte 12"));
        }
        if bits & POINTS == 0 {
            return Err(IoError::new(
                path,
                "the file has no points array (bit 1 of the array bits is clear)",
            )
            .at("byte 12"));
        }

        // Where each array starts, and whether the file holds them all.
        let mut offset = HEADER;
        let mut layout = Vec::new();
        let mut add = |bit: u32, bytes: u64| {
            let start = offset;
            if bits & bit != 0 {
                offset += bytes;
            }
            (bits & bit != 0).then_some(start)
        };
        let seg_at = add(SEGMENTS, 2 * n_strands);
        let points_at = add(POINTS, 12 * n_points).unwrap_or(HEADER);
        for (bit, name, floats) in [
            (THICKNESS, "thickness", 1),
            (TRANSPARENCY, "transparency", 1),
            (COLORS, "colour", 3),
        ] {
            if let Some(at) = add(bit, 4 * floats as u64 * n_points) {
                layout.push((at, name, floats));
            }
        }
        if offset > len {
            return Err(IoError::new(
                path,
                format!(
                    "file truncated: the header announces {n_strands} strands and {n_points} points, \
                     whose arrays need {offset} bytes, but the file has {len}"
                ),
            )
            .at("byte 4"));
        }

        let segments = match seg_at {
            Some(_) => {
                // Checked above: 2 bytes a strand are in the file.
                let mut raw = vec![0u8; 2 * n_strands as usize];
                src.read_exact(&mut raw, "the segments array")?;
                let segs: Vec<u16> = raw
                    .chunks_exact(2)
                    .map(|b| u16::from_le_bytes([b[0], b[1]]))
                    .collect();
                let sum = segs.iter().map(|&s| s as u64 + 1).sum::<u64>();
                if sum != n_points {
                    return Err(IoError::new(
                        path,
                        format!(
                            "the segments array gives {sum} points (segments + 1 per strand), \
                             but the header says {n_points}"
                        ),
                    )
                    .at(format!("byte {HEADER}")));
                }
                Some(segs)
            }
            None => {
                let sum = n_strands * (default_segments as u64 + 1);
                if sum != n_points {
                    return Err(IoError::new(
                        path,
                        format!(
                            "{n_strands} strands of {default_segments} default segments have \
                             {sum} points, but the header says {n_points}"
                        ),
                    )
                    .at("byte 16"));
                }
                None
            }
        };

        let mut points = src;
        points.seek_to(points_at, "the points array")?;
        let mut arrays = Vec::new();
        let mut names = Vec::new();
        for (at, name, floats) in layout {
            let mut s = ByteSource::open(path)?;
            s.seek_to(at, name)?;
            arrays.push(PointArray {
                src: s,
                name,
                floats,
            });
            if floats == 1 {
                names.push(name.to_string());
            } else {
                names.extend(["color_r", "color_g", "color_b"].map(String::from));
            }
        }

        let mut meta = Metadata::new(Format::Hair);
        meta.count = Some(n_strands);
        meta.point_data_names = names;
        let end = info.iter().position(|&b| b == 0).unwrap_or(INFO);
        meta.extra = vec![
            (
                "hair.info".into(),
                String::from_utf8_lossy(&info[..end]).into_owned(),
            ),
            ("hair.default_segments".into(), default_segments.to_string()),
            (
                "hair.default_thickness".into(),
                default_thickness.to_string(),
            ),
            (
                "hair.default_transparency".into(),
                default_transparency.to_string(),
            ),
            (
                "hair.default_color".into(),
                default_color.map(|c| c.to_string()).join(" "),
            ),
        ];
        Ok(HairReader {
            meta,
            segments,
            default_segments,
            n_strands,
            points,
            arrays,
            next: 0,
            done: false,
            buf: Vec::new(),
        })
    }

    fn read_strand(&mut self, i: u64) -> Result<Curve, IoError> {
        let n = match &self.segments {
            Some(s) => s.get(i as usize).map_or(1, |&s| s as usize + 1),
            None => self.default_segments as usize + 1,
        };
        // The header check guarantees these bytes are in the file.
        self.buf.resize(12 * n, 0);
        self.points.read_exact(&mut self.buf, "a strand's points")?;
        let mut points = Vec::with_capacity(n);
        for p in self.buf.chunks_exact(12) {
            let v = |j: usize| f32::from_le_bytes([p[j], p[j + 1], p[j + 2], p[j + 3]]) as f64;
            // Non-finite points are refused (or skipped) by the one check
            // every reader goes through (`io::open_reader`).
            points.push(DVec3::new(v(0), v(4), v(8)));
        }
        let width: usize = self.arrays.iter().map(|a| a.floats).sum();
        let mut point_data = vec![0f32; n * width];
        let mut col = 0;
        for a in &mut self.arrays {
            self.buf.resize(4 * a.floats * n, 0);
            a.src.read_exact(&mut self.buf, a.name)?;
            for (k, v) in self.buf.chunks_exact(4).enumerate() {
                let (p, c) = (k / a.floats, k % a.floats);
                point_data[p * width + col + c] = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
            }
            col += a.floats;
        }
        Ok(Curve {
            id: None,
            points,
            point_data,
            curve_data: Vec::new(),
        })
    }
}

impl Iterator for HairReader {
    type Item = Result<Curve, IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done || self.next >= self.n_strands {
            return None;
        }
        let i = self.next;
        let r = self.read_strand(i).map(Some).map_err(|e| e.curve(i));
        if r.is_ok() {
            self.next += 1;
        }
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for HairReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

// ---------------------------------------------------------------------------
// Writer

/// Create a `.hair` file (see [Output](create#output) for what is kept).
///
/// A strand's thickness is kept; other per-point values are dropped:
///
/// ```
/// use strandfit::io::{create_hair, open_hair, Curve, CurveReader, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-hair-create-{}.hair", std::process::id()));
/// let mut meta = Metadata::new(Format::Json);
/// meta.point_data_names = vec!["thickness".into(), "fa".into()];
/// let points = vec![DVec3::ZERO, DVec3::Y, DVec3::new(0.0, 2.0, 0.5)];
/// let data = vec![0.1, 9.0, 0.2, 9.0, 0.3, 9.0]; // (thickness, fa) per point
/// let mut w = create_hair(&path, &meta).unwrap();
/// w.write_curve(&Curve { point_data: data, ..Curve::from_points(points.clone()) }).unwrap();
/// w.finish().unwrap();
/// let reader = open_hair(&path).unwrap();
/// assert_eq!(reader.metadata().point_data_names, ["thickness"]);
/// let curves: Vec<Curve> = reader.collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((&curves[0].points, &curves[0].point_data), (&points, &vec![0.1f32, 0.2, 0.3]));
/// ```
///
/// # Output
///
/// The header needs both counts, so the points and per-point arrays are
/// spooled to scratch files next to the target (the segments, 2 bytes a
/// strand, stay in memory) and the file is assembled at
/// [`CurveWriter::finish`] through an [`AtomicFile`]. The segments array is
/// always written. Per-point data named as the reader names it (see
/// [`open_hair`](crate::io::open_hair), Format) is written (colour only
/// when all three channels are there); other per-point and all per-curve
/// data has no place in the format and is dropped. Defaults and info come
/// from `extra` when the source was a `.hair` file (else cyHairFile's own
/// defaults, and `vtk.title` as the info); the info keeps at most 87 bytes
/// and a terminating NUL.
pub fn create(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Ok(Box::new(HairWriter::new(path, meta)?))
}

/// A per-point array being spooled: which columns of `Curve::point_data`.
struct OutArray {
    bit: u32,
    columns: Vec<usize>,
    spool: Spool,
}

/// Writer of `.hair` files.
pub struct HairWriter {
    path: PathBuf,
    out: AtomicFile,
    segments: Vec<u16>,
    n_points: u64,
    points: Spool,
    arrays: Vec<OutArray>,
    width: usize,
    default_segments: u32,
    default_thickness: f32,
    default_transparency: f32,
    default_color: [f32; 3],
    info: [u8; INFO],
    bytes: Vec<u8>,
}

impl HairWriter {
    /// Create a `.hair` file at `path` for curves described by `meta`.
    ///
    /// Nothing is at `path` until [`CurveWriter::finish`]; the info string
    /// comes from `meta`'s `hair.info` (or `vtk.title`):
    ///
    /// ```
    /// use strandfit::io::{Curve, CurveReader, CurveWriter, Format, HairReader, HairWriter, Metadata};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("strand.hair");
    /// let mut meta = Metadata::new(Format::Json);
    /// meta.extra.push(("vtk.title".into(), "one strand".into()));
    /// let mut w = Box::new(HairWriter::new(&path, &meta).unwrap());
    /// let points = vec![DVec3::ZERO, DVec3::Y, DVec3::new(0.0, 2.0, 0.5)];
    /// w.write_curve(&Curve::from_points(points.clone())).unwrap();
    /// assert!(!path.exists());
    /// w.finish().unwrap();
    /// let mut reader = HairReader::open(&path).unwrap();
    /// assert_eq!(reader.metadata().extra("hair.info"), Some("one strand"));
    /// assert_eq!(reader.next().unwrap().unwrap().points, points);
    /// // A folder that is not there is an error at once.
    /// assert!(HairWriter::new(&dir.path().join("no/strand.hair"), &meta).is_err());
    /// ```
    pub fn new(path: &Path, meta: &Metadata) -> Result<Self, IoError> {
        let out = AtomicFile::create(path)?;
        let col = |n: &str| meta.point_data_names.iter().position(|m| m == n);
        let mut arrays = Vec::new();
        for (bit, names) in [
            (THICKNESS, &["thickness"][..]),
            (TRANSPARENCY, &["transparency"][..]),
            (COLORS, &["color_r", "color_g", "color_b"][..]),
        ] {
            let columns: Option<Vec<usize>> = names.iter().map(|n| col(n)).collect();
            if let Some(columns) = columns {
                arrays.push(OutArray {
                    bit,
                    columns,
                    spool: Spool::new(path)?,
                });
            }
        }
        let f = |key: &str, default: f32| {
            meta.extra(key)
                .and_then(|v| v.trim().parse().ok())
                .unwrap_or(default)
        };
        let mut default_color = [1f32; 3];
        if let Some(c) = meta.extra("hair.default_color") {
            let v: Vec<f32> = c
                .split_whitespace()
                .filter_map(|x| x.parse().ok())
                .collect();
            if v.len() == 3 {
                default_color.copy_from_slice(&v);
            }
        }
        let mut info = [0u8; INFO];
        let text = meta
            .extra("hair.info")
            .or(meta.extra("vtk.title"))
            .unwrap_or("");
        let mut end = text.len().min(INFO - 1);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        info[..end].copy_from_slice(&text.as_bytes()[..end]);
        Ok(HairWriter {
            path: path.to_path_buf(),
            out,
            segments: Vec::new(),
            n_points: 0,
            points: Spool::new(path)?,
            arrays,
            width: meta.point_data_names.len(),
            default_segments: meta
                .extra("hair.default_segments")
                .and_then(|v| v.trim().parse().ok())
                .unwrap_or(0),
            default_thickness: f("hair.default_thickness", 1.0),
            default_transparency: f("hair.default_transparency", 0.0),
            default_color,
            info,
            bytes: Vec::new(),
        })
    }
}

impl CurveWriter for HairWriter {
    fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
        let i = self.segments.len() as u64;
        let err = |reason: String| IoError::new(&self.path, reason).curve(i);
        let n = c.points.len();
        if n == 0 || n > u16::MAX as usize + 1 {
            return Err(err(format!(
                "a strand has {n} points; the format holds 1 to 65536 (uint16 segments)"
            )));
        }
        if c.point_data.len() != n * self.width {
            return Err(err(format!(
                "{} per-point values for {n} points and {} arrays",
                c.point_data.len(),
                self.width
            )));
        }
        if i >= u32::MAX as u64 || self.n_points + n as u64 > u32::MAX as u64 {
            return Err(err(
                "more than 2^32 - 1 strands or points: the counts are uint32".into(),
            ));
        }
        self.bytes.clear();
        for (k, p) in c.points.iter().enumerate() {
            let q = p.as_vec3();
            if !q.is_finite() {
                let what = if p.is_finite() {
                    "does not fit in float32"
                } else {
                    "is not finite"
                };
                return Err(err(format!("point {k} {p} {what}")));
            }
            for x in q.to_array() {
                self.bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        self.points.write(&self.bytes)?;
        for a in &mut self.arrays {
            self.bytes.clear();
            for row in c.point_data.chunks_exact(self.width.max(1)) {
                for &col in &a.columns {
                    let v = row.get(col).copied().unwrap_or(0.0);
                    self.bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
            a.spool.write(&self.bytes)?;
        }
        self.segments.push((n - 1) as u16);
        self.n_points += n as u64;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), IoError> {
        let HairWriter {
            path,
            mut out,
            segments,
            n_points,
            points,
            arrays,
            default_segments,
            default_thickness,
            default_transparency,
            default_color,
            info,
            ..
        } = *self;
        let bits = SEGMENTS | POINTS | arrays.iter().map(|a| a.bit).fold(0, |a, b| a | b);
        let mut h = Vec::with_capacity(HEADER as usize + 2 * segments.len());
        h.extend_from_slice(b"HAIR");
        for v in [
            segments.len() as u32,
            n_points as u32,
            bits,
            default_segments,
        ] {
            h.extend_from_slice(&v.to_le_bytes());
        }
        for v in [default_thickness, default_transparency] {
            h.extend_from_slice(&v.to_le_bytes());
        }
        for v in default_color {
            h.extend_from_slice(&v.to_le_bytes());
        }
        h.extend_from_slice(&info);
        for s in &segments {
            h.extend_from_slice(&s.to_le_bytes());
        }
        use std::io::Write as _;
        out.write_all(&h)
            .map_err(|e| IoError::os(&path, "cannot write", e))?;
        points.copy_into(&mut out)?;
        for a in arrays {
            a.spool.copy_into(&mut out)?;
        }
        out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal file by hand: 2 strands (1 and 2 segments), thickness.
    fn tiny(bits: u32, segs: &[u16], n_points: u32) -> Vec<u8> {
        let mut b = b"HAIR".to_vec();
        for v in [segs.len() as u32, n_points, bits, 1] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [0.5f32, 0.25, 0.1, 0.2, 0.3] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let mut info = [0u8; INFO];
        info[..4].copy_from_slice(b"tiny");
        b.extend_from_slice(&info);
        if bits & SEGMENTS != 0 {
            for s in segs {
                b.extend_from_slice(&s.to_le_bytes());
            }
        }
        for k in 0..n_points {
            for c in 0..3 {
                b.extend_from_slice(&(k as f32 + c as f32 / 10.0).to_le_bytes());
            }
        }
        if bits & THICKNESS != 0 {
            for k in 0..n_points {
                b.extend_from_slice(&(k as f32 * 0.01).to_le_bytes());
            }
        }
        b
    }

    #[test]
    fn reads_a_hand_made_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.hair");
        std::fs::write(&p, tiny(SEGMENTS | POINTS | THICKNESS, &[1, 2], 5)).unwrap();
        let r = HairReader::open(&p).unwrap();
        assert_eq!(r.metadata().extra("hair.info"), Some("tiny"));
        assert_eq!(r.metadata().point_data_names, ["thickness"]);
        let curves: Vec<Curve> = r.collect::<Result<_, _>>().unwrap();
        assert_eq!(curves.len(), 2);
        assert_eq!(curves[0].points.len(), 2);
        assert_eq!(
            curves[1].points[2],
            DVec3::new(4.0, 4.1f32 as f64, 4.2f32 as f64)
        );
        assert_eq!(curves[1].point_data, [0.02, 0.03, 0.04]);
    }

    #[test]
    fn default_segments_without_the_array() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.hair");
        // default segments 1: 3 strands of 2 points.
        std::fs::write(&p, tiny(POINTS, &[9, 9, 9], 6)).unwrap();
        let curves: Vec<Curve> = HairReader::open(&p)
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(
            curves.iter().map(|c| c.points.len()).collect::<Vec<_>>(),
            [2, 2, 2]
        );
        std::fs::write(&p, tiny(POINTS, &[9, 9, 9], 7)).unwrap();
        let e = HairReader::open(&p).err().unwrap().to_string();
        assert!(
            e.contains("default segments") && e.contains("header says 7"),
            "{e}"
        );
    }
}
