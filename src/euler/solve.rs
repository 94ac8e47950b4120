//! A 3D Euler spiral between two point–tangent pairs by Levenberg–Marquardt
//! on the end conditions; the method is described on `solve_spiral`.

use glam::DVec3;

use super::frenet::{FrenetEnd, FrenetError, FrenetProblem};

/// Options of [`solve_spiral`] (and [`solve_spirals`](super::solve_spirals)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveOptions {
    /// Integration steps per candidate curve at the start of a run (at
    /// least 2).
    pub steps: usize,
    /// The most steps the truncation check may raise `steps` to.
    pub max_steps: usize,
    /// The truncation error allowed in the solved end: position relative to
    /// `|x_f − x₀|`, tangent absolute. Once a solve converges, the end at
    /// `steps/2` is compared with the end at `steps` (the scheme is fourth
    /// order, so their difference over 15 estimates the error at `steps`);
    /// while the estimate is above this, `steps` doubles (up to
    /// `max_steps`) and the solve resumes from the solution.
    /// `f64::INFINITY`: no check, `steps` throughout.
    pub truncation: f64,
    /// Per run (a restart, a doubling of `steps` each start a new run).
    /// Default 30: converging runs take about 8; a run still short of
    /// [`CONVERGED`] after 30 is nearly always creeping along a local
    /// minimum, and the restarts do better than more iterations (measured:
    /// 30,000 of 30,000 random pairs converge with 20, 30, 50 or 100; the
    /// lockstep solve of 1,000 takes 142 rounds with 30, 526 with 100).
    pub max_iterations: usize,
    /// Stop when `ε` (Eq. 9, in the scaled problem) falls below this.
    pub tolerance: f64,
    /// `ε` at or below which a run counts as converged (for the restarts,
    /// the truncation check and the caller): [`CONVERGED`] by default,
    /// [`CONVERGED_F32`] on an `f32` GPU ([`for_backend`](Self::for_backend)).
    pub converged: f64,
    /// `N₀`; default (`None`): the in-plane normal of the paper's Step 1.
    /// The five parameters and the two end conditions leave the start frame's
    /// rotation about `T₀` free; the paper fixes it by the plane.
    pub start_normal: Option<DVec3>,
    /// What to try, in turn, when the run from the in-plane normal ends
    /// without converging (`ε` above [`CONVERGED`] or `tolerance`,
    /// whichever is larger): a local minimum, which happens to about 2% of
    /// random pairs within a revolution. The first restart that converges
    /// is kept (if none does, the best forward run). Not used with a given
    /// `start_normal`; empty: the paper's single start.
    pub restarts: &'static [Restart],
}

/// A restart of the solve ([`SolveOptions::restarts`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Restart {
    /// The reversed problem, from `(x_f, −T_f)` to `(x₀, −T₀)`, solved from
    /// its own in-plane normal (the paper's Step 1 at the other end); the
    /// solution run backwards (Prop. 5.2) starts a forward run, which
    /// converges at once (the integrator is self-adjoint, so the reversed
    /// discrete curve is the forward one). Its start normal is the reversed
    /// curve's end normal: in general not the in-plane one.
    Reversed,
    /// `N₀` turned about `T₀` by this angle (radians), with its own planar
    /// initial guess in the plane of `T₀` and the turned `N₀`. Turning by
    /// `a` and by `a − π` is the same start (the flipped normal only flips
    /// the sign of `κ`), so angles in `(0, π)` cover all.
    Turned(f64),
}

/// The restarts of [`SolveOptions::default`]: the reversed problem, then
/// `N₀` turned by 90°, 60°, 120°, 45°, 135°, 30°, 150°. Measured on the
/// 60,000 pairs of seeds 1–6 of
/// [`random_spirals`](crate::synthetic::random_spirals)
/// (`tests/euler_random.rs`): 1,405 (2.3%) do not converge from the
/// in-plane normal; the reversed problem rescues 1,395 of them, the turned
/// normals the other 10 (90°: 3, 60°: 5, 120°: 2). Turned normals alone
/// (seeds 1–3, 722 failures) rescue 397, 253, 45, 15, 9 and 3 in this
/// order, all of them.
pub const DEFAULT_RESTARTS: [Restart; 8] = [
    Restart::Reversed,
    Restart::Turned(std::f64::consts::FRAC_PI_2),
    Restart::Turned(std::f64::consts::FRAC_PI_3),
    Restart::Turned(2.0 * std::f64::consts::FRAC_PI_3),
    Restart::Turned(std::f64::consts::FRAC_PI_4),
    Restart::Turned(3.0 * std::f64::consts::FRAC_PI_4),
    Restart::Turned(std::f64::consts::FRAC_PI_6),
    Restart::Turned(5.0 * std::f64::consts::FRAC_PI_6),
];

