//! A piecewise cubic Bézier spline with a precomputed arc-length table.

use glam::DVec3;

use super::cubic::CubicBez;
use super::gauss::gl8;
use super::SplineError;

/// Default requested arc-length accuracy, relative to the total length.
pub const DEFAULT_ACCURACY: f64 = 1e-12;

/// Requested accuracies below this are raised to it: the panel sums cannot
/// be more accurate than a few ulps of the total.
const MIN_ACCURACY: f64 = 16.0 * f64::EPSILON;

/// Maximum bisection depth of the adaptive quadrature. Smooth segments stop
/// after a few levels; only a near-cusp (where `|B'|` has a kink) needs
/// `O(log₂(1/tol))` levels, and only along the path to the kink.
const MAX_DEPTH: u32 = 40;

/// Newton stops once its step is below this (in `t`); with quadratic
/// convergence the error after such a step is `O(step²)`, far below it.
const NEWTON_STEP_TOL: f64 = 1e-14;

/// Iteration cap of the safeguarded Newton solve. Bisection alone halves a
/// panel (width ≤ 1) to below `f64::EPSILON` in 53 steps.
const MAX_NEWTON_ITERS: u32 = 64;

/// One breakpoint of the arc-length table of a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Knot {
    /// Parameter in `[0, 1]`.
    t: f64,
    /// Arc length from the start of the segment to `t`.
    s: f64,
}

/// `B'(t) = c₀ + c₁t + c₂t²` in power form: the integrand is evaluated
/// thousands of times per spline, and Horner needs 2 fused steps per
/// coordinate against the 3 lerps of the Bernstein form. On `[0, 1]` the
/// coefficients are at most `12·leg`, so the absolute error stays
/// `O(ε·leg)`, negligible next to the integral.
#[derive(Clone, Copy, Debug)]
struct Speed {
    c0: DVec3,
    c1: DVec3,
    c2: DVec3,
}

impl Speed {
    #[inline]
    fn new(c: &CubicBez) -> Self {
        let d0 = c.p1 - c.p0;
        let d1 = c.p2 - c.p1;
        let d2 = c.p3 - c.p2;
        Speed {
            c0: 3.0 * d0,
            c1: 6.0 * (d1 - d0),
            c2: 3.0 * (d0 - 2.0 * d1 + d2),
        }
    }

    /// `|B'(t)|`.
    #[inline]
    fn at(&self, t: f64) -> f64 {
        (self.c0 + t * (self.c1 + t * self.c2)).length()
    }

    /// `|B''(t)|`.
    #[inline]
    fn accel(&self, t: f64) -> f64 {
        (self.c1 + 2.0 * t * self.c2).length()
    }

    /// `∫ₐᵇ |B'(t)| dt` by one 8-point Gauss–Legendre panel.
    #[inline]
    fn integrate(&self, a: f64, b: f64) -> f64 {
        gl8(a, b, |t| self.at(t))
    }
}

/// A piecewise cubic Bézier spline from `3k + 1` control points: segment `i`
/// is `P₃ᵢ, P₃ᵢ₊₁, P₃ᵢ₊₂, P₃ᵢ₊₃`, so consecutive segments share an end point.
///
/// Arc length `s(t) = ∫|B'|` is tabulated at construction by adaptive
/// Gauss–Legendre quadrature: each segment is split into panels on which the
/// 8-point rule is accurate to the requested tolerance, and the cumulative
/// lengths at the panel breakpoints are stored. Arc length at any parameter
/// is then one table look-up plus one 8-point rule on a sub-panel, and the
/// inverse is a look-up plus a few safeguarded Newton steps.
///
/// Zero-length segments (all four control points equal) are allowed; they
/// are skipped when locating an arc length and when choosing a tangent.
#[derive(Clone, Debug)]
pub struct BezierSpline {
    points: Vec<DVec3>,
    segs: Vec<CubicBez>,
    /// `cum[i]`: arc length from the start to the start of segment `i`;
    /// `k + 1` entries, `cum[k]` is the total length.
    cum: Vec<f64>,
    /// Segment `i` owns `knots[koff[i]..koff[i + 1]]`, from `(0, 0)` to
    /// `(1, length of segment i)`.
    koff: Vec<usize>,
    knots: Vec<Knot>,
    /// First and last segment of positive length.
    first_live: usize,
    last_live: usize,
    accuracy: f64,
}

