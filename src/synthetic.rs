//! Deterministic synthetic inputs for benchmarks, examples and tests.

use glam::DVec3;

use crate::spline::{BezierSpline, SplineError};

/// Cubic Hermite spline through `segments + 1` samples of `pos` on
/// `[u0, u1]`, with derivatives from central differences of `pos` (step 1e-6):
/// a smooth `G1` spline that approximates `pos` to `O(h⁴)`.
pub fn hermite_spline(
    pos: impl Fn(f64) -> DVec3,
    u0: f64,
    u1: f64,
    segments: usize,
) -> Result<BezierSpline, SplineError> {
    let vel = |u: f64| (pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6;
    let h = (u1 - u0) / segments.max(1) as f64;
    let mut cps = vec![pos(u0)];
    for k in 0..segments {
        let (a, b) = (u0 + k as f64 * h, u0 + (k + 1) as f64 * h);
        cps.push(pos(a) + vel(a) * h / 3.0);
        cps.push(pos(b) - vel(b) * h / 3.0);
        cps.push(pos(b));
    }
    BezierSpline::from_control_points(&cps)
}

/// Deterministic smooth test splines: Hermite cubics of a wandering helix
/// (curvature and torsion varying slowly), about the shape of a hair strand.
pub fn synthetic_splines(count: usize, segments: usize) -> Vec<BezierSpline> {
    (0..count)
        .filter_map(|c| {
            let phase = c as f64 * 0.618_033_988_75;
            let pos = |u: f64| {
                let r = 1.0 + 0.3 * (0.7 * u + phase).sin();
                DVec3::new(
                    r * (2.0 * u + phase).cos(),
                    r * (2.0 * u + phase).sin(),
                    0.8 * u + 0.2 * (1.3 * u).sin(),
                )
            };
            hermite_spline(pos, 0.0, 6.0, segments).ok()
        })
        .collect()
}

/// Deterministic point–tangent pairs `(P₁, T₁, P₂, T₂)` for completion
/// benchmarks: the ends of arcs of the wandering helices above, each arc
/// turning by 0.2 to 1.2 rad — gaps like those between fibre fragments.
pub fn synthetic_hermite_pairs(count: usize) -> Vec<(DVec3, DVec3, DVec3, DVec3)> {
    (0..count)
        .map(|c| {
            let phase = c as f64 * 0.618_033_988_75;
            let pos = |u: f64| {
                let r = 1.0 + 0.3 * (0.7 * u + phase).sin();
                DVec3::new(
                    r * (2.0 * u + phase).cos(),
                    r * (2.0 * u + phase).sin(),
                    0.8 * u + 0.2 * (1.3 * u).sin(),
                )
            };
            let tangent = |u: f64| ((pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6).normalize();
            let u0 = (c as f64 * 0.414_213_562_37).fract() * 6.0;
            let u1 = u0 + 0.1 + 0.5 * (c as f64 * 0.732_050_807_57).fract();
            (pos(u0), tangent(u0), pos(u1), tangent(u1))
        })
        .collect()
}
