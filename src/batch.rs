//! Many curves at once: a flat array of positions with offsets
//! ([`Polylines`]), compressed, decompressed or fitted in one call — the
//! library side of what the command line does to a whole file.

use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use crate::adaptive::{fit_polyline_chain, AdaptiveError, AdaptiveOptions, ChainFit};
use crate::backend::{Backend, GpuError};
use crate::codec::{compress_to_bytes, read_range, ArcChecker, CodecHeader, CodecReader, Effort};
use crate::io::{Curve, Format, IoError, Metadata, SourceMeta, VecReader};

/// What a batch call reports in place of a path for in-memory curves.
const IN_MEMORY: &str = "<memory>";

/// Why a batch call failed as a whole (a single curve's own failure is
/// reported per curve where the call returns one result per curve).
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The offsets do not describe the positions.
    #[error("bad offsets: {0}")]
    Offsets(String),
    /// The codec or the container refused the data.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The GPU backend failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Curves as one array of points and `n + 1` offsets: curve `i` is
/// `positions[offsets[i]..offsets[i + 1]]` (the layout of TRX files and
/// of the Python package's arrays).
///
/// ```
/// use strandfit::{DVec3, Polylines};
///
/// let positions = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
/// let curves = Polylines::new(&positions, &[0, 2, 5]).unwrap();
/// assert_eq!(curves.len(), 2);
/// assert_eq!(curves.get(1), Some(&positions[2..5]));
/// assert!(Polylines::new(&positions, &[0, 3, 2, 5]).is_err());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Polylines<'a> {
    positions: &'a [DVec3],
    offsets: &'a [usize],
}

impl<'a> Polylines<'a> {
    /// Checks that `offsets` start at 0, never decrease and end at
    /// `positions.len()`.
    ///
    /// ```
    /// use strandfit::{DVec3, Polylines};
    ///
    /// let positions = [DVec3::ZERO, DVec3::X, DVec3::Y];
    /// // An empty curve is allowed; no curves at all is `[0]` with no points.
    /// assert_eq!(Polylines::new(&positions, &[0, 0, 3]).unwrap().len(), 2);
    /// assert!(Polylines::new(&[], &[0]).unwrap().is_empty());
    /// // The offsets must end at the number of points.
    /// let err = Polylines::new(&positions, &[0, 2]).unwrap_err();
    /// assert!(err.to_string().contains("number of points (3)"));
    /// ```
    pub fn new(positions: &'a [DVec3], offsets: &'a [usize]) -> Result<Self, BatchError> {
        if offsets.first() != Some(&0) || offsets.last() != Some(&positions.len()) {
            return Err(BatchError::Offsets(format!(
                "offsets must run from 0 to the number of points ({}), one more than the curves",
                positions.len()
            )));
        }
        if let Some(c) = offsets.windows(2).position(|w| w[1] < w[0]) {
            return Err(BatchError::Offsets(format!(
                "offsets must not decrease: offsets[{c}] = {} > offsets[{}] = {}",
                offsets[c],
                c + 1,
                offsets[c + 1]
            )));
        }
        Ok(Polylines { positions, offsets })
    }

    /// The number of curves.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// No curves.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The points of curve `i`.
    pub fn get(&self, i: usize) -> Option<&'a [DVec3]> {
        (i < self.len()).then(|| &self.positions[self.offsets[i]..self.offsets[i + 1]])
    }

    /// The curves in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &'a [DVec3]> + '_ {
        self.offsets.windows(2).map(|w| &self.positions[w[0]..w[1]])
    }
}

/// Compress every curve with the arc codec into an in-memory container
/// (the bytes of a `.sfh` file): each decoded curve is within `tolerance`
/// of its input in the two-sided Hausdorff distance ([`crate::codec`]).
/// On the GPU backend the codec's candidate elements are checked by the
/// `arc_check` kernel; the bytes are the same on every backend. (With the
/// default effort: [`compress_polylines_with_effort`] takes one.)
///
/// ```
/// use strandfit::{compress_polylines, decompress_polylines, Backend, DVec3, Polylines};
///
/// let helix: Vec<DVec3> = (0..100)
///     .map(|k| {
///         let s = k as f64 * 0.1;
///         DVec3::new(3.0 * s.cos(), 3.0 * s.sin(), 0.8 * s)
///     })
///     .collect();
/// let curves = Polylines::new(&helix, &[0, 100]).unwrap();
/// let bytes = compress_polylines(curves, 0.05, &Backend::Cpu).unwrap();
/// let (points, offsets) = decompress_polylines(&bytes).unwrap();
/// assert_eq!(offsets.len(), 2);
/// let h = strandfit::metrics::hausdorff(&helix, &points).unwrap();
/// assert!(h <= 0.05);
/// ```
pub fn compress_polylines(
    curves: Polylines<'_>,
    tolerance: f64,
    backend: &Backend,
) -> Result<Vec<u8>, BatchError> {
    compress_polylines_with_effort(curves, tolerance, Effort::Default, backend)
}

