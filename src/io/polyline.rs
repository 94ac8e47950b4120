//! Plain polylines: JSON (one document) and CSV (one row per point). The
//! formats are described on `open_json` and `open_csv`.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;

use super::bytes::ByteSource;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, Format, IoError, Metadata};

/// A CSV row's point and per-point values.
type Row = (DVec3, Vec<f32>);

/// Longest CSV line accepted (a guard against binary input).
const CSV_MAX_LINE: usize = 1 << 16;

#[derive(Deserialize)]
struct JsonDoc {
    #[serde(default)]
    units: Option<String>,
    curves: Vec<JsonCurve>,
}

#[derive(Deserialize)]
struct JsonCurve {
    #[serde(default)]
    id: Option<serde_json::Value>,
    points: Vec<[f64; 3]>,
    /// `null` is a NaN value (what the writer writes for one).
    #[serde(default)]
    point_data: BTreeMap<String, Vec<Option<f64>>>,
    #[serde(default)]
    curve_data: BTreeMap<String, Option<f64>>,
}

/// Open a JSON polyline file (read whole; see [Format](open_json#format)).
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_json;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-open-json-{}.json", std::process::id()));
/// std::fs::write(&path, r#"{"curves": [{"points": [[0, 0]]}]}"#).unwrap(); // two coordinates
/// let err = open_json(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert!(err.reason.starts_with("not a polyline JSON document"));
/// assert!(err.at.unwrap().starts_with("line 1, column"));
/// ```
///
/// # Format
///
/// JSON, read whole into memory (it is the format for small data and for
/// hand-made inputs; the binary formats stream):
///
/// ```json
/// {"units": "mm",
///  "curves": [{"id": "a", "points": [[x, y, z], …],
///              "point_data": {"fa": [v0, v1, …]}, "curve_data": {"weight": w}}, …]}
/// ```
///
/// `units`, `id`, `point_data` and `curve_data` are optional; all curves
/// must carry the same data names. Other fields (e.g. the `tangents` that
/// `strandfit evaluate --tangents` writes) are ignored, so `evaluate`'s
/// output reads as polylines. Numbers are written with the shortest
/// representation that reads back to the same `f64`.
pub fn open_json(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    let text = std::fs::read_to_string(path).map_err(|e| IoError::os(path, "cannot read", e))?;
    let doc: JsonDoc = serde_json::from_str(&text).map_err(|e| {
        IoError::new(path, format!("not a polyline JSON document: {e}")).at(format!(
            "line {}, column {}",
            e.line(),
            e.column()
        ))
    })?;
    let mut meta = Metadata::new(Format::Json);
    meta.units = doc.units;
    meta.count = Some(doc.curves.len() as u64);
    if let Some(first) = doc.curves.first() {
        meta.point_data_names = first.point_data.keys().cloned().collect();
        meta.curve_data_names = first.curve_data.keys().cloned().collect();
    }
    let mut curves = Vec::with_capacity(doc.curves.len());
    for (i, c) in doc.curves.into_iter().enumerate() {
        let err = |reason: String| {
            IoError::new(path, reason)
                .curve(i as u64)
                .at(format!("curves[{i}]"))
        };
        let pd: Vec<&String> = c.point_data.keys().collect();
        let cd: Vec<&String> = c.curve_data.keys().collect();
        if pd.iter().copied().ne(meta.point_data_names.iter())
            || cd.iter().copied().ne(meta.curve_data_names.iter())
        {
            return Err(err(format!(
                "its data names (point_data {pd:?}, curve_data {cd:?}) differ from the first curve's ({:?}, {:?})",
                meta.point_data_names, meta.curve_data_names
            )));
        }
        let n = c.points.len();
        let mut point_data = Vec::with_capacity(n * pd.len());
        for (name, values) in &c.point_data {
            if values.len() != n {
                return Err(err(format!(
                    "point_data \"{name}\" has {} values for {n} points",
                    values.len()
                )));
            }
        }
        for k in 0..n {
            point_data.extend(
                c.point_data
                    .values()
                    .map(|v| v[k].map_or(f32::NAN, |x| x as f32)),
            );
        }
        let id = c.id.map(|v| match v {
            serde_json::Value::String(s) => s,
            other => other.to_string(),
        });
        // JSON has no NaN or Inf literal and serde refuses numbers beyond
        // f64; the range check is `io::open_reader`'s.
        let points: Vec<DVec3> = c.points.iter().map(|p| DVec3::from_array(*p)).collect();
        curves.push(Curve {
            id,
            points,
            point_data,
            curve_data: c
                .curve_data
                .values()
                .map(|v| v.map_or(f32::NAN, |x| x as f32))
                .collect(),
        });
    }
    Ok(Box::new(VecReader {
        meta,
        curves: curves.into_iter(),
    }))
}

