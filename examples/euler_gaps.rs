//! Complete gaps between curve ends with 3D Euler spirals (curvature and
//! torsion linear in arc length): each gap is a point and a tangent at
//! either end ([`HermitePair`]), read from `examples/gaps.json` (the input
//! of `strandfit complete`), all solved in one batch call.
//!
//! `cargo run --example euler_gaps [-- GAPS.json]`

use std::error::Error;
use std::path::PathBuf;

use strandfit::euler::{solve_spirals, SolveOptions};
use strandfit::{Backend, DVec3, HermitePair, ParamCurve3};

#[derive(serde::Deserialize)]
struct Gaps {
    pairs: Vec<Gap>,
}

#[derive(serde::Deserialize)]
struct Gap {
    id: String,
    p0: [f64; 3],
    t0: [f64; 3],
    p1: [f64; 3],
    t1: [f64; 3],
}

fn main() -> Result<(), Box<dyn Error>> {
    run(std::env::args().skip(1).collect())
}

/// The example on `args` (none: `examples/gaps.json`).
pub fn run(args: Vec<String>) -> Result<(), Box<dyn Error>> {
    let path = args
        .into_iter()
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/gaps.json"));
    let gaps: Gaps = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
    let pairs: Vec<HermitePair> = gaps
        .pairs
        .iter()
        .map(|g| {
            let v = DVec3::from;
            HermitePair::new(v(g.p0), v(g.t0), v(g.p1), v(g.t1))
        })
        .collect();

    // One call for all gaps; `&Backend::Cpu` or an opened GPU backend.
    let solved = solve_spirals(&pairs, &SolveOptions::default(), &Backend::Cpu)?;

    let mut completed = 0;
    for ((gap, pair), result) in gaps.pairs.iter().zip(&pairs).zip(&solved) {
        match result {
            Ok(s) => {
                let spiral = &s.problem;
                // The spiral is a curve like any other: sample it, and check
                // that it ends where and as the gap asks.
                let points = ParamCurve3::sample(spiral, 17);
                let end = *points.last().expect("17 points");
                let miss = end.distance(pair.p1) / pair.chord().length();
                let turn = ParamCurve3::tangent(spiral, 1.0).angle_between(pair.t1);
                println!(
                    "{:>15}: length {:.4}, κ₀ {:+.4}, γ {:+.4}, τ₀ {:+.4}, δ {:+.4}; \
                     end missed by {miss:.1e} of the chord, {turn:.1e} rad",
                    gap.id,
                    spiral.arc_length(),
                    spiral.kappa0,
                    spiral.gamma,
                    spiral.tau0,
                    spiral.delta,
                );
                if miss > 1e-6 || turn > 1e-6 {
                    return Err(format!("{}: the spiral misses the gap's end", gap.id).into());
                }
                completed += 1;
            }
            // E.g. coincident ends: no curve of positive length joins them.
            Err(e) => println!("{:>15}: not completed: {e}", gap.id),
        }
    }
    println!("{completed} of {} gaps completed", pairs.len());
    if completed == 0 {
        return Err("no gap completed".into());
    }
    Ok(())
}
