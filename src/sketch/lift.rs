//! The whole method, `lift_sketch` (its steps are described there), with its
//! options and result types.

use glam::{DVec2, DVec3};

use super::cover::{
    cover_probed, merge_noisy, plausible, CoverOptions, Drawn, Probes, COVER_GAIN,
    DENOISED_COVER_GAIN, NOISY_COVER_GAIN,
};
use super::estimate::{
    denoise, densify, estimate_noise, resample, residual_agreement, smoothed,
    tangents_and_curvatures,
};
use super::placed::{PlacedHelix, PARAMS};
use super::refine::{objective, refine, refine_holding, Objective, Piece, RefineReport};
use super::ProjectedHelix;
use crate::euler::normalize_angle;

/// Inputs whose longest edge is within this factor of the shortest are
/// used as they are; others are resampled ([`Resampling`]).
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions, UNIFORM_RATIO};
///
/// // Even edges: used as they are.
/// let even = one_helix();
/// let lift = lift_sketch(&even, &SketchOptions::default()).unwrap();
/// assert!(!lift.resampled);
/// assert_eq!(lift.points_2d, even);
/// // Every vertex of the first half, every fourth of the second: the longest
/// // edge is over UNIFORM_RATIO times the shortest, so the drawing is evened
/// // out first (densified by default: the drawn vertices are all kept).
/// let uneven: Vec<DVec2> = even.iter().enumerate().filter(|(k, _)| *k < 30 || k % 4 == 3).map(|(_, p)| *p).collect();
/// let lift = lift_sketch(&uneven, &SketchOptions::default()).unwrap();
/// assert!(lift.resampled);
/// assert!(uneven.iter().all(|p| lift.points_2d.contains(p)));
/// ```
pub const UNIFORM_RATIO: f64 = 3.0;

/// How an unevenly sampled drawing is evened out before the covering.
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, Resampling, SketchOptions};
///
/// // An unevenly sampled drawing (every fourth vertex in its second half).
/// let uneven: Vec<DVec2> = one_helix().into_iter().enumerate().filter(|(k, _)| *k < 30 || k % 4 == 3).map(|(_, p)| p).collect();
/// assert_eq!(SketchOptions::default().resampling, Resampling::Densify);
/// let densified = lift_sketch(&uneven, &SketchOptions::default()).unwrap();
/// assert!(densified.points_2d.len() > uneven.len());
/// assert!(uneven.iter().all(|p| densified.points_2d.contains(p)));
/// // The paper's: as many points, evenly spaced; the ends kept.
/// let opts = SketchOptions { resampling: Resampling::Uniform, ..Default::default() };
/// let uniform = lift_sketch(&uneven, &opts).unwrap();
/// assert_eq!(uniform.points_2d.len(), uneven.len());
/// assert_eq!(uniform.points_2d.last(), uneven.last());
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resampling {
    /// Every edge longer than the mean split along a spline through the
    /// vertices ([`densify`]); the drawing's own vertices are all kept.
    /// Measured on 144 projections of 2–4 helices (45 of them uneven):
    /// every junction of the uneven ones on its corner vertex (uniform:
    /// within 0.9 of a sample step, never on it), the largest projection
    /// error 11× smaller (0.04 against 0.47 `E_max` on average), 1
    /// spurious junction instead of 3.
    #[default]
    Densify,
    /// The paper's: the same number of points, equally spaced in arc
    /// length along the polyline ([`resample`]); corners and near-cusps
    /// that fall between samples are cut.
    Uniform,
}

/// The paper's `E_max`, as a fraction of the sketch's length (Section 6.3).
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions, EMAX_FRACTION};
///
/// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
///
/// // A clean drawing: E_max is the paper's 0.1 % of its length.
/// assert!((lift.emax - EMAX_FRACTION * lift.length).abs() < 1e-12 * lift.length);
/// ```
pub const EMAX_FRACTION: f64 = 1e-3;

/// The automatic `E_max` is at least this many times the drawing's noise
/// (per coordinate): every vertex of a helix's stretch must lie within
/// `E_max` of it for the covering to go on, and of 500 vertices with
/// Gaussian noise the farthest is about 3.3 σ from the true curve.
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions, NOISE_FACTOR};
///
/// // Every vertex moved by ±0.01 in x and y: E_max follows the noise.
/// let noisy: Vec<DVec2> = one_helix()
///     .iter()
///     .enumerate()
///     .map(|(k, p)| *p + 0.01 * if (k * 7919) % 3 == 0 { DVec2::new(1.0, -1.0) } else { DVec2::new(-1.0, 1.0) })
///     .collect();
/// let lift = lift_sketch(&noisy, &SketchOptions::default()).unwrap();
/// assert!(lift.noise > 0.005);
/// assert!((lift.emax - NOISE_FACTOR * lift.noise).abs() < 1e-12 * lift.emax);
/// ```
pub const NOISE_FACTOR: f64 = 5.0;

