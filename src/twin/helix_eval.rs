//! Twin of `shaders/helix_eval.wgsl`: one point and unit tangent of a helix
//! element per invocation (decompression of piecewise helices into samples).
//!
//! The formula is [`crate::helix::HelixElement`]'s cancellation-free form, with
//! `φ = ωs` and `b₀ = t₀ × n₀`:
//!
//! ```text
//! α(s) − p₀ = (s − κ²s³ g(φ)) t₀ + κ s² h(φ) n₀ + κτ s³ g(φ) b₀
//! t(s)      = (1 − κ²s² h(φ)) t₀ + κ s sinc(φ) n₀ + κτ s² h(φ) b₀
//! ```
//!
//! `sinc`, `h` and `g` come from one `sincos(φ/2)` ([`sincos`], never the
//! WGSL built-ins): `sinc(φ/2) = sin(φ/2)/(φ/2)`, then without cancellation
//! `sinc φ = sinc(φ/2) cos(φ/2)`, `h(φ) = ½ sinc²(φ/2)`, and
//! `g(φ) = (φ − sin φ)/φ³` with `sin φ = 2 sin(φ/2) cos(φ/2)` for `|φ| ≥ 1`,
//! its Taylor series (the reference's 9 terms) below, where the difference
//! cancels. `sinc(φ/2)` takes the reference's series below `1e-4` (only
//! `φ = 0` would actually need it).
//!
//! Split of the work. The host, in `f64`, locates each sample in its element
//! and hands over the element's parameters *relative to its start*: the
//! kernel never sees the start point, so in `f32` large coordinates cost no
//! relative precision — the offset is accurate to a few `ε` of the element's
//! size and the host adds `p₀` in `f64`. The host also computes `φ = ωs` in
//! `f64` exactly as the reference does (`hypot`, no `κ²` underflow in
//! `f32`), and keeps samples with `|φ| > PHI_MAX` (beyond the range where
//! `sincos`'s reduction is exact) or values that do not fit the kernel's
//! precision on the `f64` reference.
//!
//! Record layout: input [`IN_STRIDE`] reals `s, κ, τ, φ, t₀ (3), n₀ (3)`;
//! output [`OUT_STRIDE`] reals, the offset `α(s) − p₀` at
//! [`OUT_OFFSET`]`..+3` and the tangent at [`OUT_TANGENT`]`..+3` (unit up to
//! rounding, not renormalised — as the reference's).

use super::math::sincos;
use super::{r, Real};

/// Reals per input record: `s, kappa, tau, phi, t0.xyz, n0.xyz`.
pub const IN_STRIDE: usize = 10;
/// Reals per output record: `offset.xyz, tangent.xyz`.
pub const OUT_STRIDE: usize = 6;

pub const IN_S: usize = 0;
pub const IN_KAPPA: usize = 1;
pub const IN_TAU: usize = 2;
pub const IN_PHI: usize = 3;
pub const IN_T0: usize = 4;
pub const IN_N0: usize = 7;

/// `α(s) − p₀`, 3 reals.
pub const OUT_OFFSET: usize = 0;
/// `t(s)`, 3 reals.
pub const OUT_TANGENT: usize = 3;

/// Largest `|φ|` the kernel is given: `sincos(φ/2)` reduces by `q·π/2` with
/// `|q| < 2⁸` exact, i.e. `|φ/2| < 400`; 256 leaves margin (a 40-turn
/// element; the host evaluates longer ones with the reference).
pub const PHI_MAX: f64 = 256.0;

/// `1/(2k+3)!`, k = 0..=8: the Taylor coefficients of `g` (alternating).
const G_SERIES: [f64; 9] = [
    1.0 / 6.0,
    1.0 / 120.0,
    1.0 / 5040.0,
    1.0 / 362_880.0,
    1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    1.0 / 121_645_100_408_832_000.0,
];

/// `(sinc φ, h(φ), g(φ))` from one `sincos(φ/2)`.
#[inline]
pub fn helix_coefficients<R: Real>(phi: R) -> (R, R, R) {
    let x = r::<R>(0.5) * phi;
    let (sh, ch) = sincos(x);
    let sinc_half = if x.abs() < r(1e-4) {
        let x2 = x * x;
        r::<R>(1.0) - x2 / r(6.0) * (r::<R>(1.0) - x2 / r(20.0))
    } else {
        sh / x
    };
    let sinc = sinc_half * ch;
    let h = r::<R>(0.5) * sinc_half * sinc_half;
    let g = if phi.abs() < r(1.0) {
        // Horner in φ², signs alternating from the last term (k = 8: +).
        let p2 = phi * phi;
        let mut acc = R::zero();
        for (k, &c) in G_SERIES.iter().enumerate().rev() {
            acc = if k % 2 == 0 {
                acc * p2 + r(c)
            } else {
                acc * p2 - r(c)
            };
        }
        acc
    } else {
        (phi - r::<R>(2.0) * sh * ch) / (phi * phi * phi)
    };
    (sinc, h, g)
}

