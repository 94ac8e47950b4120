//! A projected helix placed in the sketch plane, `PlacedHelix` (the
//! placement and the lift are described in the item's documentation).

use glam::{DVec2, DVec3};

use super::trig::sin_cos;
use super::ProjectedHelix;

/// The number of parameters of one placed helix.
///
/// ```
/// use strandfit::sketch::{PlacedHelix, PARAMS};
///
/// // The parameter vector, and one column of the Jacobian per parameter.
/// let p: [f64; PARAMS] = [0.7, 0.3, -0.2, 0.4, 0.15, 0.5];
/// let h = PlacedHelix::from_params(&p, false);
/// assert_eq!(h.params(), p);
/// assert_eq!(h.param_jacobian(0.4).len(), PARAMS);
/// ```
pub const PARAMS: usize = 6;

/// A projected helix in sketch coordinates.
///
/// Placed by the alignment of Section 6.1 (translation, rotation and
/// possibly a reflection between the helix frame `F_H` at `t = 0` and the
/// sketch), with the helix `(a, b, c)`:
///
/// ```text
/// P(t) = o + R(θ) S H(t),   S = diag(−1, 1) if reflected, else I,
/// ```
///
/// and its lift `(P(t), σ H_3D,R,z(t) + z₀)` (Section 7; `σ = −1` is the
/// mirror helix `H_3D,S`). The map `(x, y, z) ↦ (o + R S (x, y), σ z + z₀)`
/// is an isometry of space, so the lift of a helix is a helix.
///
/// Parameters for the fits are `p = [θ, o_x, o_y, a, b, c]`; `a` and `b`
/// may go negative during a fit (the curve is still a helix of radius `|a|`
/// and pitch `|b|`).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::PlacedHelix;
///
/// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
///
/// // H(0) lands on the origin; the placement keeps distances.
/// assert!((h.point(0.0) - h.origin).length() < 1e-15);
/// let (s, u) = (-1.0, 2.0);
/// let placed = (h.point(s) - h.point(u)).length();
/// let own = (h.helix.point(s) - h.helix.point(u)).length();
/// assert!((placed - own).abs() < 1e-14);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedHelix {
    /// The projected helix in its own frame.
    pub helix: ProjectedHelix,
    /// Rotation of the helix frame into the sketch.
    pub theta: f64,
    /// Where `H(0)` lands.
    pub origin: DVec2,
    /// The helix frame's `x` axis is flipped before the rotation.
    pub reflect: bool,
}