/// Drawings whose noise ([`estimate_noise`]) is over this fraction of
/// their length, and looks like noise ([`WHITE_BELOW`]), are denoised
/// before the covering (where [`SketchOptions::denoise`]): from there on
/// the noise moves the curvature estimates of Section 5 by more than the
/// covering's two-vertex fits tolerate (measured: at 1e-5 of the length,
/// 4 of 40 drawings were cut in the wrong place, 1 of 40 denoised).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::{lift_sketch, SketchOptions, DENOISE_ABOVE};
///
/// // A clean drawing is fitted as drawn; the same with jitter is denoised.
/// let clean: Vec<DVec2> = (0..200).map(|k| DVec2::from_angle(k as f64 * 0.02)).collect();
/// let lift = lift_sketch(&clean, &SketchOptions::default()).unwrap();
/// assert!(!lift.denoised && lift.noise < DENOISE_ABOVE * lift.length);
/// let jitter = |k: usize| 0.002 * if (k * 7919) % 5 < 2 { 1.0 } else { -1.0 };
/// let noisy: Vec<DVec2> = clean.iter().enumerate().map(|(k, p)| *p + DVec2::new(jitter(k), jitter(k + 2))).collect();
/// let lift = lift_sketch(&noisy, &SketchOptions::default()).unwrap();
/// assert!(lift.denoised && lift.max_error < lift.drawn_error);
/// ```
pub const DENOISE_ABOVE: f64 = 3e-6;

/// The covering's refinements stop early ([`NOISY_COVER_GAIN`]) where the
/// drawing's noise is over this fraction of `E_max`: no helix fits it
/// closer than the noise, and the last iterations only crawl. Below, they
/// run to [`COVER_GAIN`]: at noise 1 % of `E_max` the early stop left fits
/// 30 σ off, loose enough for the covering to take a wrong helix (3 of 40
/// noisy drawings at 1e-5 of the length, against 1 of 40 run to
/// `COVER_GAIN`); at 10 % of `E_max` it brought four more of 40 to the
/// right helix count, in two thirds of the time.
pub const NOISY_GAIN_ABOVE: f64 = 0.05;

/// The noise estimate of a clean drawing is the estimator's bias on its
/// bends (up to 1e-5 of the length on coarse drawings of 40–60 vertices),
/// which is no noise to remove: a drawing is denoised only where its
/// neighbouring residuals point the same way in fewer than this fraction
/// of pairs ([`residual_agreement`]; noise: about 0.4, bias: nearly 1).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::{lift_sketch, SketchOptions};
///
/// // A coarse clean drawing: its estimated noise is bias, and it is fitted
/// // as drawn.
/// let coarse: Vec<DVec2> = (0..40).map(|k| DVec2::from_angle(k as f64 * 0.15)).collect();
/// let lift = lift_sketch(&coarse, &SketchOptions::default()).unwrap();
/// assert!(!lift.denoised && lift.points_2d == coarse);
/// ```
pub const WHITE_BELOW: f64 = 0.65;

/// Options of [`lift_sketch`].
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, SketchError, SketchOptions};
///
/// // E_max given: 0.5 % of the length, whatever the drawing.
/// let opts = SketchOptions { emax: Some(5e-3), ..Default::default() };
/// let lift = lift_sketch(&one_helix(), &opts).unwrap();
/// assert!((lift.emax - 5e-3 * lift.length).abs() < 1e-12);
/// assert!(lift.max_error <= lift.emax);
/// // Options out of range are refused before any work.
/// for bad in [
///     SketchOptions { emax: Some(0.0), ..Default::default() },
///     SketchOptions { alpha_t: 1.0, ..Default::default() },
///     SketchOptions { window: 0, ..Default::default() },
/// ] {
///     assert!(matches!(lift_sketch(&one_helix(), &bad), Err(SketchError::Options(_))));
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SketchOptions {
    /// `E_max` as a fraction of the sketch length. `None` (the default):
    /// chosen from the drawing, the paper's 0.1 % ([`EMAX_FRACTION`]) or
    /// [`NOISE_FACTOR`] times the noise the drawing shows
    /// ([`estimate_noise`]), whichever is larger.
    pub emax: Option<f64>,
    /// `α_T` of the fine fitting, in `[0, 1)` (0: distances only).
    pub alpha_t: f64,
    /// `NMAX`: neighbours of each seed tried on each side (Section 6.3).
    pub nmax: usize,
    /// Half-width of the curvature estimator's window (Section 5).
    pub window: usize,
    /// Iteration cap of the fine fitting.
    pub fine_iterations: usize,
    /// How an unevenly sampled drawing is evened out.
    pub resampling: Resampling,
    /// Denoise a drawing whose noise is over [`DENOISE_ABOVE`] of its
    /// length before the covering ([`denoise`]); `false`: fit the drawn
    /// vertices as they are (the paper's).
    pub denoise: bool,
}

impl Default for SketchOptions {
    fn default() -> Self {
        SketchOptions {
            emax: None,
            alpha_t: 0.5,
            nmax: 12,
            window: 3,
            fine_iterations: 100,
            resampling: Resampling::Densify,
            denoise: true,
        }
    }
}

