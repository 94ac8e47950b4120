//! Reading and writing the curve files users have: tractography (MRtrix
//! `.tck`, TrackVis `.trk`, TRX), VTK legacy polylines, Cem Yuksel's `.hair`,
//! and plain JSON/CSV polylines.
//!
//! Every reader is a streaming iterator over [`Curve`]s, so files larger than
//! memory work: only the header and one curve are held at a time. Points come
//! out in **world space** (RAS+ millimetres for tractography; the file's own
//! units otherwise), and the [`Metadata`] a reader returns carries what a
//! writer needs to put them back exactly in the source's convention (the
//! affine, voxel sizes, header fields, names of per-point and per-curve data).
//!
//! Errors name the file, the curve (0-based index) where known, the byte
//! offset or line where known, and the reason ([`IoError`]). No reader
//! panics on any input: truncated, corrupted and hostile files (absurd
//! counts in headers) are errors, and counts from headers never size an
//! allocation before the bytes behind them have been seen.
//!
//! Writers write to a temporary file next to the target and rename it into
//! place in [`CurveWriter::finish`]; dropping a writer without finishing it
//! (a failed run) leaves nothing behind and never clobbers an existing file
//! ([`AtomicFile`]).
//!
//! Each format's reader documents the format and what is read from it
//! ([`open_tck`], [`open_trk`], [`open_trx`], [`VtkReader`], [`open_hair`],
//! [`open_json`], [`open_csv`], [`read_sketch`]), and its writer what is
//! written ([`create_tck`], [`create_trk`], [`create_trx`], [`VtkWriter`],
//! [`create_hair`]).

mod atomic;
mod bytes;
mod container;
mod format;
mod hair;
mod inspect;
mod polyline;
mod sketch;
mod spool;
mod tck;
mod trk;
mod trx;
mod vtk;
mod vtk_frames;

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};

pub use atomic::{remove_unfinished_outputs, AtomicFile};
// The `.sfh` container's generic names get a `Container` prefix here.
pub use container::{
    encoded_size, is_container, ContainerReader, ContainerWriter, Header as ContainerHeader,
    QuantChain, Shape, SourceMeta, Storage, StoredCurve, BLOCK_CURVES as CONTAINER_BLOCK_CURVES,
    MAGIC as CONTAINER_MAGIC, VERSION as CONTAINER_VERSION,
};
pub use format::{data_losses, source_losses, Format};
// Each format's own reader and writer (without the point check of
// [`open_reader`]), named after the format.
pub use hair::{create as create_hair, open as open_hair, HairReader, HairWriter};
pub use inspect::CurveStats;
pub use polyline::{create_csv, create_json, open_csv, open_json, VecReader};
pub use sketch::{
    parse_sketch_csv, parse_sketch_json, parse_sketch_svg, read_sketch, write_preview_svg,
    FLATTEN_TOLERANCE as SVG_FLATTEN_TOLERANCE, SKETCH_EXTENSIONS,
};
pub use tck::{create as create_tck, open as open_tck};
pub use trk::{create as create_trk, open as open_trk, HEADER_KEY as TRK_HEADER_KEY};
pub use trx::{create as create_trx, open as open_trx, GROUP_PREFIX as TRX_GROUP_PREFIX};
pub use vtk::{create as create_vtk, open as open_vtk, VtkReader, VtkWriter};
pub use vtk_frames::{write_framed_paths, FramedPath};

/// One curve as read from a file: points in world space, plus the per-point
/// and per-curve values the file carried (carried through to writers of the
/// same format; see [`Metadata::point_data_names`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curve {
    /// The curve's name where the format has one (JSON, CSV); `None`
    /// elsewhere, where curves are known by their index.
    pub id: Option<String>,
    /// Points in world space, in order.
    pub points: Vec<DVec3>,
    /// Per-point values, `points.len() × point_data_names.len()`, row-major
    /// (all values of point 0, then point 1, …).
    pub point_data: Vec<f32>,
    /// Per-curve values, `curve_data_names.len()` of them.
    pub curve_data: Vec<f32>,
}

