//! A 3D Euler spiral between two point–tangent pairs by Levenberg–Marquardt
//! on the end conditions (the fast solver of issue 5; the paper's own
//! coordinate descent, Algorithm 1, is to come beside it).
//!
//! Given `(x₀, T₀)` and `(x_f, T_f)`, find `(κ₀, γ, τ₀, δ, L)` so that the
//! spiral from `x₀` with frame `[T₀, N₀, T₀ × N₀]` ends at `x_f` with tangent
//! `T_f`. Residual (six components, Eq. 9 of paper 004 is its squared norm):
//!
//! ```text
//! r = (x(L) − x_f, T(L) − T_f)
//! ```
//!
//! As in the paper (Section 6), the problem is translated by `−x₀` and scaled
//! by `D = max |x_f − x₀|` per axis, solved, and scaled back (Prop. 5.1:
//! curvatures scale by `1/D`, their rates by `1/D²`, `L` by `D`). `N₀` is
//! the in-plane normal `normalize(d − (d·T₀)T₀)`, `d = x_f − x₀`
//! (ERRATA 004.2). Curves are integrated with the fourth-order scheme of
//! [`frenet`](super::frenet) at a fixed step count, so residuals are smooth
//! in the parameters; the Jacobian is by central differences.
//!
//! Initial guess (the paper's Step 1): the planar clothoid G1 fit in the
//! plane of `T₀` and `d` to `T_f`'s projection, `τ₀ = δ = 0`.

use glam::DVec3;

use super::frenet::{FrenetEnd, FrenetError, FrenetProblem};

/// Options of [`solve_spiral`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveOptions {
    /// Integration steps per candidate curve.
    pub steps: usize,
    pub max_iterations: usize,
    /// Stop when `ε` (Eq. 9, in the scaled problem) falls below this.
    pub tolerance: f64,
    /// `N₀`; default (`None`): the in-plane normal of the paper's Step 1.
    /// The five parameters and the two end conditions leave the start frame's
    /// rotation about `T₀` free; the paper fixes it by the plane.
    pub start_normal: Option<DVec3>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            steps: 128,
            max_iterations: 100,
            tolerance: 1e-24,
            start_normal: None,
        }
    }
}

/// The solved spiral, its error `ε` (Eq. 9, in the input's units) and the
/// iterations used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpiralSolution {
    pub problem: FrenetProblem,
    pub error: f64,
    pub iterations: usize,
}

/// Why no spiral was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    #[error("the end points coincide")]
    Coincident,
    #[error("an input is not finite, or a tangent is zero")]
    BadInput,
    #[error("integration: {0}")]
    Frenet(#[from] FrenetError),
}

