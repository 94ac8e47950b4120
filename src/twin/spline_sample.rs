//! Twin of `shaders/spline_sample.wgsl`: equal-arc-length sampling of many
//! piecewise cubic Bézier splines at once, arc length included — the
//! GPU does the quadrature from the control points, it is not handed the
//! `f64` reference's table.
//!
//! Three entry points, run one after another over the same buffers:
//!
//! 1. [`seg_table`], one invocation per cubic segment (all segments of all
//!    splines of a chunk): a fixed table of [`FINE`] equal-width panels in
//!    `t`, each integrated with the 8-point Gauss–Legendre rule, stored as
//!    cumulative lengths from the segment start. The fine panels are the
//!    halves of [`COARSE`] panels; `|GL(coarse) − GL(half) − GL(half)|`
//!    estimates the coarse panel's error (as in the reference's adaptive
//!    refinement), and a segment whose estimate exceeds
//!    [`QUAD_TOL`]`·ε·(segment length)/COARSE` on any panel (beyond a
//!    rounding floor of `8ε` of the panel) is *flagged*: near-cusps, where
//!    `|B'|` has a kink and a fixed table cannot reach working precision.
//!    The host samples flagged splines with the `f64` reference instead.
//! 2. [`prefix`], one invocation per spline piece: the running sum of the
//!    segment lengths (the end of each segment from the spline start) and
//!    the spline's length and flag. Sequential sums of non-negative terms:
//!    monotone, and exact across zero-length segments, which the location
//!    search relies on.
//! 3. [`sample`], one invocation per output sample (ragged: a spline of 10
//!    samples and one of 10,000 share a dispatch): find the piece by binary
//!    search in the output offsets, `s = L·(j·(1/N))`, the segment by binary
//!    search in the cumulative ends (skipping zero-length segments), the
//!    fine panel by binary search, then `t` by the reference's safeguarded
//!    Newton bracketed by the panel, and the point and unit tangent (the
//!    rule of [`crate::spline::CubicBez::unit_tangent`] where `B'` vanishes).
//!
//! Precision split. Each segment is handed over *relative to its own start
//! point* and divided by a per-spline power of two `S` (the largest leg,
//! rounded up), both in `f64` on the host: the kernel's numbers are `O(1)`,
//! a segment `10⁻⁶` long keeps its shape to working precision next to one
//! of length 1, far-away coordinates cost nothing, and squares neither
//! overflow nor underflow in `f32`. Outputs are in these units: the host
//! forms `p₀ + S·offset` in `f64`. Arc lengths are relative to the spline
//! start, so positions along the curve are accurate to a few `ε·L` (the
//! resolution of `s` itself), independent of where the spline lies.
//!
//! Buffer layouts (`real` = `R`):
//! * segments: [`SEG_STRIDE`] reals, `P₁ − P₀, P₂ − P₀, P₃ − P₀` over `S`;
//! * table: [`TABLE_STRIDE`] reals per segment, cumulative fine-panel
//!   lengths `0..FINE` (the last is the segment length), the flag at
//!   [`T_FLAG`] (pass 1), the cumulative end from the spline start at
//!   [`T_CUM_END`] (pass 2);
//! * pieces: [`PIECE_STRIDE`] `u32`, see the `P_*` constants;
//! * spline scratch: [`SPL_STRIDE`] reals per piece, length and flag;
//! * output: [`OUT_STRIDE`] reals per sample, see the `OUT_*` constants.

// Digits beyond f64 are kept so the constants can be checked against tables.
#![allow(clippy::excessive_precision)]
// `!(x <= y)` is deliberate: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{r, Real};

/// Coarse panels per segment (the error estimate's panels).
pub const COARSE: usize = 16;
/// Fine panels per segment: the halves of the coarse ones (the table).
pub const FINE: usize = 2 * COARSE;
/// Accepted coarse-panel error estimate, in units of `ε` times the
/// segment's length over [`COARSE`] (so at most `QUAD_TOL·ε` of the
/// segment's length per segment, summed over panels).
pub const QUAD_TOL: f64 = 16.0;
/// Rounding floor of the estimate, in units of `ε` of the panel's length:
/// below it the estimate is noise.
pub const QUAD_FLOOR: f64 = 8.0;