/// Index of the first non-finite point, if any.
fn check_finite(points: &[DVec3]) -> Result<(), usize> {
    match points.iter().position(|p| !p.is_finite()) {
        Some(k) => Err(k),
        None => Ok(()),
    }
}

/// Curves already in memory, as a [`CurveReader`] (e.g. arrays handed over
/// by a program; the caller checks the points).
pub struct VecReader {
    meta: Metadata,
    curves: std::vec::IntoIter<Curve>,
}

impl VecReader {
    /// A reader that yields `curves` with metadata `meta`.
    pub fn new(meta: Metadata, curves: Vec<Curve>) -> Self {
        VecReader {
            meta,
            curves: curves.into_iter(),
        }
    }
}

impl Iterator for VecReader {
    type Item = Result<Curve, IoError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.curves.next().map(Ok)
    }
}

impl CurveReader for VecReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

/// Streams curves into a JSON document.
struct JsonWriter {
    out: AtomicFile,
    meta: Metadata,
    written: u64,
}

/// Create a JSON polyline writer (the format of [`open_json`]).
///
/// Curve names and per-curve values are kept:
///
/// ```
/// use strandfit::io::{create_json, open_json, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-create-json-{}.json", std::process::id()));
/// let mut meta = Metadata::new(Format::Json);
/// meta.curve_data_names = vec!["length".into()];
/// let curve = Curve {
///     id: Some("arc".into()),
///     curve_data: vec![1.5],
///     ..Curve::from_points(vec![DVec3::ZERO, DVec3::new(0.5, 0.25, 1.0)])
/// };
/// let mut w = create_json(&path, &meta).unwrap();
/// w.write_curve(&curve).unwrap();
/// w.finish().unwrap();
/// let back: Vec<Curve> = open_json(&path).unwrap().collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(back, [curve]);
/// ```
pub fn create_json(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    let mut out = AtomicFile::create(path)?;
    let head = match &meta.units {
        Some(u) => format!("{{\"units\":{},\"curves\":[", json_str(u)),
        None => "{\"curves\":[".to_string(),
    };
    out.write_all(head.as_bytes()).map_err(|e| out.err(e))?;
    Ok(Box::new(JsonWriter {
        out,
        meta: meta.clone(),
        written: 0,
    }))
}

