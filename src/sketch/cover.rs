//! Covering the sketch with projected helices (Sections 6.1–6.4); the
//! method is described on `cover`.

use std::f64::consts::FRAC_PI_4;

use glam::DVec2;
use rayon::prelude::*;

use super::estimate::is_corner;
use super::least_squares::{least_squares, LeastSquaresOptions};
use super::placed::{Evaluator, PlacedHelix};
use super::refine::{refine_to, Objective, Piece};
use super::trig::sin_cos;

/// The refinements of the covering stop once an iteration gains less than
/// this (relative): on a short stretch the fit crawls along a valley of
/// nearly equal helices, by ~1e-4 of `E` per iteration, for hundreds of
/// iterations that change no vertex by a visible fraction of `E_max`. The
/// fine fit of Section 7 converges fully afterwards.
pub const COVER_GAIN: f64 = 1e-6;

/// [`COVER_GAIN`] for a denoised drawing: no helix fits it closer than the
/// noise left, and the fits crawl towards their minimum for many more
/// iterations than on a clean drawing. Measured on the noisy drawings of
/// `benches/sketch_noise.rs` (40 at 0.1 % noise): the same helix counts
/// as with 1e-6, in half the time.
pub const NOISY_COVER_GAIN: f64 = 1e-3;

/// [`COVER_GAIN`] for a drawing denoised but fitted as clean (its noise
/// left under `NOISY_GAIN_ABOVE` of `E_max`, see `lift_sketch`): its fits
/// stop on the noise left, not on rounding, and at 1e-6 a fresh fit of a
/// piece crawled to its 100-iteration cap (a sixth of the refinements
/// of the two coils at 1e-5, two fifths of their time). Measured
/// 2026-11-30 (`benches/sketch_noise.rs`, 48 seeds, noise 1e-5 and 3e-5
/// of the length, 480 lifts): all 480 right before and after; mean time
/// a lift 11–32 % less (two coils 154 → 109 and 286 → 196 ms, four curls
/// 76 → 63 and 317 → 250 ms). Which lifts split a coil and need the
/// costly refit changes: of the first 16 seeds of the two coils at 1e-5,
/// four before and four others after, 140 → 164 ms there. The 320 at
/// 0–0.03 % noise: the same lifts.
pub const DENOISED_COVER_GAIN: f64 = 1e-4;

/// Whether a covering refined to `gain` is of a noisy drawing (its
/// several seeds, early restarts and no fresh refits): from
/// [`NOISY_COVER_GAIN`] up.
fn noisy_gain(gain: f64) -> bool {
    gain >= NOISY_COVER_GAIN
}

/// Refine one piece of the covering (see [`COVER_GAIN`]).
fn refine(points: &[DVec2], piece: &mut Piece, obj: &Objective, gain: f64, max_iterations: usize) {
    refine_to(
        points,
        std::slice::from_mut(piece),
        obj,
        max_iterations,
        gain,
    );
}
use super::ProjectedHelix;

/// The smallest number of vertices a helix is fitted to.
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
/// # /// The drawing scaled to unit length, and its tangents and curvatures.
/// # fn unit(d: &[DVec2]) -> (Vec<DVec2>, Vec<(DVec2, f64)>) {
/// #     let length: f64 = d.windows(2).map(|w| (w[1] - w[0]).length()).sum();
/// #     let unit: Vec<DVec2> = d.iter().map(|p| *p / length).collect();
/// #     let geometry = strandfit::sketch::tangents_and_curvatures(&unit, 3);
/// #     (unit, geometry)
/// # }
/// use strandfit::sketch::{cover, CoverOptions, COVER_GAIN, MIN_VERTICES};
///
/// // Every helix of a covering fits at least MIN_VERTICES vertices.
/// let (points, geometry) = unit(&two_helices());
/// let pieces = cover(&points, &geometry, &CoverOptions { emax: 1e-3, nmax: 12, end_guard: 3, gain: COVER_GAIN, noise: 0.0 });
/// assert!(pieces.iter().all(|p| p.last + 1 - p.first >= MIN_VERTICES));
/// ```
pub const MIN_VERTICES: usize = 4;

/// `β_D` of Section 6.2.
const BETA_D: f64 = 0.5;

/// Refinement rounds (refine, then extend) per candidate helix, and the
/// iteration cap of each refinement.
const GROW_ROUNDS: usize = 8;
const GROW_ITERATIONS: usize = 100;

/// Restarts of a refinement that leaves a vertex farther than
/// `HOP_BELOW · E_max`, from these multiples of the radius. Measured on the
/// four-curl drawings at 0.1 % noise (1,127 restarts, 2026-11-29): the best
/// of the radii 0.6, 0.8, 1.25 and 1.6 improved the piece by over 1 % 530
/// times, and was 0.6 or 1.6 in 445 of them. With those two alone the
/// benchmark's 480 drawings at 0.1 % and 0.3 % (`SKETCH_SEEDS=48`) came out
/// with the count and the depth right 389 times against 384 (8 drawings
/// gained, 3 lost), the 320 at lower noise 312 against 312, in 13–15 %
/// less time.
const HOP_BELOW: f64 = 1e-3;
const HOP_SCALES: [f64; 2] = [0.6, 1.6];

/// Where [`hop`]'s restarts from the radius leave a clean drawing's
/// piece in [`fit_at`]'s growth over this fraction of `E_max`, it is
/// restarted from the pitch scaled as well. A piece of an exact drawing
/// that is its helix fits to rounding; one stuck where a neighbouring
/// helix fits nearly as well stays at 0.2–0.5 `E_max`, and its growth
/// stops there: the covering then splits the helix, and the merge of the
/// parts gets stuck too. Measured 2026-11-30 on exact drawings turned
/// (the same drawing to the lift but for rounding): `lift_sketch`'s
/// example (43 vertices) lifted right at 46 → 60 of 60 angles; the
/// two-coil drawing of `benches/sketch_noise.rs` drawn with 60 vertices at
/// 5 → 19 of 24, with 120 at 0 → 11 of 24 (the curls' drawings the same);
/// the benchmark's 480 noisy drawings unchanged (noisy refinements do not
/// restart from the pitch), its 320 at 0–0.03 % noise 312 → 311 right
/// (two coils at 1e-5, one seed), in 0–15 % more time.
const PITCH_HOP_ABOVE: f64 = 0.1;

/// A merge of two pieces (or an absorption of the piece between two) is
/// pursued only if `MERGE_PROBE_ITERATIONS` iterations of the fit bring
/// every vertex within `MERGE_PROBE_LIMIT · E_max`.
const MERGE_PROBE_ITERATIONS: usize = 15;
/// Steps in which a piece is grown over its neighbour for a merge.
const MERGE_STEPS: usize = 3;
/// See [`MERGE_PROBE_ITERATIONS`]. The probes have mostly converged: on
/// the four curls at 0.1 % noise (16 drawings), 81 of 85 absorptions
/// probed passed a limit of 8 `E_max` to be refitted in full at 2.3–7.6
/// `E_max` (a whole curl between its neighbours), where the full fit
/// moved the worst vertex by at most a tenth, and the two accepted were
/// probed at 0.67 and 1.08. With 2 instead of 8, measured 2026-11-30 on
/// the benchmark's 480 noisy drawings (0.1 % and 0.3 %, 48 seeds): right
/// 461 → 462 (one lost, two gained), the four curls at 0.1 % 122 → 111
/// ms, three curls 96 → 89 ms, the two coils 34 → 30 ms; the 320 at
/// 0–0.03 % the same lifts.
const MERGE_PROBE_LIMIT: f64 = 2.0;

/// Beyond the paper, the bounds of a plausible helix on a drawing of unit
/// length: its radius at most `MAX_RADIUS` lengths, its depth slope
/// ([`Piece::depth_slope`]) at most `MAX_DEPTH_SLOPE` (the depth at most
/// three times the length drawn: 72° out of the plane on average; a curve
/// rising steadily at that slope is √10 ≈ 3.2 times as long in space as
/// drawn). On a noisy
/// drawing, where `E_max` is set above the noise, stretches are fitted
/// within `E_max` by helices of any size seen almost end-on (measured at
/// 0.1 % noise: radii to 175 lengths, depths to 4000 times the drawn
/// length); those are refused, so a stretch goes to a plausible helix or
/// to its neighbours. A drawing does not show such a depth: it is what the
/// noise leaves undetermined. The benchmark's drawings have slopes of
/// 0.25–0.39. Measured on `benches/sketch_noise.rs` (48 seeds at 0.1 % and
/// 0.3 %, 480 lifts; with [`stays_plausible`] and [`fit_one`]'s plausible
/// grid seed), against a bound of 10 (84°): the count and depth right
/// 394 → 417, lifts over 4× the exact depth 50 → 9, the deepest 27 → 7.5×,
/// the worst drawn vertex 22 → 8.7 σ; at 0 to 0.03 % (320 lifts) 311 →
/// 312. A bound of 2 made 426 right but one lift 1,500× too deep and
/// nine with a drawn vertex over 8 σ; 5 made 403.
const MAX_RADIUS: f64 = 10.0;
const MAX_DEPTH_SLOPE: f64 = 3.0;

/// Whether a piece is a helix a drawing of unit length can show (see
/// [`MAX_RADIUS`]).
pub(super) fn plausible(piece: &Piece) -> bool {
    piece.helix.helix.a.abs() <= MAX_RADIUS && piece.depth_slope() <= MAX_DEPTH_SLOPE
}

/// Whether `after`, a refit of a piece that `was` [`plausible`], is
/// plausible where that was: a step of the covering (a junction slide, an
/// absorption) may not make a plausible piece implausible. (A slide that
/// did left a piece the next take-over grew its neighbour over, beyond
/// `E_max`: three curls at 0.1 %, seed 9, came back as two helices with a
/// drawn vertex 18 σ off.)
fn stays_plausible(was: bool, after: &Piece) -> bool {
    !was || plausible(after)
}

/// Evaluations of a two-vertex fit's residuals ([`least_squares`]: a
/// Jacobian costs three, so about six steps). The paper fits these by
/// Nelder–Mead ([`minimize`](super::minimize)), which took up to 400
/// evaluations (85 % of the fits ran into that cap: where the two vertices
/// have no exact helix, the simplex creeps along a flat valley) and was a
/// fifth of a noisy lift. By Levenberg–Marquardt on the four residuals
/// (the position's two and the tangent's two), capped at 16, 30, 60, 100
/// or 200 evaluations, the benchmark's 480 lifts at 0.1 % and 0.3 % noise
/// (48 seeds, `benches/sketch_noise.rs`) were 463, 464, 464, 456 and 452
/// right against Nelder–Mead's 461, in 80, 77, 82, 86 and 89 % of its CPU
/// time. The fits only rank the candidates, which are then refined and
/// grown (`fit_at`); a few steps place them as well as a converged fit,
/// and the lifts that differ are the ones decided by last-bit rounding.
/// With 30: four curls on 144 seeds, 139 → 143 right at 0.1 % (86 → 69 ms
/// a lift) and 112 → 118 at 0.3 % (117 → 104 ms); the 400 lifts at 0 to
/// 0.03 % 398 → 398, the 960 at 1e-5 to 4.5e-5 all right as before.
const TWO_VERTEX_EVALS: usize = 30;

/// Starting tilts `c` of the two-vertex fits.
const START_TILTS: [f64; 3] = [0.0, 0.9, -0.9];

/// Candidates of the two-vertex fit that are refined and grown.
const REFINED_CANDIDATES: usize = 3;

/// [`REFINED_CANDIDATES`] on a denoised drawing, where [`fit_one`] tries
/// more seeds instead (measured on the noisy drawings of
/// `benches/sketch_noise.rs`, 80 at 0.1 %, with the seed search: 1
/// candidate lost two right helix counts; 2 kept them, 30 % faster than 3).
const NOISY_REFINED_CANDIDATES: usize = 2;

