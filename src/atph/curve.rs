//! A spatial ATPH curve: `AtphCurve`, whose documentation gives its closed
//! form and differential geometry.

use glam::DVec3;

use super::bernstein::{Bernstein, Sign};
use super::tangent::SphericalTangent;

#[derive(Clone, Copy, Debug, PartialEq)]
/// A spatial ATPH curve on `ξ ∈ [0, 1]`: start point, unit tangent field
/// and signed speed.
///
/// The curve is `r(ξ) = r₀ + ∫₀^ξ ρ(t) T(t) dt`, `ξ ∈ [0, 1]` (Eq. 2.2),
/// with `T` from [`SphericalTangent`] and `ρ` a polynomial of
/// degree ≤ 3 in Bernstein form.
///
/// **Closed form.** With `ρ = Σ c_k tᵏ`, `r(ξ) = r₀ + Σ c_k V_k(ξ)` where
/// `V_k = ∫₀^ξ tᵏ T` ([`SphericalTangent::moment_vectors`]); in the
/// Bernstein coefficients this is Eq. (2.8) (quadratic) or (2.10) (cubic).
/// Accuracy: each `V_k` is good to a few ulps of `ξ^{k+1}`, and the
/// Bernstein-to-monomial weights are at most 6, so `r` is good to about
/// `1e-15 · Σ|ρ_j|` — a few ulps of the curve's size.
///
/// **Differential geometry** (Section 2): `r′ = ρT`, so `‖r′‖ = |ρ|`,
/// `κ = ‖T × T′‖/|ρ|`, `τ = det(T, T′, T″)/(ρ ‖T × T′‖²)` (the paper writes
/// `|ρ|` in `τ`, which flips its sign where `ρ < 0`; `det(r′, r″, r‴)` has
/// `ρ³`).
pub struct AtphCurve {
    /// `r₀ = r(0)`.
    pub start: DVec3,
    /// The unit tangent field `T(ξ)` (latitude and azimuth linear in `ξ`).
    pub tangent: SphericalTangent,
    /// `ρ`, the signed speed `r′ = ρT`.
    pub rho: Bernstein,
}

impl AtphCurve {
    /// `r(ξ)`, by the closed form (2.8)/(2.10).
    ///
    /// Constant latitude `π/4` and speed `ρ = 2π√2` over a full turn of azimuth is
    /// the helix of radius 1 about the line `x = 0, y = 1`, rising `2π` per turn:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_4, PI, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// assert!((helix.position(0.5) - DVec3::new(0.0, 2.0, PI)).length() < 1e-13);
    /// assert!((helix.position(1.0) - DVec3::new(0.0, 0.0, TAU)).length() < 1e-13);
    /// ```
    pub fn position(&self, xi: f64) -> DVec3 {
        let c = self.rho.monomial();
        let v = self.tangent.moment_vectors(xi);
        let mut r = DVec3::ZERO;
        for k in 0..=self.rho.degree() {
            r += c[k] * v[k];
        }
        self.start + r
    }

    /// `r′(ξ) = ρ(ξ) T(ξ)`.
    ///
    /// On the helix of radius 1 and pitch `2π` (latitude `π/4`), after a quarter
    /// turn, `r′ = ρT = (0, 2π, 2π)`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_4, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// assert!((helix.hodograph(0.25) - DVec3::new(0.0, TAU, TAU)).length() < 1e-13);
    /// ```
    pub fn hodograph(&self, xi: f64) -> DVec3 {
        self.rho.eval(xi) * self.tangent.at(xi)
    }

    /// The unit tangent of the curve as traversed, `sign(ρ) T` (`T` where
    /// `ρ = 0`).
    ///
    /// With `ρ < 0` the curve runs against its field:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let field = SphericalTangent::new(0.0, 0.0, 0.0, 1.0); // along the equator
    /// let fwd = AtphCurve { start: DVec3::ZERO, tangent: field, rho: Bernstein::new(&[1.0, 2.0, 1.0]) };
    /// let back = AtphCurve { rho: Bernstein::new(&[-1.0, -2.0, -1.0]), ..fwd };
    /// assert!((fwd.unit_tangent(0.0) - DVec3::X).length() < 1e-15);
    /// assert!((back.unit_tangent(0.0) + DVec3::X).length() < 1e-15);
    /// ```
    pub fn unit_tangent(&self, xi: f64) -> DVec3 {
        let t = self.tangent.at(xi);
        if self.rho.eval(xi) < 0.0 {
            -t
        } else {
            t
        }
    }

