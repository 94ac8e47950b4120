//! Fixed-order Gauss–Legendre quadrature.
//!
//! The 8-point rule is exact for polynomials of degree ≤ 15 and its error on
//! a panel of width `h` is `O(h¹⁶ f⁽¹⁶⁾)`. The arc-length integrand `|B'(t)|`
//! is the square root of a quartic; it is analytic on `[0, 1]` except near
//! cusps (where `B'` nearly vanishes), so on all but a few panels the rule
//! converges extremely fast and adaptive bisection only has to work near the
//! near-singular points.

// Digits beyond f64 are kept so the constants can be checked against tables.
#![allow(clippy::excessive_precision)]

/// Abscissae `xᵢ > 0` of the 8-point rule on `[−1, 1]` (symmetric pairs ±xᵢ).
const X: [f64; 4] = [
    0.183_434_642_495_649_804_939_476_142_360_2,
    0.525_532_409_916_328_985_817_739_049_189_3,
    0.796_666_477_413_626_739_591_553_936_475_8,
    0.960_289_856_497_536_231_683_560_868_569_5,
];

/// Weights `wᵢ` matching [`X`]; `2 Σ wᵢ = 2`.
const W: [f64; 4] = [
    0.362_683_783_378_361_982_965_150_449_277_2,
    0.313_706_645_877_887_287_337_962_201_986_6,
    0.222_381_034_453_374_470_544_355_994_426_2,
    0.101_228_536_290_376_259_152_531_354_309_9,
];

/// `∫ₐᵇ f(t) dt` by the 8-point Gauss–Legendre rule (16 ops + 8 calls).
///
/// Works for `b < a` too (returns the negated integral) and gives exactly 0
/// for `a == b`.
#[inline]
pub(crate) fn gl8(a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
    let mid = 0.5 * (a + b);
    let half = 0.5 * (b - a);
    let mut sum = 0.0;
    for i in 0..4 {
        let dx = half * X[i];
        sum += W[i] * (f(mid - dx) + f(mid + dx));
    }
    sum * half
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_degree_15() {
        // ∫₀¹ (16 t¹⁵ + 3 t²) dt = 1 + 1 = 2.
        let v = gl8(0.0, 1.0, |t| 16.0 * t.powi(15) + 3.0 * t * t);
        assert!((v - 2.0).abs() < 1e-14, "{v}");
        // Degree 16 is not integrated exactly: the rule really has order 16.
        let v = gl8(0.0, 1.0, |t| 17.0 * t.powi(16));
        assert!((v - 1.0).abs() > 1e-12, "{v}");
    }

    #[test]
    fn weights_sum_to_one_on_unit_interval() {
        let v = gl8(0.0, 1.0, |_| 1.0);
        assert!((v - 1.0).abs() < 1e-15);
    }
}
