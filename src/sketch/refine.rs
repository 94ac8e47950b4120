//! Least-squares refinement of placed helices, and the fine fitting of
//! Section 7 (the objective and the method are described on `refine`).

use faer::linalg::solvers::Solve;
use faer::Mat;
use glam::{DVec2, DVec3};

use super::placed::{Foot, PlacedHelix, PARAMS};

/// One helix of the covering with the sketch vertices it fits.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::{Piece, PlacedHelix};
///
/// // Twenty vertices of a placed helix, and the piece that fits them.
/// let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// let piece = Piece { helix, first: 0, last: 19, ts, mirror: false };
/// assert!(piece.max_distance(&points) < 1e-15);
/// assert_eq!(piece.orientation(), 1.0);
/// ```
#[derive(Debug, PartialEq)]
pub struct Piece {
    /// The helix, placed in the sketch.
    pub helix: PlacedHelix,
    /// First and last vertex (inclusive); a junction vertex is the `last`
    /// of one piece and the `first` of the next.
    pub first: usize,
    /// See `first`.
    pub last: usize,
    /// Closest-point parameters of vertices `first..=last`, monotone.
    pub ts: Vec<f64>,
    /// Lift with the mirror helix `H_3D,S` (Section 7).
    pub mirror: bool,
}

impl Clone for Piece {
    fn clone(&self) -> Self {
        Piece {
            helix: self.helix,
            first: self.first,
            last: self.last,
            ts: self.ts.clone(),
            mirror: self.mirror,
        }
    }

    /// Reuses the parameters' allocation (a least-squares fit copies its
    /// pieces into the trial at every step).
    fn clone_from(&mut self, other: &Self) {
        self.helix = other.helix;
        self.first = other.first;
        self.last = other.last;
        self.ts.clone_from(&other.ts);
        self.mirror = other.mirror;
    }
}

impl Piece {
    /// Re-project every vertex, each from its previous parameter.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    ///
    /// // From parameters 0.05 off, each vertex goes back to its own.
    /// piece.ts.iter_mut().for_each(|t| *t += 0.05);
    /// piece.reproject(&points);
    /// assert!(piece.ts.iter().zip(&ts).all(|(a, b)| (a - b).abs() < 1e-9));
    /// ```
    pub fn reproject(&mut self, points: &[DVec2]) {
        self.reproject_feet(points);
    }

    /// [`reproject`](Self::reproject), returning each vertex measured at
    /// its new parameter.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    /// // The vertices moved 0.01 off the curve, along its normals.
    /// let off: Vec<DVec2> = piece.feet(&points).iter().zip(&points).map(|(f, p)| *p + 0.01 * f.normal).collect();
    /// piece.ts.iter_mut().for_each(|t| *t -= 0.05);
    /// let feet = piece.reproject_feet(&off);
    /// assert!(feet.iter().all(|f| (f.offset - 0.01).abs() < 1e-12));
    /// assert!(piece.ts.iter().zip(&ts).all(|(a, b)| (a - b).abs() < 1e-9));
    /// ```
    pub fn reproject_feet(&mut self, points: &[DVec2]) -> Vec<Foot> {
        let vertices = &points[self.first..self.first + self.ts.len()];
        self.helix.evaluator().project_all(vertices, &mut self.ts)
    }

    /// [`reproject_feet`](Self::reproject_feet) to a least-squares step's
    /// precision ([`Evaluator::project_all_coarse`](super::Evaluator::project_all_coarse)),
    /// returning the sum of the squared offsets, or `None` (and the feet
    /// part done) once that passes `limit`.
    fn reproject_feet_coarse(
        &mut self,
        points: &[DVec2],
        feet: &mut Vec<Foot>,
        limit: f64,
    ) -> Option<f64> {
        let vertices = &points[self.first..self.first + self.ts.len()];
        self.helix
            .evaluator()
            .project_all_coarse_into(vertices, &mut self.ts, feet, limit)
    }

    /// Every vertex measured at its parameter.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    ///
    /// // Measured where the parameters are, without a search.
    /// let feet = piece.feet(&points);
    /// assert_eq!(feet.len(), 20);
    /// assert!(feet.iter().zip(&ts).all(|(f, &t)| f.t == t && f.offset.abs() < 1e-15));
    /// ```
    pub fn feet(&self, points: &[DVec2]) -> Vec<Foot> {
        let e = self.helix.evaluator();
        self.ts
            .iter()
            .enumerate()
            .map(|(k, &t)| e.foot(points[self.first + k], t))
            .collect()
    }

