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
//! * [`moments`]: the trigonometric moments every closed form is made of,
//!   with the paper's zero-divisor cases (`a₁`, `A₁` or `B₁ = 0`);
//! * [`tangent`]: the field `T` and the choices Section 3.1 leaves open
//!   (azimuth branch, poles, equal tangents);
//! * [`bernstein`]: `ρ` in Bernstein form, and the regularity test;
//! * [`curve`]: evaluation, curvature, torsion, arc length, sampling;
//! * [`hermite`]: the interpolation (Sections 3 and 4);
//! * [`spline`]: G1 splines through points and tangents (Section 5);
//! * [`batch`]: many pairs in parallel.
//!
//! Corrections to the paper are in `shared/papers/ERRATA.md`, section 002.

pub mod batch;
pub mod bernstein;
pub mod curve;
pub mod hermite;
pub mod moments;
pub mod spline;
pub mod tangent;

pub use batch::{interpolate_pairs, HermitePair};
pub use bernstein::{Bernstein, Sign};
pub use curve::AtphCurve;
pub use hermite::{
    check_ends, interpolate, interpolate_field, interpolate_with_length, tangent_field, AtphError,
    SINGULAR_TOL,
};
pub use spline::{AtphSpline, SplineError};
pub use tangent::{FieldKind, SphericalTangent};