/// `ε` (scaled) at or below which a run counts as converged for the
/// restart and truncation logic: `|r| ≤ 1e-10 |x_f − x₀|`, far below the
/// truncation error of any step count used.
pub const CONVERGED: f64 = 1e-20;

/// [`CONVERGED`] where the spirals are integrated in single precision
/// (the GPU backend in `f32`): `|r| ≤ 1e-5 |x_f − x₀|`. Rounding in `f32`
/// leaves `ε` far above [`CONVERGED`]: measured on lavapipe, 200 random
/// pairs ([`random_spirals`](crate::synthetic::random_spirals) seed 9)
/// settle between 2e-16 and 6e-14 (median 5e-15), and some runs stop
/// improving at 1e-12 to 2.3e-12; with [`CONVERGED`] every run went on to
/// the iteration cap and through every restart (112,584 iterations,
/// against 2,247 in `f64`) and still reported failure to converge.
pub const CONVERGED_F32: f64 = 1e-10;

impl SolveOptions {
    /// These options for a solve on `backend`: [`converged`] raised to
    /// what its arithmetic can reach ([`CONVERGED_F32`] on an `f32` GPU,
    /// and [`tolerance`] to a thousandth of it; unchanged otherwise). [`solve_spirals`](super::solve_spirals) uses
    /// them; a caller checking [`SpiralSolution::error`] should compare it
    /// with [`converged_below`](Self::converged_below) of these.
    ///
    /// [`tolerance`]: Self::tolerance
    /// [`converged`]: Self::converged
    ///
    /// ```
    /// use strandfit::euler::{SolveOptions, CONVERGED};
    /// use strandfit::Backend;
    ///
    /// let opts = SolveOptions::default().for_backend(&Backend::Cpu);
    /// assert_eq!(opts, SolveOptions::default());
    /// assert_eq!(opts.converged_below(), CONVERGED);
    /// ```
    pub fn for_backend(&self, backend: &crate::Backend) -> SolveOptions {
        let floor = match backend {
            crate::Backend::Gpu(g) if g.precision == crate::gpu::Precision::F32 => CONVERGED_F32,
            _ => return *self,
        };
        SolveOptions {
            // Iterate down to f32's rounding (runs that stagnate before
            // stop on their own, measured between 1e-12 and 2.3e-12),
            // count success at the floor: the end checked at another step
            // count may land a little above where the iteration stopped.
            // Measured (100 pairs, lavapipe): stopping at 1e-12 took 1,829
            // iterations, at 1e-13 2,409, at 1e-14 5,925 (f64: 1,201).
            tolerance: self.tolerance.max(floor * 1e-3),
            converged: self.converged.max(floor),
            ..*self
        }
    }

    /// The `ε` at or below which a run counts as converged under these
    /// options: [`tolerance`](Self::tolerance) or
    /// [`converged`](Self::converged), whichever is larger.
    ///
    /// ```
    /// use strandfit::euler::{SolveOptions, CONVERGED};
    ///
    /// assert_eq!(SolveOptions::default().converged_below(), CONVERGED);
    /// let loose = SolveOptions { tolerance: 1e-12, ..Default::default() };
    /// assert_eq!(loose.converged_below(), 1e-12);
    /// ```
    pub fn converged_below(&self) -> f64 {
        self.tolerance.max(self.converged)
    }
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            steps: 32,
            max_steps: 1024,
            truncation: 1e-7,
            max_iterations: 30,
            tolerance: 1e-24,
            converged: CONVERGED,
            start_normal: None,
            restarts: &DEFAULT_RESTARTS,
        }
    }
}

