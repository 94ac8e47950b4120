//! Quantisation steps, all fractions of the tolerance `T` (see `Steps`), and
//! how the error budget is split between fitting and quantisation.

use serde::{Deserialize, Serialize};

/// Steps as fractions of the tolerance.
///
/// An element's end point is coded in the frame of its prediction: the
/// chord length along the predicted direction `u` (step
/// [`length`](Self::length)) and the two perpendicular offsets (step
/// [`offset`](Self::offset)). Only the
/// perpendicular offsets move the curve sideways; an error along `u` slides
/// the end along the curve, so its step can be coarser. Start points are on
/// a lattice of their own ([`start`](Self::start)).
///
/// The steps are stored in the container's header (as these fractions and
/// `T`), so a decoder needs nothing else.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Steps {
    /// Perpendicular end-point offsets and corner bulges.
    pub offset: f64,
    /// Chord lengths.
    pub length: f64,
    /// Start points: the half step of their body-centred cubic lattice
    /// (error `≤ √5/2 · start`).
    pub start: f64,
    /// A curve's first end and jumps (cubic grid, relative to the point
    /// before).
    pub first: f64,
    /// Sagitta of the decoder's chords to its arcs.
    pub sagitta: f64,
}

impl Default for Steps {
    /// Measured on the shared data (fornix, hair, field lines; offset and
    /// length steps 0.5/2.0, 0.8/1.6 and 1.1/1.1 tried): equal steps just
    /// under the grid's `2T/√3` are smallest everywhere. An end point then
    /// moves by at most `0.95 T`; the arcs between ends take what is left.
    /// Starts, first ends and jumps on coarse grids (start and first
    /// 0.4 → 1.1/1.0 on cubic grids measured: field lines −7.6 %, fornix
    /// −7 %, hair −2 %, the 60 short EuDX curves −27 %); starts then on the
    /// body-centred cubic lattice with the same worst error `0.95 T`
    /// (half step 0.85 T: 0.9 bits fewer per start; field lines −1.3 %,
    /// fornix +1 %). A start lies up to `0.95 T` off and its first element
    /// must come back within `T`, which the first element's search allows for.
    fn default() -> Self {
        Steps {
            offset: 1.1,
            length: 1.1,
            start: 0.85,
            first: 1.0,
            sagitta: 0.15,
        }
    }
}

/// Steps in the data's units for one tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantiser {
    pub offset: f64,
    pub length: f64,
    pub start: f64,
    pub first: f64,
    pub sagitta: f64,
}

impl Quantiser {
    pub fn new(tolerance: f64, steps: Steps) -> Self {
        Quantiser {
            offset: steps.offset * tolerance,
            length: steps.length * tolerance,
            start: steps.start * tolerance,
            first: steps.first * tolerance,
            sagitta: steps.sagitta * tolerance,
        }
    }

    /// `round(x / step)` as an integer, or `None` when it is not finite or
    /// too large to code.
    pub fn index(x: f64, step: f64) -> Option<i64> {
        let k = (x / step).round();
        if k.is_finite() && k.abs() < (1u64 << super::entropy::MAX_BITS) as f64 {
            Some(k as i64)
        } else {
            None
        }
    }

    /// The index toward zero (`trunc`), a cheaper code within one step.
    pub fn index_toward_zero(x: f64, step: f64) -> Option<i64> {
        let k = (x / step).trunc();
        if k.is_finite() && k.abs() < (1u64 << super::entropy::MAX_BITS) as f64 {
            Some(k as i64)
        } else {
            None
        }
    }
}

/// Half step of a block's points lattice: covering radius `T` less the
/// margin that writing coordinates up to `scale` as `f32` needs (the same
/// margin as the arcs' acceptance test), so that the nearest lattice point
/// of every point passes; `None` when nothing is left.
pub fn lattice_half(tolerance: f64, scale: f64) -> Option<f64> {
    let t = tolerance * (1.0 - 1e-9) - 4.0 * scale * f32::EPSILON as f64;
    (t > 0.0 && t.is_finite()).then(|| 2.0 * t / 5f64.sqrt() * (1.0 - 1e-9))
}

/// The exponent `e` of the smallest power of two `2^e ≥ scale` (clamped to
/// `-128..=127`): a block's coordinate bound, coded in one byte.
pub fn scale_exponent(scale: f64) -> i32 {
    if !(scale > 0.0) {
        return -128;
    }
    if !scale.is_finite() {
        return 127;
    }
    let mut e = (scale.log2().ceil() as i32).clamp(-128, 127);
    while e < 127 && 2f64.powi(e) < scale {
        e += 1;
    }
    while e > -128 && 2f64.powi(e - 1) >= scale {
        e -= 1;
    }
    e
}

/// The point of the body-centred cubic (BCC) lattice nearest to `p`, in
/// half-step integer coordinates `k` (the point is `k · half`, all three
/// of the same parity). The BCC lattice is the thinnest covering of space
/// by equal balls: with cube side `a = 2·half` every point of space is
/// within `a√5/4` of it, so at covering radius `T` it has 1.86 times fewer
/// points per volume than the cubic grid of step `2T/√3`, about 0.9 bits
/// less per coded point. `None` when not codable.
#[inline(always)]
pub fn bcc_nearest(p: glam::DVec3, half: f64) -> Option<[i64; 3]> {
    let x = [p.x / half, p.y / half, p.z / half];
    let limit = (1u64 << super::entropy::MAX_BITS) as f64;
    if !x.iter().all(|v| v.is_finite() && v.abs() < limit) {
        return None;
    }
    let even = x.map(|v| 2.0 * round_small(v / 2.0));
    let odd = x.map(|v| 2.0 * floor_small(v / 2.0) + 1.0);
    let d2 = |c: [f64; 3]| (0..3).map(|k| (c[k] - x[k]) * (c[k] - x[k])).sum::<f64>();
    // Either lattice is as likely: picked without a branch.
    let keep_even = (d2(even) <= d2(odd)) as i64;
    let (e, o) = (even.map(|v| v as i64), odd.map(|v| v as i64));
    Some([0, 1, 2].map(|k| (e[k] & -keep_even) | (o[k] & (keep_even - 1))))
}

