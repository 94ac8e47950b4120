//! Beyond the paper: the lift re-fitted exactly G1 (`refit_g1`, where the
//! method and its bound are described).

use glam::DVec3;

use super::SketchLift;
use crate::adaptive::{fit_polyline_chain, AdaptiveError, AdaptiveOptions, ElementCount};
use crate::helix::PiecewiseHelix;
use crate::metrics::ordered_distance;

/// The G1 re-fit of a lift.
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{resample, PlacedHelix};
/// # /// The projections of two helices, the second starting where the first
/// # /// ends with a corner of 0.6 rad, each sampled evenly along its length:
/// # /// 43 vertices, the corner at vertex 24.
/// # fn two_helices() -> Vec<DVec2> {
/// #     let a = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 1.0, 0.3, 0.8], false);
/// #     let turn = a.derivative(3.0).to_angle() + 0.6 - std::f64::consts::FRAC_PI_2;
/// #     let end = a.point(3.0);
/// #     let b = PlacedHelix::from_params(&[turn, end.x, end.y, 0.7, 0.1, 1.0], true);
/// #     let dense = |h: &PlacedHelix| -> Vec<DVec2> {
/// #         (0..=1000).map(|k| h.point(3.0 * k as f64 / 1000.0)).collect()
/// #     };
/// #     let (da, db) = (dense(&a), dense(&b));
/// #     let len = |p: &[DVec2]| -> f64 { p.windows(2).map(|w| (w[1] - w[0]).length()).sum() };
/// #     let nb = (25.0 * len(&db) / len(&da)).round() as usize;
/// #     let mut d = resample(&da, 25);
/// #     d.extend(resample(&db, nb + 1).into_iter().skip(1));
/// #     assert_eq!(d.len(), 43);
/// #     d
/// # }
/// use strandfit::sketch::{lift_sketch, refit_g1, SketchOptions};
///
/// // The lift of a drawing with a corner has a kink at its junction; the
/// // re-fit has none (to rounding).
/// let lift = lift_sketch(&two_helices(), &SketchOptions::default()).unwrap();
/// assert!(lift.junctions[0].tangent_angle > 0.1);
/// let g1 = refit_g1(&lift, 1e-3 * lift.length).unwrap();
/// let (gap, angle) = g1.continuity;
/// assert!(gap < 1e-9 * lift.length && angle < 1e-7, "{gap} {angle}");
/// assert!(g1.chain.len() >= 2);
/// ```
#[derive(Clone, Debug)]
pub struct G1Refit {
    /// The chain, in the drawing's units (`x, y` the drawing's, `z` lifted).
    pub chain: PiecewiseHelix,
    /// `T`, in the drawing's units.
    pub tolerance: f64,
    /// Whether the fitter met `T` (it returns its best chain otherwise).
    pub within_tolerance: bool,
    /// The chain's distance from the lifted polyline (the fitter's bound:
    /// its vertices within this of the chain, in order).
    pub distance_3d: f64,
    /// How far the chain's projection moved from the drawing: its vertices
    /// (the ones the lift ran on) within this of the projected chain, in
    /// order — an upper bound (sampling sagitta included).
    pub projection_distance: f64,
    /// Largest position gap and tangent angle (radians) between
    /// consecutive elements: rounding only.
    pub continuity: (f64, f64),
}

/// Re-fit `lift.points_3d` with the floating-tangents fitter within
/// `tolerance` (drawing units; the lift's `E_max · L` is the natural
/// choice).
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, refit_g1, SketchOptions};
///
/// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
/// let t = 1e-3 * lift.length;
/// let g1 = refit_g1(&lift, t).unwrap();
/// // Within T of the lifted vertices, and so of the drawing once projected
/// // (up to the sampling allowance, T/64 twice).
/// assert!(g1.within_tolerance && g1.distance_3d <= t);
/// assert!(g1.projection_distance <= g1.distance_3d + t / 32.0);
/// assert_eq!(g1.tolerance, t);
/// ```
///
/// # Method
///
/// Beyond the paper: an exactly G1 result.
///
/// The piecewise helix of Section 7 is neither C0 in space nor G1 at its
/// junctions (the fine fit trades the tangent gaps against the drawing;
/// `z` continuity is imposed afterwards). Here the lifted polyline — the
/// drawing's vertices with the lifted `z` — is re-fitted by the
/// floating-tangents fitter of the core ([`crate::fit_polyline_chain`]: Schneider
/// smoothing, then the fewest helix elements within a tolerance `T`), whose
/// chain is G1 by construction. What that costs in the drawing is
/// measured, not assumed: the chain is sampled, projected on `z = 0` and
/// the drawing's vertices are compared with it in order
/// ([`ordered_distance`]).
///
/// Bound: the lifted vertex `i` projects to the drawing's vertex `i`, and
/// orthogonal projection does not lengthen distances, so the projected
/// chain is within the chain's 3D distance of the drawing. The reported
/// projection distance measures the chain sampled, with a sagitta of at
/// most `T/64`, and adds that sagitta: it is at most the 3D one plus twice
/// the sagitta (so at most `T + T/32` when the tolerance is met);
/// `tests/sketch.rs` checks it.
pub fn refit_g1(lift: &SketchLift, tolerance: f64) -> Result<G1Refit, AdaptiveError> {
    let opts = AdaptiveOptions::new(ElementCount::Tolerance(tolerance));
    let fit = fit_polyline_chain(&lift.points_3d, &opts)?;
    let chain = fit.chain;
    // Samples with sagitta κ_max h²/8 ≤ T/64 (at least 8 per vertex).
    let kappa = chain
        .elements()
        .iter()
        .map(|e| e.curvature)
        .fold(0.0, f64::max);
    let length = chain.length();
    let mut step = length / (8 * lift.points_2d.len().max(1)) as f64;
    if kappa > 0.0 {
        step = step.min((tolerance / 8.0 / kappa).sqrt());
    }
    let sagitta = kappa * step * step / 8.0;
    let projected: Vec<DVec3> = chain
        .sample_step(step)
        .into_iter()
        .map(|p| DVec3::new(p.x, p.y, 0.0))
        .collect();
    let drawing: Vec<DVec3> = lift.points_2d.iter().map(|p| p.extend(0.0)).collect();
    let projection_distance =
        ordered_distance(&drawing, &projected, 1e-6).map_or(f64::INFINITY, |d| d + sagitta);
    Ok(G1Refit {
        continuity: chain.continuity_defects(),
        chain,
        tolerance,
        within_tolerance: fit.within_tolerance,
        distance_3d: fit.frechet,
        projection_distance,
    })
}
