//! `strandfit complete --method euler|atph [--length L] IN.json -o OUT.json`:
//! the curve that fills the gap between each pair of point–tangent
//! conditions.
//!
//! * `euler`: 3D Euler spirals, batched on the chosen backend
//!   (`euler::batch`: every candidate curve of an LM round in one
//!   `frenet_integrate` dispatch on the GPU).
//! * `atph`: ATPH curves, a closed form and a 3×3 (4×4 with a prescribed
//!   length) solve per pair: `atph::batch` on the CPU, one `atph_hermite`
//!   kernel run for all spatial pairs on the GPU (`kernels::atph_hermite`).
//!
//! Every pair gets its own result or its own error; the batch never stops
//! on a bad pair.

use anyhow::{Context, Result};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::io_util::{self, input_name, read_input, Output};
use super::usage;
use super::{CompleteArgs, CompleteMethod};
use crate::atph::{AtphCurve, Sign};
use crate::backend::Backend;
use crate::euler::{solve_spirals, SolveOptions};
use crate::HermitePair;

#[derive(Deserialize)]
struct Input {
    pairs: Vec<PairIn>,
}

#[derive(Deserialize)]
struct PairIn {
    id: Option<serde_json::Value>,
    p0: [f64; 3],
    t0: [f64; 3],
    p1: [f64; 3],
    t1: [f64; 3],
    /// ATPH only: this pair's prescribed arc length.
    length: Option<f64>,
}

#[derive(Serialize)]
struct PairOut {
    id: serde_json::Value,
    #[serde(flatten)]
    result: Outcome,
}

#[derive(Serialize)]
#[serde(untagged)]
enum Outcome {
    Spiral {
        kappa0: f64,
        gamma: f64,
        tau0: f64,
        delta: f64,
        length: f64,
        /// Start Frenet normal (the frame's rotation about `t0`).
        normal: [f64; 3],
        /// The solver's residual, Eq. 9 of paper 004: squared end-point
        /// plus squared end-tangent error.
        residual: f64,
        iterations: usize,
        /// `true` when the end conditions are met (residual < 1e-12).
        regular: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        points: Option<Vec<[f64; 3]>>,
    },
    Atph {
        /// Tangent field θ(ξ) = a1 ξ + a0, φ(ξ) = b1 ξ + b0 (Eq. 2.1 of
        /// paper 002), in the input's coordinates.
        a0: f64,
        a1: f64,
        b0: f64,
        b1: f64,
        /// Bernstein coefficients of ρ (degree 2, or 3 with a prescribed
        /// length; one less for a planar field; 0 for a straight segment).
        rho: Vec<f64>,
        /// Arc length ∫|ρ|.
        length: f64,
        /// |r(1) − p1|² + |T(1) − t1|², as Eq. 9 of paper 004.
        residual: f64,
        /// ρ ≠ 0 on [0, 1] (Proposition 1): no singular point.
        regular: bool,
        /// ρ > 0: the curve runs along t0 and t1, not against them.
        forward: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        points: Option<Vec<[f64; 3]>>,
    },
    Failed {
        failure: String,
    },
}

pub fn run(args: &CompleteArgs, backend: &Backend) -> Result<()> {
    if matches!(args.points, 1) {
        usage!("--points must be 0 (none) or at least 2");
    }
    if let Some(l) = args.length {
        if args.method != CompleteMethod::Atph {
            usage!("--length applies to --method atph (Euler spirals take no prescribed length)");
        }
        if !(l > 0.0 && l.is_finite()) {
            usage!("--length must be positive and finite, got {l}");
        }
    }
    let name = input_name(&args.input);
    let text = read_input(&args.input)?;
    let input: Input = serde_json::from_str(&text).with_context(|| {
        format!("{name}: expected {{\"pairs\":[{{\"id\",\"p0\",\"t0\",\"p1\",\"t1\"}}]}}")
    })?;
    drop(text);
    let outcomes = match args.method {
        CompleteMethod::Euler => euler(&input.pairs, args, backend)?,
        CompleteMethod::Atph => atph(&input.pairs, args, backend)?,
    };
    let out_pairs: Vec<PairOut> = input
        .pairs
        .iter()
        .zip(outcomes)
        .enumerate()
        .map(|(i, (p, r))| PairOut {
            id: p.id.clone().unwrap_or(serde_json::Value::from(i)),
            result: r.unwrap_or_else(|e| Outcome::Failed {
                failure: format!(
                    "{}: {e}",
                    io_util::label(
                        "pair",
                        "pairs",
                        i,
                        p.id.as_ref().unwrap_or(&serde_json::Value::Null)
                    )
                ),
            }),
        })
        .collect();
    #[derive(Serialize)]
    struct Doc {
        pairs: Vec<PairOut>,
    }
    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &super::versioned(&Doc { pairs: out_pairs }))
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}