/// `y.floor()` for `|y| < 2^52`, through an integer: the x86-64 baseline
/// has no rounding instruction, and the libm call was a twentieth of
/// `compress` (tested equal to `floor`).
#[inline]
fn floor_small(y: f64) -> f64 {
    let t = y as i64 as f64;
    // Without a branch (which a lattice point's coordinates would make
    // unpredictable): the comparison as a number.
    t - (t > y) as u8 as f64
}

/// `y.round()` (half away from zero) for `|y| < 2^52`, as [`floor_small`].
#[inline]
pub(crate) fn round_small(y: f64) -> f64 {
    let t = y as i64 as f64;
    // Exact: the fraction of a double is a double.
    let frac = y - t;
    // Without branches, as `floor_small` (a zero may change sign, which no
    // caller sees: the result goes to an integer).
    t + (frac >= 0.5) as u8 as f64 - (frac <= -0.5) as u8 as f64
}

/// The lattice point of half-step coordinates `k`.
pub fn bcc_point(k: [i64; 3], half: f64) -> glam::DVec3 {
    glam::DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * half
}

/// The `k`-th least of `values` (`1 ≤ k ≤ 16`), or infinity when there
/// are fewer.
fn kth_least(values: impl Iterator<Item = f64>, k: usize) -> f64 {
    if k <= 2 {
        // The slide's beam: the two least in two registers.
        let (mut a, mut b) = (f64::INFINITY, f64::INFINITY);
        for v in values {
            if v < b {
                (a, b) = if v < a { (v, a) } else { (a, v) };
            }
        }
        return if k == 1 { a } else { b };
    }
    let mut least = [f64::INFINITY; 16];
    for v in values {
        let mut i = k - 1;
        if v < least[i] {
            while i > 0 && least[i - 1] > v {
                least[i] = least[i - 1];
                i -= 1;
            }
            least[i] = v;
        }
    }
    least[k - 1]
}

/// A residual's estimated bits, separable by axis: `base + Σₐ axis(dₐ)`
/// (summed in axis order).
#[derive(Clone, Copy)]
pub struct AxisCost<F> {
    /// The part that does not depend on the residual.
    pub base: f64,
    /// One axis's part.
    pub axis: F,
}

impl<F: Fn(i64) -> f64> AxisCost<F> {
    /// The bits of residual `d`.
    pub fn of(&self, d: [i64; 3]) -> f64 {
        self.sum(d.map(&self.axis))
    }

    /// The bits from the three axes' parts.
    fn sum(&self, t: [f64; 3]) -> f64 {
        self.base + (t[0] + t[1] + t[2])
    }
}

/// `a == b`, without a branch per coordinate (the slide asks it of
/// every candidate and child: as `==`, 6 % of its time in the profile).
#[inline(always)]
fn same_point(a: [i64; 3], b: [i64; 3]) -> bool {
    ((a[0] ^ b[0]) | (a[1] ^ b[1]) | (a[2] ^ b[2])) == 0
}

/// A segment ready for many distance queries.
#[derive(Clone, Copy)]
struct Segment {
    a: glam::DVec3,
    d: glam::DVec3,
    /// `1 / |d|²` (0 for a point).
    inv: f64,
}

impl Segment {
    fn new(a: glam::DVec3, b: glam::DVec3) -> Self {
        let d = b - a;
        let dd = d.length_squared();
        Segment {
            a,
            d,
            inv: if dd > 0.0 { 1.0 / dd } else { 0.0 },
        }
    }

    /// Squared distance from `p`, as [`super::check::dist2_to_segment`].
    fn dist2(&self, p: glam::DVec3) -> f64 {
        let w = p - self.a;
        let t = (w.dot(self.d) * self.inv).clamp(0.0, 1.0);
        (w - self.d * t).length_squared()
    }
}

/// How far on along the input segment after a vertex the slide may move
/// it (a fraction of the segment). Measured with 0.5, 0.6, 0.75 and 1 (and
/// with the half segment before as well; and with a reach of the
/// prediction's distance from the vertex plus one to three tolerances):
/// the bytes within ±0.5 % of each other on the shared data, 10,000 fornix
/// replicas and the heart fibres of `benches/make_unseen.py` at 0.1 mm, but
/// each step further costs the slide a tenth more time.
const SLIDE_REACH: f64 = 0.5;

/// How widely [`cheapest_points`] searches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Search {
    /// Partial choices kept from vertex to vertex (1: greedy; at most 16).
    pub beam: usize,
    /// The most, in tolerances, that a vertex may slide on (the reach is
    /// the lesser of this and [`SLIDE_REACH`] of the segment after the
    /// vertex; a negative one is taken as 0). Where the input's
    /// segments are long against the tolerance (a curve already
    /// simplified, resampled bundles, noisy fibres at 0.1 mm), the tube
    /// and the choice among its points grow with it, and a slide that far
    /// buys little back: the prediction's error along the curve is what it
    /// buys.
    pub reach: f64,
}

