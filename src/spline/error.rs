//! Errors reported by spline construction and sampling.

use thiserror::Error;

/// Why a [`BezierSpline`](super::BezierSpline) could not be built or sampled.
///
/// Every input-dependent failure is reported through this type; the spline
/// code never panics on bad input.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SplineError {
    /// A piecewise cubic with `k` segments has `3k + 1` control points.
    #[error("expected 3k+1 control points (k ≥ 1), got {0}")]
    BadControlPointCount(usize),
    /// A control point has a NaN or infinite coordinate.
    #[error("control point {0} is not finite")]
    NonFiniteControlPoint(usize),
    /// All control points coincide, so the spline has no length.
    #[error("spline has zero length")]
    ZeroLength,
    /// Coordinates are finite but so large that differences overflow.
    #[error("spline length is not finite (coordinates too large)")]
    NonFiniteLength,
    /// The requested arc-length accuracy is not a positive finite number.
    #[error("arc-length accuracy must be positive and finite, got {0}")]
    BadAccuracy(f64),
    /// Equal-arc-length sampling needs at least one element (two points).
    #[error("need at least {min} {what}, got {got}")]
    TooFewSamples {
        /// What was counted.
        what: &'static str,
        /// The least allowed.
        min: usize,
        /// The count given.
        got: usize,
    },
}
