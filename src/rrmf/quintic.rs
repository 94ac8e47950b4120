//! PH quintics from a quadratic quaternion pre-image (Section 2.1): see
//! `PhQuintic`.

use glam::DVec3;

use super::quat::{Quat, I, J, K};

/// A PH quintic `𝐫(t) = 𝐫₀ + ∫₀ᵗ 𝒜𝐢𝒜*`, `t ∈ [0, 1]`.
///
/// The pre-image is quadratic (Section 2.1):
/// `𝒜(t) = 𝒜₀B₀²(t) + 𝒜₁B₁²(t) + 𝒜₂B₂²(t)`, hodograph `𝐡 = 𝒜 𝐢 𝒜*`
/// (Eq. 2.7 with `ρ = 1`), so the parametric speed is the polynomial
/// `σ = |𝒜|²` and the arc length is exact.
///
/// * hodograph control points `𝐡₀…𝐡₄` (2.8) and curve control points
///   `𝐫₀…𝐫₅` (2.10);
/// * speed weights `w₀…w₄` (2.12): `σ(t) = Σ wᵢ Bᵢ⁴(t)`, and the arc length
///   `s(t) = ∫σ`, a quintic in Bernstein form with coefficients
///   `sₖ = (w₀ + … + w_{k−1})/5`;
/// * the tangent indicatrix `𝐭 = 𝐡/σ` (2.11) and the Euler–Rodrigues frame
///   `(𝒜𝐢𝒜*, 𝒜𝐣𝒜*, 𝒜𝐤𝒜*)/|𝒜|²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhQuintic {
    /// `𝐫(0)`.
    pub start: DVec3,
    /// `𝒜₀, 𝒜₁, 𝒜₂`.
    pub pre_image: [Quat; 3],
}

/// `B₀², B₁², B₂²` at `t`.
///
/// A partition of unity: at `t = ¼`, `(9, 6, 1)/16`:
/// ```
/// use strandfit::rrmf::bernstein2;
///
/// assert_eq!(bernstein2(0.25), [0.5625, 0.375, 0.0625]);
/// ```
#[inline]
pub fn bernstein2(t: f64) -> [f64; 3] {
    let u = 1.0 - t;
    [u * u, 2.0 * t * u, t * t]
}

/// de Casteljau for any `Copy` value with `+` and scaling.
fn de_casteljau<const N: usize>(mut c: [DVec3; N], t: f64) -> DVec3 {
    for r in 1..N {
        for j in 0..N - r {
            c[j] = (1.0 - t) * c[j] + t * c[j + 1];
        }
    }
    c[0]
}

fn de_casteljau_f64<const N: usize>(mut c: [f64; N], t: f64) -> f64 {
    for r in 1..N {
        for j in 0..N - r {
            c[j] = (1.0 - t) * c[j] + t * c[j + 1];
        }
    }
    c[0]
}

impl PhQuintic {
    /// The PH quintic from `start` with pre-image Bernstein coefficients `pre_image`.
    pub fn new(start: DVec3, pre_image: [Quat; 3]) -> Self {
        PhQuintic { start, pre_image }
    }

    /// `𝒜(t)`.
    ///
    /// At `t = ½`: `(𝒜₀ + 2𝒜₁ + 𝒜₂)/4`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let [a0, a1, a2] = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, [a0, a1, a2]);
    /// let want = (a0 + a1 * 2.0 + a2) * 0.25;
    /// assert!((c.pre_image_at(0.5) - want).norm() < 1e-15);
    /// ```
    pub fn pre_image_at(&self, t: f64) -> Quat {
        let b = bernstein2(t);
        let [a0, a1, a2] = self.pre_image;
        a0 * b[0] + a1 * b[1] + a2 * b[2]
    }

