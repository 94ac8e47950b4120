//! Many spirals at once: `solve_spirals`, and the lockstep solve it runs on
//! the GPU (`solve_spirals_lockstep`, whose documentation describes it).

use super::frenet::{FrenetEnd, FrenetProblem};
use super::solve::{
    converged, first_steps, forward_from_reversed, lm_step, norm2, normal_equations, refine_steps,
    restart_problem, starts, Restart, Run, Scaled, SolveError, SolveOptions, SpiralSolution,
    LAMBDA0, LAMBDA_DOWN, LAMBDA_UP,
};
use crate::backend::Backend;
use crate::backend::GpuError;
use crate::euler::solve_spiral;
use crate::pair::HermitePair;

/// Solve every pair; results in input order. A pair's own bad input is its
/// `Err`; a GPU failure fails the whole call.
///
/// On the CPU backend this is [`solve_spiral`] on every pair (rayon): the
/// same answers as one at a time, by construction. On the GPU backend it is
/// [`solve_spirals_lockstep`]: the same solve, run in lockstep over the
/// batch (see there).
///
/// Each solved spiral meets its end conditions:
/// ```
/// use strandfit::euler::{solve_spirals, SolveOptions};
/// use strandfit::{Backend, DVec3, HermitePair};
///
/// let pairs = [
///     HermitePair::new(DVec3::X, DVec3::Y, DVec3::Y, -DVec3::X),
///     HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.5), DVec3::new(0.0, 1.0, 1.0)),
/// ];
/// let out = solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap();
/// for (pair, s) in pairs.iter().zip(out) {
///     let s = s.unwrap();
///     let end = s.problem.integrate(s.steps).unwrap();
///     assert!((end.point - pair.p1).length() < 1e-9);
///     assert!((end.frame[0] - pair.t1.normalize()).length() < 1e-9);
/// }
/// ```
pub fn solve_spirals(
    pairs: &[HermitePair],
    opts: &SolveOptions,
    backend: &Backend,
) -> Result<Vec<Result<SpiralSolution, SolveError>>, GpuError> {
    use rayon::prelude::*;
    match backend {
        Backend::Cpu => Ok(pairs
            .par_iter()
            .map(|p| solve_spiral(p.p0, p.t0, p.p1, p.t1, opts))
            .collect()),
        Backend::Gpu(_) => solve_spirals_lockstep(pairs, opts, backend),
    }
}

/// What a pair's lockstep solve does next.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// A run begins at `p`: its residual is needed.
    Begin,
    /// LM rounds.
    Lm,
    /// Converged: the end at `steps/2` is needed for the truncation check.
    Check,
    Done,
}

struct State {
    /// Start 0's problem (the in-plane or given normal).
    base: Scaled,
    /// The current run's problem (`None`: `base`).
    sc: Option<Scaled>,
    /// Whether the current run solves the reversed problem (the first leg
    /// of [`Restart::Reversed`]).
    reversed: bool,
    pair: HermitePair,
    /// The current run (`r`, `err` valid from `Lm` on).
    run: Run,
    lambda: f64,
    /// Iterations of the current run, and of all before it.
    run_iterations: usize,
    total_iterations: usize,
    /// The best finished forward run so far, with its problem.
    best: Option<(Option<Scaled>, Run)>,
    phase: Phase,
}

impl State {
    fn sc(&self) -> &Scaled {
        self.sc.as_ref().unwrap_or(&self.base)
    }

    /// A run at `steps` from `p` (of the current problem).
    fn begin(&mut self, p: [f64; 5], steps: usize) {
        self.run.p = p;
        self.run.steps = steps;
        self.run.truncation = 0.0;
        self.lambda = LAMBDA0;
        self.run_iterations = 0;
        self.phase = Phase::Begin;
    }

    /// The current start ended (converged and checked, or not converged):
    /// keep a forward run if best, then the next start or done.
    fn end_start(&mut self, opts: &SolveOptions) {
        let done = !self.reversed && converged(self.run.err, opts);
        if !self.reversed && self.best.as_ref().is_none_or(|b| self.run.err < b.1.err) {
            self.best = Some((self.sc.take(), self.run));
        }
        let next = self.run.start + 1;
        if done || next >= starts(opts) {
            self.phase = Phase::Done;
            return;
        }
        let restart = opts.restarts[next - 1];
        match restart_problem(&self.pair, &self.base, restart) {
            Ok(sc) => {
                let p = sc.initial;
                self.sc = Some(sc);
                self.reversed = restart == Restart::Reversed;
                self.run.start = next;
                self.begin(p, first_steps(opts));
            }
            Err(_) => self.phase = Phase::Done,
        }
    }

