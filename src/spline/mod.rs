//! Piecewise cubic Bézier splines: evaluation, arc length, equal-arc-length
//! sampling (step 1 of the floating tangents method).

mod cubic;

pub use cubic::CubicBez;
