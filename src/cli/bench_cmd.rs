//! `strandfit bench`: whole-fit throughput on synthetic splines.

use std::time::Instant;

use super::BenchArgs;
use crate::fit::{fit_splines, FitOptions};
use crate::synthetic::synthetic_splines;
use anyhow::Result;

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
    println!(
        "  best   {:.4} s  {:>12.0} elements/s",
        best,
        elements / best
    );
    println!(
        "  median {:.4} s  {:>12.0} elements/s",
        median,
        elements / median
    );
    if failures > 0 {
        println!("  ({failures} curves failed to fit)");
    }
    Ok(())
}
