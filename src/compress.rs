//! Compression of polylines into the `.sfh` container, curve by curve; the
//! method and its error budget are described on `compress_curve`.

use glam::DVec3;

use crate::adaptive::{
    chain_frechet, chain_within, fit_polyline_chain, AdaptiveError, AdaptiveOptions, Distance,
    ElementCount,
};
use crate::helix::PiecewiseHelix;
use crate::io::{encoded_size, QuantChain, Shape, Storage, StoredCurve};

/// Options of [`compress_curve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompressOptions {
    /// How many elements per curve.
    pub count: ElementCount,
    /// How the chain parameters are stored.
    pub storage: Storage,
    /// Share of the tolerance given to the fit; the rest is the
    /// quantisation's (compact storage only).
    pub fit_share: f64,
    /// Share of the fit's tolerance given to the Schneider smoothing spline.
    pub smoothing_share: f64,
    /// Cap on elements per curve.
    pub max_elements: usize,
    /// The distance the tolerance is measured in.
    pub distance: Distance,
}

impl CompressOptions {
    /// Options for `count` and `storage`, with the default shares, cap and distance.
    pub fn new(count: ElementCount, storage: Storage) -> Self {
        CompressOptions {
            count,
            storage,
            fit_share: 0.95,
            smoothing_share: 0.5,
            max_elements: 4096,
            distance: Distance::Ordered,
        }
    }

    fn tolerance(&self) -> Option<f64> {
        match self.count {
            ElementCount::Tolerance(t) => Some(t),
            _ => None,
        }
    }
}

/// What happened to one curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveOutcome {
    /// What is stored.
    pub shape: Shape,
    /// Distance (an upper bound, in the options' [`Distance`]) of what is
    /// stored, as decoded, to the input; 0 for verbatim curves.
    pub frechet: f64,
    /// Helix elements stored (0 for verbatim curves).
    pub elements: usize,
    /// Within the tolerance (always true without one).
    pub within: bool,
    /// Why the curve is stored verbatim, if it is.
    pub verbatim: Option<String>,
    /// Stored as its points because they take fewer bytes than its helices
    /// (sparse polylines at tight tolerances): exact, and never larger.
    pub points_cheaper: bool,
}

