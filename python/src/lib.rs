//! `strandfit._strandfit`: the thin PyO3 layer over the Rust library. It
//! converts arrays and errors and releases the GIL during the work; the
//! Python package (`strandfit/__init__.py`) checks and normalises the
//! inputs, documents the API and holds the adapters.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyIndexError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use strandfit::codec::{
    compress_stream, compress_to_bytes, decompress_stream, output_curve, read_range, CodecHeader,
    CodecReader, DecodedCurve, Effort,
};
use strandfit::io::{
    create_writer, curve_problem, data_losses, open_reader_with, source_losses, BadCurves, Curve,
    CurveReader, Format, IoError, Metadata, SourceMeta, VecReader,
};
use strandfit::DVec3;

/// The name arrays go by in messages.
const ARRAYS: &str = "<arrays>";

/// An I/O error as Python's: `OSError` where the operating system refused,
/// `ValueError` for bad data (the message names the file and curve).
fn py_err(e: IoError) -> PyErr {
    if e.os_error.is_some() {
        PyOSError::new_err(e.to_string())
    } else {
        PyValueError::new_err(e.to_string())
    }
}

fn check_tolerance(tolerance: f64) -> PyResult<()> {
    if tolerance > 0.0 && tolerance.is_finite() {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "tolerance must be positive and finite, got {tolerance}"
        )))
    }
}

/// `"default"` or `"best"`, as the command line's `--effort`.
fn effort_from(effort: &str) -> PyResult<Effort> {
    Effort::from_name(effort).ok_or_else(|| {
        PyValueError::new_err(format!(
            "effort must be \"default\" or \"best\", got {effort:?}"
        ))
    })
}

/// Curves from `(P, 3)` positions and `C + 1` offsets, every point checked.
fn curves_from(positions: &PyReadonlyArray2<f64>, offsets: &[i64]) -> PyResult<Vec<Curve>> {
    let pos = positions.as_array();
    if pos.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "positions must have shape (P, 3), got (P, {})",
            pos.ncols()
        )));
    }
    let p = pos.nrows() as i64;
    if offsets.is_empty() || offsets[0] != 0 || *offsets.last().unwrap() != p {
        return Err(PyValueError::new_err(format!(
            "offsets must run from 0 to the number of points ({p}), one more than the curves"
        )));
    }
    let mut curves = Vec::with_capacity(offsets.len() - 1);
    for (c, w) in offsets.windows(2).enumerate() {
        if w[1] < w[0] {
            return Err(PyValueError::new_err(format!(
                "offsets must not decrease: offsets[{c}] = {} > offsets[{}] = {}",
                w[0],
                c + 1,
                w[1]
            )));
        }
        let points: Vec<DVec3> = (w[0] as usize..w[1] as usize)
            .map(|k| DVec3::new(pos[[k, 0]], pos[[k, 1]], pos[[k, 2]]))
            .collect();
        if let Some(why) = curve_problem(&points) {
            return Err(PyValueError::new_err(format!("{ARRAYS}, curve {c}: {why}")));
        }
        curves.push(Curve::from_points(points));
    }
    Ok(curves)
}

/// Decoded curves as NumPy arrays: `(positions, offsets)`.
type Arrays<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<i64>>);

/// Positions (float32, as files hold them and as the guarantee is made
/// for) and offsets of decoded curves.
fn to_arrays<'py>(py: Python<'py>, curves: &[DecodedCurve]) -> Arrays<'py> {
    let total: usize = curves.iter().map(|c| c.points.len()).sum();
    let mut flat = Vec::with_capacity(3 * total);
    let mut offsets = Vec::with_capacity(curves.len() + 1);
    offsets.push(0i64);
    for c in curves {
        for p in &c.points {
            flat.extend([p.x as f32, p.y as f32, p.z as f32]);
        }
        offsets.push((flat.len() / 3) as i64);
    }
    let positions = Array2::from_shape_vec((total, 3), flat).expect("3 per point");
    (positions.into_pyarray(py), offsets.into_pyarray(py))
}

