//! Twin of `shaders/frenet_integrate.wgsl`: the Frenet–Serret integration of
//! one 3D Euler spiral per invocation, in the kernel's precision.
//!
//! The integrator is [`crate::euler::FrenetProblem`]'s (its
//! [documentation](crate::euler::FrenetProblem#integration) has the math and
//! the error argument): scaled arc length `u = s/L ∈ [0, 1]`, `N` steps
//! of `h = 1/N`, each two rotations by the closed-form fourth-order Magnus
//! vector `Ω = (ℓ(t₀ + d u_m), ℓ³c/12, ℓ(k₀ + g u_m))`, `ℓ = h/2`,
//! `c = k₀d − t₀g`, `u_m` the half step's midpoint, each applied as the
//! quaternion `r = (cos φ/2, ½ sinc(φ/2) Ω)` (one [`sincos`], never the WGSL
//! built-ins); the position by Simpson's rule on the tangents at the step's
//! start, middle and end, summed with Neumaier's compensation. The same
//! scheme as the reference, so the same truncation error; what differs is
//! the rounding, organised here for `f32` (the reference uses `glam`'s
//! quaternions and renormalises them). The quaternion algebra is written
//! out in the same operation order as the shader.
//!
//! `f32` drift, and what guards it.
//! - The values are `O(1)` by construction: the host hands over the scaled
//!   rates `k₀ = κ₀L`, `g = γL²`, `t₀ = τ₀L`, `d = δL²` (computed in `f64`),
//!   the kernel returns the offset `(x(L) − x₀)/L`, and the host multiplies
//!   by `L` and adds `x₀` in `f64` (so large coordinates and large or tiny
//!   `L` cost no relative precision).
//! - The rotation. Composing `q ⊗ r` and renormalising rounds `q` by `O(ε)`
//!   per rotation, and with small steps these roundings are correlated from
//!   step to step (the state barely moves between them), so the frame
//!   drifts by `≈ 0.2–0.5 ε` per step, linearly in `N` (measured: `f32`,
//!   `N = 4096`, 8e-5). Instead `q` is kept in two words (`hi + lo`) and
//!   updated as `q + q ⊗ (r − 1)` with `cos φ/2 − 1 = −sin²/(1 + cos)`: the
//!   increment is `O(φ)` and computed to relative `O(ε)`, the sum is exact
//!   to the second word, so the drift is `O(ε φ)` per rotation, `O(εΘ)` in
//!   all, `Θ = ∫|ω| du` the total turning. `q` is not renormalised (an exact
//!   rotation keeps `|q|`, and `r − 1` has no `|r| ≠ 1` bias); the frame
//!   columns are divided by `|q|²`.
//! - `u_m = (k + ¼)h`, `(k + ¾)h` are formed from the step index, not
//!   accumulated; the position sum is compensated.
//! - What is left: `O(ε)` per step from the tangents (independent, so
//!   `≈ √N ε` in the position), `O(εΘ)` from the Magnus vectors, and the
//!   rounding of the inputs (`ε/2` relative on the rates moves the end
//!   frame by `≈ εΘ/2`).
//!
//! Record layout (reals). Input, [`IN_STRIDE`]: the rates `k₀, g, t₀, d` at
//! [`IN_RATES`], then the start frame `T₀, N₀, B₀` (3 each) at [`IN_T0`],
//! [`IN_N0`], [`IN_B0`]. The step count is the dispatch's `Params.param`
//! (an `f32`, exact up to [`MAX_STEPS`] = 2²⁴): `N` for the end mode, the
//! steps *per sample interval* for the sampled mode.
//!
//! Output, end mode ([`OUT_STRIDE`]): a status at [`OUT_STATUS`]
//! ([`STATUS_OK`] or [`STATUS_RANGE`]), the scaled offset `(x(L) − x₀)/L` at
//! [`OUT_OFFSET`], the end frame `T, N, B` at [`OUT_T`], [`OUT_N`], [`OUT_B`]
//! (world axes: `F₀` applied in the kernel).
//!
//! Output, sampled mode ([`sampled_out_stride`]`(m)` = `1 + 6m`): the status,
//! then `m` samples at `u = j/(m − 1)` of [`SAMPLE_STRIDE`] reals each, the
//! scaled offset at [`SAMPLE_OFFSET`] and the unit tangent at
//! [`SAMPLE_TANGENT`]: one march of `(m − 1)·steps_per_interval` steps, as
//! [`crate::euler::FrenetProblem::sample`]. In the shader `m` is the
//! compile-time constant `SAMPLES` (0 selects the end mode).
//!
//! A record whose step angle bound ([`step_bound`]) is beyond
//! [`STEP_ANGLE_MAX`] (or not a number) is not integrated: status
//! [`STATUS_RANGE`] and zeros; the host evaluates such problems (and any it
//! rejects itself) with the `f64` reference.