    /// `𝒜′(t) = 2(1 − t)(𝒜₁ − 𝒜₀) + 2t(𝒜₂ − 𝒜₁)`.
    ///
    /// It matches a central difference of [`pre_image_at`](Self::pre_image_at):
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let h = 1e-5;
    /// let fd = (c.pre_image_at(0.3 + h) - c.pre_image_at(0.3 - h)) * (0.5 / h);
    /// assert!((c.pre_image_derivative(0.3) - fd).norm() < 1e-9);
    /// ```
    pub fn pre_image_derivative(&self, t: f64) -> Quat {
        let [a0, a1, a2] = self.pre_image;
        (a1 - a0) * (2.0 * (1.0 - t)) + (a2 - a1) * (2.0 * t)
    }

    /// `𝐡₀ … 𝐡₄` (Eq. 2.8), with `𝐡ᵢ` in the ⋆ notation of (3.2).
    ///
    /// The end control points are the end hodographs:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let h = c.hodograph_control_points();
    /// assert!((h[0] - c.hodograph(0.0)).length() < 1e-15 && (h[4] - c.hodograph(1.0)).length() < 1e-15);
    /// ```
    pub fn hodograph_control_points(&self) -> [DVec3; 5] {
        let [a0, a1, a2] = self.pre_image;
        [
            a0.star(a0),
            a0.star(a1),
            // ⅙(𝒜₂𝐢𝒜₀* + 4𝒜₁𝐢𝒜₁* + 𝒜₀𝐢𝒜₂*) = ⅓(𝒜₀⋆𝒜₂ + 2 𝒜₁⋆𝒜₁)
            (a0.star(a2) + 2.0 * a1.star(a1)) / 3.0,
            a1.star(a2),
            a2.star(a2),
        ]
    }

    /// `w₀ … w₄` (Eq. 2.12): `σ = |𝒜|² = Σ wᵢ Bᵢ⁴`.
    ///
    /// `σ(t) = Σ wᵢ Bᵢ⁴(t)`; at `t = ½` the weights are `(1, 4, 6, 4, 1)/16`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let w = c.speed_weights();
    /// let mid = (w[0] + 4.0 * w[1] + 6.0 * w[2] + 4.0 * w[3] + w[4]) / 16.0;
    /// assert!((mid - c.speed(0.5)).abs() < 1e-15);
    /// ```
    pub fn speed_weights(&self) -> [f64; 5] {
        let [a0, a1, a2] = self.pre_image;
        let dot = |a: Quat, b: Quat| a.s * b.s + a.v.dot(b.v);
        [
            a0.norm2(),
            dot(a0, a1),
            (dot(a2, a0) + 2.0 * a1.norm2()) / 3.0,
            dot(a1, a2),
            a2.norm2(),
        ]
    }

    /// `𝐫₀ … 𝐫₅` (Eq. 2.10).
    ///
    /// They start at `𝐫₀` and end at `𝐫(1)`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ONE, pre);
    /// let r = c.control_points();
    /// assert_eq!(r[0], DVec3::ONE);
    /// assert!((r[5] - c.position(1.0)).length() < 1e-15);
    /// assert!((r[1] - r[0] - c.hodograph(0.0) / 5.0).length() < 1e-15);
    /// ```
    pub fn control_points(&self) -> [DVec3; 6] {
        let h = self.hodograph_control_points();
        let mut r = [self.start; 6];
        for k in 0..5 {
            r[k + 1] = r[k] + h[k] / 5.0;
        }
        r
    }

    /// `𝐫(t)`.
    ///
    /// Its derivative (here a central difference) is the hodograph `𝒜𝐢𝒜*`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ONE, pre);
    /// let h = 1e-5;
    /// let fd = (c.position(0.4 + h) - c.position(0.4 - h)) / (2.0 * h);
    /// assert!((fd - c.hodograph(0.4)).length() < 1e-9);
    /// ```
    pub fn position(&self, t: f64) -> DVec3 {
        de_casteljau(self.control_points(), t)
    }

