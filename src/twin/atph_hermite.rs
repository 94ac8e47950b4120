//! Twin of `shaders/atph_hermite.wgsl`: one ATPH Hermite solve per
//! invocation (paper 002, Sections 3.2 and 4), for a *spatial* tangent field
//! (planar and constant fields stay on the `f64` reference,
//! [`crate::atph::interpolate_field`]).
//!
//! Given the field `θ = a₁ξ + a₀`, `φ = b₁ξ + b₀` and the chord, the kernel
//! forms the moment vectors `V_k = ∫₀¹ tᵏ T` at the three frequencies
//! `A₁ = a₁ + b₁`, `B₁ = a₁ − b₁`, `a₁` (as [`crate::atph::trig_moments`]: the
//! power series for `|ω| < 2`, here with a fixed [`SERIES_TERMS`] terms so
//! invocations do not diverge; the corrected closed form (2.5)–(2.6) above),
//! the Bernstein columns `∫B_jⁿ T`, and solves system (3.1) (`n = 2`) or
//! (4.1) (`n = 3`, prescribed length) by Gaussian elimination with partial
//! pivoting. `sin`/`cos` come from [`sincos`] (never the WGSL built-ins).
//!
//! Split of the work. The host, in `f64`, builds the field (branch rules,
//! poles) exactly as the reference does and divides the chord and the
//! length by `|P₂ − P₁|`: `ρ` scales with the chord, so the kernel solves the
//! unit problem, its values stay O(1) in `f32` for any coordinates, and the
//! host multiplies `ρ` back. It also gets the determinant's size relative to
//! the columns, and applies the reference's singularity test to it.
//!
//! Record layout: input [`IN_STRIDE`] reals `a₀, a₁, b₀, b₁, chord/|chord|
//! (3), L/|chord|` (`L = 0`: no prescribed length); output [`OUT_STRIDE`]
//! reals, the Bernstein coefficients `ρ₀ … ρ₃` of the unit problem (`ρ₃ = 0`
//! for `n = 2`) and `|det| / Π‖column‖`.

use super::math::sincos;
use super::{r, Real};

/// Reals per input record.
pub const IN_STRIDE: usize = 8;
/// Reals per output record.
pub const OUT_STRIDE: usize = 5;
/// Output index of `|det| / Π‖column‖`.
pub const OUT_REL_DET: usize = 4;
/// Below this `|ω|` the moments are summed as a series.
pub const SERIES_BELOW: f64 = 2.0;
/// Series terms: `2ⁿ/n!` at `n = 28` is `9e-22`, below `f64` rounding of
/// the first term.
pub const SERIES_TERMS: usize = 28;

/// `(Re, Im)` of `M_k = ∫₀¹ tᵏ e^{i(ωt + α)} dt`, `k = 0..=3`.
pub fn moments<R: Real>(omega: R, alpha: R) -> ([R; 4], [R; 4]) {
    let mut re = [R::zero(); 4];
    let mut im = [R::zero(); 4];
    if omega.abs() < r(SERIES_BELOW) {
        let mut sr = [R::zero(); 4];
        let mut si = [R::zero(); 4];
        let mut p = R::one();
        for n in 0..SERIES_TERMS {
            let nf = r::<R>(n as f64);
            for k in 0..4 {
                let term = p / (nf + r(k as f64 + 1.0));
                match n % 4 {
                    0 => sr[k] += term,
                    1 => si[k] += term,
                    2 => sr[k] -= term,
                    _ => si[k] -= term,
                }
            }
            p = p * omega / (nf + R::one());
        }
        let (sa, ca) = sincos(alpha);
        for k in 0..4 {
            re[k] = ca * sr[k] - sa * si[k];
            im[k] = ca * si[k] + sa * sr[k];
        }
    } else {
        let (s1, c1) = sincos(omega + alpha);
        let (s0, c0) = sincos(alpha);
        let inv = R::one() / omega;
        re[0] = (s1 - s0) * inv;
        im[0] = -(c1 - c0) * inv;
        for k in 1..4 {
            let kf = r::<R>(k as f64);
            let x = c1 - kf * re[k - 1];
            let y = s1 - kf * im[k - 1];
            re[k] = y * inv;
            im[k] = -x * inv;
        }
    }
    (re, im)
}

