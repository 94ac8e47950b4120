//! G1 splines of RRMF quintics through a stream of points with a globally
//! continuous rational RMF (Section 5); the construction is described on
//! `RrmfSpline`.

use glam::{DMat3, DQuat, DVec3};
use std::f64::consts::{FRAC_PI_3, PI};

use super::local::{interpolate_local, unit_displacement, LocalError, LocalSolution};
use super::quat::{bisector, Quat};
use super::quintic::PhQuintic;
use super::rmf::RrmfQuintic;

/// How far inside the admissible set a boundary turn is moved (rad): the
/// set is open, so its boundary is not admissible; 1e-8 rad keeps the
/// strict inequalities robustly true and costs under 1e-8 of `u·u_ref`
/// (1e-4 rad, before, cost Example 5.5's end tangent 1.6e-5).
pub const NUDGE: f64 = 1e-8;
/// Below this `τ` (rad) a segment is straight.
pub const STRAIGHT_TAU: f64 = 1e-9;

/// Why a motion could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MotionError {
    #[error("a motion needs at least two points, got {0}")]
    /// Fewer than two points.
    TooFew(usize),
    #[error("point {0} is not finite")]
    /// A point is not finite (its index).
    NotFinite(usize),
    #[error("points {index} and {next} coincide", next = .0 + 1, index = .0)]
    /// Two consecutive points coincide (the first's index).
    Repeated(usize),
    #[error("{points} points but {references} reference tangents")]
    /// Points and reference tangents differ in count.
    Mismatch {
        /// Number of points.
        points: usize,
        /// Number of reference tangents.
        references: usize,
    },
    #[error("the parameter c = {0} of Algorithm 1 must be in (0, 1]")]
    /// The parameter `c` of Algorithm 1 is not in `(0, 1]`.
    BadC(f64),
    #[error("reference tangent {0} is zero or not finite")]
    /// A reference tangent is zero or not finite (its index).
    BadReference(usize),
    #[error("segment {segment} (points {segment} to {}): {source}", segment + 1)]
    /// A segment's local problem has no solution.
    Segment {
        /// Index of the segment.
        segment: usize,
        #[source]
        /// Why it has none.
        source: LocalError,
    },
    #[error("segment {0}: no admissible end tangent (tau = {1:.4} rad)")]
    /// A segment has no admissible end tangent (its index and `τ`, radians).
    NoTangent(usize, f64),
}

/// A point inserted by Algorithm 1 between data points `after` and
/// `after + 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inserted {
    /// Index of the data point it follows.
    pub after: usize,
    /// The inserted point.
    pub point: DVec3,
    /// Its tangent.
    pub tangent: DVec3,
    /// `τ` of the original segment, which triggered the insertion.
    pub tau: f64,
}

/// One spline segment: the quintic with its RMF, and the data segment it
/// belongs to (two segments share it when a point was inserted).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionSegment {
    /// Index of the data segment the spline segment belongs to.
    pub data_segment: usize,
    /// The quintic with its RMF.
    pub curve: RrmfQuintic,
    /// `μ` of (4.4) (`|𝚫𝐩|^{1/2}` for a straight segment).
    pub mu: f64,
}

/// The motion: a G1 spline of RRMF quintics with a continuous RMF, knots at
/// cumulative chord lengths.
///
/// # Construction
///
/// Segment `k` starts with the frame the previous one ended with (the given
/// frame for `k = 0`), so the frame is continuous; its end tangent must
/// satisfy (4.1), i.e. be `𝐮ᵢ` turned about `𝚫𝐮` by some angle `β`. Among
/// those, (5.4) takes the one closest to a reference tangent — analytic
/// tangents, or MinAJ2 estimates for raw streams ([`minaj2_references`]) —
/// within the admissible set: `γ > 2π/5` (Proposition 4.4) or the
/// sufficient condition (4.30). When the unconstrained best turn is not
/// admissible the paper does not say what to take; we take the admissible
/// turn closest to it, on the boundary of the admissible set found by
/// bisection and nudged inside by [`NUDGE`] rad (ERRATA 001.3). When
/// `τ = ∠(𝐮ᵢ, 𝚫𝐮) ≥ 4π/5` no turn is admissible (Proposition 5.1) and
/// Algorithm 1 inserts a point first.
///
/// A segment whose chord is along the incoming tangent (`τ < 1e-9`) is the
/// straight segment with a constant pre-image: a degenerate class I quintic
/// (all `𝒜ᵢ` equal satisfy 2.17) whose RMF is the constant frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RrmfSpline {
    /// The spline segments, in order.
    pub segments: Vec<MotionSegment>,
    /// Global parameter at each segment's start, and at the end (cumulative chord lengths).
    pub knots: Vec<f64>,
    /// Points inserted by Algorithm 1.
    pub inserted: Vec<Inserted>,
}

