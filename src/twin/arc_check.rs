//! Twin of `shaders/arc_check.wgsl`: the codec's two-sided acceptance test
//! (`src/codec/check.rs`) for one candidate arc, decided with a band.
//!
//! A candidate is a circular arc (start `q`, unit tangent `t`, unit normal
//! `n` towards the centre, curvature `κ`, end `e`) cut into `N` equal pieces
//! of arc length `h`, as the decoder cuts it (`Arc` of `src/codec/predict.rs`):
//! sample `k` is `q` for `k = 0`, `e` for `k = N`, and otherwise
//!
//! ```text
//!   q + s·sinc(φ/2)·cos(φ/2)·t + s·(φ/2)·sinc²(φ/2)·n,   s = k·h, φ = κs
//! ```
//!
//! (`sin φ/κ` and `(1 − cos φ)/κ` written without a division by `κ`, so
//! that a straight or nearly straight arc needs no special case). The test
//! is the encoder's: every covered input vertex within `√tol²` of the
//! sample polyline, and every sample but the first within `√tol²` of the
//! input window's polyline. The CPU reference accepts a vertex iff its
//! exact distance (the minimum over all segments) is `≤ tol²`; here a
//! vertex is *surely in* when the nearest-segment walk already finds a
//! segment within `tol²_lo`, *surely out* when the exact minimum exceeds
//! `tol²_hi`, and *unsure* in between. With `tol²_lo = tol² − η` and
//! `tol²_hi = tol² + η`, `η` bounding the difference between these
//! distances and the reference's ([`band`]), a sure verdict is the
//! reference's verdict; an unsure one is left to the reference. So the
//! encoder, whichever backend checks, accepts exactly what the CPU accepts
//! and writes byte-identical containers.
//!
//! Coordinates are relative to an origin per curve (its first input
//! point), so that `f32` loses nothing to the curve's distance from the
//! world origin.

use super::math::sincos;
use super::{r, Real};

/// Reals per candidate: start (3), tangent (3), normal (3), end (3), `κ`,
/// piece length `h`, `tol²_lo`, `tol²_hi`.
pub const IN_STRIDE: usize = 16;
pub const IN_START: usize = 0;
pub const IN_TANGENT: usize = 3;
pub const IN_NORMAL: usize = 6;
pub const IN_END: usize = 9;
pub const IN_KAPPA: usize = 12;
pub const IN_STEP: usize = 13;
pub const IN_TOL_LO: usize = 14;
pub const IN_TOL_HI: usize = 15;

/// `u32`s per candidate: pieces `N`, first and last covered vertex, first
/// and last vertex of the window (indices into the flat points buffer,
/// inclusive), and three unused.
pub const IDX_STRIDE: usize = 8;
pub const IDX_PIECES: usize = 0;
pub const IDX_COVER_FIRST: usize = 1;
pub const IDX_COVER_LAST: usize = 2;
pub const IDX_WINDOW_FIRST: usize = 3;
pub const IDX_WINDOW_LAST: usize = 4;

/// Verdicts.
pub const PASS: u32 = 0;
pub const FAIL: u32 = 1;
pub const UNSURE: u32 = 2;

/// The band `η` (in squared distance) around `tol²` within which a verdict
/// computed in precision `R` may differ from the `f64` reference's, for a
/// candidate whose arc has length `length` and `pieces` pieces, whose
/// coordinates (relative to the curve's origin) are at most `radius` in
/// size, at acceptance distance `tol`.
///
/// A coordinate converted to `R` is off by `ε_R·radius/2`; a sample by a
/// few `ε_R·(radius + length)` more (the sinc form and `sincos` are within
/// a few ulp; [`crate::twin::math`]); the reference's own samples come from
/// an angle-addition recurrence that drifts by about `k·ε₆₄` of the radius
/// per step; and a squared distance `|w − d·t|²` is formed with a
/// cancellation of order `ε_R·|w|`, `|w| ≤ radius + length`. With `E` the
/// sum of these (each with a factor of 16 or more to spare), two distances
/// to a segment within `tol + 2E` differ by at most
/// `η = 4E·tol + 4E² + 8ε_R·tol²` in their squares. The test
/// `arc_check_band_covers_the_reference` checks the verdicts against the
/// reference over many random candidates in both precisions.
pub fn band<R: Real>(tol: f64, radius: f64, length: f64, pieces: usize) -> f64 {
    let eps = R::EPSILON.to_f64();
    let e = 64.0 * eps * (radius + length) + 16.0 * f64::EPSILON * pieces as f64 * length;
    4.0 * e * tol + 4.0 * e * e + 8.0 * eps * tol * tol
}

#[inline]
fn v3<R: Real>(a: &[R], i: usize) -> [R; 3] {
    [a[i], a[i + 1], a[i + 2]]
}

