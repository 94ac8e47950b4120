//! Rigid-body motions along G1 splines of RRMF quintics of class I with a
//! rational rotation-minimising frame (paper 001, Giannelli, Sacco, Sestini
//! & Šír). Corrections to the paper: `shared/papers/ERRATA.md`, section 001.
//!
//! * [`quat`]: quaternions, the ⋆ and □ operators, square roots w.r.t. `𝐢`;
//! * [`quintic`]: PH quintics from a quadratic pre-image (Section 2.1);
//! * [`rmf`]: the rational rotation-minimising frame `ℬ = 𝒜𝒲` (Prop. 2.7);
//! * [`local`]: G1 Hermite interpolation with a one-sided frame (Section 4);
//! * [`spline`]: the motion through a point stream (Section 5).

pub mod local;
pub mod quat;
pub mod quintic;
pub mod rmf;
pub mod spline;

pub use local::{interpolate_local, LocalError, LocalSolution};
pub use quat::Quat;
pub use quintic::PhQuintic;
pub use rmf::{RmfError, RrmfQuintic};
pub use spline::{default_frame, minaj2_references, validate_points, MotionError, RrmfSpline};