/// Why a sketch cannot be lifted.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::{lift_sketch, SketchError, SketchOptions};
///
/// let lift = |p: &[DVec2]| lift_sketch(p, &SketchOptions::default()).err();
/// let (o, x) = (DVec2::ZERO, DVec2::X);
/// assert_eq!(lift(&[o, o, x]), Some(SketchError::TooFew(2)));
/// assert_eq!(lift(&[o, o, o, o]), Some(SketchError::TooFew(1)));
/// assert_eq!(lift(&[o, DVec2::NAN, x]), Some(SketchError::NonFinite(1)));
/// let far = DVec2::new(1e308, 0.0);
/// assert_eq!(lift(&[o, far, -far]), Some(SketchError::ZeroLength));
/// assert_eq!(
///     SketchError::TooFew(2).to_string(),
///     "a sketch needs at least 3 distinct points, found 2"
/// );
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SketchError {
    /// Fewer than 3 points once repeated consecutive points are dropped
    /// (the count left).
    #[error("a sketch needs at least 3 distinct points, found {0}")]
    TooFew(usize),
    /// A coordinate is NaN or infinite (the point's index).
    #[error("point {0} is not finite")]
    NonFinite(usize),
    /// The sketch's length is zero or not finite (its points are too far
    /// apart for `f64`). A sketch whose points are all the same is
    /// [`TooFew`](Self::TooFew).
    #[error("the sketch has zero length")]
    ZeroLength,
    /// An option out of its range (which, and why).
    #[error("invalid option: {0}")]
    Options(&'static str),
}

/// One helix of the result, in the sketch's units.
///
/// ```
/// # use glam::DVec2;
/// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
/// # fn one_helix() -> Vec<DVec2> {
/// #     let (tilt, pitch) = (0.8f64, 0.3);
/// #     (0..60)
/// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
/// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
/// #         .collect()
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions};
///
/// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
///
/// // One helix over the whole drawing, from t_start at its first vertex to
/// // t_end at its last, its radius and pitch the drawn helix's.
/// let h = lift.helices[0];
/// assert_eq!((lift.helices.len(), h.first, h.last), (1, 0, 59));
/// assert!((h.point_2d(h.t_start) - lift.points_2d[0]).length() <= h.max_error);
/// assert!((h.point_2d(h.t_end) - lift.points_2d[59]).length() <= h.max_error);
/// assert!((h.helix.a.abs() - 1.0).abs() < 1e-3 && (h.helix.b.abs() - 0.3).abs() < 1e-3);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiftedHelix {
    /// `(a, b, c)` of Section 4.1 (radius `|a|`, pitch `|b|` per radian,
    /// tilt `c`).
    pub helix: ProjectedHelix,
    /// Placement of the helix frame in the sketch plane (Section 6.1):
    /// its rotation,
    pub theta: f64,
    /// where `H(0)` lands,
    pub origin: DVec2,
    /// and whether its `x` axis is flipped first.
    pub reflect: bool,
    /// `H_3D,S` (the mirror) rather than `H_3D,R`.
    pub mirror: bool,
    /// `z` offset: the lift is `(P(t), ±z(t) + z0)`.
    pub z0: f64,
    /// Parameter at the first vertex.
    pub t_start: f64,
    /// Parameter at the last vertex (`t` may run either way).
    pub t_end: f64,
    /// First vertex covered (of [`SketchLift::points_2d`]).
    pub first: usize,
    /// Last vertex covered (inclusive; shared with the next helix).
    pub last: usize,
    /// Largest vertex distance from the projected helix.
    pub max_error: f64,
}

impl LiftedHelix {
    fn placed(&self) -> PlacedHelix {
        PlacedHelix {
            helix: self.helix,
            theta: self.theta,
            origin: self.origin,
            reflect: self.reflect,
        }
    }

    /// The projected helix in the sketch plane.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
    /// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
    /// # fn one_helix() -> Vec<DVec2> {
    /// #     let (tilt, pitch) = (0.8f64, 0.3);
    /// #     (0..60)
    /// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
    /// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
    /// #         .collect()
    /// # }
    /// use strandfit::sketch::{lift_sketch, SketchOptions};
    ///
    /// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
    ///
    /// // The projection of the 3D helix, near the drawing.
    /// let h = lift.helices[0];
    /// let t = 0.5 * (h.t_start + h.t_end);
    /// assert_eq!(h.point_2d(t), h.point_3d(t).truncate());
    /// assert!((h.point_2d(h.t_start) - lift.points_2d[h.first]).length() <= lift.max_error);
    /// ```
    pub fn point_2d(&self, t: f64) -> DVec2 {
        self.placed().point(t)
    }

    /// The 3D helix.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
    /// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
    /// # fn one_helix() -> Vec<DVec2> {
    /// #     let (tilt, pitch) = (0.8f64, 0.3);
    /// #     (0..60)
    /// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
    /// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
    /// #         .collect()
    /// # }
    /// use strandfit::sketch::{lift_sketch, SketchOptions};
    ///
    /// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
    ///
    /// // The lifted vertices' depths are the helix's, at their parameters; the
    /// // first vertex is at z = 0.
    /// let h = lift.helices[0];
    /// assert_eq!(lift.points_3d[0].z, h.point_3d(h.t_start).z);
    /// assert!(h.point_3d(h.t_start).z.abs() < 1e-12);
    /// ```
    pub fn point_3d(&self, t: f64) -> DVec3 {
        self.placed().point_3d(t, self.mirror, self.z0)
    }

    /// The unit tangent of the 3D helix, pointing along the sketch (`t`
    /// may run either way: from `t_start` at the first vertex to `t_end`).
    ///
    /// ```
    /// # use glam::DVec2;
    /// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
    /// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
    /// # fn one_helix() -> Vec<DVec2> {
    /// #     let (tilt, pitch) = (0.8f64, 0.3);
    /// #     (0..60)
    /// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
    /// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
    /// #         .collect()
    /// # }
    /// use strandfit::sketch::{lift_sketch, SketchOptions};
    ///
    /// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
    ///
    /// // A unit vector, pointing from the first vertex towards the next.
    /// let h = lift.helices[0];
    /// let tangent = h.tangent_3d(h.t_start).unwrap();
    /// assert!((tangent.length() - 1.0).abs() < 1e-12);
    /// assert!(tangent.dot(lift.points_3d[1] - lift.points_3d[0]) > 0.0);
    /// ```
    pub fn tangent_3d(&self, t: f64) -> Option<DVec3> {
        let sign = if self.t_end < self.t_start { -1.0 } else { 1.0 };
        self.placed().tangent_3d(t, self.mirror).map(|v| sign * v)
    }