#[inline]
fn sub<R: Real>(a: [R; 3], b: [R; 3]) -> [R; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot<R: Real>(a: [R; 3], b: [R; 3]) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Squared distance from `p` to the segment `[a, b]` (as
/// `dist2_to_segment` of `src/codec/check.rs`).
#[inline]
pub fn dist2_to_segment<R: Real>(p: [R; 3], a: [R; 3], b: [R; 3]) -> R {
    let d = sub(b, a);
    let dd = dot(d, d);
    let w = sub(p, a);
    let mut t = R::zero();
    if dd > R::zero() {
        t = (dot(w, d) / dd).max(R::zero()).min(R::one());
    }
    let x = [w[0] - d[0] * t, w[1] - d[1] * t, w[2] - d[2] * t];
    dot(x, x)
}

/// The arc of one candidate.
struct ArcIn<R> {
    start: [R; 3],
    tangent: [R; 3],
    normal: [R; 3],
    end: [R; 3],
    kappa: R,
    step: R,
    pieces: u32,
}

impl<R: Real> ArcIn<R> {
    fn sample(&self, k: u32) -> [R; 3] {
        if k == 0 {
            return self.start;
        }
        if k >= self.pieces {
            return self.end;
        }
        let s = self.step * r::<R>(k as f64);
        let x = r::<R>(0.5) * self.kappa * s;
        let (sh, ch) = sincos(x);
        let sinc_half = if x.abs() < r(1e-4) {
            let x2 = x * x;
            R::one() - x2 / r(6.0) * (R::one() - x2 / r(20.0))
        } else {
            sh / x
        };
        let along = s * sinc_half * ch;
        let across = s * x * sinc_half * sinc_half;
        [0, 1, 2].map(|j| self.start[j] + self.tangent[j] * along + self.normal[j] * across)
    }
}

/// Where a point stands against a polyline: sure in, sure out, unsure.
/// `near` carries the nearest segment from the previous point (the walk);
/// `segs` segments, `seg(k, p)` the squared distance to segment `k`.
#[inline]
fn classify<R: Real>(
    p: [R; 3],
    segs: u32,
    near: &mut u32,
    lo: R,
    hi: R,
    seg: impl Fn(u32, [R; 3]) -> R,
) -> u32 {
    let mut best = seg(*near, p);
    while *near + 1 < segs {
        let d = seg(*near + 1, p);
        if d > best {
            break;
        }
        best = d;
        *near += 1;
    }
    if best <= lo {
        return PASS;
    }
    for k in 0..segs {
        let d = seg(k, p);
        if d < best {
            best = d;
            *near = k;
        }
    }
    verdict_of(best, lo, hi)
}

/// PASS at or below `lo`, FAIL above `hi` (finite: an overflow is never a
/// sure fail), UNSURE between.
#[inline]
fn verdict_of<R: Real>(best: R, lo: R, hi: R) -> u32 {
    if best <= lo {
        PASS
    } else if best > hi && best.is_finite() {
        FAIL
    } else {
        UNSURE
    }
}

/// The verdict on one candidate: `rec` its reals, `idx` its indices,
/// `points` the flat points buffer (xyz per point).
pub fn arc_check<R: Real>(rec: &[R], idx: &[u32], points: &[R]) -> u32 {
    let arc = ArcIn {
        start: v3(rec, IN_START),
        tangent: v3(rec, IN_TANGENT),
        normal: v3(rec, IN_NORMAL),
        end: v3(rec, IN_END),
        kappa: rec[IN_KAPPA],
        step: rec[IN_STEP],
        pieces: idx[IDX_PIECES].max(1),
    };
    let (lo, hi) = (rec[IN_TOL_LO], rec[IN_TOL_HI]);
    let point = |i: u32| v3(points, 3 * i as usize);
    let mut verdict = PASS;
    // Covered input vertices against the sample polyline.
    let mut near = 0u32;
    for i in idx[IDX_COVER_FIRST]..=idx[IDX_COVER_LAST] {
        let v = classify(point(i), arc.pieces, &mut near, lo, hi, |k, p| {
            dist2_to_segment(p, arc.sample(k), arc.sample(k + 1))
        });
        if v == FAIL {
            return FAIL;
        }
        verdict = verdict.max(v);
    }
    // Samples (all but the start) against the input window.
    let (w0, w1) = (idx[IDX_WINDOW_FIRST], idx[IDX_WINDOW_LAST]);
    let segs = w1 - w0;
    let mut near = 0u32;
    for k in 1..=arc.pieces {
        let q = arc.sample(k);
        let v = if segs == 0 {
            let d = sub(q, point(w0));
            verdict_of(dot(d, d), lo, hi)
        } else {
            classify(q, segs, &mut near, lo, hi, |k, p| {
                dist2_to_segment(p, point(w0 + k), point(w0 + k + 1))
            })
        };
        if v == FAIL {
            return FAIL;
        }
        verdict = verdict.max(v);
    }
    verdict
}
