//! One cubic Bézier segment.

use glam::DVec3;

/// A cubic Bézier segment `B(t) = Σ bᵢ,₃(t) Pᵢ`, `t ∈ [0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicBez {
    /// Start point.
    pub p0: DVec3,
    /// First inner control point.
    pub p1: DVec3,
    /// Second inner control point.
    pub p2: DVec3,
    /// End point.
    pub p3: DVec3,
}

impl CubicBez {
    #[inline]
    /// The cubic with control points `p0 … p3`.
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3) -> Self {
        CubicBez { p0, p1, p2, p3 }
    }

    /// `B(t)`, by de Casteljau's algorithm (stable for `t ∈ [0, 1]`).
    ///
    /// For `B(t) = t³ x` (control points `0, 0, 0, x`):
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::X);
    /// assert_eq!(c.eval(0.5), 0.125 * DVec3::X);
    /// ```
    #[inline]
    pub fn eval(&self, t: f64) -> DVec3 {
        let a = self.p0.lerp(self.p1, t);
        let b = self.p1.lerp(self.p2, t);
        let c = self.p2.lerp(self.p3, t);
        let d = a.lerp(b, t);
        let e = b.lerp(c, t);
        d.lerp(e, t)
    }

    /// `B'(t) = 3[(1−t)²(P1−P0) + 2t(1−t)(P2−P1) + t²(P3−P2)]`.
    ///
    /// For `B(t) = t³ x`, `B'(t) = 3t² x`:
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::X);
    /// assert!((c.deriv(0.5) - 0.75 * DVec3::X).length() < 1e-15);
    /// ```
    #[inline]
    pub fn deriv(&self, t: f64) -> DVec3 {
        let d0 = self.p1 - self.p0;
        let d1 = self.p2 - self.p1;
        let d2 = self.p3 - self.p2;
        let a = d0.lerp(d1, t);
        let b = d1.lerp(d2, t);
        3.0 * a.lerp(b, t)
    }

    /// `B''(t) = 6[(1−t)(P2 − 2P1 + P0) + t(P3 − 2P2 + P1)]`.
    ///
    /// For `B(t) = t³ x`, `B''(t) = 6t x`:
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::X);
    /// assert!((c.deriv2(0.5) - 3.0 * DVec3::X).length() < 1e-15);
    /// ```
    #[inline]
    pub fn deriv2(&self, t: f64) -> DVec3 {
        let a = self.p2 - 2.0 * self.p1 + self.p0;
        let b = self.p3 - 2.0 * self.p2 + self.p1;
        6.0 * a.lerp(b, t)
    }

    /// `B'''(t) = 6(P3 − 3P2 + 3P1 − P0)` (constant).
    ///
    /// For `B(t) = t³ x`, `B''' = 6x`; for a quadratic (degree-elevated), 0:
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::X);
    /// assert_eq!(c.deriv3(), 6.0 * DVec3::X);
    /// let q = CubicBez::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 0.0), DVec3::new(2.0, 2.0, 0.0), DVec3::new(3.0, 0.0, 0.0));
    /// assert!(q.deriv3().length() < 1e-15);
    /// ```
    #[inline]
    pub fn deriv3(&self) -> DVec3 {
        6.0 * (self.p3 - 3.0 * self.p2 + 3.0 * self.p1 - self.p0)
    }
}

/// Multiple of `f64::EPSILON` below which a derivative counts as vanishing.
///
/// Why noise level and not a looser relative tolerance: a small *nonzero*
/// `B'(t)` is the true (and accurately computed, since the Bernstein form
/// keeps `Pᵢ₊₁ − Pᵢ` exact for coincident points) forward direction, e.g.
/// just before a zero of `B'` at `t = 1` it points along `−B''(1)`, which a
/// loose threshold followed by `+B''(t)` would flip. Only values that are
/// indistinguishable from rounding of the control point differences are
/// treated as zero.
const NOISE: f64 = 64.0 * f64::EPSILON;

/// Within this parameter distance of an end whose derivative vanishes, a
/// noise-level `B'(t)` is attributed to that end's zero (one-sided rule of
/// the end) rather than to an interior cusp.
const END_SNAP: f64 = 1e-6;

impl CubicBez {
    /// `true` when all four control points coincide (a zero-length segment).
    ///
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// assert!(CubicBez::new(DVec3::ONE, DVec3::ONE, DVec3::ONE, DVec3::ONE).is_point());
    /// assert!(!CubicBez::new(DVec3::ONE, DVec3::ONE, DVec3::ONE, DVec3::X).is_point());
    /// ```
    #[inline]
    pub fn is_point(&self) -> bool {
        self.p0 == self.p1 && self.p1 == self.p2 && self.p2 == self.p3
    }

