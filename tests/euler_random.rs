//! The default Euler-spiral solver on 1,000 random pairs within one
//! revolution: per-pair end errors against a fine reference integration.
//!
//! Pairs: [`random_spirals`] (seed 1; start, tangent and normal uniform,
//! `κ₀ ∈ [0.1, 1.5)`, `γ ∈ [−0.5, 0.5)`, `τ₀ ∈ [−0.8, 0.8)`,
//! `δ ∈ [−0.3, 0.3)`, `L ∈ [0.5, 3)`, rejected when `∫|κ| ds > 2π`;
//! inflections kept), their ends by 4096 steps ([`spiral_end_pairs`]).
//! The solver's start normal is the in-plane one, not the generating
//! spiral's, so it finds another spiral through the same ends: the test
//! measures the ends, not the parameters.
//!
//! Error of a pair: the solved spiral integrated with 4096 steps (truncation
//! ≈ 1e-13 relative at the turning of these curves, far below what is
//! measured), `max(|x(L) − x_f| / |x_f − x₀|, |T(L) − T_f|)`. A pair
//! converges when that is below 1e-6.
//!
//! Measured (seeds 1–6, 10,000 pairs each, `--release`, the `without_restarts`
//! study below): 60,000 of 60,000 converge; worst error 9.97e-8 (the
//! truncation check's 1e-7 at work). With the paper's single start
//! (no restarts) 58,598 (97.7%) converge, the rest stopping in local minima
//! at errors up to 0.9; of the 1,405 pairs the default restarts, the
//! reversed problem rescues 1,395, turned start normals the other 10. About
//! half the pairs need more than the first 32 steps. Before this solver
//! (lockstep LM by central differences at a fixed 128 steps, one start):
//! 978 of the 1,000 pairs of the test below converged, worst 6.0e-7; of
//! seeds 1–2, 97.6% and 98.0%, worst 8.6e-7.

use strandfit::euler::{solve_spiral, solve_spirals, SolveOptions, SpiralSolution};
use strandfit::synthetic::{random_spirals, spiral_end_pairs};
use strandfit::Backend;
use strandfit::HermitePair as Pair;

/// `max(|x(L) − x_f| / |x_f − x₀|, |T(L) − T_f|)` of a solution, its end
/// integrated with 4096 steps.
fn end_error(s: &SpiralSolution, pair: &Pair) -> f64 {
    let e = s.problem.integrate(4096).expect("a valid solution");
    let (x0, _, xf, tf) = (*pair).into();
    let pos = e.point.distance(xf) / xf.distance(x0);
    let tan = e.frame[0].distance(tf.normalize());
    pos.max(tan)
}

struct Summary {
    converged: usize,
    worst_converged: f64,
    worst: f64,
    restarted: usize,
    /// Pairs solved from each start (0: the in-plane normal; `i`: the
    /// `i`-th restart).
    starts: Vec<usize>,
    refined: usize,
}

fn summarise(pairs: &[Pair], solved: &[SpiralSolution], opts: &SolveOptions) -> Summary {
    let mut s = Summary {
        converged: 0,
        worst_converged: 0.0,
        worst: 0.0,
        restarted: 0,
        starts: vec![0; 1 + opts.restarts.len()],
        refined: 0,
    };
    for (pair, sol) in pairs.iter().zip(solved) {
        let e = end_error(sol, pair);
        s.worst = s.worst.max(e);
        if e < 1e-6 {
            s.converged += 1;
            s.worst_converged = s.worst_converged.max(e);
        }
        s.restarted += usize::from(sol.start > 0);
        s.starts[sol.start] += 1;
        s.refined += usize::from(sol.steps > opts.steps);
    }
    s
}