    /// The current run has stopped iterating.
    fn end_run(&mut self, opts: &SolveOptions) {
        self.total_iterations += self.run_iterations;
        let ok = converged(self.run.err, opts);
        if self.reversed {
            // The reversed leg: on to the forward run from its solution.
            let forward = ok
                .then(|| forward_from_reversed(&self.pair, self.sc(), &self.run.p, self.run.steps))
                .and_then(Result::ok);
            match forward {
                Some((sc, p)) => {
                    self.sc = Some(sc);
                    self.reversed = false;
                    let steps = self.run.steps;
                    self.begin(p, steps);
                }
                None => self.end_start(opts),
            }
        } else if ok && opts.truncation.is_finite() {
            self.phase = Phase::Check;
        } else {
            self.end_start(opts);
        }
    }
}

/// A failed integration (a candidate the validator refuses) counts as an
/// infinitely bad residual, so the step is rejected.
fn end_residual(sc: &Scaled, e: &Result<FrenetEnd, super::FrenetError>) -> [f64; 6] {
    match e {
        Ok(e) => sc.residual(e),
        Err(_) => [f64::INFINITY; 6],
    }
}

/// Integrate `(problem, steps)` items with one backend call per distinct
/// step count; ends in input order.
fn integrate_grouped(
    backend: &Backend,
    items: &[(FrenetProblem, usize)],
) -> Result<Vec<Result<FrenetEnd, super::FrenetError>>, GpuError> {
    let mut counts: Vec<usize> = items.iter().map(|i| i.1).collect();
    counts.sort_unstable();
    counts.dedup();
    let mut out: Vec<Option<Result<FrenetEnd, super::FrenetError>>> = vec![None; items.len()];
    for steps in counts {
        let idx: Vec<usize> = (0..items.len()).filter(|&i| items[i].1 == steps).collect();
        let probs: Vec<FrenetProblem> = idx.iter().map(|&i| items[i].0).collect();
        for (&i, e) in idx.iter().zip(backend.integrate(&probs, steps)?) {
            out[i] = Some(e);
        }
    }
    Ok(out
        .into_iter()
        .map(|e| e.expect("every item integrated"))
        .collect())
}