/// The solved spiral, its error `ε` (Eq. 9, in the input's units, at the
/// `steps` used), the iterations used (all runs) and how it was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpiralSolution {
    /// The spiral found.
    pub problem: FrenetProblem,
    /// The residual of the end conditions (relative to the chord) at the solution.
    pub error: f64,
    /// Levenberg–Marquardt iterations, over all starts.
    pub iterations: usize,
    /// Integration steps of the final run (after the truncation check).
    pub steps: usize,
    /// The estimated truncation error of the end at `steps` (as
    /// [`SolveOptions::truncation`]; 0 when the check is off or the solve
    /// did not converge).
    pub truncation: f64,
    /// Which start gave it: 0 the in-plane normal, `i` the `i`-th of
    /// [`SolveOptions::restarts`].
    pub start: usize,
}

/// Why no spiral was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    #[error("the end points coincide")]
    /// The end points coincide.
    Coincident,
    #[error("an input is not finite, or a tangent is zero")]
    /// An input is not finite, or a tangent is zero.
    BadInput,
    #[error("integration: {0}")]
    /// The Frenet integration refused a problem.
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

/// LM's damping: `λ` at the start of a run, its factor after an accepted
/// step and after a rejected one. Starting small (a nearly Gauss–Newton
/// first step from the planar guess) took 14% fewer iterations than
/// `λ₀ = 1e-3` on 20,000 random pairs, with the same pairs converging.
pub(crate) const LAMBDA0: f64 = 1e-6;
pub(crate) const LAMBDA_DOWN: f64 = 0.3;
pub(crate) const LAMBDA_UP: f64 = 10.0;

/// Solve `(A + λ diag A) Δ = −g` for the 5×5 normal equations: Gaussian
/// elimination with partial pivoting on the stack (a general LU, as faer's
/// was, without its allocations: they were a tenth of the solve's time).
/// `None` when a pivot vanishes or the step is not finite.
pub(crate) fn lm_step(a: &[[f64; 5]; 5], g: &[f64; 5], lambda: f64) -> Option<[f64; 5]> {
    let mut m = *a;
    let mut x: [f64; 5] = std::array::from_fn(|i| -g[i]);
    for i in 0..5 {
        m[i][i] += lambda * a[i][i].max(1e-12);
    }
    for col in 0..5 {
        let piv = (col..5)
            .max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))
            .expect("a row");
        if m[piv][col] == 0.0 {
            return None;
        }
        m.swap(col, piv);
        x.swap(col, piv);
        for row in col + 1..5 {
            let f = m[row][col] / m[col][col];
            for k in col..5 {
                m[row][k] -= f * m[col][k];
            }
            x[row] -= f * x[col];
        }
    }
    for col in (0..5).rev() {
        let tail: f64 = (col + 1..5).map(|k| m[col][k] * x[k]).sum();
        x[col] = (x[col] - tail) / m[col][col];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
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

    /// The residual of `p`, integrated in `steps` steps, and its Jacobian
    /// (one march; `L` clamped at 0 as in [`problem`](Self::problem)).
    pub fn residual_and_jacobian(&self, p: &[f64; 5], steps: usize) -> ([f64; 6], [[f64; 5]; 6]) {
        let (end, dx, dt) = self.problem(p).integrate_with_derivatives_unchecked(steps);
        let mut jac = [[0.0; 5]; 6];
        for k in 0..5 {
            for i in 0..3 {
                jac[i][k] = dx[k][i];
                jac[3 + i][k] = dt[k][i];
            }
        }
        (self.residual(&end), jac)
    }

    /// The solution in the input's units, validated, with its Eq. 9 error
    /// against `x_f` re-integrated in `steps` steps by the reference
    /// integrator (no truncation estimate).
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
            steps,
            truncation: 0.0,
            start: 0,
        })
    }

    /// The solution of a run in the input's units, validated; its Eq. 9
    /// error from the run's last residual (`r` is scaled by `1/D` in
    /// position, so `ε = D²|r_x|² + |r_T|²`).
    pub(crate) fn finish(&self, x0: DVec3, run: &Run) -> Result<SpiralSolution, SolveError> {
        let problem = self.unscale(x0, &run.p);
        problem.validate()?;
        let r = &run.r;
        let error = self.scale * self.scale * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
            + (r[3] * r[3] + r[4] * r[4] + r[5] * r[5]);
        Ok(SpiralSolution {
            problem,
            error,
            iterations: run.iterations,
            steps: run.steps,
            truncation: run.truncation,
            start: run.start,
        })
    }

    /// The truncation estimate of [`SolveOptions::truncation`] for `p`
    /// whose residual at `steps` is `r`: the end at `steps/2` against it.
    pub(crate) fn truncation_estimate(&self, p: &[f64; 5], r: &[f64; 6], steps: usize) -> f64 {
        let (half, _, _) = self
            .problem(p)
            .integrate_with_derivatives_unchecked((steps / 2).max(1));
        self.truncation_of(r, &self.residual(&half))
    }

    /// `max(|Δx|/|d|, |ΔT|)/15` between the residuals at `N` and `N/2`.
    pub(crate) fn truncation_of(&self, r: &[f64; 6], r_half: &[f64; 6]) -> f64 {
        let d: [f64; 6] = std::array::from_fn(|i| r[i] - r_half[i]);
        let dx = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / self.target.length();
        let dt = (d[3] * d[3] + d[4] * d[4] + d[5] * d[5]).sqrt();
        dx.max(dt) / 15.0
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

/// Where a solve ended: parameters, residual and `ε` at `steps`, the
/// iterations so far, the truncation estimate and the start used.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Run {
    pub p: [f64; 5],
    pub r: [f64; 6],
    pub err: f64,
    pub iterations: usize,
    pub steps: usize,
    pub truncation: f64,
    pub start: usize,
}

