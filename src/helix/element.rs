//! One circular helix element, `HelixElement`, whose documentation gives
//! its closed form, and the cancellation-free functions it is made of.

use glam::DVec3;

/// `sin x / x`, accurate for all `x` (series near 0).
///
/// `sinc(π/2) = 2/π`, and the series branch gives `1 − x²/6` near 0:
/// ```
/// use strandfit::helix::sinc;
/// use std::f64::consts::{FRAC_PI_2, PI};
///
/// assert!((sinc(FRAC_PI_2) - 2.0 / PI).abs() < 1e-15);
/// assert!((sinc(1e-5) - (1.0 - 1e-10 / 6.0)).abs() < 1e-16);
/// ```
#[inline]
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        let x2 = x * x;
        1.0 - x2 / 6.0 * (1.0 - x2 / 20.0)
    } else {
        x.sin() / x
    }
}

/// `(1 − cos x)/x² = ½ sinc²(x/2)`: the half-angle form has no cancellation.
///
/// It agrees with the direct form where that is accurate, and tends to `½`:
/// ```
/// use strandfit::helix::versinc2;
///
/// assert!((versinc2(2.0) - (1.0 - 2f64.cos()) / 4.0).abs() < 1e-15);
/// assert!((versinc2(1e-9) - 0.5).abs() < 1e-16);
/// ```
#[inline]
pub fn versinc2(x: f64) -> f64 {
    let s = sinc(0.5 * x);
    0.5 * s * s
}

/// `(x − sin x)/x³`. For `|x| < 1` the Taylor series
/// `Σₖ (−1)ᵏ x²ᵏ/(2k+3)!` to `k = 8` (next term < 1e-17 relative); beyond,
/// the direct form loses at most `6ε/x² < 1e-15` relative.
///
/// It agrees with the direct form where that is accurate, and tends to `1/6`:
/// ```
/// use strandfit::helix::sinc_defect3;
///
/// assert!((sinc_defect3(2.0) - (2.0 - 2f64.sin()) / 8.0).abs() < 1e-15);
/// // Here the direct form loses every digit: x − sin x is below x's rounding.
/// assert!((sinc_defect3(1e-8) - 1.0 / 6.0).abs() < 1e-15);
/// ```
#[inline]
pub fn sinc_defect3(x: f64) -> f64 {
    if x.abs() < 1.0 {
        // 1/(2k+3)! for k = 0..=8, alternating signs applied in Horner.
        const C: [f64; 9] = [
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
        let x2 = x * x;
        let mut acc = 0.0;
        for (k, c) in C.iter().enumerate().rev() {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            acc = acc * x2 + sign * c;
        }
        acc
    } else {
        (x - x.sin()) / (x * x * x)
    }
}

/// An orthonormal Frenet-type frame `(t, n, b)`, `b = t × n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Unit tangent `t`.
    pub tangent: DVec3,
    /// Unit principal normal `n`.
    pub normal: DVec3,
    /// Unit binormal `b = t × n`.
    pub binormal: DVec3,
}

/// One helical element of a piecewise helix.
///
/// For a straight element (`κ = 0`) the normal is not defined by the
/// geometry; it is kept as a reference direction (any unit vector ⊥ `t₀`) so
/// that frames can be carried through straight runs, and `τ` is 0.
///
/// # Closed form
///
/// The element has constant curvature `κ ≥ 0` and torsion `τ`.
///
/// The element is stored by its start point `p₀` and start Frenet frame
/// `(t₀, n₀, b₀ = t₀ × n₀)`. Its Darboux vector `Ω = τ t + κ b` is constant,
/// with length `ω = √(κ² + τ²)` and unit axis `Ω̄ = (τ t₀ + κ b₀)/ω`; the whole
/// frame rotates about `Ω̄` at rate `ω` (paper 000, Eqs. (A.3)–(A.4)).
///
/// Eq. (7)/(A.9) of the paper writes the helix with `sin(ωs)/ω` and
/// `(1 − cos ωs)/ω`, which lose all precision as `ω → 0`. Expanding
/// `Ω̄`, `t₀ − τ̄Ω̄ = κ̄(κ̄t₀ − τ̄b₀)` and `t₀ × Ω̄ = −κ̄n₀` gives the equivalent
/// form used here, with `φ = ωs`,
///
/// ```text
/// α(s) = p₀ + (s − κ²s³ g(φ)) t₀ + κ s² h(φ) n₀ + κτ s³ g(φ) b₀
/// t(s) = (1 − κ²s² h(φ)) t₀ + κ s sinc(φ) n₀ + κτ s² h(φ) b₀
/// n(s) = cos φ n₀ + s sinc(φ) (τ b₀ − κ t₀)
/// b(s) = (1 − τ²s² h(φ)) b₀ − τ s sinc(φ) n₀ + κτ s² h(φ) t₀
/// ```
///
/// where `sinc x = sin x / x`, `h(x) = (1 − cos x)/x²` and
/// `g(x) = (x − sin x)/x³`, all evaluated without cancellation. The straight
/// segment (`κ = τ = 0`) is the ordinary special case `α(s) = p₀ + s t₀`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HelixElement {
    /// Start point `p₀`.
    pub start: DVec3,
    /// Unit start tangent `t₀`.
    pub tangent: DVec3,
    /// Unit start principal normal `n₀` (⊥ `t₀`).
    pub normal: DVec3,
    /// Curvature `κ ≥ 0`.
    pub curvature: f64,
    /// Signed torsion `τ` (right-handed helix: `τ > 0`).
    pub torsion: f64,
    /// Arc length `L ≥ 0`.
    pub length: f64,
}

