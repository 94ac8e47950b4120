//! Beyond the paper: an exactly G1 result.
//!
//! The piecewise helix of Section 7 is neither C0 in space nor G1 at its
//! junctions (the fine fit trades the tangent gaps against the drawing;
//! `z` continuity is imposed afterwards). Here the lifted polyline — the
//! drawing's vertices with the lifted `z` — is re-fitted by the
//! floating-tangents fitter of the core ([`crate::fit_polyline_chain`]: Schneider
//! smoothing, then the fewest helix elements within a tolerance `T`), whose
//! chain is G1 by construction. What that costs in the drawing is
//! measured, not assumed: the chain is sampled, projected on `z = 0` and
//! the drawing's vertices are compared with it in order
//! ([`ordered_distance`]).
//!
//! Bound: the lifted vertex `i` projects to the drawing's vertex `i`, and
//! orthogonal projection does not lengthen distances, so the projected
//! chain is within the chain's 3D distance of the drawing — the reported
//! projection distance is at most the 3D one (and at most `T` when the
//! tolerance is met); `tests/sketch.rs` checks it.

use glam::DVec3;

use super::SketchLift;
use crate::adaptive::{fit_polyline_chain, AdaptiveError, AdaptiveOptions, ElementCount};
use crate::helix::PiecewiseHelix;
use crate::metrics::ordered_distance;

/// The G1 re-fit of a lift.
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
