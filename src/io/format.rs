//! File formats, chosen by extension or by name.

use std::path::Path;

use super::{CurveReader, CurveWriter, IoError, Metadata};

/// The curve file formats strandfit reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// MRtrix `.tck`: text header, float32/float64 triplets, NaN separators,
    /// Inf terminator; RAS+ mm.
    Tck,
    /// TrackVis `.trk` v2: 1000-byte header, voxmm coordinates.
    Trk,
    /// VTK legacy POLYDATA with LINES, ASCII or BINARY.
    Vtk,
    /// TRX (tee-ar-ex): a zip archive or folder of `header.json`,
    /// `positions`, `offsets` and per-vertex/per-streamline arrays; RAS+ mm.
    Trx,
    /// Cem Yuksel's `.hair`.
    Hair,
    /// JSON `{"curves":[{"id":…,"points":[[x,y,z],…]},…]}`.
    Json,
    /// CSV `curve,x,y,z` rows, one per point.
    Csv,
}

impl Format {
    /// Every format, in the order the command line lists them.
    pub const ALL: [Format; 7] = [
        Format::Tck,
        Format::Trk,
        Format::Trx,
        Format::Vtk,
        Format::Hair,
        Format::Json,
        Format::Csv,
    ];

    /// The usual extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Tck => "tck",
            Format::Trk => "trk",
            Format::Trx => "trx",
            Format::Vtk => "vtk",
            Format::Hair => "hair",
            Format::Json => "json",
            Format::Csv => "csv",
        }
    }

    /// By name or extension, case-insensitive (`"tck"`, `"TRK"`, …).
    ///
    /// ```
    /// use strandfit::io::Format;
    ///
    /// assert_eq!(Format::from_name("TRK"), Some(Format::Trk));
    /// assert_eq!(Format::from_name("nii"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Format> {
        let n = name.to_ascii_lowercase();
        Format::ALL.into_iter().find(|f| f.extension() == n)
    }

    /// By the extension of `path`.
    ///
    /// ```
    /// use std::path::Path;
    /// use strandfit::io::Format;
    ///
    /// assert_eq!(Format::from_path(Path::new("run/bundle.Tck")).unwrap(), Format::Tck);
    /// let err = Format::from_path(Path::new("bundle.nii")).unwrap_err();
    /// assert!(err.reason.starts_with("cannot tell the format from the extension \"nii\""));
    /// ```
    pub fn from_path(path: &Path) -> Result<Format, IoError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        Format::from_name(ext).ok_or_else(|| {
            IoError::new(
                path,
                format!(
                    "cannot tell the format from the extension {:?}; use one of {} or name the format",
                    ext,
                    Format::ALL.map(|f| f.extension()).join(", ")
                ),
            )
        })
    }

    pub(super) fn open_reader(self, path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
        match self {
            Format::Tck => super::tck::open(path),
            Format::Trk => super::trk::open(path),
            Format::Trx => super::trx::open(path),
            Format::Vtk => super::vtk::open(path),
            Format::Hair => super::hair::open(path),
            Format::Json => super::polyline::open_json(path),
            Format::Csv => super::polyline::open_csv(path),
        }
    }

    pub(super) fn create_writer(
        self,
        path: &Path,
        meta: &Metadata,
    ) -> Result<Box<dyn CurveWriter>, IoError> {
        match self {
            Format::Tck => super::tck::create(path, meta),
            Format::Trk => super::trk::create(path, meta),
            Format::Trx => super::trx::create(path, meta),
            Format::Vtk => super::vtk::create(path, meta),
            Format::Hair => super::hair::create(path, meta),
            Format::Json => super::polyline::create_json(path, meta),
            Format::Csv => super::polyline::create_csv(path, meta),
        }
    }
}

