//! Curve distances and complexity.
//!
//! * [`discrete_frechet`]: discrete Fréchet distance between point sequences;
//! * [`frechet_polyline`] / [`frechet_within`]: continuous Fréchet distance
//!   between polylines (Alt–Godau free space), for tolerances below the
//!   sampling step;
//! * [`hausdorff`]: symmetric vertex-to-polyline Hausdorff distance, and the
//!   discrete vertex-set variant [`hausdorff_vertices`];
//! * [`complexity_cubic`]: the curve complexity `C(Γ) = ∫ √(κ² + τ²) ds` of
//!   Bézier cubics (the piecewise-helix form `Σ ωᵢ Lᵢ` lives with the helices);
//! * [`preview_svg`]: a picture of input and decoded curves, coloured by
//!   the local error.

mod complexity;
mod error;
mod frechet;
mod frechet_polyline;
mod hausdorff;
mod preview;

pub use complexity::{complexity_cubic, complexity_cubics};
pub use error::MetricsError;
pub use frechet::{discrete_frechet, discrete_frechet_with_buf};
pub use frechet_polyline::{frechet_polyline, frechet_within, ordered_distance, ordered_within};
pub use hausdorff::{
    hausdorff, hausdorff_directed, hausdorff_vertices, hausdorff_vertices_directed,
};
pub use preview::{distance_to_polyline, error_bin, error_colour, preview_svg, BINS};