/// [`HOP_BELOW`] on a denoised drawing: no helix fits it closer than the
/// noise left, so a refinement is restarted only where its worst vertex
/// is over half `E_max` away (with 1e-3, every refinement was; measured
/// at 0.1 % noise with the seed search: 80 → 79 right helix counts of 80,
/// within the seeds' spread, 8 % less time).
const NOISY_HOP_BELOW: f64 = 0.5;

/// A piece of a denoised drawing is taken for the helix drawn where its
/// vertices' root-mean-square distance ([`Piece::rms_distance`]) is at
/// most this fraction of `E_max` (`E_max` is at least [`NOISE_FACTOR`]
/// times the noise drawn, and denoising leaves 0.25–0.65 of it): measured
/// at 0.1 % noise, the pieces that are the drawn helix lie at 0.02–0.08
/// `E_max`, those that only stay within `E_max` (a flat arc across a
/// near-cusp, a helix across a corner) at 0.2–0.4 (a few partly right
/// ones at 0.10–0.13).
///
/// [`NOISE_FACTOR`]: super::NOISE_FACTOR
const CONFIDENT_RMS: f64 = 0.12;

/// Seeds, evenly spread over the range, that [`fit_one`] tries on a
/// denoised drawing after the two curvature peaks where neither gave a
/// confident piece ([`CONFIDENT_RMS`]).
const SEED_GRID: usize = 3;

/// The [`SEED_GRID`] seeds spread evenly inside vertices `[lo, hi]`.
fn grid_seeds((lo, hi): (usize, usize)) -> impl Iterator<Item = usize> {
    (1..=SEED_GRID).map(move |k| lo + (hi - lo) * k / (SEED_GRID + 1))
}

/// Options of the covering.
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
/// # /// The drawing scaled to unit length, and its tangents and curvatures.
/// # fn unit(d: &[DVec2]) -> (Vec<DVec2>, Vec<(DVec2, f64)>) {
/// #     let length: f64 = d.windows(2).map(|w| (w[1] - w[0]).length()).sum();
/// #     let unit: Vec<DVec2> = d.iter().map(|p| *p / length).collect();
/// #     let geometry = strandfit::sketch::tangents_and_curvatures(&unit, 3);
/// #     (unit, geometry)
/// # }
/// use strandfit::sketch::{cover, CoverOptions, COVER_GAIN};
///
/// // One helix drawn: one piece, every vertex within E_max of it.
/// let (points, geometry) = unit(&one_helix());
/// let opts = CoverOptions { emax: 1e-3, nmax: 12, end_guard: 3, gain: COVER_GAIN, noise: 0.0 };
/// let pieces = cover(&points, &geometry, &opts);
/// assert_eq!(pieces.len(), 1);
/// assert_eq!((pieces[0].first, pieces[0].last), (0, 59));
/// assert!(pieces[0].max_distance(&points) <= opts.emax);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoverOptions {
    /// `E_max`, in the sketch's units.
    pub emax: f64,
    /// `NMAX`: neighbours of the seed tried on each side.
    pub nmax: usize,
    /// Vertices at either end of the sketch not taken as seeds.
    pub end_guard: usize,
    /// The covering's refinements stop once an iteration gains less than
    /// this, relative: [`COVER_GAIN`], [`DENOISED_COVER_GAIN`] for a
    /// drawing denoised but fitted as clean, or [`NOISY_COVER_GAIN`] for a
    /// noisy one (the covering treats the drawing as noisy from
    /// [`NOISY_COVER_GAIN`] up).
    pub gain: f64,
    /// The noise of the drawing before it was denoised (standard deviation
    /// per coordinate, in the sketch's units), or 0 where it was not: on a
    /// drawing denoised but fitted as clean, the RMS distance under which
    /// a piece is not refitted (see `refit_unconfident`).
    pub noise: f64,
}

/// Parameter of the vertex after `t` along the walk direction `dir` (±1):
/// a Gauss–Newton guess from the previous foot, then Newton.
fn next_parameter(h: &Evaluator, v: DVec2, t: f64) -> f64 {
    let (p, d1, _) = h.jet(t);
    let speed2 = d1.length_squared();
    let guess = if speed2 > 0.0 {
        t + ((v - p).dot(d1) / speed2).clamp(-1.0, 1.0)
    } else {
        t
    };
    h.closest_parameter(v, guess)
}

/// Parameter steps (radians) of [`forward_parameter`]'s scan.
const FORWARD_STEPS: usize = 16;

/// The parameter of the point nearest `v` among those ahead of `t` (in the
/// direction `ahead`, ±1) by at most one radian: the best of a scan of
/// [`FORWARD_STEPS`] samples, polished by Newton; `None` where the polish
/// ends behind `t`.
fn forward_parameter(h: &Evaluator, v: DVec2, t: f64, ahead: f64) -> Option<f64> {
    let step = ahead / FORWARD_STEPS as f64;
    let best = (1..=FORWARD_STEPS)
        .map(|k| t + step * k as f64)
        .min_by(|&a, &b| {
            (h.jet(a).0 - v)
                .length_squared()
                .total_cmp(&(h.jet(b).0 - v).length_squared())
        })?;
    let f = h.closest_parameter(v, best);
    ((f - t) * ahead > 0.0).then_some(f)
}

/// Walk from vertex `from` (parameter `t_from`) in direction `dir` within
/// `[lo, hi]` while vertices stay within `emax` and parameters keep
/// moving the same way (`t` runs along the sketch if `orient > 0`,
/// against it otherwise). The accepted parameters, in walk order.
#[allow(clippy::too_many_arguments)]
fn walk(
    h: &PlacedHelix,
    points: &[DVec2],
    from: usize,
    t_from: f64,
    dir: isize,
    orient: f64,
    (lo, hi): (usize, usize),
    emax: f64,
) -> Vec<f64> {
    let mut out = Vec::new();
    let mut t = t_from;
    let mut i = from as isize + dir;
    let h = h.evaluator();
    while i >= lo as isize && i <= hi as isize {
        let v = points[i as usize];
        let mut tn = next_parameter(&h, v, t);
        let ahead = dir as f64 * orient;
        if (tn - t) * ahead <= 0.0 {
            // A foot behind the last one: the helix turns back, or the
            // vertex is nearer the branch the walk came by (at a near-cusp
            // of the projection under noise), or (on a noisy drawing,
            // where noise along the stroke is a good part of an edge) it
            // lies a little behind its predecessor. The nearest foot ahead
            // is taken where it is within E_max; else the walk goes on
            // from the last foot, if near enough.
            match forward_parameter(&h, v, t, ahead).filter(|&f| (h.jet(f).0 - v).length() <= emax)
            {
                Some(f) => tn = f,
                None => {
                    if (h.jet(tn).0 - h.jet(t).0).length() > emax {
                        break;
                    }
                    tn = t;
                }
            }
        }
        if (h.jet(tn).0 - v).length() > emax {
            break;
        }
        out.push(tn);
        t = tn;
        i += dir;
    }
    out
}

/// The piece `h` covers around vertex `s` (parameter `ts`).
fn coverage(
    h: &PlacedHelix,
    points: &[DVec2],
    s: usize,
    ts: f64,
    range: (usize, usize),
    emax: f64,
) -> Piece {
    // Does t run along the sketch here?
    let ahead = points[(s + 1).min(range.1)] - points[s.saturating_sub(1).max(range.0)];
    let orient = if h.derivative(ts).dot(ahead) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let back = walk(h, points, s, ts, -1, orient, range, emax);
    let fwd = walk(h, points, s, ts, 1, orient, range, emax);
    let mut params: Vec<f64> = back.iter().rev().copied().collect();
    params.push(ts);
    params.extend(&fwd);
    Piece {
        helix: *h,
        first: s - back.len(),
        last: s + fwd.len(),
        ts: params,
        mirror: false,
    }
}

/// Extend `piece` by walking on from both of its ends.
fn extend(piece: &mut Piece, points: &[DVec2], range: (usize, usize), emax: f64) -> bool {
    let h = piece.helix;
    let orient = piece.orientation();
    let back = walk(
        &h,
        points,
        piece.first,
        piece.ts[0],
        -1,
        orient,
        range,
        emax,
    );
    let fwd = walk(
        &h,
        points,
        piece.last,
        piece.ts[piece.ts.len() - 1],
        1,
        orient,
        range,
        emax,
    );
    if back.is_empty() && fwd.is_empty() {
        return false;
    }
    let mut ts: Vec<f64> = back.iter().rev().copied().collect();
    ts.extend(&piece.ts);
    ts.extend(&fwd);
    piece.first -= back.len();
    piece.last += fwd.len();
    piece.ts = ts;
    true
}

/// Whether a corner lies within `w` vertices of `i`.
fn near_corner(points: &[DVec2], i: usize, w: usize) -> bool {
    (i.saturating_sub(w)..=(i + w).min(points.len() - 1)).any(|j| is_corner(points, j))
}

/// The seed of a helix on vertices `[lo, hi]`: the largest curvature (the
/// paper), away from the sketch's ends where the estimator's window is
/// one-sided (and the ends of a drawn stroke hook) unless the range has
/// nothing else. Beyond the paper: away from corners of the drawing too,
/// where the estimated curvature peaks but no helix goes on (a seed there
/// covers a few vertices and leaves a sliver); and at a local maximum of
/// `|κ|` within `±guard`, in the whole drawing rather than the range (the
/// flank of a peak just outside the range is no seed either; Proposition 1
/// puts `t = 0` at a peak). The flank of a peak excluded as a corner has a
/// large `|κ|` too, but the two-vertex fit's `t = 0` is wrong there and its
/// helices fit a short arc only (measured: a 1000-vertex drawing of two
/// helices was first covered by nine pieces, and took 450 ms instead of
/// 50 ms).
fn seed_vertex(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    (lo, hi): (usize, usize),
    guard: usize,
) -> usize {
    let n = points.len();
    let curvature = |i: usize| geometry[i].1.abs();
    let by_curvature = |&i: &usize, &j: &usize| curvature(i).total_cmp(&curvature(j));
    let inner = lo.max(guard)..=hi.min(n.saturating_sub(1 + guard));
    let local_max = |i: usize| {
        (i.saturating_sub(guard)..=(i + guard).min(n - 1)).all(|j| curvature(j) <= curvature(i))
    };
    // The corner test (a sort per vertex around) only at local maxima.
    let smooth = |i: &usize| !near_corner(points, *i, guard);
    inner
        .clone()
        .filter(|i| local_max(*i) && smooth(i))
        .max_by(by_curvature)
        .or_else(|| inner.clone().filter(smooth).max_by(by_curvature))
        .or_else(|| inner.max_by(by_curvature))
        .or_else(|| (lo..=hi).max_by(by_curvature))
        .unwrap_or(lo)
}

