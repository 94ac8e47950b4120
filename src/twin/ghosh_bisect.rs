//! Twin of `shaders/ghosh_bisect.wgsl`: one Ghosh short helix per segment by
//! bisection on `G(φ) = A·N(φ) + B·D(φ) = 0` over the full `I₀` (paper 000,
//! Algorithm 2 with the ERRATA corrections; the `f64` reference with Brent's
//! method is [`crate::helix::interpolate`], whose documentation derives the
//! formulas).
//!
//! Split of the work. The host, in `f64`, reduces each segment to five
//! scalars — `|d|`, `|t₁ − t₀| = 2 sin(θ/2)`, `|t₁ + t₀| = 2 cos(θ/2)` and
//! `d` in Ghosh's basis (`d·e₁`, `d·e₂`, `d·e₃`) — and turns the kernel's
//! answer back into vectors (axis `Ω̄ = a₁e₁ + a₂e₂`, normal `Ω̄ × t₀`).
//! The kernel does the root finding and every closed form. Why: on short
//! arcs `d·e₂` is third order in the arc and `|t₁ − t₀|` first order, and
//! near a half turn `e₁ ∝ t₁ + t₀` is a small difference; computed in `f32`
//! from rounded vectors they carry up to 100% noise (measured before this
//! split: 1.6e-4 relative length error at `θ = 2.5e-4`, 1e-2 rad normal
//! error near `θ = π`). As scalars from `f64` they keep full relative
//! precision, so the `f32` kernel is as accurate as `f32` allows.
//!
//! The kernel keeps the reference's formulation — unknown measured from the
//! nearer end of `I₀`, half-angle quantities straight from the data — and
//! changes only what a GPU wants changed:
//! - bisection in `z = √w` (`w` the offset of `φ` from the end of `I₀`):
//!   near-uniform control flow, ≈ `log₂(1/2ε)` steps (52 in `f64`, 23 in
//!   `f32`) for roots of the interval's scale, a relative error `Δz ≤ 2εz`
//!   (what `τ̄ ∝ z` and `φ* = θ + z²` on short arcs need), and a cap
//!   ([`Real::BISECT_MAX`]) for roots at the end;
//! - one `sincos(w/2)` per step: `sin(β − w/2)`, `sin(β − w)`, `sin(φ/2)`,
//!   `cos(φ/2)` follow by angle addition from the data's `sin(θ/2)`,
//!   `cos(θ/2)` (never from `β = π − θ` itself, which near `π` keeps `θ`
//!   only to `ulp(π)`).
//!
//! Degenerate branches are classified in the kernel (status codes) exactly
//! as in the reference: parallel tangents (`|t₁ − t₀| ≤ 1e-12`: straight),
//! opposite tangents (`|t₁ + t₀| ≤ 1e-12`: half circle), co-helicity
//! residual `|d·e₃|/|d|` above the tolerance, `d = 0`, non-finite data.
//!
//! Record layout: input [`IN_STRIDE`] reals `|d|, |t₁ − t₀|, |t₁ + t₀|, d·e₁,
//! d·e₂, d·e₃` (the basis terms zero where it is undefined); output
//! [`OUT_STRIDE`] reals, indices `OUT_*`.

use super::math::{atan2_pos, sincos};

use super::{r, Real};

/// Reals per input record: `dist, nd, ns, de1, de2, de3`.
pub const IN_STRIDE: usize = 6;
/// Reals per output record.
pub const OUT_STRIDE: usize = 12;

pub const OUT_STATUS: usize = 0;
pub const OUT_PHI: usize = 1;
pub const OUT_OMEGA: usize = 2;
pub const OUT_TAU_BAR: usize = 3;
pub const OUT_CURVATURE: usize = 4;
pub const OUT_TORSION: usize = 5;
pub const OUT_LENGTH: usize = 6;
/// Axis `Ω̄ = a₁ e₁ + a₂ e₂` (not normalised): `a₁`, `a₂`.
pub const OUT_AXIS_E1: usize = 7;
pub const OUT_AXIS_E2: usize = 8;
pub const OUT_CHI: usize = 9;
/// Co-helicity residual `|d·e₃|/|d|`.
pub const OUT_RESIDUAL: usize = 10;
/// Bisection steps taken (diagnostic).
pub const OUT_STEPS: usize = 11;