/// Calls `f(k, x)` once for each lattice point `x = k·half` within `√r2`
/// of the segment `a`–`b` (a point on the boundary may be missed or not
/// by rounding).
///
/// Up to [`BOX_RADII`] radii long, every lattice point of the box about
/// the segment grown by `√r2` is tested (the lattice's points have
/// coordinates of one parity, so a row along the last axis steps by two);
/// longer, windows plane by plane about the segment's line
/// ([`lattice_near_long_segment`]), which test fewer points but cost more
/// to set up. The slide's segments are mostly a few radii long: with the
/// windows only, the encoder took 6.88 G instructions on 10,000 fornix
/// replicas at 0.1 mm (segments of about 4 radii), with the box 6.46 G;
/// with the box only, the resampled bundles of the shared data (16 radii)
/// took 10–16 % more (the same containers either way).
fn lattice_near_segment(
    a: glam::DVec3,
    b: glam::DVec3,
    half: f64,
    r2: f64,
    mut f: impl FnMut([i64; 3], glam::DVec3),
) {
    let d = b - a;
    let dd = d.length_squared();
    let inv = if dd > 0.0 { 1.0 / dd } else { 0.0 };
    let r = r2.sqrt();
    if dd > BOX_RADII * BOX_RADII * r2 {
        return lattice_near_long_segment(a, d, inv, half, r2, f);
    }
    let inv_half = 1.0 / half;
    // (Integer floors and ceilings: the libm calls were a tenth of the
    // slide.)
    let lo = (a.min(b) - glam::DVec3::splat(r)) * inv_half;
    let hi = (a.max(b) + glam::DVec3::splat(r)) * inv_half;
    let ceil = |y: f64| -floor_small(-y) as i64;
    let floor = |y: f64| floor_small(y) as i64;
    let (lo, hi) = (
        [ceil(lo.x), ceil(lo.y), ceil(lo.z)],
        [floor(hi.x), floor(hi.y), floor(hi.z)],
    );
    // The first of `parity` from `k` up.
    let from = |k: i64, parity: i64| k + ((k - parity) & 1);
    for k0 in lo[0]..=hi[0] {
        let parity = k0 & 1;
        let w0 = k0 as f64 * half - a.x;
        let mut k1 = from(lo[1], parity);
        while k1 <= hi[1] {
            let w1 = k1 as f64 * half - a.y;
            let along01 = w0 * d.x + w1 * d.y;
            let mut k2 = from(lo[2], parity);
            while k2 <= hi[2] {
                let w2 = k2 as f64 * half - a.z;
                let t = ((along01 + w2 * d.z) * inv).clamp(0.0, 1.0);
                let (e0, e1, e2) = (w0 - d.x * t, w1 - d.y * t, w2 - d.z * t);
                if e0 * e0 + e1 * e1 + e2 * e2 <= r2 {
                    let k = [k0, k1, k2];
                    f(k, bcc_point(k, half));
                }
                k2 += 2;
            }
            k1 += 2;
        }
    }
}

/// The longest segment, in radii, whose box [`lattice_near_segment`]
/// searches.
const BOX_RADII: f64 = 6.0;

/// [`lattice_near_segment`] for a segment `a`–`a + d` long against the
/// radius (many radii: most of its box is far from it; `inv` is `1/|d|²`):
/// plane by plane across the segment's longest axis (the lattice's points
/// of one parity lie in every other plane): in a plane, such a point is in
/// the section of the cylinder around the segment's line, an ellipse about
/// the line's point whose extent on axis `j` is `√r2·√(1 + (dⱼ/d₀)²)`
/// (`d₀` on the longest axis), or in the section of the ball at an end.
/// Each candidate in that window is tested.
fn lattice_near_long_segment(
    a: glam::DVec3,
    d: glam::DVec3,
    inv: f64,
    half: f64,
    r2: f64,
    mut f: impl FnMut([i64; 3], glam::DVec3),
) {
    let r = r2.sqrt();
    let long = d.abs().max_position();
    let (o1, o2) = ((long + 1) % 3, (long + 2) % 3);
    // The segment with its longest axis first.
    let (a0, a1, a2) = (a[long], a[o1], a[o2]);
    let (d0, d1, d2) = (d[long], d[o1], d[o2]);
    let inv_half = 1.0 / half;
    // (Integer floors and ceilings: the libm calls were a tenth of the
    // slide.)
    let floor = |y: f64| floor_small(y) as i64;
    let ceil = |y: f64| -floor_small(-y) as i64;
    let lo = floor((a0.min(a0 + d0) - r) * inv_half);
    let hi = ceil((a0.max(a0 + d0) + r) * inv_half);
    // The window on the other two axes: the section of the cylinder
    // around the segment's line (an ellipse about the line's point, whose
    // extent on axis `j` is `r·√(1 + (dⱼ/d₀)²)`), and of the balls at its
    // ends where the plane cuts them.
    let slope = |dj: f64| if d0 != 0.0 { dj / d0 } else { 0.0 };
    let (s1, s2) = (slope(d1), slope(d2));
    let (h1, h2) = (r * (1.0 + s1 * s1).sqrt(), r * (1.0 + s2 * s2).sqrt());
    let ends = [(a0, a1, a2), (a0 + d0, a1 + d1, a2 + d2)];
    let mut k = [0i64; 3];
    for kl in lo..=hi {
        let parity = kl & 1;
        let c = kl as f64 * half;
        let w0 = c - a0;
        let (mut lo1, mut hi1, mut lo2, mut hi2) = if d0 != 0.0 {
            let (l1, l2) = (a1 + s1 * w0, a2 + s2 * w0);
            (l1 - h1, l1 + h1, l2 - h2, l2 + h2)
        } else {
            (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            )
        };
        for (e0, e1, e2) in ends {
            let dl = c - e0;
            if dl * dl <= r2 {
                let rr = (r2 - dl * dl).sqrt();
                (lo1, hi1) = (lo1.min(e1 - rr), hi1.max(e1 + rr));
                (lo2, hi2) = (lo2.min(e2 - rr), hi2.max(e2 + rr));
            }
        }
        if !(lo1 <= hi1 && lo2 <= hi2) {
            continue;
        }
        // The first of `kl`'s parity from `y` up.
        let from = |y: f64| {
            let k = ceil(y * inv_half);
            k + ((k - parity) & 1)
        };
        let (to1, to2) = (floor(hi1 * inv_half), floor(hi2 * inv_half));
        let from2 = from(lo2);
        let mut k1 = from(lo1);
        while k1 <= to1 {
            let w1 = k1 as f64 * half - a1;
            let mut k2 = from2;
            while k2 <= to2 {
                let w2 = k2 as f64 * half - a2;
                let t = ((w0 * d0 + w1 * d1 + w2 * d2) * inv).clamp(0.0, 1.0);
                let (e0, e1, e2) = (w0 - d0 * t, w1 - d1 * t, w2 - d2 * t);
                if e0 * e0 + e1 * e1 + e2 * e2 <= r2 {
                    k[long] = kl;
                    k[o1] = k1;
                    k[o2] = k2;
                    f(k, bcc_point(k, half));
                }
                k2 += 2;
            }
            k1 += 2;
        }
    }
}

