//! The floating tangents pipeline (paper 000, Algorithm 1 + Algorithm 2):
//! spline → `N + 1` equally spaced points and tangents → relaxed points →
//! one Ghosh short helix per pair → G1 piecewise helix of `N` elements.

use glam::DVec3;
use rayon::prelude::*;
use thiserror::Error;

use crate::helix::{
    ghosh, relax_dense, relax_tridiagonal, HelixElement, HelixError, HermitePair, PiecewiseHelix,
    RelaxScratch, Relaxation,
};
use crate::spline::{BezierSpline, SplineError};

/// Options of a fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Number of helix elements `N ≥ 1`.
    pub elements: usize,
    /// Relaxation solver (default: the `O(N)` tridiagonal one).
    pub relaxation: Relaxation,
    /// Relative co-helicity tolerance passed to [`ghosh::interpolate`]. The
    /// relaxed points satisfy the condition to rounding (≈1e-14 relative),
    /// so this only guards against a broken relaxation.
    pub cohelical_tol: f64,
}

impl FitOptions {
    /// Options for `elements` helices, tridiagonal relaxation, the default co-helicity tolerance.
    pub fn new(elements: usize) -> Self {
        FitOptions {
            elements,
            relaxation: Relaxation::Tridiagonal,
            cohelical_tol: ghosh::DEFAULT_COHELICAL_TOL,
        }
    }
}

/// Why a curve could not be fitted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    #[error("invalid spline: {0}")]
    /// The spline is invalid.
    Spline(#[from] SplineError),
    #[error("the number of elements must be at least 1")]
    /// Zero elements were asked for.
    NoElements,
    #[error("need at least two points with tangents, got {0}")]
    /// Fewer than two points with tangents.
    TooFewPoints(usize),
    #[error("points and tangents differ in count ({points} vs {tangents})")]
    /// Points and tangents differ in count.
    CountMismatch {
        /// Number of points.
        points: usize,
        /// Number of tangents.
        tangents: usize,
    },
    #[error("point or tangent {index} is not finite")]
    /// A point or tangent is not finite.
    NonFinite {
        /// Its index.
        index: usize,
    },
    #[error("element {index}: {source}")]
    /// An element has no short helix.
    Element {
        /// Index of the element.
        index: usize,
        #[source]
        /// Why it has none.
        source: HelixError,
    },
}

/// Reusable buffers, one per worker thread.
#[derive(Default, Debug)]
pub struct FitScratch {
    points: Vec<DVec3>,
    tangents: Vec<DVec3>,
    relaxed: Vec<DVec3>,
    relax: RelaxScratch,
}

/// Steps 2–3 on given break points and tangents (tangents need not be unit).
pub fn fit_points(
    points: &[DVec3],
    tangents: &[DVec3],
    relaxation: Relaxation,
    cohelical_tol: f64,
) -> Result<PiecewiseHelix, FitError> {
    let mut scratch = FitScratch::default();
    scratch.points.extend_from_slice(points);
    scratch.tangents.extend_from_slice(tangents);
    fit_scratch_points(&mut scratch, relaxation, cohelical_tol)
}

/// Fit a spline with `opts.elements` helices.
pub fn fit_spline(spline: &BezierSpline, opts: &FitOptions) -> Result<PiecewiseHelix, FitError> {
    fit_spline_with(spline, opts, &mut FitScratch::default())
}

/// [`fit_spline`] with caller-provided buffers.
pub fn fit_spline_with(
    spline: &BezierSpline,
    opts: &FitOptions,
    scratch: &mut FitScratch,
) -> Result<PiecewiseHelix, FitError> {
    if opts.elements == 0 {
        return Err(FitError::NoElements);
    }
    spline.sample_equal_arclen_into(opts.elements, &mut scratch.points, &mut scratch.tangents)?;
    fit_scratch_points(scratch, opts.relaxation, opts.cohelical_tol)
}

/// Fit many splines in parallel (rayon); results in input order.
pub fn fit_splines(
    splines: &[BezierSpline],
    opts: &FitOptions,
) -> Vec<Result<PiecewiseHelix, FitError>> {
    splines
        .par_iter()
        .map_init(FitScratch::default, |scratch, s| {
            fit_spline_with(s, opts, scratch)
        })
        .collect()
}

fn fit_scratch_points(
    scratch: &mut FitScratch,
    relaxation: Relaxation,
    cohelical_tol: f64,
) -> Result<PiecewiseHelix, FitError> {
    relax_scratch(scratch, relaxation)?;
    let FitScratch {
        tangents, relaxed, ..
    } = scratch;
    let mut elements: Vec<HelixElement> = Vec::with_capacity(relaxed.len() - 1);
    for i in 0..relaxed.len() - 1 {
        let h = ghosh::interpolate(
            relaxed[i],
            tangents[i],
            relaxed[i + 1],
            tangents[i + 1],
            cohelical_tol,
        )
        .map_err(|source| FitError::Element { index: i, source })?;
        elements.push(h.element);
    }
    Ok(PiecewiseHelix::new(elements))
}

/// Validate the sampled points and tangents (normalising the tangents) and
/// relax the points into `scratch.relaxed`.
fn relax_scratch(scratch: &mut FitScratch, relaxation: Relaxation) -> Result<(), FitError> {
    let FitScratch {
        points,
        tangents,
        relaxed,
        relax,
    } = scratch;
    if points.len() != tangents.len() {
        return Err(FitError::CountMismatch {
            points: points.len(),
            tangents: tangents.len(),
        });
    }
    if points.len() < 2 {
        return Err(FitError::TooFewPoints(points.len()));
    }
    for (index, (p, t)) in points.iter().zip(tangents.iter_mut()).enumerate() {
        let len = t.length();
        if !p.is_finite() || !len.is_normal() {
            return Err(FitError::NonFinite { index });
        }
        *t /= len;
    }
    match relaxation {
        Relaxation::Tridiagonal => relax_tridiagonal(points, tangents, relaxed, relax),
        Relaxation::DenseLu => *relaxed = relax_dense(points, tangents),
    }
    Ok(())
}

/// Steps 1–2 for one spline: the `N` Hermite pairs of the relaxed points
/// (appended to `out`), ready for Ghosh interpolation on any backend.
pub fn relaxed_pairs(
    spline: &BezierSpline,
    opts: &FitOptions,
    scratch: &mut FitScratch,
    out: &mut Vec<HermitePair>,
) -> Result<(), FitError> {
    if opts.elements == 0 {
        return Err(FitError::NoElements);
    }
    spline.sample_equal_arclen_into(opts.elements, &mut scratch.points, &mut scratch.tangents)?;
    relax_scratch(scratch, opts.relaxation)?;
    let (p, t) = (&scratch.relaxed, &scratch.tangents);
    out.extend((0..p.len() - 1).map(|i| HermitePair {
        p0: p[i],
        t0: t[i],
        p1: p[i + 1],
        t1: t[i + 1],
    }));
    Ok(())
}