use super::math::sincos;
use super::{r, Real};

/// Reals per input record: `k0, g, t0, d, T0.xyz, N0.xyz, B0.xyz`.
pub const IN_STRIDE: usize = 13;
pub const IN_RATES: usize = 0;
pub const IN_T0: usize = 4;
pub const IN_N0: usize = 7;
pub const IN_B0: usize = 10;

/// Reals per output record in the end mode:
/// `status, offset.xyz, T.xyz, N.xyz, B.xyz`.
pub const OUT_STRIDE: usize = 13;
pub const OUT_STATUS: usize = 0;
pub const OUT_OFFSET: usize = 1;
pub const OUT_T: usize = 4;
pub const OUT_N: usize = 7;
pub const OUT_B: usize = 10;

/// Reals per sample in the sampled mode: `offset.xyz, tangent.xyz`.
pub const SAMPLE_STRIDE: usize = 6;
pub const SAMPLE_OFFSET: usize = 0;
pub const SAMPLE_TANGENT: usize = 3;
/// Index of the first sample in a sampled-mode output record.
pub const OUT_SAMPLES: usize = 1;

/// Reals per output record in the sampled mode with `m` samples.
pub const fn sampled_out_stride(m: usize) -> usize {
    OUT_SAMPLES + SAMPLE_STRIDE * m
}

/// Status: integrated.
pub const STATUS_OK: f64 = 0.0;
/// Status: the step angle bound is beyond [`STEP_ANGLE_MAX`] (or NaN);
/// nothing integrated, outputs zero.
pub const STATUS_RANGE: f64 = 1.0;

/// Largest step angle bound the kernel integrates. [`sincos`] takes `φ/2`
/// and is accurate for `|φ/2| ≤ 64`; a step of 64 rad (10 turns) is useless
/// anyway — accurate results need steps well below 1 rad.
pub const STEP_ANGLE_MAX: f64 = 64.0;

/// Largest step count the `f32` `Params.param` carries exactly.
pub const MAX_STEPS: usize = 1 << 24;

/// Unit quaternion `(w, x, y, z)`.
type Quat<R> = [R; 4];

/// `h(max(|t₀|, |t₀ + d|) + max(|k₀|, |k₀ + g|)) + h³|c|/12`: at least the
/// rotation angle of any step (both of its Magnus rotations together).
#[inline]
pub fn step_bound<R: Real>(k0: R, g: R, t0: R, d: R, h: R) -> R {
    let c = k0 * d - t0 * g;
    h * (t0.abs().max((t0 + d).abs()) + k0.abs().max((k0 + g).abs()))
        + h * h * h / r(12.0) * c.abs()
}

/// Magnus vector over the interval of length `len` centred at `um`.
#[inline]
fn magnus<R: Real>(rates: [R; 4], c: R, um: R, len: R) -> [R; 3] {
    let [k0, g, t0, d] = rates;
    [
        len * (t0 + d * um),
        len * len * len / r(12.0) * c,
        len * (k0 + g * um),
    ]
}

