//! The projected helix of Section 4 (paper 003), `ProjectedHelix` (its
//! formula is in the item's documentation).

use glam::{DVec2, DVec3};

/// `(a, b, c)`: radius `|a|`, pitch `|b|` per radian, tilt `c` about the
/// `x` axis (`a` and `b` are signed: a fit may leave either negative).
///
/// The projected helix of Section 4 (paper 003): the helix of radius `a`
/// and pitch `b` about the `y` axis, through the origin,
/// `H_Prim(t) = (a(cos t − 1), bt, a sin t)`, turned by `c` about the `x`
/// axis,
///
/// ```text
/// H_3D,R(t) = (a(cos t − 1), bt cos c − a sin c sin t, bt sin c + a cos c sin t),
/// ```
///
/// and its orthogonal projection on `z = 0`, `H(t)` = the first two
/// coordinates. Only the rotation about `x` changes the projection's shape
/// (a rotation about `y` shifts `t`, one about `z` turns the plane).
///
/// ```
/// use strandfit::sketch::ProjectedHelix;
///
/// // In 3D it is a helix: constant speed √(a² + b²) whatever the tilt.
/// let h = ProjectedHelix::new(1.3, 0.4, 0.7);
/// for t in [-2.0, 0.0, 0.5, 3.0] {
///     assert!((h.derivative_3d(t).length() - (1.3f64 * 1.3 + 0.4 * 0.4).sqrt()).abs() < 1e-14);
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectedHelix {
    /// Radius (signed; `|a|` is the radius).
    pub a: f64,
    /// Pitch per radian (signed).
    pub b: f64,
    /// Tilt of the axis out of the sketch plane, radians.
    pub c: f64,
}

impl ProjectedHelix {
    /// The helix `(a, b, c)`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// let h = ProjectedHelix::new(1.0, 0.2, -0.5);
    /// assert_eq!((h.a, h.b, h.c), (1.0, 0.2, -0.5));
    /// ```
    pub fn new(a: f64, b: f64, c: f64) -> Self {
        ProjectedHelix { a, b, c }
    }

    /// `H_3D,R(t)`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    /// use glam::{DQuat, DVec3};
    ///
    /// // H_Prim(t) turned by c about the x axis.
    /// let (a, b, c, t) = (1.3, 0.4, 0.7, 2.1f64);
    /// let prim = DVec3::new(a * (t.cos() - 1.0), b * t, a * t.sin());
    /// let h = ProjectedHelix::new(a, b, c);
    /// assert!((DQuat::from_rotation_x(c) * prim - h.point_3d(t)).length() < 1e-14);
    /// ```
    pub fn point_3d(&self, t: f64) -> DVec3 {
        self.point_3d_trig(t, t.sin_cos(), self.c.sin_cos())
    }

    /// [`point_3d`](Self::point_3d) with `(sin t, cos t)` and
    /// `(sin c, cos c)` given (the same operations, so the same bits).
    #[inline]
    pub(crate) fn point_3d_trig(
        &self,
        t: f64,
        (st, ct): (f64, f64),
        (sc, cc): (f64, f64),
    ) -> DVec3 {
        DVec3::new(
            self.a * (ct - 1.0),
            self.b * t * cc - self.a * sc * st,
            self.b * t * sc + self.a * cc * st,
        )
    }

    /// `H_3D,R′(t)`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// // Against a central difference of the points.
    /// let h = ProjectedHelix::new(1.3, 0.4, 0.7);
    /// let (t, e) = (0.9, 1e-6);
    /// let d = (h.point_3d(t + e) - h.point_3d(t - e)) / (2.0 * e);
    /// assert!((d - h.derivative_3d(t)).length() < 1e-8);
    /// ```
    pub fn derivative_3d(&self, t: f64) -> DVec3 {
        let (st, ct) = t.sin_cos();
        let (sc, cc) = self.c.sin_cos();
        DVec3::new(
            -self.a * st,
            self.b * cc - self.a * sc * ct,
            self.b * sc + self.a * cc * ct,
        )
    }

    /// `H(t)`, the projection on `z = 0`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    /// let h = ProjectedHelix::new(1.0, 0.2, 0.5);
    /// let t = 0.7;
    /// assert_eq!(h.point(t), h.point_3d(t).truncate());
    /// // The helix passes through the origin at t = 0.
    /// assert!(h.point_3d(0.0).length() < 1e-15);
    /// ```
    pub fn point(&self, t: f64) -> DVec2 {
        let p = self.point_3d(t);
        DVec2::new(p.x, p.y)
    }

    /// `H′(t) = (−a sin t, b cos c − a sin c cos t)`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// // Against a central difference, and the first two coordinates of H_3D,R′.
    /// let h = ProjectedHelix::new(1.3, 0.4, 0.7);
    /// let (t, e) = (0.9, 1e-6);
    /// let d = (h.point(t + e) - h.point(t - e)) / (2.0 * e);
    /// assert!((d - h.derivative(t)).length() < 1e-8);
    /// assert_eq!(h.derivative(t), h.derivative_3d(t).truncate());
    /// ```
    pub fn derivative(&self, t: f64) -> DVec2 {
        self.derivative_trig(t.sin_cos(), self.c.sin_cos())
    }