/// Sections 6.1–6.3 on vertices `[lo, hi]`, then refinement and growth,
/// from the seed [`seed_vertex`] picks (and, on a noisy drawing, from
/// more seeds, see below). `fits` keeps the fits made so far.
fn fit_one(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    (lo, hi): (usize, usize),
    opts: &CoverOptions,
    fits: &SeedFits,
) -> Piece {
    let s = seed_vertex(points, geometry, (lo, hi), opts.end_guard);
    if !noisy_gain(opts.gain) {
        return fit_at(points, geometry, (lo, hi), opts, s, fits);
    }
    // A denoised drawing: its largest curvature can be a near-cusp blurred
    // by the noise, whose two-vertex fits are the noise's, and a helix
    // grown from a seed on a flat stretch can stay within E_max as a flat
    // arc, or run past a corner, and stop there. Where the piece is not
    // confident (CONFIDENT_RMS), the next-highest peak of |κ| at least
    // 2·NMAX vertices away is tried (the better of the two kept:
    // plausible, confident, covering most, in that order), then
    // SEED_GRID seeds spread over the range until one gives a confident
    // piece, which is then taken. A grid seed's piece that is not
    // confident is not taken: at 0.3 % noise, taking the longest made the
    // depth wild (9× the exact's). Measured by benches/sketch_noise.rs
    // (16 seeds of its five drawings, 80 lifts a level; before → after):
    // right helix count at 0.1 % 75 → 77, at 0.2 % 67 → 70, at 0.3 %
    // 66 → 74; depth within 2× 76 → 77, 69 → 65, 57 → 58; at 0.01 % and
    // 0.03 %: 79 → 79, 78 → 76 counts; mean time at 0.1 % 93 → 74 ms.
    // But a plausible grid seed's piece replaces an implausible best (an
    // implausible piece is the worst answer; the rest of the covering
    // would grow a neighbour over it: three curls at 0.1 %, seed 9, then
    // came back right, where it had been two helices with a drawn vertex
    // 18 σ off; over the 480 noisy drawings 414 → 417 right). And a
    // plausible grid seed's piece that covers at least as many vertices
    // as the best and fits them closer in RMS replaces it: a piece
    // across a near-cusp that is a deeper helix than drawn (or a flat arc)
    // stays within E_max, but leaves an RMS well above the noise, where
    // the drawn helix, found from a seed on its other side, leaves the
    // noise and covers more (three curls, the third curl: 0.32 against
    // 0.12 E_max, 134 against 176 vertices). Measured 2026-11-30 on the
    // benchmark's 480 noisy drawings: 417 → 443 right (35 gained, 9 lost;
    // three curls at 0.3 % 27 → 41, two coils at 0.3 % 38 → 44, four
    // curls at 0.1 % 40 → 44), lifts over 4× the exact depth 9 → 5, and
    // 10 % less CPU time (fewer pieces to merge); the 320 at lower noise
    // 311 → 310. With the least-squares steps' coarser projections
    // (`Evaluator::project_all_coarse`), 450 right and 312: alone, those
    // had made three curls at 0.1 % 46 → 42, the flat-arc test's seeds 7
    // and 9 four helices.
    let n = points.len();
    let guard = opts.end_guard;
    let curvature = |i: usize| geometry[i].1.abs();
    let second = (lo.max(guard)..=hi.min(n.saturating_sub(1 + guard)))
        .filter(|&i| i.abs_diff(s) > 2 * opts.nmax)
        .filter(|&i| {
            (i.saturating_sub(guard)..=(i + guard).min(n - 1)).all(|j| curvature(j) <= curvature(i))
        })
        .max_by(|&a, &b| curvature(a).total_cmp(&curvature(b)));
    // (plausible, confident, vertices covered), measured once a piece.
    // (and the RMS distance it rests on, kept for the grid's comparison).
    let rank = |p: &Piece| {
        let rms = p.rms_distance(points);
        (
            (
                plausible(p),
                rms <= CONFIDENT_RMS * opts.emax,
                p.last - p.first,
            ),
            rms,
        )
    };
    let settled = |r: &(bool, bool, usize)| r.0 && r.1;
    let grid = (hi - lo > 4 * MIN_VERTICES)
        .then(|| grid_seeds((lo, hi)))
        .into_iter()
        .flatten();
    let mut best = fit_at(points, geometry, (lo, hi), opts, s, fits);
    let (mut best_rank, mut best_rms) = rank(&best);
    if let (Some(second), false) = (second, settled(&best_rank)) {
        let other = fit_at(points, geometry, (lo, hi), opts, second, fits);
        let (other_rank, other_rms) = rank(&other);
        if other_rank > best_rank {
            (best, best_rank, best_rms) = (other, other_rank, other_rms);
        }
    }
    for seed in grid {
        if settled(&best_rank) {
            break;
        }
        let other = fit_at(points, geometry, (lo, hi), opts, seed, fits);
        let (other_rank, other_rms) = rank(&other);
        // A plausible grid piece that covers at least as much as the best
        // and fits it closer (in RMS) replaces it, confident or not.
        let dominates = other_rank.0 && other_rank.2 >= best_rank.2 && other_rms < best_rms;
        if settled(&other_rank) || (other_rank.0 && !best_rank.0) || dominates {
            (best, best_rank, best_rms) = (other, other_rank, other_rms);
        }
    }
    best
}

/// [`fit_one`] from seed vertex `s`.
fn fit_at(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    (lo, hi): (usize, usize),
    opts: &CoverOptions,
    s: usize,
    fits: &SeedFits,
) -> Piece {
    let first_n = s.saturating_sub(opts.nmax).max(lo);
    let last_n = (s + opts.nmax).min(hi);
    if let Some(piece) = fits.get(s, (first_n, last_n), (lo, hi)) {
        return piece;
    }
    let (tangent, kappa) = geometry[s];
    // 6.1: R(θ) takes +y to T̂_{v_s}; reflect if the sketch turns right.
    let base = PlacedHelix {
        helix: ProjectedHelix::new(0.0, 0.0, 0.0),
        theta: (-tangent.x).atan2(tangent.y),
        origin: points[s],
        reflect: kappa < 0.0,
    };
    let fit_options = LeastSquaresOptions {
        max_evals: TWO_VERTEX_EVALS,
        ..Default::default()
    };
    // The neighbours' fits are independent: in parallel, collected in
    // neighbour order.
    let candidates: Vec<(usize, f64, Piece)> = (first_n..=last_n)
        .into_par_iter()
        .filter(|&n| n != s)
        .flat_map_iter(|n| {
            let v = base.to_local(points[n]);
            let tn = base.to_local(points[s] + geometry[n].0);
            let alpha = if n > s { FRAC_PI_4 } else { -FRAC_PI_4 };
            let scale2 = v.length_squared();
            // Start from c = 0, where H(α) = (a(cos α − 1), bα).
            let floor = 0.05 * scale2.sqrt();
            let a0 = (v.x / (alpha.cos() - 1.0)).max(floor);
            let b0 = (v.y / alpha).max(floor);
            // The sines and cosines that do not change from one evaluation
            // to the next, once (each evaluation then takes one `sin_cos`,
            // of the tilt, where it took six; the same values, so the same
            // fits).
            let (at_0, at_alpha, at_minus_alpha) =
                (0f64.sin_cos(), alpha.sin_cos(), (-alpha).sin_cos());
            let e = move |x: &[f64; 3]| {
                let h = ProjectedHelix::new(x[0].abs(), x[1].abs(), x[2]);
                let tilt = sin_cos(h.c);
                // Along the sketch, t runs one way or the other: compare
                // tangents up to that sign (fixed at t = 0 by T̂_H(0) = ±y).
                let lead = h.derivative_trig(at_0, tilt).y.signum();
                let tangent = h
                    .derivative_trig(at_alpha, tilt)
                    .try_normalize()
                    .unwrap_or(DVec2::ZERO)
                    * lead;
                let t = alpha * lead;
                let at_t = if lead == 1.0 {
                    at_alpha
                } else if lead == -1.0 {
                    at_minus_alpha
                } else {
                    t.sin_cos()
                };
                let p = h.point_3d_trig(t, at_t, tilt);
                let (wp, wt) = ((BETA_D / scale2).sqrt(), (1.0 - BETA_D).sqrt());
                let (dp, dt) = (v - DVec2::new(p.x, p.y), tn - tangent);
                [wp * dp.x, wp * dp.y, wt * dt.x, wt * dt.y]
            };
            // Several starting tilts: the two-vertex problem has several
            // minima (a loop or not at the seed, the axis towards or away).
            let tilts = if scale2 > 0.0 { &START_TILTS[..] } else { &[] };
            tilts.iter().map(move |&c0| {
                let m = least_squares(e, [a0, b0, c0], &fit_options);
                let mut h = base;
                h.helix = ProjectedHelix::new(m.x[0].abs(), m.x[1].abs(), m.x[2]);
                let piece = coverage(&h, points, s, 0.0, (lo, hi), opts.emax);
                (piece.last - piece.first, m.value, piece)
            })
        })
        .collect();
    // The paper keeps the candidate covering most vertices. Beyond the
    // paper: the best few are refined on the vertices they cover and the
    // walk resumed, repeatedly; the refined piece covering most wins (a
    // refinement can stop in a local minimum — the distance to a curve
    // that loops has many — so one start is not enough).
    // Implausible candidates last (they are grown only where nothing else
    // is left).
    // (Each candidate's plausibility once: it measures every vertex.)
    let mut candidates: Vec<(bool, (usize, f64, Piece))> = candidates
        .into_iter()
        .map(|c| (plausible(&c.2), c))
        .collect();
    candidates.sort_by(|(px, x), (py, y)| py.cmp(px).then(y.0.cmp(&x.0)).then(x.1.total_cmp(&y.1)));
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    // How far the walks went: a fit that stayed clear of the range's ends
    // is the same in any range around it (see SeedFits).
    let mut reach = candidates
        .iter()
        .fold((s, s), |(f, l), (_, c)| (f.min(c.2.first), l.max(c.2.last)));
    let refined = if noisy_gain(opts.gain) {
        NOISY_REFINED_CANDIDATES
    } else {
        REFINED_CANDIDATES
    };
    // The three tilts' fits from one neighbour often reach the same
    // minimum (to rounding): of the candidates taken, each helix is grown
    // once, a copy dropped, not replaced. A copy grown again only repeated
    // the work (its growth ends alike); replaced by the next distinct
    // candidate, the 480 noisy lifts were 459 right against 463.
    // Measured (48 seeds a drawing): the 960 lifts at 1e-5–4.5e-5 noise
    // the same, 20–50 % faster (three curls 47–54 → 27–33 ms, four curls
    // 53–66 → 42–44 ms); the 400 at 0–0.03 % the same; the 480 at 0.1 %
    // and 0.3 % 463 → 465 right (one lost, three gained), as fast (their
    // two candidates grow in parallel).
    let same = |x: &Piece, y: &Piece| {
        let (hx, hy) = (x.helix.helix, y.helix.helix);
        let close = |u: f64, v: f64| (u - v).abs() <= 1e-6 * (u.abs() + v.abs()) + 1e-12;
        x.first == y.first
            && x.last == y.last
            && close(hx.a, hy.a)
            && close(hx.b, hy.b)
            && close(hx.c, hy.c)
    };
    let mut distinct: Vec<(bool, (usize, f64, Piece))> = Vec::with_capacity(refined);
    for c in candidates.into_iter().take(refined) {
        if !distinct.iter().any(|d| same(&d.1 .2, &c.1 .2)) {
            distinct.push(c);
        }
    }
    let grown: Vec<Piece> = distinct
        .into_par_iter()
        .map(|(_, (_, _, mut piece))| {
            for _ in 0..GROW_ROUNDS {
                if piece.ts.len() >= 3 {
                    refine(points, &mut piece, &obj, opts.gain, GROW_ITERATIONS);
                    hop(points, &mut piece, &obj, opts.gain, true);
                }
                if !extend(&mut piece, points, (lo, hi), opts.emax) {
                    break;
                }
            }
            piece
        })
        .collect();
    for p in &grown {
        reach = (reach.0.min(p.first), reach.1.max(p.last));
    }
    // In candidate order, so the result does not depend on the threads.
    let mut best: Option<Piece> = None;
    for piece in grown {
        let better = best.as_ref().is_none_or(|b| {
            let (nb, np) = (b.last - b.first, piece.last - piece.first);
            let (ob, op) = (plausible(b), plausible(&piece));
            op && !ob
                || op == ob
                    && (np > nb || np == nb && piece.max_distance(points) < b.max_distance(points))
        });
        if better {
            best = Some(piece);
        }
    }
    // A range of one vertex cannot happen (callers pass ≥ 2).
    let piece = best.unwrap_or(Piece {
        helix: base,
        first: s,
        last: s,
        ts: vec![0.0],
        mirror: false,
    });
    fits.keep(s, (first_n, last_n), (lo, hi), reach, &piece);
    piece
}

/// The fits [`fit_at`] has made in one covering, for reuse. The covering
/// fits a seed in a range, then recurses into the ranges left on either
/// side, where (on a noisy drawing, [`fit_one`] trying several seeds) the
/// same seed often comes up again. A fit depends on its range only through
/// the neighbours of the seed it takes (clamped to the range) and through
/// the walks, which stop at the range's ends; where the neighbours are the
/// same and every walk of the first fit stopped short of the ends of both
/// its range and the new one (each walk then stopped where the drawing
/// left the helix), the fit in the new range is the same, and it is not
/// made again (measured at 0.1 % noise: a fifth of the fits; results
/// unchanged).
#[derive(Default)]
struct SeedFits(std::sync::Mutex<Vec<SeedFit>>);