/// MinAJ2 reference derivatives (Debski 2020, as Section 5.2 prints them)
/// for chord-length parameters `u_k = u_{k−1} + |𝐩_k − 𝐩_{k−1}|`; not
/// normalised. Needs at least three points (two: the chord).
///
/// Two points give the chord; on a line every reference runs along it:
/// ```
/// use strandfit::rrmf::minaj2_references;
/// use strandfit::DVec3;
///
/// assert_eq!(minaj2_references(&[DVec3::ZERO, DVec3::new(0.0, 3.0, 4.0)]), vec![DVec3::new(0.0, 0.6, 0.8); 2]);
/// let line: Vec<DVec3> = [0.0, 1.0, 3.0, 4.0].iter().map(|&x| DVec3::new(x, 0.0, 0.0)).collect();
/// assert!(minaj2_references(&line).iter().all(|r| r.x > 0.0 && r.cross(DVec3::X).length() < 1e-14));
/// ```
pub fn minaj2_references(points: &[DVec3]) -> Vec<DVec3> {
    let n = points.len();
    if n < 2 {
        return vec![DVec3::ZERO; n];
    }
    if n == 2 {
        let d = points[1] - points[0];
        return vec![d / d.length(); 2];
    }
    let h = |k: usize| (points[k] - points[k - 1]).length();
    let mut u = vec![DVec3::ZERO; n];
    let (h1, h2) = (h(1), h(2));
    u[0] = ((points[1] - points[0]) * (h2 + h1).powi(2) + (points[1] - points[2]) * h1 * h1)
        / (h1 * h2 * (h2 + h1));
    for k in 1..n - 1 {
        let (hk, hk1) = (h(k), h(k + 1));
        let a = -hk1 * hk1 * (2.0 * hk1 * hk1 + 6.0 * hk1 * hk + 3.0 * hk * hk);
        let b = -hk * hk1 * hk1 * (hk1 + hk).powi(2);
        let c =
            (hk1 + hk) * (2.0 * hk1.powi(3) + 4.0 * hk1 * hk1 * hk - hk1 * hk * hk - hk.powi(3));
        let d = hk.powi(3) * (2.0 * hk1 + hk);
        let e = hk * hk1 * (hk1 + hk) * (hk1 * hk1 + 3.0 * hk1 * hk + hk * hk);
        u[k] = (a * points[k - 1] + b * u[k - 1] + c * points[k] + d * points[k + 1]) / e;
    }
    let hn = h(n - 1);
    u[n - 1] = -(u[n - 2] * hn - 2.0 * points[n - 1] + 2.0 * points[n - 2]) / hn;
    u
}

/// Algorithm 1: the point `𝐩_m` and tangent `𝐮_m = 𝚫𝐮` inserted between
/// `p_i` (tangent `u_i`) and `p_f`, with parameter `c ∈ (0, 1]`.
///
/// The inserted tangent is the chord direction, and the point lies on the line
/// from `p_i` along the bisector of `u_i` and the chord:
/// ```
/// use strandfit::rrmf::{bisector, insert_point};
/// use strandfit::DVec3;
///
/// let (p_i, p_f, u_i) = (DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(-1.0, 1.0, 0.0).normalize());
/// let (p_m, u_m) = insert_point(p_i, p_f, u_i, 0.25).unwrap();
/// assert_eq!(u_m, DVec3::X);
/// assert!(p_m.normalize().cross(bisector(u_i, DVec3::X).unwrap()).length() < 1e-14);
/// ```
pub fn insert_point(p_i: DVec3, p_f: DVec3, u_i: DVec3, c: f64) -> Option<(DVec3, DVec3)> {
    let p_c = (1.0 - c) * p_i + c * p_f;
    let du = (p_f - p_i).try_normalize()?;
    let u_c = (du.cross(u_i).cross(du)).try_normalize()?;
    let b = bisector(u_i, du)?;
    // p_i + r b = p_c + s u_c: least squares on the two coplanar lines.
    let rhs = p_c - p_i;
    let (bb, bu, uu) = (b.dot(b), b.dot(u_c), u_c.dot(u_c));
    let (rb, ru) = (rhs.dot(b), rhs.dot(u_c));
    let det = bb * uu - bu * bu;
    if det.abs() < 1e-15 {
        return None;
    }
    // [bb −bu; bu −uu] (r, s) = (rb, ru)
    let s = (bb * ru - bu * rb) / (-bb * uu + bu * bu);
    Some((p_c + s * u_c, du))
}

/// The straight segment from `p_i` along frame `f` to `p_f` (`𝚫𝐩 ∥ 𝐟₁`).
fn straight(p_i: DVec3, frame: [DVec3; 3], p_f: DVec3) -> Result<RrmfQuintic, LocalError> {
    let len = (p_f - p_i).length();
    let q = DQuat::from_mat3(&DMat3::from_cols(frame[0], frame[1], frame[2])).normalize();
    let a = Quat::new(q.w, DVec3::new(q.x, q.y, q.z)) * len.sqrt();
    Ok(RrmfQuintic::new(PhQuintic::new(p_i, [a; 3]))?)
}