impl Curve {
    /// A curve of points only.
    pub fn from_points(points: Vec<DVec3>) -> Self {
        Curve {
            points,
            ..Default::default()
        }
    }
}

/// What a reader learned from a file's header that is not per curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Metadata {
    /// The format the file was read as.
    pub format: Format,
    /// Number of curves the header announces, when it does (`.tck` `count`,
    /// `.trk` `n_count`, `.hair` strand count, VTK line count). Advisory: a
    /// reader checks it against what it finds, and never allocates by it.
    pub count: Option<u64>,
    /// Voxel-to-world (RAS+ mm) affine of the reference image, for
    /// tractography; identity otherwise.
    pub vox_to_world: DMat4,
    /// Voxel sizes (mm) and image dimensions of the reference image, where
    /// the format has them (`.trk`).
    pub voxel_size: Option<[f64; 3]>,
    /// Image dimensions in voxels (`.trk`).
    pub dimensions: Option<[u32; 3]>,
    /// Length unit of the world coordinates, e.g. "mm" for tractography,
    /// "solar radius" for the bundled field lines; `None` when unknown.
    pub units: Option<String>,
    /// Names of the per-point values in [`Curve::point_data`].
    pub point_data_names: Vec<String>,
    /// Names of the per-curve values in [`Curve::curve_data`].
    pub curve_data_names: Vec<String>,
    /// Format-specific header fields kept verbatim so that a writer of the
    /// same format reproduces them (e.g. `.tck` key-value lines, the `.trk`
    /// header bytes, the `.hair` info string, the VTK title line).
    pub extra: Vec<(String, String)>,
}

impl Metadata {
    /// Metadata with nothing but the format: identity affine, no data names.
    pub fn new(format: Format) -> Self {
        Metadata {
            format,
            count: None,
            vox_to_world: DMat4::IDENTITY,
            voxel_size: None,
            dimensions: None,
            units: None,
            point_data_names: Vec::new(),
            curve_data_names: Vec::new(),
            extra: Vec::new(),
        }
    }