/// How far back a prediction given to [`cheapest_points`] may look: it
/// reads only `g[k − PREDICT_LOOKBACK..k]` (the screw prediction reads
/// seven points back, second order two, a reference's one, and model 10's
/// along-step prediction `AlongStep::STEPS + 1`).
pub const PREDICT_LOOKBACK: usize = 16;
const _: () = assert!(super::predict::AlongStep::STEPS < PREDICT_LOOKBACK);

/// Lattice points for the polyline `points`, the cheapest to code (`cost`
/// of each difference from `predict`'s prediction, given the points chosen
/// before it) among those that keep the two-sided promise: output vertex
/// `k` within `√tol2` of an input segment beside input vertex `k`, and
/// input vertex `k` within `√tol2` of an output segment that ends at
/// output vertex `k` (the first point is `first`, within `√tol2` of the
/// first input vertex).
///
/// The promise is about vertex-to-segment distances, so an output vertex
/// may slide forward along the curve by up to about `T / θ` (θ the turn at
/// the vertex): the prediction's error along the curve costs less. The
/// candidates for a vertex are the prediction, the nearest lattice point
/// (always feasible, so no point costs more than rounding) and the lattice
/// points within `√tol2` of the input from the vertex to half-way on to the
/// next ([`SLIDE_REACH`], at most [`Search::reach`]), found once
/// per vertex ([`lattice_near_segment`]). The search keeps the
/// [`Search::beam`] cheapest partial choices (ending at different points)
/// from vertex to vertex, so a point a little dearer now may buy cheaper
/// ones after it (one: greedy). Linear in the curve's length (each vertex's
/// candidates bounded by the reach in tolerances): `predict` sees the
/// chosen points only through `g[k − PREDICT_LOOKBACK..k]` (the rest of
/// the slice is scratch). `rounded`, where given, are the points' nearest
/// lattice points, each within `√tol2` (as found here otherwise).
/// Returns the points, the sum of `rate` over their residuals (the
/// prediction's own, so a caller need not predict again) and the
/// predictions they are residuals of (`predict(points, k)` at `k ≥ 1`; 0 at
/// the first); `None` if a vertex has no lattice point within `√tol2`.
/// The promise holds up to rounding (a point on its boundary may pass by a
/// few ulps: tests within the tube are taken from sums that round
/// differently); the codec's `tol2` leaves a margin for it
/// ([`super::encoder::acceptance_tolerance`]).
/// (Sliding back as well, the vertex then covered by the next segment,
/// measured no better: 1 % smaller on some files, 3 % larger on others.)
#[allow(clippy::too_many_arguments)]
pub fn cheapest_points(
    points: &[glam::DVec3],
    half: f64,
    tol2: f64,
    first: [i64; 3],
    search: Search,
    predict: impl Fn(&[[i64; 3]], usize) -> [i64; 3],
    cost: AxisCost<impl Fn(i64) -> f64>,
    rate: impl Fn([i64; 3]) -> u64,
    along: bool,
    rounded: Option<&[[i64; 3]]>,
) -> Option<Slid> {
    use super::check::dist2_to_segment;
    /// One partial choice: its last point, its parent (an index into
    /// `flat`, the previous vertex's beam), its cost so far, and its last
    /// residual as coded (the rate is summed along the chosen path only).
    #[derive(Clone, Copy)]
    struct Node {
        q: [i64; 3],
        parent: u32,
        cost: f64,
        coded: [i64; 3],
        /// The along-step window for the next vertex
        /// (`predict::step_window`; 0 without `along`).
        window: u64,
        /// The prediction its residual is from.
        pred: [i64; 3],
    }
    /// A kept candidate: its cost as coded, its squared distance from the
    /// vertex (`-1` for the prediction, which is made first), the point and
    /// its residual as coded.
    #[derive(Clone, Copy)]
    struct Kept {
        cost: f64,
        slid: f64,
        q: [i64; 3],
        coded: [i64; 3],
    }
    /// Whether a candidate of `cost` and `slid` comes before `k`: cheaper,
    /// or as cheap and slid less. (Made later, a candidate equal in both
    /// comes after. `&` and `|`, not `&&` and `||`: no branches.)
    #[inline(always)]
    fn goes_before(cost: f64, slid: f64, k: &Kept) -> bool {
        (cost < k.cost) | ((cost == k.cost) & (slid < k.slid))
    }
    let n = points.len();
    if n == 0 {
        return Some((Vec::new(), 0, Vec::new()));
    }
    let beam = search.beam.clamp(1, 16);
    // The beams of all vertices one after the other (one allocation per
    // curve); vertex k's is flat[level[k]..level[k + 1]].
    let mut flat: Vec<Node> = Vec::with_capacity(n * beam);
    let mut level: Vec<usize> = Vec::with_capacity(n + 1);
    level.push(0);
    flat.push(Node {
        q: first,
        parent: 0,
        cost: 0.0,
        coded: [0; 3],
        window: 0,
        pred: [0; 3],
    });
    level.push(1);
    let mut scratch = vec![[0i64; 3]; n];
    // Which node of `flat` each scratch entry was copied from: a path is
    // the same as the one in scratch from the first entry walked back to
    // that is, so a partial choice copies only where its path differs
    // (usually one or two points, not `PREDICT_LOOKBACK`).
    let mut scratch_from = vec![usize::MAX; n];
    let mut next: Vec<Node> = Vec::new();
    // Each partial choice's step out of its children's along-step windows.
    let mut step_out = [0u64; 16];
    // The lattice points the slide may move vertex k to (see below), with
    // their squared distance from the vertex, and one partial choice's
    // kept candidates among them.
    let mut tube: Vec<([i64; 3], glam::DVec3, f64)> = Vec::new();
    let mut top: Vec<Kept> = Vec::with_capacity(beam);
    const EMPTY: Kept = Kept {
        cost: f64::INFINITY,
        slid: f64::INFINITY,
        q: [0; 3],
        coded: [0; 3],
    };
    // Every vertex's nearest lattice point first: a vertex without one
    // within the tolerance (or not codable) ends the search before its
    // neighbour's tube is sought. (The caller's, where it has them: the
    // encoder rounded the points already.)
    let nearests = match rounded {
        Some(r) if r.len() == n => {
            debug_assert!(
                r.iter()
                    .zip(points)
                    .all(|(&q, &p)| bcc_nearest(p, half) == Some(q)
                        && bcc_point(q, half).distance_squared(p) <= tol2),
                "the rounded points given are the nearest lattice points"
            );
            std::borrow::Cow::Borrowed(r)
        }
        _ => {
            let mut nearests = Vec::with_capacity(n);
            for &p in points {
                let q = bcc_nearest(p, half)?;
                if bcc_point(q, half).distance_squared(p) > tol2 {
                    return None;
                }
                nearests.push(q);
            }
            std::borrow::Cow::Owned(nearests)
        }
    };
    for k in 1..n {
        let v = points[k];
        let before = points[k - 1];
        let after = points.get(k + 1).copied();
        let nearest = nearests[k];
        // The input segments beside the vertex, for every partial choice.
        let seg_before = Segment::new(before, v);
        let seg_after = after.map(|a| Segment::new(v, a));
        // Where vertex k may go: the lattice points within the tolerance
        // of the input from the vertex to half-way on to the one after
        // ([`SLIDE_REACH`], at most [`Search::reach`]). A point within the
        // tolerance of that part of the segment after is within it of the
        // segment (at the last vertex the part is the vertex, which ends
        // the segment before): no test of its own. (Behind the vertex, a
        // point beyond the tolerance of it is feasible only where the
        // vertex before slid past it: with those the bytes were the same
        // within 0.03 %.) The nearest point is every partial choice's
        // child already, never a candidate. Of candidates that cost the
        // same, the one that slides less is kept (measured against the
        // order found: the hair at 0.1 mm 1.3 % smaller, 10,000 fornix
        // replicas and the noisy heart fibres of `benches/make_unseen.py`
        // 0.2 % and 0.4 % larger).
        tube.clear();
        let ahead = after.map_or(v, |a| {
            let cap = search.reach * tol2.sqrt() / a.distance(v);
            v + (a - v) * SLIDE_REACH.min(cap).max(0.0)
        });
        lattice_near_segment(v, ahead, half, tol2, |q, x| {
            if !same_point(q, nearest) {
                tube.push((q, x, x.distance_squared(v)));
            }
        });
        next.clear();
        for pi in level[k - 1]..level[k] {
            let node = &flat[pi];
            // The path's last points into the scratch window.
            let mut at = pi;
            for j in (k.saturating_sub(PREDICT_LOOKBACK)..k).rev() {
                if scratch_from[j] == at {
                    break;
                }
                let nd = &flat[at];
                scratch[j] = nd.q;
                scratch_from[j] = at;
                at = nd.parent as usize;
            }
            let o_prev = bcc_point(node.q, half);
            let feasible = |q: [i64; 3]| {
                let x = bcc_point(q, half);
                (seg_after.is_some_and(|s| s.dist2(x) <= tol2) || seg_before.dist2(x) <= tol2)
                    && dist2_to_segment(v, o_prev, x) <= tol2
            };
            let pred = predict(&scratch[..k], k);
            let diff = |q: [i64; 3]| [0, 1, 2].map(|a| q[a].wrapping_sub(pred[a]));
            // Model 10 codes the coordinate along the step against the
            // step length (`AlongStep`): residuals are costed as coded.
            let step = (along && k >= 2)
                .then(|| super::predict::AlongStep::at(&scratch[..k], k, pred, node.window));
            // The step that leaves a child's along-step window (the path's
            // `STEPS` before; its window is made once it is kept, below).
            step_out[pi - level[k - 1]] = if along && k > super::predict::AlongStep::STEPS {
                super::predict::step_length2(&scratch[..k], k - super::predict::AlongStep::STEPS)
            } else {
                0
            };
            let coded = |d: [i64; 3]| step.map_or(d, |st| st.coded(d));
            let parent = pi as u32;
            // (`c` the cost of `q`'s residual as coded, `r`.)
            let push = |next: &mut Vec<Node>, q: [i64; 3], c: f64, r: [i64; 3]| {
                let cost = node.cost + c;
                // (The whole list scanned, the last match kept: no exit
                // from the scan to mispredict. A point is in it once.)
                let mut found = usize::MAX;
                for (i, o) in next.iter().enumerate() {
                    found = if same_point(o.q, q) { i } else { found };
                }
                if let Some(o) = next.get_mut(found) {
                    if cost < o.cost {
                        *o = Node {
                            q,
                            parent,
                            cost,
                            coded: r,
                            window: 0,
                            pred,
                        };
                    }
                } else {
                    next.push(Node {
                        q,
                        parent,
                        cost,
                        coded: r,
                        window: 0,
                        pred,
                    });
                }
            };
            // The nearest point is always feasible: it is within the
            // tolerance of the vertex, which ends both segments.
            let r_near = coded(diff(nearest));
            let c_near = cost.of(r_near);
            push(&mut next, nearest, c_near, r_near);
            // What a child's whole cost must not exceed to be kept: the
            // `beam`-th least of the children so far. Their costs only
            // fall, and one dearer than that ends behind `beam` cheaper
            // ones in the stable sort below. (An equal one is searched: it
            // may replace a dearer child of the same point that stands
            // before an equal one.) With `beam = 1`, a candidate must cost
            // less than the nearest point (pushed already).
            let beat = kth_least(next.iter().map(|o| o.cost), beam);
            let bar = if beam > 1 { f64::INFINITY } else { c_near };
            // (`&`, not `&&`: no branch.)
            let within = |c: f64| (node.cost + c <= beat) & (c < bar);
            // The kept candidates: the cheapest `beam` feasible ones by
            // (cost as coded, order made: the prediction, then the tube
            // nearest the vertex first), in that order. Each candidate is
            // costed exactly (along the step too) and tested only where it
            // would be kept, in one pass: taking them lazily by a bound
            // under the cost (session 54's form) asked fewer costs and
            // tests but branched on every comparison, and the slide's time
            // was its mispredicted branches.
            // (`top` is `beam` long, its empty places infinitely dear: a
            // candidate enters where it comes before the last, with no
            // test of the length.)
            top.clear();
            top.resize(beam, EMPTY);
            let mut kept = 0;
            // `k` into `top` (which it comes before the last of).
            let mut offer = |top: &mut Vec<Kept>, k: Kept| {
                kept += 1;
                let mut i = beam - 1;
                while i > 0 && goes_before(k.cost, k.slid, &top[i - 1]) {
                    top[i] = top[i - 1];
                    i -= 1;
                }
                top[i] = k;
            };
            // Whether a candidate would enter `top`.
            let enters =
                |top: &Vec<Kept>, cost: f64, slid: f64| goes_before(cost, slid, &top[beam - 1]);
            let pred_apart = !same_point(pred, nearest);
            if pred_apart {
                let r = coded([0; 3]);
                let c = cost.of(r);
                if within(c) && feasible(pred) {
                    let k = Kept {
                        cost: c,
                        slid: -1.0,
                        q: pred,
                        coded: r,
                    };
                    offer(&mut top, k);
                }
            }
            for &(q, x, slid) in tube.iter() {
                let r = coded(diff(q));
                // (The prediction, where it is in the tube, was offered
                // first at the same cost: never offered twice.)
                let c = if pred_apart & same_point(q, pred) {
                    f64::INFINITY
                } else {
                    cost.of(r)
                };
                // A point of the tube is within the tolerance of the input
                // already: only the output segment into it is asked, which
                // is within it where its end is (no division).
                // (An infinite cost is never `within`.)
                if within(c) & enters(&top, c, slid)
                    && (slid <= tol2 || dist2_to_segment(v, o_prev, x) <= tol2)
                {
                    let k = Kept {
                        cost: c,
                        slid,
                        q,
                        coded: r,
                    };
                    offer(&mut top, k);
                }
            }
            for k in &top[..kept.min(beam)] {
                push(&mut next, k.q, k.cost, k.coded);
            }
        }
        next.sort_by(|a, b| a.cost.total_cmp(&b.cost));
        next.truncate(beam);
        // A kept child's window for the vertex after it: its parent's, its
        // step in, the step `STEPS` before out.
        if along {
            for child in next.iter_mut() {
                let parent = &flat[child.parent as usize];
                let step_in = (0..3)
                    .map(|a| {
                        let l = child.q[a].wrapping_sub(parent.q[a]).unsigned_abs();
                        l.saturating_mul(l)
                    })
                    .fold(0u64, u64::saturating_add);
                let mut w = parent.window.saturating_add(step_in);
                if k > super::predict::AlongStep::STEPS {
                    w = w.saturating_sub(step_out[child.parent as usize - level[k - 1]]);
                }
                child.window = w;
            }
        }
        flat.extend_from_slice(&next);
        level.push(flat.len());
    }
    // The cheapest path, back from its end.
    let mut g = vec![[0i64; 3]; n];
    let mut preds = vec![[0i64; 3]; n];
    let mut at = level[n - 1];
    let mut total = 0u64;
    for k in (0..n).rev() {
        let nd = flat[at];
        g[k] = nd.q;
        preds[k] = nd.pred;
        if k > 0 {
            total += rate(nd.coded);
        }
        at = nd.parent as usize;
    }
    Some((g, total, preds))
}