fn json_str(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

/// Shortest round-trip decimal of a finite `f64` (JSON has no NaN).
fn num(x: f64) -> String {
    serde_json::Number::from_f64(x)
        .map(|n| n.to_string())
        .unwrap_or_else(|| "null".into())
}

impl CurveWriter for JsonWriter {
    fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
        let i = self.written;
        let err = |r: String| IoError::new(self.out.target(), r).curve(i);
        check_finite(&c.points).map_err(|k| err(format!("point {k} is not finite")))?;
        // NaN data are written as `null` and read back as NaN; JSON has no
        // way to write an infinity.
        if let Some(v) = c
            .point_data
            .iter()
            .chain(&c.curve_data)
            .find(|v| v.is_infinite())
        {
            return Err(err(format!("a data value is {v}, which JSON cannot hold")));
        }
        let np = self.meta.point_data_names.len();
        if c.point_data.len() != c.points.len() * np
            || c.curve_data.len() != self.meta.curve_data_names.len()
        {
            return Err(err("its data do not match the metadata's data names".into()));
        }
        let mut s = String::with_capacity(32 * c.points.len() + 64);
        if i > 0 {
            s.push(',');
        }
        s.push_str("\n{");
        match &c.id {
            Some(id) => s.push_str(&format!("\"id\":{},", json_str(id))),
            None => s.push_str(&format!("\"id\":{i},")),
        }
        s.push_str("\"points\":[");
        for (k, p) in c.points.iter().enumerate() {
            if k > 0 {
                s.push(',');
            }
            s.push_str(&format!("[{},{},{}]", num(p.x), num(p.y), num(p.z)));
        }
        s.push(']');
        if np > 0 {
            s.push_str(",\"point_data\":{");
            for (j, name) in self.meta.point_data_names.iter().enumerate() {
                if j > 0 {
                    s.push(',');
                }
                s.push_str(&json_str(name));
                s.push_str(":[");
                for k in 0..c.points.len() {
                    if k > 0 {
                        s.push(',');
                    }
                    s.push_str(&num(c.point_data[k * np + j] as f64));
                }
                s.push(']');
            }
            s.push('}');
        }
        if !c.curve_data.is_empty() {
            s.push_str(",\"curve_data\":{");
            for (j, (name, v)) in self
                .meta
                .curve_data_names
                .iter()
                .zip(&c.curve_data)
                .enumerate()
            {
                if j > 0 {
                    s.push(',');
                }
                s.push_str(&format!("{}:{}", json_str(name), num(*v as f64)));
            }
            s.push('}');
        }
        s.push('}');
        self.out
            .write_all(s.as_bytes())
            .map_err(|e| self.out.err(e))?;
        self.written += 1;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<(), IoError> {
        self.out.write_all(b"\n]}\n").map_err(|e| self.out.err(e))?;
        self.out.commit()
    }
}

/// Streaming CSV reader.
struct CsvReader {
    src: ByteSource,
    meta: Metadata,
    line_no: u64,
    /// The first row of the next curve, already read (and its line).
    #[allow(clippy::type_complexity)]
    pending: Option<(String, Result<Option<Row>, String>)>,
    /// Curve ids seen, to catch a curve split over non-consecutive rows.
    seen: std::collections::HashSet<String>,
    index: u64,
    done: bool,
}

/// Open a CSV polyline file (streamed; see [Format](open_csv#format)).
///
/// A file that is not one is an error naming the file and the line:
///
/// ```
/// use strandfit::io::open_csv;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-open-csv-{}.csv", std::process::id()));
/// std::fs::write(&path, "id,x,y\n").unwrap();
/// let err = open_csv(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(err.at.as_deref(), Some("line 1"));
/// assert_eq!(err.reason, "the header must start with `curve,x,y,z`, found `id,x,y`");
/// ```
///
/// # Format
///
/// CSV, streamed: a header `curve,x,y,z[,name…]` (extra columns are per-point
/// values), then one row per point; consecutive rows with the same `curve`
/// value form one curve. The header is required (a file without one is not
/// guessed at), so that a column shift cannot go unnoticed. A curve with no
/// points is one row with its id and every other field empty (`c7,,,`), so
/// that it survives a round trip instead of vanishing.
pub fn open_csv(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    let mut src = ByteSource::open(path)?;
    let header = src
        .line(CSV_MAX_LINE)?
        .ok_or_else(|| IoError::new(path, "empty file: a CSV needs the header `curve,x,y,z`"))?;
    let cols: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
    if cols.len() < 4 || cols[..4] != ["curve", "x", "y", "z"] {
        return Err(IoError::new(
            path,
            format!("the header must start with `curve,x,y,z`, found `{header}`"),
        )
        .at("line 1"));
    }
    let mut meta = Metadata::new(Format::Csv);
    meta.point_data_names = cols[4..].to_vec();
    let mut r = CsvReader {
        src,
        meta,
        line_no: 1,
        pending: None,
        seen: Default::default(),
        index: 0,
        done: false,
    };
    r.pending = r.row()?;
    Ok(Box::new(r))
}

impl CsvReader {
    fn err(&self, reason: String) -> IoError {
        IoError::new(self.src.path(), reason)
            .curve(self.index)
            .at(format!("line {}", self.line_no))
    }

    /// The next non-blank row: its curve id and the parsed values, or the
    /// reason it does not parse (the caller knows which curve it is in).
    #[allow(clippy::type_complexity)]
    fn row(&mut self) -> Result<Option<(String, Result<Option<Row>, String>)>, IoError> {
        loop {
            let Some(line) = self
                .src
                .line(CSV_MAX_LINE)
                .map_err(|e| e.curve(self.index))?
            else {
                return Ok(None);
            };
            self.line_no += 1;
            if line.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            return Ok(Some((fields[0].to_string(), self.parse(&fields))));
        }
    }

    /// A point and its values, or `None` for the row of an empty curve.
    fn parse(&self, fields: &[&str]) -> Result<Option<Row>, String> {
        let want = 4 + self.meta.point_data_names.len();
        if fields.len() != want {
            return Err(format!(
                "{} fields where the header has {want}",
                fields.len()
            ));
        }
        if fields[1..].iter().all(|f| f.is_empty()) {
            return Ok(None);
        }
        let mut xyz = [0.0; 3];
        for (k, f) in fields[1..4].iter().enumerate() {
            // `nan`, `inf` and 1e999 parse; `io::open_reader` refuses (or
            // skips) the curve, naming the point.
            xyz[k] = f
                .parse::<f64>()
                .map_err(|_| format!("`{f}` is not a number"))?;
        }
        let data = fields[4..]
            .iter()
            .map(|f| {
                f.parse::<f32>()
                    .map_err(|_| format!("`{f}` is not a number"))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Some((DVec3::from_array(xyz), data)))
    }

    fn next_curve(&mut self) -> Result<Option<Curve>, IoError> {
        let Some((id, first)) = self.pending.take() else {
            return Ok(None);
        };
        if !self.seen.insert(id.clone()) {
            return Err(self.err(format!(
                "curve `{id}` continues here after other curves' rows; rows of a curve must be consecutive"
            )));
        }
        let first = first.map_err(|r| self.err(r))?;
        let empty = first.is_none();
        let mut curve = Curve {
            id: Some(id.clone()),
            ..Default::default()
        };
        if let Some((p, d)) = first {
            curve.points.push(p);
            curve.point_data = d;
        }
        while let Some((next_id, row)) = self.row()? {
            if next_id != id {
                // The next curve's first row: its errors are that curve's.
                self.pending = Some((next_id, row));
                break;
            }
            match row.map_err(|r| self.err(r))? {
                Some((p, d)) if !empty => {
                    curve.points.push(p);
                    curve.point_data.extend(d);
                }
                _ => {
                    return Err(self.err(format!(
                        "curve `{id}` has both an empty row (no point) and other rows; \
                         an empty curve is one row with every field but the id empty"
                    )))
                }
            }
        }
        Ok(Some(curve))
    }
}

impl Iterator for CsvReader {
    type Item = Result<Curve, IoError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.next_curve();
        if matches!(r, Ok(Some(_))) {
            self.index += 1;
        }
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for CsvReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

struct CsvWriter {
    out: AtomicFile,
    np: usize,
    written: u64,
    target: PathBuf,
}

/// Create a CSV polyline writer (per-point data become extra columns; per-
/// curve data are dropped, CSV has no place for them).
///
/// ```
/// use strandfit::io::{create_csv, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-create-csv-{}.csv", std::process::id()));
/// let mut meta = Metadata::new(Format::Trk);
/// meta.point_data_names = vec!["fa".into()];
/// let curve = Curve { point_data: vec![0.5, 0.75], ..Curve::from_points(vec![DVec3::ZERO, DVec3::Z]) };
/// let mut w = create_csv(&path, &meta).unwrap();
/// w.write_curve(&curve).unwrap();
/// w.finish().unwrap();
/// let text = std::fs::read_to_string(&path).unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(text.lines().count(), 3); // the header, then a row per point
/// assert!(text.starts_with("curve,x,y,z,fa\n"));
/// ```
pub fn create_csv(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    let mut out = AtomicFile::create(path)?;
    let mut head = String::from("curve,x,y,z");
    for n in &meta.point_data_names {
        if n.contains(',') || n.contains('\n') {
            return Err(IoError::new(
                path,
                format!("data name `{n}` cannot be a CSV column"),
            ));
        }
        head.push(',');
        head.push_str(n);
    }
    head.push('\n');
    out.write_all(head.as_bytes()).map_err(|e| out.err(e))?;
    Ok(Box::new(CsvWriter {
        out,
        np: meta.point_data_names.len(),
        written: 0,
        target: path.to_path_buf(),
    }))
}

impl CurveWriter for CsvWriter {
    fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
        let i = self.written;
        let err = |r: String| IoError::new(&self.target, r).curve(i);
        check_finite(&c.points).map_err(|k| err(format!("point {k} is not finite")))?;
        if c.point_data.len() != c.points.len() * self.np {
            return Err(err(
                "its point data do not match the metadata's data names".into()
            ));
        }
        let id = match &c.id {
            Some(id) if !id.contains(',') && !id.contains('\n') && !id.trim().is_empty() => {
                id.clone()
            }
            Some(id) => return Err(err(format!("curve id `{id}` cannot be a CSV field"))),
            None => i.to_string(),
        };
        let mut s = String::with_capacity(48 * c.points.len());
        if c.points.is_empty() {
            // The empty-curve row (see `open_csv`, Format).
            s.push_str(&id);
            s.push_str(&",".repeat(3 + self.np));
            s.push('\n');
        }
        for (k, p) in c.points.iter().enumerate() {
            s.push_str(&format!("{id},{},{},{}", num(p.x), num(p.y), num(p.z)));
            for v in &c.point_data[k * self.np..(k + 1) * self.np] {
                s.push(',');
                // NaN and ±Inf as `NaN`/`inf`/`-inf`, which read back.
                if v.is_finite() {
                    s.push_str(&num(*v as f64));
                } else {
                    s.push_str(&v.to_string());
                }
            }
            s.push('\n');
        }
        self.out
            .write_all(s.as_bytes())
            .map_err(|e| self.out.err(e))?;
        self.written += 1;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), IoError> {
        self.out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curves() -> (Metadata, Vec<Curve>) {
        let mut meta = Metadata::new(Format::Json);
        meta.units = Some("mm".into());
        meta.point_data_names = vec!["fa".into(), "md".into()];
        let c = |id: &str, n: usize, s: f64| Curve {
            id: Some(id.into()),
            points: (0..n)
                .map(|k| DVec3::new(s * k as f64, 0.1 + 1.0 / 3.0 * k as f64, -1e-7 * k as f64))
                .collect(),
            point_data: (0..2 * n).map(|k| 0.25 * k as f32 + 0.1).collect(),
            curve_data: vec![],
        };
        (meta, vec![c("a", 3, 1.5), c("b,", 0, 1.0), c("c", 1, -2.0)])
    }

    fn roundtrip(format: Format, cs: Vec<Curve>, meta: &Metadata) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("x.{format}"));
        let mut w = format.create_writer(&path, meta).unwrap();
        for c in &cs {
            w.write_curve(c).unwrap();
        }
        w.finish().unwrap();
        let (m2, back) = super::super::read_all(&path, None).unwrap();
        assert_eq!(m2.point_data_names, meta.point_data_names);
        // Empty curves too (CSV: the `id,,,` row).
        assert_eq!(back, cs, "{format} round trip");
    }

    #[test]
    fn json_roundtrip_is_exact() {
        let (meta, cs) = curves();
        roundtrip(Format::Json, cs, &meta);
    }

    #[test]
    fn csv_roundtrip_is_exact() {
        let (meta, mut cs) = curves();
        cs[1].id = Some("b".into()); // a comma cannot be a CSV field
        roundtrip(Format::Csv, cs, &meta);
    }

    #[test]
    fn nan_data_values_read_back_and_infinities_are_refused() {
        for format in [Format::Json, Format::Csv] {
            let (mut meta, mut cs) = curves();
            cs[1].id = Some("b".into());
            cs[0].point_data[3] = f32::NAN;
            if format == Format::Json {
                meta.curve_data_names = vec!["w".into()];
                for (k, c) in cs.iter_mut().enumerate() {
                    c.curve_data = vec![if k == 2 { f32::NAN } else { k as f32 }];
                }
            }
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join(format!("x.{format}"));
            let mut w = format.create_writer(&path, &meta).unwrap();
            for c in &cs {
                w.write_curve(c).unwrap();
            }
            w.finish().unwrap();
            let (_, back) = super::super::read_all(&path, None).unwrap();
            let bits = |cs: &[Curve]| -> Vec<Vec<u32>> {
                cs.iter()
                    .map(|c| {
                        c.point_data
                            .iter()
                            .chain(&c.curve_data)
                            .map(|v| v.to_bits())
                            .collect()
                    })
                    .collect()
            };
            assert_eq!(bits(&back), bits(&cs), "{format}");
        }
        // JSON cannot write an infinity: an error, not a file that fails
        // to read back.
        let (meta, mut cs) = curves();
        cs[0].point_data[0] = f32::INFINITY;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.json");
        let mut w = create_json(&path, &meta).unwrap();
        let e = w.write_curve(&cs[0]).unwrap_err().to_string();
        assert!(e.contains("curve 0") && e.contains("inf"), "{e}");
    }

    #[test]
    fn csv_writer_refuses_ids_it_cannot_write() {
        let (meta, cs) = curves();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.csv");
        let mut w = create_csv(&path, &meta).unwrap();
        let e = w
            .write_curve(&Curve {
                points: vec![DVec3::ZERO],
                point_data: vec![0.0, 0.0],
                ..cs[1].clone()
            })
            .unwrap_err();
        assert!(
            e.to_string().contains("curve 0") && e.to_string().contains("b,"),
            "{e}"
        );
        drop(w);
        assert!(!path.exists(), "an unfinished writer leaves nothing behind");
    }

    fn write(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        (dir, p)
    }

    fn read_err(name: &str, text: &str) -> String {
        let (_d, p) = write(name, text);
        let e = super::super::read_all(&p, None).unwrap_err().to_string();
        assert!(e.contains(name), "error names the file: {e}");
        e
    }

    #[test]
    fn bad_inputs_are_named_errors() {
        let e = read_err(
            "a.json",
            "{\"curves\":[{\"points\":[[0,0,0]]},{\"points\":[[0,0]]}]}",
        );
        assert!(e.contains("line 1"), "{e}");
        let e = read_err("a.json", "{\"curves\":[{\"points\":[[0,0,1e999]]}]}");
        assert!(e.contains("line 1"), "{e}");
        let e = read_err(
            "a.json",
            "{\"curves\":[{\"points\":[[0,0,0]],\"point_data\":{\"fa\":[1,2]}}]}",
        );
        assert!(
            e.contains("curve 0") && e.contains("2 values for 1 points"),
            "{e}"
        );
        let e = read_err(
            "a.json",
            "{\"curves\":[{\"points\":[]},{\"points\":[],\"curve_data\":{\"w\":1}}]}",
        );
        assert!(e.contains("curve 1") && e.contains("differ"), "{e}");
        let e = read_err("a.csv", "x,y,z\n1,2,3\n");
        assert!(e.contains("curve,x,y,z"), "{e}");
        let e = read_err("a.csv", "curve,x,y,z\na,1,2,3\na,1,2\n");
        assert!(e.contains("line 3") && e.contains("3 fields"), "{e}");
        let e = read_err("a.csv", "curve,x,y,z\na,1,2,3\nb,1,2,3\nc,1,2,nan\n");
        assert!(e.contains("curve 2: point 0: coordinate z is NaN"), "{e}");
        let e = read_err("a.csv", "curve,x,y,z\na,1,2,3\nb,1,2,3\nb,1,1e300,3\n");
        assert!(
            e.contains("curve 1: point 1: coordinate y = 1e300 is beyond the float32 range"),
            "{e}"
        );
        let e = read_err("a.json", "{\"curves\":[{\"points\":[[0,0,0],[4e38,0,0]]}]}");
        assert!(e.contains("curve 0: point 1: coordinate x = 4e38"), "{e}");
        let e = read_err("a.csv", "curve,x,y,z\na,,,\na,1,2,3\n");
        assert!(e.contains("both an empty row"), "{e}");
        let e = read_err("a.csv", "curve,x,y,z\na,1,2,3\nb,1,2,3\na,1,2,4\n");
        assert!(e.contains("consecutive") && e.contains("line 4"), "{e}");
        let e = read_err("a.csv", "");
        assert!(e.contains("empty"), "{e}");
    }

    #[test]
    fn corrupted_files_never_panic() {
        use rand::{Rng, SeedableRng};
        let (meta, cs) = curves();
        let dir = tempfile::tempdir().unwrap();
        for format in [Format::Json, Format::Csv] {
            let path = dir.path().join(format!("x.{format}"));
            let mut w = format.create_writer(&path, &meta).unwrap();
            for c in cs.iter().filter(|c| c.id.as_deref() != Some("b,")) {
                w.write_curve(c).unwrap();
            }
            w.finish().unwrap();
            let good = std::fs::read(&path).unwrap();
            let bad = dir.path().join(format!("bad.{format}"));
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
            for cut in 0..good.len() {
                std::fs::write(&bad, &good[..cut]).unwrap();
                let _ = super::super::read_all(&bad, None);
            }
            for _ in 0..300 {
                let mut b = good.clone();
                for _ in 0..rng.gen_range(1..4) {
                    let i = rng.gen_range(0..b.len());
                    b[i] = rng.gen();
                }
                std::fs::write(&bad, &b).unwrap();
                let _ = super::super::read_all(&bad, None);
            }
        }
    }
}
