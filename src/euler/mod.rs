//! 3D Euler spirals (paper 004): curves whose curvature and torsion are
//! linear in arc length, `κ(s) = κ₀ + γs`, `τ(s) = τ₀ + δs`, `0 ≤ s ≤ L`.
//!
//! The curve has no closed form; it is the solution of the Frenet–Serret
//! equations from a start point and frame (Definition 4.1 of the paper).
//! [`FrenetProblem`] integrates them in `f64` with a fourth-order Lie-group
//! method that keeps the frame orthonormal by construction — the reference
//! that the GPU kernel `shaders/frenet_integrate.wgsl` (twin:
//! [`crate::twin::frenet_integrate`]) is checked against. The paper's own
//! integrator (explicit Euler) is first order and drifts off the rotation
//! group; see `shared/papers/ERRATA.md`, section 004. [`solve_spiral`] finds the
//! spiral between two point–tangent pairs (Levenberg–Marquardt on the end
//! conditions).

mod batch;
mod clothoid;
mod frenet;
mod paper;
mod solve;

pub use batch::{solve_spirals, solve_spirals_lockstep};
pub use clothoid::{
    clothoid_g1, fresnel_cs, generalized_fresnel, normalize_angle, Clothoid, ClothoidError,
};
pub use frenet::{FrenetEnd, FrenetError, FrenetProblem, FRAME_TOL};
pub use paper::{paper_spiral, PaperIntegrator, PaperOptions};
pub use solve::{
    solve_spiral, Restart, SolveError, SolveOptions, SpiralSolution, CONVERGED, CONVERGED_F32,
    DEFAULT_RESTARTS,
};
