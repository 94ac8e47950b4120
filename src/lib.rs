//! # strandfit
//!
//! Fit 3D curves to compact, smooth primitives, and compress tractograms
//! with them. The core (this crate's CPU reference path, in `f64`) is the
//! *floating tangents* method of Derouet-Jourdan, Bertails-Descoubes and
//! Thollot (CAGD 30(5), 2013):
//!
//! 1. sample a Bézier spline at `N + 1` points equally spaced in arc length,
//!    with their unit tangents ([`spline`]);
//! 2. relax the points so that every consecutive pair is co-helical,
//!    `⟨p'ᵢ₊₁ − p'ᵢ, tᵢ₊₁ − tᵢ⟩ = 0` ([`helix::relax()`]);
//! 3. join each pair by Ghosh's unique short helix ([`helix::interpolate`]),
//!    giving a G1 piecewise helix of `N` elements ([`PiecewiseHelix`]).
//!
//! # The front door
//!
//! * Curve primitives, all [`ParamCurve3`] (evaluate, tangent, arc length,
//!   sample): [`HelixElement`] (Ghosh helix), [`PiecewiseHelix`],
//!   [`FrenetProblem`] (3D Euler spiral), [`AtphCurve`], [`RrmfSpline`],
//!   [`BezierSpline`].
//! * Two-point interpolation data: [`HermitePair`] (a point and a tangent
//!   at each end), for [`helix::interpolate`], [`atph::interpolate`],
//!   [`euler::solve_spiral`] and their batch forms.
//! * Many curves at once, on a [`Backend`] (CPU or GPU): [`Backend::fit`],
//!   [`Backend::sample`], [`Backend::evaluate`], [`Backend::interpolate`],
//!   [`Backend::interpolate_atph`], [`euler::solve_spirals`], and for
//!   polylines given as positions and offsets ([`Polylines`]):
//!   [`compress_polylines`] (with an [`codec::Effort`]:
//!   [`compress_polylines_with_effort`]), [`decompress_polylines`],
//!   [`fit_polylines`].
//! * One curve at a time: [`fit_spline`], [`fit_polyline_chain`],
//!   [`compress_curve`].
//! * Subsystems, as namespaces: [`codec`] (the tractography codec and its
//!   container), [`io`] (TCK, TRK, TRX, VTK, hair and JSON readers and
//!   writers), [`metrics`] (Hausdorff and Fréchet distances), [`atph`],
//!   [`euler`], [`helix`], [`rrmf`], [`spline`], [`sketch`].
//!
//! The library never prints; [`Backend::open_explained`] returns the
//! sentence a program may show its user.
//!
//! Conventions: lengths are in the input's units; curvature is `κ ≥ 0`;
//! torsion follows the standard Frenet–Serret sign (a right-handed helix has
//! `τ > 0`).
//!
//! ```
//! use strandfit::{fit_spline, BezierSpline, DVec3, FitOptions, ParamCurve3};
//!
//! // One cubic segment, fitted with 8 helices.
//! let spline = BezierSpline::from_control_points(&[
//!     DVec3::ZERO,
//!     DVec3::new(1.0, 1.0, 0.0),
//!     DVec3::new(2.0, -1.0, 1.0),
//!     DVec3::new(3.0, 0.0, 1.0),
//! ])
//! .unwrap();
//! let chain = fit_spline(&spline, &FitOptions::new(8)).unwrap();
//! assert_eq!(chain.len(), 8);
//! assert!((chain.arc_length() - spline.arc_length()).abs() < 1e-2 * spline.arc_length());
//! // The relaxation moves the break points a little, the ends included.
//! assert!(chain.eval(1.0).distance(DVec3::new(3.0, 0.0, 1.0)) < 1e-2);
//! ```

#![warn(missing_docs)]
// Deliberate numerics idioms: constants written with all the digits their
// source publishes; `!(x > 0.0)` comparisons that also reject NaN; index
// loops over several arrays in lockstep, as the equations are written.
#![allow(
    clippy::excessive_precision,
    clippy::neg_cmp_op_on_partial_ord,
    clippy::needless_range_loop
)]

// Public namespaces: the subsystems users reach into.
pub mod atph;
pub mod codec;
pub mod euler;
pub mod helix;
pub mod io;
pub mod metrics;
pub mod rrmf;
pub mod sketch;
pub mod spline;

// Private: their items are re-exported below.
mod adaptive;
mod backend;
mod batch;
mod compress;
mod curve;
mod fit;
mod pair;
mod sampled;

// Not part of the public API: the command line (src/main.rs), the GPU
// engine and its kernels' CPU twins, and the synthetic data of the tests
// and benchmarks. Public only for the binary, tests and benches.
#[doc(hidden)]
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]
pub mod cli;
#[doc(hidden)]
pub mod gpu;
#[doc(hidden)]
pub mod kernels;
#[doc(hidden)]
pub mod synthetic;
#[doc(hidden)]
pub mod twin;

pub use adaptive::{
    chain_frechet, chain_samples, chain_within, fit_polyline_chain, AdaptiveError, AdaptiveOptions,
    ChainFit, Distance, ElementCount,
};
pub use atph::AtphCurve;
pub use backend::{Backend, BackendChoice, GpuEngine, GpuError, PrecisionChoice, Samples};
pub use batch::{
    compress_polylines, compress_polylines_with_effort, decompress_polylines, fit_polylines,
    BatchError, Polylines,
};
pub use compress::{compress_curve, CompressOptions, CurveOutcome};
pub use curve::ParamCurve3;
pub use euler::FrenetProblem;
pub use fit::{
    fit_points, fit_spline, fit_spline_with, fit_splines, relaxed_pairs, FitError, FitOptions,
    FitScratch,
};
/// The vector type of every point and tangent (re-exported from `glam`).
pub use glam::DVec3;
pub use helix::{HelixElement, PiecewiseHelix};
pub use pair::HermitePair;
pub use rrmf::RrmfSpline;
pub use sampled::SampledCurve;
pub use spline::BezierSpline;