/// Condition for a turn `β` of the end tangent: `γ > 2π/5` or (4.30).
fn admissible(u_i: DVec3, du: DVec3, u: DVec3) -> bool {
    let gamma = u_i.dot(u).clamp(-1.0, 1.0).acos();
    if gamma > 0.4 * PI {
        return true;
    }
    let (Some(b), Some(s)) = (bisector(u_i, u), unit_displacement(u_i, u, 2.0 * FRAC_PI_3)) else {
        return false;
    };
    b.dot(du - s) > 0.0
}

/// (5.4): the end tangent for a segment from tangent `u_i` along `du`:
/// among the admissible turns `u(β)` of `u_i` about `du`, the one that
/// maximises `u(β)·reference`.
///
/// `u(β)·ref = C + A cos(β − β*)`, so where the unconstrained maximiser
/// `β*` is not admissible the maximum over the admissible set is at one
/// of the two boundary turns nearest `β*`, one on each side: both are
/// found (a scan outwards from `β*` to the first admissible turn, then
/// bisection of the boundary), moved [`NUDGE`] rad inside (the set is
/// open), and the one with the larger `u·ref` is taken. Exact ties (equal
/// scores to 1e-15) go to the positive turn about `du`.
pub(crate) fn select_tangent(u_i: DVec3, du: DVec3, reference: DVec3) -> Option<DVec3> {
    let turn = |beta: f64| DQuat::from_axis_angle(du, beta) * u_i;
    // u(β)·ref = const + cos β (u⊥·ref) + sin β ((𝚫𝐮 × u⊥)·ref).
    let perp = u_i - u_i.dot(du) * du;
    let best = (du.cross(perp).dot(reference)).atan2(perp.dot(reference));
    if admissible(u_i, du, turn(best)) {
        return Some(turn(best));
    }
    let n = 720;
    let h = 2.0 * PI / n as f64;
    let mut found: Option<(f64, f64)> = None; // (score, β)
    for side in [1.0, -1.0] {
        // The first admissible turn going from β* this way.
        let Some(k) = (1..=n / 2).find(|&k| admissible(u_i, du, turn(best + side * k as f64 * h)))
        else {
            continue;
        };
        let (mut out, mut inside) = (best + side * (k - 1) as f64 * h, best + side * k as f64 * h);
        for _ in 0..60 {
            let mid = 0.5 * (out + inside);
            if admissible(u_i, du, turn(mid)) {
                inside = mid;
            } else {
                out = mid;
            }
        }
        let nudged = inside + side * NUDGE;
        let beta = if admissible(u_i, du, turn(nudged)) {
            nudged
        } else {
            inside
        };
        let score = turn(beta).dot(reference);
        let better = match found {
            None => true,
            // The positive side comes first: it keeps an exact tie.
            Some((s, _)) => score > s + 1e-15,
        };
        if better {
            found = Some((score, beta));
        }
    }
    found.map(|(_, beta)| turn(beta))
}

impl RrmfSpline {
    /// Build the motion through `points` from the initial `frame`
    /// (`(𝐮₀, 𝐯₀, 𝐰₀)`, orthonormal and right-handed), with reference
    /// tangents `references` (one per point, any length) and Algorithm 1's
    /// parameter `c`.
    ///
    /// Example 5.5 of the paper: the stream `(0, 0, 0), (−5, 5, 2), (2, 2, 0)`
    /// turns back by `τ = 0.8599π` on its first segment, so Algorithm 1 inserts a
    /// point, printed as `(−2.29636, 8.60499, 2.18027)` for `c = 1/8`:
    /// ```
    /// use strandfit::rrmf::{default_frame, minaj2_references, RrmfSpline};
    /// use strandfit::DVec3;
    ///
    /// let p = [DVec3::ZERO, DVec3::new(-5.0, 5.0, 2.0), DVec3::new(2.0, 2.0, 0.0)];
    /// let r = minaj2_references(&p);
    /// let s = RrmfSpline::build(&p, &r, default_frame(r[0]).unwrap(), 0.125).unwrap();
    /// assert_eq!(s.inserted.len(), 1);
    /// assert!((s.inserted[0].point - DVec3::new(-2.29636, 8.60499, 2.18027)).length() < 1e-5);
    /// assert!((s.inserted[0].tau / std::f64::consts::PI - 0.8599).abs() < 1e-4);
    /// ```
    pub fn build(
        points: &[DVec3],
        references: &[DVec3],
        frame: [DVec3; 3],
        c: f64,
    ) -> Result<Self, MotionError> {
        if points.len() < 2 {
            return Err(MotionError::TooFew(points.len()));
        }
        if references.len() != points.len() {
            return Err(MotionError::Mismatch {
                points: points.len(),
                references: references.len(),
            });
        }
        if !(c > 0.0 && c <= 1.0) {
            return Err(MotionError::BadC(c));
        }
        validate_points(points)?;
        let mut frame = frame;
        let mut segments = Vec::with_capacity(points.len() - 1);
        let mut inserted = Vec::new();
        let mut knots = vec![0.0];
        let seg_err = |segment: usize| move |source| MotionError::Segment { segment, source };
        for k in 0..points.len() - 1 {
            let reference = references[k + 1]
                .try_normalize()
                .filter(|r| r.is_finite())
                .ok_or(MotionError::BadReference(k + 1))?;
            let mut p_i = points[k];
            let p_f = points[k + 1];
            let du = (p_f - p_i).normalize();
            let tau = frame[0].dot(du).clamp(-1.0, 1.0).acos();
            if tau >= 0.8 * PI {
                let (p_m, u_m) =
                    insert_point(p_i, p_f, frame[0], c).ok_or(MotionError::NoTangent(k, tau))?;
                let sol = interpolate_local(p_i, frame, p_m, u_m).map_err(seg_err(k))?;
                frame = sol.curve.frame(1.0);
                knots.push(knots.last().unwrap_or(&0.0) + (p_m - p_i).length());
                segments.push(MotionSegment {
                    data_segment: k,
                    curve: sol.curve,
                    mu: sol.mu,
                });
                inserted.push(Inserted {
                    after: k,
                    point: p_m,
                    tangent: u_m,
                    tau,
                });
                p_i = p_m;
            }
            let du = (p_f - p_i).normalize();
            let tau = frame[0].dot(du).clamp(-1.0, 1.0).acos();
            let (curve, mu) = if tau < STRAIGHT_TAU {
                (
                    straight(p_i, frame, p_f).map_err(seg_err(k))?,
                    (p_f - p_i).length().sqrt(),
                )
            } else {
                let u_f = select_tangent(frame[0], du, reference)
                    .ok_or(MotionError::NoTangent(k, tau))?;
                let sol: LocalSolution =
                    interpolate_local(p_i, frame, p_f, u_f).map_err(seg_err(k))?;
                (sol.curve, sol.mu)
            };
            frame = curve.frame(1.0);
            knots.push(knots.last().unwrap_or(&0.0) + (p_f - p_i).length());
            segments.push(MotionSegment {
                data_segment: k,
                curve,
                mu,
            });
        }
        Ok(RrmfSpline {
            segments,
            knots,
            inserted,
        })
    }