    /// The largest vertex distance from the curve.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    /// // The vertices moved 0.01 off the curve, along its normals.
    /// let off: Vec<DVec2> = piece.feet(&points).iter().zip(&points).map(|(f, p)| *p + 0.01 * f.normal).collect();
    /// assert!((piece.max_distance(&off) - 0.01).abs() < 1e-12);
    /// ```
    pub fn max_distance(&self, points: &[DVec2]) -> f64 {
        let e = self.helix.evaluator();
        self.ts
            .iter()
            .enumerate()
            .map(|(k, &t)| (points[self.first + k] - e.jet(t).0).length())
            .fold(0.0, f64::max)
    }

    /// The root mean square of the vertices' distances from the curve (at
    /// their parameters). Where [`max_distance`](Self::max_distance) is set
    /// by the piece's worst vertex (on a grown piece, the last one its walk
    /// took, by construction near `E_max`), this weighs all of them: a helix
    /// that follows the drawing leaves the noise, one that merely stays
    /// within `E_max` leaves a systematic error over long runs.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    /// // Every other vertex moved 0.03 off the curve: √(0.03²/2) in all.
    /// let off: Vec<DVec2> = piece.feet(&points).iter().zip(&points).enumerate()
    ///     .map(|(k, (f, p))| if k % 2 == 0 { *p + 0.03 * f.normal } else { *p })
    ///     .collect();
    /// assert!((piece.rms_distance(&off) - 0.03 / 2f64.sqrt()).abs() < 1e-12);
    /// assert!((piece.max_distance(&off) - 0.03).abs() < 1e-12);
    /// ```
    pub fn rms_distance(&self, points: &[DVec2]) -> f64 {
        self.inner_rms_distance(points, 0)
    }

    /// [`rms_distance`](Self::rms_distance) over the vertices but `skip` at
    /// each end (over all of them where that would leave fewer than
    /// `skip`): a denoised drawing's corners are rounded over a few
    /// vertices, so a piece that ends at one may leave its end vertices off
    /// however well the helix follows the rest.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly; the last moved off.
    /// let mut off = points.clone();
    /// off[19] += DVec2::new(0.0, 0.5);
    /// assert!(piece.rms_distance(&off) > 0.1);
    /// assert!(piece.inner_rms_distance(&off, 2) < 1e-12);
    /// // Too short to skip so many: all of them.
    /// assert_eq!(piece.inner_rms_distance(&off, 8), piece.rms_distance(&off));
    /// ```
    pub fn inner_rms_distance(&self, points: &[DVec2], skip: usize) -> f64 {
        let m = self.ts.len();
        let skip = if m >= 3 * skip { skip } else { 0 };
        let e = self.helix.evaluator();
        let sum: f64 = self.ts[skip..m - skip]
            .iter()
            .enumerate()
            .map(|(k, &t)| (points[self.first + skip + k] - e.jet(t).0).length_squared())
            .sum();
        (sum / (m - 2 * skip).max(1) as f64).sqrt()
    }

    /// How steeply the lift leaves the sketch plane: the range of `z` over
    /// the piece's vertices' parameters, over the length of the projected
    /// curve between them (0 for fewer than two vertices). Beyond the
    /// paper: a drawing is a view of its curve, and a piece whose depth
    /// runs to many times its drawn length (a curve seen almost end-on)
    /// fits noise, not a stroke (see [`cover`](super::cover())).
    ///
    /// ```
    /// use strandfit::sketch::{Piece, PlacedHelix};
    ///
    /// // A helix seen along its axis (tilt π/2): a circle of radius 1 drawn,
    /// // depth 0.5 per radian, so a slope of 0.5.
    /// let helix = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 1.0, 0.5, std::f64::consts::FRAC_PI_2], false);
    /// let ts: Vec<f64> = (0..20).map(|k| 0.05 * k as f64).collect();
    /// let mut piece = Piece { helix, first: 0, last: 19, ts, mirror: false };
    /// assert!((piece.depth_slope() - 0.5).abs() < 1e-3);
    /// piece.ts.truncate(1);
    /// assert_eq!(piece.depth_slope(), 0.0);
    /// ```
    pub fn depth_slope(&self) -> f64 {
        let e = self.helix.evaluator();
        let (mut lo, mut hi, mut drawn) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
        let mut last: Option<DVec2> = None;
        for &t in &self.ts {
            let z = self.helix.point_3d(t, false, 0.0).z;
            lo = lo.min(z);
            hi = hi.max(z);
            let p = e.jet(t).0;
            if let Some(q) = last {
                drawn += (p - q).length();
            }
            last = Some(p);
        }
        if self.ts.len() < 2 {
            0.0
        } else if drawn > 0.0 {
            (hi - lo) / drawn
        } else {
            f64::INFINITY
        }
    }