/// compress_arrays(positions, offsets, tolerance, effort="default") ->
/// bytes (see the Python package's docstring).
#[pyfunction]
#[pyo3(signature = (positions, offsets, tolerance, effort="default"))]
fn compress_arrays<'py>(
    py: Python<'py>,
    positions: PyReadonlyArray2<'py, f64>,
    offsets: PyReadonlyArray1<'py, i64>,
    tolerance: f64,
    effort: &str,
) -> PyResult<Bound<'py, PyBytes>> {
    check_tolerance(tolerance)?;
    let effort = effort_from(effort)?;
    let curves = curves_from(&positions, offsets.as_slice()?)?;
    let bytes = py
        .allow_threads(|| -> Result<Vec<u8>, IoError> {
            let meta = Metadata::new(Format::Json);
            let mut source = SourceMeta::from_metadata(&meta, None);
            source.format = "numpy".into();
            let mut header = CodecHeader::new(tolerance, source, Vec::new());
            header.effort = effort;
            let mut reader = VecReader::new(meta, curves);
            compress_to_bytes(&mut reader, Path::new(ARRAYS), &header, None)
        })
        .map_err(py_err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// With `strict`, what the output cannot hold is an error (as the command
/// line's `--strict`); otherwise it is reported in the result's `dropped`.
fn refuse_losses(src: &Path, dst: &Path, dropped: &[String], strict: bool) -> Result<(), IoError> {
    if strict && !dropped.is_empty() {
        return Err(IoError::new(
            src,
            format!(
                "writing {} would drop {} (strict)",
                dst.display(),
                dropped.join("; ")
            ),
        ));
    }
    Ok(())
}

/// `points` at least 2 and `step` positive, as the command line checks.
fn check_resampling(points: Option<usize>, step: Option<f64>) -> PyResult<()> {
    if points.is_some() && step.is_some() {
        return Err(PyValueError::new_err("give points or step, not both"));
    }
    if matches!(points, Some(m) if m < 2) {
        return Err(PyValueError::new_err("points must be at least 2"));
    }
    if let Some(s) = step {
        if !(s > 0.0 && s.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "step must be positive, got {s}"
            )));
        }
    }
    Ok(())
}

/// Decoded curves resampled as asked (`None`, `None`: as decoded).
fn resampled(
    curves: Vec<DecodedCurve>,
    points: Option<usize>,
    step: Option<f64>,
) -> Vec<DecodedCurve> {
    if points.is_none() && step.is_none() {
        return curves;
    }
    curves
        .into_iter()
        .map(|mut c| {
            // Per-point values are not returned with arrays.
            c.point_data.clear();
            let out = output_curve(c, points, step, 0);
            DecodedCurve {
                id: out.id,
                points: out.points,
                point_data: out.point_data,
                curve_data: out.curve_data,
            }
        })
        .collect()
}

/// decompress_arrays(data, points=None, step=None) -> (positions, offsets).
#[pyfunction]
#[pyo3(signature = (data, points=None, step=None))]
fn decompress_arrays<'py>(
    py: Python<'py>,
    data: &[u8],
    points: Option<usize>,
    step: Option<f64>,
) -> PyResult<Arrays<'py>> {
    check_resampling(points, step)?;
    let data = data.to_vec();
    let curves = py
        .allow_threads(|| -> Result<Vec<DecodedCurve>, IoError> {
            let mut reader = CodecReader::from_bytes(data)?;
            let n = reader.curve_count();
            Ok(resampled(read_range(&mut reader, 0, n)?, points, step))
        })
        .map_err(py_err)?;
    Ok(to_arrays(py, &curves))
}