/// Status codes (`OUT_STATUS`).
pub mod status {
    pub const OK: u32 = 0;
    pub const NON_FINITE: u32 = 1;
    pub const COINCIDENT: u32 = 3;
    pub const NOT_COHELICAL: u32 = 4;
    /// Parallel tangents: a straight segment if the chord runs along them.
    pub const STRAIGHT: u32 = 6;
    /// Opposite tangents, chord ⊥ `t₀`: half circle.
    pub const HALF_CIRCLE: u32 = 7;
}

/// Tangents closer than this are parallel (the reference's
/// [`crate::helix::PARALLEL_EPS`]; `|t₁ ± t₀|` arrive from the host in full
/// relative precision, so the same threshold serves both precisions).
pub const PARALLEL_EPS: f64 = 1e-12;

/// `2(x cos x − sin x)` at `x = φ/2` given `sin x`, `cos x`; the series
/// `Σₖ≥₁ (−1)ᵏ 2k x²ᵏ⁺¹/(2k+1)!` (8 terms) for `x < 0.5`, where the direct
/// form cancels.
#[inline]
fn half_angle_defect<R: Real>(phi: R, sin_x: R, cos_x: R) -> R {
    let x = r::<R>(0.5) * phi;
    if x < r(0.5) {
        let x2 = x * x;
        // Horner in x² of Σ (−1)^k 2k/(2k+1)! x^(2k−2), k = 1..=8.
        let mut p = r::<R>(16.0 / 355_687_428_096_000.0);
        p = p * x2 - r(14.0 / 1_307_674_368_000.0);
        p = p * x2 + r(12.0 / 6_227_020_800.0);
        p = p * x2 - r(10.0 / 39_916_800.0);
        p = p * x2 + r(8.0 / 362_880.0);
        p = p * x2 - r(6.0 / 5040.0);
        p = p * x2 + r(4.0 / 120.0);
        p = p * x2 - r(2.0 / 6.0);
        r::<R>(2.0) * x * x2 * p
    } else {
        phi * cos_x - r::<R>(2.0) * sin_x
    }
}

/// The data `G` needs, fixed per segment.
struct Segment<R> {
    a: R,
    b: R,
    theta: R,
    sin_half: R,
    cos_half: R,
    sin_beta: R,
    cos_beta: R,
}

/// What `G` and the final formulas share at one `w`.
struct AtW<R> {
    phi: R,
    /// `t₀·t₁ − cos φ ≥ 0`.
    q: R,
    sin_half_phi: R,
    cos_half_phi: R,
    g: R,
}

impl<R: Real> Segment<R> {
    /// Everything at `φ = θ + w` (`side = 1`) or `φ = 2π − θ − w` (`side = −1`).
    #[inline]
    fn at(&self, side: R, w: R) -> AtW<R> {
        let two = r::<R>(2.0);
        let (sh, ch) = sincos(r::<R>(0.5) * w);
        let sin_bmh = self.sin_beta * ch - self.cos_beta * sh; // sin(β − w/2)
        let q = two * sin_bmh * sh;
        let sw = two * sh * ch; // sin w
        let cw = R::one() - two * sh * sh; // cos w
        let sin_phi = side * (self.sin_beta * cw - self.cos_beta * sw); // side·sin(β − w)
        let phi = if side > R::zero() {
            self.theta + w
        } else {
            r::<R>(std::f64::consts::TAU) - self.theta - w
        };
        let sin_half_phi = self.sin_half * ch + self.cos_half * sh;
        let cos_half_phi = side * (self.cos_half * ch - self.sin_half * sh);
        let one_minus_c = two * self.sin_half * self.sin_half;
        // N(φ) = (1 − c) sin φ + φ (c − cos φ)            (A.14)
        let n = one_minus_c * sin_phi + phi * q;
        // D(φ) = (φ cos(φ/2) − 2 sin(φ/2)) √(c − cos φ)    (A.15)
        let d = half_angle_defect(phi, sin_half_phi, cos_half_phi) * q.max(R::zero()).sqrt();
        AtW {
            phi,
            q,
            sin_half_phi,
            cos_half_phi,
            g: self.a * n + self.b * d,
        }
    }
}