/// `|r|²`: Eq. 9's `ε` for a residual.
pub(crate) fn norm2(r: &[f64; 6]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// The Gauss–Newton normal equations `(JᵀJ, Jᵀr)` of a 6×5 Jacobian.
pub(crate) fn normal_equations(jac: &[[f64; 5]; 6], r: &[f64; 6]) -> ([[f64; 5]; 5], [f64; 5]) {
    let mut a = [[0.0; 5]; 5];
    let mut g = [0.0; 5];
    for i in 0..5 {
        for j in 0..5 {
            a[i][j] = (0..6).map(|k| jac[k][i] * jac[k][j]).sum();
        }
        g[i] = (0..6).map(|k| jac[k][i] * r[k]).sum();
    }
    (a, g)
}

/// Solve `(A + λ diag A) Δ = −g` for the 5×5 normal equations (faer LU).
pub(crate) fn lm_step(a: &[[f64; 5]; 5], g: &[f64; 5], lambda: f64) -> Option<[f64; 5]> {
    use faer::linalg::solvers::Solve;
    let m = faer::Mat::<f64>::from_fn(5, 5, |i, j| {
        a[i][j]
            + if i == j {
                lambda * a[i][i].max(1e-12)
            } else {
                0.0
            }
    });
    let rhs = faer::Mat::<f64>::from_fn(5, 1, |i, _| -g[i]);
    let x = m.partial_piv_lu().solve(&rhs);
    let d: [f64; 5] = std::array::from_fn(|i| x[(i, 0)]);
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// The problem translated to the origin and scaled by `D` (Section 6), with
/// its start frame and the circular-arc initial guess.
pub(crate) struct Scaled {
    pub frame: [DVec3; 3],
    /// `(x_f − x₀)/D`.
    pub target: DVec3,
    /// Unit `T_f`.
    pub tangent: DVec3,
    pub scale: f64,
    /// `(κ₀, γ, τ₀, δ, L)` of the scaled problem.
    pub initial: [f64; 5],
}

impl Scaled {
    pub fn new(
        x0: DVec3,
        t0: DVec3,
        xf: DVec3,
        tf: DVec3,
        start_normal: Option<DVec3>,
    ) -> Result<Self, SolveError> {
        if !(x0.is_finite() && t0.is_finite() && xf.is_finite() && tf.is_finite()) {
            return Err(SolveError::BadInput);
        }
        let (t0, tf) = match (t0.try_normalize(), tf.try_normalize()) {
            (Some(a), Some(b)) => (a, b),
            _ => return Err(SolveError::BadInput),
        };
        let d = xf - x0;
        let scale = d.abs().max_element();
        if scale == 0.0 {
            return Err(SolveError::Coincident);
        }
        let ds = d / scale;
        // In-plane normal towards x_f's side; any perpendicular if d ∥ T₀.
        let n0 = match start_normal {
            Some(n) => (n - n.dot(t0) * t0)
                .try_normalize()
                .ok_or(SolveError::BadInput)?,
            None => (ds - ds.dot(t0) * t0)
                .try_normalize()
                .unwrap_or_else(|| t0.any_orthonormal_vector()),
        };
        Ok(Scaled {
            frame: [t0, n0, t0.cross(n0)],
            target: ds,
            tangent: tf,
            scale,
            initial: planar_guess(t0, n0, ds, tf),
        })
    }

    /// The scaled problem of parameters `p = (κ₀, γ, τ₀, δ, L)`, from the
    /// origin with the start frame (`L` clamped at 0).
    pub fn problem(&self, p: &[f64; 5]) -> FrenetProblem {
        FrenetProblem {
            start: DVec3::ZERO,
            frame: self.frame,
            kappa0: p[0],
            gamma: p[1],
            tau0: p[2],
            delta: p[3],
            length: p[4].max(0.0),
        }
    }

    /// `r = (x(L) − x_f, T(L) − T_f)` of an integrated scaled problem.
    pub fn residual(&self, e: &FrenetEnd) -> [f64; 6] {
        let dx = e.point - self.target;
        let dt = e.frame[0] - self.tangent;
        [dx.x, dx.y, dx.z, dt.x, dt.y, dt.z]
    }

    /// The residual of `p`, integrated in `steps` steps.
    fn residual_of(&self, p: &[f64; 5], steps: usize) -> [f64; 6] {
        self.residual(&self.problem(p).integrate_unchecked(steps))
    }

    /// The solution in the input's units, validated, with its Eq. 9 error
    /// against `x_f` re-integrated in `steps` steps.
    pub fn solution(
        &self,
        x0: DVec3,
        xf: DVec3,
        p: &[f64; 5],
        steps: usize,
        iterations: usize,
    ) -> Result<SpiralSolution, SolveError> {
        let problem = self.unscale(x0, p);
        problem.validate()?;
        let end = problem.integrate_unchecked(steps);
        let error =
            (end.point - xf).length_squared() + (end.frame[0] - self.tangent).length_squared();
        Ok(SpiralSolution {
            problem,
            error,
            iterations,
        })
    }

    /// The solution in the input's units (Prop. 5.1).
    pub fn unscale(&self, x0: DVec3, p: &[f64; 5]) -> FrenetProblem {
        let sc = self.scale;
        FrenetProblem {
            start: x0,
            frame: self.frame,
            kappa0: p[0] / sc,
            gamma: p[1] / (sc * sc),
            tau0: p[2] / sc,
            delta: p[3] / (sc * sc),
            length: p[4] * sc,
        }
    }
}

/// Step 1 of the paper: the planar clothoid in the plane of `T₀` and `d`
/// (axes `T₀`, `N₀`) from the origin with angle 0 to `d` with the angle of
/// `T_f`'s projection (Bertolazzi–Frego, [`clothoid`](super::clothoid));
/// `τ₀ = δ = 0`. Falls back to the circular arc through `d` (tangent `T₀`
/// at the start) when the projection vanishes or the clothoid fit fails.
fn planar_guess(t0: DVec3, n0: DVec3, d: DVec3, tf: DVec3) -> [f64; 5] {
    use glam::DVec2;
    let p1 = DVec2::new(d.dot(t0), d.dot(n0));
    let tproj = DVec2::new(tf.dot(t0), tf.dot(n0));
    if tproj.length() > 1e-9 {
        let theta1 = tproj.y.atan2(tproj.x);
        if let Ok(c) = super::clothoid::clothoid_g1(DVec2::ZERO, 0.0, p1, theta1) {
            if c.length > 0.0 && c.kappa0.is_finite() && c.dkappa.is_finite() {
                return [c.kappa0, c.dkappa, 0.0, 0.0, c.length];
            }
        }
    }
    let dl = d.length();
    let alpha = t0.angle_between(d);
    if alpha < 1e-9 {
        [0.0, 0.0, 0.0, 0.0, dl]
    } else {
        [
            2.0 * alpha.sin() / dl,
            0.0,
            0.0,
            0.0,
            dl * alpha / alpha.sin(),
        ]
    }
}

/// The spiral from `(x0, t0)` to `(xf, tf)` (tangents need not be unit).
pub fn solve_spiral(
    x0: DVec3,
    t0: DVec3,
    xf: DVec3,
    tf: DVec3,
    opts: &SolveOptions,
) -> Result<SpiralSolution, SolveError> {
    let sc = Scaled::new(x0, t0, xf, tf, opts.start_normal)?;
    let dl = sc.target.length();
    let mut p = sc.initial;
    let steps = opts.steps.max(1);
    let mut r = sc.residual_of(&p, steps);
    let mut err = norm2(&r);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    while iterations < opts.max_iterations && err > opts.tolerance {
        iterations += 1;
        // Jacobian by central differences.
        let mut jac = [[0.0; 5]; 6];
        for k in 0..5 {
            let h = 1e-6 * (1.0 + p[k].abs());
            let (mut pp, mut pm) = (p, p);
            pp[k] += h;
            pm[k] -= h;
            let (rp, rm) = (sc.residual_of(&pp, steps), sc.residual_of(&pm, steps));
            for i in 0..6 {
                jac[i][k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let (a, g) = normal_equations(&jac, &r);
        let mut improved = false;
        for _ in 0..30 {
            let Some(step) = lm_step(&a, &g, lambda) else {
                lambda *= 10.0;
                continue;
            };
            let mut q = p;
            for k in 0..5 {
                q[k] += step[k];
            }
            q[4] = q[4].max(1e-3 * dl);
            let rq = sc.residual_of(&q, steps);
            let eq = norm2(&rq);
            if eq < err {
                p = q;
                r = rq;
                err = eq;
                lambda = (lambda * 0.3).max(1e-15);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break; // at a (local) minimum to rounding
        }
    }
    sc.solution(x0, xf, &p, steps, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_end(s: &SpiralSolution, xf: DVec3, tf: DVec3, tol: f64) {
        let e = s.problem.integrate(1024).unwrap();
        let scale = 1.0 + xf.length();
        assert!(
            e.point.distance(xf) < tol * scale,
            "end {} vs {xf}",
            e.point
        );
        assert!(
            e.frame[0].distance(tf.normalize()) < tol,
            "tangent {} vs {tf}",
            e.frame[0]
        );
    }

    #[test]
    fn roundness_pairs_on_a_circle_give_the_circle() {
        // Points on a circle of radius 3 with its tangents (Prop. 5.4).
        let r = 3.0;
        for theta in [0.3f64, 1.0, 2.0, 3.0, 4.5] {
            let x0 = DVec3::new(r, 0.0, 0.0);
            let t0 = DVec3::Y;
            let xf = DVec3::new(r * theta.cos(), r * theta.sin(), 0.0);
            let tf = DVec3::new(-theta.sin(), theta.cos(), 0.0);
            let s = solve_spiral(x0, t0, xf, tf, &SolveOptions::default()).unwrap();
            let p = s.problem;
            assert!(
                (p.kappa0 - 1.0 / r).abs() < 1e-9,
                "θ = {theta}: κ₀ = {}",
                p.kappa0
            );
            assert!(
                p.gamma.abs() < 1e-9 && p.tau0.abs() < 1e-9 && p.delta.abs() < 1e-9,
                "{p:?}"
            );
            // The circle's position is integrated by Simpson at 128 steps
            // (error ≈ (θ/128)⁴ relative): L absorbs it.
            assert!(
                (p.length - r * theta).abs() < 1e-7 * r * theta,
                "L = {}",
                p.length
            );
            assert!(s.error < 1e-20, "ε = {}", s.error);
        }
    }

    #[test]
    fn extensibility_recovers_a_spiral_from_its_ends() {
        // Completing between the ends of a spiral reproduces it (Prop. 5.3).
        let truth = FrenetProblem::new(
            DVec3::new(1.0, 2.0, -1.0),
            DVec3::new(0.0, 0.6, 0.8),
            DVec3::X,
            0.8,
            0.3,
            0.4,
            -0.2,
            2.5,
        );
        let end = truth.integrate(4096).unwrap();
        // With the truth's start normal (the end conditions leave it free).
        let o = SolveOptions {
            start_normal: Some(truth.frame[1]),
            ..Default::default()
        };
        let s = solve_spiral(truth.start, truth.frame[0], end.point, end.frame[0], &o).unwrap();
        check_end(&s, end.point, end.frame[0], 1e-8);
        let p = s.problem;
        for (a, b) in [
            (p.kappa0, truth.kappa0),
            (p.gamma, truth.gamma),
            (p.tau0, truth.tau0),
            (p.delta, truth.delta),
            (p.length, truth.length),
        ] {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}: {p:?}");
        }
    }

    #[test]
    fn invariant_to_rotation_translation_and_scale() {
        let (x0, t0) = (DVec3::ZERO, DVec3::new(1.0, 0.2, 0.0));
        let (xf, tf) = (DVec3::new(2.0, 1.0, 0.5), DVec3::new(0.1, 1.0, 0.3));
        let base = solve_spiral(x0, t0, xf, tf, &SolveOptions::default()).unwrap();
        let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let (s, shift) = (3.5, DVec3::new(-4.0, 1.0, 9.0));
        let tr = |p: DVec3| rot * p * s + shift;
        let other =
            solve_spiral(tr(x0), rot * t0, tr(xf), rot * tf, &SolveOptions::default()).unwrap();
        let (a, b) = (base.problem, other.problem);
        assert!((b.kappa0 - a.kappa0 / s).abs() < 1e-8 * (1.0 + a.kappa0.abs()));
        assert!((b.gamma - a.gamma / (s * s)).abs() < 1e-8 * (1.0 + a.gamma.abs()));
        assert!((b.tau0 - a.tau0 / s).abs() < 1e-8 * (1.0 + a.tau0.abs()));
        assert!((b.delta - a.delta / (s * s)).abs() < 1e-8 * (1.0 + a.delta.abs()));
        assert!((b.length - a.length * s).abs() < 1e-8 * a.length * s);
        check_end(&other, tr(xf), rot * tf, 1e-8);
    }

    /// Planar data: the spiral is the planar clothoid (τ₀ = δ = 0, same
    /// κ₀, γ, L as Bertolazzi–Frego's fit), and reversing the problem gives
    /// the same curve run backwards (κ₀ ↔ −κ(L), γ unchanged: the
    /// reversed Frenet normal flips the curvature's sign).
    #[test]
    fn planar_data_reduce_to_the_clothoid_and_reverse() {
        use glam::DVec2;
        for (p1, th1) in [
            (DVec2::new(4.0, 1.0), 0.0),
            (DVec2::new(2.0, 2.0), 2.0),
            (DVec2::new(3.0, -1.0), -0.7),
        ] {
            let c = crate::euler::clothoid_g1(DVec2::ZERO, 0.3, p1, th1).unwrap();
            let v = |p: DVec2| DVec3::new(p.x, p.y, 0.0);
            let a = |t: f64| DVec3::new(t.cos(), t.sin(), 0.0);
            let (x0, t0, xf, tf) = (DVec3::ZERO, a(0.3), v(p1), a(th1));
            let s = solve_spiral(x0, t0, xf, tf, &SolveOptions::default()).unwrap();
            let p = s.problem;
            // The solver's N₀ is the in-plane normal towards x_f: signs of
            // curvature follow it; compare |κ| and the shape via γ/κ₀.
            let sign = p.frame[1]
                .dot(DVec3::new(-0.3f64.sin(), 0.3f64.cos(), 0.0))
                .signum();
            assert!(p.tau0.abs() < 1e-9 && p.delta.abs() < 1e-9, "{p:?}");
            assert!(
                (sign * p.kappa0 - c.kappa0).abs() < 1e-7,
                "{} vs {}",
                sign * p.kappa0,
                c.kappa0
            );
            assert!(
                (sign * p.gamma - c.dkappa).abs() < 1e-7,
                "{} vs {}",
                sign * p.gamma,
                c.dkappa
            );
            assert!(
                (p.length - c.length).abs() < 1e-7,
                "{} vs {}",
                p.length,
                c.length
            );
            // Reverse.
            let r = solve_spiral(xf, -tf, x0, -t0, &SolveOptions::default())
                .unwrap()
                .problem;
            // Signed curvatures about +z (κ B·z): run backwards the curve's
            // signed curvature is −κ(L − s), its rate unchanged.
            let (bz, brz) = (p.frame[2].z, r.frame[2].z);
            let kend = p.kappa0 + p.gamma * p.length;
            assert!(
                (r.kappa0 * brz + kend * bz).abs() < 1e-7,
                "{} vs {}",
                r.kappa0 * brz,
                -kend * bz
            );
            assert!((r.gamma * brz - p.gamma * bz).abs() < 1e-7);
            assert!((r.length - p.length).abs() < 1e-7);
        }
    }

    #[test]
    fn straight_and_bad_input() {
        let s = solve_spiral(
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::X,
            &SolveOptions::default(),
        )
        .unwrap();
        assert!(s.problem.kappa0.abs() < 1e-12 && (s.problem.length - 2.0).abs() < 1e-12);
        assert_eq!(
            solve_spiral(
                DVec3::ONE,
                DVec3::X,
                DVec3::ONE,
                DVec3::Y,
                &SolveOptions::default()
            ),
            Err(SolveError::Coincident)
        );
        assert_eq!(
            solve_spiral(
                DVec3::ZERO,
                DVec3::ZERO,
                DVec3::ONE,
                DVec3::Y,
                &SolveOptions::default()
            ),
            Err(SolveError::BadInput)
        );
        assert_eq!(
            solve_spiral(
                DVec3::ZERO,
                DVec3::X,
                DVec3::new(f64::NAN, 0.0, 0.0),
                DVec3::Y,
                &SolveOptions::default()
            ),
            Err(SolveError::BadInput)
        );
    }
}