/// compress_file(src, dst, tolerance, strict=False, skip_bad=False,
/// effort="default") -> dict: what `strandfit compress SRC --tolerance T
/// -o DST --json` does (the same bytes, the same report).
#[pyfunction]
#[pyo3(signature = (src, dst, tolerance, strict=false, skip_bad=false, effort="default"))]
fn compress_file<'py>(
    py: Python<'py>,
    src: PathBuf,
    dst: PathBuf,
    tolerance: f64,
    strict: bool,
    skip_bad: bool,
    effort: &str,
) -> PyResult<Bound<'py, PyDict>> {
    check_tolerance(tolerance)?;
    let effort = effort_from(effort)?;
    let started = std::time::Instant::now();
    let bad = if skip_bad {
        BadCurves::Skip
    } else {
        BadCurves::Fail
    };
    let (summary, dropped, skipped) = py
        .allow_threads(|| {
            let mut reader = open_reader_with(&src, None, bad)?;
            let meta = reader.metadata().clone();
            let mut dropped = source_losses(&meta);
            dropped.extend(data_losses(&meta, |_| true, true, "sfh"));
            refuse_losses(&src, &dst, &dropped, strict)?;
            let mut header = CodecHeader::new(
                tolerance,
                SourceMeta::from_metadata(&meta, None),
                meta.point_data_names.clone(),
            );
            header.effort = effort;
            let summary = compress_stream(&mut *reader, &src, &dst, &header, None, &mut |_| {})
                .map_err(|mut e| {
                    // As counted in the input, skipped curves included.
                    if e.path == src {
                        if let Some(mut c) = e.curve {
                            for s in reader.skipped() {
                                if s.index <= c {
                                    c += 1;
                                }
                            }
                            e.curve = Some(c);
                        }
                    }
                    e
                })?;
            let skipped: Vec<u64> = reader.skipped().iter().map(|s| s.index).collect();
            Ok((summary, dropped, skipped))
        })
        .map_err(py_err)?;
    let bytes_in = std::fs::metadata(&src).map(|m| m.len()).unwrap_or(0);
    let seconds = started.elapsed().as_secs_f64();
    // The keys of the command line's `--json` report, in its order
    // (docs/schemas/compress.schema.json).
    let d = PyDict::new(py);
    d.set_item("version", strandfit::cli::JSON_VERSION)?;
    d.set_item("input", src.display().to_string())?;
    d.set_item("output", dst.display().to_string())?;
    d.set_item("curve_count", summary.curves)?;
    d.set_item("point_count", summary.points)?;
    d.set_item("element_count", 0)?;
    d.set_item("bytes_in", bytes_in)?;
    d.set_item("bytes_out", summary.bytes)?;
    d.set_item("ratio", bytes_in as f64 / summary.bytes.max(1) as f64)?;
    d.set_item("distance", "hausdorff")?;
    d.set_item("effort", effort.name())?;
    d.set_item("tolerance", tolerance)?;
    d.set_item("container_version", 3)?;
    d.set_item("mean_distance", py.None())?;
    d.set_item("max_distance", tolerance)?;
    d.set_item("output_point_count", summary.output_points)?;
    d.set_item("over_tolerance_count", 0)?;
    d.set_item("verbatim_count", summary.kinds[3])?;
    d.set_item("points_cheaper_count", summary.kinds[1])?;
    d.set_item("arc_count", summary.kinds[2])?;
    d.set_item("skipped", skipped)?;
    d.set_item("dropped", dropped)?;
    d.set_item("seconds", seconds)?;
    d.set_item(
        "curves_per_second",
        summary.curves as f64 / seconds.max(1e-9),
    )?;
    Ok(d)
}

/// Curves `first..first + count` of another reader (the rest is read past
/// and dropped): one shard of a file for [`compress_file_range`].
struct RangeReader {
    inner: Box<dyn CurveReader>,
    skip: u64,
    left: u64,
}

impl Iterator for RangeReader {
    type Item = Result<Curve, IoError>;
    fn next(&mut self) -> Option<Self::Item> {
        while self.skip > 0 {
            match self.inner.next()? {
                Ok(_) => self.skip -= 1,
                Err(e) => return Some(Err(e)),
            }
        }
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        self.inner.next()
    }
}

impl CurveReader for RangeReader {
    fn metadata(&self) -> &Metadata {
        self.inner.metadata()
    }
}

/// compress_file_range(src, dst, tolerance, first, count) -> dict: curves
/// `first..first + count` of `src` compressed as `compress_file` would
/// compress them (for shards: with `first` a multiple of the block size,
/// the shard's blocks are those of the whole file's container).
#[pyfunction]
fn compress_file_range<'py>(
    py: Python<'py>,
    src: PathBuf,
    dst: PathBuf,
    tolerance: f64,
    first: u64,
    count: u64,
) -> PyResult<Bound<'py, PyDict>> {
    check_tolerance(tolerance)?;
    let summary = py
        .allow_threads(|| {
            let inner = open_reader_with(&src, None, BadCurves::Fail)?;
            let meta = inner.metadata().clone();
            let header = CodecHeader::new(
                tolerance,
                SourceMeta::from_metadata(&meta, None),
                meta.point_data_names.clone(),
            );
            let mut reader = RangeReader {
                inner,
                skip: first,
                left: count,
            };
            // Errors name curves as counted in the file: the reader's
            // already do; the encoder's count from the range's start.
            compress_stream(&mut reader, &src, &dst, &header, None, &mut |_| {}).map_err(|mut e| {
                if e.path == src && e.reason.starts_with("cannot be compressed") {
                    e.curve = e.curve.map(|c| c + first);
                }
                e
            })
        })
        .map_err(py_err)?;
    let d = PyDict::new(py);
    d.set_item("input", src.display().to_string())?;
    d.set_item("output", dst.display().to_string())?;
    d.set_item("first", first)?;
    d.set_item("curve_count", summary.curves)?;
    d.set_item("point_count", summary.points)?;
    d.set_item("bytes_out", summary.bytes)?;
    d.set_item("output_point_count", summary.output_points)?;
    d.set_item("tolerance", tolerance)?;
    Ok(d)
}

