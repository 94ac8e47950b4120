//! Sketch to 3D (paper 003, Cherin, Cordier & Melkemi 2014): a 2D polyline
//! lifted to a 3D piecewise helix whose orthogonal projection matches it.
//!
//! * [`lift_sketch`]: the whole method (its steps are described there), with
//!   [`SketchOptions`] and the result, [`SketchLift`].
//! * [`ProjectedHelix`]: the projected helix `H(t)` with tilt `c`
//!   (Section 4).
//! * [`tangents_and_curvatures`]: polyline tangents and curvatures
//!   (Section 5); [`resample`] and [`densify`] even out the sampling,
//!   [`estimate_noise`] and [`denoise`] deal with a noisy drawing.
//! * [`PlacedHelix`]: a projected helix placed in the sketch plane (6.1),
//!   its lift, closest points ([`Evaluator`], [`Foot`]).
//! * [`minimize`]: the Nelder–Mead simplex search the paper uses (6.2);
//!   [`least_squares`], the Levenberg–Marquardt search the covering's
//!   two-vertex fits use in its place (faster, measured no worse).
//! * [`cover()`]: one helix around the curvature maximum (6.1–6.3), and the
//!   recursive covering (6.4), in [`Piece`]s.
//! * [`refine()`]: least squares on placed helices; the fine fitting (7).
//! * [`refit_g1`]: beyond the paper, the lift re-fitted exactly G1 by the
//!   floating-tangents fitter.
//!
//! ```
//! use glam::DVec2;
//! use strandfit::sketch::{lift_sketch, refit_g1, SketchOptions};
//! use strandfit::ParamCurve3;
//!
//! // A drawing: the projection of a helix whose axis is tilted 0.8 rad out
//! // of the page, one and a half turns.
//! let (tilt, pitch) = (0.8f64, 0.3);
//! let drawing: Vec<DVec2> = (0..60)
//!     .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
//!     .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
//!     .collect();
//! // Lifted: its vertices raised out of the page, fitted by one helix.
//! let lift = lift_sketch(&drawing, &SketchOptions::default()).unwrap();
//! assert_eq!(lift.helices.len(), 1);
//! assert!(lift.points_3d.iter().zip(&drawing).all(|(p, q)| p.truncate() == *q));
//! let depth = lift.points_3d.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max)
//!     - lift.points_3d.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
//! assert!(depth > 1.0);
//! // As a G1 piecewise helix of the core, within 0.1 % of the length.
//! let g1 = refit_g1(&lift, 1e-3 * lift.length).unwrap();
//! assert!(g1.within_tolerance);
//! assert!(g1.chain.arc_length() > lift.length);
//! ```

mod cover;
mod estimate;
mod g1;
mod least_squares;
mod lift;
mod nelder_mead;
mod placed;
mod projected;
mod refine;
mod trig;

pub use cover::{
    cover, CoverOptions, COVER_GAIN, DENOISED_COVER_GAIN, MIN_VERTICES, NOISY_COVER_GAIN,
};
pub use estimate::{
    denoise, densify, estimate_noise, is_corner, resample, residual_agreement, smoothed,
    tangents_and_curvatures,
};
pub use g1::{refit_g1, G1Refit};
pub use least_squares::{least_squares, LeastSquaresOptions};
pub use lift::{
    lift_sketch, Junction, LiftedHelix, Resampling, SketchError, SketchLift, SketchOptions,
    DEEPENED, DEEPENED_FROM, DENOISE_ABOVE, EMAX_FRACTION, NOISE_FACTOR, NOISY_GAIN_ABOVE,
    UNIFORM_RATIO, WHITE_BELOW,
};
pub use nelder_mead::{minimize, Minimum, NelderMeadOptions};
pub use placed::{Evaluator, Foot, PlacedHelix, PARAMS};
pub use projected::ProjectedHelix;
pub use refine::{objective, refine, refine_to, Objective, Piece, RefineReport};

/// Helpers of the unit tests.
#[cfg(test)]
pub(crate) mod testing {
    use glam::DVec2;

    /// `points` with Gaussian noise of `sigma` on each coordinate (Box–Muller
    /// on ChaCha8, the generator of `benches/sketch_noise.rs`).
    pub(crate) fn with_noise(points: &[DVec2], sigma: f64, seed: u64) -> Vec<DVec2> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut gauss = move || {
            let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
            let v: f64 = rng.gen();
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        points
            .iter()
            .map(|&p| p + sigma * DVec2::new(gauss(), gauss()))
            .collect()
    }
}
