//! Rigid-body motions along G1 splines of RRMF quintics of class I with a
//! rational rotation-minimising frame (paper 001, Giannelli, Sacco, Sestini
//! & Šír). Corrections to the paper: `shared/papers/ERRATA.md`, section 001.
//!
//! * [`Quat`]: quaternions, the ⋆ and □ operators, square roots w.r.t. `𝐢`
//!   ([`sqrt_wrt_i`]);
//! * [`PhQuintic`]: PH quintics from a quadratic pre-image (Section 2.1);
//! * [`RrmfQuintic`]: the rational rotation-minimising frame `ℬ = 𝒜𝒲`
//!   (Prop. 2.7);
//! * [`interpolate_local`]: G1 Hermite interpolation with a one-sided frame
//!   (Section 4);
//! * [`RrmfSpline`]: the motion through a point stream (Section 5).

mod local;
mod quat;
mod quintic;
mod rmf;
mod spline;

pub use local::{interpolate_local, unit_displacement, LocalError, LocalSolution, INPUT_TOL};
pub use quat::{bisector, neg_cross, sqrt_wrt_i, Quat};
pub use quintic::{bernstein2, PhQuintic};
pub use rmf::{RmfError, RrmfQuintic};
pub use spline::{
    default_frame, insert_point, minaj2_references, validate_points, Inserted, MotionError,
    MotionSegment, RrmfSpline, NUDGE, STRAIGHT_TAU,
};