    /// `m ≥ 2` points of the 3D helix, evenly spaced in `t`.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # /// The projection of a helix of radius 1 and pitch 0.3 per radian whose
    /// # /// axis is tilted 0.8 rad out of the page, one and a half turns, 60 vertices.
    /// # fn one_helix() -> Vec<DVec2> {
    /// #     let (tilt, pitch) = (0.8f64, 0.3);
    /// #     (0..60)
    /// #         .map(|k| 3.0 * std::f64::consts::PI * k as f64 / 59.0)
    /// #         .map(|u| DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin()))
    /// #         .collect()
    /// # }
    /// use strandfit::sketch::{lift_sketch, SketchOptions};
    ///
    /// let lift = lift_sketch(&one_helix(), &SketchOptions::default()).unwrap();
    ///
    /// let h = lift.helices[0];
    /// let s = h.sample_3d(10);
    /// assert_eq!(s.len(), 10);
    /// assert_eq!(s[0], h.point_3d(h.t_start));
    /// assert!((s[9] - h.point_3d(h.t_end)).length() < 1e-12);
    /// assert_eq!(h.sample_3d(0).len(), 2); // at least the ends
    /// ```
    pub fn sample_3d(&self, m: usize) -> Vec<DVec3> {
        let m = m.max(2);
        (0..m)
            .map(|k| {
                let u = k as f64 / (m - 1) as f64;
                self.point_3d(self.t_start + u * (self.t_end - self.t_start))
            })
            .collect()
    }
}

/// What is left at a junction vertex (the paper's curve is neither C0 nor
/// G1 there).
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{resample, PlacedHelix};
/// # /// The projections of two helices, the second starting where the first
/// # /// ends with a corner of 0.6 rad, each sampled evenly along its length:
/// # /// 43 vertices, the corner at vertex 24.
/// # fn two_helices() -> Vec<DVec2> {
/// #     let a = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 1.0, 0.3, 0.8], false);
/// #     let turn = a.derivative(3.0).to_angle() + 0.6 - std::f64::consts::FRAC_PI_2;
/// #     let end = a.point(3.0);
/// #     let b = PlacedHelix::from_params(&[turn, end.x, end.y, 0.7, 0.1, 1.0], true);
/// #     let dense = |h: &PlacedHelix| -> Vec<DVec2> {
/// #         (0..=1000).map(|k| h.point(3.0 * k as f64 / 1000.0)).collect()
/// #     };
/// #     let (da, db) = (dense(&a), dense(&b));
/// #     let len = |p: &[DVec2]| -> f64 { p.windows(2).map(|w| (w[1] - w[0]).length()).sum() };
/// #     let nb = (25.0 * len(&db) / len(&da)).round() as usize;
/// #     let mut d = resample(&da, 25);
/// #     d.extend(resample(&db, nb + 1).into_iter().skip(1));
/// #     assert_eq!(d.len(), 43);
/// #     d
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions};
///
/// // Two helices drawn with a corner at vertex 24: one junction there. The
/// // depths meet; the gap left is in the drawing, within both helices' errors.
/// let lift = lift_sketch(&two_helices(), &SketchOptions::default()).unwrap();
/// assert_eq!(lift.junctions.len(), 1);
/// let (j, l, r) = (lift.junctions[0], lift.helices[0], lift.helices[1]);
/// assert_eq!((j.vertex, l.last, r.first), (24, 24, 24));
/// assert!(j.position_gap <= l.max_error + r.max_error + 1e-12);
/// assert!(j.tangent_angle > 0.1); // the lift is not G1 there
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Junction {
    /// The vertex the two helices share.
    pub vertex: usize,
    /// Angle between the 3D tangents of the two helices, radians.
    pub tangent_angle: f64,
    /// Distance between the two helices' points at the junction.
    pub position_gap: f64,
}