fn rotate(theta: f64, v: DVec2) -> DVec2 {
    let (s, c) = theta.sin_cos();
    DVec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

impl PlacedHelix {
    /// From the parameter vector `[θ, o_x, o_y, a, b, c]`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::{PlacedHelix, ProjectedHelix};
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    /// assert_eq!((h.theta, h.origin, h.reflect), (0.7, DVec2::new(0.3, -0.2), true));
    /// assert_eq!(h.helix, ProjectedHelix::new(0.4, 0.15, 0.5));
    /// ```
    pub fn from_params(p: &[f64; PARAMS], reflect: bool) -> Self {
        PlacedHelix {
            helix: ProjectedHelix::new(p[3], p[4], p[5]),
            theta: p[0],
            origin: DVec2::new(p[1], p[2]),
            reflect,
        }
    }

    /// The parameter vector `[θ, o_x, o_y, a, b, c]` (the inverse of
    /// [`from_params`](Self::from_params)).
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// assert_eq!(PlacedHelix::from_params(&h.params(), h.reflect), h);
    /// ```
    pub fn params(&self) -> [f64; PARAMS] {
        [
            self.theta,
            self.origin.x,
            self.origin.y,
            self.helix.a,
            self.helix.b,
            self.helix.c,
        ]
    }

    /// `R S v`: a vector of the helix frame in the sketch.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// // Turned a quarter: x goes to y, or to −y when reflected first.
    /// let p = [std::f64::consts::FRAC_PI_2, 0.0, 0.0, 1.0, 0.2, 0.3];
    /// let turned = PlacedHelix::from_params(&p, false).to_sketch_vector(DVec2::X);
    /// assert!((turned - DVec2::Y).length() < 1e-15);
    /// let reflected = PlacedHelix::from_params(&p, true).to_sketch_vector(DVec2::X);
    /// assert!((reflected + DVec2::Y).length() < 1e-15);
    /// ```
    pub fn to_sketch_vector(&self, v: DVec2) -> DVec2 {
        let v = if self.reflect {
            DVec2::new(-v.x, v.y)
        } else {
            v
        };
        rotate(self.theta, v)
    }

    /// The inverse map of a sketch point into the helix frame.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // The inverse of the placement.
    /// for t in [-2.0, 0.3, 1.7] {
    ///     assert!((h.to_local(h.point(t)) - h.helix.point(t)).length() < 1e-14);
    /// }
    /// ```
    pub fn to_local(&self, p: DVec2) -> DVec2 {
        let v = rotate(-self.theta, p - self.origin);
        if self.reflect {
            DVec2::new(-v.x, v.y)
        } else {
            v
        }
    }

    /// `P(t)`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// assert_eq!(h.point(0.0), h.origin);
    /// let t = 1.1;
    /// assert!((h.point(t) - (h.origin + h.to_sketch_vector(h.helix.point(t)))).length() < 1e-15);
    /// ```
    pub fn point(&self, t: f64) -> DVec2 {
        self.origin + self.to_sketch_vector(self.helix.point(t))
    }

    /// `P′(t)`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // Against a central difference.
    /// let (t, e) = (0.8, 1e-6);
    /// let d = (h.point(t + e) - h.point(t - e)) / (2.0 * e);
    /// assert!((d - h.derivative(t)).length() < 1e-8);
    /// ```
    pub fn derivative(&self, t: f64) -> DVec2 {
        self.to_sketch_vector(self.helix.derivative(t))
    }

    /// `P″(t)`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // Against a central difference of P′.
    /// let (t, e) = (0.8, 1e-6);
    /// let dd = (h.derivative(t + e) - h.derivative(t - e)) / (2.0 * e);
    /// assert!((dd - h.second_derivative(t)).length() < 1e-8);
    /// ```
    pub fn second_derivative(&self, t: f64) -> DVec2 {
        self.to_sketch_vector(self.helix.second_derivative(t))
    }

    /// `∂P(t)/∂p` for `p = [θ, o_x, o_y, a, b, c]`, from
    /// `∂H/∂a = (cos t − 1, −sin c sin t)`, `∂H/∂b = (0, t cos c)`,
    /// `∂H/∂c = (0, −bt sin c − a cos c sin t)` and `∂(R v)/∂θ = (R v)^⊥`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // The origin moves the point as itself; the radius as a central
    /// // difference says.
    /// let t = 1.3;
    /// let j = h.param_jacobian(t);
    /// assert_eq!((j[1], j[2]), (DVec2::X, DVec2::Y));
    /// let e = 1e-6;
    /// let (mut up, mut down) = (h.params(), h.params());
    /// up[3] += e;
    /// down[3] -= e;
    /// let fd = (PlacedHelix::from_params(&up, true).point(t) - PlacedHelix::from_params(&down, true).point(t)) / (2.0 * e);
    /// assert!((fd - j[3]).length() < 1e-8);
    /// ```
    pub fn param_jacobian(&self, t: f64) -> [DVec2; PARAMS] {
        self.evaluator().param_jacobian(t)
    }

    /// The lifted point `(P(t), σ z(t) + z₀)`, `σ = −1` when `mirror`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // Over the sketch point; the mirror turns z over, z0 raises it.
    /// let t = 0.9;
    /// let (up, mirrored) = (h.point_3d(t, false, 0.0), h.point_3d(t, true, 2.0));
    /// assert_eq!(up.truncate(), h.point(t));
    /// assert_eq!(mirrored.truncate(), h.point(t));
    /// assert!((mirrored.z - (2.0 - up.z)).abs() < 1e-15);
    /// ```
    pub fn point_3d(&self, t: f64, mirror: bool, z0: f64) -> DVec3 {
        let p = self.point(t);
        let z = self.helix.point_3d(t).z;
        DVec3::new(p.x, p.y, if mirror { -z } else { z } + z0)
    }

    /// The unit tangent of the lift; `None` where the helix degenerates to
    /// a point (`a = b = 0`).
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // Along a central difference of the lift, unit length.
    /// let (t, e) = (0.9, 1e-6);
    /// let tangent = h.tangent_3d(t, true).unwrap();
    /// let d = (h.point_3d(t + e, true, 0.0) - h.point_3d(t - e, true, 0.0)).normalize();
    /// assert!((tangent - d).length() < 1e-8);
    /// // A helix of no radius and no pitch is a point.
    /// let dot = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.0, 0.0, 0.5], false);
    /// assert_eq!(dot.tangent_3d(t, false), None);
    /// ```
    pub fn tangent_3d(&self, t: f64, mirror: bool) -> Option<DVec3> {
        let d = self.helix.derivative_3d(t);
        let xy = self.to_sketch_vector(DVec2::new(d.x, d.y));
        DVec3::new(xy.x, xy.y, if mirror { -d.z } else { d.z }).try_normalize()
    }

    /// The parameter of the point of the curve nearest `v`, by Newton's
    /// method from `guess`; see [`Evaluator::closest_parameter`].
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // A point 0.01 off the curve along its normal at t: the foot is at t.
    /// let t = 0.6;
    /// let (_, normal) = h.normal_offset(DVec2::ZERO, t);
    /// let v = h.point(t) + 0.01 * normal;
    /// assert!((h.closest_parameter(v, t + 0.1) - t).abs() < 1e-9);
    /// ```
    pub fn closest_parameter(&self, v: DVec2, guess: f64) -> f64 {
        self.evaluator().closest_parameter(v, guess)
    }

    /// The signed distance of `v` from the curve at parameter `t` along the
    /// unit normal `ν = P′^⊥/|P′|`, and that normal (zero at a cusp).
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// let t = 0.6;
    /// let (_, normal) = h.normal_offset(DVec2::ZERO, t);
    /// assert!((normal.length() - 1.0).abs() < 1e-15);
    /// assert!(normal.dot(h.derivative(t)).abs() < 1e-15);
    /// // Signed: the side of the normal is positive.
    /// let (d, _) = h.normal_offset(h.point(t) - 0.02 * normal, t);
    /// assert!((d + 0.02).abs() < 1e-15);
    /// ```
    pub fn normal_offset(&self, v: DVec2, t: f64) -> (f64, DVec2) {
        self.evaluator().normal_offset(v, t)
    }

    /// The curve with its trigonometry precomputed, for inner loops.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// let e = h.evaluator();
    /// let (p, d1, d2) = e.jet(0.4);
    /// assert!((p - h.point(0.4)).length() < 1e-15);
    /// assert!((d1 - h.derivative(0.4)).length() < 1e-15);
    /// assert!((d2 - h.second_derivative(0.4)).length() < 1e-15);
    /// ```
    pub fn evaluator(&self) -> Evaluator {
        let (st, ct) = self.theta.sin_cos();
        let sx = if self.reflect { -1.0 } else { 1.0 };
        let (sc, cc) = self.helix.c.sin_cos();
        Evaluator {
            origin: self.origin,
            ex: DVec2::new(sx * ct, sx * st),
            ey: DVec2::new(-st, ct),
            a: self.helix.a,
            b: self.helix.b,
            sc,
            cc,
        }
    }
}

/// A vertex measured against the curve at parameter `t`: its signed
/// distance along the unit normal there (see
/// [`PlacedHelix::normal_offset`]), the normal, and `sin t`, `cos t` (or
/// those a last sub-1e-9 Newton step before `t`; see
/// [`Evaluator::project`]).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::PlacedHelix;
///
/// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
///
/// // A vertex 0.01 off the curve along its normal at t = 0.6, projected.
/// let (_, normal) = h.normal_offset(DVec2::ZERO, 0.6);
/// let foot = h.evaluator().project(h.point(0.6) + 0.01 * normal, 0.5);
/// assert!((foot.t - 0.6).abs() < 1e-9);
/// assert!((foot.offset - 0.01).abs() < 1e-12);
/// assert!((foot.normal - normal).length() < 1e-9);
/// assert!((foot.sin_t - foot.t.sin()).abs() < 1e-8 && (foot.cos_t - foot.t.cos()).abs() < 1e-8);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foot {
    /// The parameter of the foot.
    pub t: f64,
    /// Signed distance of the vertex from the curve along `normal`.
    pub offset: f64,
    /// Unit normal of the projected curve at the foot.
    pub normal: DVec2,
    /// `sin t`, kept for the Jacobian.
    pub sin_t: f64,
    /// `cos t`, kept for the Jacobian.
    pub cos_t: f64,
}