/// One segment: input record and relative co-helicity tolerance `tol`;
/// returns the output record.
pub fn ghosh_bisect<R: Real>(input: &[R; IN_STRIDE], tol: R) -> [R; OUT_STRIDE] {
    let mut out = [R::zero(); OUT_STRIDE];
    let code = |c: u32| r::<R>(c as f64);
    if !input.iter().all(|x| x.is_finite()) {
        out[OUT_STATUS] = code(status::NON_FINITE);
        return out;
    }
    let [dist, nd, ns, de1, de2, de3] = *input;
    if !(dist > R::zero()) {
        out[OUT_STATUS] = code(status::COINCIDENT);
        return out;
    }
    if nd <= r(PARALLEL_EPS) {
        out[OUT_STATUS] = code(status::STRAIGHT);
        out[OUT_LENGTH] = dist;
        return out;
    }
    // Co-helicity (Theorem 5.1, Eq. (6)), relative to |d||t₁ − t₀|.
    let residual = de3.abs() / dist;
    out[OUT_RESIDUAL] = residual;
    if residual > tol {
        out[OUT_STATUS] = code(status::NOT_COHELICAL);
        return out;
    }
    let pi = r::<R>(std::f64::consts::PI);
    if ns <= r(PARALLEL_EPS) {
        // Half circle of diameter |d|: I₀ = {π}, τ̄ = 0.
        let omega = r::<R>(2.0) / dist;
        out[OUT_STATUS] = code(status::HALF_CIRCLE);
        out[OUT_PHI] = pi;
        out[OUT_OMEGA] = omega;
        out[OUT_CURVATURE] = omega;
        out[OUT_LENGTH] = pi / omega;
        return out;
    }

    let half = r::<R>(0.5);
    let sin_half = half * nd;
    let cos_half = half * ns;
    let theta = r::<R>(2.0) * atan2_pos(nd, ns);
    let beta = r::<R>(2.0) * atan2_pos(ns, nd); // π − θ
                                                // sin β = sin θ, cos β = −cos θ from the half angles: β itself, near π
                                                // for short arcs, holds θ only to ulp(π) absolute (in f32, 4% of
                                                // θ = 6e-6 — measured as a 7e-3 relative length error).
    let sin_beta = r::<R>(2.0) * sin_half * cos_half;
    let cos_beta = (sin_half - cos_half) * (sin_half + cos_half);
    let a = r::<R>(std::f64::consts::SQRT_2) * de2.abs();
    let b = r::<R>(2.0) * sin_half * de1;
    out[OUT_CHI] = b / a; // ±∞ in the planar case

    let seg = Segment {
        a,
        b,
        theta,
        sin_half,
        cos_half,
        sin_beta,
        cos_beta,
    };
    // G(θ) > 0 > G(2π − θ); the sign of G(π) says which half holds the root.
    let g_mid = seg.at(R::one(), beta).g;
    let side = if g_mid > R::zero() {
        -R::one()
    } else {
        R::one()
    };
    let mut w = beta;
    let mut steps = 0u32;
    if g_mid != R::zero() && seg.at(side, R::zero()).g != R::zero() {
        // Bisection in z = √w on [0, √β]; G has the sign of `side` at z = 0.
        // Stop at 2ε relative to the bracket's upper end: short arcs and
        // near-planar data put the root at tiny z, where an absolute
        // stopping rule would leave φ* = θ + w with few correct digits.
        let mut lo = R::zero();
        let mut hi = beta.sqrt();
        while hi - lo > r::<R>(2.0) * R::EPSILON * hi && steps < R::BISECT_MAX {
            let mid = half * (lo + hi);
            if seg.at(side, mid * mid).g * side > R::zero() {
                lo = mid;
            } else {
                hi = mid;
            }
            steps += 1;
        }
        let z = half * (lo + hi);
        w = z * z;
    } else if g_mid != R::zero() {
        // G = 0 at the end of I₀: planar data (A = 0), φ* = θ or 2π − θ.
        w = R::zero();
    }

    // Lemma 5.2 (corrected), as in the reference.
    let at = seg.at(side, w);
    let phi = at.phi;
    let one_minus_cos_phi = r::<R>(2.0) * at.sin_half_phi * at.sin_half_phi;
    let tau_abs = (at.q.max(R::zero()) / one_minus_cos_phi)
        .sqrt()
        .min(R::one());
    let tau_bar = if de2 < R::zero() { -tau_abs } else { tau_abs };
    let kappa_bar = (sin_half / at.sin_half_phi).min(R::one());
    let tp = tau_bar * phi;
    let omega = (r::<R>(4.0) * sin_half * sin_half + tp * tp).sqrt() / dist;

    out[OUT_STATUS] = code(status::OK);
    out[OUT_PHI] = phi;
    out[OUT_OMEGA] = omega;
    out[OUT_TAU_BAR] = tau_bar;
    out[OUT_CURVATURE] = omega * kappa_bar;
    out[OUT_TORSION] = omega * tau_bar;
    out[OUT_LENGTH] = phi / omega;
    // Ω̄ = τ̄/cos(θ/2) e₁ − tan(θ/2) cot(φ*/2) e₂ (ERRATA 1: minus sign).
    out[OUT_AXIS_E1] = tau_bar / cos_half;
    out[OUT_AXIS_E2] = -(sin_half / cos_half) * (at.cos_half_phi / at.sin_half_phi);
    out[OUT_STEPS] = code(steps);
    out
}

