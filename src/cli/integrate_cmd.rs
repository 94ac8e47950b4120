//! `strandfit integrate`: Frenet–Serret integration of curves whose
//! curvature and torsion are linear in arc length (3D Euler spirals), one
//! JSON Lines record per curve, on the chosen backend.

use std::io::BufRead;

use anyhow::{bail, Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{input_name, open_input, Output};
use super::IntegrateArgs;
use crate::backend::Backend;
use crate::euler::{FrenetEnd, FrenetProblem};
use crate::gpu::frenet::SpiralSamples;

#[derive(Deserialize)]
struct Record {
    start: [f64; 3],
    tangent: [f64; 3],
    normal: [f64; 3],
    kappa0: f64,
    #[serde(default)]
    gamma: f64,
    #[serde(default)]
    tau0: f64,
    #[serde(default)]
    delta: f64,
    length: f64,
}

#[derive(Serialize)]
struct EndOut {
    end: [f64; 3],
    tangent: [f64; 3],
    normal: [f64; 3],
    binormal: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    points: Option<Vec<[f64; 3]>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tangents: Option<Vec<[f64; 3]>>,
}

#[derive(Serialize)]
struct Failure {
    error: String,
}

/// Lines per parallel batch: bounds memory for any input size.
const CHUNK: usize = 1 << 16;

pub fn run(args: &IntegrateArgs, backend: &Backend) -> Result<()> {
    if args.steps == 0 {
        bail!("--steps must be at least 1");
    }
    if args.samples == 1 {
        bail!("--samples must be 0 (none) or at least 2 (both ends are included)");
    }
    let name = input_name(&args.input);
    let mut input = open_input(&args.input)?;
    let mut out = Output::create(&args.output)?;
    let mut lines: Vec<String> = Vec::with_capacity(CHUNK);
    let mut line_no = 0usize;
    loop {
        lines.clear();
        for _ in 0..CHUNK {
            let mut s = String::new();
            let n = input.read_line(&mut s).with_context(|| {
                format!("{name}: cannot read line {}", line_no + lines.len() + 1)
            })?;
            if n == 0 {
                break;
            }
            lines.push(s);
        }
        if lines.is_empty() {
            break;
        }
        let first = line_no + 1;
        let parsed: Vec<Result<FrenetProblem, String>> = lines
            .par_iter()
            .map(|line| parse_line(line.trim_end_matches(['\n', '\r'])))
            .collect();
        let problems: Vec<FrenetProblem> = parsed
            .iter()
            .filter_map(|p| p.as_ref().ok())
            .copied()
            .collect();
        let ends = backend.integrate(&problems, args.steps)?;
        let samples: Option<Vec<_>> = if args.samples >= 2 {
            let per = args.steps.div_ceil(args.samples - 1);
            Some(backend.integrate_samples(&problems, args.samples, per)?)
        } else {
            None
        };
        let mut ends = ends.into_iter();
        let mut samples = samples.map(|s| s.into_iter());
        let solved: Vec<Result<EndOut, String>> = parsed
            .into_iter()
            .map(|p| {
                p.and_then(|_| {
                    let end = ends.next().ok_or("internal error: missing result")?;
                    let smp = samples.as_mut().map(|s| s.next());
                    let end = end.map_err(|e| e.to_string())?;
                    let smp = match smp {
                        Some(Some(Ok(s))) => Some(s),
                        Some(Some(Err(e))) => return Err(e.to_string()),
                        Some(None) => return Err("internal error: missing samples".into()),
                        None => None,
                    };
                    Ok(answer(&end, smp))
                })
            })
            .collect();
        let answers: Vec<String> = solved
            .into_par_iter()
            .enumerate()
            .map(|(k, r)| to_json(r, first + k))
            .collect();
        let w = out.writer();
        for a in &answers {
            w.write_all(a.as_bytes())?;
            w.write_all(b"\n")?;
        }
        line_no += lines.len();
    }
    out.commit()
}

fn to_json(result: Result<EndOut, String>, line_no: usize) -> String {
    let json = match result {
        Ok(a) => serde_json::to_string(&a),
        Err(reason) => serde_json::to_string(&Failure {
            error: format!("line {line_no}: {reason}"),
        }),
    };
    json.unwrap_or_else(|e| format!("{{\"error\":\"line {line_no}: cannot serialise: {e}\"}}"))
}

fn parse_line(line: &str) -> Result<FrenetProblem, String> {
    if line.trim().is_empty() {
        return Err("empty line".into());
    }
    let r: Record = serde_json::from_str(line).map_err(|e| format!("bad JSON record: {e}"))?;
    let v = |a: [f64; 3]| DVec3::from(a);
    let p = FrenetProblem::new(
        v(r.start),
        v(r.tangent),
        v(r.normal),
        r.kappa0,
        r.gamma,
        r.tau0,
        r.delta,
        r.length,
    );
    p.validate().map_err(|e| e.to_string())?;
    Ok(p)
}

fn answer(end: &FrenetEnd, samples: Option<SpiralSamples>) -> EndOut {
    let arr = |v: &[DVec3]| v.iter().map(|p| p.to_array()).collect::<Vec<_>>();
    EndOut {
        end: end.point.to_array(),
        tangent: end.frame[0].to_array(),
        normal: end.frame[1].to_array(),
        binormal: end.frame[2].to_array(),
        points: samples.as_ref().map(|s| arr(&s.points)),
        tangents: samples.as_ref().map(|s| arr(&s.tangents)),
    }
}