    /// `𝐫′(t) = 𝒜(t) 𝐢 𝒜*(t)`.
    ///
    /// Pythagorean hodograph: `|𝐫′(t)|` is the polynomial `|𝒜(t)|²`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// assert!((c.hodograph(0.7).length() - c.pre_image_at(0.7).norm2()).abs() < 1e-15);
    /// ```
    pub fn hodograph(&self, t: f64) -> DVec3 {
        self.pre_image_at(t).sandwich(I)
    }

    /// `σ(t) = |𝐫′(t)| = |𝒜(t)|²`.
    ///
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// assert!((c.speed(0.2) - c.hodograph(0.2).length()).abs() < 1e-15);
    /// assert!((c.speed(0.0) - 1.14).abs() < 1e-15); // |𝒜₀|²
    /// ```
    pub fn speed(&self, t: f64) -> f64 {
        self.pre_image_at(t).norm2()
    }

    /// `s(t) = ∫₀ᵗ σ`, exact (a quintic in Bernstein form).
    ///
    /// `s′ = σ` (here a central difference), and `s(1)` is the length:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let h = 1e-5;
    /// assert!(((c.arc_length_to(0.6 + h) - c.arc_length_to(0.6 - h)) / (2.0 * h) - c.speed(0.6)).abs() < 1e-9);
    /// assert!((c.arc_length_to(1.0) - c.length()).abs() < 1e-15);
    /// ```
    pub fn arc_length_to(&self, t: f64) -> f64 {
        let w = self.speed_weights();
        let mut s = [0.0; 6];
        for k in 1..6 {
            s[k] = s[k - 1] + w[k - 1] / 5.0;
        }
        de_casteljau_f64(s, t)
    }

    /// Total arc length `s(1)`, exact.
    ///
    /// Boole's rule is exact for the quartic `σ`:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let s = |t| c.speed(t);
    /// let boole = (7.0 * s(0.0) + 32.0 * s(0.25) + 12.0 * s(0.5) + 32.0 * s(0.75) + 7.0 * s(1.0)) / 90.0;
    /// assert!((c.length() - boole).abs() < 1e-14);
    /// ```
    pub fn length(&self) -> f64 {
        self.speed_weights().iter().sum::<f64>() / 5.0
    }

    /// The tangent indicatrix `𝐭(t) = 𝒜𝐢𝒜*/|𝒜|²` (Eq. 2.11).
    ///
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// assert!((c.tangent(0.3) - c.hodograph(0.3).normalize()).length() < 1e-15);
    /// ```
    pub fn tangent(&self, t: f64) -> DVec3 {
        let a = self.pre_image_at(t);
        a.sandwich(I) / a.norm2()
    }

    /// The Euler–Rodrigues frame `(𝐞₁, 𝐞₂, 𝐞₃)` at `t`.
    ///
    /// Orthonormal and right-handed, led by the tangent:
    /// ```
    /// use strandfit::rrmf::{PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let pre = [[1.0, 0.2, -0.3, 0.1], [0.8, 0.5, 0.1, -0.2], [0.6, 0.1, 0.4, 0.3]].map(Quat::from_array);
    /// let c = PhQuintic::new(DVec3::ZERO, pre);
    /// let [e1, e2, e3] = c.euler_rodrigues_frame(0.3);
    /// assert!((e1 - c.tangent(0.3)).length() < 1e-15);
    /// assert!(e1.dot(e2).abs() < 1e-15 && (e1.cross(e2) - e3).length() < 1e-15);
    /// ```
    pub fn euler_rodrigues_frame(&self, t: f64) -> [DVec3; 3] {
        let a = self.pre_image_at(t);
        let n = a.norm2();
        [a.sandwich(I) / n, a.sandwich(J) / n, a.sandwich(K) / n]
    }