fn vectors(p: &PairIn) -> HermitePair {
    let v = |a: [f64; 3]| DVec3::from(a);
    HermitePair::new(v(p.p0), v(p.t0), v(p.p1), v(p.t1))
}

/// ATPH curves, one per pair, with the pair's or the command's length.
fn atph(
    input: &[PairIn],
    args: &CompleteArgs,
    backend: &Backend,
) -> Result<Vec<Result<Outcome, String>>> {
    let pairs: Vec<_> = input.iter().map(vectors).collect();
    let lengths: Vec<Option<f64>> = input.iter().map(|p| p.length.or(args.length)).collect();
    let curves = backend.interpolate_atph(&pairs, Some(&lengths))?;
    Ok(curves
        .into_iter()
        .zip(&pairs)
        .map(|(r, &HermitePair { p1, t1, .. })| {
            let c: AtphCurve = r.map_err(|e| e.to_string())?;
            let t1 = t1.normalize();
            let residual =
                c.position(1.0).distance_squared(p1) + c.tangent.at(1.0).distance_squared(t1);
            let sign = c.speed_sign();
            Ok(Outcome::Atph {
                a0: c.tangent.a0,
                a1: c.tangent.a1,
                b0: c.tangent.b0,
                b1: c.tangent.b1,
                rho: c.rho.coefficients().to_vec(),
                length: c.length(),
                residual,
                regular: sign != Sign::Vanishes,
                forward: sign == Sign::Positive,
                points: (args.points >= 2)
                    .then(|| c.sample(args.points).iter().map(|p| p.to_array()).collect()),
            })
        })
        .collect())
}

/// Euler spirals, batched on the backend.
fn euler(
    input: &[PairIn],
    args: &CompleteArgs,
    backend: &Backend,
) -> Result<Vec<Result<Outcome, String>>> {
    let pairs: Vec<_> = input.iter().map(vectors).collect();
    let opts = SolveOptions::default();
    let solved = solve_spirals(&pairs, &opts, backend)?;
    let sampled: Vec<Option<Vec<[f64; 3]>>> = if args.points >= 2 {
        let problems: Vec<_> = solved
            .iter()
            .filter_map(|r| r.as_ref().ok())
            .map(|s| s.problem)
            .collect();
        // As many steps in all as the solve used (the most any pair
        // needed after its truncation check), so the last sample is the
        // solved end to within the truncation tolerance.
        let steps = solved
            .iter()
            .filter_map(|r| r.as_ref().ok())
            .map(|s| s.steps)
            .max()
            .unwrap_or(opts.steps);
        let mut it = backend
            .integrate_samples(&problems, args.points, steps.div_ceil(args.points - 1))?
            .into_iter();
        solved
            .iter()
            .map(|r| {
                r.as_ref().ok().and_then(|_| {
                    it.next()
                        .and_then(|s| s.ok())
                        .map(|s| s.points.iter().map(|p| p.to_array()).collect())
                })
            })
            .collect()
    } else {
        vec![None; solved.len()]
    };
    Ok(solved
        .into_iter()
        .zip(sampled)
        .zip(input)
        .map(|((r, pts), p)| {
            if p.length.is_some() {
                return Err("a prescribed \"length\" applies to --method atph".to_string());
            }
            let s = r.map_err(|e| e.to_string())?;
            Ok(Outcome::Spiral {
                kappa0: s.problem.kappa0,
                gamma: s.problem.gamma,
                tau0: s.problem.tau0,
                delta: s.problem.delta,
                length: s.problem.length,
                normal: s.problem.frame[1].to_array(),
                residual: s.error,
                iterations: s.iterations,
                regular: s.error < 1e-12,
                points: pts,
            })
        })
        .collect())
}
