//! Sketch to 3D (paper 003, Cherin, Cordier & Melkemi 2014): a 2D polyline
//! lifted to a 3D piecewise helix whose orthogonal projection matches it.
//!
//! * [`projected`]: the projected helix `H(t)` with tilt `c` (Section 4).
//! * [`estimate`]: polyline tangents and curvatures (Section 5).
//! * [`placed`]: a projected helix placed in the sketch plane (6.1), its
//!   lift, closest points.
//! * [`nelder_mead`]: the simplex search the paper uses (6.2).
//! * [`cover`]: one helix around the curvature maximum (6.1–6.3), and the
//!   recursive covering (6.4).
//! * [`refine`]: least squares on placed helices; the fine fitting (7).
//! * [`lift`]: the whole method, [`lift_sketch`].
//! * [`g1`]: beyond the paper, the lift re-fitted exactly G1 by the
//!   floating-tangents fitter, [`refit_g1`].

pub mod cover;
pub mod estimate;
pub mod g1;
pub mod lift;
pub mod nelder_mead;
pub mod placed;
pub mod projected;
pub mod refine;

pub use g1::{refit_g1, G1Refit};
pub use lift::{
    lift_sketch, Junction, LiftedHelix, Resampling, SketchError, SketchLift, SketchOptions,
};
pub use placed::PlacedHelix;
pub use projected::ProjectedHelix;
