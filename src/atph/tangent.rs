//! The unit tangent field of an ATPH curve: `SphericalTangent`, whose
//! documentation gives the choices Section 3.1 leaves open.

use glam::DVec3;
use std::f64::consts::{PI, TAU};

use super::moments::trig_moments;

/// `cos θ` below this: the tangent is at a pole and has no azimuth.
pub const POLE_TOL: f64 = 1e-12;
/// Angles (`b₁`, or `a₀` and `a₁`) this close to zero make the field planar.
pub const PLANAR_TOL: f64 = 1e-12;
/// `|b₁|` this close to `π` is a half turn, decided by the chord.
pub const HALF_TURN_TOL: f64 = 1e-7;

/// `θ(ξ) = a₁ξ + a₀` (latitude), `φ(ξ) = b₁ξ + b₀` (azimuth).
///
/// The unit tangent field of an ATPH curve: a sphere curve in spherical
/// coordinates with latitude and azimuth linear in the parameter (Eq. 2.1):
///
/// ```text
/// T(ξ) = (cos θ cos φ, cos θ sin φ, sin θ),  θ = a₁ξ + a₀,  φ = b₁ξ + b₀.
/// ```
///
/// The coordinates are those of the input: the construction is invariant to
/// translation, scale and rotation about `z`, not to other rotations (the poles
/// are special). Section 3.1 interpolates `T(0) = T₁`, `T(1) = T₂` with
/// `a₀ = θ₁`, `a₁ = θ₂ − θ₁`, `b₀ = φ₁`, `b₁ = φ₂ − φ₁`;
/// [`interpolating`](Self::interpolating) fixes the choices the paper leaves
/// open or gets wrong:
///
/// * **Azimuth branch.** The paper's `arctan` rule, taken literally, makes
///   `b₁` jump by `−π` or `−3π/2` along a spline (ERRATA 002.2). Here the
///   azimuth is continuous: `b₁` is the shortest turn, `wrap(φ₂ − φ₁)` in
///   `(−π, π]`. A half turn (`|b₁|` within `1e-7` of `π`) is ambiguous; it
///   turns towards the chord (a circular arc's chord azimuth is
///   `φ₁ + b₁/2`), which is what the cylinder of Table 1 needs at `n = 2`.
/// * **Poles.** At `T = ±z` the azimuth is free (Fig. 2). It is taken from
///   the chord's projection on the `xy` plane, so the field leaves the pole
///   towards the other end, else from the other tangent, else 0.
/// * **`T₁ = T₂`.** Parallel to the chord (and pointing along it): the
///   straight line, `a₁ = b₁ = 0`. Otherwise the full latitude circle,
///   `b₁ = 2π` (Section 3.2, Fig. 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalTangent {
    /// `a₀`: latitude at `ξ = 0`.
    pub a0: f64,
    /// `a₁`: latitude rate.
    pub a1: f64,
    /// `b₀`: azimuth at `ξ = 0`.
    pub b0: f64,
    /// `b₁`: azimuth rate.
    pub b1: f64,
}

/// What the field spans, which decides the linear system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldKind {
    /// `T` is constant: the curve is a straight segment.
    Constant,
    /// `T` stays on a great circle with this unit normal (a meridian,
    /// `b₁ = 0`, or the equator, `a₀ = a₁ = 0`): the curve is planar.
    Planar(DVec3),
    /// Neither: the 3×3 (or 4×4) system of Section 3.2 (4) applies.
    Spatial,
}

/// `(θ, φ)` of a unit vector; `φ` is `None` at the poles.
///
/// ```
/// use strandfit::atph::spherical_angles;
/// use strandfit::DVec3;
/// use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
///
/// assert_eq!(spherical_angles(DVec3::Z), (FRAC_PI_2, None)); // a pole: no azimuth
/// let (theta, phi) = spherical_angles(DVec3::new(1.0, 1.0, 2f64.sqrt()).normalize());
/// assert!((theta - FRAC_PI_4).abs() < 1e-15 && (phi.unwrap() - FRAC_PI_4).abs() < 1e-15);
/// ```
pub fn spherical_angles(t: DVec3) -> (f64, Option<f64>) {
    let h = t.x.hypot(t.y);
    // atan2 keeps θ accurate near the poles, where asin(t_z) loses half the
    // digits.
    let theta = t.z.atan2(h);
    let phi = (h > POLE_TOL).then(|| t.y.atan2(t.x));
    (theta, phi)
}

