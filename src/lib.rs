//! # strandfit
//!
//! Fit 3D curves to compact, smooth primitives. The core (this crate's CPU
//! reference path, in `f64`) is the *floating tangents* method of
//! Derouet-Jourdan, Bertails-Descoubes and Thollot (CAGD 30(5), 2013):
//!
//! 1. sample a Bézier spline at `N + 1` points equally spaced in arc length,
//!    with their unit tangents ([`spline`]);
//! 2. relax the points so that every consecutive pair is co-helical,
//!    `⟨p'ᵢ₊₁ − p'ᵢ, tᵢ₊₁ − tᵢ⟩ = 0` ([`helix::relax`]);
//! 3. join each pair by Ghosh's unique short helix ([`helix::ghosh`]),
//!    giving a G1 piecewise helix of `N` elements ([`helix::PiecewiseHelix`]).
//!
//! Conventions: lengths are in the input's units; curvature is `κ ≥ 0`;
//! torsion follows the standard Frenet–Serret sign (a right-handed helix has
//! `τ > 0`).

// Deliberate numerics idioms: constants written with all the digits their
// source publishes; `!(x > 0.0)` comparisons that also reject NaN; index
// loops over several arrays in lockstep, as the equations are written.
#![allow(
    clippy::excessive_precision,
    clippy::neg_cmp_op_on_partial_ord,
    clippy::needless_range_loop
)]

pub mod adaptive;
pub mod atph;
pub mod backend;
mod batch;
pub mod cli;
pub mod codec;
pub mod compress;
mod curve;
pub mod euler;
pub mod fit;
pub mod gpu;
pub mod helix;
pub mod io;
pub mod kernels;
pub mod metrics;
mod pair;
pub mod rrmf;
pub mod sampled;
pub mod sketch;
pub mod spline;
pub mod synthetic;
pub mod twin;

pub use adaptive::{AdaptiveOptions, ChainFit, ElementCount};
pub use atph::AtphCurve;
pub use backend::{Backend, BackendChoice, PrecisionChoice};
pub use batch::{compress_polylines, decompress_polylines, fit_polylines, BatchError, Polylines};
pub use curve::ParamCurve3;
pub use euler::FrenetProblem;
pub use glam::DVec3;
pub use helix::{HelixElement, PiecewiseHelix};
pub use pair::HermitePair;
pub use rrmf::RrmfSpline;
pub use spline::BezierSpline;
