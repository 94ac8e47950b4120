//! `sin t` and `cos t` together, inlined, for the closest-point searches.
//!
//! Why not `f64::sin_cos`: on Linux it is a call into libm (`__sincos`),
//! which the compiler cannot inline or interleave with the arithmetic
//! around it. The covering's least-squares steps project every vertex of a
//! stretch onto a trial helix by Newton's method, one `sin_cos` a step, and
//! measured on the benchmark's four-curl drawings at 0.1 % noise
//! (`benches/sketch_noise.rs`, `perf`, 2026-11-30) that call was 27 % of
//! the lift's time. This is fdlibm's method (`__kernel_sin`,
//! `__kernel_cos`), branch-free on the arguments the searches meet:
//! `t = kπ/2 + r`, `|r| ≤ π/4`, with `k` rounded by adding and subtracting
//! 1.5·2⁵² and `π/2` split in three parts (`k` times the first two
//! exact); then minimax polynomials in `r²` of degree 6
//! on each side. It differs from `f64::sin_cos` by at most 1.26 ulps
//! (measured on 2·10⁷ random arguments in ±8·10⁵ and ±4, and at every
//! multiple of π/2 there and its neighbours; tested below within 2).

use std::f64::consts::FRAC_2_PI;

/// π/2 in three parts (fdlibm's `pio2_1`, `pio2_2`, `pio2_2t`): the
/// first two of 33 bits, so `k · PIO2_1` and `k · PIO2_2` are exact for
/// `|k| < 2²⁰`, and the rest.
const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
const PIO2_2T: f64 = 2.022_266_248_795_950_631_54e-21;
/// Beyond this `|t|`, `k` may reach 2¹⁹ and libm reduces instead.
const FAST_LIMIT: f64 = 8.0e5;
/// 1.5·2⁵²: adding and subtracting it rounds to the nearest integer.
const ROUNDER: f64 = 6_755_399_441_055_744.0;

// fdlibm k_sin.c: sin r ≈ r + r³(S1 + r²(S2 + … + r⁸ S6)) on |r| ≤ π/4.
const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

// fdlibm k_cos.c: cos r ≈ 1 − r²/2 + r⁴(C1 + r²(C2 + … + r¹⁰ C6)).
const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `(sin t, cos t)`, within two ulps of [`f64::sin_cos`]; `|t|` from 8·10⁵
/// on, and NaN or infinite `t`, go to [`f64::sin_cos`] itself.
#[inline(always)]
pub(crate) fn sin_cos(t: f64) -> (f64, f64) {
    if !(t.abs() < FAST_LIMIT) {
        return t.sin_cos();
    }
    let k = (t * FRAC_2_PI + ROUNDER) - ROUNDER;
    let r = ((t - k * PIO2_1) - k * PIO2_2) - k * PIO2_2T;
    // The polynomials by Estrin's scheme (pairs, then pairs of pairs): a
    // shorter chain of dependent operations than Horner's.
    let z = r * r;
    let z2 = z * z;
    let sin_r = r + r * z * ((S1 + z * S2) + z2 * ((S3 + z * S4) + z2 * (S5 + z * S6)));
    // k_cos.c's split of 1 − r²/2, which keeps the sum exact to an ulp.
    let tail = z2 * ((C1 + z * C2) + z2 * ((C3 + z * C4) + z2 * (C5 + z * C6)));
    let half = 0.5 * z;
    let w = 1.0 - half;
    let cos_r = w + (((1.0 - w) - half) + tail);
    // The quadrant: t = kπ/2 + r turns (sin r, cos r) by k quarter turns.
    let quadrant = k as i64;
    let (s, c) = if quadrant & 1 == 0 {
        (sin_r, cos_r)
    } else {
        (cos_r, sin_r)
    };
    let sin_sign = ((quadrant & 2) as u64) << 62;
    let cos_sign = (((quadrant + 1) & 2) as u64) << 62;
    (
        f64::from_bits(s.to_bits() ^ sin_sign),
        f64::from_bits(c.to_bits() ^ cos_sign),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// One ulp at 1 (2⁻⁵²): both results are within an ulp of the truth,
    /// so within two of each other where they are near 1, and nearer
    /// where they are smaller.
    const ULP_1: f64 = f64::EPSILON;

    fn assert_close(t: f64) {
        let (s, c) = sin_cos(t);
        let (s0, c0) = t.sin_cos();
        // Two ulps of the value, and no tighter than 1e-300 near zero.
        let bound = |v: f64| (2.0 * ULP_1 * v.abs()).max(1e-300);
        assert!(
            (s - s0).abs() <= bound(s0),
            "sin({t:e}): {s:e} against {s0:e}"
        );
        assert!(
            (c - c0).abs() <= bound(c0),
            "cos({t:e}): {c:e} against {c0:e}"
        );
    }

    #[test]
    fn it_agrees_with_libm_at_the_quadrants_edges() {
        for k in -40..=40 {
            let edge = k as f64 * std::f64::consts::FRAC_PI_4;
            for t in [
                edge,
                edge.next_up(),
                edge.next_down(),
                edge + 1e-9,
                edge - 1e-9,
            ] {
                assert_close(t);
            }
        }
        for t in [
            0.0, -0.0, 1e-300, -1e-300, 1e-8, 0.5, 1.0, 3.0, 100.0, 7.9e5,
        ] {
            assert_close(t);
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }

    #[test]
    fn beyond_the_fast_range_and_off_the_reals_it_is_libm() {
        for t in [
            8.0e5,
            -9.1e5,
            1e12,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            let (s, c) = sin_cos(t);
            let (s0, c0) = t.sin_cos();
            assert_eq!(s.to_bits(), s0.to_bits(), "sin({t:e})");
            assert_eq!(c.to_bits(), c0.to_bits(), "cos({t:e})");
        }
        let (s, c) = sin_cos(f64::NAN);
        assert!(s.is_nan() && c.is_nan());
    }

    #[test]
    fn it_is_odd_and_even() {
        for k in 1..2000 {
            let t = k as f64 * 0.377;
            let ((s, c), (sm, cm)) = (sin_cos(t), sin_cos(-t));
            assert_eq!(sm, -s, "sin(-{t})");
            assert_eq!(cm, c, "cos(-{t})");
        }
    }

    proptest! {
        #[test]
        fn it_agrees_with_libm(t in -7.9e5f64..7.9e5) {
            assert_close(t);
        }

        #[test]
        fn it_agrees_with_libm_near_zero(t in -4.0f64..4.0) {
            assert_close(t);
            let (s, c) = sin_cos(t);
            prop_assert!((s * s + c * c - 1.0).abs() <= 4.0 * ULP_1);
        }
    }
}