/// [`cheapest_points`]' result: the points, their residuals' rate, and the
/// predictions the residuals are from.
pub type Slid = (Vec<[i64; 3]>, u64, Vec<[i64; 3]>);

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn kth_least_is_the_sorted_kth() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for _ in 0..500 {
            let v: Vec<f64> = (0..rng.gen_range(0..12))
                .map(|_| rng.gen_range(0..6) as f64)
                .collect();
            for k in 1..=4 {
                let mut s = v.clone();
                s.sort_by(f64::total_cmp);
                let want = s.get(k - 1).copied().unwrap_or(f64::INFINITY);
                assert_eq!(kth_least(v.iter().copied(), k), want, "{v:?} k {k}");
            }
        }
    }

    #[test]
    fn small_floor_and_round_are_libms() {
        // Halves, near-halves, integers, signed zeros and wide magnitudes.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut ys = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
            1.0,
            -1.0,
            4503599627370495.5,
            -4503599627370495.5,
        ];
        for _ in 0..200_000 {
            let scale = 2f64.powi(rng.gen_range(-3..52));
            let y: f64 = rng.gen_range(-1.0..1.0) * scale;
            ys.extend([
                y,
                y.trunc() + 0.5,
                y.trunc() - 0.5,
                y.next_up(),
                y.next_down(),
            ]);
        }
        for y in ys {
            if y.abs() < 2f64.powi(52) {
                assert_eq!(floor_small(y), y.floor(), "floor {y}");
                assert_eq!(round_small(y), y.round(), "round {y}");
            }
        }
    }

    #[test]
    fn lattice_near_segment_finds_each_point_within_the_radius_once() {
        // Against every lattice point of the segment's bounding box: all
        // within the radius found (but for those on its boundary, within
        // rounding), none twice, none beyond it, all on the lattice. Any
        // direction, lengths from zero (a ball) to many radii, segments
        // along an axis and on a diagonal.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let half = 0.37;
        let mut found_total = 0;
        for case in 0..3_000 {
            let r: f64 = rng.gen_range(0.2..1.5);
            let a = glam::DVec3::new(
                rng.gen_range(-5.0..5.0),
                rng.gen_range(-5.0..5.0),
                rng.gen_range(-5.0..5.0),
            );
            let len = [0.0, 0.01, rng.gen_range(0.0..8.0)][case % 3];
            let dir = match case % 7 {
                0 => glam::DVec3::X,
                1 => glam::DVec3::new(0.0, -1.0, 0.0),
                2 => glam::DVec3::ONE.normalize(),
                _ => glam::DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                )
                .normalize_or_zero(),
            };
            let b = a + dir * len;
            let seg = Segment::new(a, b);
            let mut found = Vec::new();
            lattice_near_segment(a, b, half, r * r, |k, x| {
                assert_eq!(x, bcc_point(k, half));
                assert!(
                    k[0].rem_euclid(2) == k[1].rem_euclid(2)
                        && k[1].rem_euclid(2) == k[2].rem_euclid(2)
                );
                assert!(
                    seg.dist2(x) <= r * r * (1.0 + 1e-9),
                    "case {case}: {k:?} beyond"
                );
                found.push(k);
            });
            let n = found.len();
            found.sort();
            found.dedup();
            assert_eq!(found.len(), n, "case {case}: a point found twice");
            let lo = ((a.min(b) - glam::DVec3::splat(r)) / half).floor();
            let hi = ((a.max(b) + glam::DVec3::splat(r)) / half).ceil();
            let mut inside = 0;
            for i in lo.x as i64..=hi.x as i64 {
                for j in lo.y as i64..=hi.y as i64 {
                    for l in lo.z as i64..=hi.z as i64 {
                        if (i - j) % 2 != 0 || (j - l) % 2 != 0 {
                            continue;
                        }
                        let k = [i, j, l];
                        if seg.dist2(bcc_point(k, half)) <= r * r * (1.0 - 1e-9) {
                            inside += 1;
                            assert!(found.binary_search(&k).is_ok(), "case {case}: {k:?} missed");
                        }
                    }
                }
            }
            assert!(n >= inside);
            found_total += n;
        }
        // The cases are not empty: a ball of radius 0.2..1.5 holds a few
        // points of this lattice on average.
        assert!(found_total > 3_000 * 5, "{found_total}");
    }

    #[test]
    fn bcc_nearest_is_within_the_covering_radius_and_on_the_lattice() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let half = 0.37;
        let radius = 2.0 * half * 5f64.sqrt() / 4.0;
        let mut worst = 0f64;
        for _ in 0..100_000 {
            let p = glam::DVec3::new(
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
            );
            let k = bcc_nearest(p, half).unwrap();
            assert!(
                k[0].rem_euclid(2) == k[1].rem_euclid(2)
                    && k[1].rem_euclid(2) == k[2].rem_euclid(2)
            );
            worst = worst.max(bcc_point(k, half).distance(p));
        }
        assert!(worst <= radius * (1.0 + 1e-12), "{worst} > {radius}");
        // The bound is attained: the worst is close to it.
        assert!(worst > 0.97 * radius);
        assert!(bcc_nearest(glam::DVec3::splat(f64::NAN), 1.0).is_none());
    }

    #[test]
    fn indices_round_and_refuse_the_uncodable() {
        assert_eq!(Quantiser::index(0.74, 0.5), Some(1));
        assert_eq!(Quantiser::index(-0.76, 0.5), Some(-2));
        assert_eq!(Quantiser::index_toward_zero(-0.76, 0.5), Some(-1));
        assert_eq!(Quantiser::index(f64::NAN, 0.5), None);
        assert_eq!(Quantiser::index(1e30, 1e-9), None);
    }

    /// Second-order prediction on the lattice (first order for the second
    /// point), and a cost that grows with the residual.
    fn second_order(g: &[[i64; 3]], k: usize) -> [i64; 3] {
        if k >= 2 {
            [0, 1, 2].map(|a| 2 * g[k - 1][a] - g[k - 2][a])
        } else {
            g[k - 1]
        }
    }
    fn axis_cost(v: i64) -> f64 {
        (1.0 + v.unsigned_abs() as f64).log2()
    }
    const RESIDUAL_COST: AxisCost<fn(i64) -> f64> = AxisCost {
        base: 0.0,
        axis: axis_cost,
    };
    fn residual_cost(d: [i64; 3]) -> f64 {
        RESIDUAL_COST.of(d)
    }
    /// The points chosen against second-order prediction.
    fn slid(pts: &[glam::DVec3], half: f64, tol: f64, first: [i64; 3]) -> Vec<[i64; 3]> {
        slide_second_order(
            pts,
            half,
            tol,
            first,
            Search {
                beam: 1,
                reach: 3.0,
            },
            false,
        )
        .0
    }

    /// [`cheapest_points`] against second-order prediction, all it returns.
    fn slide_second_order(
        pts: &[glam::DVec3],
        half: f64,
        tol: f64,
        first: [i64; 3],
        search: Search,
        along: bool,
    ) -> Slid {
        cheapest_points(
            pts,
            half,
            tol * tol,
            first,
            search,
            second_order,
            RESIDUAL_COST,
            |_| 0,
            along,
            None,
        )
        .unwrap()
    }
    fn total_cost(g: &[[i64; 3]]) -> f64 {
        (1..g.len())
            .map(|k| {
                let p = second_order(g, k);
                residual_cost([0, 1, 2].map(|a| g[k][a] - p[a]))
            })
            .sum()
    }

    #[test]
    fn cheapest_points_keep_the_two_sided_promise() {
        // Random walks with steps from a fifth of the tolerance to twenty
        // times it, turning by up to 1.5 rad: the chosen points are within
        // the tolerance of the input both ways (independent checker).
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for trial in 0..300 {
            let tol: f64 = rng.gen_range(0.01..1.0);
            let half = 2.0 * tol / 5f64.sqrt() * (1.0 - 1e-9);
            let n = rng.gen_range(2..60);
            let mut p = glam::DVec3::new(
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
            );
            let mut dir = glam::DVec3::X;
            let mut pts = Vec::with_capacity(n);
            for _ in 0..n {
                pts.push(p);
                let turn = glam::DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                ) * rng.gen_range(0.0..1.5);
                dir = (dir + turn).normalize();
                p += dir * tol * rng.gen_range(0.2..20.0);
            }
            let first = bcc_nearest(pts[0], half).unwrap();
            // Greedy, the codec's beam and a wider one, each with the
            // codec's reaches, a shorter one and a negative one (taken as
            // 0); costed plainly and as model 10 codes the step.
            let search = Search {
                beam: [1, 2, 4][trial % 3],
                reach: [3.0, 2.0, 1.0, -1.0][trial % 4],
            };
            let (g, _, predicted) =
                slide_second_order(&pts, half, tol, first, search, trial % 2 == 1);
            assert_eq!(g.len(), n);
            // The predictions returned are those of the chosen points.
            for k in 1..n {
                assert_eq!(predicted[k], second_order(&g, k), "trial {trial} point {k}");
            }
            assert!(g.iter().all(|k| k[0].rem_euclid(2) == k[1].rem_euclid(2)
                && k[1].rem_euclid(2) == k[2].rem_euclid(2)));
            let out: Vec<glam::DVec3> = g.iter().map(|&k| bcc_point(k, half)).collect();
            let d = crate::metrics::hausdorff(&pts, &out).unwrap();
            assert!(d <= tol * (1.0 + 1e-12), "trial {trial}: {d} > {tol}");
        }
    }

    #[test]
    fn cheapest_points_slide_along_a_line_for_free() {
        // A straight line sampled unevenly (steps 3–5 T): rounded, the
        // uneven steps are second-order residuals along the line; the
        // promise lets each point slide to where the prediction lands (the
        // lattice's error across the line stays: measured 0.61 of the
        // rounded points' bits).
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let tol = 0.1;
        let half = 2.0 * tol / 5f64.sqrt();
        let dir = glam::DVec3::new(0.6, -0.48, 0.64).normalize();
        let mut s = 0.0;
        let pts: Vec<glam::DVec3> = (0..200)
            .map(|_| {
                s += tol * rng.gen_range(3.0..5.0);
                glam::DVec3::new(1.0, 2.0, 3.0) + dir * s
            })
            .collect();
        let rounded: Vec<[i64; 3]> = pts.iter().map(|&p| bcc_nearest(p, half).unwrap()).collect();
        let first = rounded[0];
        let g = slid(&pts, half, tol, first);
        let (slid, near) = (total_cost(&g), total_cost(&rounded));
        assert!(slid < 0.7 * near, "slid {slid} bits, rounded {near}");
        let out: Vec<glam::DVec3> = g.iter().map(|&k| bcc_point(k, half)).collect();
        assert!(crate::metrics::hausdorff(&pts, &out).unwrap() <= tol);
    }

    #[test]
    fn a_wider_beam_finds_cheaper_points_within_the_promise() {
        // Noisy curls (a helix of radius 20 T sampled every 6 T, jittered
        // by T/2): keeping four partial choices instead of one costs fewer
        // bits in total over the trials, every curve within the tolerance,
        // and the first point stays.
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let tol = 0.1;
        let half = 2.0 * tol / 5f64.sqrt() * (1.0 - 1e-9);
        let (mut greedy, mut wide) = (0.0, 0.0);
        for _ in 0..40 {
            let phase: f64 = rng.gen_range(0.0..6.0);
            let pts: Vec<glam::DVec3> = (0..80)
                .map(|k| {
                    let s = phase + k as f64 * 0.3;
                    glam::DVec3::new(2.0 * s.cos(), 2.0 * s.sin(), 0.5 * s)
                        + glam::DVec3::new(
                            rng.gen_range(-0.03..0.03),
                            rng.gen_range(-0.03..0.03),
                            rng.gen_range(-0.03..0.03),
                        )
                })
                .collect();
            let first = bcc_nearest(pts[0], half).unwrap();
            let search = |beam| Search { beam, reach: 3.0 };
            let (g1, g4) = (
                slide_second_order(&pts, half, tol, first, search(1), false).0,
                slide_second_order(&pts, half, tol, first, search(4), false).0,
            );
            assert_eq!(g4[0], first);
            let out: Vec<glam::DVec3> = g4.iter().map(|&k| bcc_point(k, half)).collect();
            assert!(crate::metrics::hausdorff(&pts, &out).unwrap() <= tol);
            greedy += total_cost(&g1);
            wide += total_cost(&g4);
        }
        assert!(wide < 0.97 * greedy, "beam 4: {wide} bits, greedy {greedy}");
    }
}