/// The lockstep solve (see [Method](solve_spirals_lockstep#method)) through any
/// backend: what [`solve_spirals`] runs on the GPU; on the CPU backend, for
/// tests and comparison.
///
/// The lockstep solve (here on the CPU) reaches the same spiral as
/// [`solve_spiral`]:
/// ```
/// use strandfit::euler::{solve_spiral, solve_spirals_lockstep, SolveOptions};
/// use strandfit::{Backend, DVec3, HermitePair};
///
/// let pair = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.5), DVec3::new(0.0, 1.0, 1.0));
/// let opts = SolveOptions::default();
/// let lock = solve_spirals_lockstep(&[pair], &opts, &Backend::Cpu).unwrap().remove(0).unwrap();
/// let one = solve_spiral(pair.p0, pair.t0, pair.p1, pair.t1, &opts).unwrap();
/// assert!((lock.problem.kappa0 - one.problem.kappa0).abs() < 1e-6);
/// assert!((lock.problem.length - one.problem.length).abs() < 1e-6);
/// ```
///
/// # Method
///
/// The same solve as [`solve_spiral`] — the same starts, restarts and
/// truncation check of [`SolveOptions`] — run in lockstep over the batch,
/// with every curve evaluation of a round in one [`Backend::integrate`] call
/// per step count in use (one `frenet_integrate` dispatch each on the GPU;
/// the first count and a doubling or two): first the initial residuals of
/// runs that begin (a start, a restart, a doubling of the steps) and the
/// half-step ends of the truncation checks, then the ten Jacobian columns'
/// `±h` candidates of every pair (central differences: the kernel returns
/// ends, not derivatives), then one trial step per pair.
///
/// Lockstep differs from the sequential solver in two ways: the Jacobian is
/// by central differences instead of [`solve_spiral`]'s one-march
/// derivatives (the same residual, so the same solutions, reached by a
/// slightly different path), and a rejected trial raises `λ` and waits for
/// the next round instead of retrying at once, so a pair may take more
/// rounds (each run is allowed `4 × max_iterations`).
pub fn solve_spirals_lockstep(
    pairs: &[HermitePair],
    opts: &SolveOptions,
    backend: &Backend,
) -> Result<Vec<Result<SpiralSolution, SolveError>>, GpuError> {
    // Convergence as the backend's arithmetic allows (f32: CONVERGED_F32).
    let opts = &opts.for_backend(backend);
    let max_rounds = 4 * opts.max_iterations.max(1);
    let mut states: Vec<Result<State, SolveError>> = pairs
        .iter()
        .map(|&pair| {
            let (x0, t0, xf, tf) = pair.into();
            let base = Scaled::new(x0, t0, xf, tf, opts.start_normal)?;
            let p = base.initial;
            let mut s = State {
                base,
                sc: None,
                reversed: false,
                pair,
                run: Run {
                    p,
                    r: [0.0; 6],
                    err: f64::INFINITY,
                    iterations: 0,
                    steps: 0,
                    truncation: 0.0,
                    start: 0,
                },
                lambda: LAMBDA0,
                run_iterations: 0,
                total_iterations: 0,
                best: None,
                phase: Phase::Begin,
            };
            s.begin(p, first_steps(opts));
            Ok(s)
        })
        .collect();
    loop {
        // Stage 0: residuals of runs that begin, half-step ends of checks.
        let mut items = Vec::new();
        let mut who = Vec::new();
        for (i, s) in states.iter().enumerate() {
            let Ok(s) = s else { continue };
            match s.phase {
                Phase::Begin => items.push((s.sc().problem(&s.run.p), s.run.steps)),
                Phase::Check => items.push((s.sc().problem(&s.run.p), (s.run.steps / 2).max(1))),
                _ => continue,
            }
            who.push(i);
        }
        let ends = integrate_grouped(backend, &items)?;
        for (&i, e) in who.iter().zip(&ends) {
            let s = states[i].as_mut().expect("live");
            let r = end_residual(s.sc(), e);
            if s.phase == Phase::Begin {
                s.run.r = r;
                s.run.err = norm2(&r);
                s.phase = Phase::Lm;
                if s.run.err <= opts.tolerance {
                    s.end_run(opts);
                }
            } else {
                s.run.truncation = s.sc().truncation_of(&s.run.r, &r);
                match refine_steps(s.run.truncation, s.run.steps, opts) {
                    Some(steps) => {
                        let p = s.run.p;
                        s.begin(p, steps);
                    }
                    None => s.end_start(opts),
                }
            }
        }
        let active: Vec<usize> = (0..states.len())
            .filter(|&i| matches!(&states[i], Ok(s) if s.phase == Phase::Lm))
            .collect();
        if active.is_empty() {
            if states
                .iter()
                .all(|s| s.as_ref().map_or(true, |s| s.phase == Phase::Done))
            {
                break;
            }
            continue;
        }
        // Stage 1: the Jacobian candidates of every active pair.
        let mut items = Vec::with_capacity(10 * active.len());
        let mut hs = Vec::with_capacity(5 * active.len());
        for &i in &active {
            let s = states[i].as_ref().expect("active");
            for k in 0..5 {
                let h = 1e-6 * (1.0 + s.run.p[k].abs());
                hs.push(h);
                for sign in [1.0, -1.0] {
                    let mut q = s.run.p;
                    q[k] += sign * h;
                    items.push((s.sc().problem(&q), s.run.steps));
                }
            }
        }
        let ends = integrate_grouped(backend, &items)?;
        // Stage 2: one trial step per pair.
        let mut trials = Vec::with_capacity(active.len());
        let mut trial_p = Vec::with_capacity(active.len());
        for (a, &i) in active.iter().enumerate() {
            let s = states[i].as_ref().expect("active");
            let sc = s.sc();
            let mut jac = [[0.0; 5]; 6];
            for k in 0..5 {
                let rp = end_residual(sc, &ends[10 * a + 2 * k]);
                let rm = end_residual(sc, &ends[10 * a + 2 * k + 1]);
                for row in 0..6 {
                    jac[row][k] = (rp[row] - rm[row]) / (2.0 * hs[5 * a + k]);
                }
            }
            let (am, g) = normal_equations(&jac, &s.run.r);
            let mut q = s.run.p;
            if let Some(step) = lm_step(&am, &g, s.lambda) {
                for k in 0..5 {
                    q[k] += step[k];
                }
            }
            q[4] = q[4].max(1e-3 * sc.target.length());
            trials.push((sc.problem(&q), s.run.steps));
            trial_p.push(q);
        }
        let ends = integrate_grouped(backend, &trials)?;
        for (a, &i) in active.iter().enumerate() {
            let s = states[i].as_mut().expect("active");
            s.run_iterations += 1;
            let rq = end_residual(s.sc(), &ends[a]);
            let eq = norm2(&rq);
            if eq < s.run.err {
                s.run.p = trial_p[a];
                s.run.r = rq;
                s.run.err = eq;
                s.lambda = (s.lambda * LAMBDA_DOWN).max(1e-15);
            } else {
                s.lambda *= LAMBDA_UP;
            }
            // At the tolerance, at a minimum to rounding (no step helps
            // even when tiny), or out of iterations.
            if s.run.err <= opts.tolerance || s.lambda > 1e16 || s.run_iterations >= max_rounds {
                s.end_run(opts);
            }
        }
    }
    Ok(states
        .into_iter()
        .map(|st| {
            let s = st?;
            let (sc, mut run) = s.best.expect("a finished solve has a best start");
            run.iterations = s.total_iterations;
            sc.as_ref().unwrap_or(&s.base).finish(s.pair.p0, &run)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{random_spirals, spiral_end_pairs};

    #[test]
    fn cpu_batch_is_the_sequential_solver() {
        let pairs = spiral_end_pairs(&random_spirals(20, 3));
        let batch = solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap();
        for (p, b) in pairs.iter().zip(&batch) {
            assert_eq!(
                b,
                &solve_spiral(p.p0, p.t0, p.p1, p.t1, &SolveOptions::default())
            );
        }
    }

    /// Lockstep (central differences, λ retried by rounds) against the
    /// sequential solver (one-march derivatives): the same residual, so
    /// where both converge from the same start, the same spiral.
    #[test]
    fn lockstep_matches_the_sequential_solver() {
        let pairs = spiral_end_pairs(&random_spirals(200, 5));
        let opts = SolveOptions::default();
        let lock = solve_spirals_lockstep(&pairs, &opts, &Backend::Cpu).unwrap();
        let (mut both, mut same_start, mut agree, mut restarted) = (0, 0, 0, 0);
        for (pair, b) in pairs.iter().zip(&lock) {
            let s = solve_spiral(pair.p0, pair.t0, pair.p1, pair.t1, &opts).unwrap();
            let b = b.as_ref().unwrap();
            restarted += usize::from(b.start > 0);
            if s.error < 1e-20 && b.error < 1e-20 {
                both += 1;
                if s.start == b.start && s.steps == b.steps {
                    same_start += 1;
                    let (x, y) = (s.problem, b.problem);
                    let d = [
                        x.kappa0 - y.kappa0,
                        x.gamma - y.gamma,
                        x.tau0 - y.tau0,
                        x.delta - y.delta,
                        x.length - y.length,
                    ]
                    .iter()
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                    if d < 1e-7 {
                        agree += 1;
                    }
                }
            }
        }
        eprintln!(
            "{both}/200 converged in both; {same_start} from the same start and steps, \
             {agree} of them to the same spiral; lockstep restarted {restarted}"
        );
        assert!(both >= 199, "{both}");
        assert!(same_start >= both - 3, "{same_start} of {both}");
        assert!(agree >= same_start - 2, "{agree} of {same_start}");
    }

    #[test]
    fn bad_pairs_fail_alone() {
        let mut pairs = spiral_end_pairs(&random_spirals(3, 1));
        pairs[1].p1 = pairs[1].p0; // coincident ends
        for r in [
            solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap(),
            solve_spirals_lockstep(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap(),
        ] {
            assert!(r[0].is_ok() && r[2].is_ok());
            assert_eq!(r[1].as_ref().unwrap_err(), &SolveError::Coincident);
        }
    }
}