    /// The value of an [`extra`](Self::extra) field.
    pub fn extra(&self, key: &str) -> Option<&str> {
        self.extra
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// A read or write failure, naming the file, the curve and where in the
/// file, and why.
#[derive(Debug, thiserror::Error)]
#[error("{}{}{}: {reason}", path.display(), curve.map(|c| format!(", curve {c}")).unwrap_or_default(), at.as_ref().map(|a| format!(" ({a})")).unwrap_or_default())]
pub struct IoError {
    /// The file concerned.
    pub path: PathBuf,
    /// 0-based index of the curve being read or written, if any.
    pub curve: Option<u64>,
    /// Where in the file: "byte 1234", "line 17", "header field `count`".
    pub at: Option<String>,
    /// What went wrong.
    pub reason: String,
    /// The operating-system error, when there is one. Its text is already
    /// in `reason`, so it is not the `Error::source` (an error chain would
    /// print it twice).
    pub os_error: Option<std::io::Error>,
}

impl IoError {
    /// An error about `path` for `reason`.
    pub fn new(path: &Path, reason: impl Into<String>) -> Self {
        IoError {
            path: path.to_path_buf(),
            curve: None,
            at: None,
            reason: reason.into(),
            os_error: None,
        }
    }

    /// An operating-system error (open, read, write) on `path`.
    pub fn os(path: &Path, what: &str, e: std::io::Error) -> Self {
        IoError {
            reason: format!("{what}: {e}"),
            os_error: Some(e),
            ..IoError::new(path, "")
        }
    }

    /// The same error, about curve `index`.
    pub fn curve(mut self, index: u64) -> Self {
        self.curve = Some(index);
        self
    }

    /// The same error, at a place in the file.
    pub fn at(mut self, at: impl Into<String>) -> Self {
        self.at = Some(at.into());
        self
    }
}

/// A streaming reader: its [`Metadata`] up front, then the curves in file
/// order. After the first `Err` the iterator ends (returns `None`).
pub trait CurveReader: Iterator<Item = Result<Curve, IoError>> {
    /// The file's metadata (read from its header).
    fn metadata(&self) -> &Metadata;
    /// Curves left out so far under [`BadCurves::Skip`], in file order
    /// (none for a reader that skips nothing).
    fn skipped(&self) -> &[SkippedCurve] {
        &[]
    }
}

/// The largest coordinate magnitude a point may have: `f32`'s largest
/// finite value. Several formats and the `.sfh` container store `f32`, so a
/// point beyond it could be read but never written back; it is refused at
/// reading, where the file and curve can still be named.
pub const MAX_COORDINATE: f64 = f32::MAX as f64;

/// Whether every coordinate of `p` is a number within the float32 range
/// (`|x| ≤ MAX_COORDINATE`; NaN fails the comparison): the quick test
/// before [`point_problem`] says why not.
///
/// ```
/// use strandfit::{io::fits_f32, DVec3};
///
/// assert!(fits_f32(DVec3::new(1.0, -2.0, 3.0)));
/// assert!(!fits_f32(DVec3::new(0.0, f64::NAN, 0.0)));
/// assert!(!fits_f32(DVec3::new(f64::INFINITY, 0.0, 0.0)));
/// assert!(!fits_f32(DVec3::new(0.0, 0.0, -1e39)));
/// ```
#[inline]
pub fn fits_f32(p: DVec3) -> bool {
    // `&`, not `&&`: no branch per coordinate, and a slice's test
    // vectorises.
    (p.x.abs() <= MAX_COORDINATE) & (p.y.abs() <= MAX_COORDINATE) & (p.z.abs() <= MAX_COORDINATE)
}

/// Why a point cannot be used (a non-finite coordinate, or one beyond
/// [`MAX_COORDINATE`]), or `None` when it can.
///
/// ```
/// use strandfit::{io::point_problem, DVec3};
///
/// assert_eq!(point_problem(DVec3::new(1.0, 2.0, 3.0)), None);
/// let why = point_problem(DVec3::new(0.0, f64::NAN, 0.0)).unwrap();
/// assert!(why.starts_with("coordinate y is NaN"));
/// assert!(point_problem(DVec3::new(1e39, 0.0, 0.0)).is_some()); // beyond f32
/// ```
pub fn point_problem(p: DVec3) -> Option<String> {
    if fits_f32(p) {
        return None;
    }
    let a = p.to_array();
    if let Some(k) = a.iter().position(|x| !x.is_finite()) {
        return Some(format!(
            "coordinate {} is {} ({}, {}, {})",
            ["x", "y", "z"][k],
            a[k],
            a[0],
            a[1],
            a[2]
        ));
    }
    if let Some(k) = a.iter().position(|x| x.abs() > MAX_COORDINATE) {
        return Some(format!(
            "coordinate {} = {:e} is beyond the float32 range (|x| ≤ {:e}) that the \
             output formats store",
            ["x", "y", "z"][k],
            a[k],
            MAX_COORDINATE
        ));
    }
    None
}

/// Why `points` cannot be used, naming the first bad point, or `None`.
///
/// ```
/// use strandfit::{io::curve_problem, DVec3};
///
/// let mut points = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
/// assert_eq!(curve_problem(&points), None);
/// points[2].z = f64::INFINITY;
/// assert!(curve_problem(&points).unwrap().starts_with("point 2: coordinate z"));
/// ```
pub fn curve_problem(points: &[DVec3]) -> Option<String> {
    points
        .iter()
        .enumerate()
        .find_map(|(k, &p)| point_problem(p).map(|why| format!("point {k}: {why}")))
}

/// What a reader does with a curve holding a point that cannot be used
/// (see [`point_problem`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BadCurves {
    /// Stop with an error naming the file, the curve and the point.
    #[default]
    Fail,
    /// Leave the curve out and go on; [`CurveReader::skipped`] lists it.
    Skip,
}

/// A curve left out under [`BadCurves::Skip`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkippedCurve {
    /// 0-based index of the curve in the file.
    pub index: u64,
    /// Why, naming the point.
    pub reason: String,
}

