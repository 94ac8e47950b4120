//! The floating tangents pipeline (paper 000, Algorithm 1 + Algorithm 2):
//! spline → `N + 1` equally spaced points and tangents → relaxed points →
//! one Ghosh short helix per pair → G1 piecewise helix of `N` elements.

use glam::DVec3;
use rayon::prelude::*;
use thiserror::Error;

use crate::helix::{
    self, relax_dense, relax_tridiagonal, HelixElement, HelixError, HermitePair, PiecewiseHelix,
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
    /// Relative co-helicity tolerance passed to [`helix::interpolate`]. The
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
            cohelical_tol: helix::DEFAULT_COHELICAL_TOL,
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
///
/// Points already co-helical (on one circle) stay where they are:
///
/// ```
/// use std::f64::consts::FRAC_PI_2;
/// use strandfit::helix::Relaxation;
/// use strandfit::{fit_points, DVec3, FitError, ParamCurve3};
///
/// // Points and tangents on a quarter circle of radius 1.
/// let angles = [0.0, 0.5, 1.0, FRAC_PI_2];
/// let points: Vec<DVec3> = angles.iter().map(|&a| DVec3::new(a.sin(), 1.0 - a.cos(), 0.0)).collect();
/// let tangents: Vec<DVec3> = angles.iter().map(|&a| DVec3::new(a.cos(), a.sin(), 0.0)).collect();
/// let chain = fit_points(&points, &tangents, Relaxation::Tridiagonal, 1e-9).unwrap();
/// assert_eq!(chain.len(), 3);
/// assert!((chain.arc_length() - FRAC_PI_2).abs() < 1e-9);
/// let err = fit_points(&points, &tangents[..3], Relaxation::Tridiagonal, 1e-9).unwrap_err();
/// assert_eq!(err, FitError::CountMismatch { points: 4, tangents: 3 });
/// ```
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
///
/// ```
/// use strandfit::{fit_spline, BezierSpline, DVec3, FitError, FitOptions, ParamCurve3};
///
/// let line = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::X, 2.0 * DVec3::X, 3.0 * DVec3::X]).unwrap();
/// let chain = fit_spline(&line, &FitOptions::new(3)).unwrap();
/// assert!((chain.arc_length() - 3.0).abs() < 1e-9);
/// assert!(chain.elements().iter().all(|e| e.curvature.abs() < 1e-9)); // straight elements
/// assert_eq!(fit_spline(&line, &FitOptions::new(0)).unwrap_err(), FitError::NoElements);
/// ```
pub fn fit_spline(spline: &BezierSpline, opts: &FitOptions) -> Result<PiecewiseHelix, FitError> {
    fit_spline_with(spline, opts, &mut FitScratch::default())
}

/// [`fit_spline`] with caller-provided buffers.
///
/// One set of buffers for many fits, same results:
///
/// ```
/// use strandfit::{fit_spline, fit_spline_with, BezierSpline, DVec3, FitOptions, FitScratch};
///
/// let mut scratch = FitScratch::default();
/// let opts = FitOptions::new(6);
/// for z in [0.5, 1.0, 2.0] {
///     let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::X, DVec3::new(2.0, 1.0, z), DVec3::new(3.0, 0.0, z)]).unwrap();
///     assert_eq!(fit_spline_with(&s, &opts, &mut scratch).unwrap(), fit_spline(&s, &opts).unwrap());
/// }
/// ```
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
///
/// ```
/// use strandfit::{fit_splines, BezierSpline, DVec3, FitOptions, ParamCurve3};
///
/// let splines: Vec<BezierSpline> = [1.0, 2.0, 4.0]
///     .map(|x| BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::Y, DVec3::new(x, 1.0, 1.0), DVec3::new(x, 0.0, 1.0)]).unwrap())
///     .to_vec();
/// let chains = fit_splines(&splines, &FitOptions::new(8));
/// assert_eq!(chains.len(), 3);
/// for (chain, spline) in chains.iter().zip(&splines) {
///     let chain = chain.as_ref().unwrap(); // in input order: its own spline's length
///     assert!((chain.length() - spline.arc_length()).abs() < 1e-2 * spline.arc_length());
/// }
/// ```
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
        let h = helix::interpolate(
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
///
/// The pairs chain up, each starting where the last ended, and every pair
/// is co-helical, `⟨p₁ − p₀, t₁ − t₀⟩ = 0`:
///
/// ```
/// use strandfit::{relaxed_pairs, BezierSpline, DVec3, FitOptions, FitScratch};
///
/// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::X, DVec3::new(2.0, 1.0, 1.0), DVec3::new(3.0, 0.0, 1.0)]).unwrap();
/// let mut pairs = Vec::new();
/// relaxed_pairs(&s, &FitOptions::new(5), &mut FitScratch::default(), &mut pairs).unwrap();
/// assert_eq!(pairs.len(), 5);
/// assert!(pairs.windows(2).all(|w| w[0].p1 == w[1].p0));
/// assert!(pairs.iter().all(|p| p.chord().dot(p.t1 - p.t0).abs() < 1e-12));
/// ```
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