    /// Curvature `κ(ξ) = ‖T × T′‖ / |ρ|`.
    ///
    /// The helix of radius 1 and pitch `2π` (`c = 1`) has `κ = r/(r² + c²) = ½`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_4, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// assert!((helix.curvature(0.3) - 0.5).abs() < 1e-14);
    /// ```
    pub fn curvature(&self, xi: f64) -> f64 {
        let t = self.tangent.at(xi);
        t.cross(self.tangent.derivative(xi)).length() / self.rho.eval(xi).abs()
    }

    /// Torsion `τ(ξ) = det(T, T′, T″) / (ρ ‖T × T′‖²)`; `0` where the curve
    /// is straight (`T′ = 0`: the binormal is undefined).
    ///
    /// The right-handed helix of radius 1 and pitch `2π` has `τ = c/(r² + c²) = ½`;
    /// a curve in the equator plane has `τ = 0`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_4, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// assert!((helix.torsion(0.3) - 0.5).abs() < 1e-14);
    /// let flat = AtphCurve { tangent: SphericalTangent::new(0.0, 0.0, 0.0, 1.0), ..helix };
    /// assert_eq!(flat.torsion(0.3), 0.0);
    /// ```
    pub fn torsion(&self, xi: f64) -> f64 {
        let t = self.tangent.at(xi);
        let d1 = self.tangent.derivative(xi);
        let d2 = self.tangent.second_derivative(xi);
        let c = t.cross(d1);
        let c2 = c.length_squared();
        if c2 == 0.0 {
            return 0.0;
        }
        c.dot(d2) / (self.rho.eval(xi) * c2)
    }

    /// How `ρ` behaves on `[0, 1]` (exact test; see [`Bernstein::sign`]).
    ///
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, Sign, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let field = SphericalTangent::new(0.3, 0.2, 0.0, 1.0);
    /// let c = AtphCurve { start: DVec3::ZERO, tangent: field, rho: Bernstein::new(&[-1.0, -0.5, -2.0]) };
    /// assert_eq!(c.speed_sign(), Sign::Negative);
    /// ```
    pub fn speed_sign(&self) -> Sign {
        self.rho.sign()
    }

    /// Proposition 1: `ρ ≠ 0` on `[0, 1]`, so the curve has no singular
    /// point (it may run against `T` if `ρ < 0`).
    ///
    /// `ρ = (1 − 2ξ)²` (Bernstein `1, −1, 1`) vanishes at `ξ = ½`; Bernstein
    /// `1, −0.2, 1` has a negative coefficient but stays positive (`ρ(½) = 0.4`):
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let field = SphericalTangent::new(0.3, 0.2, 0.0, 1.0);
    /// let cusp = AtphCurve { start: DVec3::ZERO, tangent: field, rho: Bernstein::new(&[1.0, -1.0, 1.0]) };
    /// assert!(!cusp.is_regular());
    /// assert!(AtphCurve { rho: Bernstein::new(&[1.0, -0.2, 1.0]), ..cusp }.is_regular());
    /// ```
    pub fn is_regular(&self) -> bool {
        self.rho.sign() != Sign::Vanishes
    }

    /// Arc length from `0` to `ξ`, `∫₀^ξ |ρ|`, exact between the sign
    /// changes of `ρ`.
    ///
    /// `ρ = 1 − 2ξ` changes sign at `½`: `∫₀¹ ρ = 0` but `∫₀¹ |ρ| = ½`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let field = SphericalTangent::new(0.3, 0.2, 0.0, 1.0);
    /// let c = AtphCurve { start: DVec3::ZERO, tangent: field, rho: Bernstein::new(&[1.0, -1.0]) };
    /// assert!((c.arc_length_to(1.0) - 0.5).abs() < 1e-15);
    /// assert!((c.arc_length_to(0.25) - 0.1875).abs() < 1e-15); // ξ − ξ²
    /// ```
    pub fn arc_length_to(&self, xi: f64) -> f64 {
        let mut s = 0.0;
        let mut lo = 0.0;
        for r in self.rho.roots().into_iter().filter(|&r| r < xi) {
            s += (self.rho.integral_to(r) - self.rho.integral_to(lo)).abs();
            lo = r;
        }
        s + (self.rho.integral_to(xi) - self.rho.integral_to(lo)).abs()
    }

    /// The whole arc length, `∫₀¹ |ρ|` (= `|Σρ_j|/(n+1)` when regular).
    ///
    /// One turn of the helix of radius 1 and pitch `2π`: `2π√2`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_4, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// assert!((helix.length() - TAU * SQRT_2).abs() < 1e-14);
    /// ```
    pub fn length(&self) -> f64 {
        self.arc_length_to(1.0)
    }