/// Reals per segment record: `P₁ − P₀, P₂ − P₀, P₃ − P₀` (scaled).
pub const SEG_STRIDE: usize = 9;
/// Reals per segment table entry.
pub const TABLE_STRIDE: usize = FINE + 2;
/// Table index of the accuracy flag (0 or 1).
pub const T_FLAG: usize = FINE;
/// Table index of the cumulative length at the segment's end.
pub const T_CUM_END: usize = FINE + 1;

/// `u32`s per piece (a run of consecutive samples of one spline).
pub const PIECE_STRIDE: usize = 6;
/// First segment of the spline (chunk-local index).
pub const P_SEG_FIRST: usize = 0;
/// Number of segments `k ≥ 1`.
pub const P_SEG_COUNT: usize = 1;
/// First output record of the piece (chunk-local).
pub const P_OUT_FIRST: usize = 2;
/// Number of output records of the piece.
pub const P_OUT_COUNT: usize = 3;
/// Elements `N ≥ 1` of the spline (samples `j = 0..=N`).
pub const P_N: usize = 4;
/// Sample index `j` of the piece's first output record.
pub const P_J_FIRST: usize = 5;

/// Reals per piece in the spline scratch buffer: length, flag.
pub const SPL_STRIDE: usize = 2;

/// Reals per output record.
pub const OUT_STRIDE: usize = 9;
/// Nonzero: the spline was flagged (or this sample is not finite).
pub const OUT_FLAG: usize = 0;
/// Segment index within the spline (exact: `k < 2²⁴`).
pub const OUT_SEG: usize = 1;
/// Parameter `t` in the segment.
pub const OUT_T: usize = 2;
/// `(B(t) − P₀)/S`, 3 reals.
pub const OUT_POINT: usize = 3;
/// Unit tangent, 3 reals.
pub const OUT_TANGENT: usize = 6;

/// Newton stops once its step (in `t`) is below this many `ε`.
pub const NEWTON_STEP_EPS: f64 = 32.0;
/// Iteration cap of the safeguarded Newton solve (bisection alone halves a
/// fine panel to `ε` in well under this).
pub const NEWTON_MAX: u32 = 64;
/// Noise multiple of [`crate::spline::CubicBez::unit_tangent`] (`64ε`).
pub const NOISE_EPS: f64 = 64.0;
/// Its end snap in `t`.
pub const END_SNAP: f64 = 1e-6;

/// Abscissae `xᵢ > 0` of the 8-point rule on `[−1, 1]` (as `spline::gauss`).
pub const GL_X: [f64; 4] = [
    0.183_434_642_495_649_804_939_476_142_360_2,
    0.525_532_409_916_328_985_817_739_049_189_3,
    0.796_666_477_413_626_739_591_553_936_475_8,
    0.960_289_856_497_536_231_683_560_868_569_5,
];
/// Weights matching [`GL_X`].
pub const GL_W: [f64; 4] = [
    0.362_683_783_378_361_982_965_150_449_277_2,
    0.313_706_645_877_887_287_337_962_201_986_6,
    0.222_381_034_453_374_470_544_355_994_426_2,
    0.101_228_536_290_376_259_152_531_354_309_9,
];

type V3<R> = [R; 3];