/// `r − 1` for `r = exp(Ω̂)`, the quaternion `(cos φ/2, ½ sinc(φ/2) Ω)`,
/// `φ = |Ω|`: `(cos φ/2 − 1, ½ sinc(φ/2) Ω)` with
/// `cos φ/2 − 1 = −sin²(φ/2)/(1 + cos φ/2)` while `cos φ/2 > 0` (no
/// cancellation: for small `φ` the real part is `≈ −φ²/8`, not a rounded 1).
#[inline]
fn exp_quat_m1<R: Real>(v: [R; 3]) -> Quat<R> {
    let phi = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let x = r::<R>(0.5) * phi;
    let (s, c) = sincos(x);
    let sinc = if x < r(1e-4) {
        let x2 = x * x;
        r::<R>(1.0) - x2 / r(6.0) * (r::<R>(1.0) - x2 / r(20.0))
    } else {
        s / x
    };
    let cm1 = if c > R::zero() {
        -(s * s) / (r::<R>(1.0) + c)
    } else {
        c - r(1.0)
    };
    let a = r::<R>(0.5) * sinc;
    [cm1, a * v[0], a * v[1], a * v[2]]
}

/// Hamilton product `a ⊗ b`.
#[inline]
fn qmul<R: Real>(a: Quat<R>, b: Quat<R>) -> Quat<R> {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

/// The accumulated rotation in two words per component, `hi + lo`, `hi`
/// the rounded value.
#[derive(Clone, Copy)]
struct TwoQuat<R> {
    hi: Quat<R>,
    lo: Quat<R>,
}

/// `q ← q ⊗ r` as `q + q ⊗ (r − 1)`, the increment added in two words
/// (TwoSum, then renormalised so that `hi` is the rounded sum). The
/// increment is `O(φ)`, computed from `hi` to relative `O(ε)`; the sum
/// itself loses nothing, so the rotation drifts by `O(ε φ)` per step, not
/// the `O(ε)` of rounding a product `q ⊗ r` back to working precision.
#[inline]
#[allow(clippy::needless_range_loop)] // component i of four arrays, as in the shader
fn rotate<R: Real>(q: TwoQuat<R>, rm1: Quat<R>) -> TwoQuat<R> {
    let d = qmul(q.hi, rm1);
    let mut out = q;
    for i in 0..4 {
        let (s, x) = (q.hi[i], d[i]);
        let t = s + x;
        let e = if s.abs() >= x.abs() {
            (s - t) + x
        } else {
            (x - t) + s
        };
        let c = q.lo[i] + e;
        let u = t + c;
        out.lo[i] = (t - u) + c;
        out.hi[i] = u;
    }
    out
}

/// First column of the rotation matrix of `q` (any length): the tangent.
#[inline]
fn col_t<R: Real>(q: Quat<R>) -> [R; 3] {
    let [w, x, y, z] = q;
    let (one, two) = (r::<R>(1.0), r::<R>(2.0));
    let n2 = w * w + x * x + y * y + z * z;
    [
        one - two * (y * y + z * z) / n2,
        two * (x * y + w * z) / n2,
        two * (x * z - w * y) / n2,
    ]
}

/// Second column: the normal.
#[inline]
fn col_n<R: Real>(q: Quat<R>) -> [R; 3] {
    let [w, x, y, z] = q;
    let (one, two) = (r::<R>(1.0), r::<R>(2.0));
    let n2 = w * w + x * x + y * y + z * z;
    [
        two * (x * y - w * z) / n2,
        one - two * (x * x + z * z) / n2,
        two * (y * z + w * x) / n2,
    ]
}

/// Third column: the binormal.
#[inline]
fn col_b<R: Real>(q: Quat<R>) -> [R; 3] {
    let [w, x, y, z] = q;
    let (one, two) = (r::<R>(1.0), r::<R>(2.0));
    let n2 = w * w + x * x + y * y + z * z;
    [
        two * (x * z + w * y) / n2,
        two * (y * z - w * x) / n2,
        one - two * (x * x + y * y) / n2,
    ]
}

/// `F₀ v = T₀ v₀ + N₀ v₁ + B₀ v₂`.
#[inline]
fn world<R: Real>(rec: &[R], v: [R; 3]) -> [R; 3] {
    let mut o = [R::zero(); 3];
    for (j, oj) in o.iter_mut().enumerate() {
        *oj = rec[IN_T0 + j] * v[0] + rec[IN_N0 + j] * v[1] + rec[IN_B0 + j] * v[2];
    }
    o
}

/// Neumaier's compensated `s + x` (sum `s`, compensation `c`).
#[inline]
fn comp_add<R: Real>(s: &mut R, c: &mut R, x: R) {
    let t = *s + x;
    *c += if s.abs() >= x.abs() {
        (*s - t) + x
    } else {
        (x - t) + *s
    };
    *s = t;
}

/// March `steps` steps and call `visit(offset/L, q)` (body coordinates)
/// after every `every`-th. `false` (nothing visited) when the record is out
/// of range.
fn march<R: Real>(
    rec: &[R],
    steps: u32,
    every: u32,
    mut visit: impl FnMut([R; 3], Quat<R>),
) -> bool {
    let rates = [
        rec[IN_RATES],
        rec[IN_RATES + 1],
        rec[IN_RATES + 2],
        rec[IN_RATES + 3],
    ];
    let [k0, g, t0, d] = rates;
    let h = r::<R>(1.0) / R::from_f64(steps as f64);
    // `!(a <= b)`: NaN is out of range too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(step_bound(k0, g, t0, d, h) <= r(STEP_ANGLE_MAX)) {
        return false;
    }
    let c = k0 * d - t0 * g;
    let h6 = h / r(6.0);
    let half = r::<R>(0.5) * h;
    let mut q = TwoQuat {
        hi: [r(1.0), R::zero(), R::zero(), R::zero()],
        lo: [R::zero(); 4],
    };
    let mut t = [r::<R>(1.0), R::zero(), R::zero()];
    let mut ps = [R::zero(); 3];
    let mut pc = [R::zero(); 3];
    for k in 0..steps {
        let kf = R::from_f64(k as f64);
        let mid = rotate(q, exp_quat_m1(magnus(rates, c, (kf + r(0.25)) * h, half)));
        let next = rotate(mid, exp_quat_m1(magnus(rates, c, (kf + r(0.75)) * h, half)));
        let tm = col_t(mid.hi);
        let tn = col_t(next.hi);
        for j in 0..3 {
            comp_add(
                &mut ps[j],
                &mut pc[j],
                h6 * ((t[j] + r::<R>(4.0) * tm[j]) + tn[j]),
            );
        }
        q = next;
        t = tn;
        if (k + 1) % every == 0 {
            visit([ps[0] + pc[0], ps[1] + pc[1], ps[2] + pc[2]], q.hi);
        }
    }
    true
}