    /// The parameter at arc length `s` (clamped to `[0, L]`): bisection on
    /// the nondecreasing `s(ξ)`, 60 halvings (to rounding in `ξ`).
    ///
    /// With `ρ = 1 + 2ξ` (Bernstein `1, 3`), `s(ξ) = ξ + ξ²`, so `s = ¾` at `ξ = ½`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let field = SphericalTangent::new(0.3, 0.2, 0.0, 1.0);
    /// let c = AtphCurve { start: DVec3::ZERO, tangent: field, rho: Bernstein::new(&[1.0, 3.0]) };
    /// assert!((c.param_at_length(0.75) - 0.5).abs() < 1e-14);
    /// assert_eq!(c.param_at_length(5.0), 1.0); // clamped
    /// ```
    pub fn param_at_length(&self, s: f64) -> f64 {
        let total = self.length();
        if !(s > 0.0) {
            return 0.0;
        }
        if s >= total {
            return 1.0;
        }
        crate::curve::bisect_unit(|xi| self.arc_length_to(xi), s)
    }

    /// `m ≥ 2` points equally spaced in arc length, ends included (in the
    /// parameter when the length is zero).
    ///
    /// Quarter turns of the helix of radius 1 and pitch `2π` about `x = 0, y = 1`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, SQRT_2, TAU};
    ///
    /// let helix = AtphCurve { start: DVec3::ZERO, tangent: SphericalTangent::new(FRAC_PI_4, 0.0, 0.0, TAU),
    ///     rho: Bernstein::new(&[TAU * SQRT_2; 3]) };
    /// let p = helix.sample(5);
    /// assert!((p[1] - DVec3::new(1.0, 1.0, FRAC_PI_2)).length() < 1e-12);
    /// assert!((p[3] - DVec3::new(-1.0, 1.0, 3.0 * FRAC_PI_2)).length() < 1e-12);
    /// ```
    pub fn sample(&self, m: usize) -> Vec<DVec3> {
        let m = m.max(2);
        let total = self.length();
        (0..m)
            .map(|i| {
                let f = i as f64 / (m - 1) as f64;
                let xi = if total > 0.0 {
                    if i == m - 1 {
                        1.0
                    } else {
                        self.param_at_length(f * total)
                    }
                } else {
                    f
                };
                self.position(xi)
            })
            .collect()
    }

