//! Quaternions as the paper writes them (Section 2): `Quat`, whose
//! documentation gives the conventions, and the ⋆ and □ operators.

use glam::DVec3;
use std::ops::{Add, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
/// A quaternion `s + 𝐯` (scalar and vector part).
///
/// Written as in the paper (Section 2): `𝒜 = a + 𝐚`, scalar
/// part `scal(𝒜) = a`, vector part `vect(𝒜) = 𝐚`, product
/// `(a + 𝐚)(b + 𝐛) = (ab − 𝐚·𝐛) + (a𝐛 + b𝐚 + 𝐚 × 𝐛)`, conjugate
/// `𝒜* = a − 𝐚`, and the operators of Definition 2.11,
///
/// ```text
/// 𝒜 ⋆ ℬ = ½(𝒜 𝐢 ℬ* + ℬ 𝐢 𝒜*),   𝒜 □ ℬ = ½(𝒜 ℬ* − ℬ 𝒜*),
/// ```
///
/// both pure vectors. `𝐢, 𝐣, 𝐤` are the standard basis (the paper allows any
/// unit `𝐢`; fixing it costs nothing, since the constructions rotate the
/// data instead). A type of our own rather than `glam::DQuat`, whose API is
/// about rotations: here quaternions are pre-image *coefficients* — not
/// unit, added and scaled — and the formulas read as printed.
pub struct Quat {
    /// `scal(𝒜)`.
    pub s: f64,
    /// `vect(𝒜)`.
    pub v: DVec3,
}

/// `𝐢`, as a vector.
pub const I: DVec3 = DVec3::X;
/// `𝐣`, as a vector.
pub const J: DVec3 = DVec3::Y;
/// `𝐤`, as a vector.
pub const K: DVec3 = DVec3::Z;

impl Quat {
    /// `0`.
    pub const ZERO: Quat = Quat {
        s: 0.0,
        v: DVec3::ZERO,
    };
    /// `1`.
    pub const ONE: Quat = Quat {
        s: 1.0,
        v: DVec3::ZERO,
    };

    /// The quaternion `s + 𝐯`.
    pub const fn new(s: f64, v: DVec3) -> Self {
        Quat { s, v }
    }

    /// From `(a₀, a₁, a₂, a₃)` as the paper lists them.
    pub const fn from_array(a: [f64; 4]) -> Self {
        Quat {
            s: a[0],
            v: DVec3::new(a[1], a[2], a[3]),
        }
    }

    /// `[s, vx, vy, vz]`.
    ///
    /// The inverse of [`from_array`](Self::from_array):
    /// ```
    /// use strandfit::rrmf::Quat;
    ///
    /// assert_eq!(Quat::from_array([1.0, 2.0, 3.0, 4.0]).to_array(), [1.0, 2.0, 3.0, 4.0]);
    /// ```
    pub fn to_array(self) -> [f64; 4] {
        [self.s, self.v.x, self.v.y, self.v.z]
    }

    /// The pure vector quaternion `𝐯`.
    pub const fn pure(v: DVec3) -> Self {
        Quat { s: 0.0, v }
    }

    /// `e^{𝐮φ} = cos φ + 𝐮 sin φ` (`𝐮` a unit vector).
    ///
    /// `e^{𝐤π/4}` turns `𝐢` by `π/2` about `𝐤` (the sandwich turns by twice the angle):
    /// ```
    /// use strandfit::rrmf::Quat;
    /// use strandfit::DVec3;
    ///
    /// let q = Quat::exp(DVec3::Z, std::f64::consts::FRAC_PI_4);
    /// assert!((q.norm() - 1.0).abs() < 1e-15);
    /// assert!((q.sandwich(DVec3::X) - DVec3::Y).length() < 1e-15);
    /// ```
    pub fn exp(axis: DVec3, phi: f64) -> Self {
        let (s, c) = phi.sin_cos();
        Quat { s: c, v: axis * s }
    }

    /// The conjugate `s − 𝐯`.
    ///
    /// `𝒜𝒜* = |𝒜|²`, a real number:
    /// ```
    /// use strandfit::rrmf::Quat;
    /// use strandfit::DVec3;
    ///
    /// let a = Quat::from_array([1.0, 2.0, 3.0, 4.0]);
    /// assert_eq!(a * a.conj(), Quat::new(30.0, DVec3::ZERO));
    /// ```
    pub fn conj(self) -> Self {
        Quat {
            s: self.s,
            v: -self.v,
        }
    }

    /// `𝒜𝒜* = |𝒜|²`.
    ///
    /// ```
    /// use strandfit::rrmf::Quat;
    ///
    /// assert_eq!(Quat::from_array([1.0, 2.0, 3.0, 4.0]).norm2(), 30.0);
    /// ```
    pub fn norm2(self) -> f64 {
        self.s * self.s + self.v.length_squared()
    }

    /// `|q| = √(s² + |𝐯|²)`.
    ///
    /// The norm is multiplicative, `|𝒜ℬ| = |𝒜||ℬ|`:
    /// ```
    /// use strandfit::rrmf::Quat;
    ///
    /// let (a, b) = (Quat::from_array([1.0, 2.0, 3.0, 4.0]), Quat::from_array([0.5, -1.0, 0.0, 2.0]));
    /// assert!(((a * b).norm() - a.norm() * b.norm()).abs() < 1e-14);
    /// assert!((a.norm() - 30f64.sqrt()).abs() < 1e-15);
    /// ```
    pub fn norm(self) -> f64 {
        self.norm2().sqrt()
    }

    /// All four components are finite.
    ///
    /// ```
    /// use strandfit::rrmf::Quat;
    ///
    /// assert!(Quat::ONE.is_finite());
    /// assert!(!Quat::from_array([1.0, f64::NAN, 0.0, 0.0]).is_finite());
    /// ```
    pub fn is_finite(self) -> bool {
        self.s.is_finite() && self.v.is_finite()
    }

    /// `𝒜 𝐮 𝒜*` for a pure vector `𝐮`: `|𝒜|²` times `𝐮` rotated by the unit
    /// quaternion `𝒜/|𝒜|` (Eq. 2.1), written out (no quaternion products).
    ///
    /// `1 + 𝐤` has `|𝒜|² = 2` and turns by `π/2` about `𝐤`; the result matches
    /// the quaternion product `𝒜𝐮𝒜*`:
    /// ```
    /// use strandfit::rrmf::Quat;
    /// use strandfit::DVec3;
    ///
    /// let a = Quat::new(1.0, DVec3::Z);
    /// assert!((a.sandwich(DVec3::X) - 2.0 * DVec3::Y).length() < 1e-15);
    /// let b = Quat::from_array([0.3, 1.0, -0.2, 0.4]);
    /// let u = DVec3::new(0.5, -1.0, 2.0);
    /// assert!((b.sandwich(u) - (b * Quat::pure(u) * b.conj()).v).length() < 1e-15);
    /// ```
    pub fn sandwich(self, u: DVec3) -> DVec3 {
        let (a, w) = (self.s, self.v);
        // (a² − |𝐰|²) 𝐮 + 2 (𝐰·𝐮) 𝐰 + 2a (𝐰 × 𝐮)
        (a * a - w.length_squared()) * u + 2.0 * w.dot(u) * w + 2.0 * a * w.cross(u)
    }

    /// `𝒜 ⋆ ℬ = ½(𝒜 𝐢 ℬ* + ℬ 𝐢 𝒜*)` (Definition 2.11).
    ///
    /// `𝒜 ⋆ 𝒜 = 𝒜𝐢𝒜*`, and `⋆` is symmetric:
    /// ```
    /// use strandfit::rrmf::Quat;
    /// use strandfit::DVec3;
    ///
    /// let (a, b) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// assert!((a.star(a) - a.sandwich(DVec3::X)).length() < 1e-15);
    /// assert!((a.star(b) - b.star(a)).length() < 1e-15);
    /// ```
    pub fn star(self, b: Quat) -> DVec3 {
        let x = self * Quat::pure(I) * b.conj();
        let y = b * Quat::pure(I) * self.conj();
        0.5 * (x.v + y.v)
    }

    /// `𝒜 □ ℬ = ½(𝒜ℬ* − ℬ𝒜*)` (Definition 2.11).
    ///
    /// `𝒜 □ ℬ = vect(𝒜ℬ*)` (`ℬ𝒜*` is its conjugate), antisymmetric:
    /// ```
    /// use strandfit::rrmf::Quat;
    ///
    /// let (a, b) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// assert!((a.square(b) - (a * b.conj()).v).length() < 1e-15);
    /// assert!((a.square(b) + b.square(a)).length() < 1e-15);
    /// ```
    pub fn square(self, b: Quat) -> DVec3 {
        let x = self * b.conj();
        let y = b * self.conj();
        0.5 * (x.v - y.v)
    }
}

impl Mul for Quat {
    type Output = Quat;
    #[inline]
    fn mul(self, b: Quat) -> Quat {
        Quat {
            s: self.s * b.s - self.v.dot(b.v),
            v: self.s * b.v + b.s * self.v + self.v.cross(b.v),
        }
    }
}

impl Mul<f64> for Quat {
    type Output = Quat;
    #[inline]
    fn mul(self, k: f64) -> Quat {
        Quat {
            s: self.s * k,
            v: self.v * k,
        }
    }
}

impl Mul<Quat> for f64 {
    type Output = Quat;
    #[inline]
    fn mul(self, q: Quat) -> Quat {
        q * self
    }
}

impl Add for Quat {
    type Output = Quat;
    #[inline]
    fn add(self, b: Quat) -> Quat {
        Quat {
            s: self.s + b.s,
            v: self.v + b.v,
        }
    }
}

impl Sub for Quat {
    type Output = Quat;
    #[inline]
    fn sub(self, b: Quat) -> Quat {
        Quat {
            s: self.s - b.s,
            v: self.v - b.v,
        }
    }
}

impl Neg for Quat {
    type Output = Quat;
    #[inline]
    fn neg(self) -> Quat {
        Quat {
            s: -self.s,
            v: -self.v,
        }
    }
}

/// The unit bisector `𝐛(𝐯, 𝐰)` of Definition 2.13, `None` when `𝐯/|𝐯| +
/// 𝐰/|𝐰| = 0` (or an input is zero).
///
/// ```
/// use strandfit::rrmf::bisector;
/// use strandfit::DVec3;
///
/// assert!((bisector(DVec3::X, 3.0 * DVec3::Y).unwrap() - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
/// assert_eq!(bisector(DVec3::X, -DVec3::X), None);
/// ```
pub fn bisector(v: DVec3, w: DVec3) -> Option<DVec3> {
    (v.try_normalize()? + w.try_normalize()?).try_normalize()
}

/// `𝐧(𝐯, 𝐰) = −(𝐯 × 𝐰)/|𝐯 × 𝐰|` (Definition 2.13), `None` when parallel.
///
/// ```
/// use strandfit::rrmf::neg_cross;
/// use strandfit::DVec3;
///
/// assert_eq!(neg_cross(DVec3::X, 2.0 * DVec3::Y), Some(-DVec3::Z));
/// assert_eq!(neg_cross(DVec3::X, -DVec3::X), None);
/// ```
pub fn neg_cross(v: DVec3, w: DVec3) -> Option<DVec3> {
    (-v.cross(w)).try_normalize()
}

/// One quaternion square root of `𝐯` with respect to `𝐢` (Definition 2.15):
/// an `𝒜` with `𝒜 𝐢 𝒜* = 𝐯` (every other is `𝒜 e^{𝐢α}`). Where `𝐢·𝐯 ≥
/// −|𝐯|/2` it is the paper's member `√|𝐯| 𝐛(𝐢, 𝐯)` (Eq. 2.21), a half turn
/// about the bisector. Nearer to `−𝐢` that bisector loses digits (it divides
/// by `|𝐢 + 𝐯/|𝐯||`), and exactly at `−𝐢` it does not exist (the paper's
/// special case): there the root is `√|𝐯| 𝒬 𝐣`, with `𝐣` taking `𝐢` to `−𝐢`
/// and `𝒬` the shortest rotation from `−𝐢` to `𝐯/|𝐯|`, well conditioned
/// there (at `𝐯 = −|𝐯|𝐢` it is `√|𝐯| 𝐣`, the special case with `𝛅₁^⊥ = 𝐣`).
/// `None` for `𝐯 = 0` or non-finite `𝐯`.
///
/// `𝒜𝐢𝒜* = 𝐯`, for a general `𝐯` and for the special case `𝐯 ∥ −𝐢`:
/// ```
/// use strandfit::rrmf::sqrt_wrt_i;
/// use strandfit::DVec3;
///
/// for v in [DVec3::new(1.0, 2.0, 3.0), DVec3::new(-2.0, 0.0, 0.0)] {
///     assert!((sqrt_wrt_i(v).unwrap().sandwich(DVec3::X) - v).length() < 1e-14);
/// }
/// assert_eq!(sqrt_wrt_i(DVec3::ZERO), None);
/// ```
pub fn sqrt_wrt_i(v: DVec3) -> Option<Quat> {
    let len = v.length();
    if !(len > 0.0) || !len.is_finite() {
        return None;
    }
    let d = v / len;
    let root = if d.x >= -0.5 {
        Quat::pure((I + d).normalize())
    } else {
        // Shortest arc from −𝐢 to 𝐝: (1 + (−𝐢)·𝐝, (−𝐢) × 𝐝), normalised.
        let q = Quat::new(1.0 - d.x, (-I).cross(d));
        let q = q * (1.0 / q.norm());
        q * Quat::pure(J)
    };
    Some(root * len.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arb_quat() -> impl Strategy<Value = Quat> {
        prop::array::uniform4(-2.0f64..2.0).prop_map(Quat::from_array)
    }

    fn arb_vec() -> impl Strategy<Value = DVec3> {
        prop::array::uniform3(-2.0f64..2.0).prop_map(DVec3::from)
    }

    #[test]
    fn basis_products() {
        let (i, j, k) = (Quat::pure(I), Quat::pure(J), Quat::pure(K));
        assert_eq!(i * j, k);
        assert_eq!(j * k, i);
        assert_eq!(k * i, j);
        assert_eq!(i * i, -Quat::ONE);
        assert_eq!(j * i, -k);
    }

    #[test]
    fn special_square_roots() {
        for v in [
            -3.0 * I,
            -I,
            2.0 * I,
            DVec3::new(-1.0, 1e-12, 0.0),
            DVec3::new(-1.0, 0.9, 0.1),
        ] {
            let a = sqrt_wrt_i(v).unwrap();
            assert!((a.sandwich(I) - v).length() < 4e-16 * v.length(), "{v}");
        }
        assert_eq!(sqrt_wrt_i(DVec3::ZERO), None);
    }

    proptest! {
        #[test]
        fn algebra(a in arb_quat(), b in arb_quat(), c in arb_quat(), u in arb_vec()) {
            // Associativity, conjugate of a product, multiplicative norm.
            let d = (a * b) * c - a * (b * c);
            prop_assert!(d.norm() < 1e-12);
            prop_assert!(((a * b).conj() - b.conj() * a.conj()).norm() < 1e-13);
            prop_assert!(((a * b).norm2() - a.norm2() * b.norm2()).abs() < 1e-11);
            // 𝒜𝐮𝒜* is a pure vector equal to the sandwich formula.
            let p = a * Quat::pure(u) * a.conj();
            prop_assert!(p.s.abs() < 1e-12);
            prop_assert!((p.v - a.sandwich(u)).length() < 1e-12);
            // ⋆ and □ are pure, ⋆ symmetric, □ antisymmetric; 𝒜⋆𝒜 = 𝒜𝐢𝒜*.
            prop_assert!((a.star(b) - b.star(a)).length() < 1e-13);
            prop_assert!((a.square(b) + b.square(a)).length() < 1e-13);
            prop_assert!((a.star(a) - a.sandwich(I)).length() < 1e-13);
            let full = a * b.conj() - b * a.conj();
            prop_assert!(full.s.abs() < 1e-13);
        }

        #[test]
        fn square_roots_and_their_family(v in arb_vec(), alpha in -3.0f64..3.0) {
            prop_assume!(v.length() > 1e-6);
            let a = sqrt_wrt_i(v).unwrap();
            prop_assert!((a.sandwich(I) - v).length() < 1e-12);
            // Remark 2.6: 𝒜 e^{𝐢α} is a root too.
            let b = a * Quat::exp(I, alpha);
            prop_assert!((b.sandwich(I) - v).length() < 1e-12);
            prop_assert!((b.norm2() - v.length()).abs() < 1e-12);
        }
    }
}