    /// Longest control polygon leg `max |Pᵢ₊₁ − Pᵢ|`; `|B'(t)| ≤ 3·leg`.
    ///
    /// The bound `|B'(t)| ≤ 3·leg` holds along the curve:
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 2.0), DVec3::new(2.0, 2.0, 2.0), DVec3::X);
    /// assert_eq!(c.leg_scale(), 3.0);
    /// assert!((0..=10).all(|i| c.deriv(i as f64 / 10.0).length() <= 3.0 * c.leg_scale()));
    /// ```
    #[inline]
    pub fn leg_scale(&self) -> f64 {
        let a = (self.p1 - self.p0).length();
        let b = (self.p2 - self.p1).length();
        let c = (self.p3 - self.p2).length();
        a.max(b).max(c)
    }

    /// Unit forward tangent at `t` (clamped to `[0, 1]`; NaN reads as 0),
    /// correct where `B'` vanishes; `None` only for a point segment.
    ///
    /// Where `B'(t) ≠ 0` this is `B'/|B'|`. Where it vanishes the direction
    /// of motion comes from Taylor expansion of `B'` on the side the curve
    /// continues to:
    /// * `t < 1` (approached from the right): `B'(t+h) ≈ h B''(t) + h²/2 B'''`,
    ///   so `+B''(t)`, or `+B'''` if that vanishes too;
    /// * `t = 1` (approached from the left): `B'(1−h) ≈ −h B''(1) + h²/2 B'''`,
    ///   so `−B''(1)`, or `+B'''`.
    ///
    /// `B'`, `B''`, `B'''` cannot all vanish for a non-point cubic (they
    /// determine `B'` on `[0, 1]` by Taylor's formula), so the cascade ends.
    ///
    /// Where `B'` vanishes: `B(t) = t³ x` starts along `B''' = 6x`; with `P₂ = P₃`
    /// the end direction is `−B''(1) ∥ P₃ − P₁`:
    /// ```
    /// use strandfit::spline::CubicBez;
    /// use strandfit::DVec3;
    ///
    /// let c = CubicBez::new(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::X);
    /// assert_eq!(c.unit_tangent(0.0), Some(DVec3::X));
    /// let e = CubicBez::new(DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::X);
    /// assert!((e.unit_tangent(1.0).unwrap() - DVec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-15);
    /// assert_eq!(CubicBez::new(DVec3::X, DVec3::X, DVec3::X, DVec3::X).unit_tangent(0.5), None);
    /// ```
    pub fn unit_tangent(&self, t: f64) -> Option<DVec3> {
        if self.is_point() {
            return None;
        }
        // Noise floor of the computed derivatives: the leg differences carry
        // rounding relative to the coordinates' magnitude, the lerps relative
        // to the legs. B'' and B''' have 4× and 8× the range of B'.
        let mag = self
            .p0
            .abs()
            .max(self.p1.abs())
            .max(self.p2.abs())
            .max(self.p3.abs())
            .max_element();
        let thr = NOISE * (self.leg_scale() + mag);
        let t = if t >= 1.0 {
            1.0
        } else if t > 0.0 {
            t
        } else {
            0.0
        };
        let d1 = self.deriv(t);
        if d1.length() > thr {
            return Some(d1.normalize());
        }
        // Noise-level B'(t) strictly inside: if it belongs to the zero at the
        // end t = 1 (P2 = P3), the forward direction is the end's one; the
        // same holds at t = 0 but there the right-side rule is the same one.
        let at_end = t == 1.0 || (1.0 - t <= END_SNAP && self.deriv(1.0).length() <= thr);
        let d3 = self.deriv3();
        if at_end {
            let d2 = self.deriv2(1.0);
            if d2.length() > 4.0 * thr {
                return Some(-d2.normalize());
            }
        } else {
            let d2 = self.deriv2(t);
            if d2.length() > 4.0 * thr {
                return Some(d2.normalize());
            }
        }
        if d3.length() > 8.0 * thr {
            return Some(d3.normalize());
        }
        // Unreachable for finite non-point input (see above) except through
        // extreme cancellation; fall back to the chord, else the first
        // nonzero leg.
        let chord = self.p3 - self.p0;
        if chord.length() > 0.0 {
            return chord.try_normalize();
        }
        [self.p1 - self.p0, self.p2 - self.p1, self.p3 - self.p2]
            .into_iter()
            .find_map(|v| v.try_normalize())
    }
}
