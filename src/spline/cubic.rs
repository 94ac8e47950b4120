//! One cubic Bézier segment.

use glam::DVec3;

/// A cubic Bézier segment `B(t) = Σ bᵢ,₃(t) Pᵢ`, `t ∈ [0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicBez {
    pub p0: DVec3,
    pub p1: DVec3,
    pub p2: DVec3,
    pub p3: DVec3,
}

impl CubicBez {
    #[inline]
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3) -> Self {
        CubicBez { p0, p1, p2, p3 }
    }

    /// `B(t)`, by de Casteljau's algorithm (stable for `t ∈ [0, 1]`).
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
    #[inline]
    pub fn deriv2(&self, t: f64) -> DVec3 {
        let a = self.p2 - 2.0 * self.p1 + self.p0;
        let b = self.p3 - 2.0 * self.p2 + self.p1;
        6.0 * a.lerp(b, t)
    }

    /// `B'''(t) = 6(P3 − 3P2 + 3P1 − P0)` (constant).
    #[inline]
    pub fn deriv3(&self) -> DVec3 {
        6.0 * (self.p3 - 3.0 * self.p2 + 3.0 * self.p1 - self.p0)
    }
}