/// One fit of [`SeedFits`].
struct SeedFit {
    seed: usize,
    /// First and last neighbour of the two-vertex fits.
    neighbours: (usize, usize),
    /// The range it was fitted in.
    range: (usize, usize),
    /// The first and last vertex any of its walks took.
    reach: (usize, usize),
    piece: Piece,
}

impl SeedFits {
    /// The fit from `seed` with these `neighbours`, if one was made whose
    /// walks all stopped inside both its range and `(lo, hi)`.
    fn get(
        &self,
        seed: usize,
        neighbours: (usize, usize),
        (lo, hi): (usize, usize),
    ) -> Option<Piece> {
        let fits = self.0.lock().unwrap_or_else(|e| e.into_inner());
        fits.iter()
            .find(|f| {
                let inside = |(a, b): (usize, usize)| f.reach.0 > a && f.reach.1 < b;
                f.seed == seed && f.neighbours == neighbours && inside(f.range) && inside((lo, hi))
            })
            .map(|f| f.piece.clone())
    }

    /// The fits kept from seeds strictly inside `(first, last)`, in the
    /// order made, each helix once and none that is `except`.
    fn seeded_inside(&self, (first, last): (usize, usize), except: &PlacedHelix) -> Vec<Piece> {
        let fits = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let mut found: Vec<Piece> = Vec::new();
        for f in fits.iter().filter(|f| f.seed > first && f.seed < last) {
            let new = f.piece.helix != *except && found.iter().all(|p| p.helix != f.piece.helix);
            if new {
                found.push(f.piece.clone());
            }
        }
        found
    }

    fn keep(
        &self,
        seed: usize,
        neighbours: (usize, usize),
        range: (usize, usize),
        reach: (usize, usize),
        piece: &Piece,
    ) {
        let mut fits = self.0.lock().unwrap_or_else(|e| e.into_inner());
        fits.push(SeedFit {
            seed,
            neighbours,
            range,
            reach,
            piece: piece.clone(),
        });
    }
}

/// Where a refinement stops short of fitting its vertices (a local
/// minimum: over a short arc many helices fit nearly as well, and the one
/// reached need not extend), restart it from the radius scaled by each of
/// [`HOP_SCALES`] and keep the best. With `pitch`, on a clean drawing
/// (refinements run to [`COVER_GAIN`]), a piece still over
/// [`PITCH_HOP_ABOVE`] `· E_max` is restarted from its pitch `b` scaled
/// the same ways too.
fn hop(points: &[DVec2], piece: &mut Piece, obj: &Objective, gain: f64, pitch: bool) {
    let noisy = noisy_gain(gain);
    let below = if noisy { NOISY_HOP_BELOW } else { HOP_BELOW };
    if piece.max_distance(points) <= below * obj.emax {
        return;
    }
    // Indices in `from_params`' [θ, oₓ, o_y, a, b, c]. Both restarts
    // from where the refinement stopped.
    const RADIUS: usize = 3;
    const PITCH: usize = 4;
    let start = piece.clone();
    restart(points, &start, piece, obj, gain, RADIUS);
    if pitch && !noisy && piece.max_distance(points) > PITCH_HOP_ABOVE * obj.emax {
        restart(points, &start, piece, obj, gain, PITCH);
    }
}

/// [`hop`]'s restarts from `start` with parameter `param` scaled by each
/// of [`HOP_SCALES`]: the best kept, if better than `piece`.
fn restart(
    points: &[DVec2],
    start: &Piece,
    piece: &mut Piece,
    obj: &Objective,
    gain: f64,
    param: usize,
) {
    let cost = |p: &Piece| distance_cost(points, p, obj);
    let mut best_cost = cost(piece);
    // The restarts are independent: in parallel, kept in scale order.
    let trials: Vec<(f64, Piece)> = HOP_SCALES
        .into_par_iter()
        .map(|scale| {
            let mut trial = start.clone();
            let mut p = trial.helix.params();
            p[param] *= scale;
            trial.helix = PlacedHelix::from_params(&p, trial.helix.reflect);
            trial.reproject(points);
            refine(points, &mut trial, obj, gain, GROW_ITERATIONS);
            (cost(&trial), trial)
        })
        .collect();
    for (c, trial) in trials {
        if c < best_cost {
            best_cost = c;
            *piece = trial;
        }
    }
}

/// Force `piece` to span `[first, last]`, projecting the new vertices.
fn stretch(piece: &mut Piece, points: &[DVec2], first: usize, last: usize) {
    let e = piece.helix.evaluator();
    let orient = piece.orientation();
    // As in the walk: a foot behind its predecessor (a loop of the
    // projection crossed, a near-cusp under noise, or noise along the
    // stroke) is taken at the nearest point ahead, or else stays at the
    // predecessor's parameter, for the fit to move on from.
    let next = |v: DVec2, t0: f64, ahead: f64| {
        let t = next_parameter(&e, v, t0);
        if (t - t0) * ahead > 0.0 {
            t
        } else {
            forward_parameter(&e, v, t0, ahead).unwrap_or(t0)
        }
    };
    while piece.first > first {
        piece.first -= 1;
        let t = next(points[piece.first], piece.ts[0], -orient);
        piece.ts.insert(0, t);
    }
    while piece.last < last {
        piece.last += 1;
        let t = next(points[piece.last], piece.ts[piece.ts.len() - 1], orient);
        piece.ts.push(t);
    }
}

/// Make `piece` span exactly `[first, last]`: dropping vertices it no
/// longer covers, projecting new ones.
fn set_range(piece: &mut Piece, points: &[DVec2], first: usize, last: usize) {
    if piece.first < first {
        piece.ts.drain(..first - piece.first);
        piece.first = first;
    }
    if piece.last > last {
        piece.ts.truncate(piece.ts.len() - (piece.last - last));
        piece.last = last;
    }
    stretch(piece, points, first, last);
}

/// `left` and `right` made to meet at each vertex `j` of `meetings` (each
/// keeping its far end), refitted with `iterations`, and the sum of their
/// `E_D`; in the order of `meetings`.
///
/// The two sides of a meeting are independent fits: they run as tasks of
/// their own, `2·|meetings|` of them, which two threads share more evenly
/// than one task a meeting (the same fits either way).
fn meet_all(
    points: &[DVec2],
    left: &Piece,
    right: &Piece,
    meetings: &[usize],
    obj: &Objective,
    gain: f64,
    iterations: usize,
) -> Vec<(f64, Piece, Piece)> {
    let sides: Vec<(f64, Piece)> = (0..2 * meetings.len())
        .into_par_iter()
        .map(|k| {
            let j = meetings[k / 2];
            let mut p = if k % 2 == 0 {
                let mut l = left.clone();
                set_range(&mut l, points, left.first, j);
                l
            } else {
                let mut r = right.clone();
                set_range(&mut r, points, j, right.last);
                r
            };
            refine(points, &mut p, obj, gain, iterations);
            (distance_cost(points, &p, obj), p)
        })
        .collect();
    // In pairs again: each meeting's left side, then its right.
    let mut sides = sides.into_iter();
    std::iter::from_fn(|| Some((sides.next()?, sides.next()?)))
        .map(|((cl, l), (cr, r))| (cl + cr, l, r))
        .collect()
}

/// `E_D` of one piece: `Σ (d / E_max)²` over its vertices.
fn distance_cost(points: &[DVec2], piece: &Piece, obj: &Objective) -> f64 {
    super::refine::objective(points, std::slice::from_ref(piece), obj)
}

/// Half-width of the junction search of [`polish_junctions`].
const JUNCTION_WINDOW: usize = 3;

/// Beyond the paper: slide each junction vertex to where its two helices,
/// refitted, leave the least `E_D` (searching `±JUNCTION_WINDOW` vertices,
/// and on while the best lies at the window's edge). The coverage walk
/// stops where the *next* vertex leaves `E_max`, so a helix can take a
/// vertex or two of its neighbour's (or stop that short of the corner
/// between them); least squares over both pieces puts the junction where
/// the two helices explain the drawing best — at the corner, for the
/// projection of two helices meeting there. Returns whether any moved.
fn polish_junctions(points: &[DVec2], pieces: &mut [Piece], opts: &CoverOptions) -> bool {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let mut moved = false;
    for i in 1..pieces.len() {
        if pieces[i - 1].last != pieces[i].first {
            continue;
        }
        for _ in 0..8 {
            let (left, right) = (&pieces[i - 1], &pieces[i]);
            let j0 = left.last;
            let lo = (left.first + MIN_VERTICES - 1).max(j0.saturating_sub(JUNCTION_WINDOW));
            let hi = right
                .last
                .saturating_sub(MIN_VERTICES - 1)
                .min(j0 + JUNCTION_WINDOW);
            let window: Vec<usize> = (lo..=hi).collect();
            let met = meet_all(
                points,
                left,
                right,
                &window,
                &obj,
                opts.gain,
                POLISH_ITERATIONS,
            );
            let trials: Vec<(f64, usize, Piece, Piece)> = met
                .into_iter()
                .zip(window)
                .map(|((score, l, r), j)| (score, j, l, r))
                .collect();
            // The least score (ties to the earlier junction) whose pieces
            // stay plausible: plausibility, which measures every vertex,
            // asked best first, only until one passes.
            let was = (plausible(left), plausible(right));
            let mut trials = trials;
            trials.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            let best = trials
                .into_iter()
                .find(|(_, _, l, r)| stays_plausible(was.0, l) && stays_plausible(was.1, r));
            let Some((_, j, l, r)) = best else { break };
            let edge = j != j0 && (j == lo || j == hi);
            pieces[i - 1] = l;
            pieces[i] = r;
            moved |= j != j0;
            if !edge {
                break;
            }
        }
    }
    moved
}

/// Iteration cap of the refinements of [`polish_junctions`] (warm starts).
const POLISH_ITERATIONS: usize = 30;