    /// `+1` if `t` increases along the sketch on this piece, `−1` if it
    /// decreases.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    ///
    /// assert_eq!(piece.orientation(), 1.0);
    /// piece.ts.reverse();
    /// assert_eq!(piece.orientation(), -1.0);
    /// ```
    pub fn orientation(&self) -> f64 {
        match self.ts.len() {
            0 | 1 => 1.0,
            n if self.ts[n - 1] < self.ts[0] => -1.0,
            _ => 1.0,
        }
    }

    /// The unit tangent of the lift at the first or last vertex, pointing
    /// along the sketch.
    ///
    /// ```
    /// # use glam::DVec2;
    /// # use strandfit::sketch::{Piece, PlacedHelix};
    /// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
    /// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
    /// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
    /// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
    /// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
    ///
    /// let end = piece.end_tangent(true);
    /// assert!((end.length() - 1.0).abs() < 1e-12);
    /// // Along the sketch: run the other way, the start's tangent is the end's, reversed.
    /// piece.ts.reverse();
    /// assert!((piece.end_tangent(false) + end).length() < 1e-12);
    /// ```
    pub fn end_tangent(&self, at_end: bool) -> DVec3 {
        let t = if at_end {
            self.ts[self.ts.len() - 1]
        } else {
            self.ts[0]
        };
        self.orientation() * self.helix.tangent_3d(t, self.mirror).unwrap_or(DVec3::ZERO)
    }
}

/// Weights of the objective `E` of the fine fitting (see [`refine()`]).
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{Piece, PlacedHelix};
/// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
/// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
/// use strandfit::sketch::{objective, Objective};
///
/// // The vertices moved 0.01 off the curve, along its normals.
/// let off: Vec<DVec2> = piece.feet(&points).iter().zip(&points).map(|(f, p)| *p + 0.01 * f.normal).collect();
/// // Each vertex one E_max off: E_D = 20, weighed by 1 − α_T (no junctions).
/// let e = |alpha_t| objective(&off, std::slice::from_ref(&piece), &Objective { alpha_t, emax: 0.01 });
/// assert!((e(0.0) - 20.0).abs() < 1e-9);
/// assert!((e(0.5) - 10.0).abs() < 1e-9);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Objective {
    /// `α_T ∈ [0, 1)`: the weight of tangent continuity.
    pub alpha_t: f64,
    /// `E_max`, the distance unit of `E_D`.
    pub emax: f64,
}

/// What a refinement did.
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{Piece, PlacedHelix};
/// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
/// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
/// use strandfit::sketch::{refine, Objective};
///
/// // A helix a little off the vertices, refined in at most 50 iterations.
/// piece.helix.helix.a += 0.02;
/// piece.reproject(&points);
/// let report = refine(&points, std::slice::from_mut(&mut piece), &Objective { alpha_t: 0.5, emax: 0.01 }, 50);
/// assert!(report.iterations >= 1 && report.iterations <= 50);
/// assert!(report.after < report.before);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineReport {
    /// Iterations run.
    pub iterations: usize,
    /// The objective before.
    pub before: f64,
    /// The objective after.
    pub after: f64,
}

/// Whether pieces `i − 1` and `i` share a junction vertex.
fn joined(pieces: &[Piece], i: usize) -> bool {
    pieces[i - 1].last == pieces[i].first
}

/// `E` (see [`refine()`]) for the current parameters and projections.
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{Piece, PlacedHelix};
/// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
/// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
/// use strandfit::sketch::{objective, Objective};
///
/// // The piece cut in two at vertex 10: no kink, no distance, E = 0.
/// let mut left = piece.clone();
/// left.last = 10;
/// left.ts.truncate(11);
/// let mut right = piece.clone();
/// right.first = 10;
/// right.ts.drain(..10);
/// let obj = Objective { alpha_t: 0.5, emax: 0.01 };
/// assert!(objective(&points, &[left.clone(), right.clone()], &obj) < 1e-20);
/// // Lift the right half with the mirror helix: E = α_T ‖T̂⁻ − T̂⁺‖².
/// right.mirror = true;
/// let kink = (left.end_tangent(true) - right.end_tangent(false)).length_squared();
/// assert!(kink > 0.01);
/// assert!((objective(&points, &[left, right], &obj) - 0.5 * kink).abs() < 1e-12);
/// ```
pub fn objective(points: &[DVec2], pieces: &[Piece], obj: &Objective) -> f64 {
    let feet: Vec<Vec<Foot>> = pieces.iter().map(|p| p.feet(points)).collect();
    objective_with(pieces, &feet, obj)
}