impl BezierSpline {
    /// Builds the spline with the [`DEFAULT_ACCURACY`] arc-length accuracy.
    ///
    /// Errors: a count that is not `3k + 1` with `k ≥ 1`, a non-finite
    /// coordinate, all points equal (zero length), or overflowing length.
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// // A straight cubic with its controls at thirds: length 3.
    /// let s = BezierSpline::from_control_points(&[
    ///     DVec3::ZERO, DVec3::X, 2.0 * DVec3::X, 3.0 * DVec3::X,
    /// ]).unwrap();
    /// assert!((s.length() - 3.0).abs() < 1e-12);
    /// assert!((s.point_at_arclen(1.5) - DVec3::new(1.5, 0.0, 0.0)).length() < 1e-12);
    /// ```
    pub fn from_control_points(points: &[DVec3]) -> Result<Self, SplineError> {
        Self::from_control_points_with_accuracy(points, DEFAULT_ACCURACY)
    }

    /// Builds the spline with arc lengths accurate to `accuracy × length`
    /// (absolute error of every tabulated and computed arc length; values
    /// below `16ε` are raised to `16ε`).
    ///
    /// A parabola `y = x²`, `x ∈ [0, 1]` (a degree-elevated quadratic) has length
    /// `√5/2 + asinh(2)/4`; the table honours the requested accuracy, and requests
    /// below `16ε` are raised to it:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let c = [DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0), DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)];
    /// let exact = 5f64.sqrt() / 2.0 + 2f64.asinh() / 4.0;
    /// let s = BezierSpline::from_control_points_with_accuracy(&c, 1e-4).unwrap();
    /// assert!((s.length() - exact).abs() <= 1e-4 * exact);
    /// let fine = BezierSpline::from_control_points_with_accuracy(&c, 1e-30).unwrap();
    /// assert_eq!(fine.accuracy(), 16.0 * f64::EPSILON);
    /// ```
    pub fn from_control_points_with_accuracy(
        points: &[DVec3],
        accuracy: f64,
    ) -> Result<Self, SplineError> {
        let n = points.len();
        if n < 4 || !(n - 1).is_multiple_of(3) {
            return Err(SplineError::BadControlPointCount(n));
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(SplineError::NonFiniteControlPoint(i));
        }
        if !(accuracy > 0.0 && accuracy.is_finite()) {
            return Err(SplineError::BadAccuracy(accuracy));
        }
        let accuracy = accuracy.max(MIN_ACCURACY);
        let segs: Vec<CubicBez> = points
            .windows(4)
            .step_by(3)
            .map(|w| CubicBez::new(w[0], w[1], w[2], w[3]))
            .collect();
        let k = segs.len();

        // A one-panel estimate of the total fixes the absolute tolerance.
        // It is a positive-weight rule of a nonnegative integrand, so it is
        // positive for any non-point segment and off by at most a modest
        // factor even across a cusp.
        let mut estimate = 0.0;
        let mut live = 0usize;
        for c in &segs {
            if !c.is_point() {
                estimate += Speed::new(c).integrate(0.0, 1.0);
                live += 1;
            }
        }
        if live == 0 {
            return Err(SplineError::ZeroLength);
        }
        if !estimate.is_finite() {
            return Err(SplineError::NonFiniteLength);
        }
        if !(estimate > 0.0) {
            return Err(SplineError::ZeroLength);
        }
        // Error budget per unit of parameter: the panels of a segment cover
        // [0, 1], so each segment contributes at most `tol / live`.
        let tol_density = accuracy * estimate / live as f64;

        let mut cum = Vec::with_capacity(k + 1);
        let mut koff = Vec::with_capacity(k + 1);
        // Smooth segments typically need 2–4 panels (3–5 knots).
        let mut knots = Vec::with_capacity(5 * k);
        cum.push(0.0);
        let mut total = 0.0;
        for c in &segs {
            koff.push(knots.len());
            knots.push(Knot { t: 0.0, s: 0.0 });
            let mut len = 0.0;
            if !c.is_point() {
                let sp = Speed::new(c);
                let whole = sp.integrate(0.0, 1.0);
                refine(
                    &sp,
                    0.0,
                    1.0,
                    whole,
                    tol_density,
                    MAX_DEPTH,
                    &mut knots,
                    &mut len,
                );
            } else {
                knots.push(Knot { t: 1.0, s: 0.0 });
            }
            total += len;
            cum.push(total);
        }
        koff.push(knots.len());
        if !total.is_finite() {
            return Err(SplineError::NonFiniteLength);
        }
        if !(total > 0.0) {
            return Err(SplineError::ZeroLength);
        }
        // Live segments are those with positive tabulated length; there is
        // at least one since the total is positive.
        let seg_len = |i: usize| cum[i + 1] - cum[i];
        let first_live = (0..k).find(|&i| seg_len(i) > 0.0).unwrap_or(0);
        let last_live = (0..k).rev().find(|&i| seg_len(i) > 0.0).unwrap_or(k - 1);
        Ok(BezierSpline {
            points: points.to_vec(),
            segs,
            cum,
            koff,
            knots,
            first_live,
            last_live,
            accuracy,
        })
    }