/// [`compress_polylines`] with the encoder's [`Effort`] (the command
/// line's `--effort`): [`Effort::Best`] looks one element ahead and keeps
/// each block's smaller coding, for fewer bytes (never more) in about three
/// times the time; the format, the decoder and the guarantee are the same.
///
/// ```
/// use strandfit::{codec::Effort, compress_polylines_with_effort, decompress_polylines};
/// use strandfit::{Backend, DVec3, Polylines};
///
/// // A slow wave: --effort best's look-ahead codes it in fewer bytes
/// // (and it is never larger: each block's smaller coding is kept).
/// let wave: Vec<DVec3> = (0..600)
///     .map(|k| {
///         let s = k as f64 * 0.2;
///         DVec3::new(s, 3.0 * (0.12 * s).sin(), 3.0 * (0.07 * s).cos())
///     })
///     .collect();
/// let curves = Polylines::new(&wave, &[0, 600]).unwrap();
/// let cpu = &Backend::Cpu;
/// let default = compress_polylines_with_effort(curves, 0.05, Effort::Default, cpu).unwrap();
/// let bytes = compress_polylines_with_effort(curves, 0.05, Effort::Best, cpu).unwrap();
/// assert!(bytes.len() < default.len());
/// let (points, _) = decompress_polylines(&bytes).unwrap();
/// assert!(strandfit::metrics::hausdorff(&wave, &points).unwrap() <= 0.05);
/// ```
pub fn compress_polylines_with_effort(
    curves: Polylines<'_>,
    tolerance: f64,
    effort: Effort,
    backend: &Backend,
) -> Result<Vec<u8>, BatchError> {
    let meta = Metadata::new(Format::Json);
    let mut header = CodecHeader::new(
        tolerance,
        SourceMeta::from_metadata(&meta, None),
        Vec::new(),
    );
    header.effort = effort;
    let mut reader = VecReader::new(
        meta,
        curves
            .iter()
            .map(|c| Curve::from_points(c.to_vec()))
            .collect(),
    );
    let checker = backend.arc_checker()?;
    let checker = checker.as_ref().map(|c| c as &dyn ArcChecker);
    Ok(compress_to_bytes(
        &mut reader,
        Path::new(IN_MEMORY),
        &header,
        checker,
    )?)
}

/// Decode a container made by [`compress_polylines`] (or the bytes of any
/// version-3 `.sfh` file): all curves as positions and offsets, as
/// decoded (no resampling).
///
/// Bytes that are not a container are an error:
///
/// ```
/// use strandfit::{decompress_polylines, BatchError};
///
/// let err = decompress_polylines(b"not a container").unwrap_err();
/// assert!(matches!(err, BatchError::Io(_)));
/// ```
pub fn decompress_polylines(bytes: &[u8]) -> Result<(Vec<DVec3>, Vec<usize>), BatchError> {
    let mut reader = CodecReader::from_bytes(bytes.to_vec())?;
    let n = reader.curve_count();
    let curves = read_range(&mut reader, 0, n)?;
    let mut positions = Vec::with_capacity(curves.iter().map(|c| c.points.len()).sum());
    let mut offsets = Vec::with_capacity(curves.len() + 1);
    offsets.push(0);
    for c in curves {
        positions.extend_from_slice(&c.points);
        offsets.push(positions.len());
    }
    Ok((positions, offsets))
}

/// Fit every polyline with a G1 piecewise helix
/// ([`fit_polyline_chain`]: smoothing spline, then the floating tangents
/// fit with the element count `opts` asks for), in parallel on the CPU;
/// results in input order, one bad curve never stopping the others. For
/// splines already in hand, [`Backend::fit`] runs the fit on either
/// backend.
///
/// ```
/// use strandfit::{fit_polylines, AdaptiveOptions, DVec3, ElementCount, Polylines};
///
/// let arc: Vec<DVec3> = (0..50)
///     .map(|k| DVec3::new((k as f64 * 0.05).cos(), (k as f64 * 0.05).sin(), 0.0))
///     .collect();
/// let curves = Polylines::new(&arc, &[0, 50]).unwrap();
/// let fits = fit_polylines(curves, &AdaptiveOptions::new(ElementCount::Tolerance(1e-3)));
/// let fit = fits[0].as_ref().unwrap();
/// assert!(fit.within_tolerance && fit.frechet <= 1e-3);
/// ```
pub fn fit_polylines(
    curves: Polylines<'_>,
    opts: &AdaptiveOptions,
) -> Vec<Result<ChainFit, AdaptiveError>> {
    let all: Vec<&[DVec3]> = curves.iter().collect();
    all.par_iter()
        .map(|c| fit_polyline_chain(c, opts))
        .collect()
}