/// `ε` at or below which a run has converged under `opts`.
pub(crate) fn converged(err: f64, opts: &SolveOptions) -> bool {
    err <= opts.converged_below()
}

/// The first step count of a solve.
pub(crate) fn first_steps(opts: &SolveOptions) -> usize {
    opts.steps.max(2)
}

/// The next step count if a converged solve at `steps` with truncation
/// estimate `trunc` must go on, else `None`.
pub(crate) fn refine_steps(trunc: f64, steps: usize, opts: &SolveOptions) -> Option<usize> {
    (trunc > opts.truncation && steps < opts.max_steps).then(|| (2 * steps).min(opts.max_steps))
}

/// How many starts a solve may use (the first and the restarts).
pub(crate) fn starts(opts: &SolveOptions) -> usize {
    if opts.start_normal.is_some() {
        1
    } else {
        1 + opts.restarts.len()
    }
}

/// The problem a restart solves first: the forward problem with the turned
/// normal, or the reversed problem ([`Restart::Reversed`]).
pub(crate) fn restart_problem(
    pair: &crate::pair::HermitePair,
    base: &Scaled,
    restart: Restart,
) -> Result<Scaled, SolveError> {
    let (x0, t0, xf, tf) = (*pair).into();
    match restart {
        Restart::Reversed => Scaled::new(xf, -tf, x0, -t0, None),
        Restart::Turned(a) => {
            let [_, n0, b0] = base.frame;
            Scaled::new(x0, t0, xf, tf, Some(a.cos() * n0 + a.sin() * b0))
        }
    }
}

/// The forward problem and parameters of a solved reversed problem
/// (`rev`, parameters `p` at `steps`): the reversed curve run backwards
/// (Prop. 5.2), its start normal the reversed curve's end normal.
/// Both problems share the scale `D` (`x_f − x₀` only changes sign), so the
/// scaled parameters convert as the unscaled ones.
pub(crate) fn forward_from_reversed(
    pair: &crate::pair::HermitePair,
    rev: &Scaled,
    p: &[f64; 5],
    steps: usize,
) -> Result<(Scaled, [f64; 5]), SolveError> {
    let (x0, t0, xf, tf) = (*pair).into();
    let end = rev.problem(p).integrate_unchecked(steps);
    let sc = Scaled::new(x0, t0, xf, tf, Some(end.frame[1]))?;
    let l = p[4];
    Ok((sc, [p[0] + p[1] * l, -p[1], p[2] + p[3] * l, -p[3], l]))
}