    /// The cubic segments, `k` of them.
    #[inline]
    pub fn segments(&self) -> &[CubicBez] {
        &self.segs
    }

    /// The `3k + 1` control points.
    #[inline]
    pub fn control_points(&self) -> &[DVec3] {
        &self.points
    }

    /// Number of segments `k`.
    #[inline]
    pub fn num_segments(&self) -> usize {
        self.segs.len()
    }

    /// The (effective) arc-length accuracy relative to the total length.
    #[inline]
    pub fn accuracy(&self) -> f64 {
        self.accuracy
    }

    /// Total arc length `L`.
    ///
    /// The parabola `y = x²`, `x ∈ [0, 1]`: `∫₀¹ √(1 + 4x²) dx = √5/2 + asinh(2)/4`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// assert!((s.length() - (5f64.sqrt() / 2.0 + 2f64.asinh() / 4.0)).abs() < 1e-12);
    /// ```
    #[inline]
    pub fn length(&self) -> f64 {
        self.cum[self.segs.len()]
    }

    /// Arc length of segment `seg` (0 for an index out of range).
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::X, 2.0 * DVec3::X,
    ///     3.0 * DVec3::X, 3.0 * DVec3::X, 3.0 * DVec3::X, DVec3::new(3.0, 2.0, 0.0)]).unwrap();
    /// assert!((s.segment_length(0) - 3.0).abs() < 1e-12);
    /// assert!((s.segment_length(1) - 2.0).abs() < 1e-12);
    /// assert_eq!(s.segment_length(2), 0.0); // out of range
    /// ```
    #[inline]
    pub fn segment_length(&self, seg: usize) -> f64 {
        if seg < self.segs.len() {
            self.cum[seg + 1] - self.cum[seg]
        } else {
            0.0
        }
    }

    /// Number of quadrature panels in the arc-length table (all segments).
    pub fn num_panels(&self) -> usize {
        self.knots.len() - self.segs.len()
    }

    /// `B(t)` on segment `seg`; `seg` is clamped to the last segment and
    /// `t` to `[0, 1]` (NaN reads as 0).
    ///
    /// The parabola `y = x²` (its `x` is linear in `t`):
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// assert!((s.eval(0, 0.3) - DVec3::new(0.3, 0.09, 0.0)).length() < 1e-15);
    /// assert_eq!(s.eval(7, 2.0), DVec3::new(1.0, 1.0, 0.0)); // clamped
    /// ```
    #[inline]
    pub fn eval(&self, seg: usize, t: f64) -> DVec3 {
        let (seg, t) = self.clamp_param(seg, t);
        self.segs[seg].eval(t)
    }