/// The result of [`lift_sketch`].
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{resample, PlacedHelix};
/// # /// The projections of two helices, the second starting where the first
/// # /// ends with a corner of 0.6 rad, each sampled evenly along its length:
/// # /// 43 vertices, the corner at vertex 24.
/// # fn two_helices() -> Vec<DVec2> {
/// #     let a = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 1.0, 0.3, 0.8], false);
/// #     let turn = a.derivative(3.0).to_angle() + 0.6 - std::f64::consts::FRAC_PI_2;
/// #     let end = a.point(3.0);
/// #     let b = PlacedHelix::from_params(&[turn, end.x, end.y, 0.7, 0.1, 1.0], true);
/// #     let dense = |h: &PlacedHelix| -> Vec<DVec2> {
/// #         (0..=1000).map(|k| h.point(3.0 * k as f64 / 1000.0)).collect()
/// #     };
/// #     let (da, db) = (dense(&a), dense(&b));
/// #     let len = |p: &[DVec2]| -> f64 { p.windows(2).map(|w| (w[1] - w[0]).length()).sum() };
/// #     let nb = (25.0 * len(&db) / len(&da)).round() as usize;
/// #     let mut d = resample(&da, 25);
/// #     d.extend(resample(&db, nb + 1).into_iter().skip(1));
/// #     assert_eq!(d.len(), 43);
/// #     d
/// # }
/// use strandfit::sketch::{lift_sketch, SketchOptions};
///
/// let drawing = two_helices();
/// let lift = lift_sketch(&drawing, &SketchOptions::default()).unwrap();
/// // The helices cover the vertices in order, sharing the junction vertices.
/// let spans: Vec<_> = lift.helices.iter().map(|h| (h.first, h.last)).collect();
/// assert_eq!(spans, [(0, 24), (24, 42)]);
/// // The lifted vertices are the drawing's, raised.
/// assert_eq!(lift.points_2d, drawing);
/// assert!(lift.points_3d.iter().zip(&drawing).all(|(p, q)| p.truncate() == *q));
/// assert!(lift.rms_error <= lift.max_error && lift.max_error <= lift.emax);
/// assert!(lift.fine_fit.after <= lift.fine_fit.before);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SketchLift {
    /// The helices, in order along the drawing.
    pub helices: Vec<LiftedHelix>,
    /// The vertices the fit ran on: the input, denoised where
    /// `denoised`, and (where `resampled`) evened out as
    /// [`SketchOptions::resampling`] says (densified: every vertex before
    /// is among them).
    pub points_2d: Vec<DVec2>,
    /// Whether the input's edges differed by more than [`UNIFORM_RATIO`].
    pub resampled: bool,
    /// The lifted vertices `(x, y, z)` (Section 7: `x, y` are the sketch's).
    pub points_3d: Vec<DVec3>,
    /// What is left at each junction.
    pub junctions: Vec<Junction>,
    /// Largest distance of a vertex of [`points_2d`](Self::points_2d)
    /// from the projected fit.
    pub max_error: f64,
    /// Largest distance of a drawn vertex from the projected fit: the
    /// same as `max_error` unless the drawing was denoised or resampled.
    pub drawn_error: f64,
    /// Whether the drawing was denoised before the covering
    /// ([`SketchOptions::denoise`]); [`points_2d`](Self::points_2d) are
    /// then the denoised vertices.
    pub denoised: bool,
    /// Root-mean-square vertex distance from the projected fit.
    pub rms_error: f64,
    /// Length of the sketch polyline.
    pub length: f64,
    /// The drawing's noise as estimated (standard deviation of a vertex
    /// about a smooth curve, per coordinate, in the sketch's units).
    pub noise: f64,
    /// The `E_max` the covering used, in the sketch's units.
    pub emax: f64,
    /// The fine fitting (Section 7).
    pub fine_fit: RefineReport,
}

fn check(points: &[DVec2]) -> Result<Vec<DVec2>, SketchError> {
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(SketchError::NonFinite(i));
    }
    let mut clean: Vec<DVec2> = Vec::with_capacity(points.len());
    for &p in points {
        if clean.last() != Some(&p) {
            clean.push(p);
        }
    }
    if clean.len() < 3 {
        return Err(SketchError::TooFew(clean.len()));
    }
    Ok(clean)
}

/// How much steeper than its covering fit ([`Piece::depth_slope`]) the
/// fine fit may make a piece before the piece keeps the covering fit. The
/// fine fit's tangent term (`α_T E_T`) is there to close the junctions'
/// tangent gaps, not to choose another helix; on a noisy drawing it can
/// pull a piece whose covering fit is the helix drawn (depth slope 0.3) to
/// a much deeper one that meets its neighbours' tangents (2.4–2.8), and
/// the lift comes out 2–4× too deep. Measured on the 480 noisy drawings of
/// `benches/sketch_noise.rs`: 458 → 464 right (three curls at 0.3 % 41 →
/// 46, four curls at 0.3 % 37 → 38; none lost; 1.5 gave the same, 3 one
/// fewer); the 320 at 0–0.03 % unchanged (no piece deepened so).
pub const DEEPENED: f64 = 2.0;

/// The least depth slope [`DEEPENED`] is taken of (a nearly flat
/// covering fit may steepen a little without being another helix).
pub const DEEPENED_FROM: f64 = 0.2;