#[inline]
fn add<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
fn sub<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
fn mul<R: Real>(s: R, a: V3<R>) -> V3<R> {
    [s * a[0], s * a[1], s * a[2]]
}
#[inline]
fn norm<R: Real>(a: V3<R>) -> R {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
/// `a(1 − t) + b t` (glam's `lerp`: exact at both ends).
#[inline]
fn lerp<R: Real>(a: V3<R>, b: V3<R>, t: R) -> V3<R> {
    let u = R::one() - t;
    [
        a[0] * u + b[0] * t,
        a[1] * u + b[1] * t,
        a[2] * u + b[2] * t,
    ]
}
#[inline]
fn max_abs<R: Real>(a: V3<R>) -> R {
    a[0].abs().max(a[1].abs()).max(a[2].abs())
}
#[inline]
fn is_zero<R: Real>(a: V3<R>) -> bool {
    a[0] == R::zero() && a[1] == R::zero() && a[2] == R::zero()
}
#[inline]
fn normalize<R: Real>(a: V3<R>) -> V3<R> {
    let l = norm(a);
    [a[0] / l, a[1] / l, a[2] / l]
}

/// One segment relative to its start `P₀ = 0`.
#[derive(Clone, Copy, Debug)]
pub struct Seg<R: Real> {
    pub p1: V3<R>,
    pub p2: V3<R>,
    pub p3: V3<R>,
}

impl<R: Real> Seg<R> {
    /// From a segment record ([`SEG_STRIDE`] reals).
    #[inline]
    pub fn from_record(rec: &[R]) -> Self {
        Seg {
            p1: [rec[0], rec[1], rec[2]],
            p2: [rec[3], rec[4], rec[5]],
            p3: [rec[6], rec[7], rec[8]],
        }
    }

    /// Legs `P₁ − P₀, P₂ − P₁, P₃ − P₂`.
    #[inline]
    fn legs(&self) -> (V3<R>, V3<R>, V3<R>) {
        (self.p1, sub(self.p2, self.p1), sub(self.p3, self.p2))
    }

    #[inline]
    pub fn is_point(&self) -> bool {
        is_zero(self.p1) && is_zero(self.p2) && is_zero(self.p3)
    }

    /// `B(t) − P₀` by de Casteljau.
    #[inline]
    pub fn eval(&self, t: R) -> V3<R> {
        let z = [R::zero(); 3];
        let a = lerp(z, self.p1, t);
        let b = lerp(self.p1, self.p2, t);
        let c = lerp(self.p2, self.p3, t);
        let d = lerp(a, b, t);
        let e = lerp(b, c, t);
        lerp(d, e, t)
    }

    /// `B'(t)` in Bernstein form (as `CubicBez::deriv`).
    #[inline]
    fn deriv(&self, t: R) -> V3<R> {
        let (d0, d1, d2) = self.legs();
        let a = lerp(d0, d1, t);
        let b = lerp(d1, d2, t);
        mul(r(3.0), lerp(a, b, t))
    }

    /// `B''(t)` (as `CubicBez::deriv2`).
    #[inline]
    fn deriv2(&self, t: R) -> V3<R> {
        let z = [R::zero(); 3];
        let a = add(sub(self.p2, mul(r(2.0), self.p1)), z);
        let b = add(sub(self.p3, mul(r(2.0), self.p2)), self.p1);
        mul(r(6.0), lerp(a, b, t))
    }

    /// `B'''` (as `CubicBez::deriv3`).
    #[inline]
    fn deriv3(&self) -> V3<R> {
        let v = add(sub(self.p3, mul(r(3.0), self.p2)), mul(r(3.0), self.p1));
        mul(r(6.0), v)
    }

    /// Unit forward tangent at `t ∈ [0, 1]`, `None` for a point: the rule
    /// of [`crate::spline::CubicBez::unit_tangent`] with its noise threshold
    /// in this precision and these (relative) coordinates.
    pub fn unit_tangent(&self, t: R) -> Option<V3<R>> {
        if self.is_point() {
            return None;
        }
        let (d0, d1, d2) = self.legs();
        let leg = norm(d0).max(norm(d1)).max(norm(d2));
        let mag = max_abs(self.p1).max(max_abs(self.p2)).max(max_abs(self.p3));
        let thr = r::<R>(NOISE_EPS) * R::EPSILON * (leg + mag);
        let v = self.deriv(t);
        if norm(v) > thr {
            return Some(normalize(v));
        }
        let at_end =
            t == R::one() || (R::one() - t <= r(END_SNAP) && norm(self.deriv(R::one())) <= thr);
        let d3 = self.deriv3();
        if at_end {
            let v2 = self.deriv2(R::one());
            if norm(v2) > r::<R>(4.0) * thr {
                return Some(mul(-R::one(), normalize(v2)));
            }
        } else {
            let v2 = self.deriv2(t);
            if norm(v2) > r::<R>(4.0) * thr {
                return Some(normalize(v2));
            }
        }
        if norm(d3) > r::<R>(8.0) * thr {
            return Some(normalize(d3));
        }
        if norm(self.p3) > R::zero() {
            return Some(normalize(self.p3));
        }
        for leg in [d0, d1, d2] {
            if norm(leg) > R::zero() {
                return Some(normalize(leg));
            }
        }
        None
    }
}

/// `B'(t) = c₀ + c₁t + c₂t²` in power form (as the reference's `Speed`).
#[derive(Clone, Copy, Debug)]
pub struct Speed<R: Real> {
    c0: V3<R>,
    c1: V3<R>,
    c2: V3<R>,
}

impl<R: Real> Speed<R> {
    #[inline]
    pub fn new(s: &Seg<R>) -> Self {
        let (d0, d1, d2) = s.legs();
        Speed {
            c0: mul(r(3.0), d0),
            c1: mul(r(6.0), sub(d1, d0)),
            c2: mul(r(3.0), add(sub(d0, mul(r(2.0), d1)), d2)),
        }
    }

    /// `|B'(t)|`.
    #[inline]
    pub fn at(&self, t: R) -> R {
        let c = self;
        let v = [
            c.c0[0] + t * (c.c1[0] + t * c.c2[0]),
            c.c0[1] + t * (c.c1[1] + t * c.c2[1]),
            c.c0[2] + t * (c.c1[2] + t * c.c2[2]),
        ];
        norm(v)
    }

    /// `|B''(t)|`.
    #[inline]
    pub fn accel(&self, t: R) -> R {
        let t2 = r::<R>(2.0) * t;
        norm(add(self.c1, mul(t2, self.c2)))
    }

    /// `∫ₐᵇ |B'|` by one 8-point Gauss–Legendre panel.
    #[inline]
    pub fn gl8(&self, a: R, b: R) -> R {
        let mid = r::<R>(0.5) * (a + b);
        let half = r::<R>(0.5) * (b - a);
        let mut sum = R::zero();
        for i in 0..4 {
            let dx = half * r(GL_X[i]);
            sum += r::<R>(GL_W[i]) * (self.at(mid - dx) + self.at(mid + dx));
        }
        sum * half
    }
}

/// Pass 1 on one segment record: the first `FINE + 1` entries of its table
/// (cumulative fine-panel lengths, then the flag).
pub fn seg_table<R: Real>(rec: &[R]) -> [R; FINE + 1] {
    let mut out = [R::zero(); FINE + 1];
    let seg = Seg::from_record(rec);
    if seg.is_point() {
        return out;
    }
    let sp = Speed::new(&seg);
    let inv = r::<R>(1.0 / COARSE as f64);
    let mut whole = [R::zero(); COARSE];
    let mut est = R::zero();
    for (c, w) in whole.iter_mut().enumerate() {
        let a = r::<R>(c as f64) * inv;
        let b = r::<R>((c + 1) as f64) * inv;
        *w = sp.gl8(a, b);
        est += *w;
    }
    let tol = r::<R>(QUAD_TOL) * R::EPSILON * est * inv;
    let floor = r::<R>(QUAD_FLOOR) * R::EPSILON;
    let mut flag = R::zero();
    let mut acc = R::zero();
    for (c, &w) in whole.iter().enumerate() {
        let a = r::<R>(c as f64) * inv;
        let b = r::<R>((c + 1) as f64) * inv;
        let m = r::<R>(0.5) * (a + b);
        let left = sp.gl8(a, m);
        let right = sp.gl8(m, b);
        let both = left + right;
        let err = (w - both).abs();
        if !(err <= tol.max(floor * both)) {
            flag = R::one();
        }
        acc += left;
        out[2 * c] = acc;
        acc += right;
        out[2 * c + 1] = acc;
    }
    if !acc.is_finite() {
        flag = R::one();
    }
    out[T_FLAG] = flag;
    out
}

/// Pass 2 on one piece: writes `T_CUM_END` of the piece's segments in
/// `table` and returns `(length, flag)`.
pub fn prefix<R: Real>(piece: &[u32], table: &mut [R]) -> [R; SPL_STRIDE] {
    let first = piece[P_SEG_FIRST] as usize;
    let count = piece[P_SEG_COUNT] as usize;
    let mut acc = R::zero();
    let mut flag = R::zero();
    for i in first..first + count {
        let row = &mut table[i * TABLE_STRIDE..(i + 1) * TABLE_STRIDE];
        acc += row[FINE - 1];
        row[T_CUM_END] = acc;
        flag = flag.max(row[T_FLAG]);
    }
    if !acc.is_finite() || !(acc > R::zero()) {
        flag = R::one();
    }
    [acc, flag]
}

/// Initial guess of the inverse on a panel (the reference's
/// `initial_fraction`: linear speed model between the end speeds).
#[inline]
pub fn initial_fraction<R: Real>(v0: R, v1: R, f: R) -> R {
    let c = f * (v0 + v1);
    let den = v0 + ((R::one() - f) * v0 * v0 + f * v1 * v1).sqrt();
    let u = c / den;
    if u >= R::zero() && u <= R::one() {
        u
    } else {
        f
    }
}

/// `t` in fine panel `q` of the segment with table row `row` such that the
/// length from the segment start is `local` (the reference's
/// `solve_panel`, with the panel ends `q/FINE`, `(q+1)/FINE`).
pub fn solve_panel<R: Real>(sp: &Speed<R>, row: &[R], q: usize, local: R) -> R {
    if q >= FINE {
        return R::one();
    }
    let inv = r::<R>(1.0 / FINE as f64);
    let t0 = r::<R>(q as f64) * inv;
    let t1 = r::<R>((q + 1) as f64) * inv;
    let s0 = if q == 0 { R::zero() } else { row[q - 1] };
    let target = local - s0;
    let span = row[q] - s0;
    if !(target > R::zero()) {
        return t0;
    }
    if !(target < span) {
        return t1;
    }
    let (mut lo, mut hi) = (t0, t1);
    let mut t = lo + (hi - lo) * initial_fraction(sp.at(lo), sp.at(hi), target / span);
    let step_tol = r::<R>(NEWTON_STEP_EPS) * R::EPSILON;
    for _ in 0..NEWTON_MAX {
        let g = sp.gl8(t0, t) - target;
        if g == R::zero() {
            return t;
        }
        if g > R::zero() {
            hi = t;
        } else {
            lo = t;
        }
        let speed = sp.at(t);
        let step = g / speed;
        let tn = t - step;
        let a = step.abs();
        if a <= step_tol || (a <= r(1e-5) && a * a * sp.accel(t) <= step_tol * r::<R>(2.0) * speed)
        {
            return tn.max(lo).min(hi);
        }
        if tn > lo && tn < hi {
            t = tn;
        } else {
            let mid = r::<R>(0.5) * (lo + hi);
            if mid <= lo || mid >= hi {
                return mid;
            }
            t = mid;
        }
    }
    t
}

/// Chunk-local index of the piece holding output record `i`: the last piece
/// whose `P_OUT_FIRST ≤ i`.
pub fn find_piece(pieces: &[u32], i: u32) -> usize {
    let n = pieces.len() / PIECE_STRIDE;
    let (mut lo, mut hi) = (0usize, n);
    // Invariant: piece lo starts at or before i, piece hi after (or n).
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if pieces[mid * PIECE_STRIDE + P_OUT_FIRST] <= i {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Pass 3: output record `i`.
pub fn sample<R: Real>(
    i: u32,
    pieces: &[u32],
    segs: &[R],
    table: &[R],
    spl: &[R],
) -> [R; OUT_STRIDE] {
    let p = find_piece(pieces, i);
    let piece = &pieces[p * PIECE_STRIDE..(p + 1) * PIECE_STRIDE];
    let first = piece[P_SEG_FIRST] as usize;
    let k = piece[P_SEG_COUNT] as usize;
    let n = piece[P_N];
    let j = piece[P_J_FIRST] + (i - piece[P_OUT_FIRST]);
    let total = spl[p * SPL_STRIDE];
    let mut flag = spl[p * SPL_STRIDE + 1];
    let cum_end = |l: usize| table[(first + l) * TABLE_STRIDE + T_CUM_END];
    let (seg, t);
    if j >= n {
        // The end: the last segment of positive length, i.e. the last one
        // that starts before the total.
        let (mut lo, mut hi) = (0usize, k - 1);
        while lo < hi {
            let mid = (lo + hi).div_ceil(2);
            if cum_end(mid - 1) < total {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        seg = lo;
        t = R::one();
    } else {
        let s = total * (r::<R>(j as f64) * (R::one() / r::<R>(n as f64)));
        // First segment whose end lies beyond s (skips zero-length ones).
        let (mut lo, mut hi) = (0usize, k - 1);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if cum_end(mid) > s {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        seg = lo;
        let start = if seg == 0 {
            R::zero()
        } else {
            cum_end(seg - 1)
        };
        let local = s - start;
        let row = &table[(first + seg) * TABLE_STRIDE..(first + seg + 1) * TABLE_STRIDE];
        // Fine panel: the number of table entries ≤ local.
        let (mut lo, mut hi) = (0usize, FINE);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if row[mid] <= local {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        let sg = Seg::from_record(&segs[(first + seg) * SEG_STRIDE..]);
        t = solve_panel(&Speed::new(&sg), row, lo, local);
    }
    let sg = Seg::from_record(&segs[(first + seg) * SEG_STRIDE..]);
    let pt = sg.eval(t);
    let tan = sg.unit_tangent(t).unwrap_or([R::zero(); 3]);
    let mut out = [R::zero(); OUT_STRIDE];
    out[OUT_SEG] = r(seg as f64);
    out[OUT_T] = t;
    out[OUT_POINT..OUT_POINT + 3].copy_from_slice(&pt);
    out[OUT_TANGENT..OUT_TANGENT + 3].copy_from_slice(&tan);
    if !out.iter().all(|x| x.is_finite()) || norm(tan) == R::zero() {
        flag = R::one();
    }
    out[OUT_FLAG] = flag;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spline::BezierSpline;
    use glam::DVec3;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    /// One spline as a one-piece chunk, run through the three passes.
    /// Returns per sample `(flag, seg, t, point, tangent)` in `f64`, the
    /// point back in absolute coordinates.
    fn run<R: Real>(s: &BezierSpline, n: usize) -> Vec<(f64, usize, f64, DVec3, DVec3)> {
        let segs_f64 = s.segments();
        let scale = segs_f64
            .iter()
            .map(|c| c.leg_scale())
            .fold(0.0, f64::max)
            .log2()
            .ceil()
            .exp2();
        let mut segs = Vec::new();
        for c in segs_f64 {
            for p in [c.p1, c.p2, c.p3] {
                let d = (p - c.p0) / scale;
                segs.extend([d.x, d.y, d.z].map(R::from_f64));
            }
        }
        let k = segs_f64.len();
        let pieces = [0, k as u32, 0, (n + 1) as u32, n as u32, 0];
        let mut table = vec![R::zero(); k * TABLE_STRIDE];
        for i in 0..k {
            let t = seg_table(&segs[i * SEG_STRIDE..(i + 1) * SEG_STRIDE]);
            table[i * TABLE_STRIDE..i * TABLE_STRIDE + FINE + 1].copy_from_slice(&t);
        }
        let spl = prefix(&pieces, &mut table);
        (0..=n as u32)
            .map(|i| {
                let o = sample(i, &pieces, &segs, &table, &spl);
                let g = |j: usize| DVec3::new(o[j].to_f64(), o[j + 1].to_f64(), o[j + 2].to_f64());
                let seg = o[OUT_SEG].to_f64() as usize;
                (
                    o[OUT_FLAG].to_f64(),
                    seg,
                    o[OUT_T].to_f64(),
                    segs_f64[seg].p0 + scale * g(OUT_POINT),
                    g(OUT_TANGENT),
                )
            })
            .collect()
    }

    fn tight(cps: &[DVec3]) -> BezierSpline {
        // Reference tables at their tightest (16ε of L).
        BezierSpline::from_control_points_with_accuracy(cps, 1e-300).unwrap()
    }

    fn smooth_cases() -> Vec<BezierSpline> {
        let k = 4.0 / 3.0 * (std::f64::consts::PI / 8.0).tan();
        let mut out = vec![
            // quarter circle far from the origin
            tight(&[
                v(1001.0, 0.0, 5.0),
                v(1001.0, k, 5.0),
                v(1000.0 + k, 1.0, 5.0),
                v(1000.0, 1.0, 5.0),
            ]),
            // collinear, evenly and unevenly spaced control points
            tight(&[
                v(0.0, 0.0, 0.0),
                v(1.0, 1.0, 1.0),
                v(2.0, 2.0, 2.0),
                v(3.0, 3.0, 3.0),
            ]),
            tight(&[
                v(0.0, 0.0, 0.0),
                v(0.1, 0.0, 0.0),
                v(2.5, 0.0, 0.0),
                v(3.0, 0.0, 0.0),
            ]),
            // a zero-length segment between two live ones, and at the ends
            tight(&[
                v(0.0, 0.0, 0.0),
                v(0.0, 0.0, 0.0),
                v(0.0, 0.0, 0.0),
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.0, 1.0, 0.0),
                v(2.0, 1.0, 0.5),
                v(2.0, 1.0, 0.5),
                v(2.0, 1.0, 0.5),
                v(2.0, 1.0, 0.5),
                v(3.0, 1.0, 0.0),
                v(3.0, 2.0, 1.0),
                v(4.0, 2.0, 1.0),
                v(4.0, 2.0, 1.0),
                v(4.0, 2.0, 1.0),
                v(4.0, 2.0, 1.0),
            ]),
            // very uneven segment lengths: 1e-6 next to 1
            tight(&[
                v(0.0, 0.0, 0.0),
                v(0.3, 0.1, 0.0),
                v(0.7, 0.1, 0.0),
                v(1.0, 0.0, 0.0),
                v(1.0 + 3e-7, 1e-7, 0.0),
                v(1.0 + 7e-7, 1e-7, 0.0),
                v(1.0 + 1e-6, 0.0, 0.0),
                v(1.3, -0.1, 0.2),
                v(1.7, 0.1, 0.4),
                v(2.0, 0.0, 0.0),
            ]),
        ];
        out.extend(
            crate::synthetic::synthetic_splines(2, 12)
                .into_iter()
                .map(|s| tight(s.control_points())),
        );
        out
    }

    /// Equal spacing measured by the reference: the arc length at the twin's
    /// `(seg, t)` is `jL/N` to within the error budget, ends are the end
    /// control points, and smooth splines are not flagged.
    fn equal_spacing<R: Real>(budget: f64) {
        let eps = R::EPSILON.to_f64();
        for (c, s) in smooth_cases().iter().enumerate() {
            let n = 37;
            let total = s.length();
            let k = s.num_segments() as f64;
            let got = run::<R>(s, n);
            let mut worst = 0.0f64;
            for (j, &(flag, seg, t, p, tan)) in got.iter().enumerate() {
                assert_eq!(flag, 0.0, "case {c} sample {j} flagged");
                let want_s = total * j as f64 / n as f64;
                let err = (s.arclen_at(seg, t) - want_s).abs() / (eps * total);
                worst = worst.max(err);
                assert!(err <= budget + k, "case {c} sample {j}: {err} εL");
                assert!((p - s.eval(seg, t)).length() <= 16.0 * eps * total.max(1.0) + 1e-12);
                assert!((tan.length() - 1.0).abs() < 8.0 * eps);
            }
            eprintln!("{} case {c}: arc length error {worst:.2} εL", R::WGSL);
            // The runner's ends are the control points exactly.
            let full = crate::kernels::spline_sample::sample_twin::<R>(std::slice::from_ref(s), n)
                .unwrap();
            let cps = s.control_points();
            assert_eq!(full[0].points[0], cps[0]);
            assert_eq!(full[0].points[n], cps[cps.len() - 1]);
            assert!(!full[0].fallback);
            let want = s.sample_equal_arclen(n).unwrap();
            assert_eq!(full[0].tangents[0], got[0].4);
            for (j, (p, _)) in want.iter().enumerate() {
                assert!(
                    (full[0].points[j] - *p).length() <= (budget + k + 16.0) * eps * total + 1e-12
                );
            }
        }
    }

    #[test]
    fn equal_spacing_f64() {
        equal_spacing::<f64>(64.0);
    }

    #[test]
    fn equal_spacing_f32() {
        equal_spacing::<f32>(64.0);
    }

    /// `B(t) = ((t − c)², (t − c)³, 0)`: a cusp at `t = c`, in Bézier form.
    fn cusp_at(c: f64) -> BezierSpline {
        // power-form coefficients a₀ + a₁t + a₂t² + a₃t³
        let a0 = v(c * c, -c * c * c, 0.0);
        let a1 = v(-2.0 * c, 3.0 * c * c, 0.0);
        let a2 = v(1.0, -3.0 * c, 0.0);
        let a3 = v(0.0, 1.0, 0.0);
        tight(&[
            a0,
            a0 + a1 / 3.0,
            a0 + 2.0 * a1 / 3.0 + a2 / 3.0,
            a0 + a1 + a2 + a3,
        ])
    }

    #[test]
    fn cusp_is_flagged() {
        // A cusp on a panel boundary (t = 1/2) costs the table nothing: |B'|
        // is smooth on each panel, and the samples are accurate.
        let s = cusp_at(0.5);
        let n = 16;
        for (j, r) in run::<f64>(&s, n).iter().enumerate() {
            assert_eq!(r.0, 0.0);
            let want = s.length() * j as f64 / n as f64;
            assert!((s.arclen_at(r.1, r.2) - want).abs() < 1e-14 * s.length());
        }
        // Inside a panel, |B'| has a kink there, which a fixed table cannot
        // integrate to working precision: flagged.
        let s = cusp_at(0.3);
        assert!(run::<f64>(&s, 10).iter().all(|r| r.0 == 1.0));
        assert!(run::<f32>(&s, 10).iter().all(|r| r.0 == 1.0));
        let full = crate::kernels::spline_sample::sample_twin::<f32>(std::slice::from_ref(&s), 10)
            .unwrap();
        assert!(full[0].fallback);
        let want: (Vec<DVec3>, Vec<DVec3>) = s.sample_equal_arclen(10).unwrap().into_iter().unzip();
        assert_eq!((full[0].points.clone(), full[0].tangents.clone()), want);
    }

    #[test]
    fn tangent_where_the_derivative_vanishes_at_the_ends() {
        // P0 = P1 and P2 = P3: B'(0) = B'(1) = 0, tangents from ±B''.
        let s = tight(&[
            v(0.0, 0.0, 0.0),
            v(0.0, 0.0, 0.0),
            v(1.0, 2.0, 0.0),
            v(1.0, 2.0, 0.0),
        ]);
        for (flag, seg, t, _, tan) in [run::<f64>(&s, 4), run::<f32>(&s, 4)].concat() {
            assert_eq!(flag, 0.0);
            let want = s.unit_tangent(seg, t);
            assert!((tan - want).length() < 1e-5, "t = {t}: {tan} vs {want}");
        }
        let ends = run::<f64>(&s, 4);
        assert!((ends[0].4 - v(1.0, 2.0, 0.0).normalize()).length() < 1e-15);
        assert!((ends[4].4 - v(1.0, 2.0, 0.0).normalize()).length() < 1e-15);
    }

    #[test]
    #[ignore = "measurement: fraction of smooth random segments the table flags"]
    fn flag_rate() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (mut f64s, mut f32s, total) = (0, 0, 20_000);
        for _ in 0..total {
            let mut rec = [0.0f64; SEG_STRIDE];
            rec.iter_mut().for_each(|x| *x = rng.gen_range(-1.0..1.0));
            let r32: Vec<f32> = rec.iter().map(|&x| x as f32).collect();
            f64s += (seg_table(&rec)[T_FLAG] != 0.0) as usize;
            f32s += (seg_table(&r32)[T_FLAG] != 0.0) as usize;
        }
        eprintln!("random segments flagged: f64 {f64s}/{total}, f32 {f32s}/{total}");
        let hair = crate::synthetic::synthetic_splines(50, 20);
        let (mut h64, mut hn) = (0, 0);
        for s in &hair {
            for c in s.segments() {
                let d = [c.p1 - c.p0, c.p2 - c.p0, c.p3 - c.p0];
                let rec: Vec<f64> = d.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
                h64 += (seg_table(&rec)[T_FLAG] != 0.0) as usize;
                hn += 1;
            }
        }
        eprintln!("synthetic hair segments flagged (f64): {h64}/{hn}");
    }
}