    /// Arc length from the start of the spline to parameter `t` of segment
    /// `seg` (clamped as in [`eval`](Self::eval)).
    ///
    /// On the parabola `y = x²`, `s(x) = x√(1 + 4x²)/2 + asinh(2x)/4`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// let exact = 0.5 * 2f64.sqrt() / 2.0 + 1f64.asinh() / 4.0; // x = 0.5
    /// assert!((s.arclen_at(0, 0.5) - exact).abs() < 1e-12);
    /// ```
    pub fn arclen_at(&self, seg: usize, t: f64) -> f64 {
        let (seg, t) = self.clamp_param(seg, t);
        let ks = self.seg_knots(seg);
        let panels = ks.len() - 1;
        // Panel j covers [ks[j].t, ks[j+1].t); t = 1 is the last knot.
        let j = ks[1..].partition_point(|kn| kn.t <= t);
        let local = if j >= panels {
            ks[panels].s
        } else {
            let sp = Speed::new(&self.segs[seg]);
            ks[j].s + sp.integrate(ks[j].t, t)
        };
        self.cum[seg] + local
    }

    /// The parameter `(segment, t)` at arc length `s` from the start,
    /// clamped to `[0, L]` (NaN reads as 0).
    ///
    /// A point on a join belongs to the segment that starts there (`t = 0`),
    /// the end of the spline to the last segment (`t = 1`); zero-length
    /// segments are never returned.
    ///
    /// The inverse of [`arclen_at`](Self::arclen_at):
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// let (seg, t) = s.param_at_arclen(s.arclen_at(0, 0.3));
    /// assert_eq!(seg, 0);
    /// assert!((t - 0.3).abs() < 1e-12);
    /// ```
    pub fn param_at_arclen(&self, s: f64) -> (usize, f64) {
        if !(s > 0.0) {
            return (self.first_live, 0.0);
        }
        let k = self.segs.len();
        if s >= self.cum[k] {
            return (self.last_live, 1.0);
        }
        // First segment whose end lies beyond s: skips zero-length ones.
        let seg = self.cum[1..].partition_point(|&c| c <= s).min(k - 1);
        let local = s - self.cum[seg];
        let ks = self.seg_knots(seg);
        let j = ks[1..].partition_point(|kn| kn.s <= local);
        (seg, self.solve_panel(seg, j, local))
    }

    /// The point at arc length `s` (clamped to `[0, L]`).
    ///
    /// On the parabola `y = x²`, the point at `s(½) = √2/4 + asinh(1)/4` is `(½, ¼)`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// let p = s.point_at_arclen(2f64.sqrt() / 4.0 + 1f64.asinh() / 4.0);
    /// assert!((p - DVec3::new(0.5, 0.25, 0.0)).length() < 1e-12);
    /// ```
    pub fn point_at_arclen(&self, s: f64) -> DVec3 {
        let (seg, t) = self.param_at_arclen(s);
        self.segs[seg].eval(t)
    }

    /// Unit forward tangent at `t` of segment `seg` (clamped as in
    /// [`eval`](Self::eval)), correct where `B'` vanishes (see
    /// [`CubicBez::unit_tangent`]). On a zero-length segment this is the
    /// start tangent of the next segment of positive length, or failing
    /// that the end tangent of the previous one.
    ///
    /// The parabola's tangent `(1, 2x)` normalised, and a start where `B'` vanishes
    /// (`P₀ = P₁`), which still gives the direction of motion:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// assert!((s.unit_tangent(0, 0.5) - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
    /// let cusp = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::ZERO, DVec3::Y, DVec3::X]).unwrap();
    /// assert!((cusp.unit_tangent(0, 0.0) - DVec3::Y).length() < 1e-15);
    /// ```
    pub fn unit_tangent(&self, seg: usize, t: f64) -> DVec3 {
        let (seg, t) = self.clamp_param(seg, t);
        if let Some(v) = self.segs[seg].unit_tangent(t) {
            return v;
        }
        let next = self.segs[seg + 1..]
            .iter()
            .find_map(|c| c.unit_tangent(0.0));
        let prev = || {
            self.segs[..seg]
                .iter()
                .rev()
                .find_map(|c| c.unit_tangent(1.0))
        };
        // Construction guarantees a non-point segment, so one of them exists.
        next.or_else(prev).unwrap_or(DVec3::ZERO)
    }