/// count_curves(src) -> int: the number of curves in a curve file, read
/// through (a header's count is advisory: planning shards by a wrong one
/// would drop curves).
#[pyfunction]
fn count_curves(py: Python<'_>, src: PathBuf) -> PyResult<u64> {
    py.allow_threads(|| -> Result<u64, IoError> {
        let mut reader = open_reader_with(&src, None, BadCurves::Fail)?;
        let mut n = 0u64;
        for c in &mut reader {
            c?;
            n += 1;
        }
        Ok(n)
    })
    .map_err(py_err)
}

/// decompress_file(src, dst, points=None, step=None, strict=False) ->
/// dict: what `strandfit decompress SRC -o DST` does (by default the points
/// the guarantee is about).
#[pyfunction]
#[pyo3(signature = (src, dst, points=None, step=None, strict=false))]
fn decompress_file<'py>(
    py: Python<'py>,
    src: PathBuf,
    dst: PathBuf,
    points: Option<usize>,
    step: Option<f64>,
    strict: bool,
) -> PyResult<Bound<'py, PyDict>> {
    check_resampling(points, step)?;
    let started = std::time::Instant::now();
    let (n, dropped) = py
        .allow_threads(|| -> Result<(u64, Vec<String>), IoError> {
            let mut reader = CodecReader::open(&src)?;
            let header = reader.header().clone();
            let mut meta = header.source.to_metadata();
            meta.point_data_names = header.point_data_names.clone();
            let format = Format::from_path(&dst)?;
            let dropped = format.losses(&meta);
            refuse_losses(&src, &dst, &dropped, strict)?;
            let mut writer = create_writer(&dst, Some(format), &meta)?;
            let width = header.point_data_names.len();
            let map = move |c: DecodedCurve| output_curve(c, points, step, width);
            let n = decompress_stream(&mut reader, &mut *writer, &map, &mut |_| {})?;
            writer.finish()?;
            Ok((n, dropped))
        })
        .map_err(py_err)?;
    let d = PyDict::new(py);
    d.set_item("input", src.display().to_string())?;
    d.set_item("output", dst.display().to_string())?;
    d.set_item("curve_count", n)?;
    d.set_item("guaranteed", points.is_none() && step.is_none())?;
    d.set_item("dropped", dropped)?;
    d.set_item("seconds", started.elapsed().as_secs_f64())?;
    Ok(d)
}

/// A container opened for random access (`strandfit.open`).
#[pyclass(module = "strandfit._strandfit")]
struct Container {
    reader: Mutex<CodecReader>,
    curves: u64,
    blocks: Vec<(u64, u64)>,
    tolerance: f64,
}

#[pymethods]
impl Container {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let reader = py
            .allow_threads(|| CodecReader::open(&path))
            .map_err(py_err)?;
        let blocks = (0..reader.block_count())
            .map(|k| reader.block_span(k))
            .collect();
        Ok(Container {
            curves: reader.curve_count(),
            tolerance: reader.header().tolerance,
            blocks,
            reader: Mutex::new(reader),
        })
    }

    fn __len__(&self) -> usize {
        self.curves as usize
    }

    /// The tolerance the container was written with.
    #[getter]
    fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// `(first curve, curve count)` of each block, in order.
    #[getter]
    fn blocks(&self) -> Vec<(u64, u64)> {
        self.blocks.clone()
    }

    /// Curves `start..stop` as `(positions, offsets)`, decoding only the
    /// blocks that hold them.
    fn read<'py>(&self, py: Python<'py>, start: u64, stop: u64) -> PyResult<Arrays<'py>> {
        if start > stop || stop > self.curves {
            return Err(PyIndexError::new_err(format!(
                "curves {start}..{stop} of a container of {}",
                self.curves
            )));
        }
        let curves = py
            .allow_threads(|| {
                let mut r = self.reader.lock().unwrap_or_else(|e| e.into_inner());
                read_range(&mut r, start, stop - start)
            })
            .map_err(py_err)?;
        Ok(to_arrays(py, &curves))
    }
}

#[pymodule]
fn _strandfit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(compress_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(decompress_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(compress_file, m)?)?;
    m.add_function(wrap_pyfunction!(decompress_file, m)?)?;
    m.add_function(wrap_pyfunction!(compress_file_range, m)?)?;
    m.add_function(wrap_pyfunction!(count_curves, m)?)?;
    m.add_class::<Container>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