    /// [`derivative`](Self::derivative) with `(sin t, cos t)` and
    /// `(sin c, cos c)` given (the same operations, so the same bits).
    #[inline]
    pub(crate) fn derivative_trig(&self, (st, ct): (f64, f64), (sc, cc): (f64, f64)) -> DVec2 {
        DVec2::new(-self.a * st, self.b * cc - self.a * sc * ct)
    }

    /// `H″(t) = (−a cos t, a sin c sin t)`.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// // Against a central difference of H′.
    /// let h = ProjectedHelix::new(1.3, 0.4, 0.7);
    /// let (t, e) = (-1.2, 1e-6);
    /// let dd = (h.derivative(t + e) - h.derivative(t - e)) / (2.0 * e);
    /// assert!((dd - h.second_derivative(t)).length() < 1e-8);
    /// ```
    pub fn second_derivative(&self, t: f64) -> DVec2 {
        let (st, ct) = t.sin_cos();
        DVec2::new(-self.a * ct, self.a * self.c.sin() * st)
    }

    /// The unit tangent `T̂_H(t)` (Section 4.3); `None` at a cusp of the
    /// projection (`H′ = 0`).
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// let h = ProjectedHelix::new(1.0, 0.3, 0.4);
    /// let tangent = h.unit_tangent(0.8).unwrap();
    /// assert!((tangent.length() - 1.0).abs() < 1e-15);
    /// assert!(tangent.perp_dot(h.derivative(0.8)).abs() < 1e-15);
    /// // Untilted and without pitch, the projection runs back and forth along a
    /// // segment: cusps at t = 0 and π.
    /// assert_eq!(ProjectedHelix::new(1.0, 0.0, 0.0).unit_tangent(0.0), None);
    /// ```
    pub fn unit_tangent(&self, t: f64) -> Option<DVec2> {
        self.derivative(t).try_normalize()
    }

    /// `κ_H(t) = |a(b cos c cos t − a sin c)| / (a² sin²t + (b cos c −
    /// a sin c cos t)²)^{3/2}` (Section 4.2); infinite at a cusp.
    ///
    /// ```
    /// use strandfit::sketch::ProjectedHelix;
    ///
    /// // The plane curvature |x′y″ − y′x″| / |H′|³.
    /// let h = ProjectedHelix::new(1.3, 0.4, 0.7);
    /// let (d1, d2) = (h.derivative(0.6), h.second_derivative(0.6));
    /// let kappa = d1.perp_dot(d2).abs() / d1.length().powi(3);
    /// assert!((h.curvature(0.6) - kappa).abs() < 1e-12);
    /// // Seen along its axis (c = π/2), a helix projects to a circle of radius |a|.
    /// let h = ProjectedHelix::new(2.0, 0.5, std::f64::consts::FRAC_PI_2);
    /// for t in [0.0, 1.0, 2.5] {
    ///     assert!((h.curvature(t) - 0.5).abs() < 1e-12);
    /// }
    /// ```
    pub fn curvature(&self, t: f64) -> f64 {
        let (st, ct) = t.sin_cos();
        let (sc, cc) = self.c.sin_cos();
        let (a, b) = (self.a, self.b);
        let num = (a * (b * cc * ct - a * sc)).abs();
        let q = a * a * st * st + (b * cc - a * sc * ct).powi(2);
        num / (q * q.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    #[test]
    fn it_is_a_helix_turned_about_x() {
        let h = ProjectedHelix::new(1.3, 0.4, 0.7);
        let rot = glam::DQuat::from_rotation_x(0.7);
        for k in 0..20 {
            let t = -3.0 + 0.3 * k as f64;
            let prim = DVec3::new(1.3 * (t.cos() - 1.0), 0.4 * t, 1.3 * t.sin());
            assert!((rot * prim - h.point_3d(t)).length() < 1e-14);
            // Constant curvature a/(a² + b²) and speed √(a² + b²) in 3D.
            assert!((h.derivative_3d(t).length() - (1.3f64.powi(2) + 0.16).sqrt()).abs() < 1e-14);
            // Derivatives against finite differences.
            let e = 1e-6;
            let d = (h.point(t + e) - h.point(t - e)) / (2.0 * e);
            assert!((d - h.derivative(t)).length() < 1e-8);
            let dd = (h.derivative(t + e) - h.derivative(t - e)) / (2.0 * e);
            assert!((dd - h.second_derivative(t)).length() < 1e-8);
            // κ of (4.2) equals the plane-curve curvature |x′y″ − y′x″|/|H′|³.
            let (d1, d2) = (h.derivative(t), h.second_derivative(t));
            let k_num = d1.perp_dot(d2).abs() / d1.length().powi(3);
            assert!((h.curvature(t) - k_num).abs() < 1e-12 * k_num.max(1.0));
        }
    }

    proptest! {
        /// Proposition 1: κ_H is largest at t = 0 or t = π (mod 2π).
        #[test]
        fn proposition_1_curvature_is_maximal_at_multiples_of_pi(
            a in 0.05f64..3.0, b in 0.0f64..3.0, c in -PI..PI,
        ) {
            let h = ProjectedHelix::new(a, b, c);
            let at_ends = h.curvature(0.0).max(h.curvature(PI));
            for k in 0..=4000 {
                let t = -PI + 2.0 * PI * k as f64 / 4000.0;
                let kt = h.curvature(t);
                prop_assert!(kt <= at_ends * (1.0 + 1e-9), "t = {t}: {kt} > {at_ends}");
            }
        }
    }
}