    /// Unit tangent at arc length `s` (clamped to `[0, L]`).
    ///
    /// At the end of the parabola `y = x²` the tangent is `(1, 2)/√5`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// let t = s.tangent_at_arclen(s.length());
    /// assert!((t - DVec3::new(1.0, 2.0, 0.0).normalize()).length() < 1e-15);
    /// ```
    pub fn tangent_at_arclen(&self, s: f64) -> DVec3 {
        let (seg, t) = self.param_at_arclen(s);
        self.unit_tangent(seg, t)
    }

    /// `N + 1` points with unit tangents at `s_j = j·L/N`, `j = 0..=N`
    /// (step 1 of the floating tangents method). The first and last points
    /// are exactly the first and last control points.
    ///
    /// A straight cubic parameterised unevenly (`B(t) = (3t² − 2t³)·3x`) is still
    /// sampled at equal arc lengths; `B'(0) = 0`, yet the start tangent is `x`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::ZERO, 3.0 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// let samples = s.sample_equal_arclen(3).unwrap();
    /// for (j, (p, t)) in samples.iter().enumerate() {
    ///     assert!((*p - j as f64 * DVec3::X).length() < 1e-12 && (*t - DVec3::X).length() < 1e-15);
    /// }
    /// ```
    pub fn sample_equal_arclen(
        &self,
        n_elements: usize,
    ) -> Result<Vec<(DVec3, DVec3)>, SplineError> {
        check_count("elements", 1, n_elements)?;
        let mut out = Vec::with_capacity(n_elements + 1);
        self.walk(n_elements, |p, tan| out.push((p, tan)), true);
        Ok(out)
    }

    /// As [`sample_equal_arclen`](Self::sample_equal_arclen), writing into
    /// caller buffers (cleared first; no allocation once they have room).
    ///
    /// On the parabola `y = x²`, the `x` of sample `j` solves `s(x) = jL/N`, with
    /// `s(x) = x√(1 + 4x²)/2 + asinh(2x)/4`:
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::new(1.0 / 3.0, 0.0, 0.0),
    ///     DVec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]).unwrap();
    /// let (mut p, mut t) = (Vec::new(), Vec::new());
    /// s.sample_equal_arclen_into(8, &mut p, &mut t).unwrap();
    /// let arc = |x: f64| x * (1.0 + 4.0 * x * x).sqrt() / 2.0 + (2.0 * x).asinh() / 4.0;
    /// for j in 0..=8 {
    ///     assert!((arc(p[j].x) - j as f64 * s.length() / 8.0).abs() < 1e-12);
    /// }
    /// ```
    pub fn sample_equal_arclen_into(
        &self,
        n_elements: usize,
        points: &mut Vec<DVec3>,
        tangents: &mut Vec<DVec3>,
    ) -> Result<(), SplineError> {
        check_count("elements", 1, n_elements)?;
        points.clear();
        tangents.clear();
        points.reserve(n_elements + 1);
        tangents.reserve(n_elements + 1);
        self.walk(
            n_elements,
            |p, tan| {
                points.push(p);
                tangents.push(tan);
            },
            true,
        );
        Ok(())
    }

    /// `m ≥ 2` points equally spaced in arc length, ends included.
    ///
    /// A straight cubic parameterised unevenly (`B(t) = (3t² − 2t³)·3x`):
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::ZERO, 3.0 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// let p = s.sample_points(7).unwrap();
    /// assert!((p[3] - 1.5 * DVec3::X).length() < 1e-12 && (p[5] - 2.5 * DVec3::X).length() < 1e-12);
    /// ```
    pub fn sample_points(&self, m: usize) -> Result<Vec<DVec3>, SplineError> {
        let mut out = Vec::new();
        self.sample_points_into(m, &mut out)?;
        Ok(out)
    }

    /// As [`sample_points`](Self::sample_points), into a caller buffer.
    ///
    /// ```
    /// use strandfit::{BezierSpline, DVec3};
    ///
    /// let s = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::ZERO, 3.0 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// let mut buf = vec![DVec3::NAN; 10]; // cleared first
    /// s.sample_points_into(4, &mut buf).unwrap();
    /// assert!(buf.iter().enumerate().all(|(j, p)| p.distance(j as f64 * DVec3::X) < 1e-12));
    /// assert!(s.sample_points_into(1, &mut buf).is_err()); // m ≥ 2
    /// ```
    pub fn sample_points_into(&self, m: usize, out: &mut Vec<DVec3>) -> Result<(), SplineError> {
        check_count("points", 2, m)?;
        out.clear();
        out.reserve(m);
        self.walk(m - 1, |p, _| out.push(p), false);
        Ok(())
    }