/// Levenberg–Marquardt from `p` at `steps`, with the one-march Jacobian
/// ([`FrenetProblem::integrate_with_derivatives_unchecked`]).
pub(crate) fn lm(sc: &Scaled, p: [f64; 5], steps: usize, opts: &SolveOptions) -> Run {
    let dl = sc.target.length();
    let mut p = p;
    let (mut r, mut jac) = sc.residual_and_jacobian(&p, steps);
    let mut err = norm2(&r);
    let mut lambda = LAMBDA0;
    let mut iterations = 0;
    while iterations < opts.max_iterations && err > opts.tolerance {
        iterations += 1;
        let (a, g) = normal_equations(&jac, &r);
        let mut improved = false;
        for _ in 0..30 {
            let Some(step) = lm_step(&a, &g, lambda) else {
                lambda *= LAMBDA_UP;
                continue;
            };
            let mut q = p;
            for k in 0..5 {
                q[k] += step[k];
            }
            q[4] = q[4].max(1e-3 * dl);
            let (rq, jq) = sc.residual_and_jacobian(&q, steps);
            let eq = norm2(&rq);
            if eq < err {
                p = q;
                r = rq;
                jac = jq;
                err = eq;
                lambda = (lambda * LAMBDA_DOWN).max(1e-15);
                improved = true;
                break;
            }
            lambda *= LAMBDA_UP;
        }
        if !improved {
            break; // at a (local) minimum to rounding
        }
    }
    Run {
        p,
        r,
        err,
        iterations,
        steps,
        truncation: 0.0,
        start: 0,
    }
}

/// A forward run: LM from `p` at `steps`, then the truncation check
/// (doubling the steps and resuming while it fails).
fn solve_from(sc: &Scaled, p: [f64; 5], steps: usize, opts: &SolveOptions) -> Run {
    let mut run = lm(sc, p, steps, opts);
    while converged(run.err, opts) && opts.truncation.is_finite() {
        run.truncation = sc.truncation_estimate(&run.p, &run.r, run.steps);
        let Some(steps) = refine_steps(run.truncation, run.steps, opts) else {
            break;
        };
        let more = lm(sc, run.p, steps, opts);
        run = Run {
            iterations: run.iterations + more.iterations,
            ..more
        };
    }
    run
}