/// `x` reduced to `(−π, π]`.
///
/// ```
/// use strandfit::atph::wrap_angle;
/// use std::f64::consts::{FRAC_PI_2, PI};
///
/// assert!((wrap_angle(3.0 * FRAC_PI_2) + FRAC_PI_2).abs() < 1e-15);
/// assert_eq!(wrap_angle(-PI), PI);
/// ```
pub fn wrap_angle(x: f64) -> f64 {
    let mut r = x.rem_euclid(TAU);
    if r > PI {
        r -= TAU;
    }
    r
}

impl SphericalTangent {
    /// The field with `θ = a₁ξ + a₀`, `φ = b₁ξ + b₀`.
    pub fn new(a0: f64, a1: f64, b0: f64, b1: f64) -> Self {
        SphericalTangent { a0, a1, b0, b1 }
    }

    /// The field of Section 3.1 from unit tangents `t1`, `t2` and the chord
    /// `P₂ − P₁` (which decides the free choices; see [`SphericalTangent`]).
    ///
    /// The field runs from `t1` to `t2`; equal tangents off the chord give the
    /// full latitude circle (`b₁ = 2π`):
    /// ```
    /// use strandfit::atph::SphericalTangent;
    /// use strandfit::DVec3;
    /// use std::f64::consts::TAU;
    ///
    /// let (t1, t2) = (DVec3::new(1.0, 0.0, 1.0).normalize(), DVec3::new(0.0, -1.0, 0.5).normalize());
    /// let f = SphericalTangent::interpolating(t1, t2, DVec3::new(1.0, -1.0, 1.0));
    /// assert!((f.at(0.0) - t1).length() < 1e-15 && (f.at(1.0) - t2).length() < 1e-15);
    /// assert_eq!(SphericalTangent::interpolating(DVec3::X, DVec3::X, DVec3::Y).b1, TAU);
    /// ```
    pub fn interpolating(t1: DVec3, t2: DVec3, chord: DVec3) -> Self {
        let (theta1, phi1) = spherical_angles(t1);
        let (theta2, phi2) = spherical_angles(t2);
        let chord_phi =
            (chord.x.hypot(chord.y) > POLE_TOL * chord.length()).then(|| chord.y.atan2(chord.x));
        let phi1 = phi1.or(chord_phi).or(phi2).unwrap_or(0.0);
        let phi2 = phi2.or(chord_phi).unwrap_or(phi1);
        let a0 = theta1;
        let a1 = theta2 - theta1;
        let mut b1 = wrap_angle(phi2 - phi1);
        if b1.abs() > PI - HALF_TURN_TOL {
            if let Some(c) = chord_phi {
                let target = 2.0 * wrap_angle(c - phi1);
                let up = if b1 > 0.0 { b1 } else { b1 + TAU };
                let down = up - TAU;
                b1 = if (up - target).abs() <= (down - target).abs() {
                    up
                } else {
                    down
                };
            }
        }
        let same = a1.abs() <= PLANAR_TOL && b1.abs() <= PLANAR_TOL;
        if same && a0.cos() > POLE_TOL {
            let along = chord.dot(t1);
            let off = chord.cross(t1).length();
            if !(along > 0.0 && off <= 1e-9 * chord.length()) {
                b1 = TAU;
            }
        }
        SphericalTangent {
            a0,
            a1,
            b0: phi1,
            b1,
        }
    }