    // ---- internals ----

    #[inline]
    fn clamp_param(&self, seg: usize, t: f64) -> (usize, f64) {
        let seg = seg.min(self.segs.len() - 1);
        let t = if t >= 1.0 {
            1.0
        } else if t > 0.0 {
            t
        } else {
            0.0
        };
        (seg, t)
    }

    #[inline]
    fn seg_knots(&self, seg: usize) -> &[Knot] {
        &self.knots[self.koff[seg]..self.koff[seg + 1]]
    }

    /// Visits the `n + 1` equal-arc-length samples in order. Targets
    /// increase, so a cursor `(segment, panel)` only moves forward: the walk
    /// costs `O(k + panels + n)` look-ups in total instead of `n` binary
    /// searches. Tangents are computed only when `with_tangents`.
    fn walk(&self, n: usize, mut emit: impl FnMut(DVec3, DVec3), with_tangents: bool) {
        let k = self.segs.len();
        let total = self.cum[k];
        let tangent = |seg: usize, t: f64| {
            if with_tangents {
                self.unit_tangent(seg, t)
            } else {
                DVec3::ZERO
            }
        };
        // Exact end points, whatever rounding the table carries.
        emit(self.points[0], tangent(self.first_live, 0.0));
        let mut seg = self.first_live;
        let mut j = 0usize;
        let inv_n = 1.0 / n as f64;
        for i in 1..n {
            let s = total * (i as f64 * inv_n);
            // Advance to the first segment whose end lies beyond s (this
            // skips zero-length segments); s < total keeps seg < k.
            let mut moved = false;
            while seg + 1 < k && self.cum[seg + 1] <= s {
                seg += 1;
                moved = true;
            }
            if moved {
                j = 0;
            }
            let local = s - self.cum[seg];
            let ks = self.seg_knots(seg);
            while j + 1 < ks.len() && ks[j + 1].s <= local {
                j += 1;
            }
            let t = self.solve_panel(seg, j, local);
            let c = &self.segs[seg];
            emit(c.eval(t), tangent(seg, t));
        }
        let last = self.points[self.points.len() - 1];
        emit(last, tangent(self.last_live, 1.0));
    }

    /// `t` in panel `j` of `seg` with `s(t) − s(start of segment) = local`,
    /// by Newton's method on `g(t) = ∫_{tⱼ}^{t} |B'| − (local − sⱼ)` with
    /// `g' = |B'(t)|`, safeguarded by the bracket `[tⱼ, tⱼ₊₁]`: any step
    /// that leaves the (shrinking) bracket, or a vanishing `|B'|`, falls
    /// back to bisection, so the solve always converges.
    fn solve_panel(&self, seg: usize, j: usize, local: f64) -> f64 {
        let ks = self.seg_knots(seg);
        if j + 1 >= ks.len() {
            // At (or rounding past) the segment end.
            return 1.0;
        }
        let (k0, k1) = (ks[j], ks[j + 1]);
        let target = local - k0.s;
        let span = k1.s - k0.s;
        if !(target > 0.0) {
            return k0.t;
        }
        if !(target < span) {
            return k1.t;
        }
        let sp = Speed::new(&self.segs[seg]);
        let (mut lo, mut hi) = (k0.t, k1.t);
        let mut t = lo + (hi - lo) * initial_fraction(sp.at(lo), sp.at(hi), target / span);
        for _ in 0..MAX_NEWTON_ITERS {
            let g = sp.integrate(k0.t, t) - target;
            if g == 0.0 {
                return t;
            }
            if g > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let speed = sp.at(t);
            let step = g / speed;
            let tn = t - step;
            // Converged: Newton's next error is `≈ s''/(2s')·step²` with
            // `|s''| = |B'·B''|/|B'| ≤ |B''|`, so a small enough step is
            // final and the (costly) confirming iteration is skipped. This is
            // tested before the bracket check, since a step below one ulp
            // leaves `tn == t`, which is a bracket end by now.
            let a = step.abs();
            if a <= NEWTON_STEP_TOL
                || (a <= 1e-5 && a * a * sp.accel(t) <= NEWTON_STEP_TOL * 2.0 * speed)
            {
                return tn.clamp(lo, hi);
            }
            // `!(lo < tn < hi)` also catches NaN/∞ from a zero speed.
            if tn > lo && tn < hi {
                t = tn;
            } else {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    return mid;
                }
                t = mid;
            }
        }
        t
    }
}

