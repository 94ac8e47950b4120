//! [`ParamCurve3`]: the small interface every curve primitive of the crate
//! implements — evaluation, unit tangent, arc length and sampling — so that
//! code written once (error metrics, exporters, plots) works on all of them.

use glam::DVec3;

use crate::atph::AtphCurve;
use crate::euler::FrenetProblem;
use crate::helix::{HelixElement, PiecewiseHelix};
use crate::rrmf::RrmfSpline;
use crate::spline::BezierSpline;

/// A parametric curve in 3D on `t ∈ [0, 1]`: the small interface every
/// curve primitive of the crate implements — evaluation, unit tangent, arc
/// length and sampling — so that code written once (error metrics,
/// exporters, plots) works on all of them.
///
/// **Parameter domain.** Every implementation takes `t ∈ [0, 1]` (values
/// outside are clamped), the primitive's own parameter rescaled to that
/// interval:
///
/// | primitive                      | `t` is                                         |
/// |--------------------------------|------------------------------------------------|
/// | [`HelixElement`] (Ghosh helix) | arc length `s/L`                               |
/// | [`PiecewiseHelix`]             | arc length `s/L` over the whole chain          |
/// | [`FrenetProblem`] (Euler spiral) | arc length `s/L`                             |
/// | [`AtphCurve`]                  | the curve's own `ξ ∈ [0, 1]`                   |
/// | [`RrmfSpline`]                 | the global chord-length parameter `u/u_N`      |
/// | [`BezierSpline`]               | `(i + tᵢ)/k` on segment `i` of `k`, local `tᵢ` |
///
/// so `t` is proportional to arc length for the first three and not, in
/// general, for the others. [`ParamCurve3::sample`] is always equally spaced
/// in *arc length*, whatever the parameter.
///
/// Some primitives have inherent methods of the same names with other
/// conventions (e.g. [`PiecewiseHelix::tangent`] takes an arc length and
/// returns an `Option`); inherent methods win method resolution, so call the
/// trait's as `ParamCurve3::tangent(&c, t)` or through a generic `C: ParamCurve3`.
///
/// ```
/// use strandfit::{DVec3, HelixElement, ParamCurve3};
///
/// // A quarter of a unit circle in the xy plane, as a helix element.
/// let quarter = HelixElement {
///     start: DVec3::X,
///     tangent: DVec3::Y,
///     normal: -DVec3::X,
///     curvature: 1.0,
///     torsion: 0.0,
///     length: std::f64::consts::FRAC_PI_2,
/// };
/// assert!((quarter.eval(1.0) - DVec3::Y).length() < 1e-12);
/// assert!((quarter.tangent(1.0) + DVec3::X).length() < 1e-12);
/// assert!((quarter.arc_length() - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
/// let pts = quarter.sample(5);
/// assert_eq!(pts.len(), 5);
/// assert!(pts.iter().all(|p| (p.length() - 1.0).abs() < 1e-12));
/// ```
pub trait ParamCurve3 {
    /// The point at parameter `t ∈ [0, 1]` (clamped).
    ///
    /// On a one-segment Bézier spline `t` is the segment's own parameter
    /// (the spline's inherent `eval` takes a segment index too, hence the
    /// trait's name in the call):
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3, ParamCurve3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::Y, DVec3::new(1.0, 1.0, 0.0), DVec3::X]).unwrap();
    /// // B(½) = (P₀ + 3P₁ + 3P₂ + P₃)/8
    /// assert!(ParamCurve3::eval(&s, 0.5).distance(DVec3::new(0.5, 0.75, 0.0)) < 1e-15);
    /// assert_eq!(ParamCurve3::eval(&s, 7.0), ParamCurve3::eval(&s, 1.0)); // clamped
    /// ```
    fn eval(&self, t: f64) -> DVec3;

    /// The unit tangent at `t ∈ [0, 1]` (clamped), pointing towards
    /// increasing `t`.
    ///
    /// Unit whatever the speed of the parametrisation (here 6 at the start):
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3, ParamCurve3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, 2.0 * DVec3::Y, DVec3::new(1.0, 1.0, 0.0), DVec3::X]).unwrap();
    /// assert!(ParamCurve3::tangent(&s, 0.0).distance(DVec3::Y) < 1e-12);
    /// assert!(ParamCurve3::tangent(&s, 1.0).distance(-DVec3::Y) < 1e-12);
    /// ```
    fn tangent(&self, t: f64) -> DVec3;

    /// The total arc length `L = ∫₀¹ |dγ/dt| dt`.
    ///
    /// A straight spline of length 3 whose parameter is far from arc
    /// length (its control points bunch at the start):
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3, ParamCurve3};
    ///
    /// let line = BezierSpline::from_control_points(&[DVec3::ZERO, 0.1 * DVec3::X, 0.2 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// assert!((line.arc_length() - 3.0).abs() < 1e-6);
    /// ```
    fn arc_length(&self) -> f64;

    /// `n` points equally spaced in arc length, both ends included
    /// (`n = 1`: the start; `n = 0`: none).
    ///
    /// Equally spaced in arc length even where the parameter is not:
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3, ParamCurve3};
    ///
    /// let line = BezierSpline::from_control_points(&[DVec3::ZERO, 0.1 * DVec3::X, 0.2 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// let xs: Vec<f64> = ParamCurve3::sample(&line, 4).iter().map(|p| p.x).collect();
    /// assert!(xs.iter().zip([0.0, 1.0, 2.0, 3.0]).all(|(x, e)| (x - e).abs() < 1e-6), "{xs:?}");
    /// assert_eq!(ParamCurve3::sample(&line, 1), [DVec3::ZERO]);
    /// assert!(ParamCurve3::sample(&line, 0).is_empty());
    /// ```
    fn sample(&self, n: usize) -> Vec<DVec3>;
}