impl Format {
    /// Does a writer of this format keep per-point values named `name`?
    ///
    /// ```
    /// use strandfit::io::Format;
    ///
    /// assert!(Format::Trk.keeps_point_data("fa"));
    /// assert!(!Format::Tck.keeps_point_data("fa"));
    /// assert!(Format::Hair.keeps_point_data("thickness") && !Format::Hair.keeps_point_data("fa"));
    /// ```
    pub fn keeps_point_data(self, name: &str) -> bool {
        match self {
            Format::Tck => false,
            Format::Trk | Format::Trx | Format::Vtk | Format::Json | Format::Csv => true,
            // The format's own arrays only (colour needs all three channels,
            // see `hair`).
            Format::Hair => matches!(
                name,
                "thickness" | "transparency" | "color_r" | "color_g" | "color_b"
            ),
        }
    }

    /// Does a writer of this format keep per-curve values?
    ///
    /// ```
    /// use strandfit::io::Format;
    ///
    /// let keep: Vec<Format> = Format::ALL.into_iter().filter(|f| f.keeps_curve_data()).collect();
    /// assert_eq!(keep, [Format::Trk, Format::Trx, Format::Vtk, Format::Json]);
    /// ```
    pub fn keeps_curve_data(self) -> bool {
        matches!(self, Format::Trk | Format::Trx | Format::Vtk | Format::Json)
    }

    /// What of `meta`'s per-point and per-curve data a writer of this
    /// format drops, one line each (empty when it keeps everything).
    ///
    /// ```
    /// use strandfit::io::{Format, Metadata};
    ///
    /// let mut meta = Metadata::new(Format::Trk);
    /// meta.point_data_names = vec!["fa".into()];
    /// meta.curve_data_names = vec!["length".into()];
    /// assert!(Format::Trx.losses(&meta).is_empty());
    /// let lost = Format::Csv.losses(&meta); // keeps per-point values only
    /// assert_eq!(lost, ["per-curve data `length` (a csv file has no place for them)"]);
    /// ```
    pub fn losses(self, meta: &Metadata) -> Vec<String> {
        data_losses(
            meta,
            |n| self.keeps_point_data(n),
            self.keeps_curve_data(),
            self.extension(),
        )
    }
}

/// What of `meta`'s data a destination drops that keeps per-point values
/// for which `keeps_point` holds, and per-curve values if `keeps_curve`.
///
/// ```
/// use strandfit::io::{data_losses, Format, Metadata};
///
/// let mut meta = Metadata::new(Format::Vtk);
/// meta.point_data_names = vec!["fa".into(), "md".into()];
/// let lost = data_losses(&meta, |name| name == "fa", true, "viewer");
/// assert_eq!(lost, ["per-point data `md` (a viewer file has no place for them)"]);
/// ```
pub fn data_losses(
    meta: &Metadata,
    keeps_point: impl Fn(&str) -> bool,
    keeps_curve: bool,
    destination: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    let point: Vec<&str> = meta
        .point_data_names
        .iter()
        .map(String::as_str)
        .filter(|n| !keeps_point(n))
        .collect();
    if !point.is_empty() {
        out.push(format!(
            "per-point data {} (a {destination} file has no place for them)",
            quoted(&point)
        ));
    }
    if !keeps_curve && !meta.curve_data_names.is_empty() {
        let names: Vec<&str> = meta.curve_data_names.iter().map(String::as_str).collect();
        out.push(format!(
            "per-curve data {} (a {destination} file has no place for them)",
            quoted(&names)
        ));
    }
    out
}

/// What the reader of `meta`'s source saw but does not carry (TRX groups
/// and data per group, VTK colour scalars and lookup tables, …), one line
/// each.
///
/// ```
/// use strandfit::io::{source_losses, Format, Metadata};
///
/// let mut meta = Metadata::new(Format::Trx);
/// meta.extra.push(("groups.dropped".into(), "2 groups".into()));
/// meta.extra.push(("title".into(), "kept".into()));
/// assert_eq!(source_losses(&meta), ["2 groups (found in the trx source, not read)"]);
/// ```
pub fn source_losses(meta: &Metadata) -> Vec<String> {
    meta.extra
        .iter()
        .filter(|(k, _)| k.ends_with(".dropped"))
        .map(|(_, v)| format!("{v} (found in the {} source, not read)", meta.format))
        .collect()
}

fn quoted(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.extension())
    }
}