/// Lift a 2D polyline to a 3D piecewise helix.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::{lift_sketch, SketchOptions};
/// // The projection of a helix of radius 1 and pitch 0.3 per radian whose
/// // axis is tilted 0.8 rad out of the page, one and a half turns.
/// let (tilt, pitch) = (0.8f64, 0.3);
/// let drawing: Vec<DVec2> = (0..120)
///     .map(|k| {
///         let u = 3.0 * std::f64::consts::PI * k as f64 / 119.0;
///         DVec2::new(u.cos(), u.sin() * tilt.cos() - pitch * u * tilt.sin())
///     })
///     .collect();
/// let lift = lift_sketch(&drawing, &SketchOptions::default()).unwrap();
/// assert_eq!(lift.helices.len(), 1);
/// assert!(lift.max_error <= 1e-3 * lift.length);
/// // The helix found has the drawn one's radius and pitch.
/// let h = lift.helices[0].helix;
/// assert!((h.a.abs() - 1.0).abs() < 1e-3 && (h.b.abs() - pitch).abs() < 1e-3);
/// ```
///
/// # Method
///
/// Sections 6–7 of the paper, in five steps:
///
/// 1. Checks, and normalisation to unit length about the centroid (so every
///    tolerance below is relative, and the result is invariant to
///    translation and uniform scale by construction; rotation invariance
///    follows from the tangent-based alignment, as the paper says).
/// 2. Resampling when the input's edges differ by more than
///    [`UNIFORM_RATIO`] (Section 6 assumes even sampling); otherwise the
///    input vertices are used as they are. The paper resamples uniformly
///    ([`Resampling::Uniform`]); the default splits the long edges along a
///    spline and keeps every drawn vertex ([`Resampling::Densify`]), which
///    measured better (see there).
/// 3. Tangents and curvatures (Section 5), covering (6.1–6.4).
/// 4. Lift (Section 7): each helix or its mirror, chosen so the 3D tangents
///    at each junction are most parallel; then the fine fitting of
///    `α_T E_T + (1 − α_T) E_D` ([`refine`](super::refine())); then `z`
///    offsets making the curve continuous in `z` at every junction.
/// 5. Report: per junction the remaining tangent angle and position gap,
///    and the projection error (vertex distances from the fitted curves).
pub fn lift_sketch(points: &[DVec2], opts: &SketchOptions) -> Result<SketchLift, SketchError> {
    if let Some(e) = opts.emax {
        if !(e > 0.0 && e < 1.0) {
            return Err(SketchError::Options(
                "emax must be in (0, 1) (a fraction of the length)",
            ));
        }
    }
    if !(opts.alpha_t >= 0.0 && opts.alpha_t < 1.0) {
        return Err(SketchError::Options("alpha_t must be in [0, 1)"));
    }
    if opts.nmax == 0 || opts.window == 0 {
        return Err(SketchError::Options("nmax and window must be at least 1"));
    }
    let clean = check(points)?;
    let edge_lengths =
        |p: &[DVec2]| -> Vec<f64> { p.windows(2).map(|w| (w[1] - w[0]).length()).collect() };
    let edges = edge_lengths(&clean);
    let length: f64 = edges.iter().sum();
    if !(length > 0.0) || !length.is_finite() {
        return Err(SketchError::ZeroLength);
    }
    let noise = estimate_noise(&clean);
    // A noisy drawing is denoised first: its curvatures (Section 5) and the
    // covering's two-vertex fits then see the stroke, not the jitter, and
    // E_max follows the noise left, not the noise drawn.
    // Whether what the estimate found is noise, not a coarse drawing's
    // bends (see WHITE_BELOW).
    let white = residual_agreement(&clean) < WHITE_BELOW;
    let denoised = opts.denoise && white && noise > DENOISE_ABOVE * length;
    let source = if denoised {
        denoise(&clean, noise)
    } else {
        clean.clone()
    };
    let emax = opts
        .emax
        .unwrap_or(EMAX_FRACTION.max(NOISE_FACTOR * noise / length));
    // Where the noise sets E_max it moves vertices by a good part of an
    // edge, and the edges' spread is the noise's: the sampling is judged
    // on the drawing smoothed.
    let noisy = NOISE_FACTOR * noise > EMAX_FRACTION * length;
    let judged = if noisy {
        edge_lengths(&smoothed(&source))
    } else {
        edge_lengths(&source)
    };
    let (shortest, longest) = judged
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &e| (a.min(e), b.max(e)));
    let resampled = longest > UNIFORM_RATIO * shortest;
    let work = match (resampled, opts.resampling) {
        (false, _) => source.clone(),
        // At most twice the input's vertices (edges split to the mean
        // length): the cost of the covering grows with the vertex count
        // (resampling at the shortest edge, tried first, made up to 4×
        // more vertices and 10× the time), and the neighbourhoods NMAX
        // and the estimator's window are counted in vertices of the
        // drawing's own density.
        (true, Resampling::Densify) => densify(&source, length / edges.len() as f64),
        (true, Resampling::Uniform) => resample(&source, source.len()),
    };
    // Normalise: centroid to the origin, unit length.
    let centre = work.iter().copied().sum::<DVec2>() / work.len() as f64;
    let unit: Vec<DVec2> = work.iter().map(|&p| (p - centre) / length).collect();

    // Where the noise sets E_max, what is left of it once denoised is a
    // slow wobble, which the curvature estimator's window is widened over
    // (measured on the noisy drawings at 0.1 % and 0.3 %: 3 → 6 vertices
    // brought four more of 40 to the right helix count).
    let window = if noisy && white {
        2 * opts.window
    } else {
        opts.window
    };
    let geometry = tangents_and_curvatures(&unit, window);
    let cover_opts = CoverOptions {
        emax,
        nmax: opts.nmax,
        end_guard: opts.window,
        gain: if white && noise > NOISY_GAIN_ABOVE * emax * length {
            NOISY_COVER_GAIN
        } else if denoised {
            DENOISED_COVER_GAIN
        } else {
            COVER_GAIN
        },
        noise: if denoised { noise / length } else { 0.0 },
    };
    // The covering's merge probes, reused by the noisy merges.
    let probes = Probes::default();
    let mut pieces = cover_probed(&unit, &geometry, &cover_opts, &probes);
    let at = counterparts(&source, &work);
    if denoised {
        if let Some(at) = &at {
            let vertices: Vec<(usize, DVec2)> = at
                .iter()
                .zip(&clean)
                .map(|(&j, &p)| (j, (p - centre) / length))
                .collect();
            let drawn = Drawn {
                vertices: &vertices,
                sigma: noise / length,
            };
            merge_noisy(&unit, &geometry, &mut pieces, &cover_opts, &drawn, &probes);
        }
    }
    choose_mirrors(&mut pieces);
    let obj = Objective {
        alpha_t: opts.alpha_t,
        emax,
    };
    let covered = pieces.clone();
    let mut fine_fit = refine(&unit, &mut pieces, &obj, opts.fine_iterations);
    // Tangent continuity can pull a short piece of a noisy drawing to a
    // helix seen end-on, or to one much deeper than the covering's; such a
    // piece keeps its covering fit (see DEEPENED).
    let mut kept = false;
    for (p, c) in pieces.iter_mut().zip(&covered) {
        let deepened = p.depth_slope() > DEEPENED * c.depth_slope().max(DEEPENED_FROM);
        if (!plausible(p) || deepened) && plausible(c) {
            *p = c.clone();
            kept = true;
        }
    }
    // A lone helix the drawing does not show the depth of is made flat.
    if let [piece] = pieces.as_mut_slice() {
        let sigma = if denoised { noise / length } else { 0.0 };
        if let Some(flat) = flattened(&unit, piece, sigma, emax) {
            *piece = flat;
            kept = true;
        }
    }
    if kept {
        fine_fit.after = objective(&unit, &pieces, &obj);
    }
    let z0 = z_offsets(&pieces);

    // Back to the sketch's units.
    let helices: Vec<LiftedHelix> = pieces
        .iter()
        .zip(&z0)
        .map(|(p, &z)| LiftedHelix {
            // The angles within a turn: the fits move them freely, and
            // a tilt seen along the axis can wander by several turns.
            helix: ProjectedHelix::new(
                p.helix.helix.a * length,
                p.helix.helix.b * length,
                normalize_angle(p.helix.helix.c),
            ),
            theta: normalize_angle(p.helix.theta),
            origin: centre + p.helix.origin * length,
            reflect: p.helix.reflect,
            mirror: p.mirror,
            z0: z * length,
            t_start: p.ts[0],
            t_end: p.ts[p.ts.len() - 1],
            first: p.first,
            last: p.last,
            max_error: p.max_distance(&unit) * length,
        })
        .collect();
    let mut points_3d: Vec<DVec3> = work.iter().map(|p| p.extend(0.0)).collect();
    let mut sum2 = 0.0;
    let mut count = 0usize;
    let mut max_error = 0.0f64;
    for (h, p) in helices.iter().zip(&pieces) {
        for (k, &t) in p.ts.iter().enumerate() {
            let j = p.first + k;
            points_3d[j].z = h.point_3d(t).z;
            let d = (work[j] - h.point_2d(t)).length();
            sum2 += d * d;
            count += 1;
            max_error = max_error.max(d);
        }
    }
    let drawn_error = if denoised || resampled {
        drawn_distance(&clean, at.as_deref(), &work, &pieces, centre, length)
    } else {
        max_error
    };
    let junctions = (1..helices.len())
        .filter(|&i| helices[i - 1].last == helices[i].first)
        .map(|i| {
            let (l, r) = (&helices[i - 1], &helices[i]);
            let tl = l.tangent_3d(l.t_end).unwrap_or(DVec3::ZERO);
            let tr = r.tangent_3d(r.t_start).unwrap_or(DVec3::ZERO);
            Junction {
                vertex: r.first,
                tangent_angle: tl.angle_between(tr),
                position_gap: (l.point_3d(l.t_end) - r.point_3d(r.t_start)).length(),
            }
        })
        .collect();
    Ok(SketchLift {
        helices,
        points_2d: work,
        resampled,
        points_3d,
        junctions,
        max_error,
        drawn_error,
        denoised,
        rms_error: (sum2 / count.max(1) as f64).sqrt(),
        length,
        noise,
        emax: emax * length,
        fine_fit,
    })
}