/// `E` from the pieces' measured vertices.
fn objective_with(pieces: &[Piece], feet: &[Vec<Foot>], obj: &Objective) -> f64 {
    let ed: f64 = feet
        .iter()
        .flatten()
        .map(|f| (f.offset / obj.emax).powi(2))
        .sum();
    let mut et = 0.0;
    if obj.alpha_t > 0.0 {
        for i in 1..pieces.len() {
            if joined(pieces, i) {
                et += (pieces[i - 1].end_tangent(true) - pieces[i].end_tangent(false))
                    .length_squared();
            }
        }
    }
    (1.0 - obj.alpha_t) * ed + obj.alpha_t * et
}

/// The junction tangent of `piece` (at its last vertex if `at_end`) with
/// its parameters replaced by `params`, re-projecting that vertex.
fn perturbed_tangent(piece: &Piece, params: &[f64; PARAMS], v: DVec2, at_end: bool) -> DVec3 {
    let h = PlacedHelix::from_params(params, piece.helix.reflect);
    let t0 = if at_end {
        piece.ts[piece.ts.len() - 1]
    } else {
        piece.ts[0]
    };
    let t = h.closest_parameter(v, t0);
    piece.orientation() * h.tangent_3d(t, piece.mirror).unwrap_or(DVec3::ZERO)
}

/// The Levenberg–Marquardt step `δ` of `(JᵀJ + λ·D) δ = −Jᵀr`, `D` the
/// diagonal of `JᵀJ` (each at least `10⁻¹²` of its largest, `max_diag`):
/// a symmetric positive definite system, solved by Cholesky in `scratch`
/// (`n² + n` values; no allocation: a covering solves thousands of these
/// 6 × 6 systems a lift, where a general LU's set-up cost more than the
/// solve); by partial-pivoting LU where rounding leaves it not positive
/// definite.
fn damped_step<'a>(
    jtj: &[f64],
    jtr: &[f64],
    n: usize,
    lambda: f64,
    max_diag: f64,
    scratch: &'a mut [f64],
) -> &'a [f64] {
    let (l, x) = scratch.split_at_mut(n * n);
    let damped = |r: usize, c: usize| {
        let v = jtj[r * n + c];
        if r == c {
            v + lambda * v.max(1e-12 * max_diag)
        } else {
            v
        }
    };
    // L Lᵀ = A, row by row (L in the lower triangle of `l`).
    let mut definite = true;
    'rows: for r in 0..n {
        for c in 0..=r {
            let mut s = damped(r, c);
            for k in 0..c {
                s -= l[r * n + k] * l[c * n + k];
            }
            if r == c {
                if !(s > 0.0) {
                    definite = false;
                    break 'rows;
                }
                l[r * n + r] = s.sqrt();
            } else {
                l[r * n + c] = s / l[c * n + c];
            }
        }
    }
    if definite {
        // L y = −Jᵀr, then Lᵀ δ = y.
        for r in 0..n {
            let mut s = -jtr[r];
            for k in 0..r {
                s -= l[r * n + k] * x[k];
            }
            x[r] = s / l[r * n + r];
        }
        for r in (0..n).rev() {
            let mut s = x[r];
            for k in r + 1..n {
                s -= l[k * n + r] * x[k];
            }
            x[r] = s / l[r * n + r];
        }
    } else {
        let a = Mat::<f64>::from_fn(n, n, damped);
        let rhs = Mat::<f64>::from_fn(n, 1, |r, _| -jtr[r]);
        let delta = a.partial_piv_lu().solve(&rhs);
        for (r, v) in x.iter_mut().enumerate() {
            *v = delta[(r, 0)];
        }
    }
    x
}