/// The twin over a batch (flat arrays, [`IN_STRIDE`] / [`OUT_STRIDE`] reals
/// per record), in parallel.
pub fn ghosh_bisect_batch<R: Real>(input: &[R], tol: R, out: &mut [R]) {
    use rayon::prelude::*;
    assert_eq!(input.len() % IN_STRIDE, 0);
    assert_eq!(out.len(), input.len() / IN_STRIDE * OUT_STRIDE);
    out.par_chunks_mut(OUT_STRIDE)
        .zip(input.par_chunks(IN_STRIDE))
        .for_each(|(o, i)| {
            let rec: &[R; IN_STRIDE] = i.try_into().expect("stride");
            o.copy_from_slice(&ghosh_bisect(rec, tol));
        });
}

#[cfg(test)]
mod tests {
    use crate::helix::{self, HermitePair};
    use crate::kernels::ghosh_bisect::interpolate_twin;
    use glam::DVec3;

    #[test]
    fn twins_match_reference_on_a_helix() {
        // A right-handed helix: κ = 0.8, τ = 0.3, through 2.5 rad of turning.
        let e = crate::helix::HelixElement {
            start: DVec3::ZERO,
            tangent: DVec3::X,
            normal: DVec3::Y,
            curvature: 0.8,
            torsion: 0.3,
            length: 2.5 / 0.8f64.hypot(0.3),
        };
        let pair = HermitePair {
            p0: DVec3::ZERO,
            t0: DVec3::X,
            p1: e.end_point(),
            t1: e.end_frame().tangent,
        };
        let h = helix::interpolate(pair.p0, pair.t0, pair.p1, pair.t1, 1e-6).unwrap();
        let o = interpolate_twin::<f64>(&[pair], 1e-6)[0].unwrap();
        assert!((o.phi - h.phi).abs() < 1e-13, "{} {}", o.phi, h.phi);
        assert!((o.element.curvature - 0.8).abs() < 1e-12);
        assert!((o.element.torsion - 0.3).abs() < 1e-12);
        assert!((o.element.length - e.length).abs() < 1e-12);
        let o = interpolate_twin::<f32>(&[pair], 1e-6)[0].unwrap();
        assert!((o.phi - h.phi).abs() < 1e-6, "{} {}", o.phi, h.phi);
        assert!((o.element.curvature - 0.8).abs() < 1e-6);
        assert!((o.element.torsion - 0.3).abs() < 1e-6);
        assert!((o.element.end_point() - pair.p1).length() < 1e-6 * e.length);
    }
}
