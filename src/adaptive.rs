//! Polylines → piecewise helices with the element count chosen per curve;
//! the pipeline, the check and the search are described on
//! `fit_polyline_chain`.

use glam::DVec3;

use crate::fit::{fit_spline_with, FitError, FitOptions, FitScratch};
use crate::helix::PiecewiseHelix;
use crate::metrics::{frechet_polyline, frechet_within, ordered_distance, ordered_within};
use crate::spline::{fit_polyline, PolylineFitError, SchneiderOptions};
use crate::spline::{BezierSpline, SplineError};

/// How many elements per curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ElementCount {
    /// Exactly `N`.
    Fixed(usize),
    /// `max(1, round(L/S))` for a curve of length `L`.
    ElementLength(f64),
    /// The fewest within this Fréchet distance of the input.
    Tolerance(f64),
}

/// How the distance between a chain and its input is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Distance {
    /// The input's points must lie within the tolerance of the chain, in
    /// order, the first and last at its ends
    /// ([`ordered_within`](crate::metrics::ordered_within)): the Fréchet
    /// distance with the input taken as its samples. The default.
    #[default]
    Ordered,
    /// The continuous Fréchet distance between the chain and the input
    /// polyline ([`frechet_within`](crate::metrics::frechet_within)). It
    /// also charges the input's own chords: on a bend of radius `R` sampled
    /// every `h`, no smooth curve gets closer than `h²/8R`.
    Frechet,
}

/// Options of [`fit_polyline_chain`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveOptions {
    /// How the element count is chosen.
    pub count: ElementCount,
    /// Schneider tolerance for the smoothing spline. Default: `T/2` with a
    /// tolerance (half the budget to smoothing, half to the helices),
    /// otherwise a tenth of the mean input step (a near-interpolation).
    pub smoothing: Option<f64>,
    /// Cap on `N` per curve.
    pub max_elements: usize,
    /// The distance the tolerance is measured in.
    pub distance: Distance,
    /// Passed to the floating tangents fit.
    pub fit: FitOptions,
}

impl AdaptiveOptions {
    /// Options for `count`, with the defaults of the fields.
    pub fn new(count: ElementCount) -> Self {
        AdaptiveOptions {
            count,
            smoothing: None,
            max_elements: 4096,
            distance: Distance::Ordered,
            fit: FitOptions::new(1),
        }
    }
}

/// One fitted curve.
#[derive(Clone, Debug)]
pub struct ChainFit {
    /// The fitted chain.
    pub chain: PiecewiseHelix,
    /// Upper bound on the continuous Fréchet distance between the chain and
    /// the input polyline (relative accuracy 1e-6 plus the sampling
    /// sagitta).
    pub frechet: f64,
    /// `false` only in tolerance mode when no `N ≤ max_elements` met it.
    pub within_tolerance: bool,
    /// Segments of the smoothing spline.
    pub spline_segments: usize,
    /// Floating-tangents fits run by the search.
    pub fits: usize,
}