/// Newton iterations of [`Evaluator::project`] before it stops where it is.
const MAX_NEWTON: usize = 30;

/// The Newton step at which [`Evaluator::project_all_coarse`] ends its
/// searches. Measured 2026-11-30 on the benchmark's 48 four-curl drawings
/// at 0.1 % noise (`benches/sketch_noise.rs`): 119 M Newton steps instead
/// of 183 M (4.2 a vertex searching to 1e-9); over its 480 drawings at
/// 0.1 % and 0.3 % about 10 % less CPU time, together with `fit_one`'s
/// dominating grid pieces (src/sketch/cover.rs) 20 %. Steps of 3e-4 and
/// 3e-3 made the same time within the runs' spread.
const COARSE_STEP: f64 = 1e-3;

/// `v` measured against the curve through `p` with derivative `d1` (the
/// point and derivative at parameter `t`, `sin t` and `cos t` kept).
#[inline(always)]
fn measured(v: DVec2, t: f64, (sin_t, cos_t): (f64, f64), p: DVec2, d1: DVec2) -> Foot {
    let normal = d1.perp().normalize_or_zero();
    Foot {
        t,
        offset: (v - p).dot(normal),
        normal,
        sin_t,
        cos_t,
    }
}

/// Searches [`Evaluator::project_all`] interleaves.
const LANES: usize = 2;

