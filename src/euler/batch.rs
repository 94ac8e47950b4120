//! Many spirals at once: the Levenberg–Marquardt solve of
//! [`solve`](super::solve) run in lockstep over a batch of pairs, with every
//! curve evaluation of an iteration — the ten Jacobian columns' `±h`
//! candidates of every pair, then one trial step per pair — in one
//! [`Backend::integrate`] call: one `frenet_integrate` dispatch per stage on
//! the GPU backend, rayon on the CPU backend.
//!
//! Lockstep changes one thing against the sequential solver: a rejected
//! trial raises `λ` and waits for the next round instead of retrying at
//! once, so a pair may take more rounds; each round costs two batched
//! calls for the whole batch.

use glam::DVec3;

use super::frenet::{FrenetEnd, FrenetProblem};
use super::solve::{
    lm_step, norm2, normal_equations, Scaled, SolveError, SolveOptions, SpiralSolution,
};
use crate::backend::Backend;
use crate::gpu::GpuError;

/// One pair: `(x₀, T₀, x_f, T_f)`.
pub type Pair = (DVec3, DVec3, DVec3, DVec3);

struct State {
    sc: Scaled,
    x0: DVec3,
    p: [f64; 5],
    r: [f64; 6],
    err: f64,
    lambda: f64,
    iterations: usize,
    done: bool,
}

/// A failed integration (a candidate the validator refuses) counts as an
/// infinitely bad residual, so the step is rejected.
fn end_residual(sc: &Scaled, e: &Result<FrenetEnd, super::FrenetError>) -> [f64; 6] {
    match e {
        Ok(e) => sc.residual(e),
        Err(_) => [f64::INFINITY; 6],
    }
}