    /// `T(ξ)`, Eq. (2.1).
    ///
    /// Latitude `π/4`, azimuth `π/2`:
    /// ```
    /// use strandfit::atph::SphericalTangent;
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    ///
    /// let f = SphericalTangent::new(0.0, FRAC_PI_4, FRAC_PI_2, 0.0);
    /// assert!((f.at(1.0) - DVec3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-15);
    /// ```
    #[inline]
    pub fn at(&self, xi: f64) -> DVec3 {
        let (sa, ca) = (self.a1 * xi + self.a0).sin_cos();
        let (sb, cb) = (self.b1 * xi + self.b0).sin_cos();
        DVec3::new(ca * cb, ca * sb, sa)
    }

    /// `T′(ξ)`.
    ///
    /// It matches a central difference of [`at`](Self::at):
    /// ```
    /// use strandfit::atph::SphericalTangent;
    ///
    /// let f = SphericalTangent::new(0.3, 0.7, -0.2, 1.9);
    /// let h = 1e-5;
    /// let fd = (f.at(0.4 + h) - f.at(0.4 - h)) / (2.0 * h);
    /// assert!((f.derivative(0.4) - fd).length() < 1e-9);
    /// ```
    pub fn derivative(&self, xi: f64) -> DVec3 {
        let (sa, ca) = (self.a1 * xi + self.a0).sin_cos();
        let (sb, cb) = (self.b1 * xi + self.b0).sin_cos();
        self.a1 * DVec3::new(-sa * cb, -sa * sb, ca) + self.b1 * ca * DVec3::new(-sb, cb, 0.0)
    }

    /// `T″(ξ)`.
    ///
    /// It matches a central difference of [`derivative`](Self::derivative):
    /// ```
    /// use strandfit::atph::SphericalTangent;
    ///
    /// let f = SphericalTangent::new(0.3, 0.7, -0.2, 1.9);
    /// let h = 1e-5;
    /// let fd = (f.derivative(0.4 + h) - f.derivative(0.4 - h)) / (2.0 * h);
    /// assert!((f.second_derivative(0.4) - fd).length() < 1e-8);
    /// ```
    pub fn second_derivative(&self, xi: f64) -> DVec3 {
        let (a1, b1) = (self.a1, self.b1);
        let (sa, ca) = (a1 * xi + self.a0).sin_cos();
        let (sb, cb) = (b1 * xi + self.b0).sin_cos();
        a1 * a1 * DVec3::new(-ca * cb, -ca * sb, -sa)
            + 2.0 * a1 * b1 * sa * DVec3::new(sb, -cb, 0.0)
            - b1 * b1 * ca * DVec3::new(cb, sb, 0.0)
    }

    /// `V_k(ξ) = ∫₀^ξ tᵏ T(t) dt`, `k = 0..=3`: by the product-to-sum step
    /// of (2.3), `x = ½(Re M_k(A₁, A₀) + Re M_k(B₁, B₀))`,
    /// `y = ½(Im M_k(A₁, A₀) − Im M_k(B₁, B₀))`, `z = Im M_k(a₁, a₀)`, where
    /// `A = a + b`, `B = a − b` ([`super::trig_moments`]).
    ///
    /// A quarter turn along the equator, `T = (cos πt/2, sin πt/2, 0)`:
    /// `V₀(1) = (2/π, 2/π, 0)` and `V₁(1)ₓ = ∫₀¹ t cos(πt/2) dt = 2/π − 4/π²`:
    /// ```
    /// use strandfit::atph::SphericalTangent;
    /// use strandfit::DVec3;
    /// use std::f64::consts::{FRAC_PI_2, PI};
    ///
    /// let v = SphericalTangent::new(0.0, 0.0, 0.0, FRAC_PI_2).moment_vectors(1.0);
    /// assert!((v[0] - DVec3::new(2.0 / PI, 2.0 / PI, 0.0)).length() < 1e-15);
    /// assert!((v[1].x - (2.0 / PI - 4.0 / (PI * PI))).abs() < 1e-15);
    /// ```
    pub fn moment_vectors(&self, xi: f64) -> [DVec3; 4] {
        let ma = trig_moments(self.a1 + self.b1, self.a0 + self.b0, xi);
        let mb = trig_moments(self.a1 - self.b1, self.a0 - self.b0, xi);
        let mz = trig_moments(self.a1, self.a0, xi);
        std::array::from_fn(|k| {
            DVec3::new(
                0.5 * (ma.re[k] + mb.re[k]),
                0.5 * (ma.im[k] - mb.im[k]),
                mz.im[k],
            )
        })
    }