impl HelixElement {
    /// A straight segment of length `length` along the unit vector `tangent`.
    ///
    /// The end point is `start + L·tangent`, and the kept normal is ⊥ the tangent:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let e = HelixElement::straight(DVec3::ONE, DVec3::Z, 2.5);
    /// assert!((e.end_point() - DVec3::new(1.0, 1.0, 3.5)).length() < 1e-15);
    /// assert!(e.normal.dot(DVec3::Z).abs() < 1e-15 && (e.normal.length() - 1.0).abs() < 1e-15);
    /// ```
    pub fn straight(start: DVec3, tangent: DVec3, length: f64) -> Self {
        HelixElement {
            start,
            tangent,
            normal: tangent.any_orthonormal_vector(),
            curvature: 0.0,
            torsion: 0.0,
            length,
        }
    }

    /// Length of the Darboux vector, `ω = √(κ² + τ²)`.
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let h = HelixElement { start: DVec3::ZERO, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 0.8, torsion: -0.6, length: 1.0 };
    /// assert!((h.omega() - 1.0).abs() < 1e-15);
    /// ```
    #[inline]
    pub fn omega(&self) -> f64 {
        self.curvature.hypot(self.torsion)
    }

    /// Total turning angle about the axis, `φ* = ωL` (the "azimuth" of paper 000).
    ///
    /// A helix of radius 1 and pitch `2π·0.5` turns once in `L = 2π√1.25`:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::PI;
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 2.0 * PI * 1.25f64.sqrt() };
    /// assert!((h.phi() - 2.0 * PI).abs() < 1e-12);
    /// ```
    #[inline]
    pub fn phi(&self) -> f64 {
        self.omega() * self.length
    }

    /// Start binormal `b₀ = t₀ × n₀`.
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let e = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let e = HelixElement { normal: DVec3::Y, ..e };
    /// assert_eq!(e.binormal(), DVec3::Z);
    /// ```
    #[inline]
    pub fn binormal(&self) -> DVec3 {
        self.tangent.cross(self.normal)
    }

    /// Unit helix axis `Ω̄ = (τ t₀ + κ b₀)/ω`; the tangent for a straight element.
    ///
    /// A helix winding about the `z` axis (radius 1, `κ = 0.8`, `τ = 0.4`):
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 1.0 };
    /// assert!((h.axis() - DVec3::Z).length() < 1e-15);
    /// ```
    pub fn axis(&self) -> DVec3 {
        let w = self.omega();
        if w == 0.0 {
            return self.tangent;
        }
        (self.torsion * self.tangent + self.curvature * self.binormal()) / w
    }

    /// Radius of the cylinder the helix winds on, `κ/ω²` (∞ when straight).
    ///
    /// `κ = r/(r² + c²)`, `τ = c/(r² + c²)` for radius `r = 2`, pitch `2π·c`, `c = 1`:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let h = HelixElement { start: DVec3::ZERO, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 2.0 / 5.0, torsion: 1.0 / 5.0, length: 1.0 };
    /// assert!((h.radius() - 2.0).abs() < 1e-15);
    /// ```
    pub fn radius(&self) -> f64 {
        let w = self.omega();
        self.curvature / (w * w)
    }

    /// Point at arc length `s` from the start (any real `s`; the element is
    /// the part `0 ≤ s ≤ L`).
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::PI;
    ///
    /// // One turn of a helix of radius 1 and pitch 2π·0.5: κ = 1/(1 + 0.25), τ = 0.5/(1 + 0.25).
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 2.0 * PI * 1.25f64.sqrt() };
    /// let end = h.point(h.length);
    /// assert!((end - DVec3::new(1.0, 0.0, PI)).length() < 1e-12);
    /// ```
    #[inline]
    pub fn point(&self, s: f64) -> DVec3 {
        let (k, tau) = (self.curvature, self.torsion);
        let phi = self.omega() * s;
        let g = sinc_defect3(phi);
        let h = versinc2(phi);
        let s2 = s * s;
        let s3 = s2 * s;
        self.start
            + (s - k * k * s3 * g) * self.tangent
            + (k * s2 * h) * self.normal
            + (k * tau * s3 * g) * self.binormal()
    }

    /// Unit tangent at arc length `s`.
    ///
    /// After a quarter turn about `z` the tangent has turned from `+y` to `−x`:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 1.0 };
    /// let t = h.tangent_at(FRAC_PI_2 * 1.25f64.sqrt());
    /// assert!((t - DVec3::new(-1.0, 0.0, 0.5).normalize()).length() < 1e-15);
    /// ```
    #[inline]
    pub fn tangent_at(&self, s: f64) -> DVec3 {
        self.frame(s).tangent
    }

    /// Frenet frame at arc length `s`: the start frame rotated by `ωs` about `Ω̄`.
    ///
    /// The normal points at the axis (`z`), and the frame stays orthonormal:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 1.0 };
    /// let f = h.frame(FRAC_PI_2 * 1.25f64.sqrt()); // a quarter turn, at (0, 1, π/4)
    /// assert!((f.normal - -DVec3::Y).length() < 1e-15);
    /// assert!((f.tangent.cross(f.normal) - f.binormal).length() < 1e-15);
    /// ```
    #[inline]
    pub fn frame(&self, s: f64) -> Frame {
        let (k, tau) = (self.curvature, self.torsion);
        let phi = self.omega() * s;
        let sc = s * sinc(phi);
        let h = s * s * versinc2(phi);
        let (t0, n0, b0) = (self.tangent, self.normal, self.binormal());
        Frame {
            tangent: (1.0 - k * k * h) * t0 + (k * sc) * n0 + (k * tau * h) * b0,
            normal: phi.cos() * n0 + sc * (tau * b0 - k * t0),
            binormal: (1.0 - tau * tau * h) * b0 - (tau * sc) * n0 + (k * tau * h) * t0,
        }
    }

    /// End point `α(L)`.
    ///
    /// Half a turn of a helix of radius 1 and pitch `2π·0.5`:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::{FRAC_PI_2, PI};
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: PI * 1.25f64.sqrt() };
    /// assert!((h.end_point() - DVec3::new(-1.0, 0.0, FRAC_PI_2)).length() < 1e-14);
    /// ```
    #[inline]
    pub fn end_point(&self) -> DVec3 {
        self.point(self.length)
    }

    /// End frame at `s = L`.
    ///
    /// After one full turn the frame is back to the start frame:
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    /// use std::f64::consts::PI;
    ///
    /// let h = HelixElement { start: DVec3::X, tangent: DVec3::new(0.0, 1.0, 0.5).normalize(),
    ///     normal: -DVec3::X, curvature: 0.8, torsion: 0.4, length: 2.0 * PI * 1.25f64.sqrt() };
    /// let f = h.end_frame();
    /// assert!((f.tangent - h.tangent).length() < 1e-14 && (f.normal - h.normal).length() < 1e-14);
    /// ```
    #[inline]
    pub fn end_frame(&self) -> Frame {
        self.frame(self.length)
    }

    /// Every parameter is finite (signs are not checked: a negative `κ` or
    /// `L` passes).
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement};
    ///
    /// let e = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// assert!(e.is_finite());
    /// assert!(!HelixElement { curvature: f64::NAN, ..e }.is_finite());
    /// ```
    pub fn is_finite(&self) -> bool {
        self.start.is_finite()
            && self.tangent.is_finite()
            && self.normal.is_finite()
            && self.curvature.is_finite()
            && self.torsion.is_finite()
            && self.length.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_at(e: &HelixElement, s: f64) -> [DVec3; 3] {
        let f = e.frame(s);
        [f.tangent, f.normal, f.binormal]
    }

    fn sample_element() -> HelixElement {
        let t = DVec3::new(1.0, 2.0, -0.5).normalize();
        let n = t.any_orthonormal_vector();
        HelixElement {
            start: DVec3::new(0.3, -1.0, 2.0),
            tangent: t,
            normal: n,
            curvature: 0.7,
            torsion: -0.4,
            length: 5.0,
        }
    }

    #[test]
    fn series_match_direct_forms_where_direct_is_accurate() {
        for &x in &[0.9f64, 1.0, 1.1, 0.5, 0.2] {
            let direct = (x - x.sin()) / (x * x * x);
            assert!((sinc_defect3(x) - direct).abs() < 1e-12 * direct, "x={x}");
            let v = (1.0 - x.cos()) / (x * x);
            assert!((versinc2(x) - v).abs() < 1e-14, "x={x}");
        }
        // Continuity across the series cut-off at |x| = 1.
        let below = sinc_defect3(1.0 - 1e-12);
        let above = sinc_defect3(1.0 + 1e-12);
        assert!((below - above).abs() < 1e-13); // g changes by ≈3e-14 over 2e-12
        assert!((sinc(1e-4 - 1e-15) - sinc(1e-4 + 1e-15)).abs() < 1e-15);
    }

    #[test]
    fn frame_stays_orthonormal_and_tangent_is_derivative_of_point() {
        let e = sample_element();
        for i in 0..=20 {
            let s = e.length * i as f64 / 20.0;
            let [t, n, b] = frame_at(&e, s);
            assert!((t.length() - 1.0).abs() < 1e-14);
            assert!((n.length() - 1.0).abs() < 1e-14);
            assert!(t.dot(n).abs() < 1e-14 && t.dot(b).abs() < 1e-14);
            assert!((t.cross(n) - b).length() < 1e-14);
            // central difference of the position, O(h²) accurate.
            let hh = 1e-5;
            let fd = (e.point(s + hh) - e.point(s - hh)) / (2.0 * hh);
            assert!((fd - t).length() < 1e-9, "s={s}: {fd} vs {t}");
            // Frenet–Serret: t' = κ n, b' = −τ n.
            let dt = (e.tangent_at(s + hh) - e.tangent_at(s - hh)) / (2.0 * hh);
            assert!((dt - e.curvature * n).length() < 1e-8);
            let db = (e.frame(s + hh).binormal - e.frame(s - hh).binormal) / (2.0 * hh);
            assert!((db + e.torsion * n).length() < 1e-8);
        }
    }

    #[test]
    fn right_handed_helix_has_positive_torsion() {
        // Standard right-handed helix (a cos u, a sin u, c u), a, c > 0.
        let (a, c) = (2.0f64, 0.5f64);
        let m = (a * a + c * c).sqrt();
        let kappa = a / (m * m);
        let tau = c / (m * m);
        let t0 = DVec3::new(0.0, a, c) / m;
        let n0 = DVec3::new(-1.0, 0.0, 0.0);
        let e = HelixElement {
            start: DVec3::new(a, 0.0, 0.0),
            tangent: t0,
            normal: n0,
            curvature: kappa,
            torsion: tau,
            length: 3.0 * m,
        };
        for i in 0..=10 {
            let u = 3.0 * i as f64 / 10.0;
            let exact = DVec3::new(a * u.cos(), a * u.sin(), c * u);
            assert!((e.point(u * m) - exact).length() < 1e-13);
        }
        assert!((e.axis() - DVec3::Z).length() < 1e-15);
        assert!((e.radius() - a).abs() < 1e-14);
    }

    #[test]
    fn tiny_and_zero_omega_are_continuous() {
        let mut e = sample_element();
        e.curvature = 0.0;
        e.torsion = 0.0;
        assert!((e.point(2.0) - (e.start + 2.0 * e.tangent)).length() < 1e-15);
        e.curvature = 1e-12;
        let p = e.point(2.0);
        let expected = e.start + 2.0 * e.tangent + 0.5 * 1e-12 * 4.0 * e.normal;
        assert!((p - expected).length() < 1e-15);
    }

    #[test]
    fn axis_is_fixed_by_the_motion() {
        let e = sample_element();
        let ax = e.axis();
        // t·Ω̄ = τ̄ along the whole element (constant angle with the axis).
        let tbar = e.torsion / e.omega();
        for i in 0..=10 {
            let t = e.tangent_at(e.length * i as f64 / 10.0);
            assert!((t.dot(ax) - tbar).abs() < 1e-14);
        }
    }
}
