//! Trigonometric moments `M_k(ξ) = ∫₀^ξ tᵏ e^{i(ωt + α)} dt`, `k = 0..=3`:
//! `trig_moments`, whose documentation gives the two regimes.

/// `M_k`, `k = 0..=3`, as real and imaginary parts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Real parts of `M₀ … M₃`.
    pub re: [f64; 4],
    /// Imaginary parts of `M₀ … M₃`.
    pub im: [f64; 4],
}

/// Below this `|ωξ|` the series is summed; at and above it, the closed form.
pub const SERIES_BELOW: f64 = 2.0;

/// `∫₀^ξ tᵏ e^{i(ωt + α)} dt` for `k = 0, 1, 2, 3`.
///
/// At `ω = π` (closed form): `M₀ = ∫₀¹ e^{iπt} dt = 2i/π` and
/// `Re M₁ = ∫₀¹ t cos πt dt = −2/π²`; at `ω = 0` (series): `M_k = 1/(k + 1)`:
/// ```
/// use strandfit::atph::trig_moments;
/// use std::f64::consts::PI;
///
/// let m = trig_moments(PI, 0.0, 1.0);
/// assert!(m.re[0].abs() < 1e-15 && (m.im[0] - 2.0 / PI).abs() < 1e-15);
/// assert!((m.re[1] + 2.0 / (PI * PI)).abs() < 1e-15);
/// let m = trig_moments(0.0, 0.0, 1.0);
/// assert!((0..4).all(|k| (m.re[k] - 1.0 / (k + 1) as f64).abs() < 1e-15 && m.im[k] == 0.0));
/// ```
///
/// # Method
///
/// Every closed form of paper 002 is made of these: with `ρ(t) = Σ c_k tᵏ`, the
/// coordinates (2.3) of the ATPH curve are `Re/Im` parts of `Σ c_k M_k` at the
/// three frequencies `A₁ = a₁ + b₁`, `B₁ = a₁ − b₁` and `a₁`
/// ([`SphericalTangent::moment_vectors`](super::SphericalTangent::moment_vectors)).
/// The paper's `B_x`, `C_x`, `D_x` of (2.5) are `Re M₂ + Re M₂'`,
/// `Re M₁ + Re M₁'`, `Re M₀ + Re M₀'` (primes: frequency `B₁`), and `A_x` of
/// (2.6) is the same with `M₃`; likewise `y` with `Im` and `z` with `Im` at
/// `a₁`.
///
/// Two regimes. For `|ωξ| ≥ 2` the closed form: integration by parts,
/// `M_k = [tᵏ e^{i(ωt+α)}/(iω)]₀^ξ − (k/(iω)) M_{k−1}`, which is (2.5) and
/// (2.6) with the errata of `ERRATA.md` (constants `1/A₁²` in `C`, `1/A₁` in
/// `D`). Its terms grow like `k!/|ω|^{k+1}` while the moment stays about
/// `ξ^{k+1}/(k+1)`, so for small `|ωξ|` it cancels catastrophically and at
/// `ω = 0` it divides by zero — the paper's "zero-divisor cases" `a₁ = 0`,
/// `A₁ = 0`, `B₁ = 0`. There the power series
/// `M_k = e^{iα} ξ^{k+1} Σₙ (iωξ)ⁿ / (n! (n + k + 1))` is used instead; it is
/// the same function (the paper's "recompute the formulae", done once for
/// every case, including `ω` merely small). At the switch `|ωξ| = 2` the
/// recurrence's largest term is `6ξ⁴/16 < 1.5 |M₃|`, so neither regime loses
/// more than a few ulps; the tests check both against quadrature across it.
#[inline]
pub fn trig_moments(omega: f64, alpha: f64, xi: f64) -> Moments {
    if (omega * xi).abs() < SERIES_BELOW {
        series(omega, alpha, xi)
    } else {
        closed_form(omega, alpha, xi)
    }
}

/// Integration by parts, Eqs. (2.5)–(2.6) (corrected).
fn closed_form(omega: f64, alpha: f64, xi: f64) -> Moments {
    let (s1, c1) = (omega * xi + alpha).sin_cos();
    let (s0, c0) = alpha.sin_cos();
    let inv = 1.0 / omega;
    let mut m = Moments::default();
    // (x + iy)/(iω) = (y − ix)/ω.
    m.re[0] = (s1 - s0) * inv;
    m.im[0] = -(c1 - c0) * inv;
    let mut xk = 1.0;
    for k in 1..4 {
        xk *= xi;
        let kf = k as f64;
        let x = xk * c1 - kf * m.re[k - 1];
        let y = xk * s1 - kf * m.im[k - 1];
        m.re[k] = y * inv;
        m.im[k] = -x * inv;
    }
    m
}