    /// Whether the field is constant, planar, or spans space.
    ///
    /// ```
    /// use strandfit::atph::{FieldKind, SphericalTangent};
    /// use strandfit::DVec3;
    ///
    /// assert_eq!(SphericalTangent::new(0.0, 0.0, 0.0, 1.0).kind(), FieldKind::Planar(DVec3::Z)); // equator
    /// assert_eq!(SphericalTangent::new(0.2, 0.5, 0.0, 0.0).kind(), FieldKind::Planar(DVec3::Y)); // meridian
    /// assert_eq!(SphericalTangent::new(0.2, 0.0, 0.3, 0.0).kind(), FieldKind::Constant);
    /// assert_eq!(SphericalTangent::new(0.2, 0.5, 0.0, 1.0).kind(), FieldKind::Spatial);
    /// ```
    pub fn kind(&self) -> FieldKind {
        let a_still = self.a1.abs() <= PLANAR_TOL;
        if a_still && (self.b1.abs() <= PLANAR_TOL || self.a0.cos().abs() <= POLE_TOL) {
            FieldKind::Constant
        } else if self.b1.abs() <= PLANAR_TOL {
            let (s, c) = self.b0.sin_cos();
            FieldKind::Planar(DVec3::new(-s, c, 0.0))
        } else if a_still && self.a0.abs() <= PLANAR_TOL {
            FieldKind::Planar(DVec3::Z)
        } else {
            FieldKind::Spatial
        }
    }