    /// Segment index and local parameter of the global (chord-length)
    /// parameter `u`, clamped to `[0, u_N]`.
    ///
    /// Knots are cumulative chord lengths:
    /// ```
    /// use strandfit::rrmf::{default_frame, minaj2_references, RrmfSpline};
    /// use strandfit::DVec3;
    ///
    /// let p: Vec<DVec3> = (0..4).map(|k| { let a = 0.6 * k as f64; DVec3::new(a.cos(), a.sin(), 0.3 * a) }).collect();
    /// let r = minaj2_references(&p);
    /// let s = RrmfSpline::build(&p, &r, default_frame(r[0]).unwrap(), 0.125).unwrap();
    /// assert!((s.knots[1] - p[0].distance(p[1])).abs() < 1e-15);
    /// let (i, t) = s.locate(s.knots[1] + 0.25 * (s.knots[2] - s.knots[1]));
    /// assert_eq!(i, 1);
    /// assert!((t - 0.25).abs() < 1e-14);
    /// ```
    pub fn locate(&self, u: f64) -> (usize, f64) {
        let n = self.segments.len();
        let last = self.knots[n];
        let u = u.clamp(0.0, last);
        let i = self.knots[1..n].partition_point(|&k| k <= u);
        let (a, b) = (self.knots[i], self.knots[i + 1]);
        (i, ((u - a) / (b - a)).clamp(0.0, 1.0))
    }

    /// The point at global parameter `u` (clamped to `[0, u_N]`).
    ///
    /// The motion passes through the data points at the knots:
    /// ```
    /// use strandfit::rrmf::{default_frame, minaj2_references, RrmfSpline};
    /// use strandfit::DVec3;
    ///
    /// let p: Vec<DVec3> = (0..4).map(|k| { let a = 0.6 * k as f64; DVec3::new(a.cos(), a.sin(), 0.3 * a) }).collect();
    /// let r = minaj2_references(&p);
    /// let s = RrmfSpline::build(&p, &r, default_frame(r[0]).unwrap(), 0.125).unwrap();
    /// assert!(s.inserted.is_empty());
    /// assert!((0..4).all(|k| (s.position(s.knots[k]) - p[k]).length() < 1e-12));
    /// ```
    pub fn position(&self, u: f64) -> DVec3 {
        let (i, t) = self.locate(u);
        self.segments[i].curve.curve.position(t)
    }

    /// The rotation-minimising frame at `u` (clamped).
    ///
    /// It starts as the given frame, is continuous at the knots, and its first
    /// vector is the unit tangent:
    /// ```
    /// use strandfit::rrmf::{default_frame, minaj2_references, RrmfSpline};
    /// use strandfit::DVec3;
    ///
    /// let p: Vec<DVec3> = (0..4).map(|k| { let a = 0.6 * k as f64; DVec3::new(a.cos(), a.sin(), 0.3 * a) }).collect();
    /// let r = minaj2_references(&p);
    /// let f0 = default_frame(r[0]).unwrap();
    /// let s = RrmfSpline::build(&p, &r, f0, 0.125).unwrap();
    /// assert!((0..3).all(|k| (s.frame(0.0)[k] - f0[k]).length() < 1e-12));
    /// let (u, h) = (s.knots[1], 1e-9);
    /// assert!((0..3).all(|k| (s.frame(u - h)[k] - s.frame(u + h)[k]).length() < 1e-6));
    /// let fd = (s.position(0.5 + 1e-6) - s.position(0.5 - 1e-6)).normalize();
    /// assert!((s.frame(0.5)[0] - fd).length() < 1e-8);
    /// ```
    pub fn frame(&self, u: f64) -> [DVec3; 3] {
        let (i, t) = self.locate(u);
        self.segments[i].curve.frame(t)
    }