/// One record in, one record out (layouts in the module docs).
pub fn atph_hermite<R: Real>(rec: &[R]) -> [R; OUT_STRIDE] {
    let (a0, a1, b0, b1) = (rec[0], rec[1], rec[2], rec[3]);
    let len = rec[7];
    let half = r::<R>(0.5);
    let (are, aim) = moments(a1 + b1, a0 + b0);
    let (bre, bim) = moments(a1 - b1, a0 - b0);
    let (_, zim) = moments(a1, a0);
    // v[k][i]: component i of V_k.
    let mut v = [[R::zero(); 3]; 4];
    for k in 0..4 {
        v[k][0] = half * (are[k] + bre[k]);
        v[k][1] = half * (aim[k] - bim[k]);
        v[k][2] = zim[k];
    }
    let cubic = len > R::zero();
    let n = if cubic { 4 } else { 3 };
    // a[i][j]: row i, column j = ∫ B_jⁿ T (component i); row 3 = ∫ B_j³ = ¼.
    let mut a = [[R::zero(); 4]; 4];
    let (two, three, six) = (r::<R>(2.0), r::<R>(3.0), r::<R>(6.0));
    for i in 0..3 {
        if cubic {
            a[i][0] = v[0][i] - three * v[1][i] + three * v[2][i] - v[3][i];
            a[i][1] = three * v[1][i] - six * v[2][i] + three * v[3][i];
            a[i][2] = three * v[2][i] - three * v[3][i];
            a[i][3] = v[3][i];
        } else {
            a[i][0] = v[0][i] - two * v[1][i] + v[2][i];
            a[i][1] = two * v[1][i] - two * v[2][i];
            a[i][2] = v[2][i];
        }
    }
    if cubic {
        a[3] = [r(0.25); 4];
    }
    let mut b = [rec[4], rec[5], rec[6], len];
    let mut scale2 = R::one();
    for j in 0..n {
        let mut s = R::zero();
        for i in 0..n {
            s += a[i][j] * a[i][j];
        }
        scale2 *= s;
    }
    let mut det = R::one();
    for k in 0..n {
        let mut p = k;
        for i in k + 1..n {
            if a[i][k].abs() > a[p][k].abs() {
                p = i;
            }
        }
        if p != k {
            a.swap(p, k);
            b.swap(p, k);
            det = -det;
        }
        let piv = a[k][k];
        det *= piv;
        for i in k + 1..n {
            let f = a[i][k] / piv;
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = [R::zero(); 4];
    for kk in 0..n {
        let k = n - 1 - kk;
        let mut s = b[k];
        for j in k + 1..n {
            s -= a[k][j] * x[j];
        }
        x[k] = s / a[k][k];
    }
    [x[0], x[1], x[2], x[3], det.abs() / scale2.sqrt()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atph::{interpolate, interpolate_with_length, FieldKind, HermitePair};
    use glam::DVec3;

    fn record(p1: DVec3, t1: DVec3, p2: DVec3, t2: DVec3, l: Option<f64>) -> Option<[f64; 8]> {
        let f = crate::atph::tangent_field(p1, t1, p2, t2).ok()?;
        (f.kind() == FieldKind::Spatial).then(|| {
            let d = p2 - p1;
            let c = d.length();
            let u = d / c;
            [
                f.a0,
                f.a1,
                f.b0,
                f.b1,
                u.x,
                u.y,
                u.z,
                l.map_or(0.0, |l| l / c),
            ]
        })
    }

    #[test]
    fn twin_f64_matches_the_reference() {
        let pairs = crate::synthetic::synthetic_hermite_pairs(2000);
        let mut worst = 0.0f64;
        for (
            i,
            &HermitePair {
                p0: p1,
                t0: t1,
                p1: p2,
                t1: t2,
            },
        ) in pairs.iter().enumerate()
        {
            let l = (i % 2 == 1).then(|| 1.3 * (p2 - p1).length());
            let Some(rec) = record(p1, t1, p2, t2, l) else {
                continue;
            };
            let c = (p2 - p1).length();
            let out = atph_hermite::<f64>(&rec);
            let reference = match l {
                Some(l) => interpolate_with_length(p1, t1, p2, t2, l),
                None => interpolate(p1, t1, p2, t2),
            }
            .unwrap();
            let rho = reference.rho.coefficients();
            let size: f64 = rho.iter().map(|v| v.abs()).sum();
            for (j, v) in rho.iter().enumerate() {
                // In units of ε Σ|ρ| / rel_det: the system's condition
                // number times the rounding of its entries.
                let err = (out[j] * c - v).abs() / (f64::EPSILON * size / out[OUT_REL_DET]);
                worst = worst.max(err);
            }
            if l.is_none() {
                assert_eq!(out[3], 0.0);
            }
            assert!(out[OUT_REL_DET] > 1e-12);
        }
        eprintln!("twin f64 vs reference: worst |Δρ| = {worst:.3} ε Σ|ρ|/rel_det");
        assert!(worst < 4.0, "{worst:e}");
    }

    #[test]
    fn moments_match_the_reference_in_both_precisions() {
        for &w in &[0.0, 0.5, -1.999, 2.0, 3.5, -9.0] {
            for &al in &[0.0, 1.0, -2.5] {
                let m = crate::atph::trig_moments(w, al, 1.0);
                let (re, im) = moments::<f64>(w, al);
                let (re32, im32) = moments::<f32>(w as f32, al as f32);
                for k in 0..4 {
                    assert!((re[k] - m.re[k]).abs() < 4e-16 && (im[k] - m.im[k]).abs() < 4e-16);
                    assert!((re32[k] as f64 - m.re[k]).abs() < 2e-6);
                    assert!((im32[k] as f64 - m.im[k]).abs() < 2e-6);
                }
            }
        }
    }
}
