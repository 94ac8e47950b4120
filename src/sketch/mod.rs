//! Sketch to 3D (paper 003, Cherin, Cordier & Melkemi 2014): a 2D polyline
//! lifted to a 3D piecewise helix whose orthogonal projection matches it.
//! Built so far: the projected helix of Section 4 ([`projected`]) and the
//! polyline tangent/curvature estimator of Section 5 ([`estimate`]).

pub mod estimate;
pub mod projected;

pub use projected::ProjectedHelix;