    /// `m ≥ 2` samples `(position, 𝐟₁, 𝐟₂, 𝐟₃)` equally spaced in the global
    /// parameter, ends included.
    ///
    /// Ends included, frames orthonormal:
    /// ```
    /// use strandfit::rrmf::{default_frame, minaj2_references, RrmfSpline};
    /// use strandfit::DVec3;
    ///
    /// let p: Vec<DVec3> = (0..4).map(|k| { let a = 0.6 * k as f64; DVec3::new(a.cos(), a.sin(), 0.3 * a) }).collect();
    /// let r = minaj2_references(&p);
    /// let s = RrmfSpline::build(&p, &r, default_frame(r[0]).unwrap(), 0.125).unwrap();
    /// let out = s.sample(9);
    /// assert!((out[0].0 - p[0]).length() < 1e-12 && (out[8].0 - p[3]).length() < 1e-12);
    /// assert!(out.iter().all(|(_, [f1, f2, f3])| f1.dot(*f2).abs() < 1e-12 && (f1.cross(*f2) - *f3).length() < 1e-12));
    /// ```
    pub fn sample(&self, m: usize) -> Vec<(DVec3, [DVec3; 3])> {
        let m = m.max(2);
        let last = *self.knots.last().unwrap_or(&0.0);
        (0..m)
            .map(|k| {
                let u = last * k as f64 / (m - 1) as f64;
                (self.position(u), self.frame(u))
            })
            .collect()
    }
}

/// The checks on a point stream every motion starts with: at least two
/// points, all finite, no point repeated next to itself.
///
/// ```
/// use strandfit::rrmf::{validate_points, MotionError};
/// use strandfit::DVec3;
///
/// assert_eq!(validate_points(&[DVec3::ZERO, DVec3::X]), Ok(()));
/// assert_eq!(validate_points(&[DVec3::ZERO, DVec3::X, DVec3::X]), Err(MotionError::Repeated(1)));
/// assert_eq!(validate_points(&[DVec3::ZERO]), Err(MotionError::TooFew(1)));
/// ```
pub fn validate_points(points: &[DVec3]) -> Result<(), MotionError> {
    if points.len() < 2 {
        return Err(MotionError::TooFew(points.len()));
    }
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(MotionError::NotFinite(i));
    }
    if let Some(i) = points.windows(2).position(|w| w[0] == w[1]) {
        return Err(MotionError::Repeated(i));
    }
    Ok(())
}