/// One record: `rec` is [`IN_STRIDE`] reals, the result [`OUT_STRIDE`].
pub fn helix_eval<R: Real>(rec: &[R]) -> [R; OUT_STRIDE] {
    let s = rec[IN_S];
    let k = rec[IN_KAPPA];
    let tau = rec[IN_TAU];
    let phi = rec[IN_PHI];
    let t0 = [rec[IN_T0], rec[IN_T0 + 1], rec[IN_T0 + 2]];
    let n0 = [rec[IN_N0], rec[IN_N0 + 1], rec[IN_N0 + 2]];
    // b₀ = t₀ × n₀ (WGSL `cross`, same component order).
    let b0 = [
        t0[1] * n0[2] - t0[2] * n0[1],
        t0[2] * n0[0] - t0[0] * n0[2],
        t0[0] * n0[1] - t0[1] * n0[0],
    ];
    let (sinc, h, g) = helix_coefficients(phi);
    let s2 = s * s;
    let s3 = s2 * s;
    // Point: coefficients along t₀, n₀, b₀.
    let ks3g = k * s3 * g;
    let pa = s - k * ks3g;
    let pb = k * s2 * h;
    let pc = tau * ks3g;
    // Tangent.
    let ks2h = k * s2 * h;
    let ta = r::<R>(1.0) - k * ks2h;
    let tb = k * s * sinc;
    let tc = tau * ks2h;
    let mut out = [R::zero(); OUT_STRIDE];
    for j in 0..3 {
        out[OUT_OFFSET + j] = pa * t0[j] + pb * n0[j] + pc * b0[j];
        out[OUT_TANGENT + j] = ta * t0[j] + tb * n0[j] + tc * b0[j];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::helix::HelixElement;
    use glam::DVec3;

    fn record(e: &HelixElement, s: f64) -> [f64; IN_STRIDE] {
        let (t, n) = (e.tangent, e.normal);
        [
            s,
            e.curvature,
            e.torsion,
            e.omega() * s,
            t.x,
            t.y,
            t.z,
            n.x,
            n.y,
            n.z,
        ]
    }

    fn element(kappa: f64, tau: f64, length: f64) -> HelixElement {
        let t = DVec3::new(1.0, 2.0, -0.5).normalize();
        HelixElement {
            start: DVec3::new(100.3, -101.0, 102.0),
            tangent: t,
            normal: t.any_orthonormal_vector(),
            curvature: kappa,
            torsion: tau,
            length,
        }
    }

    /// Worst `(point error / L, tangent error)` of the twin in `R` against
    /// the reference over 201 samples of `e`.
    fn worst<R: Real>(e: &HelixElement) -> (f64, f64) {
        let (mut wp, mut wt) = (0.0f64, 0.0f64);
        for i in 0..=200 {
            let s = e.length * i as f64 / 200.0;
            let rec: Vec<R> = record(e, s).iter().map(|&x| R::from_f64(x)).collect();
            let o = helix_eval(&rec);
            let get = |j: usize| DVec3::new(o[j].to_f64(), o[j + 1].to_f64(), o[j + 2].to_f64());
            let p = e.start + get(OUT_OFFSET);
            wp = wp.max((p - e.point(s)).length() / e.length);
            wt = wt.max((get(OUT_TANGENT) - e.tangent_at(s)).length());
        }
        (wp, wt)
    }

    #[test]
    fn twin_matches_reference_on_elements() {
        let cases = [
            element(0.8, 0.3, 2.5 / 0.8f64.hypot(0.3)), // generic, φ* = 2.5
            element(0.0, 0.0, 3.0),                     // straight
            element(1.0, 0.0, 6.0),                     // circle, φ* = 6
            element(1e-9, 0.0, 2.0),                    // nearly straight: φ ≈ 2e-9
            element(1e-9, 1e-9, 5e-3),                  // tiny ω, series everywhere
            element(0.01, 3.0, 2.0),                    // steep τ ≫ κ
            element(4.0, -5.0, 6.0 / 4f64.hypot(5.0)),  // φ* = 6, negative τ
        ];
        for e in &cases {
            // f64: the same formula with polynomial sincos; the offset stays
            // within a few ε of L, `p₀ + offset` adds ε|p₀| ≈ 2e-14 here.
            let (p, t) = worst::<f64>(e);
            assert!(
                p < 1e-15 + 3e-16 * 200.0 / e.length,
                "f64 {e:?}: point {p:e}"
            );
            assert!(t < 1e-15, "f64 {e:?}: tangent {t:e}");
            // f32: inputs rounded to f32 and f32 arithmetic, relative to L.
            let (p, t) = worst::<f32>(e);
            assert!(p < 2e-6, "f32 {e:?}: point {p:e}");
            assert!(t < 2e-6, "f32 {e:?}: tangent {t:e}");
        }
    }

    #[test]
    fn coefficients_are_continuous_at_the_series_cut_offs() {
        // g across |φ| = 1, sinc(φ/2) across φ/2 = 1e-4.
        let (_, _, below) = helix_coefficients(1.0f64 - 1e-12);
        let (_, _, above) = helix_coefficients(1.0f64 + 1e-12);
        assert!((below - above).abs() < 1e-13);
        let (a, b, _) = helix_coefficients(2e-4f64 - 1e-15);
        let (c, d, _) = helix_coefficients(2e-4f64 + 1e-15);
        assert!((a - c).abs() < 1e-15 && (b - d).abs() < 1e-15);
        // φ = 0: the straight line (sinc 1, h ½, g ⅙).
        assert_eq!(helix_coefficients(0.0f64), (1.0, 0.5, 1.0 / 6.0));
    }
}