/// Cover all the vertices of `points` (Section 6.4; `geometry`: their
/// tangents and curvatures,
/// [`tangents_and_curvatures`](super::tangents_and_curvatures)); pieces in
/// order along the sketch, consecutive ones sharing their junction vertex.
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
/// # /// The drawing scaled to unit length, and its tangents and curvatures.
/// # fn unit(d: &[DVec2]) -> (Vec<DVec2>, Vec<(DVec2, f64)>) {
/// #     let length: f64 = d.windows(2).map(|w| (w[1] - w[0]).length()).sum();
/// #     let unit: Vec<DVec2> = d.iter().map(|p| *p / length).collect();
/// #     let geometry = strandfit::sketch::tangents_and_curvatures(&unit, 3);
/// #     (unit, geometry)
/// # }
/// use strandfit::sketch::{cover, CoverOptions, COVER_GAIN};
///
/// // Two helices drawn: two pieces, joined at the corner, each within E_max.
/// let (points, geometry) = unit(&two_helices());
/// let opts = CoverOptions { emax: 1e-3, nmax: 12, end_guard: 3, gain: COVER_GAIN, noise: 0.0 };
/// let pieces = cover(&points, &geometry, &opts);
/// let spans: Vec<_> = pieces.iter().map(|p| (p.first, p.last)).collect();
/// assert_eq!(spans, [(0, 24), (24, 42)]);
/// assert!(pieces.iter().all(|p| p.max_distance(&points) <= opts.emax));
/// ```
///
/// # Method
///
/// Covering the sketch with projected helices (Sections 6.1–6.4).
///
/// One helix, around the vertex `v_s` of largest curvature (Proposition 1
/// puts `t = 0` there):
/// 1. **Alignment (6.1).** The helix frame at `t = 0` has its `y` axis along
///    `T̂_H(0)` and the curve bending towards `−x` (`H″(0) = (−a, 0)`); the
///    sketch is put in that frame by the translation to `v_s`, the rotation
///    taking `T̂_{v_s}` to `+y`, and a reflection if the sketch turns right
///    at `v_s`.
/// 2. **Two-vertex fit (6.2).** For each of the `2·NMAX` neighbours `v_n`,
///    `(a, b, c)` minimising
///    `E = β_D ‖v_n − H(α)‖²/‖v_n‖² + (1 − β_D) ‖T̂_{v_n} − T̂_H(α)‖²`
///    (the paper by Nelder–Mead; here by Levenberg–Marquardt on its four
///    residuals, see [`TWO_VERTEX_EVALS`]), `α = ±π/4` (the sign of the
///    side of `v_n`). The paper
///    leaves `β_D` open and its point term has units; dividing by `‖v_n‖²`
///    makes the fit scale-free, `β_D = ½`. Helices whose tangent at `t = 0`
///    points along `−y` are rejected (a penalty), as are `a, b < 0` (the
///    search runs on `|a|`, `|b|`).
/// 3. **Coverage (6.3).** Walk from `v_s` both ways while each vertex is
///    within `E_max` of the curve (its closest point, followed from the
///    previous vertex's parameter). The paper compares the *squared*
///    distance with a length (0.1 % of the curve length); we compare the
///    distance, which is what a threshold in length units means. The
///    candidate covering most vertices wins.
///
/// Beyond the paper, the winner is then refined by least squares on the
/// vertices it covers ([`refine`](super::refine()), placement included) and
/// the walk resumed from its ends, until the coverage stops growing: the
/// two-vertex fit fixes `t = 0` at a vertex, which is exact only where the
/// sketch's curvature maximum falls on a vertex.
///
/// **Several helices (6.4).** The parts left on either side are covered
/// recursively (each from its own largest-curvature vertex), each new helix
/// sharing the junction vertex with its neighbour. A leftover of fewer than
/// [`MIN_VERTICES`] vertices is absorbed by the helix next to it.
///
/// **Segmentation (beyond the paper).** A walk stops where the *next*
/// vertex leaves `E_max`, so a helix can end a vertex or two off the
/// true junction, or stop short inside its own stretch (a local minimum of
/// the fit). After the covering, in passes until the count of pieces
/// stops dropping: each junction is slid to where its two helices, refitted,
/// leave the least `E_D` (`polish_junctions`); neighbours that one helix
/// fits within `E_max` are merged; a piece whose neighbours can meet inside
/// it is absorbed. Measured on projections of 2–4 helices with a corner at
/// each join: every junction at the corner vertex, none spurious
/// (`tests/sketch.rs`).
///
/// The two sides of a seed's helix, the two-vertex fits, the candidates'
/// refinements and their restarts, and the junction trials run in parallel
/// (rayon); choices are made in a fixed order, so the result does not
/// depend on the number of threads. Merges and absorptions are first
/// probed cheaply (a few iterations, or the neighbours extended without a
/// refit): most neighbours are different helices, and the full fits with
/// their restarts are kept for the pairs that come close.
pub fn cover(points: &[DVec2], geometry: &[(DVec2, f64)], opts: &CoverOptions) -> Vec<Piece> {
    cover_probed(points, geometry, opts, &Probes::default())
}

/// [`cover()`], keeping its merge and absorption probes in `probes` (for
/// [`merge_noisy`] to reuse).
pub(super) fn cover_probed(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    opts: &CoverOptions,
    probes: &Probes,
) -> Vec<Piece> {
    let mut out = if points.len() >= 2 {
        cover_range(points, geometry, (0, points.len() - 1), opts, &probes.fits)
    } else {
        Vec::new()
    };
    out.sort_by_key(|p| p.first);
    // Beyond the paper: slivers absorbed, then junctions put where the two
    // helices fit best, neighbours one helix fits merged, slivers absorbed;
    // again while the number of pieces drops. Slivers go first because a
    // junction slide beside one (a walk stopped a vertex or two short of a
    // corner) grows it, the slides going on while the best lies at the
    // window's edge, into a piece across the corner that neither helix
    // fits (measured 2026-11-29: on the benchmark's 480 drawings at 0.1 %
    // and 0.3 % noise the count and the depth right on 394 against 389, 9
    // gained and 4 lost, among the gains four curls of 3.3–5.6× the exact
    // depth brought within 2×; the 320 at lower noise 311 against 312).
    absorb(points, &mut out, opts, probes);
    post_passes(points, &mut out, opts, probes);
    // A piece that fits its vertices worse than the drawn helix would is
    // fitted again (see `refit_unconfident`); on a clean drawing from
    // fresh seeds too, and the passes run again where one changed.
    let noisy = noisy_gain(opts.gain);
    let fresh = (!noisy).then_some(geometry);
    if refit_unconfident(points, &mut out, opts, &probes.fits, fresh) && !noisy {
        post_passes(points, &mut out, opts, probes);
    }
    out
}

/// The covering's passes after its first pieces (see [`cover_probed`]):
/// junctions put where the two helices fit best, neighbours one helix
/// fits merged, slivers absorbed, implausible pieces taken over; again
/// while the number of pieces drops, at most [`POST_PASSES`] times.
fn post_passes(points: &[DVec2], out: &mut Vec<Piece>, opts: &CoverOptions, probes: &Probes) {
    for _ in 0..POST_PASSES {
        polish_junctions(points, out, opts);
        let before = out.len();
        merge(points, out, opts, probes);
        absorb(points, out, opts, probes);
        take_over_implausible(points, out, opts);
        if out.len() == before {
            break;
        }
    }
}

/// [`refit_unconfident`]'s bar on a clean drawing, a fraction of `E_max`
/// (RMS distance): there the helix drawn fits its vertices to rounding.
/// On exact drawings turned (24 angles), coarsely sampled: the two coils
/// at 100 vertices 0 → 24 lifted right, at 120 9 → 24, three curls at 60
/// 18 → 24, at 80 3 → 21; the 320 benchmark lifts at 0–0.03 % noise 313 →
/// 317 (the two coils at 1e-5, denoised but fitted as clean, 12 → 16 of
/// 16). 0.001 also set the two coils at 60 vertices right (19 → 24), but
/// refitted every piece of the drawings at 1e-5 noise (their noise left
/// is over it): 4–8× the time there.
///
/// On a drawing denoised but fitted as clean, the bar is the drawn noise
/// where that is higher ([`CoverOptions::noise`]): the denoised vertices
/// lie 0.25–0.65 σ from the curve drawn ([`denoise`](super::denoise)), so
/// the helix drawn leaves about that, and a piece within σ is not refitted.
/// At 3e-5 of the length (σ = 0.03 `E_max`) every piece's RMS was
/// 0.014–0.023 `E_max`, over 0.01: each was refitted from fresh seeds, to
/// the same RMS in four digits, and the passes run again (3–5× the lift's
/// time). Measured on 48 seeds of the five drawings at 1e-5, 2e-5, 3e-5
/// and 4.5e-5: 960 of 960 right before and after; mean time at 3e-5 two
/// coils 202 → 94 ms, three curls 220 → 51, four curls 246 → 56. There
/// the RMS is taken without `end_guard` vertices at each end: the piece
/// of the two coils' first coil ended on the denoised corner's vertex, at
/// 0.3 `E_max`, which alone set its RMS to 0.017 `E_max` (0.007 without
/// it) at 1e-5, and it was refitted to the same helix every time.
const CLEAN_REFIT_RMS: f64 = 0.01;

/// `trial` refitted over vertices `[first, last]` ([`refit_unconfident`]'s
/// trials): refined and restarted where stuck ([`hop`]); with its RMS
/// distance where it is plausible and within `E_max`, else `None`.
fn refit_over(
    points: &[DVec2],
    mut trial: Piece,
    (first, last): (usize, usize),
    opts: &CoverOptions,
    obj: &Objective,
) -> Option<(f64, Piece)> {
    set_range(&mut trial, points, first, last);
    refine(points, &mut trial, obj, opts.gain, GROW_ITERATIONS);
    hop(points, &mut trial, obj, opts.gain, false);
    let fits = plausible(&trial) && trial.max_distance(points) <= opts.emax;
    fits.then(|| (trial.rms_distance(points), trial))
}

/// Fresh fits ([`fit_at`]) over `range` from [`SEED_GRID`] seeds spread
/// over it, each refitted over it ([`refit_over`]), one after the other
/// until one is `settled` (each fit is parallel within): the trials made,
/// in seed order, a settled one last.
fn grid_trials(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    (first, last): (usize, usize),
    opts: &CoverOptions,
    fits: &SeedFits,
    settled: impl Fn(&Piece) -> bool,
) -> Vec<(f64, Piece)> {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let mut trials = Vec::new();
    for seed in grid_seeds((first, last)) {
        let fresh = fit_at(points, geometry, (first, last), opts, seed, fits);
        if let Some(trial) = refit_over(points, fresh, (first, last), opts, &obj) {
            let done = settled(&trial.1);
            trials.push(trial);
            if done {
                break;
            }
        }
    }
    trials
}

/// Beyond the paper: a piece whose RMS distance is over [`CONFIDENT_RMS`]
/// `· E_max` on a denoised drawing ([`CLEAN_REFIT_RMS`] on a clean one)
/// stays within `E_max` but need not be the helix drawn. Across the
/// near-cusp of a curl seen nearly edge-on, a deeper helix than drawn (depth slope 1.1–1.8 against 0.4) fits the
/// curl's vertices within `E_max` at 0.15–0.19 `E_max` RMS; the covering
/// took it when it grew from the curl's largest curvature, and no later
/// pass moved it (the merges and junction slides refit from the pieces'
/// own helices). The helix drawn, at 0.07–0.08, was often among the fits
/// the covering made from other seeds in that stretch and did not take
/// (they covered less of it at the time). So each such piece is refitted
/// over its vertices from every fit kept in [`SeedFits`] whose seed lies
/// inside it: grown to the whole piece, refined and restarted where stuck
/// ([`hop`]); the fit with the least RMS distance replaces the piece where
/// it is plausible, within `E_max`, and closer than the piece.
///
/// Measured on the 480 noisy drawings of `benches/sketch_noise.rs`
/// (0.1 % and 0.3 %, 48 seeds): 450 → 458 right (10 gained, 2 lost); at
/// 0.1 % three curls 46 → 48, four curls 44 → 47; the 320 at 0–0.03 %
/// 312 → 313 (none lost); 5 % more CPU. Fresh fits from four seeds spread
/// over the piece instead ([`fit_at`] each) gained 13 and lost 4, at 19 %
/// more CPU; refitting again after [`merge_noisy`] changed no lift.
///
/// On a clean drawing (`fresh`, its geometry) the covering grew one seed
/// per stretch, so few fits are kept: the piece is also fitted afresh
/// ([`fit_at`]) from [`SEED_GRID`] seeds spread over it (the kept fits
/// alone set the two coils at 100 vertices right at 13 angles of 24, not
/// 24). Returns whether a piece changed.
fn refit_unconfident(
    points: &[DVec2],
    pieces: &mut Vec<Piece>,
    opts: &CoverOptions,
    fits: &SeedFits,
    fresh: Option<&[(DVec2, f64)]>,
) -> bool {
    let bar = if fresh.is_some() {
        (CLEAN_REFIT_RMS * opts.emax).max(opts.noise)
    } else {
        CONFIDENT_RMS * opts.emax
    };
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let skip = if fresh.is_some() && opts.noise > 0.0 {
        opts.end_guard
    } else {
        0
    };
    // On a denoised drawing, judged without the vertices a rounded corner
    // at either end may have moved (see CLEAN_REFIT_RMS).
    let settled = |p: &Piece| p.inner_rms_distance(points, skip) <= bar;
    // Two unconfident neighbours on a denoised drawing fitted as clean are
    // first fitted as one from fresh seeds over both, one after the other
    // until one is under the bar (then it replaces them). Where the
    // covering split a coil into two poor pieces (the two coils at
    // 1e-5–4.5e-5 noise, a quarter of the lifts), each piece's own fresh
    // fits could not follow the coil past its end, and one of them at
    // times none under the bar at all (three fits for nothing); the
    // merges joined them afterwards. Measured on the 960 lifts at
    // 1e-5–4.5e-5 (48 seeds, run back to back): all right before and
    // after, the two coils 64–68 → 46–57 ms, the curls as fast.
    let mut united = false;
    if let (Some(geometry), true) = (fresh, opts.noise > 0.0) {
        let mut i = 1;
        while i < pieces.len() {
            let (l, r) = (&pieces[i - 1], &pieces[i]);
            if l.last != r.first || settled(l) || settled(r) {
                i += 1;
                continue;
            }
            let range = (l.first, r.last);
            let found = grid_trials(points, geometry, range, opts, fits, settled)
                .pop()
                .filter(|(_, trial)| settled(trial));
            if let Some((_, trial)) = found {
                pieces.splice(i - 1..=i, [trial]);
                united = true;
            }
            i += 1;
        }
    }
    // The pieces in parallel, and in each the fresh fits and the trials:
    // each piece is refitted over its own vertices from seeds strictly
    // inside it, so no piece's fits are another's starts, and the result
    // does not depend on the threads. (Refitting the pieces one after the
    // other, with the fresh fits made one by one, left a thread idle: a
    // clean drawing's refits took 300–450 ms of a 400–550 ms lift where
    // its covering had split a helix.)
    let changed: Vec<bool> = pieces
        .par_iter_mut()
        .map(|piece| {
            if settled(piece) {
                return false;
            }
            let rms = piece.rms_distance(points);
            let (first, last) = (piece.first, piece.last);
            let starts = fits.seeded_inside((first, last), &piece.helix);
            // Kept in start order.
            let mut trials: Vec<(f64, Piece)> = starts
                .into_par_iter()
                .filter_map(|trial| refit_over(points, trial, (first, last), opts, &obj))
                .collect();
            // On a clean drawing the covering fitted one seed per stretch,
            // so few fits are kept: fresh ones from the seed grid as well,
            // one after the other until a trial is under the bar (each fit
            // is parallel within; the first grid seed's was under it in
            // most of the two coils' split coils at 1e-5–4.5e-5 noise).
            if let Some(geometry) = fresh {
                if last - first > 4 * MIN_VERTICES && !trials.iter().any(|(_, t)| settled(t)) {
                    let range = (first, last);
                    trials.extend(grid_trials(points, geometry, range, opts, fits, settled));
                }
            }
            let mut best = rms;
            let mut changed = false;
            for (r, trial) in trials {
                if r < best {
                    best = r;
                    *piece = trial;
                    changed = true;
                }
            }
            changed
        })
        .collect();
    united || changed.contains(&true)
}