/// The spiral from `(x0, t0)` to `(xf, tf)` (tangents need not be unit).
///
/// ```
/// use strandfit::euler::{solve_spiral, SolveOptions};
/// use strandfit::DVec3;
///
/// // A quarter of the unit circle: the spiral is the arc (γ = τ₀ = δ = 0).
/// let s = solve_spiral(DVec3::X, DVec3::Y, DVec3::Y, -DVec3::X, &SolveOptions::default()).unwrap();
/// assert!((s.problem.kappa0 - 1.0).abs() < 1e-6);
/// assert!((s.problem.length - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
/// ```
///
/// # Method
///
/// Levenberg–Marquardt on the end conditions: the fast solver (the paper's own
/// coordinate descent, Algorithm 1, is [`paper_spiral`](super::paper_spiral)).
///
/// Given `(x₀, T₀)` and `(x_f, T_f)`, find `(κ₀, γ, τ₀, δ, L)` so that the
/// spiral from `x₀` with frame `[T₀, N₀, T₀ × N₀]` ends at `x_f` with tangent
/// `T_f`. Residual (six components, Eq. 9 of paper 004 is its squared norm):
///
/// ```text
/// r = (x(L) − x_f, T(L) − T_f)
/// ```
///
/// As in the paper (Section 6), the problem is translated by `−x₀` and scaled
/// by `D = max |x_f − x₀|` per axis, solved, and scaled back (Prop. 5.1:
/// curvatures scale by `1/D`, their rates by `1/D²`, `L` by `D`). `N₀` is
/// the in-plane normal `normalize(d − (d·T₀)T₀)`, `d = x_f − x₀`
/// (ERRATA 004.2).
///
/// Initial guess (the paper's Step 1): the planar clothoid G1 fit in the
/// plane of `T₀` and `d` to `T_f`'s projection, `τ₀ = δ = 0`.
///
/// **Residual and Jacobian.** Candidates are integrated with the fourth-order
/// scheme of [`FrenetProblem`](super::FrenetProblem) at a fixed step count per
/// run, so residuals are smooth in the parameters; one march gives the end and
/// the Jacobian together
/// ([`FrenetProblem::integrate_with_derivatives_unchecked`]: the variational
/// integrals of the Frenet equations by Simpson's rule), about 1.3 plain
/// marches where central differences took ten.
///
/// **Steps.** A run starts at [`SolveOptions::steps`] (32); once it
/// converges, the end at half the steps estimates the truncation error
/// (fourth order: the difference over 15); above
/// [`SolveOptions::truncation`] (1e-7 of `|x_f − x₀|`) the steps double and
/// LM resumes from the solution (one or two iterations). About half of
/// random pairs within a revolution stop at 32 steps, nearly all others at
/// 64.
///
/// **Restarts.** About 2% of random pairs within a revolution leave LM in a
/// local minimum from the in-plane start. [`SolveOptions::restarts`] then
/// solves the reversed problem from its own in-plane start and runs the
/// solution backwards ([`Restart::Reversed`]: on 60,000 random pairs it
/// rescued 1,395 of the 1,405 failures), then tries turned start normals
/// ([`Restart::Turned`]: the other 10). See [`DEFAULT_RESTARTS`].
pub fn solve_spiral(
    x0: DVec3,
    t0: DVec3,
    xf: DVec3,
    tf: DVec3,
    opts: &SolveOptions,
) -> Result<SpiralSolution, SolveError> {
    let pair = crate::pair::HermitePair::new(x0, t0, xf, tf);
    let base = Scaled::new(x0, t0, xf, tf, opts.start_normal)?;
    // The best forward run so far, with its problem (`None`: `base`).
    let mut best: Option<(Option<Scaled>, Run)> = None;
    let mut iterations = 0;
    let first = first_steps(opts);
    for i in 0..starts(opts) {
        let (sc, mut run) = if i == 0 {
            (None, solve_from(&base, base.initial, first, opts))
        } else {
            let restart = opts.restarts[i - 1];
            let sc = restart_problem(&pair, &base, restart)?;
            if restart == Restart::Reversed {
                let rev = lm(&sc, sc.initial, first, opts);
                iterations += rev.iterations;
                if !converged(rev.err, opts) {
                    continue;
                }
                let (fwd, p) = forward_from_reversed(&pair, &sc, &rev.p, rev.steps)?;
                let run = solve_from(&fwd, p, rev.steps, opts);
                (Some(fwd), run)
            } else {
                let run = solve_from(&sc, sc.initial, first, opts);
                (Some(sc), run)
            }
        };
        run.start = i;
        iterations += run.iterations;
        let done = converged(run.err, opts);
        if best.as_ref().is_none_or(|b| run.err < b.1.err) {
            best = Some((sc, run));
        }
        if done {
            break;
        }
    }
    let (sc, mut run) = best.expect("the first start is always a forward run");
    run.iterations = iterations;
    sc.as_ref().unwrap_or(&base).finish(x0, &run)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The solved end against `(xf, tf)`, the curve integrated finely:
    /// position relative to `|xf − x₀|`, tangent absolute, within twice the
    /// default truncation tolerance (the solve meets its own discrete end
    /// to ~1e-12; the rest is the truncation error it allows).
    fn check_end(s: &SpiralSolution, xf: DVec3, tf: DVec3) {
        let tol = 2.0 * SolveOptions::default().truncation;
        let e = s.problem.integrate(4096).unwrap();
        let d = xf.distance(s.problem.start);
        assert!(e.point.distance(xf) < tol * d, "end {} vs {xf}", e.point);
        assert!(
            e.frame[0].distance(tf.normalize()) < tol,
            "tangent {} vs {tf}",
            e.frame[0]
        );
        assert!(s.truncation <= SolveOptions::default().truncation);
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
            // The frame of a circle is exact at any step count (constant
            // ω); Simpson's position error, ≈ (θ/steps)⁴, is absorbed by κ₀
            // and L, which are off by the truncation estimate (measured:
            // equal to it to two digits, 8.5e-9 at θ = 4.5 and 64 steps).
            assert!(s.truncation <= 1e-7, "{}", s.truncation);
            let tol = 2.0 * s.truncation + 1e-12;
            assert!(
                (p.kappa0 * r - 1.0).abs() < tol,
                "θ = {theta}: κ₀ = {}, truncation {:e}",
                p.kappa0,
                s.truncation
            );
            assert!(
                p.gamma.abs() < 1e-9 && p.tau0.abs() < 1e-9 && p.delta.abs() < 1e-9,
                "{p:?}"
            );
            assert!(
                (p.length / (r * theta) - 1.0).abs() < tol,
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
        check_end(&s, end.point, end.frame[0]);
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
        check_end(&other, tr(xf), rot * tf);
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