/// `e^{iα} ξ^{k+1} Σₙ (iu)ⁿ/(n!(n+k+1))`, `u = ωξ`, `|u| < 2`: the terms fall
/// below `2⁻⁶⁰` of the first by `n = 30`.
fn series(omega: f64, alpha: f64, xi: f64) -> Moments {
    let u = omega * xi;
    let mut sr = [0.0f64; 4];
    let mut si = [0.0f64; 4];
    // p = uⁿ/n!, with the sign of iⁿ folded in: iⁿ = 1, i, −1, −i, …
    let mut p = 1.0f64;
    for n in 0..40usize {
        let nf = n as f64;
        for k in 0..4 {
            let term = p / (nf + k as f64 + 1.0);
            match n & 3 {
                0 => sr[k] += term,
                1 => si[k] += term,
                2 => sr[k] -= term,
                _ => si[k] -= term,
            }
        }
        p *= u / (nf + 1.0);
        if p.abs() < 1e-18 {
            break;
        }
    }
    let (sa, ca) = alpha.sin_cos();
    let mut m = Moments::default();
    let mut xk = xi;
    for k in 0..4 {
        m.re[k] = xk * (ca * sr[k] - sa * si[k]);
        m.im[k] = xk * (ca * si[k] + sa * sr[k]);
        xk *= xi;
    }
    m
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Composite Gauss–Legendre (5 points, `panels` panels) of `f` on `[0, x]`.
    pub(crate) fn gauss<F: Fn(f64) -> f64>(f: F, x: f64, panels: usize) -> f64 {
        const NODES: [f64; 5] = [
            -0.906_179_845_938_664,
            -0.538_469_310_105_683,
            0.0,
            0.538_469_310_105_683,
            0.906_179_845_938_664,
        ];
        const WEIGHTS: [f64; 5] = [
            0.236_926_885_056_189,
            0.478_628_670_499_366,
            0.568_888_888_888_889,
            0.478_628_670_499_366,
            0.236_926_885_056_189,
        ];
        let h = x / panels as f64;
        let mut s = 0.0;
        for p in 0..panels {
            let mid = (p as f64 + 0.5) * h;
            for (n, w) in NODES.iter().zip(WEIGHTS) {
                s += w * f(mid + 0.5 * h * n);
            }
        }
        0.5 * h * s
    }

    #[test]
    fn moments_match_quadrature_in_both_regimes() {
        // Frequencies across the switch, both signs, zero and tiny (the
        // paper's zero-divisor cases), up to many turns.
        let omegas = [
            0.0, 1e-12, -1e-7, 0.3, -1.0, 1.999, 2.0, 2.001, -2.5, 3.0, 7.5, -20.0, 60.0,
        ];
        let mut worst = 0.0f64;
        for &w in &omegas {
            for &alpha in &[0.0, 0.7, -2.9, 10.0] {
                for &xi in &[1.0, 0.5, 0.03] {
                    let m = trig_moments(w, alpha, xi);
                    for k in 0..4 {
                        let re = gauss(|t| t.powi(k as i32) * (w * t + alpha).cos(), xi, 400);
                        let im = gauss(|t| t.powi(k as i32) * (w * t + alpha).sin(), xi, 400);
                        let err = (m.re[k] - re).abs().max((m.im[k] - im).abs());
                        // Relative to the size the moment can have, ξ^{k+1}/(k+1).
                        let scale = xi.powi(k as i32 + 1) / (k as f64 + 1.0);
                        worst = worst.max(err / scale);
                        assert!(
                            err <= 1e-13 * scale,
                            "ω={w} α={alpha} ξ={xi} k={k}: {err:e}"
                        );
                    }
                }
            }
        }
        eprintln!("worst moment error / scale: {worst:e}");
    }

    #[test]
    fn the_two_regimes_meet_at_the_switch() {
        // Just below and at the switch the series and the recurrence are the
        // same function: they must agree to rounding on both sides.
        for &alpha in &[0.0, 1.3, -0.4] {
            for &w in &[1.5, 2.0, 3.0, -2.0] {
                let a = series(w, alpha, 1.0);
                let b = closed_form(w, alpha, 1.0);
                for k in 0..4 {
                    assert!((a.re[k] - b.re[k]).abs() < 4e-15, "{w} {k}");
                    assert!((a.im[k] - b.im[k]).abs() < 4e-15, "{w} {k}");
                }
            }
        }
    }

    #[test]
    fn errata_constants_of_2_5() {
        // ERRATA 002.1: in (2.5) the constant of C_x is 1/A1² and of D_x is
        // 1/A1, not 1/A1³ as printed. Written out with the corrected
        // constants they equal the moments; as printed they do not.
        let (a1, a0, xi) = (1.3f64, 0.4f64, 1.0f64);
        let m = closed_form(a1, a0, xi);
        let c_corrected = xi / a1 * (a1 * xi + a0).sin() + (a1 * xi + a0).cos() / (a1 * a1)
            - a0.cos() / (a1 * a1);
        let c_printed = xi / a1 * (a1 * xi + a0).sin() + (a1 * xi + a0).cos() / (a1 * a1)
            - a0.cos() / a1.powi(3);
        let d_corrected = (a1 * xi + a0).sin() / a1 - a0.sin() / a1;
        let d_printed = (a1 * xi + a0).sin() / a1 - a0.sin() / a1.powi(3);
        assert!((m.re[1] - c_corrected).abs() < 1e-15);
        assert!((m.re[0] - d_corrected).abs() < 1e-15);
        assert!((m.re[1] - c_printed).abs() > 0.05);
        assert!((m.re[0] - d_printed).abs() > 0.05);
        // B_x and A_x are printed right.
        let s = (a1 * xi + a0).sin();
        let c = (a1 * xi + a0).cos();
        let b_x = (xi * xi / a1 - 2.0 / a1.powi(3)) * s
            + 2.0 / (a1 * a1) * xi * c
            + 2.0 / a1.powi(3) * a0.sin();
        let a_x = (xi.powi(3) / a1 - 6.0 / a1.powi(3) * xi) * s
            + (3.0 / (a1 * a1) * xi * xi - 6.0 / a1.powi(4)) * c
            + 6.0 / a1.powi(4) * a0.cos();
        assert!((m.re[2] - b_x).abs() < 1e-15);
        assert!((m.re[3] - a_x).abs() < 1e-15);
    }
}