/// Passes of junction polishing, merging and absorption.
const POST_PASSES: usize = 4;

/// Beyond the paper: a piece that is no plausible helix ([`plausible`];
/// on a noisy drawing, where the covering found nothing better for a
/// stretch) is taken over by the neighbour that, grown over it and
/// refitted, stays plausible and fits it best, even beyond `E_max`: a
/// drawing with a few vertices farther off is a better answer than a helix
/// seen end-on. Pieces without a neighbour are kept.
fn take_over_implausible(points: &[DVec2], pieces: &mut Vec<Piece>, opts: &CoverOptions) {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let mut i = 0;
    while i < pieces.len() {
        if plausible(&pieces[i]) || pieces.len() < 2 {
            i += 1;
            continue;
        }
        let (first, last) = (pieces[i].first, pieces[i].last);
        let sides: Vec<usize> = [i.checked_sub(1), Some(i + 1)]
            .into_iter()
            .flatten()
            .filter(|&j| j < pieces.len())
            .collect();
        let trials: Vec<(f64, usize, Piece)> = sides
            .into_par_iter()
            .filter_map(|j| {
                let mut trial = pieces[j].clone();
                let (f, l) = (trial.first.min(first), trial.last.max(last));
                stretch(&mut trial, points, f, l);
                refine(points, &mut trial, &obj, opts.gain, GROW_ITERATIONS);
                hop(points, &mut trial, &obj, opts.gain, false);
                plausible(&trial).then(|| (trial.max_distance(points), j, trial))
            })
            .collect();
        match trials
            .into_iter()
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
        {
            Some((_, j, merged)) => {
                pieces[j] = merged;
                pieces.remove(i);
                i = i.saturating_sub(1);
            }
            None => i += 1,
        }
    }
}

/// Beyond the paper: a piece between two others is dropped if its
/// neighbours, extended to meet at one of its vertices, fit within `E_max`
/// (the meeting vertex with the smallest worst distance is kept). A walk
/// that stops a few vertices short of a true junction leaves such a
/// sliver, and a sliver is a spurious junction.
fn absorb(points: &[DVec2], pieces: &mut Vec<Piece>, opts: &CoverOptions, probes: &Probes) {
    absorb_while(points, pieces, opts, probes, |_, l, r| {
        let d = l.max_distance(points).max(r.max_distance(points));
        (d <= opts.emax).then_some(d)
    });
}

/// Drop the piece between neighbours `i − 1` and `i + 1` where
/// `accept(trio, left, right)` scores the neighbours grown to meet inside
/// it (the lower the better; `None`: refused), until none is dropped.
fn absorb_while(
    points: &[DVec2],
    pieces: &mut Vec<Piece>,
    opts: &CoverOptions,
    probes: &Probes,
    accept: impl Fn(&[Piece], &Piece, &Piece) -> Option<f64>,
) {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let mut i = 1;
    while i + 1 < pieces.len() {
        let trio = &pieces[i - 1..=i + 1];
        let fitted = probes.absorbed(trio, || absorb_fit(points, trio, opts, &obj));
        let best = fitted
            .filter(|(l, r)| {
                stays_plausible(plausible(&trio[0]), l) && stays_plausible(plausible(&trio[2]), r)
            })
            .and_then(|(l, r)| accept(trio, &l, &r).map(|score| (score, l, r)));
        match best {
            Some((_, l, r)) => {
                pieces[i - 1] = l;
                pieces[i + 1] = r;
                pieces.remove(i);
            }
            None => i += 1,
        }
    }
}

/// The neighbours of `trio[1]` grown to meet inside it and refitted, for
/// [`absorb_while`] to judge; `None` where they stay far off.
fn absorb_fit(
    points: &[DVec2],
    trio: &[Piece],
    opts: &CoverOptions,
    obj: &Objective,
) -> Option<(Piece, Piece)> {
    let (left, mid, right) = (&trio[0], &trio[1], &trio[2]);
    if left.last != mid.first || mid.last != right.first {
        return None;
    }
    let meetings = meeting_candidates(mid.first, mid.last);
    // Neighbours that are other helices than the piece between them,
    // extended over it as they are, leave it far off; a sliver's
    // neighbours, extended over its few vertices, nearly fit them. Only
    // where one meeting vertex keeps both extensions within
    // `ABSORB_REACH · E_max` are the (costly) refitted probes run.
    let reach = |&j: &usize| {
        let mut l = left.clone();
        set_range(&mut l, points, left.first, j);
        let mut r = right.clone();
        set_range(&mut r, points, j, right.last);
        l.max_distance(points).max(r.max_distance(points))
    };
    if !meetings
        .iter()
        .any(|j| reach(j) <= ABSORB_REACH * opts.emax)
    {
        return None;
    }
    // A short probe at every meeting vertex, the full fit at the best one
    // only.
    // `left` ends and `right` starts inside `mid`: both grow.
    let (_, mut l, mut r) = meet_all(
        points,
        left,
        right,
        &meetings,
        obj,
        opts.gain,
        MERGE_PROBE_ITERATIONS,
    )
    .into_iter()
    .min_by(|x, y| x.0.total_cmp(&y.0))?;
    // Neighbours that are other helices stay far off.
    if l.max_distance(points).max(r.max_distance(points)) > MERGE_PROBE_LIMIT * opts.emax {
        return None;
    }
    rayon::join(
        || refine(points, &mut l, obj, opts.gain, GROW_ITERATIONS),
        || refine(points, &mut r, obj, opts.gain, GROW_ITERATIONS),
    );
    Some((l, r))
}

/// See [`absorb`]: wide, as the extensions are not refitted (an
/// absorption accepted measured 5.9 `E_max` here).
const ABSORB_REACH: f64 = 16.0;

/// Where two pieces may be made to meet inside `[first, last]`: every
/// vertex of a short range, five spread over a long one (the junction
/// is then placed exactly by [`polish_junctions`]). Nine until
/// 2026-11-30: with five, the benchmark's 480 noisy drawings came out
/// right 462 → 463 times (one lost, two gained; seven: 464, two lost),
/// the 320 at 0–0.03 % noise 318 → 319, and the four curls at 0.1 %
/// took 110 → 99 ms a lift, three curls 90 → 80 ms (every absorption
/// probes each meeting with both neighbours refitted).
fn meeting_candidates(first: usize, last: usize) -> Vec<usize> {
    const SPREAD: usize = 5;
    if last - first < SPREAD {
        (first..=last).collect()
    } else {
        (0..SPREAD)
            .map(|k| first + k * (last - first) / (SPREAD - 1))
            .collect()
    }
}

/// Beyond the paper: merge neighbours that one helix fits within `E_max`
/// (refined from either one's parameters over both ranges). A covering
/// grown from a seed can stop in a local minimum of the fit (see
/// [`hop`]); the merged fit starts from a helix that already fits a
/// longer stretch, which usually escapes it.
fn merge(points: &[DVec2], pieces: &mut Vec<Piece>, opts: &CoverOptions, probes: &Probes) {
    merge_while(points, pieces, opts, probes, |_, merged| {
        let d = merged.max_distance(points);
        (d <= opts.emax).then_some(d)
    });
}

/// Merge neighbours `i − 1` and `i` where `accept(pair, merged)` scores a
/// merged trial (the lower the better; `None`: refused), until no pair
/// merges. The trials are refined from either neighbour's parameters over
/// both ranges and must be [`plausible`].
fn merge_while(
    points: &[DVec2],
    pieces: &mut Vec<Piece>,
    opts: &CoverOptions,
    probes: &Probes,
    accept: impl Fn(&[Piece], &Piece) -> Option<f64>,
) {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    merge_pairs(pieces, |pair| {
        probes
            .merged(pair, || merge_fits(points, pair, opts, &obj))
            .into_iter()
            .filter_map(|trial| accept(pair, &trial).map(|score| (score, trial)))
            .collect()
    });
}

/// The merged trials of `pair` for [`merge_while`] to judge: refined from
/// either neighbour's parameters over both ranges, restarted where stuck
/// ([`hop`]), the [`plausible`] ones in start order.
fn merge_fits(
    points: &[DVec2],
    pair: &[Piece],
    opts: &CoverOptions,
    obj: &Objective,
) -> Vec<Piece> {
    let (first, last) = (pair[0].first, pair[1].last);
    [&pair[0], &pair[1]]
        .into_par_iter()
        .filter_map(|start| {
            let mut trial = start.clone();
            // Grown into the neighbour in steps, each refitted by a
            // short probe (a helix extrapolated over the whole
            // neighbour at once can start the fit in a wrong basin).
            // Neighbours that are different helices (most pairs) stay
            // far off, and the full fit with its restarts would be
            // wasted on them.
            for k in 1..=MERGE_STEPS {
                let f = trial.first - (trial.first - first) * k / MERGE_STEPS;
                let l = trial.last + (last - trial.last) * k / MERGE_STEPS;
                stretch(&mut trial, points, f, l);
                refine(points, &mut trial, obj, opts.gain, MERGE_PROBE_ITERATIONS);
                if trial.max_distance(points) > MERGE_PROBE_LIMIT * opts.emax {
                    return None;
                }
            }
            refine(points, &mut trial, obj, opts.gain, GROW_ITERATIONS);
            hop(points, &mut trial, obj, opts.gain, false);
            plausible(&trial).then_some(trial)
        })
        .collect()
}

/// The probes of [`merge_while`] and [`absorb_while`], and the seeds'
/// fits ([`SeedFits`]), kept for one lift. A probe depends only on the
/// pieces it joins (and the drawing and options, fixed for a lift); the
/// covering's last pass and the noisy drawing's merges ([`merge_noisy`])
/// probe the same unchanged neighbours, judging them differently, so the
/// fits are made once (results unchanged; measured at 0.1 % noise, three
/// and four curls 109–114 → 95–96 ms and 136–138 → 117–119 ms).
#[derive(Default)]
pub(super) struct Probes {
    fits: SeedFits,
    merges: Kept<Vec<Piece>>,
    absorptions: Kept<Option<(Piece, Piece)>>,
}

