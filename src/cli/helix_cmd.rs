//! `strandfit helix`: one Ghosh short helix per JSON Lines record.

use std::io::BufRead;

use anyhow::{Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{input_name, open_input, Output};
use super::HelixArgs;
use crate::backend::Backend;
use crate::helix::{HermitePair, ShortHelix};

#[derive(Deserialize)]
struct Record {
    p0: [f64; 3],
    t0: [f64; 3],
    p1: [f64; 3],
    t1: [f64; 3],
}

#[derive(Serialize)]
struct Answer {
    length: f64,
    curvature: f64,
    torsion: f64,
    phi: f64,
    axis: [f64; 3],
}

#[derive(Serialize)]
struct Failure {
    error: String,
}

/// Lines processed per parallel batch: bounds memory for any input size.
const CHUNK: usize = 1 << 16;

pub fn run(args: &HelixArgs, backend: &Backend) -> Result<()> {
    if !(args.tolerance >= 0.0) {
        anyhow::bail!(
            "--tolerance must be a non-negative number, got {}",
            args.tolerance
        );
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
        let parsed: Vec<Result<HermitePair, String>> = lines
            .par_iter()
            .map(|line| parse_line(line.trim_end_matches(['\n', '\r'])))
            .collect();
        let pairs: Vec<HermitePair> = parsed
            .iter()
            .filter_map(|p| p.as_ref().ok())
            .copied()
            .collect();
        let mut helices = backend.interpolate(&pairs, args.tolerance)?.into_iter();
        let solved: Vec<Result<Answer, String>> = parsed
            .into_iter()
            .map(|p| {
                p.and_then(|_| match helices.next() {
                    Some(Ok(h)) => Ok(answer(&h)),
                    Some(Err(e)) => Err(e.to_string()),
                    None => Err("internal error: missing result".into()),
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

fn to_json(result: Result<Answer, String>, line_no: usize) -> String {
    let json = match result {
        Ok(a) => serde_json::to_string(&a),
        Err(reason) => serde_json::to_string(&Failure {
            error: format!("line {line_no}: {reason}"),
        }),
    };
    json.unwrap_or_else(|e| format!("{{\"error\":\"line {line_no}: cannot serialise: {e}\"}}"))
}

fn parse_line(line: &str) -> Result<HermitePair, String> {
    if line.trim().is_empty() {
        return Err("empty line".into());
    }
    let r: Record = serde_json::from_str(line).map_err(|e| format!("bad JSON record: {e}"))?;
    let v = |a: [f64; 3]| DVec3::from(a);
    Ok(HermitePair {
        p0: v(r.p0),
        t0: v(r.t0),
        p1: v(r.p1),
        t1: v(r.t1),
    })
}

fn answer(h: &ShortHelix) -> Answer {
    Answer {
        length: h.element.length,
        curvature: h.element.curvature,
        torsion: h.element.torsion,
        phi: h.phi,
        axis: h.axis.to_array(),
    }
}