/// A placed helix with `R S e_x`, `R S e_y`, `sin c` and `cos c`
/// precomputed: `P`, `P′` and `P″` at one `t` then cost one `sin_cos(t)`
/// (the closest-point searches and least-squares rows of every fit run
/// through here, a few hundred thousand times per sketch).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::PlacedHelix;
///
/// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
///
/// // The same curve as the placed helix.
/// let e = h.evaluator();
/// for t in [-2.1, 0.0, 1.1] {
///     assert!((e.jet(t).0 - h.point(t)).length() < 1e-15);
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluator {
    origin: DVec2,
    ex: DVec2,
    ey: DVec2,
    a: f64,
    b: f64,
    sc: f64,
    cc: f64,
}

impl Evaluator {
    fn sketch_vector(&self, v: DVec2) -> DVec2 {
        self.ex * v.x + self.ey * v.y
    }

    /// `(P(t), P′(t), P″(t))`, from `H = (a(cos t − 1), bt cos c − a sin c
    /// sin t)`, `H′ = (−a sin t, b cos c − a sin c cos t)`, `H″ = (−a cos t,
    /// a sin c sin t)`.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // P′ and P″ against central differences.
    /// let (e, t, step) = (h.evaluator(), 2.0, 1e-6);
    /// let ((p0, d0, _), (p1, d1, _), (_, d, dd)) = (e.jet(t - step), e.jet(t + step), e.jet(t));
    /// assert!(((p1 - p0) / (2.0 * step) - d).length() < 1e-8);
    /// assert!(((d1 - d0) / (2.0 * step) - dd).length() < 1e-8);
    /// ```
    pub fn jet(&self, t: f64) -> (DVec2, DVec2, DVec2) {
        let (st, ct) = sin_cos(t);
        self.jet_trig(t, st, ct)
    }

    /// [`jet`](Self::jet) with `sin t`, `cos t` given.
    fn jet_trig(&self, t: f64, st: f64, ct: f64) -> (DVec2, DVec2, DVec2) {
        let (a, b, sc, cc) = (self.a, self.b, self.sc, self.cc);
        let h = DVec2::new(a * (ct - 1.0), b * t * cc - a * sc * st);
        let d1 = DVec2::new(-a * st, b * cc - a * sc * ct);
        let d2 = DVec2::new(-a * ct, a * sc * st);
        (
            self.origin + self.sketch_vector(h),
            self.sketch_vector(d1),
            self.sketch_vector(d2),
        )
    }

    /// The parameter of the point of the curve nearest `v`, by Newton's
    /// method on `g(t) = (P(t) − v)·P′(t)` from `guess` (Gauss–Newton
    /// steps where `g′ = |P′|² + (P − v)·P″` is not safely positive, steps
    /// capped at ½ rad). Local: it follows the branch of the curve near
    /// `guess`, which is what walking along a polyline needs — a projected
    /// helix can loop back near itself, so a global search could jump.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // A point 0.01 off the curve along its normal at t: found from a guess.
    /// let e = h.evaluator();
    /// let t = -1.0;
    /// let (_, normal) = e.normal_offset(DVec2::ZERO, t);
    /// let v = e.jet(t).0 + 0.01 * normal;
    /// assert!((e.closest_parameter(v, t - 0.2) - t).abs() < 1e-9);
    /// ```
    pub fn closest_parameter(&self, v: DVec2, guess: f64) -> f64 {
        self.project(v, guess).t
    }

    /// [`closest_parameter`](Self::closest_parameter) with `v` measured
    /// there ([`foot`](Self::foot)). Where the search ends on a Newton step
    /// below 1e-9, the offset and normal are those measured before it: the
    /// offset is stationary at the foot, so it is then off by
    /// O(step²·|P″|) (below 1e-17 of the curve's scale), and one more
    /// evaluation per vertex — a third of a refinement's trigonometry — is
    /// saved.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // A vertex 0.01 off the curve along its normal at t: its foot and offset.
    /// let e = h.evaluator();
    /// let t = 1.5;
    /// let (_, normal) = e.normal_offset(DVec2::ZERO, t);
    /// let foot = e.project(e.jet(t).0 + 0.01 * normal, t + 0.1);
    /// assert!((foot.t - t).abs() < 1e-9);
    /// assert!((foot.offset - 0.01).abs() < 1e-12);
    /// ```
    pub fn project(&self, v: DVec2, guess: f64) -> Foot {
        let mut t = guess;
        for _ in 0..MAX_NEWTON {
            match self.newton_step::<false>(v, t, guess) {
                Ok(next) => t = next,
                Err((foot, _)) => return foot,
            }
        }
        self.foot(v, t)
    }