    /// The same curve traversed from the other end: `r̃(ξ) = r(1 − ξ)`, with
    /// field `−T(1 − ξ)` and speed `ρ(1 − ξ)` (coefficients reversed).
    ///
    /// `r̃(ξ) = r(1 − ξ)`:
    /// ```
    /// use strandfit::atph::{AtphCurve, Bernstein, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// let c = AtphCurve { start: DVec3::ONE, tangent: SphericalTangent::new(0.3, 0.5, -0.2, 1.2),
    ///     rho: Bernstein::new(&[1.0, 2.0, 0.5, 1.5]) };
    /// let r = c.reversed();
    /// assert!((r.position(0.3) - c.position(0.7)).length() < 1e-14);
    /// assert!((r.unit_tangent(0.3) + c.unit_tangent(0.7)).length() < 1e-14);
    /// ```
    pub fn reversed(&self) -> Self {
        let mut c = [0.0; 4];
        let n = self.rho.degree();
        for (j, v) in self.rho.coefficients().iter().enumerate() {
            c[n - j] = *v;
        }
        AtphCurve {
            start: self.position(1.0),
            tangent: self.tangent.reversed(),
            rho: Bernstein::new(&c[..=n]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atph::moments::tests::gauss;

    /// Fig. 1 of the paper: `a₁ = 0.2π, a₀ = 0, b₁ = 0.4π, b₀ = 0`, three
    /// quadratic scalings.
    fn fig1() -> Vec<AtphCurve> {
        use std::f64::consts::PI;
        let field = SphericalTangent::new(0.0, 0.2 * PI, 0.0, 0.4 * PI);
        // ρ = b t² + c t + d → Bernstein (d, d + c/2, d + c + b), Eq. (2.7).
        let bern = |b: f64, c: f64, d: f64| Bernstein::new(&[d, d + c / 2.0, d + c + b]);
        [
            bern(0.002 * PI * PI, 0.01 * PI, 0.3),
            bern(0.001 * PI * PI, 0.06 * PI, 0.2),
            bern(0.003 * PI * PI, 0.02 * PI, 0.4),
        ]
        .into_iter()
        .map(|rho| AtphCurve {
            start: DVec3::ZERO,
            tangent: field,
            rho,
        })
        .collect()
    }

    #[test]
    fn closed_form_matches_quadrature_of_rho_t() {
        let mut curves = fig1();
        // A cubic ρ with a sign change, on a field with A₁ = 0.
        curves.push(AtphCurve {
            start: DVec3::new(1.0, -2.0, 0.5),
            tangent: SphericalTangent::new(0.4, -0.8, 1.0, 0.8),
            rho: Bernstein::new(&[1.0, -2.0, 2.0, 0.3]),
        });
        for c in &curves {
            for &xi in &[0.25, 0.8, 1.0] {
                let q = c.start
                    + DVec3::new(
                        gauss(|t| c.hodograph(t).x, xi, 200),
                        gauss(|t| c.hodograph(t).y, xi, 200),
                        gauss(|t| c.hodograph(t).z, xi, 200),
                    );
                assert!((c.position(xi) - q).length() < 1e-14, "{c:?} at {xi}");
            }
        }
    }

    #[test]
    fn curvature_torsion_and_length_match_numerics() {
        for c in fig1() {
            assert!(c.is_regular());
            // Length: the polynomial integral against quadrature of |r′|.
            let q = gauss(|t| c.hodograph(t).length(), 1.0, 200);
            assert!((c.length() - q).abs() < 1e-14);
            // κ, τ from finite differences of the closed-form position.
            let h = 1e-3;
            let x = 0.45;
            let d1 = (c.position(x + h) - c.position(x - h)) / (2.0 * h);
            let d2 = (c.position(x + h) - 2.0 * c.position(x) + c.position(x - h)) / (h * h);
            let d3 = (c.position(x + 2.0 * h) - 2.0 * c.position(x + h) + 2.0 * c.position(x - h)
                - c.position(x - 2.0 * h))
                / (2.0 * h * h * h);
            let k = d1.cross(d2).length() / d1.length().powi(3);
            let tau = d1.cross(d2).dot(d3) / d1.cross(d2).length_squared();
            assert!(
                (c.curvature(x) - k).abs() < 1e-5 * k,
                "{} {k}",
                c.curvature(x)
            );
            assert!((c.torsion(x) - tau).abs() < 1e-4 * tau.abs().max(1e-3));
        }
    }

    #[test]
    fn negative_speed_flips_torsion_sign_convention() {
        // r̃ with ρ → −ρ and T → −T is the same point set and direction;
        // κ and τ are geometric, so they must agree.
        let c = fig1()[0];
        let flipped = AtphCurve {
            start: c.start,
            tangent: SphericalTangent::new(
                -c.tangent.a0,
                -c.tangent.a1,
                c.tangent.b0 + std::f64::consts::PI,
                c.tangent.b1,
            ),
            rho: Bernstein::new(&c.rho.coefficients().iter().map(|v| -v).collect::<Vec<_>>()),
        };
        for &x in &[0.0, 0.5, 1.0] {
            assert!((flipped.position(x) - c.position(x)).length() < 1e-14);
            assert!((flipped.curvature(x) - c.curvature(x)).abs() < 1e-12);
            assert!((flipped.torsion(x) - c.torsion(x)).abs() < 1e-12);
        }
        assert_eq!(flipped.speed_sign(), Sign::Negative);
        assert!(flipped.is_regular());
    }

    #[test]
    fn sampling_and_reversal() {
        let c = AtphCurve {
            start: DVec3::ZERO,
            tangent: SphericalTangent::new(0.4, -0.8, 1.0, 1.3),
            rho: Bernstein::new(&[1.0, -2.0, 2.0, 0.3]),
        };
        assert!(!c.is_regular());
        let r = c.reversed();
        for i in 0..=10 {
            let x = i as f64 / 10.0;
            assert!((r.position(x) - c.position(1.0 - x)).length() < 1e-13);
        }
        // Equal arc-length spacing (on a regular curve: at a cusp chords
        // fold back).
        let c = fig1()[1];
        let pts = c.sample(41);
        assert_eq!(pts.len(), 41);
        assert!((pts[0] - c.position(0.0)).length() < 1e-15);
        assert!((pts[40] - c.position(1.0)).length() < 1e-15);
        let l = c.length();
        for w in pts.windows(2) {
            let d = (w[1] - w[0]).length();
            assert!(
                d <= l / 40.0 + 1e-12 && d > 0.99 * l / 40.0,
                "{d} vs {}",
                l / 40.0
            );
        }
    }
}