#[test]
fn default_solver_meets_the_ends_on_1000_random_pairs() {
    let n = 1000;
    let pairs = spiral_end_pairs(&random_spirals(n, 1));
    let opts = SolveOptions::default();
    let t = std::time::Instant::now();
    let solved: Vec<SpiralSolution> = solve_spirals(&pairs, &opts, &Backend::Cpu)
        .expect("the CPU backend does not fail")
        .into_iter()
        .map(|r| r.expect("random pairs are valid input"))
        .collect();
    let secs = t.elapsed().as_secs_f64();
    let s = summarise(&pairs, &solved, &opts);
    eprintln!(
        "default Euler solver, {n} random pairs within one revolution: {}/{n} converged \
         ({:.1}%), worst end error of those {:.2e} (relative to |xf − x0|), worst overall \
         {:.2e}; {} restarted (pairs per start, in-plane first: {:?}), {} needed more than {} \
         steps; {:.2} s",
        s.converged,
        100.0 * s.converged as f64 / n as f64,
        s.worst_converged,
        s.worst,
        s.restarted,
        s.starts,
        s.refined,
        opts.steps,
        secs
    );
    // Measured 1000/1000 on this seed (and 40,000/40,000 on seeds 1–4):
    // at most one miss allowed, and the truncation check's 1e-7 with a
    // factor two of room for its estimate.
    assert!(s.converged >= 999, "{}/{n} converged", s.converged);
    assert!(s.worst_converged < 2e-7, "worst {:e}", s.worst_converged);
    // Without restarts (the paper's single start) the same pairs miss more:
    // the restarts are doing the work, not the generator being easy.
    assert!(s.restarted >= 3, "{} restarts", s.restarted);
}

/// The paper's single start (no restarts) on the same pairs: what the
/// restarts add. `cargo test --release --test euler_random -- --ignored`.
#[test]
#[ignore = "a study; a few seconds in release"]
fn without_restarts() {
    let seeds: u64 = std::env::var("SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let n = std::env::var("N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    for seed in 1..=seeds {
        let pairs = spiral_end_pairs(&random_spirals(n, seed));
        for (name, opts) in [
            (
                "single start",
                SolveOptions {
                    restarts: &[],
                    ..Default::default()
                },
            ),
            ("default", SolveOptions::default()),
        ] {
            let t = std::time::Instant::now();
            let solved: Vec<SpiralSolution> = solve_spirals(&pairs, &opts, &Backend::Cpu)
                .unwrap()
                .into_iter()
                .map(|r| r.unwrap())
                .collect();
            let secs = t.elapsed().as_secs_f64();
            let s = summarise(&pairs, &solved, &opts);
            eprintln!(
                "seed {seed}, {name}: {}/{n} converged, worst converged {:.2e}, worst {:.2e}, \
                 restarted {} {:?}, refined {}, {:.0} pairs/s",
                s.converged,
                s.worst_converged,
                s.worst,
                s.restarted,
                s.starts,
                s.refined,
                n as f64 / secs
            );
        }
    }
}

/// Which turned start normals rescue the pairs that the in-plane start
/// fails on: the study behind `DEFAULT_RESTARTS`. Prints one row per
/// failing pair (`#`: converged from `N₀` turned by 15°, 30°, …, 165°).
#[test]
#[ignore = "a study; about a minute in release"]
fn restart_angle_study() {
    let seeds: u64 = std::env::var("SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let single = SolveOptions {
        restarts: &[],
        ..Default::default()
    };
    let (mut failed, mut total, mut rescued) = (0, 0, [0usize; 11]);
    for seed in 1..=seeds {
        let pairs = spiral_end_pairs(&random_spirals(10_000, seed));
        total += pairs.len();
        for &Pair {
            p0: x0,
            t0,
            p1: xf,
            t1: tf,
        } in &pairs
        {
            let s = solve_spiral(x0, t0, xf, tf, &single).unwrap();
            if s.error < 1e-20 {
                continue;
            }
            failed += 1;
            // The in-plane frame (as the solver builds it).
            let t = t0.normalize();
            let d = xf - x0;
            let n0 = (d - d.dot(t) * t).normalize();
            let b0 = t.cross(n0);
            let mut row = String::new();
            for (k, hit) in rescued.iter_mut().enumerate() {
                let a = (15 * (k + 1)) as f64 * std::f64::consts::PI / 180.0;
                let o = SolveOptions {
                    start_normal: Some(a.cos() * n0 + a.sin() * b0),
                    ..single
                };
                let ok = solve_spiral(x0, t0, xf, tf, &o).unwrap().error < 1e-20;
                *hit += usize::from(ok);
                row.push(if ok { '#' } else { '.' });
            }
            eprintln!("{row}");
        }
    }
    eprintln!("{failed}/{total} fail from the in-plane normal; rescued per angle (15°..165°): {rescued:?}");
}