    /// One iteration of [`project`](Self::project) from `t`: the next
    /// parameter, or the foot where the search ends and the parameter to
    /// keep for the vertex (the foot's, but where `COARSE` ends the search
    /// early; see [`project_all_coarse`](Self::project_all_coarse)).
    #[inline(always)]
    fn newton_step<const COARSE: bool>(
        &self,
        v: DVec2,
        t: f64,
        guess: f64,
    ) -> Result<f64, (Foot, f64)> {
        let (st, ct) = sin_cos(t);
        let (p, d1, d2) = self.jet_trig(t, st, ct);
        let d = p - v;
        let speed2 = d1.length_squared();
        if !(speed2 > 0.0) {
            return Err((self.foot(v, t), t));
        }
        let g = d.dot(d1);
        let gp = speed2 + d.dot(d2);
        let newton = gp > 0.25 * speed2;
        let step = if newton { g / gp } else { g / speed2 };
        let step = step.clamp(-0.5, 0.5);
        let next = t - step;
        if !next.is_finite() {
            return Err((self.foot(v, guess), guess));
        }
        if COARSE && newton && step.abs() <= COARSE_STEP {
            // Measured here; the parameter kept is where Halley's step
            // (the root of `g − g′h + ½g″h²`, to O(step³)) lands, from
            // `g″ = 3 P′·P″ + (P − v)·P‴` (`P‴` costs no trigonometry).
            let (a, sc) = (self.a, self.sc);
            let d3 = self.sketch_vector(DVec2::new(a * st, a * sc * ct));
            let gpp = 3.0 * d1.dot(d2) + d.dot(d3);
            let foot = measured(v, t, (st, ct), p, d1);
            return Err((foot, next - 0.5 * gpp * step * step / gp));
        }
        // A Newton step converges quadratically: after one of 1e-9 the
        // error is of order 1e-18 (and below 1e-15 the step is rounding
        // noise, which would keep the loop going).
        let tol = if newton { 1e-9 } else { 1e-15 };
        if step.abs() <= tol * (1.0 + next.abs()) {
            return Err((measured(v, next, (st, ct), p, d1), next));
        }
        Ok(next)
    }

    /// [`project`](Self::project) of every `points[k]` from `ts[k]`,
    /// which becomes the foot's parameter: the same feet, bit for bit, as
    /// one call per vertex.
    ///
    /// Why: each search is a chain of dependent steps (a `sin_cos`, then a
    /// division), so one vertex at a time leaves the core waiting on
    /// latency. Here [`LANES`] searches advance in turn, a vertex joining
    /// as another finishes, and their chains overlap.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    /// let e = h.evaluator();
    /// let points: Vec<DVec2> = (0..11).map(|k| DVec2::new(0.1 * k as f64, 0.05)).collect();
    /// let mut ts: Vec<f64> = (0..11).map(|k| 0.2 * k as f64 - 1.0).collect();
    /// let one_by_one: Vec<_> = points.iter().zip(&ts).map(|(&v, &t)| e.project(v, t)).collect();
    /// assert_eq!(e.project_all(&points, &mut ts), one_by_one);
    /// assert!(ts.iter().zip(&one_by_one).all(|(t, f)| *t == f.t));
    /// ```
    pub fn project_all(&self, points: &[DVec2], ts: &mut [f64]) -> Vec<Foot> {
        let mut feet = Vec::new();
        self.project_lanes::<false>(points, ts, &mut feet, f64::INFINITY);
        feet
    }

    /// [`project_all`](Self::project_all) to the precision a least-squares
    /// step of the covering needs, in fewer steps: each search ends
    /// at the first Newton step under [`COARSE_STEP`] (a warm start from
    /// the previous step's feet is mostly that close), and the vertex is
    /// measured where that step starts. Its offset, stationary at the
    /// foot, is then off by O(step²·|P″|); the parameter kept in `ts` is
    /// Halley's step on from there, within O(step³) of the foot, so the
    /// next search starts closer and the piece's parameters (which
    /// [`Piece::max_distance`](super::Piece::max_distance) measures at)
    /// are that close. Each foot is consistent in itself (`t`, `sin t`,
    /// `cos t`, offset and normal all at its `t`).
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    /// let e = h.evaluator();
    /// let points: Vec<DVec2> = (0..11).map(|k| DVec2::new(0.1 * k as f64, 0.05)).collect();
    /// let start: Vec<f64> = (0..11).map(|k| 0.2 * k as f64 - 1.0).collect();
    /// let (mut exact, mut coarse) = (start.clone(), start);
    /// let feet = e.project_all(&points, &mut exact);
    /// let rough = e.project_all_coarse(&points, &mut coarse);
    /// for k in 0..11 {
    ///     assert!((coarse[k] - exact[k]).abs() < 1e-8);
    ///     assert!((rough[k].offset - feet[k].offset).abs() < 1e-6);
    ///     let (sin_t, cos_t) = rough[k].t.sin_cos();
    ///     assert!((rough[k].sin_t - sin_t).abs() < 1e-15 && (rough[k].cos_t - cos_t).abs() < 1e-15);
    /// }
    /// ```
    pub fn project_all_coarse(&self, points: &[DVec2], ts: &mut [f64]) -> Vec<Foot> {
        let mut feet = Vec::new();
        self.project_lanes::<true>(points, ts, &mut feet, f64::INFINITY);
        feet
    }

