//! Helices: single elements, Ghosh's short-helix interpolation, the
//! floating-tangents point relaxation, and G1 piecewise helices.

mod element;
mod ghosh;
mod piecewise;
mod relax;

pub use element::{sinc, sinc_defect3, versinc2, Frame, HelixElement};
pub(crate) use ghosh::ghosh_basis;
pub use ghosh::{interpolate, HermitePair, ShortHelix, DEFAULT_COHELICAL_TOL, PARALLEL_EPS};
pub use piecewise::{ChainParams, ElementParams, PiecewiseHelix};
pub use relax::{relax, relax_dense, relax_tridiagonal, RelaxScratch, Relaxation};

use thiserror::Error;

/// Why two point–tangent pairs have no short helix.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum HelixError {
    #[error("non-finite coordinate in points or tangents")]
    /// A point or tangent is not finite.
    NonFinite,
    #[error("a tangent has zero length")]
    /// A tangent has zero length.
    ZeroTangent,
    #[error("p0 and p1 coincide: no helix joins a point to itself")]
    /// The two points coincide.
    CoincidentPoints,
    #[error(
        "points and tangents are not co-helical: |<p1-p0, t1-t0>|/(|p1-p0||t1-t0|) = {residual:.3e} exceeds tolerance {tolerance:.1e} (Ghosh's condition, Eq. (6))"
    )]
    /// The data are not co-helical (Ghosh's condition, Eq. (6)).
    NotCoHelical {
        /// `|⟨p₁ − p₀, t₁ − t₀⟩|/(|p₁ − p₀||t₁ − t₀|)`.
        residual: f64,
        /// The tolerance it exceeds.
        tolerance: f64,
    },
    #[error(
        "tangents are parallel but the chord is {deviation:.3e} rad off the tangent: only a full-turn helix joins them, not a short one"
    )]
    /// The tangents are parallel but the chord is off them: only a full-turn helix joins the points.
    ParallelTangentsOffChord {
        /// Angle between the chord and the tangents (radians).
        deviation: f64,
    },
}