impl Probes {
    /// The merged trials of `pair`, made by `fit` unless kept.
    fn merged(&self, pair: &[Piece], fit: impl FnOnce() -> Vec<Piece>) -> Vec<Piece> {
        self.merges.get_or_make(pair, fit)
    }

    /// The neighbours of `trio` grown over its middle, made by `fit`
    /// unless kept.
    fn absorbed(
        &self,
        trio: &[Piece],
        fit: impl FnOnce() -> Option<(Piece, Piece)>,
    ) -> Option<(Piece, Piece)> {
        self.absorptions.get_or_make(trio, fit)
    }
}

/// Values kept by the pieces they were made from (a linear search: a
/// covering has a few pieces).
struct Kept<V>(std::sync::Mutex<Vec<(Vec<Piece>, V)>>);

impl<V> Default for Kept<V> {
    fn default() -> Self {
        Kept(std::sync::Mutex::new(Vec::new()))
    }
}

impl<V: Clone> Kept<V> {
    fn get_or_make(&self, key: &[Piece], make: impl FnOnce() -> V) -> V {
        let kept = |m: &Self| {
            let all = m.0.lock().unwrap_or_else(|e| e.into_inner());
            all.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
        };
        if let Some(v) = kept(self) {
            return v;
        }
        let v = make();
        let mut all = self.0.lock().unwrap_or_else(|e| e.into_inner());
        all.push((key.to_vec(), v.clone()));
        v
    }
}

/// A merged trial of `pair` restarted where it is stuck ([`hop`]), and
/// scored by `accept` if it is [`plausible`].
fn judged(
    points: &[DVec2],
    mut trial: Piece,
    obj: &Objective,
    gain: f64,
    pair: &[Piece],
    accept: impl Fn(&[Piece], &Piece) -> Option<f64>,
) -> Option<(f64, Piece)> {
    hop(points, &mut trial, obj, gain, false);
    if !plausible(&trial) {
        return None;
    }
    accept(pair, &trial).map(|score| (score, trial))
}

/// Replaces neighbours `i − 1` and `i` by the best (lowest-scored) of the
/// merged trials `trials(pair)` gives (in a fixed order: ties go to the
/// first), stepping back after a merge so that the merged piece is tried
/// with the one before it too, until no pair merges.
fn merge_pairs(pieces: &mut Vec<Piece>, trials: impl Fn(&[Piece]) -> Vec<(f64, Piece)>) {
    let mut i = 1;
    while i < pieces.len() {
        let best = trials(&pieces[i - 1..=i])
            .into_iter()
            .min_by(|x, y| x.0.total_cmp(&y.0));
        match best {
            Some((_, merged)) => {
                pieces[i - 1] = merged;
                pieces.remove(i);
                i = i.max(2) - 1;
            }
            None => i += 1,
        }
    }
}

/// The drawn vertices of a denoised drawing, for [`merge_noisy`]: each in
/// the units the covering ran in, with the index of its denoised
/// counterpart among the covered points, and the drawing's noise (per
/// coordinate, same units).
#[derive(Clone, Debug)]
pub(super) struct Drawn<'a> {
    /// `(index of the counterpart, drawn vertex)`, in order.
    pub vertices: &'a [(usize, DVec2)],
    /// The noise `σ` of the drawn vertices.
    pub sigma: f64,
}

impl Drawn<'_> {
    /// Sum of squared distances of the drawn vertices in `piece`'s range
    /// from its projected curve (each by a closest-point search from its
    /// counterpart's parameter).
    fn residual(&self, piece: &Piece) -> f64 {
        let e = piece.helix.evaluator();
        self.vertices
            .iter()
            .filter(|(j, _)| piece.first <= *j && *j <= piece.last)
            .map(|&(j, v)| {
                let f = e.project(v, piece.ts[j - piece.first]);
                (v - e.jet(f.t).0).length_squared()
            })
            .sum()
    }
}

/// Parameters one more helix adds to a covering: `a`, `b`, `c`, `θ`, the
/// origin's two coordinates and the junction's place.
const PARAMS_PER_HELIX: f64 = 7.0;

/// Beyond the paper, for noisy drawings: merge neighbours where one helix
/// explains the drawn vertices about as well as two, by the Bayesian
/// information criterion: the merged helix's residual sum of squares over
/// the drawn vertices may exceed the pair's by up to `k σ² ln n` (`k`
/// parameters saved, [`PARAMS_PER_HELIX`]; `n` drawn vertices in the
/// pair). Under noise, the covering's test (every vertex within `E_max`)
/// fails wherever the noise peaks and cuts a helix in two; the residual
/// sum weighs all vertices, so a merge is refused only where the two
/// helices are really different (a corner, a change of radius or pitch).
pub(super) fn merge_noisy(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    pieces: &mut Vec<Piece>,
    opts: &CoverOptions,
    drawn: &Drawn<'_>,
    probes: &Probes,
) {
    let s2 = drawn.sigma * drawn.sigma;
    let count = |first: usize, last: usize| {
        drawn
            .vertices
            .iter()
            .filter(|(j, _)| first <= *j && *j <= last)
            .count()
            .max(2) as f64
    };
    absorb_while(points, pieces, opts, probes, |trio, l, r| {
        let n = count(trio[0].first, trio[2].last);
        let before: f64 = trio.iter().map(|p| drawn.residual(p)).sum();
        let cost = drawn.residual(l) + drawn.residual(r) - before;
        (cost <= PARAMS_PER_HELIX * s2 * n.ln()).then_some(cost)
    });
    let one_helix = |pair: &[Piece], merged: &Piece| {
        let n = count(merged.first, merged.last);
        let split: f64 = pair.iter().map(|p| drawn.residual(p)).sum();
        let cost = drawn.residual(merged) - split;
        (cost <= PARAMS_PER_HELIX * s2 * n.ln()).then_some(cost)
    };
    merge_while(points, pieces, opts, probes, one_helix);
    merge_short(points, geometry, pieces, opts, probes, one_helix);
}

/// A piece at most this many times shorter (in vertices) than its
/// neighbour is tried as the same helix ([`merge_short`]).
const SHORT_RATIO: usize = 2;

/// Unions [`merge_short`] fits afresh in one covering; the later ones
/// start from the stretched pieces only. The fresh fit is a whole noisy
/// covering fit of the union (grid seeds and all), about 23 ms at 0.3 %
/// noise, and most unions are refused whatever the start (43 of the 58
/// the benchmark's 480 noisy lifts try). Measured with
/// `benches/sketch_noise.rs` (four curls at 0.3 %, 48 seeds): 27 lifts
/// try no union, 7 one, 8 two, 2 three and 3 four, and `merge_short` then
/// takes 27, 59, 84 and 106 ms. With one fresh fit a covering, one of the
/// 480 noisy lifts changed (two coils at 0.3 %, seed 27: three helices
/// instead of two), one of 288 four-curl lifts (144 seeds, 0.1 % and
/// 0.3 %) changed the other way, and the 400 and 960 lifts at lower noise
/// were the same row for row; with two, none of those changed.
const FRESH_UNIONS: usize = 1;

/// Rounds of [`nearest_feet`] and refinement in [`merge_short`].
const FOOT_ROUNDS: usize = 3;

/// Beyond the paper, for noisy drawings: a piece beside one at least
/// [`SHORT_RATIO`] times longer is tried as part of the same helix. Under
/// noise a near-cusp (a helix tilted so that its projection nearly turns
/// back) is blurred, the walk's feet past it fall on the branch it came
/// by, and the helix stops there; the stretch after it becomes a piece of
/// its own, and [`merge_while`]'s probes, grown with the same feet, fail
/// as the walk did. Here the union is fitted from three starts (a fresh
/// covering fit of the union, for the first [`FRESH_UNIONS`] unions of a
/// covering, and either piece stretched over it), each
/// refined [`FOOT_ROUNDS`] times with the feet moved to the curve's
/// nearest points ([`nearest_feet`]); the best that `accept` scores
/// replaces the pair. Measured on the noisy drawings of
/// `benches/sketch_noise.rs` (48 seeds, 240 drawings at 0.1 %): the right
/// helix count 216 → 224, the depth within 2× 221 → 224, 5 % more time.
fn merge_short(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    pieces: &mut Vec<Piece>,
    opts: &CoverOptions,
    probes: &Probes,
    accept: impl Fn(&[Piece], &Piece) -> Option<f64> + Sync,
) {
    let obj = Objective {
        alpha_t: 0.0,
        emax: opts.emax,
    };
    let near = 0.5 * opts.emax;
    let budget = std::cell::Cell::new(FRESH_UNIONS);
    merge_pairs(pieces, |pair| {
        let (first, last) = (pair[0].first, pair[1].last);
        let lengths = [&pair[0], &pair[1]].map(|p| p.last - p.first);
        if SHORT_RATIO * lengths[0].min(lengths[1]) > lengths[0].max(lengths[1]) {
            return Vec::new();
        }
        let fresh = budget.get() > 0;
        if fresh {
            budget.set(budget.get() - 1);
        }
        let starts: Vec<Option<&Piece>> = if fresh {
            vec![None, Some(&pair[0]), Some(&pair[1])]
        } else {
            vec![Some(&pair[0]), Some(&pair[1])]
        };
        starts
            .into_par_iter()
            .filter_map(|start| {
                let mut trial = match start {
                    Some(p) => p.clone(),
                    None => fit_one(points, geometry, (first, last), opts, &probes.fits),
                };
                stretch(&mut trial, points, first, last);
                for _ in 0..FOOT_ROUNDS {
                    nearest_feet(&mut trial, points, near);
                    refine(points, &mut trial, &obj, opts.gain, GROW_ITERATIONS);
                }
                judged(points, trial, &obj, opts.gain, pair, &accept)
            })
            .collect()
    });
}

/// How far beyond a piece's parameter range (radians, each way)
/// [`nearest_feet`] looks, and its scan step.
const FOOT_WIDEN: f64 = 3.0;
const FOOT_SCAN: f64 = 0.05;

/// Moves the foot of each vertex of `piece` farther than `near` from the
/// curve to the curve's nearest point over the piece's parameter range
/// widened by [`FOOT_WIDEN`] (a scan, polished by Newton), where that is
/// nearer. The walk and [`stretch`] find feet locally, from the vertex
/// before, which is what a loop needs; past a near-cusp blurred by noise
/// that can leave them on the wrong branch, and no refinement of the
/// helix moves a foot across.
fn nearest_feet(piece: &mut Piece, points: &[DVec2], near: f64) {
    let e = piece.helix.evaluator();
    let (lo, hi) = piece
        .ts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
    let (lo, hi) = (lo - FOOT_WIDEN, hi + FOOT_WIDEN);
    let steps = ((hi - lo) / FOOT_SCAN).ceil().clamp(1.0, 1e4) as usize;
    for (k, t) in piece.ts.iter_mut().enumerate() {
        let v = points[piece.first + k];
        let own = (e.jet(*t).0 - v).length_squared();
        if own <= near * near {
            continue;
        }
        let (d2, u) = (0..=steps)
            .map(|j| lo + (hi - lo) * j as f64 / steps as f64)
            .map(|u| ((e.jet(u).0 - v).length_squared(), u))
            .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a });
        if d2 < own {
            let f = e.closest_parameter(v, u);
            if (e.jet(f).0 - v).length_squared() < own {
                *t = f;
            }
        }
    }
}