    /// [`project_all_coarse`](Self::project_all_coarse) into `feet`
    /// (replacing what it held), reusing its allocation: a least-squares
    /// fit projects every vertex at each trial step. Returns the sum of
    /// the squared offsets, or `None` as soon as that passes `limit`
    /// (then `feet` and `ts` are left part done): a trial step whose
    /// distances alone already cost more than the fit it would replace is
    /// refused whatever the rest (in the covering's fits, 43 % of the
    /// vertices projected were in refused steps).
    pub(super) fn project_all_coarse_into(
        &self,
        points: &[DVec2],
        ts: &mut [f64],
        feet: &mut Vec<Foot>,
        limit: f64,
    ) -> Option<f64> {
        self.project_lanes::<true>(points, ts, feet, limit)
    }

    #[inline(always)]
    fn project_lanes<const COARSE: bool>(
        &self,
        points: &[DVec2],
        ts: &mut [f64],
        feet: &mut Vec<Foot>,
        limit: f64,
    ) -> Option<f64> {
        assert_eq!(points.len(), ts.len(), "one guess per vertex");
        let n = ts.len();
        // Every entry is written below (each vertex's search ends in one).
        feet.clear();
        feet.resize(
            n,
            Foot {
                t: 0.0,
                offset: 0.0,
                normal: DVec2::ZERO,
                sin_t: 0.0,
                cos_t: 1.0,
            },
        );
        // Per lane: the vertex searched (n when idle), its parameter and
        // the steps taken.
        let mut vertex = [n; LANES];
        let mut t = [0.0; LANES];
        let mut steps = [0usize; LANES];
        let mut queued = 0;
        for lane in 0..LANES.min(n) {
            vertex[lane] = lane;
            t[lane] = ts[lane];
            queued += 1;
        }
        let mut busy = LANES.min(n);
        let mut squares = 0.0;
        while busy > 0 {
            for lane in 0..LANES {
                let k = vertex[lane];
                if k == n {
                    continue;
                }
                let (v, guess) = (points[k], ts[k]);
                let (found, kept) = if steps[lane] == MAX_NEWTON {
                    (self.foot(v, t[lane]), t[lane])
                } else {
                    match self.newton_step::<COARSE>(v, t[lane], guess) {
                        Ok(next) => {
                            t[lane] = next;
                            steps[lane] += 1;
                            continue;
                        }
                        Err(found) => found,
                    }
                };
                squares += found.offset * found.offset;
                if squares > limit {
                    return None;
                }
                feet[k] = found;
                ts[k] = kept;
                if queued < n {
                    vertex[lane] = queued;
                    t[lane] = ts[queued];
                    steps[lane] = 0;
                    queued += 1;
                } else {
                    vertex[lane] = n;
                    busy -= 1;
                }
            }
        }
        Some(squares)
    }

    /// See [`PlacedHelix::normal_offset`].
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// let v = DVec2::new(0.5, 0.1);
    /// assert_eq!(h.evaluator().normal_offset(v, 0.3), h.normal_offset(v, 0.3));
    /// ```
    pub fn normal_offset(&self, v: DVec2, t: f64) -> (f64, DVec2) {
        let f = self.foot(v, t);
        (f.offset, f.normal)
    }

    /// [`normal_offset`](Self::normal_offset) with `sin t` and `cos t`
    /// kept, so that the least-squares row of the same vertex
    /// ([`param_jacobian_at`](Self::param_jacobian_at)) costs no more
    /// trigonometry.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// // Measured at t as given (no search).
    /// let (e, v, t) = (h.evaluator(), DVec2::new(0.5, 0.1), 0.3);
    /// let foot = e.foot(v, t);
    /// assert_eq!(foot.t, t);
    /// assert!((foot.sin_t - t.sin()).abs() < 1e-15 && (foot.cos_t - t.cos()).abs() < 1e-15);
    /// assert!((foot.offset - (v - h.point(t)).dot(foot.normal)).abs() < 1e-15);
    /// ```
    pub fn foot(&self, v: DVec2, t: f64) -> Foot {
        let (st, ct) = sin_cos(t);
        let (p, d1, _) = self.jet_trig(t, st, ct);
        measured(v, t, (st, ct), p, d1)
    }

    /// [`param_jacobian`](Self::param_jacobian) at a foot's parameter.
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// let e = h.evaluator();
    /// let foot = e.foot(DVec2::new(0.5, 0.1), 0.3);
    /// assert_eq!(e.param_jacobian_at(&foot), e.param_jacobian(0.3));
    /// ```
    pub fn param_jacobian_at(&self, foot: &Foot) -> [DVec2; PARAMS] {
        self.param_jacobian_trig(foot.t, foot.sin_t, foot.cos_t)
    }