    /// `|𝒜₁𝐢𝒜₁* − vect(𝒜₂𝐢𝒜₀*)|` relative to `|𝒜₁|²`: zero for class I
    /// RRMF quintics (Eq. 2.17).
    ///
    /// `𝒜₁ = √(vect(𝒜₂𝐢𝒜₀*))` makes a class I quintic (Eq. 2.17):
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// assert!(PhQuintic::new(DVec3::ZERO, [a0, a1, a2]).class_one_residual() < 1e-15);
    /// assert!(PhQuintic::new(DVec3::ZERO, [a0, Quat::ONE, a2]).class_one_residual() > 0.1);
    /// ```
    pub fn class_one_residual(&self) -> f64 {
        let [a0, a1, a2] = self.pre_image;
        (a1.sandwich(I) - (a2 * Quat::pure(I) * a0.conj()).v).length()
            / a1.norm2().max(a0.norm() * a2.norm())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::rrmf::quat::sqrt_wrt_i;

    /// A class I pre-image: `𝒜₀`, `𝒜₂` given, `𝒜₁` a root of
    /// `vect(𝒜₂𝐢𝒜₀*)` turned by `θ` (Section 3.2).
    pub(crate) fn class_one(a0: Quat, a2: Quat, theta: f64) -> PhQuintic {
        let v = (a2 * Quat::pure(I) * a0.conj()).v;
        let a1 = sqrt_wrt_i(v).unwrap() * Quat::exp(I, theta);
        PhQuintic::new(DVec3::new(1.0, -2.0, 0.5), [a0, a1, a2])
    }

    pub(crate) fn sample() -> PhQuintic {
        class_one(
            Quat::from_array([0.3, 1.0, -0.2, 0.4]),
            Quat::from_array([-0.5, 0.2, 0.9, -0.3]),
            0.7,
        )
    }

    #[test]
    fn control_points_hodograph_and_speed_agree() {
        let c = sample();
        assert!(c.class_one_residual() < 1e-15);
        let h = c.hodograph_control_points();
        let w = c.speed_weights();
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            let b4 = |k: usize| {
                let binom = [1.0, 4.0, 6.0, 4.0, 1.0][k];
                binom * t.powi(k as i32) * (1.0 - t).powi(4 - k as i32)
            };
            let hb: DVec3 = (0..5).map(|k| h[k] * b4(k)).sum();
            let wb: f64 = (0..5).map(|k| w[k] * b4(k)).sum();
            assert!((hb - c.hodograph(t)).length() < 1e-14);
            assert!((wb - c.speed(t)).abs() < 1e-14);
            // PH: |𝐫′| = σ.
            assert!((c.hodograph(t).length() - c.speed(t)).abs() < 1e-14);
            // 𝐫′ from the control points by central differences.
            let e = 1e-6;
            let fd = (c.position(t + e) - c.position(t - e)) / (2.0 * e);
            assert!((fd - c.hodograph(t)).length() < 1e-8);
            // Frame orthonormal, first vector the tangent.
            let f = c.euler_rodrigues_frame(t);
            assert!((f[0] - c.tangent(t)).length() < 1e-15);
            assert!(f[0].dot(f[1]).abs() < 1e-15 && f[1].dot(f[2]).abs() < 1e-15);
            assert!((f[0].cross(f[1]) - f[2]).length() < 1e-15);
        }
        // Exact arc length against composite Simpson of σ.
        let n = 2000;
        let simpson: f64 = (0..n)
            .map(|k| {
                let (a, b) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
                (b - a) / 6.0 * (c.speed(a) + 4.0 * c.speed(0.5 * (a + b)) + c.speed(b))
            })
            .sum();
        assert!((c.length() - simpson).abs() < 1e-13);
        assert!((c.arc_length_to(1.0) - c.length()).abs() < 1e-15);
        assert!((c.position(0.0) - c.start).length() == 0.0);
        // 𝐫(1) − 𝐫(0) = ∫𝐡 = Σ𝐡ᵢ/5.
        let sum: DVec3 = h.iter().sum();
        assert!((c.position(1.0) - c.start - sum / 5.0).length() < 1e-14);
    }
}