/// Why a polyline could not be fitted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AdaptiveError {
    #[error("{0}")]
    /// The smoothing spline could not be fitted.
    Smoothing(#[from] PolylineFitError),
    #[error("smoothing spline: {0}")]
    /// The smoothing spline is invalid.
    Spline(#[from] SplineError),
    #[error("{0}")]
    /// The floating tangents fit failed.
    Fit(#[from] FitError),
    #[error("invalid option: {0}")]
    /// An option is out of range.
    Options(&'static str),
}

/// Fit one polyline (at least two distinct finite points).
///
/// ```
/// use strandfit::{fit_polyline_chain, AdaptiveOptions, DVec3, ElementCount};
///
/// // A helix sampled every 0.1 rad, fitted to 0.01 with as few elements as can.
/// let points: Vec<DVec3> = (0..100)
///     .map(|k| { let a = 0.1 * k as f64; DVec3::new(a.cos(), a.sin(), 0.2 * a) })
///     .collect();
/// let fit = fit_polyline_chain(&points, &AdaptiveOptions::new(ElementCount::Tolerance(0.01))).unwrap();
/// assert!(fit.within_tolerance && fit.frechet <= 0.01);
/// assert!(fit.chain.len() < 10);
/// ```
///
/// # Method
///
/// The element count is chosen per curve ([`ElementCount`]): fixed
/// (`--elements N` on the command line), by a target element length
/// (`--element-length S`) or by a tolerance (`--tolerance T`: the fewest
/// elements whose chain stays within `T` of the input, in the distance chosen
/// by [`Distance`]: by default the input's points must lie within `T` of the
/// chain in order, the Fréchet distance with the input taken as its samples;
/// optionally the continuous Fréchet distance between the chain and the input
/// polyline).
///
/// Pipeline per curve: Schneider smoothing to a G1 cubic spline
/// ([`spline::fit_polyline`](crate::spline::fit_polyline)), then the floating
/// tangents fit ([`fit_spline`](crate::fit_spline)) with `N` elements, then the
/// check of the chain against the *input* polyline — not against the spline, so
/// the smoothing error is inside the tolerance, not added to it.
///
/// The check samples the chain at arc step `h` with `κ_max h²/8 ≈ T/64`: a
/// curve of curvature at most `κ` is within its sagitta `κh²/8` of its
/// chords, so `d(chain, input) ≤ d(samples, input) + T/64` for either
/// distance, and the test is `d(samples, input) ≤ T − sagitta`. The
/// reported distance is that bound, never an underestimate.
///
/// Failure modes the floating tangents paper names, and what is done:
/// * too few elements on a long curve: the chain cuts corners. The search
///   raises `N` until the distance is met.
/// * on a short curve with many elements, the relaxation can move break
///   points past each other and the chain loops. An element whose chord
///   runs against the chord of the samples it was fitted to marks that `N`
///   as failed (`inverted`); a loop larger than the tolerance also fails
///   the Fréchet test, which forbids backtracking.
///
/// Search for the tolerance: `N = 1, 2, 4, …` until the test passes (or
/// `max_elements`), then an upward scan between the last failure and the
/// first pass. The distance is not monotone in `N` in general, so this finds
/// the smallest passing `N` above the last failing power of two. If no `N`
/// up to the cap passes, the best chain tried is returned with
pub fn fit_polyline_chain(
    points: &[DVec3],
    opts: &AdaptiveOptions,
) -> Result<ChainFit, AdaptiveError> {
    let tol = match opts.count {
        ElementCount::Tolerance(t) if !(t > 0.0 && t.is_finite()) => {
            return Err(AdaptiveError::Options(
                "tolerance must be positive and finite",
            ))
        }
        ElementCount::ElementLength(s) if !(s > 0.0 && s.is_finite()) => {
            return Err(AdaptiveError::Options(
                "element length must be positive and finite",
            ))
        }
        ElementCount::Fixed(0) => {
            return Err(AdaptiveError::Options("elements must be at least 1"))
        }
        ElementCount::Tolerance(t) => Some(t),
        _ => None,
    };
    if opts.max_elements == 0 {
        return Err(AdaptiveError::Options("max elements must be at least 1"));
    }
    let smoothing = match (opts.smoothing, tol) {
        (Some(s), _) => s,
        (None, Some(t)) => 0.5 * t,
        (None, None) => 0.1 * mean_step(points),
    };
    let cps = fit_polyline(points, &SchneiderOptions::new(smoothing))?;
    let spline = BezierSpline::from_control_points(&cps)?;
    let spline_segments = spline.num_segments();
    let mut scratch = FitScratch::default();
    let mut fit_n = |n: usize| {
        let o = FitOptions {
            elements: n,
            ..opts.fit
        };
        fit_spline_with(&spline, &o, &mut scratch)
    };
    let (chain, fits) = match opts.count {
        ElementCount::Fixed(n) => (fit_n(n.min(opts.max_elements))?, 1),
        ElementCount::ElementLength(s) => {
            let n = ((spline.length() / s).round() as usize).clamp(1, opts.max_elements);
            (fit_n(n)?, 1)
        }
        ElementCount::Tolerance(t) => {
            let mut fits = 0;
            let mut try_n = |n: usize| -> Option<(PiecewiseHelix, bool)> {
                fits += 1;
                let chain = fit_n(n).ok()?;
                let ok =
                    !inverted(&chain, &spline) && chain_within(&chain, points, t, opts.distance);
                Some((chain, ok))
            };
            // Exponential search for a passing N, keeping the last failure.
            let (mut lo, mut hi) = (0usize, 1usize);
            let mut best: Option<PiecewiseHelix> = None;
            let mut passed = None;
            loop {
                match try_n(hi) {
                    Some((chain, true)) => {
                        passed = Some(chain);
                        break;
                    }
                    Some((chain, false)) => best = Some(chain),
                    None => {}
                }
                if hi >= opts.max_elements {
                    break;
                }
                lo = hi;
                hi = (2 * hi).min(opts.max_elements);
            }
            match passed {
                Some(mut chain) => {
                    // The distance is not monotone in N (equal arc-length
                    // break points land well or badly on a curve's
                    // features), so bisection can skip a passing N: scan
                    // (lo, hi) upwards instead and take the first pass. At
                    // most as many fits as the exponential phase's last
                    // bracket; measured on the fornix at 0.1 mm, 10 % fewer
                    // elements than bisection.
                    for n in lo + 1..hi {
                        if let Some((c, true)) = try_n(n) {
                            chain = c;
                            break;
                        }
                    }
                    (chain, fits)
                }
                None => {
                    let chain = match best {
                        Some(c) => c,
                        // Every N failed to fit at all: report the last error.
                        None => fit_n(opts.max_elements)?,
                    };
                    let frechet = chain_frechet(&chain, points, smoothing, opts.distance);
                    return Ok(ChainFit {
                        chain,
                        frechet,
                        within_tolerance: false,
                        spline_segments,
                        fits,
                    });
                }
            }
        }
    };
    let frechet = chain_frechet(&chain, points, tol.unwrap_or(smoothing), opts.distance);
    Ok(ChainFit {
        frechet,
        // With a tolerance, reaching here means the search's test passed
        // (the reported bound may exceed it by its 1e-6 bisection slack).
        within_tolerance: true,
        chain,
        spline_segments,
        fits,
    })
}

/// Mean distance between consecutive distinct points.
fn mean_step(points: &[DVec3]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for w in points.windows(2) {
        let d = w[0].distance(w[1]);
        if d > 0.0 {
            sum += d;
            n += 1;
        }
    }
    if n == 0 {
        1.0
    } else {
        sum / n as f64
    }
}

/// Break points inverted by the relaxation: an element whose chord runs
/// against the chord between the spline samples it was made from,
/// `(p₁ − p₀)·(q₁ − q₀) ≤ 0`. Its short helix must turn back, a loop. (A
/// geometric test on the element alone, such as its chord against its end
/// tangents, would also flag faithful elements that turn by more than π.)
fn inverted(chain: &PiecewiseHelix, spline: &BezierSpline) -> bool {
    let Ok(q) = spline.sample_points(chain.len() + 1) else {
        return true;
    };
    chain
        .elements()
        .iter()
        .zip(q.windows(2))
        .any(|(e, w)| (e.end_point() - e.start).dot(w[1] - w[0]) <= 0.0)
}

/// Chain samples at an arc step whose sagitta is about `tol/64`, and that
/// sagitta (the one of the step taken, which may exceed `tol/64` a little:
/// `⌈L/h⌉` points for the step `h` of sagitta `tol/64` make `⌈L/h⌉ − 1`
/// steps, each a little longer than `h`; between `2N + 1` and `256N + 1`
/// points for `N` elements).
///
/// ```
/// use strandfit::{chain_samples, DVec3, HermitePair, PiecewiseHelix};
///
/// // A quarter circle of radius 1 about (0, 1, 0) as one element.
/// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
/// let chain = PiecewiseHelix::new(vec![pair.interpolate(1e-9).unwrap().element]);
/// let (samples, sagitta) = chain_samples(&chain, 1e-3);
/// assert_eq!(samples.len(), 141); // ⌈(π/2)/h⌉ for h = √(T/8κ) = 0.0112
/// let step = std::f64::consts::FRAC_PI_2 / 140.0;
/// assert!((sagitta - step * step / 8.0).abs() < 1e-15); // κ = 1
/// assert!(sagitta < 1.01 * 1e-3 / 64.0);
/// assert!(samples.iter().all(|p| (p.distance(DVec3::Y) - 1.0).abs() < 1e-12));
/// ```
pub fn chain_samples(chain: &PiecewiseHelix, tol: f64) -> (Vec<DVec3>, f64) {
    let kappa = chain
        .elements()
        .iter()
        .fold(0.0f64, |k, e| k.max(e.curvature.abs()));
    let length = chain.length();
    let n = chain.len().max(1);
    // κ h²/8 ≤ tol/64  ⇔  h ≤ √(tol/(8κ)).
    let h = if kappa > 0.0 {
        (tol / (8.0 * kappa)).sqrt()
    } else {
        length
    };
    let m = ((length / h).ceil() as usize).clamp(2 * n + 1, 256 * n + 1);
    let step = length / (m - 1) as f64;
    (chain.sample(m), kappa * step * step / 8.0)
}

/// `d(chain, input) ≤ tol`, conservatively: the chain is replaced by
/// samples whose chords are within their sagitta of it, and the test is run
/// at `tol − sagitta` (see [`fit_polyline_chain`], Method).
///
/// ```
/// use strandfit::chain_within;
/// use std::f64::consts::PI;
/// use strandfit::{DVec3, Distance, HermitePair, PiecewiseHelix};
///
/// // A quarter circle of radius 1 about (0, 1, 0) as one element, and
/// // points on the circle of radius 1.01.
/// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
/// let chain = PiecewiseHelix::new(vec![pair.interpolate(1e-9).unwrap().element]);
/// let input: Vec<DVec3> = (0..=10)
///     .map(|k| DVec3::Y + 1.01 * DVec3::new((k as f64 * 0.05 * PI).sin(), -(k as f64 * 0.05 * PI).cos(), 0.0))
///     .collect();
/// assert!(chain_within(&chain, &input, 0.011, Distance::Ordered));
/// assert!(!chain_within(&chain, &input, 0.009, Distance::Ordered));
/// ```
pub fn chain_within(chain: &PiecewiseHelix, input: &[DVec3], tol: f64, d: Distance) -> bool {
    let (s, sag) = chain_samples(chain, tol);
    tol > sag
        && match d {
            Distance::Ordered => ordered_within(input, &s, tol - sag),
            Distance::Frechet => frechet_within(&s, input, tol - sag),
        }
        .unwrap_or(false)
}

/// Upper bound on `d(chain, input)`, to 1e-6 relative plus the sampling
/// sagitta; `scale` (the tolerance, or the expected distance) sets the
/// sampling.
///
/// ```
/// use strandfit::chain_frechet;
/// use std::f64::consts::PI;
/// use strandfit::{DVec3, Distance, HermitePair, PiecewiseHelix};
///
/// // A quarter circle of radius 1 about (0, 1, 0) as one element, and
/// // points on the circle of radius 1.01.
/// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
/// let chain = PiecewiseHelix::new(vec![pair.interpolate(1e-9).unwrap().element]);
/// let input: Vec<DVec3> = (0..=10)
///     .map(|k| DVec3::Y + 1.01 * DVec3::new((k as f64 * 0.05 * PI).sin(), -(k as f64 * 0.05 * PI).cos(), 0.0))
///     .collect();
/// let d = chain_frechet(&chain, &input, 0.01, Distance::Frechet);
/// assert!(d >= 0.01 && d < 0.01 + 1e-3);
/// ```
pub fn chain_frechet(chain: &PiecewiseHelix, input: &[DVec3], scale: f64, d: Distance) -> f64 {
    let (s, sag) = chain_samples(chain, scale.max(1e-300));
    match d {
        Distance::Ordered => ordered_distance(input, &s, 1e-6),
        Distance::Frechet => frechet_polyline(&s, input, 1e-6),
    }
    .map_or(f64::INFINITY, |f| f + sag)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn helix_points(n: usize, turns: f64) -> Vec<DVec3> {
        (0..n)
            .map(|k| {
                let t = turns * std::f64::consts::TAU * k as f64 / (n - 1) as f64;
                DVec3::new(5.0 * t.cos(), 5.0 * t.sin(), 1.5 * t)
            })
            .collect()
    }

    #[test]
    fn tolerance_is_met_with_the_fewest_elements_found() {
        let pts = helix_points(120, 2.0);
        for t in [0.5, 0.1, 0.02] {
            let f = fit_polyline_chain(&pts, &AdaptiveOptions::new(ElementCount::Tolerance(t)))
                .unwrap();
            assert!(
                f.within_tolerance && f.frechet <= t,
                "T = {t}: {}",
                f.frechet
            );
            let n = f.chain.len();
            // One fewer must fail (monotone here), unless N = 1.
            if n > 1 {
                let o = AdaptiveOptions {
                    smoothing: Some(0.5 * t), // the spline the search used
                    ..AdaptiveOptions::new(ElementCount::Fixed(n - 1))
                };
                let g = fit_polyline_chain(&pts, &o).unwrap();
                assert!(
                    !chain_within(&g.chain, &pts, t, Distance::Ordered),
                    "T = {t}: N − 1 = {} also passes",
                    n - 1
                );
            }
        }
    }

    #[test]
    fn a_sampled_helix_needs_few_elements() {
        // The input is a helix; at a tolerance well above the chord sagitta
        // of its sampling, a handful of elements suffice.
        let pts = helix_points(200, 2.0);
        let f =
            fit_polyline_chain(&pts, &AdaptiveOptions::new(ElementCount::Tolerance(0.2))).unwrap();
        assert!(f.chain.len() <= 4, "{} elements", f.chain.len());
    }

    #[test]
    fn element_length_and_fixed() {
        let pts = helix_points(100, 1.0);
        let l: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
        let f = fit_polyline_chain(
            &pts,
            &AdaptiveOptions::new(ElementCount::ElementLength(l / 7.0)),
        )
        .unwrap();
        assert_eq!(f.chain.len(), 7);
        let f = fit_polyline_chain(&pts, &AdaptiveOptions::new(ElementCount::Fixed(5))).unwrap();
        assert_eq!(f.chain.len(), 5);
        assert!(f.within_tolerance);
    }

    #[test]
    fn unreachable_tolerance_is_reported_not_hidden() {
        // A zigzag of amplitude 1 cannot be followed within 1e-3 by 4 elements.
        let pts: Vec<DVec3> = (0..40)
            .map(|k| DVec3::new(k as f64, if k % 2 == 0 { 0.0 } else { 1.0 }, 0.0))
            .collect();
        let o = AdaptiveOptions {
            max_elements: 4,
            ..AdaptiveOptions::new(ElementCount::Tolerance(1e-3))
        };
        let f = fit_polyline_chain(&pts, &o).unwrap();
        assert!(!f.within_tolerance && f.frechet > 1e-3);
    }

    #[test]
    fn inversion_is_detected_against_the_samples() {
        let pts = helix_points(60, 1.5);
        let cps = fit_polyline(&pts, &SchneiderOptions::new(0.01)).unwrap();
        let spline = BezierSpline::from_control_points(&cps).unwrap();
        let chain = crate::fit::fit_spline(&spline, &FitOptions::new(5)).unwrap();
        // Elements of 108° each turn: a test on the element's own chord
        // and tangents would not tell this from a loop; the samples do.
        assert!(!inverted(&chain, &spline));
        let rev: Vec<DVec3> = cps.iter().rev().copied().collect();
        let back = BezierSpline::from_control_points(&rev).unwrap();
        assert!(inverted(&chain, &back));
    }

    #[test]
    fn bad_options_and_points() {
        let pts = helix_points(10, 0.5);
        for c in [
            ElementCount::Tolerance(0.0),
            ElementCount::Tolerance(f64::NAN),
            ElementCount::ElementLength(-1.0),
            ElementCount::Fixed(0),
        ] {
            assert!(matches!(
                fit_polyline_chain(&pts, &AdaptiveOptions::new(c)),
                Err(AdaptiveError::Options(_))
            ));
        }
        let o = AdaptiveOptions::new(ElementCount::Fixed(3));
        assert!(matches!(
            fit_polyline_chain(&[DVec3::ONE, DVec3::ONE], &o),
            Err(AdaptiveError::Smoothing(PolylineFitError::TooFewPoints(2)))
        ));
    }
}
