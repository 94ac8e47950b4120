//! [`HermitePair`]: a point and a tangent at each end — the input of every
//! two-point interpolation in the crate (Ghosh helices, ATPH curves, Euler
//! spirals).

use glam::DVec3;

/// Two points with tangents, `(p₀, t₀) → (p₁, t₁)`: the data of one
/// interpolation. Tangents need not be unit (each method normalises them).
///
/// Converts from and to the tuple `(p₀, t₀, p₁, t₁)` and the array
/// `[p₀, t₀, p₁, t₁]`.
///
/// ```
/// use strandfit::{DVec3, HermitePair};
///
/// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
/// assert_eq!(HermitePair::from((pair.p0, pair.t0, pair.p1, pair.t1)), pair);
/// assert_eq!(pair.chord(), DVec3::new(1.0, 1.0, 0.0));
/// // The same pair traversed the other way.
/// assert_eq!(pair.reversed().p0, pair.p1);
/// assert_eq!(pair.reversed().t0, -pair.t1);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HermitePair {
    /// Start point `p₀`.
    pub p0: DVec3,
    /// Start tangent `t₀`.
    pub t0: DVec3,
    /// End point `p₁`.
    pub p1: DVec3,
    /// End tangent `t₁`.
    pub t1: DVec3,
}

impl HermitePair {
    /// The pair `(p0, t0) → (p1, t1)`.
    #[inline]
    pub const fn new(p0: DVec3, t0: DVec3, p1: DVec3, t1: DVec3) -> Self {
        HermitePair { p0, t0, p1, t1 }
    }

    /// The chord `p₁ − p₀`.
    #[inline]
    pub fn chord(&self) -> DVec3 {
        self.p1 - self.p0
    }

    /// The same data traversed backwards: `(p₁, −t₁) → (p₀, −t₀)`.
    ///
    /// Reversing twice gives the pair back, and the reversed pair's helix
    /// is the same curve:
    ///
    /// ```
    /// use strandfit::{DVec3, HermitePair, ParamCurve3};
    ///
    /// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.5), DVec3::Y);
    /// assert_eq!(pair.reversed().reversed(), pair);
    /// let there = pair.interpolate(1e-12).unwrap().element;
    /// let back = pair.reversed().interpolate(1e-12).unwrap().element;
    /// assert!((there.arc_length() - back.arc_length()).abs() < 1e-9);
    /// assert!(there.eval(0.25).distance(back.eval(0.75)) < 1e-9);
    /// ```
    #[inline]
    pub fn reversed(&self) -> Self {
        HermitePair::new(self.p1, -self.t1, self.p0, -self.t0)
    }

    /// All four vectors are finite.
    #[inline]
    ///
    /// ```
    /// use strandfit::{DVec3, HermitePair};
    ///
    /// let mut pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y);
    /// assert!(pair.is_finite());
    /// pair.t1.z = f64::NAN;
    /// assert!(!pair.is_finite());
    /// ```
    pub fn is_finite(&self) -> bool {
        self.p0.is_finite() && self.t0.is_finite() && self.p1.is_finite() && self.t1.is_finite()
    }
}

impl From<(DVec3, DVec3, DVec3, DVec3)> for HermitePair {
    #[inline]
    fn from((p0, t0, p1, t1): (DVec3, DVec3, DVec3, DVec3)) -> Self {
        HermitePair { p0, t0, p1, t1 }
    }
}

impl From<HermitePair> for (DVec3, DVec3, DVec3, DVec3) {
    #[inline]
    fn from(p: HermitePair) -> Self {
        (p.p0, p.t0, p.p1, p.t1)
    }
}

impl From<[DVec3; 4]> for HermitePair {
    #[inline]
    fn from([p0, t0, p1, t1]: [DVec3; 4]) -> Self {
        HermitePair { p0, t0, p1, t1 }
    }
}

impl From<HermitePair> for [DVec3; 4] {
    #[inline]
    fn from(p: HermitePair) -> Self {
        [p.p0, p.t0, p.p1, p.t1]
    }
}
