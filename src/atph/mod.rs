//! Spatial algebraic–trigonometric Pythagorean-hodograph (ATPH) curves and
//! G1 Hermite interpolation by them (paper 002, Wu & Yang, 2020).
//!
//! An ATPH curve integrates a scaled unit tangent field given in spherical
//! coordinates with latitude and azimuth linear in the parameter,
//! `r(ξ) = r₀ + ∫₀^ξ ρ(t) T(t) dt` (Eqs. 2.1–2.2). Its speed `|ρ|` is a
//! polynomial, so its arc length is too; with `ρ` quadratic or cubic the
//! position has a closed form (Eqs. 2.5–2.10) and Hermite interpolation —
//! with or without a prescribed arc length — is one small linear system
//! (3.1, 4.1) per pair, with a unique solution.
//!
//! * [`trig_moments`]: the trigonometric moments every closed form is made
//!   of, with the paper's zero-divisor cases (`a₁`, `A₁` or `B₁ = 0`);
//! * [`SphericalTangent`]: the field `T` and the choices Section 3.1 leaves
//!   open (azimuth branch, poles, equal tangents);
//! * [`Bernstein`]: `ρ` in Bernstein form, and the regularity test;
//! * [`AtphCurve`]: evaluation, curvature, torsion, arc length, sampling;
//! * [`interpolate`], [`interpolate_with_length`]: the interpolation
//!   (Sections 3 and 4);
//! * [`AtphSpline`]: G1 splines through points and tangents (Section 5);
//! * [`interpolate_pairs`]: many pairs in parallel.
//!
//! Corrections to the paper are in `shared/papers/ERRATA.md`, section 002.

mod batch;
mod bernstein;
mod curve;
mod hermite;
mod moments;
mod spline;
mod tangent;

pub use batch::{interpolate_pairs, HermitePair};
pub use bernstein::{Bernstein, Sign};
pub use curve::AtphCurve;
pub use hermite::{
    check_ends, interpolate, interpolate_field, interpolate_with_length, tangent_field, AtphError,
    OFF_PLANE_TOL, SINGULAR_TOL,
};
pub use moments::{trig_moments, Moments, SERIES_BELOW};
pub use spline::{AtphSpline, SplineError};
pub use tangent::{
    spherical_angles, wrap_angle, FieldKind, SphericalTangent, HALF_TURN_TOL, PLANAR_TOL, POLE_TOL,
};