/// Where each vertex of `source` is in `work`: densifying keeps them all,
/// in order, exactly; `None` where `work` does not (uniform resampling).
fn counterparts(source: &[DVec2], work: &[DVec2]) -> Option<Vec<usize>> {
    let mut at = Vec::with_capacity(source.len());
    let mut w = 0;
    for p in source {
        while w < work.len() && work[w] != *p {
            w += 1;
        }
        at.push(w);
    }
    at.iter().all(|&w| w < work.len()).then_some(at)
}

/// The largest distance of a drawn vertex (`clean`) from the projected
/// fit, in the sketch's units. The fit ran on `work`: the drawing, or the
/// drawing denoised, evened out where it was resampled. Each drawn vertex
/// is measured by a closest-point search from the parameter of its
/// counterpart in `work` (`at`, [`counterparts`]), or where there are
/// none (uniform resampling) from the nearest vertex of `work`.
fn drawn_distance(
    clean: &[DVec2],
    at: Option<&[usize]>,
    work: &[DVec2],
    pieces: &[Piece],
    centre: DVec2,
    length: f64,
) -> f64 {
    let mut worst = 0.0f64;
    for (i, &p) in clean.iter().enumerate() {
        let j = if let Some(at) = at {
            at[i]
        } else {
            // Uniform resampling: the nearest vertex of the fit.
            (0..work.len())
                .min_by(|&a, &b| {
                    (work[a] - p)
                        .length_squared()
                        .total_cmp(&(work[b] - p).length_squared())
                })
                .unwrap_or(0)
        };
        let Some(piece) = pieces.iter().find(|q| q.first <= j && j <= q.last) else {
            continue;
        };
        let e = piece.helix.evaluator();
        let v = (p - centre) / length;
        let foot = e.project(v, piece.ts[j - piece.first]);
        worst = worst.max((v - e.jet(foot.t).0).length());
    }
    worst * length
}