    /// `∂P(t)/∂p` for `p = [θ, o_x, o_y, a, b, c]`; see
    /// [`PlacedHelix::param_jacobian`].
    ///
    /// ```
    /// use glam::DVec2;
    /// use strandfit::sketch::PlacedHelix;
    ///
    /// let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true);
    ///
    /// assert_eq!(h.evaluator().param_jacobian(-0.7), h.param_jacobian(-0.7));
    /// ```
    pub fn param_jacobian(&self, t: f64) -> [DVec2; PARAMS] {
        let (st, ct) = sin_cos(t);
        self.param_jacobian_trig(t, st, ct)
    }

    fn param_jacobian_trig(&self, t: f64, st: f64, ct: f64) -> [DVec2; PARAMS] {
        let (a, b, sc, cc) = (self.a, self.b, self.sc, self.cc);
        let q = self.sketch_vector(DVec2::new(a * (ct - 1.0), b * t * cc - a * sc * st));
        [
            DVec2::new(-q.y, q.x),
            DVec2::X,
            DVec2::Y,
            self.sketch_vector(DVec2::new(ct - 1.0, -sc * st)),
            self.sketch_vector(DVec2::new(0.0, t * cc)),
            self.sketch_vector(DVec2::new(0.0, -b * t * sc - a * cc * st)),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PlacedHelix {
        PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], true)
    }

    #[test]
    fn local_and_sketch_coordinates_are_inverse() {
        let h = sample();
        for k in 0..10 {
            let t = -2.0 + 0.45 * k as f64;
            let p = h.point(t);
            let l = h.to_local(p);
            assert!((l - h.helix.point(t)).length() < 1e-14);
        }
    }