/// Levenberg–Marquardt on `E` over all pieces' parameters (mirrors and
/// vertex ranges fixed). Stops after `max_iterations`, when a step no
/// longer lowers `E` by a relative `1e-13`, or when `E` reaches zero to
/// rounding.
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{Piece, PlacedHelix};
/// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
/// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
/// use strandfit::sketch::{refine, Objective};
///
/// // From a helix a little off (radius, pitch and rotation), back onto the
/// // vertices.
/// piece.helix.helix.a += 0.02;
/// piece.helix.helix.b -= 0.01;
/// piece.helix.theta += 0.02;
/// piece.reproject(&points);
/// assert!(piece.max_distance(&points) > 1e-3);
/// let report = refine(&points, std::slice::from_mut(&mut piece), &Objective { alpha_t: 0.5, emax: 0.01 }, 100);
/// assert!(report.after < 1e-12 * report.before, "{report:?}");
/// assert!(piece.max_distance(&points) < 1e-7);
/// ```
///
/// # Method
///
/// Least-squares refinement of placed helices against the sketch, and the
/// fine fitting of Section 7.
///
/// The paper minimises `E = α_T E_T + (1 − α_T) E_D` over all `(aᵢ, bᵢ,
/// cᵢ)` by the simplex method (about a minute for 500 vertices in Matlab).
/// Here the same objective, with two changes, is minimised by
/// Levenberg–Marquardt:
///
/// * each helix's placement (`θ`, `o`) is free as well as `(a, b, c)`: the
///   alignment of Section 6.1 rests on one estimated tangent at the seed
///   vertex, and freeing it is what lets an exact projection be fitted
///   exactly;
/// * the distance term is made dimensionless, so the result does not
///   depend on the scale of the drawing: `E_D = Σ (dᵢⱼ / E_max)²` (vertex
///   distances in units of the threshold), with `E_T = Σ ‖T̂⁻ − T̂⁺‖²` over
///   junctions as printed. A junction kink of 0.1 rad then weighs as much
///   as one vertex moved by 0.1 `E_max`: with `α_T = ½` the fine fit
///   mostly keeps the drawing and removes the kinks that cost little.
///
/// `dᵢⱼ` is the signed distance of vertex `v_{i,j}` along the curve's
/// normal at its closest point `Hᵢ(t_{i,j})`; its gradient is `−ν·∂P/∂p`
/// (the closest-point condition removes the `∂t` term), so the distance
/// rows get exact Jacobians. The tangent rows depend on the junction's
/// closest parameters too and are differentiated numerically (central
/// differences, re-projecting the junction vertex) — a handful of rows.
pub fn refine(
    points: &[DVec2],
    pieces: &mut [Piece],
    obj: &Objective,
    max_iterations: usize,
) -> RefineReport {
    refine_to(points, pieces, obj, max_iterations, 1e-13)
}

/// [`refine`], stopping once a step lowers `E` by a relative `gain` or less.
///
/// ```
/// # use glam::DVec2;
/// # use strandfit::sketch::{Piece, PlacedHelix};
/// # let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
/// # let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
/// # let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
/// # let mut piece = Piece { helix, first: 0, last: 19, ts: ts.clone(), mirror: false };
/// // `piece` fits 20 `points` of its own helix exactly, at parameters `ts`.
/// use strandfit::sketch::{refine, refine_to, Objective};
///
/// // Stopping at the first step that gains less than half: fewer iterations.
/// piece.helix.helix.a += 0.02;
/// piece.helix.theta += 0.02;
/// piece.reproject(&points);
/// let obj = Objective { alpha_t: 0.5, emax: 0.01 };
/// let mut full = piece.clone();
/// let all = refine(&points, std::slice::from_mut(&mut full), &obj, 100);
/// let some = refine_to(&points, std::slice::from_mut(&mut piece), &obj, 100, 0.5);
/// assert!(some.after < some.before);
/// assert!(some.iterations < all.iterations, "{some:?} {all:?}");
/// ```
pub fn refine_to(
    points: &[DVec2],
    pieces: &mut [Piece],
    obj: &Objective,
    max_iterations: usize,
    gain_tol: f64,
) -> RefineReport {
    refine_holding(
        points,
        pieces,
        obj,
        max_iterations,
        gain_tol,
        [false; PARAMS],
    )
}