/// Every reader [`open_reader`] returns goes through this check, so that
/// no reader hands on a point that a writer could not store: one place
/// decides what a usable point is, whatever the format.
struct Checked {
    inner: Box<dyn CurveReader>,
    path: PathBuf,
    policy: BadCurves,
    /// Index of the next curve the inner reader gives.
    index: u64,
    skipped: Vec<SkippedCurve>,
    done: bool,
}

impl Iterator for Checked {
    type Item = Result<Curve, IoError>;
    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            let item = match self.inner.next() {
                None => {
                    self.done = true;
                    return None;
                }
                Some(Err(e)) => {
                    self.done = true;
                    return Some(Err(e));
                }
                Some(Ok(c)) => c,
            };
            let index = self.index;
            self.index += 1;
            match curve_problem(&item.points) {
                None => return Some(Ok(item)),
                Some(reason) => match self.policy {
                    BadCurves::Skip => self.skipped.push(SkippedCurve { index, reason }),
                    BadCurves::Fail => {
                        self.done = true;
                        return Some(Err(IoError::new(&self.path, reason).curve(index)));
                    }
                },
            }
        }
        None
    }
}

impl CurveReader for Checked {
    fn metadata(&self) -> &Metadata {
        self.inner.metadata()
    }
    fn skipped(&self) -> &[SkippedCurve] {
        &self.skipped
    }
}

/// A streaming writer. Curves are written in order; [`finish`](Self::finish)
/// completes the file (counts, terminators) and renames it into place.
pub trait CurveWriter {
    /// Write one curve.
    ///
    /// A curve the format cannot store is an error naming the file, the
    /// curve and the point:
    ///
    /// ```
    /// use strandfit::io::{create_writer, Curve, Format, Metadata};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.tck");
    /// let mut w = create_writer(&path, None, &Metadata::new(Format::Json)).unwrap();
    /// w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::X])).unwrap();
    /// let err = w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::NAN])).unwrap_err();
    /// assert_eq!((err.path.file_name(), err.curve), (path.file_name(), Some(1)));
    /// assert!(err.reason.starts_with("point 1"));
    /// ```
    fn write_curve(&mut self, curve: &Curve) -> Result<(), IoError>;

    /// Finish the file (trailers, counts) and move it into place.
    ///
    /// Until then nothing is at the path; a writer dropped unfinished
    /// leaves nothing behind:
    ///
    /// ```
    /// use strandfit::io::{create_writer, read_all, Curve, Format, Metadata};
    /// use strandfit::DVec3;
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.tck");
    /// let mut w = create_writer(&path, None, &Metadata::new(Format::Json)).unwrap();
    /// w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::X])).unwrap();
    /// assert!(!path.exists());
    /// w.finish().unwrap();
    /// let (meta, curves) = read_all(&path, None).unwrap();
    /// assert_eq!((meta.count, curves.len()), (Some(1), 1));
    /// drop(create_writer(&dir.path().join("dropped.tck"), None, &Metadata::new(Format::Json)).unwrap());
    /// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1); // out.tck only
    /// ```
    fn finish(self: Box<Self>) -> Result<(), IoError>;
}

/// The step of a reader's iterator: a curve, the end, or an error after
/// which the iterator is done (`*done` set), so that a reader never goes on
/// from a broken state.
pub(crate) fn fuse<T>(
    done: &mut bool,
    r: Result<Option<T>, IoError>,
) -> Option<Result<T, IoError>> {
    match r {
        Ok(Some(c)) => Some(Ok(c)),
        Ok(None) => {
            *done = true;
            None
        }
        Err(e) => {
            *done = true;
            Some(Err(e))
        }
    }
}