/// Adaptive Gauss–Legendre on `[a, b]` with `whole = GL(a, b)` known:
/// bisect while `|GL(a,b) − GL(a,m) − GL(m,b)| > tol_density·(b − a)`.
/// That difference estimates the error of the coarse `GL(a, b)`; the finer
/// halves are kept (their error is ~2¹⁶ times smaller for smooth integrands),
/// so the summed error over the segment is below `tol_density`. Pushes the
/// knots `m` and `b` of accepted halves with running sums in `acc`.
#[allow(clippy::too_many_arguments)]
fn refine(
    sp: &Speed,
    a: f64,
    b: f64,
    whole: f64,
    tol_density: f64,
    depth: u32,
    knots: &mut Vec<Knot>,
    acc: &mut f64,
) {
    let m = 0.5 * (a + b);
    let l = sp.integrate(a, m);
    let r = sp.integrate(m, b);
    let err = (whole - (l + r)).abs();
    // Rounding floor: below a few ulps of the panel's value the estimate is
    // noise and bisecting further cannot help.
    // A non-finite estimate (overflowing coordinates) is accepted too; the
    // caller rejects the resulting non-finite length.
    let floor = 8.0 * f64::EPSILON * (l + r);
    if depth == 0 || !(err > (tol_density * (b - a)).max(floor)) {
        *acc += l;
        knots.push(Knot { t: m, s: *acc });
        *acc += r;
        knots.push(Knot { t: b, s: *acc });
        return;
    }
    refine(sp, a, m, l, tol_density, depth - 1, knots, acc);
    refine(sp, m, b, r, tol_density, depth - 1, knots, acc);
}

/// Starting guess for the inverse on a panel: the fraction `u ∈ [0, 1]` of
/// its parameter width at which the fraction `r` of its length is reached,
/// modelling the speed as linear between the end speeds `v0`, `v1` (and
/// rescaled so the model's length is the panel's). Solves
/// `(v1−v0)/2·u² + v0·u = r(v0+v1)/2` by the cancellation-free root form
/// `u = 2c / (v0 + √((1−r)v0² + r v1²))`. This is `O(h³)` accurate against
/// `O(h²)` for plain linear interpolation, which saves a Newton step.
#[inline]
fn initial_fraction(v0: f64, v1: f64, r: f64) -> f64 {
    let c = r * (v0 + v1);
    let den = v0 + ((1.0 - r) * v0 * v0 + r * v1 * v1).sqrt();
    let u = c / den;
    if (0.0..=1.0).contains(&u) {
        u
    } else {
        // Zero end speeds (0/0) or rounding past the ends.
        r
    }
}

#[inline]
fn check_count(what: &'static str, min: usize, got: usize) -> Result<(), SplineError> {
    if got < min {
        Err(SplineError::TooFewSamples { what, min, got })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn initial_fraction_is_exact_for_linear_speed() {
        // Speed v(u) = v0 + (v1 − v0)u ⇒ s(u) = v0 u + (v1 − v0)u²/2.
        for (v0, v1) in [(1.0, 3.0), (3.0, 1.0), (2.0, 2.0), (0.0, 1.0), (1.0, 0.0)] {
            let total: f64 = 0.5 * (v0 + v1);
            for i in 0..=10 {
                let u = i as f64 / 10.0;
                let r = (v0 * u + 0.5 * (v1 - v0) * u * u) / total;
                let got = initial_fraction(v0, v1, r);
                assert!((got - u).abs() < 1e-14, "v0={v0} v1={v1} u={u} got {got}");
            }
        }
        assert_eq!(initial_fraction(0.0, 0.0, 0.25), 0.25);
        assert_eq!(initial_fraction(f64::NAN, 1.0, 0.25), 0.25);
    }
}