    /// The field traversed backwards, `T̃(ξ) = −T(1 − ξ)`: latitude
    /// `−θ(1 − ξ)`, azimuth `φ(1 − ξ) + π`.
    ///
    /// `T̃(ξ) = −T(1 − ξ)`:
    /// ```
    /// use strandfit::atph::SphericalTangent;
    ///
    /// let f = SphericalTangent::new(0.3, 0.7, -0.2, 1.9);
    /// let r = f.reversed();
    /// assert!((r.at(0.25) + f.at(0.75)).length() < 1e-15);
    /// ```
    pub fn reversed(&self) -> Self {
        SphericalTangent {
            a0: -(self.a0 + self.a1),
            a1: self.a1,
            b0: wrap_angle(self.b0 + self.b1 + PI),
            b1: -self.b1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field() -> SphericalTangent {
        SphericalTangent::new(0.3, 0.9, -1.1, 2.4)
    }

    #[test]
    fn interpolates_the_ends_and_is_unit() {
        let f = SphericalTangent::interpolating(
            DVec3::new(0.2, -0.5, 0.8).normalize(),
            DVec3::new(-0.6, 0.1, -0.3).normalize(),
            DVec3::new(1.0, 2.0, 0.5),
        );
        assert!((f.at(0.0) - DVec3::new(0.2, -0.5, 0.8).normalize()).length() < 1e-15);
        assert!((f.at(1.0) - DVec3::new(-0.6, 0.1, -0.3).normalize()).length() < 1e-15);
        assert!(f.b1.abs() <= PI, "shortest turn");
        for i in 0..=10 {
            assert!((f.at(i as f64 / 10.0).length() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let f = field();
        let h = 1e-5;
        for &x in &[0.0, 0.37, 1.0] {
            let d1 = (f.at(x + h) - f.at(x - h)) / (2.0 * h);
            let d2 = (f.derivative(x + h) - f.derivative(x - h)) / (2.0 * h);
            assert!((f.derivative(x) - d1).length() < 1e-9);
            assert!((f.second_derivative(x) - d2).length() < 1e-8);
        }
    }

    #[test]
    fn moment_vectors_match_quadrature() {
        use crate::atph::moments::tests::gauss;
        // Includes A₁ = 0 (a₁ = −b₁) and B₁ = 0 (a₁ = b₁), the zero-divisor
        // cases of Eq. (2.5).
        for f in [
            field(),
            SphericalTangent::new(0.1, 0.7, 0.4, -0.7),
            SphericalTangent::new(-0.5, 1.2, 3.0, 1.2),
            SphericalTangent::new(0.2, 0.0, 1.0, 6.0),
        ] {
            for &xi in &[1.0, 0.4] {
                let v = f.moment_vectors(xi);
                for k in 0..4 {
                    let q = DVec3::new(
                        gauss(|t| t.powi(k as i32) * f.at(t).x, xi, 200),
                        gauss(|t| t.powi(k as i32) * f.at(t).y, xi, 200),
                        gauss(|t| t.powi(k as i32) * f.at(t).z, xi, 200),
                    );
                    assert!((v[k] - q).length() < 1e-14, "{f:?} k={k}");
                }
            }
        }
    }

    #[test]
    fn reversal_runs_the_field_backwards() {
        let f = field();
        let r = f.reversed();
        for i in 0..=8 {
            let x = i as f64 / 8.0;
            assert!((r.at(x) + f.at(1.0 - x)).length() < 1e-14);
        }
        // interpolating() on the reversed data gives the reversed field.
        let (t1, t2) = (f.at(0.0), f.at(1.0));
        let chord = DVec3::new(0.3, 1.0, -0.2);
        let g = SphericalTangent::interpolating(t1, t2, chord);
        let h = SphericalTangent::interpolating(-t2, -t1, -chord);
        for i in 0..=8 {
            let x = i as f64 / 8.0;
            assert!((h.at(x) + g.at(1.0 - x)).length() < 1e-14);
        }
    }

    #[test]
    fn special_fields() {
        // Same azimuth: a meridian (planar), normal ⟂ both tangents.
        let t1 = DVec3::new(1.0, 1.0, 1.0).normalize();
        let t2 = DVec3::new(1.0, 1.0, -3.0).normalize();
        let f = SphericalTangent::interpolating(t1, t2, DVec3::new(1.0, 1.0, 0.0));
        match f.kind() {
            FieldKind::Planar(n) => {
                assert!(n.dot(t1).abs() < 1e-15 && n.dot(t2).abs() < 1e-15)
            }
            k => panic!("{k:?}"),
        }
        // Both on the equator: planar with normal z.
        let f = SphericalTangent::interpolating(DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0));
        assert_eq!(f.kind(), FieldKind::Planar(DVec3::Z));
        // T1 = T2 along the chord: constant; across it: a latitude loop.
        let t = DVec3::new(0.3, 0.4, 0.5).normalize();
        let f = SphericalTangent::interpolating(t, t, 2.0 * t);
        assert_eq!(f.kind(), FieldKind::Constant);
        let f = SphericalTangent::interpolating(t, t, DVec3::new(0.0, 0.0, 1.0));
        assert_eq!(f.b1, TAU);
        assert_eq!(f.kind(), FieldKind::Spatial);
        // T1 = T2 against the chord: not the backwards line either.
        let f = SphericalTangent::interpolating(t, t, -t);
        assert_eq!(f.b1, TAU);
        // A pole takes the chord's azimuth.
        let f = SphericalTangent::interpolating(DVec3::Z, DVec3::X, DVec3::new(1.0, 1.0, 1.0));
        assert!((f.b0 - PI / 4.0).abs() < 1e-15 && (f.b1 + PI / 4.0).abs() < 1e-15);
        assert!((f.at(0.0) - DVec3::Z).length() < 1e-15);
        // A half turn follows the chord.
        let up = SphericalTangent::interpolating(DVec3::Y, -DVec3::Y, DVec3::new(-1.0, 0.0, 0.0));
        let down = SphericalTangent::interpolating(DVec3::Y, -DVec3::Y, DVec3::new(1.0, 0.0, 0.0));
        assert!((up.b1 - PI).abs() < 1e-12 && (down.b1 + PI).abs() < 1e-12);
    }
}