/// End mode: one record (`rec` is [`IN_STRIDE`] reals) after `steps ≥ 1`
/// steps.
pub fn frenet_integrate<R: Real>(rec: &[R], steps: u32) -> [R; OUT_STRIDE] {
    let mut out = [R::zero(); OUT_STRIDE];
    let mut end = (
        [R::zero(); 3],
        [r::<R>(1.0), R::zero(), R::zero(), R::zero()],
    );
    if !march(rec, steps, steps, |p, q| end = (p, q)) {
        out[OUT_STATUS] = r(STATUS_RANGE);
        return out;
    }
    let (p, q) = end;
    out[OUT_STATUS] = r(STATUS_OK);
    let cols = [
        (OUT_OFFSET, p),
        (OUT_T, col_t(q)),
        (OUT_N, col_n(q)),
        (OUT_B, col_b(q)),
    ];
    for (at, v) in cols {
        out[at..at + 3].copy_from_slice(&world(rec, v));
    }
    out
}

/// Sampled mode: `out` ([`sampled_out_stride`]`(m)` reals, `m ≥ 1`) gets the
/// status and `m` samples, `steps_per_interval ≥ 1` steps apart.
pub fn frenet_sample<R: Real>(rec: &[R], m: usize, steps_per_interval: u32, out: &mut [R]) {
    assert!(m >= 1 && out.len() == sampled_out_stride(m));
    out.iter_mut().for_each(|x| *x = R::zero());
    let write = |out: &mut [R], j: usize, p: [R; 3], q: Quat<R>| {
        let at = OUT_SAMPLES + SAMPLE_STRIDE * j;
        out[at + SAMPLE_OFFSET..at + SAMPLE_OFFSET + 3].copy_from_slice(&world(rec, p));
        out[at + SAMPLE_TANGENT..at + SAMPLE_TANGENT + 3].copy_from_slice(&world(rec, col_t(q)));
    };
    let steps = (m as u32 - 1) * steps_per_interval;
    let mut j = 0;
    let ok = if steps == 0 {
        // m = 1: the start only (h would be 1/0).
        true
    } else {
        march(rec, steps, steps_per_interval, |p, q| {
            j += 1;
            write(out, j, p, q);
        })
    };
    if !ok {
        out[OUT_STATUS] = r(STATUS_RANGE);
        return;
    }
    out[OUT_STATUS] = r(STATUS_OK);
    write(
        out,
        0,
        [R::zero(); 3],
        [r(1.0), R::zero(), R::zero(), R::zero()],
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::euler::FrenetProblem;
    use glam::DVec3;

    fn record(p: &FrenetProblem) -> [f64; IN_STRIDE] {
        let mut rec = [0.0; IN_STRIDE];
        rec[IN_RATES..IN_RATES + 4].copy_from_slice(&p.rates());
        for (at, v) in [(IN_T0, 0), (IN_N0, 1), (IN_B0, 2)] {
            rec[at..at + 3].copy_from_slice(&p.frame[v].to_array());
        }
        rec
    }

    fn problem(k0: f64, g: f64, t0: f64, d: f64, l: f64) -> FrenetProblem {
        let t = DVec3::new(1.0, 2.0, -0.5).normalize();
        // At the origin, so that the reference's `x(L) − x₀` is exact
        // (the host's `x₀ + L·offset` is the driver's business).
        FrenetProblem::new(DVec3::ZERO, t, t.any_orthonormal_vector(), k0, g, t0, d, l)
    }

    fn get<R: Real>(o: &[R], at: usize) -> DVec3 {
        DVec3::new(o[at].to_f64(), o[at + 1].to_f64(), o[at + 2].to_f64())
    }

    /// Worst `(offset error / L, frame error)` of the twin in `R` against
    /// the reference at the same step count.
    fn worst<R: Real>(p: &FrenetProblem, steps: u32) -> (f64, f64) {
        let rec: Vec<R> = record(p).iter().map(|&x| R::from_f64(x)).collect();
        let o = frenet_integrate(&rec, steps);
        assert_eq!(o[OUT_STATUS].to_f64(), STATUS_OK);
        let want = p.integrate(steps as usize).unwrap();
        let pe = (get(&o, OUT_OFFSET) - (want.point - p.start) / p.length).length();
        let fe = [OUT_T, OUT_N, OUT_B]
            .iter()
            .zip(want.frame)
            .map(|(&at, w)| (get(&o, at) - w).length())
            .fold(0.0, f64::max);
        (pe, fe)
    }

    #[test]
    fn twin_matches_reference() {
        let cases = [
            (problem(1.0, -0.6, 0.8, 0.2, 4.0), 64),
            (problem(0.0, 0.0, 0.0, 0.0, 3.0), 4),
            (problem(3.0, -6.0, 0.0, 0.0, 1.5), 40),
            (problem(0.01, 0.0, 30.0, -5.0, 1.0), 200),
            (problem(1.0, 0.1, 0.2, 0.0, 1e-6), 8),
            (problem(2.0, 0.5, 1.0, 0.3, 157.0), 2000),
        ];
        for (p, n) in &cases {
            let (pe, fe) = worst::<f64>(p, *n);
            let tol = 8.0 * f64::EPSILON * (*n as f64).sqrt() * 4.0;
            assert!(pe < tol && fe < tol, "f64 {p:?} {n}: {pe:e} {fe:e}");
            let (pe, fe) = worst::<f32>(p, *n);
            let theta = p.rates().iter().map(|x| x.abs()).sum::<f64>();
            let tol = f32::EPSILON as f64 * (16.0 * (*n as f64).sqrt() + theta);
            assert!(
                pe < tol && fe < tol,
                "f32 {p:?} {n}: {pe:e} {fe:e} (tol {tol:e})"
            );
        }
    }

    #[test]
    fn sampled_mode_agrees_with_end_mode_and_reference() {
        let p = problem(1.0, -0.6, 0.8, 0.2, 4.0);
        let rec = record(&p);
        let m = 9;
        let mut out = vec![0.0; sampled_out_stride(m)];
        frenet_sample(&rec, m, 6, &mut out);
        assert_eq!(out[OUT_STATUS], STATUS_OK);
        let end = frenet_integrate(&rec, 48);
        let last = OUT_SAMPLES + SAMPLE_STRIDE * (m - 1);
        assert_eq!(&out[last..last + 3], &end[OUT_OFFSET..OUT_OFFSET + 3]);
        assert_eq!(&out[last + 3..last + 6], &end[OUT_T..OUT_T + 3]);
        let want = p.sample(m, 6).unwrap();
        for (j, w) in want.iter().enumerate() {
            let at = OUT_SAMPLES + SAMPLE_STRIDE * j;
            let off = get(&out, at + SAMPLE_OFFSET) * p.length + p.start;
            assert!((off - w.point).length() < 1e-13, "{j}");
            assert!((get(&out, at + SAMPLE_TANGENT) - w.frame[0]).length() < 1e-14);
        }
        // m = 1: the start only.
        let mut one = vec![9.0; sampled_out_stride(1)];
        frenet_sample(&rec, 1, 6, &mut one);
        assert_eq!(get(&one, OUT_SAMPLES), DVec3::ZERO);
        assert_eq!(get(&one, OUT_SAMPLES + 3), p.frame[0]);
    }

    #[test]
    fn out_of_range_records_are_flagged() {
        let p = problem(100.0, 0.0, 0.0, 0.0, 10.0); // 1000 rad
        let rec = record(&p);
        assert_eq!(frenet_integrate(&rec, 10)[OUT_STATUS], STATUS_RANGE);
        assert_eq!(frenet_integrate(&rec, 16)[OUT_STATUS], STATUS_OK);
        let mut nan = rec;
        nan[IN_RATES + 1] = f64::NAN;
        let o = frenet_integrate(&nan, 16);
        assert_eq!(o[OUT_STATUS], STATUS_RANGE);
        assert!(o[1..].iter().all(|&x| x == 0.0));
        let mut out = vec![0.0f32; sampled_out_stride(3)];
        let rec32: Vec<f32> = nan.iter().map(|&x| x as f32).collect();
        frenet_sample(&rec32, 3, 4, &mut out);
        assert_eq!(out[OUT_STATUS] as f64, STATUS_RANGE);
        // The kernel's range test is the reference's bound, in `R`.
        let q = problem(1.0, 2.0, -3.0, 0.5, 1.7);
        let [k0, g, t0, d] = q.rates();
        assert_eq!(step_bound(k0, g, t0, d, 1.0 / 7.0), q.max_step_angle(7));
    }
}
