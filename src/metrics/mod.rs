//! Curve distances and complexity.
//!
//! * [`discrete_frechet`]: discrete Fréchet distance between point sequences;
//! * [`frechet_polyline`] / [`frechet_within`]: continuous Fréchet distance
//!   between polylines (Alt–Godau free space), for tolerances below the
//!   sampling step;
//! * [`hausdorff`]: symmetric vertex-to-polyline Hausdorff distance, and the
//!   discrete vertex-set variant [`hausdorff_vertices`];
//! * [`complexity_cubic`]: the curve complexity `C(Γ) = ∫ √(κ² + τ²) ds` of
//!   Bézier cubics (the piecewise-helix form `Σ ωᵢ Lᵢ` lives with the helices).

mod complexity;
mod error;
mod frechet;
mod frechet_polyline;
mod hausdorff;

pub use complexity::{complexity_cubic, complexity_cubics};
pub use error::MetricsError;
pub use frechet::{discrete_frechet, discrete_frechet_with_buf};
pub use frechet_polyline::{frechet_polyline, frechet_within, ordered_distance, ordered_within};
pub use hausdorff::{
    hausdorff, hausdorff_directed, hausdorff_vertices, hausdorff_vertices_directed,
};