/// Open `path` for reading as `format` (or by its extension, see
/// [`Format::from_path`]). A curve with a point that cannot be used (see
/// [`point_problem`]) is an error naming the file, the curve and the point.
///
/// ```
/// use strandfit::io::{create_writer, open_reader, Curve, CurveReader, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-open-{}.csv", std::process::id()));
/// let mut w = create_writer(&path, None, &Metadata::new(Format::Csv)).unwrap();
/// w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::new(1.5, 0.0, -2.0)])).unwrap();
/// w.finish().unwrap();
/// let reader = open_reader(&path, None).unwrap(); // CSV, by the extension
/// assert_eq!(reader.metadata().format, Format::Csv);
/// let curves: Vec<Curve> = reader.collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(curves.len(), 1);
/// assert_eq!(curves[0].points[1], DVec3::new(1.5, 0.0, -2.0));
/// ```
pub fn open_reader(path: &Path, format: Option<Format>) -> Result<Box<dyn CurveReader>, IoError> {
    open_reader_with(path, format, BadCurves::Fail)
}

/// [`open_reader`], with a choice of what to do with curves holding
/// unusable points.
///
/// A JSON curve with a point beyond float32's range, skipped and listed:
///
/// ```
/// use strandfit::io::{open_reader_with, BadCurves, CurveReader};
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-skip-{}.json", std::process::id()));
/// std::fs::write(&path, r#"{"curves":[{"points":[[0,0,0],[1,0,0]]},
///                          {"points":[[0,0,0],[1e300,1e300,0]]}]}"#).unwrap();
/// let mut reader = open_reader_with(&path, None, BadCurves::Skip).unwrap();
/// let kept: Vec<_> = reader.by_ref().collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(kept.len(), 1);
/// assert_eq!(reader.skipped().len(), 1);
/// assert_eq!(reader.skipped()[0].index, 1);
/// ```
pub fn open_reader_with(
    path: &Path,
    format: Option<Format>,
    bad: BadCurves,
) -> Result<Box<dyn CurveReader>, IoError> {
    let format = match format {
        Some(f) => f,
        None => Format::from_path(path)?,
    };
    Ok(Box::new(Checked {
        inner: format.open_reader(path)?,
        path: path.to_path_buf(),
        policy: bad,
        index: 0,
        skipped: Vec::new(),
        done: false,
    }))
}

/// Create a writer for `path` as `format` (or by its extension). `meta`
/// describes the curves to come (their source convention, data names); a
/// writer of the same format as `meta.format` reproduces the source's
/// header, another format gets what it can express (and drops the rest, as
/// its documentation says).
///
/// A `.tck` file keeps the points (as float32) and drops the rest.
///
/// ```
/// use strandfit::io::{create_writer, read_all, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-create-{}.tck", std::process::id()));
/// let mut w = create_writer(&path, None, &Metadata::new(Format::Json)).unwrap();
/// w.write_curve(&Curve::from_points(vec![DVec3::ZERO, DVec3::new(0.1, 0.2, 0.3)])).unwrap();
/// w.finish().unwrap();
/// let (meta, curves) = read_all(&path, None).unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(meta.format, Format::Tck);
/// assert!(curves[0].points[1].distance(DVec3::new(0.1, 0.2, 0.3)) < 1e-7);
/// ```
pub fn create_writer(
    path: &Path,
    format: Option<Format>,
    meta: &Metadata,
) -> Result<Box<dyn CurveWriter>, IoError> {
    let format = match format {
        Some(f) => f,
        None => Format::from_path(path)?,
    };
    format.create_writer(path, meta)
}

/// Read a whole file into memory (for tests and small inputs).
///
/// ```
/// use strandfit::io::read_all;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-read-all-{}.csv", std::process::id()));
/// std::fs::write(&path, "curve,x,y,z\na,0,0,0\na,1,0,0\nb,0,1,0\nb,0,2,0\nb,0,3,0\n").unwrap();
/// let (_, curves) = read_all(&path, None).unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(curves.iter().map(|c| c.points.len()).collect::<Vec<_>>(), [2, 3]);
/// assert_eq!(curves[1].id.as_deref(), Some("b"));
/// ```
pub fn read_all(path: &Path, format: Option<Format>) -> Result<(Metadata, Vec<Curve>), IoError> {
    let reader = open_reader(path, format)?;
    let meta = reader.metadata().clone();
    let curves = reader.collect::<Result<Vec<_>, _>>()?;
    Ok((meta, curves))
}
