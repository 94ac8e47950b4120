//! Twin of `shaders/math.wgsl`: `sin`, `cos` and `atan2` from arithmetic only.
//!
//! Why not the WGSL built-ins: for `f64` they compile but return garbage on
//! lavapipe and NVIDIA (naga emits GLSL.std.450 ops that Vulkan defines only
//! for 16/32-bit floats; `shared/notes/gpu-wgpu-lavapipe.md`), and lavapipe's
//! `f32` `sin`/`cos` are less accurate than a good libm. Written once over
//! [`Real`], the same code serves both precisions on both sides.
//!
//! Accuracy (checked in the tests against `std`): `sincos` on `|x| ≤ 64`
//! within 2 ulp of the result's scale (Cody–Waite reduction by `π/2` in
//! three parts, then the Cephes minimax polynomials on `[−π/4, π/4]`, whose
//! truncation error is below `f64` rounding); `atan2_pos` within 2 ulp
//! (Cephes `atan`: reduction to `[0, 0.66]`, rational `P₄/Q₅` in `x²`).

use super::{r, Real};

/// Cephes `sin` polynomial on `[−π/4, π/4]`: `sin x = x + x³ P(x²)`.
const SIN_P: [f64; 6] = [
    1.589_623_015_765_465_680_60e-10,
    -2.505_074_776_285_780_728_66e-8,
    2.755_731_362_138_572_452_13e-6,
    -1.984_126_982_958_953_859_96e-4,
    8.333_333_333_322_118_588_78e-3,
    -1.666_666_666_666_663_072_95e-1,
];
/// Cephes `cos` polynomial: `cos x = 1 − x²/2 + x⁴ Q(x²)`.
const COS_P: [f64; 6] = [
    -1.135_853_652_138_768_173_00e-11,
    2.087_570_084_197_473_167_78e-9,
    -2.755_731_417_929_673_881_12e-7,
    2.480_158_728_885_170_453_48e-5,
    -1.388_888_888_887_305_641_16e-3,
    4.166_666_666_666_659_292_18e-2,
];

#[inline]
fn horner<R: Real>(c: &[f64; 6], z: R) -> R {
    let mut p = r::<R>(c[0]);
    for &ci in &c[1..] {
        p = p * z + r(ci);
    }
    p
}

/// `(sin x, cos x)`.
#[inline]
pub fn sincos<R: Real>(x: R) -> (R, R) {
    // Nearest multiple of π/2; `q` is exact (|x| ≪ 2²⁴).
    let q = (x * r(std::f64::consts::FRAC_2_PI) + r(0.5)).floor();
    let y = ((x - q * r(R::PIO2_A)) - q * r(R::PIO2_B)) - q * r(R::PIO2_C);
    let z = y * y;
    let s = y + y * z * horner(&SIN_P, z);
    let c = r::<R>(1.0) - r::<R>(0.5) * z + z * z * horner(&COS_P, z);
    // Quadrant q mod 4 (q may be negative).
    let k = q.to_f64() as i64;
    match k.rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Cephes `atan` rational approximation, `atan x = x + x³ P(x²)/Q(x²)` on
/// `[0, 0.66]`.
const ATAN_P: [f64; 5] = [
    -8.750_608_600_031_904_122_785e-1,
    -1.615_753_718_733_365_076_637e1,
    -7.500_855_792_314_704_667_340e1,
    -1.228_866_684_490_136_173_410e2,
    -6.485_021_904_942_025_371_773e1,
];
const ATAN_Q: [f64; 5] = [
    2.485_846_490_142_306_297_962e1,
    1.650_270_098_316_988_542_046e2,
    4.328_810_604_912_902_668_951e2,
    4.853_903_996_359_136_964_868e2,
    1.945_506_571_482_613_964_425e2,
];

/// `atan x` for `0 ≤ x ≤ 1`.
#[inline]
fn atan_unit<R: Real>(x: R) -> R {
    let (base, t) = if x > r(0.66) {
        (
            r::<R>(std::f64::consts::FRAC_PI_4),
            (x - r(1.0)) / (x + r(1.0)),
        )
    } else {
        (R::zero(), x)
    };
    let z = t * t;
    let mut p = r::<R>(ATAN_P[0]);
    for &c in &ATAN_P[1..] {
        p = p * z + r(c);
    }
    let mut q = z + r(ATAN_Q[0]);
    for &c in &ATAN_Q[1..] {
        q = q * z + r(c);
    }
    base + (t + t * z * p / q)
}

/// `atan2(y, x)` for `y, x ≥ 0`, not both zero: the angle in `[0, π/2]`.
#[inline]
pub fn atan2_pos<R: Real>(y: R, x: R) -> R {
    if y <= x {
        atan_unit(y / x)
    } else {
        r::<R>(std::f64::consts::FRAC_PI_2) - atan_unit(x / y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sincos_f64_matches_std() {
        let mut worst = 0.0f64;
        for i in 0..200_001 {
            let x = -64.0 + 128.0 * i as f64 / 200_000.0;
            let (s, c) = sincos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        // Reduction error grows with |x|·ε; 64·2.2e-16 ≈ 1.4e-14 at the ends.
        assert!(worst < 4e-16 * 64.0, "worst {worst:e}");
        for i in 0..100_001 {
            let x = 7.0 * i as f64 / 100_000.0;
            let (s, c) = sincos(x);
            assert!((s - x.sin()).abs() <= 3e-16, "sin {x}");
            assert!((c - x.cos()).abs() <= 3e-16, "cos {x}");
        }
        // tiny arguments keep relative precision
        let (s, c) = sincos(1e-20f64);
        assert_eq!(s, 1e-20);
        assert_eq!(c, 1.0);
    }

    #[test]
    fn sincos_f32_matches_std() {
        for i in 0..100_001 {
            let x = 7.0 * i as f64 / 100_000.0;
            let (s, c) = sincos(x as f32);
            let xf = (x as f32) as f64;
            assert!((s as f64 - xf.sin()).abs() <= 2.4e-7, "sin {x}");
            assert!((c as f64 - xf.cos()).abs() <= 2.4e-7, "cos {x}");
        }
    }

    #[test]
    fn atan2_matches_std() {
        for i in 0..=20_000 {
            let a = std::f64::consts::FRAC_PI_2 * i as f64 / 20_000.0;
            let (y, x) = (a.sin(), a.cos());
            let got = atan2_pos(y, x);
            assert!(
                (got - y.atan2(x)).abs() <= 4.5e-16,
                "{a}: {got} vs {}",
                y.atan2(x)
            );
            let got32 = atan2_pos(y as f32, x as f32) as f64;
            assert!((got32 - (y as f32 as f64).atan2(x as f32 as f64)).abs() <= 2.4e-7);
        }
        assert_eq!(atan2_pos(0.0f64, 1.0), 0.0);
        assert_eq!(atan2_pos(1.0f64, 0.0), std::f64::consts::FRAC_PI_2);
        assert_eq!(atan2_pos(1e-300f64, 1.0), 1e-300);
    }
}