/// Solve every pair; results in input order. A pair's own bad input is its
/// `Err`; a GPU failure fails the whole call.
pub fn solve_spirals(
    pairs: &[Pair],
    opts: &SolveOptions,
    backend: &Backend,
) -> Result<Vec<Result<SpiralSolution, SolveError>>, GpuError> {
    let steps = opts.steps.max(1);
    let mut states: Vec<Result<State, SolveError>> = pairs
        .iter()
        .map(|&(x0, t0, xf, tf)| {
            let sc = Scaled::new(x0, t0, xf, tf, opts.start_normal)?;
            let p = sc.initial;
            Ok(State {
                sc,
                x0,
                p,
                r: [0.0; 6],
                err: f64::INFINITY,
                lambda: 1e-3,
                iterations: 0,
                done: false,
            })
        })
        .collect();
    // Initial residuals.
    let live: Vec<usize> = (0..states.len()).filter(|&i| states[i].is_ok()).collect();
    let probs: Vec<FrenetProblem> = live
        .iter()
        .map(|&i| {
            let s = states[i].as_ref().expect("live");
            s.sc.problem(&s.p)
        })
        .collect();
    let ends = backend.integrate(&probs, steps)?;
    for (&i, e) in live.iter().zip(&ends) {
        let s = states[i].as_mut().expect("live");
        s.r = end_residual(&s.sc, e);
        s.err = norm2(&s.r);
        s.done = s.err <= opts.tolerance;
    }
    for _round in 0..4 * opts.max_iterations.max(1) {
        let active: Vec<usize> = (0..states.len())
            .filter(|&i| matches!(&states[i], Ok(s) if !s.done))
            .collect();
        if active.is_empty() {
            break;
        }
        // Stage 1: the Jacobian candidates of every active pair.
        let mut probs = Vec::with_capacity(10 * active.len());
        let mut hs = Vec::with_capacity(5 * active.len());
        for &i in &active {
            let s = states[i].as_ref().expect("active");
            for k in 0..5 {
                let h = 1e-6 * (1.0 + s.p[k].abs());
                hs.push(h);
                for sign in [1.0, -1.0] {
                    let mut q = s.p;
                    q[k] += sign * h;
                    probs.push(s.sc.problem(&q));
                }
            }
        }
        let ends = backend.integrate(&probs, steps)?;
        // Stage 2: one trial step per pair.
        let mut trials = Vec::with_capacity(active.len());
        let mut trial_p = Vec::with_capacity(active.len());
        for (a, &i) in active.iter().enumerate() {
            let s = states[i].as_mut().expect("active");
            let mut jac = [[0.0; 5]; 6];
            for k in 0..5 {
                let rp = end_residual(&s.sc, &ends[10 * a + 2 * k]);
                let rm = end_residual(&s.sc, &ends[10 * a + 2 * k + 1]);
                for row in 0..6 {
                    jac[row][k] = (rp[row] - rm[row]) / (2.0 * hs[5 * a + k]);
                }
            }
            let (am, g) = normal_equations(&jac, &s.r);
            let mut q = s.p;
            if let Some(step) = lm_step(&am, &g, s.lambda) {
                for k in 0..5 {
                    q[k] += step[k];
                }
            }
            q[4] = q[4].max(1e-3 * s.sc.target.length());
            trials.push(s.sc.problem(&q));
            trial_p.push(q);
        }
        let ends = backend.integrate(&trials, steps)?;
        for (a, &i) in active.iter().enumerate() {
            let s = states[i].as_mut().expect("active");
            s.iterations += 1;
            let rq = end_residual(&s.sc, &ends[a]);
            let eq = norm2(&rq);
            if eq < s.err {
                s.p = trial_p[a];
                s.r = rq;
                s.err = eq;
                s.lambda = (s.lambda * 0.3).max(1e-15);
            } else {
                s.lambda *= 10.0;
            }
            // At a minimum to rounding (no step helps even when tiny), at
            // the tolerance, or out of iterations.
            s.done = s.err <= opts.tolerance
                || s.lambda > 1e16
                || s.iterations >= 4 * opts.max_iterations;
        }
    }
    Ok(states
        .into_iter()
        .zip(pairs)
        .map(|(st, &(_, _, xf, _))| {
            let s = st?;
            s.sc.solution(s.x0, xf, &s.p, steps, s.iterations)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::euler::solve::solve_spiral;

    /// Pairs from the ends of random spirals (turning up to about a turn).
    pub(crate) fn random_pairs(n: usize, seed: u64) -> Vec<Pair> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let t = DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                );
                let t = t.try_normalize().unwrap_or(DVec3::X);
                let n = t.any_orthonormal_vector();
                let p = FrenetProblem::new(
                    DVec3::new(rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0), 0.0),
                    t,
                    n,
                    rng.gen_range(0.1..1.5),
                    rng.gen_range(-0.5..0.5),
                    rng.gen_range(-0.8..0.8),
                    rng.gen_range(-0.3..0.3),
                    rng.gen_range(0.5..3.0),
                );
                let e = p.integrate(2048).unwrap();
                (p.start, t, e.point, e.frame[0])
            })
            .collect()
    }

    #[test]
    fn batched_cpu_matches_the_sequential_solver() {
        let pairs = random_pairs(200, 5);
        let batch = solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap();
        let (mut both, mut agree) = (0, 0);
        for (pair, b) in pairs.iter().zip(&batch) {
            let s = solve_spiral(pair.0, pair.1, pair.2, pair.3, &SolveOptions::default()).unwrap();
            let b = b.as_ref().unwrap();
            if s.error < 1e-20 && b.error < 1e-20 {
                both += 1;
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
        eprintln!("{both}/200 converged in both; {agree} to the same spiral");
        // Both converge on nearly all; where both do, to the same spiral
        // (the lockstep λ schedule may pick another local solution rarely).
        assert!(both >= 190, "{both}");
        assert!(agree >= both - 2, "{agree} of {both}");
    }

    #[test]
    fn bad_pairs_fail_alone() {
        let mut pairs = random_pairs(3, 1);
        pairs[1].2 = pairs[1].0; // coincident ends
        let r = solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu).unwrap();
        assert!(r[0].is_ok() && r[2].is_ok());
        assert_eq!(r[1].as_ref().unwrap_err(), &SolveError::Coincident);
    }
}
