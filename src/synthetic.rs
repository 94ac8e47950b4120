//! Deterministic synthetic inputs for benchmarks, examples and tests.

use glam::DVec3;

use crate::spline::BezierSpline;

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
            let vel = |u: f64| (pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6;
            let h = 6.0 / segments as f64;
            let mut cps = vec![pos(0.0)];
            for k in 0..segments {
                let (u0, u1) = (k as f64 * h, (k + 1) as f64 * h);
                cps.push(pos(u0) + vel(u0) * h / 3.0);
                cps.push(pos(u1) - vel(u1) * h / 3.0);
                cps.push(pos(u1));
            }
            BezierSpline::from_control_points(&cps).ok()
        })
        .collect()
}