/// Compress one polyline (for the `.sfh` container; see
/// [Method](compress_curve#method)).
///
/// ```
/// use strandfit::io::{Shape, Storage};
/// use strandfit::{compress_curve, CompressOptions, DVec3, ElementCount};
///
/// let helix: Vec<DVec3> = (0..100)
///     .map(|k| { let s = k as f64 * 0.1; DVec3::new(3.0 * s.cos(), 3.0 * s.sin(), 0.8 * s) })
///     .collect();
/// let opts = CompressOptions::new(ElementCount::Tolerance(0.05), Storage::Compact);
/// let out = compress_curve(&helix, &opts);
/// assert!(out.within && out.frechet <= 0.05);
/// assert!(matches!(out.shape, Shape::Quantized(_)) && out.elements < 20);
/// // One point cannot be fitted: stored as it is, and said so.
/// let one = compress_curve(&[DVec3::ONE], &opts);
/// assert_eq!((one.shape, one.elements), (Shape::Points(vec![DVec3::ONE]), 0));
/// assert!(one.verbatim.is_some());
/// ```
///
/// # Method
///
/// Curve by curve: the adaptive fit
/// ([`fit_polyline_chain`](crate::fit_polyline_chain)) and, in compact storage,
/// the coarsest quantisation grids that keep the *decoded* chain within the
/// tolerance.
///
/// Error budget with a tolerance `T`: the fit aims at `fit_share · T` (default
/// 0.95: on the fornix at 0.5 mm, 0.8 gave 2,531 elements and 16.9 KB, 0.95
/// gave 2,235 and 14.5 KB — elements cost more than the finer grids the smaller
/// quantisation margin needs); the quantiser then takes the coarsest grids
/// `ΔL = 2^⌊log₂ T⌋ 2^{−p}`, `Δθ = 2^⌊log₂(T/S)⌋ 2^{−p}` (`S` the chain's
/// length: an angle error `Δθ` moves the far end by at most `SΔθ`) for
/// `p = 1, 2, …` whose decoded chain passes the same Fréchet test as the fit
/// against the input. So the quantisation error is inside the tolerance,
/// measured, not estimated; and drift along the chain is what the test sees, so
/// a long chain simply gets a finer grid.
///
/// Without a tolerance ([`ElementCount::Fixed`](crate::ElementCount::Fixed),
/// [`ElementCount::ElementLength`](crate::ElementCount::ElementLength)) the
/// compact grids are chosen to stay within `1.1 ×` the fit's own Fréchet
/// distance.
///
/// Curves that cannot be fitted are stored verbatim and reported: empty
/// curves, one-point curves (or all points equal), and any fit failure. In
/// compact storage a curve is also stored as its points (`f32`) when they
/// take fewer bytes than its helices: sparse polylines at a tolerance
/// below their corners' sagitta need about one element per point, and four
/// numbers per element then cost more than three per point. So the
/// container is never larger than the float32 polylines.
pub fn compress_curve(points: &[DVec3], opts: &CompressOptions) -> CurveOutcome {
    let tol = opts.tolerance();
    // Points are stored as f32 unless the container is f64: exact for
    // float32 sources, a measured rounding error for f64 ones (CSV, JSON).
    let rounding = if opts.storage == Storage::F64 {
        0.0
    } else {
        f32_rounding(points)
    };
    let as_points = |verbatim: Option<String>| CurveOutcome {
        shape: if points.is_empty() {
            Shape::Empty
        } else {
            Shape::Points(points.to_vec())
        },
        frechet: rounding,
        elements: 0,
        within: tol.is_none_or(|t| rounding <= t),
        points_cheaper: verbatim.is_none(),
        verbatim,
    };
    let verbatim = |why: String| as_points(Some(why));
    if points.is_empty() {
        return verbatim("empty curve".into());
    }
    let count = match tol {
        Some(t) if opts.storage == Storage::Compact => ElementCount::Tolerance(opts.fit_share * t),
        _ => opts.count,
    };
    let aopts = AdaptiveOptions {
        max_elements: opts.max_elements,
        distance: opts.distance,
        smoothing: tol.map(|t| opts.smoothing_share * opts.fit_share * t),
        ..AdaptiveOptions::new(count)
    };
    let fit = match fit_polyline_chain(points, &aopts) {
        Ok(f) => f,
        Err(AdaptiveError::Smoothing(e)) => return verbatim(format!("stored verbatim: {e}")),
        Err(e) => return verbatim(format!("stored verbatim: fit failed: {e}")),
    };
    let Some(params) = fit.chain.to_params() else {
        return verbatim("stored verbatim: empty chain".into());
    };
    let elements = params.elements.len();
    match opts.storage {
        Storage::F64 | Storage::F32 => {
            let (frechet, within) = if opts.storage == Storage::F32 {
                // f32 rounding: measure what will be decoded.
                let decoded = PiecewiseHelix::from_params(&round_f32(&params));
                let f = chain_frechet(&decoded, points, fit.frechet, opts.distance);
                let within = tol.is_none_or(|t| chain_within(&decoded, points, t, opts.distance));
                (f, within)
            } else {
                (fit.frechet, fit.within_tolerance)
            };
            CurveOutcome {
                within,
                shape: Shape::Chain(params),
                frechet,
                elements,
                verbatim: None,
                points_cheaper: false,
            }
        }
        Storage::Compact => {
            let budget = tol.unwrap_or(1.1 * fit.frechet).max(1e-300);
            let length = fit.chain.length().max(budget);
            let el = budget.log2().floor() as i32;
            let ea = (budget / length).log2().floor() as i32;
            for p in 1..=40 {
                let (len_exp, angle_exp) = (el - p, ea - p);
                if !(-60..=60).contains(&len_exp) || !(-60..=0).contains(&angle_exp) {
                    break;
                }
                let qc = QuantChain::quantize(&params, len_exp as i8, angle_exp as i8);
                let decoded = PiecewiseHelix::from_params(&qc.dequantize());
                if chain_within(&decoded, points, budget, opts.distance) {
                    let shape = Shape::Quantized(qc);
                    if cheaper_as_points(points, &shape) && rounding <= budget {
                        return as_points(None);
                    }
                    // Both are upper bounds on the distance: the estimate
                    // (1e-6 relative slack) and the budget the exact test
                    // just proved; report the smaller, so that a curve
                    // within the tolerance is never reported above it.
                    let frechet =
                        chain_frechet(&decoded, points, budget, opts.distance).min(budget);
                    return CurveOutcome {
                        // The test at `budget` (= the tolerance) passed.
                        within: true,
                        shape,
                        frechet,
                        elements,
                        verbatim: None,
                        points_cheaper: false,
                    };
                }
            }
            verbatim("stored verbatim: no quantisation grid met the tolerance".into())
        }
    }
}