/// `n` points at arc lengths `L j/(n − 1)` by `at(s)`, for primitives
/// parametrised by arc length.
fn sample_arclen(n: usize, length: f64, mut at: impl FnMut(f64) -> DVec3) -> Vec<DVec3> {
    match n {
        0 => Vec::new(),
        1 => vec![at(0.0)],
        _ => (0..n)
            .map(|j| at(length * j as f64 / (n - 1) as f64))
            .collect(),
    }
}

/// The `t ∈ [0, 1]` where the nondecreasing `f` reaches `target`, by 60
/// halvings (to rounding in `t`).
pub(crate) fn bisect_unit(f: impl Fn(f64) -> f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[inline]
fn unit(t: f64) -> f64 {
    // NaN reads as 0, like the primitives' own clamps.
    if t > 0.0 {
        t.min(1.0)
    } else {
        0.0
    }
}

impl ParamCurve3 for HelixElement {
    fn eval(&self, t: f64) -> DVec3 {
        self.point(unit(t) * self.length)
    }

    fn tangent(&self, t: f64) -> DVec3 {
        self.tangent_at(unit(t) * self.length)
    }

    fn arc_length(&self) -> f64 {
        self.length
    }

    fn sample(&self, n: usize) -> Vec<DVec3> {
        sample_arclen(n, self.length, |s| self.point(s))
    }
}

impl ParamCurve3 for PiecewiseHelix {
    /// The origin for an empty chain.
    fn eval(&self, t: f64) -> DVec3 {
        self.point(unit(t) * self.length()).unwrap_or(DVec3::ZERO)
    }

    /// Zero for an empty chain.
    fn tangent(&self, t: f64) -> DVec3 {
        PiecewiseHelix::tangent(self, unit(t) * self.length()).unwrap_or(DVec3::ZERO)
    }

    fn arc_length(&self) -> f64 {
        self.length()
    }

    /// [`PiecewiseHelix::sample`] (no points for an empty chain).
    fn sample(&self, n: usize) -> Vec<DVec3> {
        PiecewiseHelix::sample(self, n)
    }
}

/// Steps of the fourth-order Frenet integrator per evaluation of an Euler
/// spiral: error `≈ C (Θ/1024)⁴` for a total turning `Θ`.
const EULER_STEPS: usize = 1024;

impl ParamCurve3 for FrenetProblem {
    /// The end of [`FrenetProblem::integrate_unchecked`] on the spiral cut
    /// at `s = tL` (1024 steps).
    fn eval(&self, t: f64) -> DVec3 {
        self.cut(t).point
    }

    /// `T(tL)`, as [`eval`](Self::eval).
    fn tangent(&self, t: f64) -> DVec3 {
        self.cut(t).frame[0]
    }

    fn arc_length(&self) -> f64 {
        self.length
    }

    /// [`FrenetProblem::sample_unchecked`] with about 1024 steps in all.
    fn sample(&self, n: usize) -> Vec<DVec3> {
        let every = EULER_STEPS.div_ceil(n.saturating_sub(1).max(1));
        self.sample_unchecked(n, every)
            .into_iter()
            .map(|e| e.point)
            .collect()
    }
}

impl FrenetProblem {
    fn cut(&self, t: f64) -> crate::euler::FrenetEnd {
        FrenetProblem {
            length: unit(t) * self.length,
            ..*self
        }
        .integrate_unchecked(EULER_STEPS)
    }
}

impl ParamCurve3 for AtphCurve {
    fn eval(&self, t: f64) -> DVec3 {
        self.position(unit(t))
    }

    /// [`AtphCurve::unit_tangent`]: `sign(ρ) T`.
    fn tangent(&self, t: f64) -> DVec3 {
        self.unit_tangent(unit(t))
    }

    /// `∫₀¹ |ρ|` ([`AtphCurve::length`], exact).
    fn arc_length(&self) -> f64 {
        self.length()
    }

    /// [`AtphCurve::sample`] (arc length inverted by bisection).
    fn sample(&self, n: usize) -> Vec<DVec3> {
        match n {
            0 => Vec::new(),
            1 => vec![self.position(0.0)],
            _ => AtphCurve::sample(self, n),
        }
    }
}

impl ParamCurve3 for RrmfSpline {
    fn eval(&self, t: f64) -> DVec3 {
        self.position(unit(t) * self.last_knot())
    }

    /// The unit tangent of the segment's PH quintic (the first vector of
    /// the rotation-minimising frame).
    fn tangent(&self, t: f64) -> DVec3 {
        let (i, u) = self.locate(unit(t) * self.last_knot());
        self.segments[i].curve.curve.tangent(u)
    }

    /// Sum of the segments' exact PH arc lengths.
    fn arc_length(&self) -> f64 {
        self.segments.iter().map(|s| s.curve.curve.length()).sum()
    }

    /// Arc length inverted per segment by bisection on the exact
    /// (monotone, quintic) `s(t)`, 60 halvings.
    fn sample(&self, n: usize) -> Vec<DVec3> {
        let lengths: Vec<f64> = self
            .segments
            .iter()
            .map(|s| s.curve.curve.length())
            .collect();
        let total: f64 = lengths.iter().sum();
        let mut i = 0;
        let mut before = 0.0;
        sample_arclen(n, total, |s| {
            while i + 1 < lengths.len() && before + lengths[i] <= s {
                before += lengths[i];
                i += 1;
            }
            let c = &self.segments[i].curve.curve;
            let local = s - before;
            let t = if local >= lengths[i] {
                1.0
            } else {
                bisect_unit(|t| c.arc_length_to(t), local)
            };
            c.position(t)
        })
    }
}

impl RrmfSpline {
    fn last_knot(&self) -> f64 {
        *self.knots.last().unwrap_or(&0.0)
    }
}

impl BezierSpline {
    /// Segment and local parameter of the global `t ∈ [0, 1]`.
    fn global(&self, t: f64) -> (usize, f64) {
        let k = self.num_segments();
        let x = unit(t) * k as f64;
        let seg = (x.floor() as usize).min(k - 1);
        (seg, x - seg as f64)
    }
}

impl ParamCurve3 for BezierSpline {
    fn eval(&self, t: f64) -> DVec3 {
        let (seg, u) = self.global(t);
        BezierSpline::eval(self, seg, u)
    }

    /// [`BezierSpline::unit_tangent`] (defined where `B′` vanishes too).
    fn tangent(&self, t: f64) -> DVec3 {
        let (seg, u) = self.global(t);
        self.unit_tangent(seg, u)
    }

    /// [`BezierSpline::length`] (tabulated to the spline's accuracy).
    fn arc_length(&self) -> f64 {
        self.length()
    }

    /// [`BezierSpline::sample_points`].
    fn sample(&self, n: usize) -> Vec<DVec3> {
        match n {
            0 => Vec::new(),
            1 => vec![self.control_points()[0]],
            _ => self.sample_points(n).unwrap_or_default(),
        }
    }
}