    #[test]
    fn the_evaluator_matches_the_helix() {
        for reflect in [false, true] {
            let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], reflect);
            let e = h.evaluator();
            for t in [-2.1, -0.3, 0.0, 1.1, 4.0] {
                let (p, d1, d2) = e.jet(t);
                assert!((p - h.point(t)).length() < 1e-15);
                assert!((d1 - h.derivative(t)).length() < 1e-15);
                assert!((d2 - h.second_derivative(t)).length() < 1e-15);
            }
        }
    }

    #[test]
    fn param_jacobian_matches_finite_differences() {
        for reflect in [false, true] {
            let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], reflect);
            for t in [-1.3, 0.0, 0.4, 2.9] {
                let j = h.param_jacobian(t);
                for (k, jk) in j.iter().enumerate() {
                    let mut p = h.params();
                    let e = 1e-6;
                    p[k] += e;
                    let hp = PlacedHelix::from_params(&p, reflect).point(t);
                    p[k] -= 2.0 * e;
                    let hm = PlacedHelix::from_params(&p, reflect).point(t);
                    let fd = (hp - hm) / (2.0 * e);
                    assert!((fd - *jk).length() < 1e-8, "{k} at {t}: {fd} vs {jk}");
                }
            }
        }
    }

    #[test]
    fn the_lift_is_an_isometric_copy_of_the_helix() {
        // Distances between lifted points equal those on H_3D,R, mirrored
        // or not: the lift of a helix is a helix.
        let h = sample();
        for mirror in [false, true] {
            for (s, u) in [(0.1, 1.7), (-2.0, 0.5), (0.0, 3.0)] {
                let d_lift = (h.point_3d(s, mirror, 0.3) - h.point_3d(u, mirror, 0.3)).length();
                let d_true = (h.helix.point_3d(s) - h.helix.point_3d(u)).length();
                assert!((d_lift - d_true).abs() < 1e-14);
            }
            let t = h.tangent_3d(0.8, mirror).unwrap();
            let fd = (h.point_3d(0.8 + 1e-6, mirror, 0.0) - h.point_3d(0.8 - 1e-6, mirror, 0.0))
                .normalize();
            assert!((t - fd).length() < 1e-8);
        }
    }

    #[test]
    fn closest_parameter_finds_the_foot_of_the_normal() {
        // Radius of curvature of the projection ≥ 0.085 (at t = 0).
        let h = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.3, 0.3, 0.4], true);
        for k in 0..12 {
            let t = -2.5 + 0.4 * k as f64;
            let (_, n) = h.normal_offset(DVec2::ZERO, t);
            let v = h.point(t) + 0.01 * n;
            let found = h.closest_parameter(v, t + 0.1);
            assert!((found - t).abs() < 1e-9, "{t}: {found}");
            let (d, _) = h.normal_offset(v, found);
            assert!((d - 0.01).abs() < 1e-12);
        }
    }

    proptest::proptest! {
        /// The coarse searches keep parameters within 1e-8 of the exact
        /// feet (Halley's step after a Newton step under 1e-3 leaves
        /// O(step³)) and offsets within 1e-6 (stationary: O(step²)), each
        /// foot measured at its own parameter.
        #[test]
        fn coarse_projections_are_close_to_the_exact_ones(
            vertices in proptest::collection::vec(
                (-2.5f64..2.5, -0.01f64..0.01, -0.1f64..0.1), 1..16),
        ) {
            // Radius of curvature of the projection ≥ 0.085 (at t = 0).
            let e = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.3, 0.3, 0.4], true).evaluator();
            let points: Vec<DVec2> = vertices
                .iter()
                .map(|&(t, off, _)| {
                    let f = e.foot(DVec2::ZERO, t);
                    e.jet(t).0 + off * f.normal
                })
                .collect();
            let start: Vec<f64> = vertices.iter().map(|&(t, _, miss)| t + miss).collect();
            let (mut exact, mut coarse) = (start.clone(), start);
            let feet = e.project_all(&points, &mut exact);
            let rough = e.project_all_coarse(&points, &mut coarse);
            for k in 0..points.len() {
                proptest::prop_assert!((coarse[k] - exact[k]).abs() < 1e-8, "vertex {}", k);
                proptest::prop_assert!((rough[k].offset - feet[k].offset).abs() < 1e-6);
                proptest::prop_assert_eq!((rough[k].sin_t, rough[k].cos_t), sin_cos(rough[k].t));
                let measured = e.foot(points[k], rough[k].t);
                proptest::prop_assert_eq!(measured.offset, rough[k].offset);
            }
        }

        /// With a limit on the squared offsets, the coarse searches give
        /// the same feet, and their sum, when it is not passed, and stop
        /// (`None`) when it is.
        #[test]
        fn coarse_projections_stop_past_their_limit(
            vertices in proptest::collection::vec(
                (-2.5f64..2.5, -0.01f64..0.01, -0.1f64..0.1), 1..16),
            fraction in 0.0f64..1.0,
        ) {
            let e = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.3, 0.3, 0.4], true).evaluator();
            let points: Vec<DVec2> = vertices
                .iter()
                .map(|&(t, off, _)| e.jet(t).0 + off * e.foot(DVec2::ZERO, t).normal)
                .collect();
            let start: Vec<f64> = vertices.iter().map(|&(t, _, miss)| t + miss).collect();
            let mut free = start.clone();
            let want = e.project_all_coarse(&points, &mut free);
            let squares: f64 = want.iter().map(|f| f.offset * f.offset).sum();
            let bits = |f: &Foot| [f.t, f.offset, f.normal.x, f.normal.y, f.sin_t, f.cos_t].map(f64::to_bits);
            let mut feet = Vec::new();
            // Just above the sum (added in the order the searches end, so
            // to rounding): not passed, the same feet and parameters.
            let mut ts = start.clone();
            let sum = e.project_all_coarse_into(&points, &mut ts, &mut feet, squares * (1.0 + 1e-12));
            proptest::prop_assert!(sum.is_some_and(|sum| (sum - squares).abs() <= 1e-14 * squares));
            proptest::prop_assert_eq!(ts, free);
            proptest::prop_assert_eq!(feet.iter().map(bits).collect::<Vec<_>>(), want.iter().map(bits).collect::<Vec<_>>());
            // Any lower limit is passed.
            if squares > 0.0 {
                let mut ts = start.clone();
                let limit = fraction * squares * (1.0 - 1e-12);
                proptest::prop_assert_eq!(e.project_all_coarse_into(&points, &mut ts, &mut feet, limit), None);
            }
        }

        /// The interleaved searches give each vertex the foot its own
        /// search gives, bit for bit: converged, capped at `MAX_NEWTON`
        /// steps, or started from a guess that overflows.
        #[test]
        fn projecting_all_at_once_is_projecting_one_by_one(
            params in proptest::array::uniform6(-2.0f64..2.0),
            reflect in proptest::bool::ANY,
            vertices in proptest::collection::vec(
                (-3.0f64..3.0, -3.0f64..3.0, -20.0f64..20.0, 0u8..8), 0..12),
        ) {
            let e = PlacedHelix::from_params(&params, reflect).evaluator();
            let points: Vec<DVec2> = vertices.iter().map(|&(x, y, ..)| DVec2::new(x, y)).collect();
            // One guess in eight far out, where the search may not end.
            let mut ts: Vec<f64> = vertices
                .iter()
                .map(|&(.., t, far)| if far == 0 { t * 1e300 } else { t })
                .collect();
            let one_by_one: Vec<Foot> = points.iter().zip(&ts).map(|(&v, &t)| e.project(v, t)).collect();
            let all = e.project_all(&points, &mut ts);
            for (k, (a, b)) in all.iter().zip(&one_by_one).enumerate() {
                // Compared as bits: NaN feet must agree too.
                let bits = |f: &Foot| [f.t, f.offset, f.normal.x, f.normal.y, f.sin_t, f.cos_t].map(f64::to_bits);
                proptest::prop_assert_eq!(bits(a), bits(b), "vertex {}", k);
                proptest::prop_assert_eq!(ts[k].to_bits(), b.t.to_bits());
            }
            proptest::prop_assert_eq!(all.len(), points.len());
        }
    }
}