fn cover_range(
    points: &[DVec2],
    geometry: &[(DVec2, f64)],
    (lo, hi): (usize, usize),
    opts: &CoverOptions,
    fits: &SeedFits,
) -> Vec<Piece> {
    let mut piece = fit_one(points, geometry, (lo, hi), opts, fits);
    // At least one segment each side of the seed, so the recursion ends.
    let first = if piece.first - lo < MIN_VERTICES - 1 {
        lo
    } else {
        piece.first.min(piece.last.saturating_sub(1)).max(lo)
    };
    let last = if hi - piece.last < MIN_VERTICES - 1 {
        hi
    } else {
        piece.last.max(piece.first + 1).min(hi)
    };
    stretch(&mut piece, points, first, last);
    let (first, last) = (piece.first, piece.last);
    // The parts left on either side are independent.
    let (mut out, right) = rayon::join(
        || {
            if first > lo {
                cover_range(points, geometry, (lo, first), opts, fits)
            } else {
                Vec::new()
            }
        },
        || {
            if last < hi {
                cover_range(points, geometry, (last, hi), opts, fits)
            } else {
                Vec::new()
            }
        },
    );
    out.push(piece);
    out.extend(right);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Projections of helices `[a, b, c]` over `t ∈ [0, 2]`, `per` vertices
    /// each, chained with a 0.6 rad corner at each join; each helix with
    /// its vertex parameters.
    fn chain(shapes: &[[f64; 3]], per: usize) -> (Vec<DVec2>, Vec<(PlacedHelix, Vec<f64>)>) {
        let ts: Vec<f64> = (0..per)
            .map(|k| 2.0 * k as f64 / (per - 1) as f64)
            .collect();
        let mut points: Vec<DVec2> = Vec::new();
        let mut out = Vec::new();
        for &[a, b, c] in shapes {
            let mut h = PlacedHelix::from_params(&[0.0, 0.0, 0.0, a, b, c], false);
            if let Some(&join) = points.last() {
                let (prev, prev_ts): &(PlacedHelix, Vec<f64>) = out.last().unwrap();
                let d = prev.derivative(prev_ts[per - 1]).normalize();
                let want = DVec2::from_angle(0.6).rotate(d);
                h.theta = want.to_angle() - h.derivative(0.0).normalize().to_angle();
                h.origin = join - h.to_sketch_vector(h.helix.point(0.0));
                points.pop();
            }
            points.extend(ts.iter().map(|&t| h.point(t)));
            out.push((h, ts.clone()));
        }
        (points, out)
    }

    /// The piece of `h` over vertices `[first, last]`, projected from `t0`.
    fn piece_on(h: &PlacedHelix, points: &[DVec2], first: usize, last: usize, t0: f64) -> Piece {
        let mut p = Piece {
            helix: *h,
            first,
            last: first,
            ts: vec![h.closest_parameter(points[first], t0)],
            mirror: false,
        };
        stretch(&mut p, points, first, last);
        p
    }

    #[test]
    fn a_kept_seed_fit_is_reused_only_where_it_would_be_the_same() {
        // Three helices over [0, 39], [39, 78], [78, 117]; a seed inside the
        // middle one, fitted in many ranges, each time with a memory that
        // has seen the fits of every earlier range and with a fresh one:
        // the same piece. Among the ranges, one whose start cuts the
        // middle helix (its walk stops at the range's end, not where the
        // drawing leaves the helix), then wider ones, which must not reuse
        // that fit.
        let (points, _) = chain(&[[0.3, 0.1, 0.4], [0.2, 0.15, -0.3], [0.25, 0.05, 0.8]], 40);
        let geometry = super::super::tangents_and_curvatures(&points, 3);
        let opts = CoverOptions {
            emax: 1e-3,
            nmax: 12,
            end_guard: 3,
            gain: COVER_GAIN,
            noise: 0.0,
        };
        let kept = SeedFits::default();
        let s = 58;
        let ranges = [(44, 117), (0, 117), (30, 100), (45, 72), (0, 90), (20, 117)];
        let mut reused = 0;
        for range in ranges {
            let before = kept.0.lock().unwrap().len();
            let with_memory = fit_at(&points, &geometry, range, &opts, s, &kept);
            reused += usize::from(kept.0.lock().unwrap().len() == before);
            let fresh = fit_at(&points, &geometry, range, &opts, s, &SeedFits::default());
            assert_eq!(with_memory, fresh, "{range:?}");
        }
        // (0, 117) after (44, 117) is refitted; (30, 100), (0, 90) and
        // (20, 117), around a fit that stopped inside, reuse it.
        assert!(reused >= 2, "{reused}");
    }

    #[test]
    fn a_sliver_between_two_helices_is_absorbed_at_their_corner() {
        // Helices over vertices [0, 39] and [39, 78]; the covering left a
        // sliver [34, 44] over the corner.
        let (points, truth) = chain(&[[0.3, 0.1, 0.4], [0.2, 0.15, -0.3]], 40);
        let opts = CoverOptions {
            emax: 1e-3,
            nmax: 12,
            end_guard: 3,
            gain: COVER_GAIN,
            noise: 0.0,
        };
        let (h1, h2) = (&truth[0].0, &truth[1].0);
        let mut pieces = vec![
            piece_on(h1, &points, 0, 34, 0.0),
            piece_on(h2, &points, 34, 44, 0.0),
            piece_on(h2, &points, 44, 78, 0.5),
        ];
        absorb(&points, &mut pieces, &opts, &Probes::default());
        assert_eq!(pieces.len(), 2);
        assert_eq!((pieces[0].last, pieces[1].first), (39, 39));
        for p in &pieces {
            assert!(
                p.max_distance(&points) < 1e-9,
                "{}",
                p.max_distance(&points)
            );
        }
    }

    #[test]
    fn a_helix_between_two_others_is_kept() {
        let (points, truth) = chain(&[[0.3, 0.1, 0.4], [0.2, 0.15, -0.3], [0.25, 0.05, 0.8]], 40);
        let opts = CoverOptions {
            emax: 1e-3,
            nmax: 12,
            end_guard: 3,
            gain: COVER_GAIN,
            noise: 0.0,
        };
        let mut pieces: Vec<Piece> = truth
            .iter()
            .enumerate()
            .map(|(k, (h, _))| piece_on(h, &points, 39 * k, 39 * (k + 1), 0.0))
            .collect();
        let before = pieces.clone();
        absorb(&points, &mut pieces, &opts, &Probes::default());
        merge(&points, &mut pieces, &opts, &Probes::default());
        assert_eq!(pieces, before);
        assert!(pieces.iter().all(|p| p.max_distance(&points) < 1e-12));
    }

    use crate::sketch::testing::with_noise;

    /// [`merge_noisy`] on `pieces` of `points`, every vertex drawn with
    /// noise `sigma`; the drawn vertices' residuals, for checks.
    fn merged_noisy(
        points: &[DVec2],
        pieces: &mut Vec<Piece>,
        opts: &CoverOptions,
        sigma: f64,
    ) -> NoisyResidual {
        let vertices: Vec<(usize, DVec2)> = points.iter().copied().enumerate().collect();
        let drawn = Drawn {
            vertices: &vertices,
            sigma,
        };
        let geometry = crate::sketch::tangents_and_curvatures(points, 3);
        merge_noisy(points, &geometry, pieces, opts, &drawn, &Probes::default());
        NoisyResidual { vertices, sigma }
    }

    /// The drawn vertices of [`merged_noisy`], owned.
    struct NoisyResidual {
        vertices: Vec<(usize, DVec2)>,
        sigma: f64,
    }

    impl NoisyResidual {
        fn residual(&self, piece: &Piece) -> f64 {
            Drawn {
                vertices: &self.vertices,
                sigma: self.sigma,
            }
            .residual(piece)
        }
    }

    #[test]
    fn noisy_halves_of_one_helix_are_merged_and_two_helices_are_not() {
        // E_max at 2σ: about one vertex in seven is farther from the true
        // curve than that, so the covering's test cuts a noisy helix and
        // refuses to merge it back; the residuals over the drawn vertices
        // tell one helix from two.
        let sigma = 2e-3;
        let opts = CoverOptions {
            emax: 2.0 * sigma,
            nmax: 12,
            end_guard: 3,
            gain: NOISY_COVER_GAIN,
            noise: 0.0,
        };
        let obj = Objective {
            alpha_t: 0.0,
            emax: opts.emax,
        };
        for seed in 0..4 {
            // One helix, cut at vertex 40 of 80.
            let (clean, truth) = chain(&[[0.3, 0.1, 0.4]], 80);
            let points = with_noise(&clean, sigma, seed);
            let h = &truth[0].0;
            let mut pieces = vec![
                piece_on(h, &points, 0, 40, 0.0),
                piece_on(h, &points, 40, 79, 1.0),
            ];
            for p in &mut pieces {
                refine(&points, p, &obj, opts.gain, GROW_ITERATIONS);
            }
            let mut strict = pieces.clone();
            merge(&points, &mut strict, &opts, &Probes::default());
            assert_eq!(strict.len(), 2, "seed {seed}: within E_max");
            let drawn = merged_noisy(&points, &mut pieces, &opts, sigma);
            assert_eq!(pieces.len(), 1, "seed {seed}");
            assert_eq!((pieces[0].first, pieces[0].last), (0, 79));
            // The merged helix fits the drawing to its noise.
            let rms = (drawn.residual(&pieces[0]) / 80.0).sqrt();
            assert!(rms < 1.2 * sigma, "seed {seed}: {}", rms / sigma);

            // Two helices with a corner between them stay two, and their
            // junction stays at the corner.
            let (clean, truth) = chain(&[[0.3, 0.1, 0.4], [0.2, 0.15, -0.3]], 40);
            let points = with_noise(&clean, sigma, seed);
            let mut pieces: Vec<Piece> = truth
                .iter()
                .enumerate()
                .map(|(k, (h, _))| piece_on(h, &points, 39 * k, 39 * (k + 1), 0.0))
                .collect();
            for p in &mut pieces {
                refine(&points, p, &obj, opts.gain, GROW_ITERATIONS);
            }
            merged_noisy(&points, &mut pieces, &opts, sigma);
            assert_eq!(pieces.len(), 2, "seed {seed}");
            assert_eq!(pieces[0].last, 39, "seed {seed}");
        }
    }

    #[test]
    fn seeds_are_curvature_peaks_away_from_corners() {
        // A straight-ish polyline with a corner at 20 and estimated |κ|
        // peaking there (falling off over its flanks), and a smaller
        // smooth peak at 40: the seed is 40, not the flank at 24.
        let mut pts = vec![DVec2::ZERO];
        for k in 0..60 {
            let dir = if k < 20 { 0.0 } else { 0.6 };
            let last = *pts.last().unwrap();
            pts.push(last + 0.05 * DVec2::from_angle(dir));
        }
        let geometry: Vec<(DVec2, f64)> = (0..pts.len())
            .map(|i| {
                let corner_peak = 200.0 / (1.0 + (i as f64 - 20.0).powi(2));
                let smooth_peak = 5.0 / (1.0 + 0.1 * (i as f64 - 40.0).powi(2));
                (DVec2::X, corner_peak + smooth_peak)
            })
            .collect();
        assert!(is_corner(&pts, 20));
        assert_eq!(seed_vertex(&pts, &geometry, (0, 60), 3), 40);
        // Nor the flank just past the end of a range.
        assert_eq!(seed_vertex(&pts, &geometry, (24, 60), 3), 40);
        // Without a corner anywhere the largest curvature is the seed.
        let line: Vec<DVec2> = (0..61).map(|k| DVec2::new(0.05 * k as f64, 0.0)).collect();
        assert_eq!(seed_vertex(&line, &geometry, (0, 60), 3), 20);
    }

    #[test]
    fn corners_are_found_and_smooth_turns_are_not() {
        // An arc of radius 1 turning 0.05 rad per vertex, then a corner of
        // 0.6 rad, then the arc goes on.
        let mut pts = vec![DVec2::ZERO];
        let mut dir = 0.0f64;
        for k in 0..40 {
            dir += if k == 20 { 0.6 } else { 0.05 };
            let last = *pts.last().unwrap();
            pts.push(last + 0.05 * DVec2::from_angle(dir));
        }
        let corners: Vec<usize> = (0..pts.len()).filter(|&i| is_corner(&pts, i)).collect();
        assert_eq!(corners, vec![20]);
        assert!(near_corner(&pts, 17, 3) && !near_corner(&pts, 16, 3));
    }
}