/// Do the points (as `f32`, exact to the input's float32 data) take fewer
/// bytes than `shape`? Sizes before deflate, which treats both alike.
fn cheaper_as_points(points: &[DVec3], shape: &Shape) -> bool {
    let size = |shape: Shape| {
        encoded_size(
            &StoredCurve {
                id: None,
                source_points: 0,
                curve_data: Vec::new(),
                shape,
            },
            Storage::Compact,
        )
        .unwrap_or(usize::MAX)
    };
    size(Shape::Points(points.to_vec())) < size(shape.clone())
}

/// Largest distance between a point and its float32 rounding.
fn f32_rounding(points: &[DVec3]) -> f64 {
    points
        .iter()
        .map(|p| p.distance(p.as_vec3().as_dvec3()))
        .fold(0.0, f64::max)
}

fn round_f32(c: &crate::helix::ChainParams) -> crate::helix::ChainParams {
    let r = |x: f64| x as f32 as f64;
    let rv = |v: DVec3| DVec3::new(r(v.x), r(v.y), r(v.z));
    crate::helix::ChainParams {
        start: rv(c.start),
        tangent: rv(c.tangent),
        normal: rv(c.normal),
        elements: c
            .elements
            .iter()
            .map(|e| crate::helix::ElementParams {
                length: r(e.length),
                curvature: r(e.curvature),
                torsion: r(e.torsion),
                twist: r(e.twist),
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wavy(n: usize) -> Vec<DVec3> {
        (0..n)
            .map(|k| {
                let t = k as f64 * 0.3;
                DVec3::new(t, (0.7 * t).sin() * 2.0, (0.4 * t).cos())
            })
            .collect()
    }

    #[test]
    fn every_storage_meets_the_tolerance_as_decoded() {
        let pts = wavy(120);
        for storage in [Storage::F64, Storage::F32, Storage::Compact] {
            for t in [0.5, 0.1, 0.01] {
                let o = compress_curve(
                    &pts,
                    &CompressOptions::new(ElementCount::Tolerance(t), storage),
                );
                assert!(o.verbatim.is_none(), "{storage:?} {t}: {:?}", o.verbatim);
                let chain = match &o.shape {
                    Shape::Chain(c) => PiecewiseHelix::from_params(c),
                    Shape::Quantized(q) => PiecewiseHelix::from_params(&q.dequantize()),
                    s => panic!("{s:?}"),
                };
                // Independent check of the decoded chain: dense samples.
                let dense = chain.sample(20_000);
                let f = crate::metrics::ordered_distance(&pts, &dense, 1e-6).unwrap();
                assert!(
                    o.within && f <= t,
                    "{storage:?} T = {t}: {f} (reported {})",
                    o.frechet
                );
                assert!(
                    f <= o.frechet * (1.0 + 1e-6),
                    "reported {} below measured {f}",
                    o.frechet
                );
            }
        }
    }

    #[test]
    fn sparse_corners_at_a_tight_tolerance_are_cheaper_as_points() {
        // 12 points with sharp corners: at 1e-3 the helices need about an
        // element per point, four numbers against three.
        let pts: Vec<DVec3> = (0..12)
            .map(|k| {
                DVec3::new(
                    k as f64 * 5.0,
                    if k % 2 == 0 { 0.0 } else { 3.0 },
                    0.1 * k as f64,
                )
            })
            .collect();
        let o = compress_curve(
            &pts,
            &CompressOptions::new(ElementCount::Tolerance(1e-3), Storage::Compact),
        );
        assert!(o.points_cheaper, "{:?}", o.shape);
        assert_eq!(o.shape, Shape::Points(pts.clone()));
        // A smooth curve is not.
        let o = compress_curve(
            &wavy(120),
            &CompressOptions::new(ElementCount::Tolerance(0.1), Storage::Compact),
        );
        assert!(!o.points_cheaper && matches!(o.shape, Shape::Quantized(_)));
    }

    #[test]
    fn degenerate_curves_are_stored_verbatim_and_said_so() {
        let o = CompressOptions::new(ElementCount::Tolerance(0.1), Storage::Compact);
        let r = compress_curve(&[], &o);
        assert_eq!(r.shape, Shape::Empty);
        let p = DVec3::new(1.0, 2.0, 3.0);
        let r = compress_curve(&[p], &o);
        assert_eq!(r.shape, Shape::Points(vec![p]));
        assert!(r
            .verbatim
            .unwrap()
            .contains("fewer than two distinct points"));
        let r = compress_curve(&[p, p, p], &o);
        assert_eq!(r.shape, Shape::Points(vec![p, p, p]));
    }
}
