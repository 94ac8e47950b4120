//! Piecewise cubic Bézier splines: evaluation, arc length, equal-arc-length
//! sampling (step 1 of the floating tangents method).
//!
//! * [`CubicBez`]: one segment, with derivatives and a unit tangent that is
//!   correct at degenerate (coincident) control points.
//! * [`BezierSpline`]: `3k + 1` control points, arc length by adaptive
//!   Gauss–Legendre tabulated at construction, inverse arc length by
//!   safeguarded Newton, equal-arc-length sampling with tangents.
//! * [`fit_polyline`]: polyline → G1 cubic spline within a tolerance
//!   (Schneider's algorithm in 3D), to smooth measured curves before fitting.

mod bezier_spline;
mod cubic;
mod error;
mod gauss;
mod schneider;

pub use bezier_spline::{BezierSpline, DEFAULT_ACCURACY};
pub use cubic::CubicBez;
pub use error::SplineError;
pub use schneider::{fit_polyline, PolylineFitError, SchneiderOptions};

#[cfg(test)]
mod tests;