/// The default initial frame: `𝐮₀` along `first_reference`, `𝐯₀` any unit
/// normal, `𝐰₀ = 𝐮₀ × 𝐯₀`.
///
/// ```
/// use strandfit::rrmf::default_frame;
/// use strandfit::DVec3;
///
/// let [u, v, w] = default_frame(DVec3::new(0.0, 3.0, 4.0)).unwrap();
/// assert!((u - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
/// assert!(u.dot(v).abs() < 1e-15 && (v.length() - 1.0).abs() < 1e-15 && (u.cross(v) - w).length() < 1e-15);
/// assert_eq!(default_frame(DVec3::ZERO), None);
/// ```
pub fn default_frame(first_reference: DVec3) -> Option<[DVec3; 3]> {
    let u = first_reference.try_normalize()?;
    let v = u.any_orthonormal_vector();
    Some([u, v, u.cross(v)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_spline(s: &RrmfSpline, points: &[DVec3], frame: [DVec3; 3]) {
        // Interpolates the data (inserted points in between), G1, frame C0.
        let mut data = 0;
        let first = s.segments[0].curve.frame(0.0);
        for k in 0..3 {
            assert!((first[k] - frame[k]).length() < 1e-12);
        }
        for (i, seg) in s.segments.iter().enumerate() {
            let c = &seg.curve;
            let size = c
                .curve
                .control_points()
                .iter()
                .map(|p| (*p - c.curve.start).length())
                .fold(0.0, f64::max);
            if i == 0 || s.segments[i - 1].data_segment != seg.data_segment {
                assert!((c.curve.position(0.0) - points[seg.data_segment]).length() < 1e-12 * size);
                data = seg.data_segment;
            }
            if i + 1 == s.segments.len() || s.segments[i + 1].data_segment != seg.data_segment {
                assert!(
                    (c.curve.position(1.0) - points[data + 1]).length() < 1e-12 * size,
                    "segment {i}"
                );
            }
            if i + 1 < s.segments.len() {
                let next = &s.segments[i + 1].curve;
                assert!((c.curve.position(1.0) - next.curve.position(0.0)).length() < 1e-12 * size);
                let (f, g) = (c.frame(1.0), next.frame(0.0));
                for k in 0..3 {
                    assert!((f[k] - g[k]).length() < 1e-12, "frame jump at segment {i}");
                }
            }
            for j in 0..=10 {
                assert!(c.rmf_residual(j as f64 / 10.0) < 1e-12);
            }
            assert!(c.curve.class_one_residual() < 1e-12);
        }
    }

    fn analytic(c: impl Fn(f64) -> DVec3, u_max: f64, n: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        (0..=n)
            .map(|k| {
                let u = u_max * k as f64 / n as f64;
                let d = (c(u + 1e-6) - c(u - 1e-6)) / 2e-6;
                (c(u), d.normalize())
            })
            .unzip()
    }

    #[test]
    fn minaj2_on_lines() {
        // A straight stream with uneven spacing: every reference points
        // along the line. The first, as printed (with p₁ − p₂ where the
        // one-sided quadratic derivative has p₀ − p₂), has the wrong length
        // (ERRATA 001.2: as printed is what reproduces Example 5.5), and the
        // recursion carries that into the others' lengths; the spline uses
        // directions only.
        let dir = DVec3::new(1.0, 2.0, -2.0) / 3.0;
        let pts: Vec<DVec3> = [0.0, 0.7, 1.1, 2.9, 3.0, 4.5]
            .iter()
            .map(|&s| s * dir)
            .collect();
        for v in minaj2_references(&pts) {
            assert!((v.normalize() - dir).length() < 1e-14, "{v}");
        }
        // Started from the exact derivative, the interior formula is exact
        // on lines: A + C + D = 0 and −A h_k + B + D h_{k+1} = E.
        for (hk, hk1) in [(1.0f64, 1.0f64), (0.3, 2.0), (5.0, 0.1)] {
            let a = -hk1 * hk1 * (2.0 * hk1 * hk1 + 6.0 * hk1 * hk + 3.0 * hk * hk);
            let b = -hk * hk1 * hk1 * (hk1 + hk) * (hk1 + hk);
            let c = (hk1 + hk)
                * (2.0 * hk1 * hk1 * hk1 + 4.0 * hk1 * hk1 * hk - hk1 * hk * hk - hk * hk * hk);
            let d = hk * hk * hk * (2.0 * hk1 + hk);
            let e = hk * hk1 * (hk1 + hk) * (hk1 * hk1 + 3.0 * hk1 * hk + hk * hk);
            assert!((a + c + d).abs() < 1e-12 * e.abs());
            assert!((-a * hk + b + d * hk1 - e).abs() < 1e-12 * e.abs());
        }
    }

    #[test]
    fn example_5_2_helix() {
        let uh = 2.0 * 29f64.sqrt();
        let helix =
            |u: f64| DVec3::new(10.0 * (u / uh).sin(), 10.0 * (u / uh).cos(), -4.0 * u / uh);
        for n in [5, 10, 15] {
            let (p, t) = analytic(helix, 3.6 * PI * uh, n);
            let frame = default_frame(t[0]).unwrap();
            let s = RrmfSpline::build(&p, &t, frame, 0.125).unwrap();
            check_spline(&s, &p, frame);
        }
    }

    #[test]
    fn examples_5_3_and_5_4() {
        let torus = |u: f64| {
            DVec3::new(
                (20.0 + 10.0 * (3.0 * u).cos()) * (u / 2.0).cos(),
                (20.0 + 10.0 * (3.0 * u).cos()) * (u / 2.0).sin(),
                10.0 * (3.0 * u).sin(),
            )
        };
        let spiral = |u: f64| {
            DVec3::new(
                (u + 3.0).ln() * (PI * u).sin(),
                (u + 3.0).ln() * (PI * u).cos(),
                (u * u + 4.0 * u + 5.0).sqrt(),
            )
        };
        for (c, umax) in [(&torus as &dyn Fn(f64) -> DVec3, 2.0 * PI), (&spiral, 6.0)] {
            for n in [7, 15] {
                let (p, t) = analytic(c, umax, n);
                let frame = default_frame(t[0]).unwrap();
                let s = RrmfSpline::build(&p, &t, frame, 0.125).unwrap();
                check_spline(&s, &p, frame);
            }
        }
    }

    #[test]
    fn examples_5_6_and_5_7_streams() {
        let streams = [
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(-5.0, 5.0, 2.0),
                DVec3::new(0.0, 10.0, -2.0),
                DVec3::new(8.0, 12.0, 5.0),
                DVec3::new(15.0, 2.0, 3.0),
                DVec3::new(2.0, 0.0, 7.0),
            ],
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(5.0, 5.0, 10.0),
                DVec3::new(8.0, 11.0, 9.0),
                DVec3::new(5.0, 14.0, 3.0),
                DVec3::new(2.0, 20.0, 7.0),
            ],
        ];
        for p in streams {
            let r = minaj2_references(&p);
            let frame = default_frame(r[0]).unwrap();
            let s = RrmfSpline::build(&p, &r, frame, 0.125).unwrap();
            check_spline(&s, &p, frame);
        }
    }

    /// Example 5.5's stream, its MinAJ2 references and initial frame.
    fn example_5_5() -> ([DVec3; 3], Vec<DVec3>, [DVec3; 3]) {
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(-5.0, 5.0, 2.0),
            DVec3::new(2.0, 2.0, 0.0),
        ];
        let r = minaj2_references(&p);
        let frame = default_frame(r[0]).unwrap();
        (p, r, frame)
    }

    #[test]
    fn example_5_5_inserts_the_printed_points() {
        let (p, r, frame) = example_5_5();
        for (c, want) in [
            (0.125, DVec3::new(-2.29636, 8.60499, 2.18027)),
            (0.25, DVec3::new(0.40729, 12.20998, 2.36054)),
        ] {
            let s = RrmfSpline::build(&p, &r, frame, c).unwrap();
            check_spline(&s, &p, frame);
            assert_eq!(s.inserted.len(), 1);
            let ins = s.inserted[0];
            assert_eq!(ins.after, 1);
            eprintln!(
                "c = {c}: tau = {:.6} pi, p_m = {:?}, u_m = {:?}",
                ins.tau / PI,
                ins.point,
                ins.tangent
            );
            assert!((ins.tau / PI - 0.8599).abs() < 5e-5, "{}", ins.tau / PI);
            assert!(
                (ins.point - want).length() < 1e-5 * 3f64.sqrt(),
                "{:?}",
                ins.point
            );
            let um = DVec3::new(0.88900, -0.38100, -0.25400);
            assert!((ins.tangent - um).abs().max_element() < 5e-6);
        }
    }

    /// The admissible turn with the largest `u·ref`, by a fine scan (an
    /// independent check of (5.4)).
    fn scanned_best(u_i: DVec3, du: DVec3, reference: DVec3) -> (f64, DVec3) {
        let mut best = (f64::NEG_INFINITY, DVec3::ZERO);
        let n = 400_000;
        for k in 0..n {
            let beta = -PI + 2.0 * PI * (k as f64 + 0.5) / n as f64;
            let u = DQuat::from_axis_angle(du, beta) * u_i;
            if admissible(u_i, du, u) && u.dot(reference) > best.0 {
                best = (u.dot(reference), u);
            }
        }
        best
    }

    #[test]
    fn example_5_5_ends_on_the_admissible_tangent_nearest_the_reference() {
        // The last segment (p_m to p_2) of Example 5.5: its end tangent is
        // on the boundary of the admissible set, whose two ends score
        // 0.94118 and 0.94116 against the reference: (5.4) takes the first.
        let (p, r, frame) = example_5_5();
        let reference = r[2].normalize();
        // c = 1/8: the admissible arc's ends score 0.9411777 and 0.9411615;
        // c = 1/4: the choice scores 0.485084. In both the unconstrained
        // maximiser is not admissible: the rule's constraint is active.
        for (c, at_least) in [(0.125, 0.94117), (0.25, 0.48508)] {
            let s = RrmfSpline::build(&p, &r, frame, c).unwrap();
            let last = s.segments.last().unwrap();
            let u_i = s.segments[s.segments.len() - 2].curve.frame(1.0)[0];
            let du = (p[2] - last.curve.curve.start).normalize();
            let u_end = last.curve.curve.tangent(1.0);
            let (score, u_best) = scanned_best(u_i, du, reference);
            let perp = u_i - u_i.dot(du) * du;
            let free = (du.cross(perp).dot(reference)).atan2(perp.dot(reference));
            assert!(
                !admissible(u_i, du, DQuat::from_axis_angle(du, free) * u_i),
                "c = {c}: the constraint is not active"
            );
            // At least the best scanned admissible turn (the supremum is on
            // the boundary; the choice is NUDGE inside it).
            assert!(
                (u_end - u_best).length() < 1e-4,
                "c = {c}: {u_end} vs {u_best}"
            );
            assert!(u_end.dot(reference) >= score - 1e-9, "c = {c}");
            assert!(
                u_end.dot(reference) > at_least,
                "c = {c}: {}",
                u_end.dot(reference)
            );
        }
    }

    #[test]
    fn the_selected_tangent_is_the_admissible_maximiser_on_random_streams() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(55);
        let unit = |rng: &mut rand_chacha::ChaCha8Rng| loop {
            let v = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            if (0.1..1.0).contains(&v.length()) {
                return v.normalize();
            }
        };
        let mut constrained = 0;
        for _ in 0..300 {
            let (u_i, du, reference) = (unit(&mut rng), unit(&mut rng), unit(&mut rng));
            if u_i.dot(du).acos() >= 0.8 * PI || u_i.dot(du) > 1.0 - 1e-6 {
                continue;
            }
            let Some(u) = select_tangent(u_i, du, reference) else {
                continue;
            };
            assert!(admissible(u_i, du, u));
            let (score, _) = scanned_best(u_i, du, reference);
            let perp = u_i - u_i.dot(du) * du;
            let best = (du.cross(perp).dot(reference)).atan2(perp.dot(reference));
            if !admissible(u_i, du, DQuat::from_axis_angle(du, best) * u_i) {
                constrained += 1;
            }
            // At least the best of the scan: the choice is NUDGE (1e-8 rad)
            // inside the supremum, which costs at most 1e-8 of the score;
            // the other end of an admissible arc scores lower by far more
            // (1.6e-5 in Example 5.5).
            assert!(
                u.dot(reference) > score - 1e-7,
                "{} < {score}",
                u.dot(reference)
            );
        }
        assert!(constrained > 20, "only {constrained} constrained cases");
    }

    #[test]
    fn an_exact_tie_goes_to_the_positive_turn() {
        // The reference is `u_i` itself, in the plane of `u_i` and `Δu`:
        // the unconstrained maximiser (no turn) is not admissible, and the
        // admissible set is symmetric about it (mirrored in that plane), so
        // its two nearest ends score the same: the positive turn about `Δu`
        // is taken. With `Δu` reversed that is the other physical side, and
        // a reference tipped a little towards the negative side makes that
        // side win: the choice is the tie rule's, not a side that happens
        // to score higher.
        let cases = [0.6f64, 1.0, 1.5, 2.2]
            .into_iter()
            .flat_map(|phi| [(DVec3::Z, phi), (-DVec3::Z, PI - phi)]);
        for (du, phi) in cases {
            let u_i = DVec3::new(phi.sin(), 0.0, phi.cos());
            assert!(!admissible(u_i, du, u_i));
            let u = select_tangent(u_i, du, u_i).expect("an admissible turn");
            assert!(admissible(u_i, du, u));
            assert!(u_i.cross(u).dot(du) > 0.0, "φ = {phi}, Δu = {du}: {u}");
            // The negative side, favoured by a tipped reference.
            let side = du.cross(u_i).normalize();
            let tipped = (u_i - 1e-6 * side).normalize();
            let v = select_tangent(u_i, du, tipped).expect("an admissible turn");
            assert!(u_i.cross(v).dot(du) < 0.0, "φ = {phi}, Δu = {du}: {v}");
            // The two ends mirror each other in the plane of u_i and Δu.
            assert!((v - DVec3::new(u.x, -u.y, u.z)).length() < 1e-6, "{u} {v}");
        }
    }

    #[test]
    fn rotating_and_translating_the_stream_moves_the_motion_rigidly() {
        let p = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(-5.0, 5.0, 2.0),
            DVec3::new(0.0, 10.0, -2.0),
            DVec3::new(8.0, 12.0, 5.0),
            DVec3::new(15.0, 2.0, 3.0),
        ];
        let r = minaj2_references(&p);
        let f = default_frame(r[0]).unwrap();
        let a = RrmfSpline::build(&p, &r, f, 0.125).unwrap();
        let rot = DQuat::from_axis_angle(DVec3::new(0.3, -1.0, 0.5).normalize(), 2.1);
        let shift = DVec3::new(100.0, -7.0, 3.0);
        let q: Vec<DVec3> = p.iter().map(|v| rot * *v + shift).collect();
        let rq = minaj2_references(&q);
        let b = RrmfSpline::build(&q, &rq, f.map(|v| rot * v), 0.125).unwrap();
        assert_eq!(a.segments.len(), b.segments.len());
        for ((pa, fa), (pb, fb)) in a.sample(101).into_iter().zip(b.sample(101)) {
            assert!((rot * pa + shift - pb).length() < 1e-9, "{pa} {pb}");
            for k in 0..3 {
                assert!((rot * fa[k] - fb[k]).length() < 1e-9);
            }
        }
    }

    #[test]
    fn bad_streams_name_the_problem() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::X, DVec3::Y];
        let r = vec![DVec3::X; 4];
        let f = default_frame(DVec3::X).unwrap();
        assert_eq!(
            RrmfSpline::build(&p, &r, f, 0.125),
            Err(MotionError::Repeated(1))
        );
        assert_eq!(
            RrmfSpline::build(&p[..1], &r[..1], f, 0.125),
            Err(MotionError::TooFew(1))
        );
        assert_eq!(
            RrmfSpline::build(&p, &r[..2], f, 0.125),
            Err(MotionError::Mismatch {
                points: 4,
                references: 2
            })
        );
        assert_eq!(
            RrmfSpline::build(&p[2..], &r[2..], f, 0.0),
            Err(MotionError::BadC(0.0))
        );
        let q = [DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)];
        assert_eq!(
            RrmfSpline::build(&q, &r[..2], f, 0.5),
            Err(MotionError::NotFinite(1))
        );
        // A straight stream is a chain of straight segments.
        let line = [DVec3::ZERO, DVec3::X, 3.0 * DVec3::X];
        let s = RrmfSpline::build(&line, &[DVec3::X; 3], f, 0.125).unwrap();
        check_spline(&s, &line, f);
        assert!((s.position(2.0) - 2.0 * DVec3::X).length() < 1e-12);
    }
}
