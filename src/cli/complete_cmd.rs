//! `strandfit complete --method euler IN.json -o OUT.json`: the curve that
//! fills the gap between each pair of point–tangent conditions, batched on
//! the chosen backend (`euler::batch`: every candidate curve of an LM round
//! in one `frenet_integrate` dispatch on the GPU). ATPH curves (the other
//! method of the issue) are not built yet, so `--method` takes `euler` only.

use anyhow::{bail, Context, Result};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::io_util::{self, input_name, read_input, Output};
use super::CompleteArgs;
use crate::backend::Backend;
use crate::euler::{solve_spirals, SolveOptions};

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
        /// Eq. 9 of paper 004: squared end-point plus squared end-tangent
        /// error.
        error: f64,
        iterations: usize,
        /// `true` when the end conditions are met (error < 1e-12).
        regular: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        points: Option<Vec<[f64; 3]>>,
    },
    Failed {
        error: String,
    },
}

pub fn run(args: &CompleteArgs, backend: &Backend) -> Result<()> {
    if matches!(args.samples, 1) {
        bail!("--samples must be 0 (none) or at least 2");
    }
    let name = input_name(&args.input);
    let text = read_input(&args.input)?;
    let input: Input = serde_json::from_str(&text).with_context(|| {
        format!("{name}: expected {{\"pairs\":[{{\"id\",\"p0\",\"t0\",\"p1\",\"t1\"}}]}}")
    })?;
    drop(text);
    let v = |a: [f64; 3]| DVec3::from(a);
    let pairs: Vec<_> = input
        .pairs
        .iter()
        .map(|p| (v(p.p0), v(p.t0), v(p.p1), v(p.t1)))
        .collect();
    let opts = SolveOptions::default();
    let solved = solve_spirals(&pairs, &opts, backend)?;
    let sampled: Vec<Option<Vec<[f64; 3]>>> = if args.samples >= 2 {
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
            .integrate_samples(&problems, args.samples, steps.div_ceil(args.samples - 1))?
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
    let out_pairs: Vec<PairOut> = input
        .pairs
        .iter()
        .zip(solved)
        .zip(sampled)
        .enumerate()
        .map(|(i, ((p, r), pts))| PairOut {
            id: p.id.clone().unwrap_or(serde_json::Value::from(i)),
            result: match r {
                Ok(s) => Outcome::Spiral {
                    kappa0: s.problem.kappa0,
                    gamma: s.problem.gamma,
                    tau0: s.problem.tau0,
                    delta: s.problem.delta,
                    length: s.problem.length,
                    normal: s.problem.frame[1].to_array(),
                    error: s.error,
                    iterations: s.iterations,
                    regular: s.error < 1e-12,
                    points: pts,
                },
                Err(e) => Outcome::Failed {
                    error: format!(
                        "{}: {e}",
                        io_util::label(
                            "pair",
                            "pairs",
                            i,
                            p.id.as_ref().unwrap_or(&serde_json::Value::Null)
                        )
                    ),
                },
            },
        })
        .collect();
    #[derive(Serialize)]
    struct Doc {
        pairs: Vec<PairOut>,
    }
    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &Doc { pairs: out_pairs })
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}
