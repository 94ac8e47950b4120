//! The batched Euler-spiral solver on the GPU backend (every candidate curve
//! of an iteration in one `frenet_integrate` dispatch) against the same
//! solver on the CPU backend: the same pairs converge, to the same spirals.
//!
//! Tolerance: the f64 kernel agrees with the CPU integrator to a few ε per
//! curve (tests/gpu_frenet.rs); central differences at h = 1e-6 amplify
//! that to ~1e-10 in the Jacobian, which moves LM's path but not its
//! converged answer: parameters must agree to 1e-7 (measured on lavapipe:
//! 295 of 300 pairs converge on both, worst difference 1.0e-13).

mod common;

use glam::DVec3;
use rand::{Rng, SeedableRng};
use strandfit::backend::{Backend, BackendChoice, PrecisionChoice};
use strandfit::euler::{solve_spirals, FrenetProblem, SolveOptions};

fn pairs(n: usize) -> Vec<(DVec3, DVec3, DVec3, DVec3)> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    (0..n)
        .map(|_| {
            let t = common::unit_vector(&mut rng);
            let p = FrenetProblem::new(
                DVec3::new(rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0), 1.0),
                t,
                t.any_orthonormal_vector(),
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
fn batched_spiral_solve_gpu_matches_cpu() {
    let Some(ctx) = common::gpu_f64_or_skip("batched_spiral_solve_gpu_matches_cpu") else {
        return;
    };
    drop(ctx);
    let gpu = Backend::open(BackendChoice::Gpu, PrecisionChoice::F64).unwrap();
    let pairs = pairs(300);
    let opts = SolveOptions::default();
    let cpu = solve_spirals(&pairs, &opts, &Backend::Cpu).unwrap();
    let gpu = solve_spirals(&pairs, &opts, &gpu).unwrap();
    let (mut both, mut worst) = (0, 0.0f64);
    for (c, g) in cpu.iter().zip(&gpu) {
        let (c, g) = (c.as_ref().unwrap(), g.as_ref().unwrap());
        assert_eq!(
            c.error < 1e-20,
            g.error < 1e-20,
            "converged on one backend only"
        );
        if c.error < 1e-20 {
            both += 1;
            let (x, y) = (c.problem, g.problem);
            for (a, b) in [
                (x.kappa0, y.kappa0),
                (x.gamma, y.gamma),
                (x.tau0, y.tau0),
                (x.delta, y.delta),
                (x.length, y.length),
            ] {
                worst = worst.max((a - b).abs());
            }
        }
    }
    eprintln!("{both}/300 converged; worst parameter difference gpu vs cpu {worst:.2e}");
    assert!(both >= 280);
    assert!(worst < 1e-7, "{worst}");
}
