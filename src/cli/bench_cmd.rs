//! `strandfit bench`: whole-fit throughput on synthetic splines.

use std::time::Instant;

use anyhow::Result;
use glam::DVec3;

use super::BenchArgs;
use crate::fit::{fit_splines, FitOptions};
use crate::spline::BezierSpline;

/// Deterministic smooth test splines: Hermite cubics of a wandering helix
/// (curvature and torsion varying slowly), about the shape of a hair strand.
pub fn synthetic_splines(count: usize, segments: usize) -> Vec<BezierSpline> {
    (0..count)
        .filter_map(|c| {
            let phase = c as f64 * 0.618_033_988_75;
            let pos = |u: f64| {
                let r = 1.0 + 0.3 * (0.7 * u + phase).sin();
                DVec3::new(r * (2.0 * u + phase).cos(), r * (2.0 * u + phase).sin(), 0.8 * u + 0.2 * (1.3 * u).sin())
            };
            let vel = |u: f64| (pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6;
            let h = 6.0 / segments as f64;
            let mut cps = vec![pos(0.0)];
            for k in 0..segments {
                let (u0, u1) = (k as f64 * h, (k + 1) as f64 * h);
                cps.push(pos(u0) + vel(u0) * h / 3.0);
                cps.push(pos(u1) - vel(u1) * h / 3.0);
                cps.push(pos(u1));
            }
            BezierSpline::from_control_points(&cps).ok()
        })
        .collect()
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.curves == 0 || args.elements == 0 || args.segments == 0 || args.repeat == 0 {
        anyhow::bail!("--curves, --elements, --segments and --repeat must be at least 1");
    }
    let splines = synthetic_splines(args.curves, args.segments);
    let opts = FitOptions::new(args.elements);
    let mut times = Vec::with_capacity(args.repeat);
    let mut failures = 0;
    for _ in 0..args.repeat {
        let t = Instant::now();
        let results = fit_splines(&splines, &opts);
        times.push(t.elapsed().as_secs_f64());
        failures = results.iter().filter(|r| r.is_err()).count();
    }
    times.sort_by(f64::total_cmp);
    let elements = (splines.len() * args.elements) as f64;
    let best = times[0];
    let median = times[times.len() / 2];
    println!(
        "whole fit: {} curves x {} elements ({} cubic segments each), {} threads",
        splines.len(),
        args.elements,
        args.segments,
        rayon::current_num_threads()
    );
    println!("  best   {:.4} s  {:>12.0} elements/s", best, elements / best);
    println!("  median {:.4} s  {:>12.0} elements/s", median, elements / median);
    if failures > 0 {
        println!("  ({failures} curves failed to fit)");
    }
    Ok(())
}