/// Section 7: the first helix as is, each next one or its mirror, whichever
/// makes the 3D tangents at their junction most parallel.
fn choose_mirrors(pieces: &mut [Piece]) {
    for i in 1..pieces.len() {
        let tl = pieces[i - 1].end_tangent(true);
        let dot = |m: bool| {
            let mut p = pieces[i].clone();
            p.mirror = m;
            p.end_tangent(false).dot(tl)
        };
        pieces[i].mirror = dot(true) > dot(false);
    }
}

/// `z₀` per piece: the first vertex at `z = 0`, then continuity in `z` at
/// each junction (Section 7).
fn z_offsets(pieces: &[Piece]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(pieces.len());
    for (i, p) in pieces.iter().enumerate() {
        let z_start = p.helix.point_3d(p.ts[0], p.mirror, 0.0).z;
        let target = if i == 0 {
            0.0
        } else {
            let l = &pieces[i - 1];
            l.helix
                .point_3d(l.ts[l.ts.len() - 1], l.mirror, out[i - 1])
                .z
        };
        out.push(target - z_start);
    }
    out
}

/// Least depth (beyond the paper): a flatter helix that draws `piece`'s
/// vertices as well, where the drawing does not show its depth; `sigma`
/// (the noise, 0 where the drawing was not denoised: its residuals are
/// then its bends) and `emax` in the units of `points`.
///
/// Why: a projection shows `b cos c` (the pitch across the page) and
/// `a sin c`, not always the depth. A straight stroke (`a → 0`) is drawn by
/// a line at any tilt, and a circle arc (`c → ±π/2`, the helix seen along
/// its axis) by a helix of any pitch; the fit's steps wander along that
/// valley (a 500-vertex stroke came back 0.03 of its length deep without
/// noise, 0.08–1.6 at 0.001–0.1 %; a 5-rad arc flat without noise,
/// 0.2–4 % with). Tried: the pitch dropped (`b → 0`, the arc's valley) and
/// the tilt (`c → 0` keeping `b cos c`, the stroke's), each refined with
/// the dropped parameter held; the flattest is taken that leaves the
/// vertices' sum of squared distances at most `max(σ, E_max/1000)² ln n`
/// above the piece's (the flat fit has one parameter fewer: the
/// information criterion of the merges), no vertex farther than the
/// piece's farthest or `E_max`, and is at most half as deep. The strokes
/// come back flat (under 1e-4 of their length deep). The noisy arcs tried
/// keep their pitch but at the heaviest noise (0.3 % of the length): held
/// flat, their denoised vertices sit further off than the criterion
/// allows (their fits' tilt is off `π/2` by 0.01–0.1 rad, where the pitch
/// shows; the denoising's bias, perhaps). On the benchmark's drawings
/// (`benches/sketch_noise.rs`, 1,840 lifts from no noise to 0.3 %, the one
/// curl among them) every lift came back the same.
fn flattened(points: &[DVec2], piece: &Piece, sigma: f64, emax: f64) -> Option<Piece> {
    let n = piece.ts.len();
    if n < 3 {
        return None;
    }
    let squares = |p: &Piece| p.rms_distance(points).powi(2) * n as f64;
    let room = squares(piece) + sigma.max(1e-3 * emax).powi(2) * (n as f64).ln();
    let slope = piece.depth_slope();
    let farthest = piece.max_distance(points).max(emax);
    let h = piece.helix.helix;
    let obj = Objective { alpha_t: 0.0, emax };
    let mut best: Option<(f64, Piece)> = None;
    // (`[θ, o_x, o_y, a, b, c]`: the pitch, then the tilt, held.)
    for (b, c, q) in [(0.0, h.c, 4), (h.b * h.c.cos(), 0.0, 5)] {
        let mut p = piece.clone();
        p.helix.helix = ProjectedHelix::new(h.a, b, c);
        p.reproject(points);
        let mut held = [false; PARAMS];
        held[q] = true;
        refine_holding(points, std::slice::from_mut(&mut p), &obj, 50, 1e-6, held);
        let s = p.depth_slope();
        let flatter = s < 0.5 * slope && best.as_ref().is_none_or(|(least, _)| s < *least);
        let within = p.max_distance(points) <= farthest;
        if flatter && within && squares(&p) <= room && plausible(&p) {
            best = Some((s, p));
        }
    }
    best.map(|(_, p)| p)
}

#[cfg(test)]
mod tests {
    use crate::euler::normalize_angle;
    use std::f64::consts::{PI, TAU};

    /// The lift reports its angles through `euler::normalize_angle`:
    /// within a turn, the same direction, whole turns taken off.
    #[test]
    fn angles_are_brought_within_a_turn_keeping_their_direction() {
        for k in -2000..=2000 {
            let angle = 0.0173 * k as f64;
            let a = normalize_angle(angle);
            assert!(a > -PI && a <= PI, "{angle} -> {a}");
            assert!((a.sin() - angle.sin()).abs() < 1e-13, "{angle} -> {a}");
            assert!((a.cos() - angle.cos()).abs() < 1e-13, "{angle} -> {a}");
            // Whole turns only.
            let turns = (angle - a) / TAU;
            assert!((turns - turns.round()).abs() < 1e-12, "{angle} -> {a}");
        }
        assert_eq!(normalize_angle(PI), PI);
        assert_eq!(normalize_angle(-PI), PI);
        assert_eq!(normalize_angle(0.5), 0.5);
    }
}