/// [`refine_to`] with each parameter `q` where `held[q]` kept as it is
/// (in every piece): its Jacobian column is zero, so the damped step
/// leaves it (`δ_q = 0`: the damped system's row for it is `λ·ε·δ_q = 0`).
pub(crate) fn refine_holding(
    points: &[DVec2],
    pieces: &mut [Piece],
    obj: &Objective,
    max_iterations: usize,
    gain_tol: f64,
    held: [bool; PARAMS],
) -> RefineReport {
    let n = pieces.len() * PARAMS;
    let wd = (1.0 - obj.alpha_t).sqrt() / obj.emax;
    let wt = obj.alpha_t.sqrt();
    // Each vertex is measured once per projection: the cost and the rows
    // of the next iteration share its trigonometry.
    let mut feet: Vec<Vec<Foot>> = pieces.iter().map(|p| p.feet(points)).collect();
    let mut cost = objective_with(pieces, &feet, obj);
    let before = cost;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut jtj = vec![0.0; n * n];
    let mut jtr = vec![0.0; n];
    let mut scratch = vec![0.0; n * n + n];
    // Each trial step's pieces and feet, allocated once.
    let mut trial: Vec<Piece> = pieces.to_vec();
    let mut trial_feet: Vec<Vec<Foot>> = vec![Vec::new(); pieces.len()];
    while iterations < max_iterations && cost > 1e-30 {
        iterations += 1;
        jtj.iter_mut().for_each(|v| *v = 0.0);
        jtr.iter_mut().for_each(|v| *v = 0.0);
        // Distance rows: one block per piece.
        for (i, (p, pf)) in pieces.iter().zip(&feet).enumerate() {
            let base = i * PARAMS;
            let e = p.helix.evaluator();
            for f in pf {
                let jac = e.param_jacobian_at(f);
                let row: [f64; PARAMS] = std::array::from_fn(|q| {
                    if held[q] {
                        0.0
                    } else {
                        -wd * f.normal.dot(jac[q])
                    }
                });
                let r = wd * f.offset;
                // The block's upper triangle only: it is symmetric (and
                // `x·y` is `y·x` in floating point too), mirrored below.
                for a in 0..PARAMS {
                    jtr[base + a] += row[a] * r;
                    for b in a..PARAMS {
                        jtj[(base + a) * n + base + b] += row[a] * row[b];
                    }
                }
            }
            for a in 0..PARAMS {
                for b in 0..a {
                    jtj[(base + a) * n + base + b] = jtj[(base + b) * n + base + a];
                }
            }
        }
        // Tangent rows: three per junction, twelve columns each.
        if wt > 0.0 {
            for i in 1..pieces.len() {
                if !joined(pieces, i) {
                    continue;
                }
                let (left, right) = (&pieces[i - 1], &pieces[i]);
                let v = points[right.first];
                let r = wt * (left.end_tangent(true) - right.end_tangent(false));
                let mut cols: Vec<(usize, DVec3)> = Vec::with_capacity(2 * PARAMS);
                for (side, piece, at_end, sign) in
                    [(i - 1, left, true, 1.0), (i, right, false, -1.0)]
                {
                    let p0 = piece.helix.params();
                    for q in (0..PARAMS).filter(|&q| !held[q]) {
                        let h = 1e-6 * (1.0 + p0[q].abs());
                        let mut pp = p0;
                        pp[q] += h;
                        let tp = perturbed_tangent(piece, &pp, v, at_end);
                        pp[q] -= 2.0 * h;
                        let tm = perturbed_tangent(piece, &pp, v, at_end);
                        cols.push((side * PARAMS + q, sign * wt * (tp - tm) / (2.0 * h)));
                    }
                }
                for &(a, ja) in &cols {
                    jtr[a] += ja.dot(r);
                    for &(b, jb) in &cols {
                        jtj[a * n + b] += ja.dot(jb);
                    }
                }
            }
        }
        let max_diag = (0..n).map(|k| jtj[k * n + k]).fold(0.0, f64::max);
        if !(max_diag > 0.0) {
            break;
        }
        let grad = jtr.iter().fold(0.0f64, |g, v| g.max(v.abs()));
        if grad <= 1e-15 * cost.sqrt() * max_diag.sqrt() {
            break;
        }
        // Try steps with growing damping until one lowers E.
        let mut improved = false;
        while lambda < 1e12 {
            let delta = damped_step(&jtj, &jtr, n, lambda, max_diag, &mut scratch);
            let mut finite = true;
            // The squared offsets a trial may reach before its distance
            // term alone makes `E` no lower (`E_T ≥ 0`); the margin keeps
            // the projections' sums, added in another order than
            // `objective_with`'s, from refusing a step it would take.
            let mut room = cost * (1.0 + 1e-9) / (wd * wd);
            for (i, ((p, from), f)) in trial
                .iter_mut()
                .zip(pieces.iter())
                .zip(&mut trial_feet)
                .enumerate()
            {
                p.clone_from(from);
                let mut params = p.helix.params();
                for (q, v) in params.iter_mut().enumerate() {
                    *v += delta[i * PARAMS + q];
                    finite &= v.is_finite();
                }
                p.helix = PlacedHelix::from_params(&params, p.helix.reflect);
                if !finite {
                    break;
                }
                match p.reproject_feet_coarse(points, f, room) {
                    Some(squares) => room -= squares,
                    None => {
                        finite = false;
                        break;
                    }
                }
            }
            let new_cost = if finite {
                objective_with(&trial, &trial_feet, obj)
            } else {
                f64::INFINITY
            };
            if new_cost < cost {
                let gain = (cost - new_cost) / cost;
                // The trial's pieces and feet become the fit's (the old
                // ones the next trial's buffers).
                pieces.swap_with_slice(&mut trial);
                std::mem::swap(&mut feet, &mut trial_feet);
                cost = new_cost;
                lambda = (lambda / 3.0).max(1e-12);
                improved = gain > gain_tol;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    RefineReport {
        iterations,
        before,
        after: cost,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A held parameter is left as it was, bit for bit, while the others
    /// fit: a helix with its radius and rotation off and its pitch held
    /// right comes back onto its vertices; with the pitch held wrong, the
    /// fit does what it can without it.
    #[test]
    fn held_parameters_stay_as_they_are() {
        let helix = PlacedHelix::from_params(&[0.7, 0.3, -0.2, 0.4, 0.15, 0.5], false);
        let ts: Vec<f64> = (0..20).map(|k| 0.5 + 0.1 * k as f64).collect();
        let points: Vec<DVec2> = ts.iter().map(|&t| helix.point(t)).collect();
        let obj = Objective {
            alpha_t: 0.0,
            emax: 0.01,
        };
        let mut held = [false; PARAMS];
        held[4] = true;
        for (pitch, exact) in [(0.15, true), (0.05, false)] {
            let mut piece = Piece {
                helix,
                first: 0,
                last: 19,
                ts: ts.clone(),
                mirror: false,
            };
            piece.helix.helix.a += 0.02;
            piece.helix.helix.b = pitch;
            piece.helix.theta += 0.02;
            piece.reproject(&points);
            let report = refine_holding(
                &points,
                std::slice::from_mut(&mut piece),
                &obj,
                100,
                1e-13,
                held,
            );
            assert_eq!(piece.helix.helix.b.to_bits(), pitch.to_bits());
            assert!(report.after < report.before, "{report:?}");
            let far = piece.max_distance(&points);
            if exact {
                assert!(far < 1e-7, "{far}");
            } else {
                assert!(far > 1e-4, "{far}");
            }
        }
    }

    /// `damped_step` against faer's LU of the same damped system, on
    /// random normal equations (`JᵀJ` of a random `J`, from well- to
    /// badly conditioned), and through its fallback where the system is
    /// not positive definite.
    #[test]
    fn damped_step_solves_the_damped_normal_equations() {
        let mut rng = ChaCha8Rng::seed_from_u64(46);
        let lu = |jtj: &[f64], jtr: &[f64], n: usize, lambda: f64, max_diag: f64| {
            let a = Mat::<f64>::from_fn(n, n, |r, c| {
                let v = jtj[r * n + c];
                if r == c {
                    v + lambda * v.max(1e-12 * max_diag)
                } else {
                    v
                }
            });
            let rhs = Mat::<f64>::from_fn(n, 1, |r, _| -jtr[r]);
            let d = a.partial_piv_lu().solve(&rhs);
            (0..n).map(|r| d[(r, 0)]).collect::<Vec<f64>>()
        };
        for case in 0..300 {
            let n = [6, 12, 18][case % 3];
            let rows = n + rng.gen_range(0..2 * n);
            // Columns scaled over up to six decades (as a helix's
            // placement and shape parameters are).
            let scale: Vec<f64> = (0..n)
                .map(|_| 10f64.powf(rng.gen_range(-3.0..3.0)))
                .collect();
            let j: Vec<f64> = (0..rows * n)
                .map(|k| rng.gen_range(-1.0..1.0) * scale[k % n])
                .collect();
            let r: Vec<f64> = (0..rows).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let mut jtj = vec![0.0; n * n];
            let mut jtr = vec![0.0; n];
            for row in 0..rows {
                for a in 0..n {
                    jtr[a] += j[row * n + a] * r[row];
                    for b in 0..n {
                        jtj[a * n + b] += j[row * n + a] * j[row * n + b];
                    }
                }
            }
            let max_diag = (0..n).map(|k| jtj[k * n + k]).fold(0.0, f64::max);
            let lambda = 10f64.powf(rng.gen_range(-12.0..3.0));
            let mut scratch = vec![0.0; n * n + n];
            let got = damped_step(&jtj, &jtr, n, lambda, max_diag, &mut scratch).to_vec();
            let want = lu(&jtj, &jtr, n, lambda, max_diag);
            // Both solve the same system: the solutions agree to a small
            // part of the largest component.
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                let tol = 1e-6 * (w.abs() + want.iter().map(|v| v.abs()).fold(0.0, f64::max));
                assert!((g - w).abs() <= tol, "case {case} n {n} k {k}: {g} vs {w}");
            }
        }
        // Not positive definite (a negative eigenvalue): the LU's answer.
        let n = 6;
        let mut jtj = vec![0.0; n * n];
        for k in 0..n {
            jtj[k * n + k] = if k == 2 { -1.0 } else { 1.0 + k as f64 };
        }
        jtj[1] = 0.5;
        jtj[n] = 0.5;
        let jtr: Vec<f64> = (0..n).map(|k| 1.0 - 0.3 * k as f64).collect();
        let mut scratch = vec![0.0; n * n + n];
        let got = damped_step(&jtj, &jtr, n, 0.0, 6.0, &mut scratch).to_vec();
        assert_eq!(got, lu(&jtj, &jtr, n, 0.0, 6.0));
        assert!(got.iter().all(|v| v.is_finite()), "{got:?}");
    }

    fn exact_piece(truth: &PlacedHelix, n: usize) -> (Vec<DVec2>, Piece) {
        let ts: Vec<f64> = (0..n)
            .map(|k| -4.0 + 8.0 * k as f64 / (n - 1) as f64)
            .collect();
        let points: Vec<DVec2> = ts.iter().map(|&t| truth.point(t)).collect();
        let mut start = *truth;
        start.theta += 0.03;
        start.origin += DVec2::new(0.01, -0.02);
        start.helix.a *= 1.1;
        start.helix.b *= 0.9;
        start.helix.c += 0.05;
        let mut piece = Piece {
            helix: start,
            first: 0,
            last: n - 1,
            ts,
            mirror: false,
        };
        piece.reproject(&points);
        (points, piece)
    }

    #[test]
    fn recovers_an_exact_projection_from_a_perturbed_start() {
        let truth = PlacedHelix::from_params(&[0.4, 0.2, 0.1, 0.3, 0.12, 0.6], false);
        let (points, piece) = exact_piece(&truth, 40);
        let mut pieces = [piece];
        let obj = Objective {
            alpha_t: 0.0,
            emax: 1e-3,
        };
        let r = refine(&points, &mut pieces, &obj, 100);
        assert!(r.after < 1e-20 && r.after < r.before, "{r:?}");
        assert!(pieces[0].max_distance(&points) < 1e-10);
        let p = pieces[0].helix.params();
        for (a, b) in p.iter().zip(truth.params()) {
            assert!((a - b).abs() < 1e-7, "{p:?}");
        }
    }

    #[test]
    fn tangent_weight_trades_distance_for_continuity() {
        // Two pieces of different helices joined at a vertex with a kink:
        // a larger α_T gives a smaller kink and a larger distance term.
        let h1 = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 0.3, 0.1, 0.4], false);
        let t1: Vec<f64> = (0..20).map(|k| 0.1 * k as f64).collect();
        let mut points: Vec<DVec2> = t1.iter().map(|&t| h1.point(t)).collect();
        let join = *points.last().unwrap();
        let d = h1.derivative(1.9).normalize();
        let mut h2 = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 0.5, 0.2, -0.3], false);
        // Place h2 so that H2(0) = join with its tangent turned by 0.3 rad.
        let want = DVec2::from_angle(0.3).rotate(d);
        let have = h2.derivative(0.0).normalize();
        h2.theta = want.to_angle() - have.to_angle();
        h2.origin = join - h2.to_sketch_vector(h2.helix.point(0.0));
        let t2: Vec<f64> = (0..20).map(|k| 0.1 * k as f64).collect();
        points.extend(t2.iter().skip(1).map(|&t| h2.point(t)));
        let make = || {
            vec![
                Piece {
                    helix: h1,
                    first: 0,
                    last: 19,
                    ts: t1.clone(),
                    mirror: false,
                },
                Piece {
                    helix: h2,
                    first: 19,
                    last: 38,
                    ts: t2.clone(),
                    mirror: false,
                },
            ]
        };
        let kink = |p: &[Piece]| (p[0].end_tangent(true) - p[1].end_tangent(false)).length();
        let mut lo = make();
        let mut hi = make();
        let k0 = kink(&lo);
        refine(
            &points,
            &mut lo,
            &Objective {
                alpha_t: 0.1,
                emax: 1e-3,
            },
            200,
        );
        refine(
            &points,
            &mut hi,
            &Objective {
                alpha_t: 0.9,
                emax: 1e-3,
            },
            200,
        );
        let (klo, khi) = (kink(&lo), kink(&hi));
        assert!(khi < klo && klo < k0, "{k0} {klo} {khi}");
        let dist = |p: &[Piece]| {
            p.iter()
                .map(|q| q.max_distance(&points))
                .fold(0.0, f64::max)
        };
        assert!(dist(&hi) > dist(&lo), "{} {}", dist(&lo), dist(&hi));
    }
}
