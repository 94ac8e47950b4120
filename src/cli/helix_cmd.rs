//! `strandfit helix`: one Ghosh short helix per JSON Lines record.

use std::io::BufRead;

use anyhow::{Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{input_name, open_input, Output};
use super::HelixArgs;
use crate::helix::interpolate;

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

pub fn run(args: &HelixArgs) -> Result<()> {
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
        let answers: Vec<String> = lines
            .par_iter()
            .enumerate()
            .map(|(k, line)| answer_line(line, first + k, args.tolerance))
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

/// The JSON answer for one input line (never fails: errors become
/// `{"error": ...}` so one bad line never stops the others).
pub fn answer_line(line: &str, line_no: usize, tol: f64) -> String {
    let result = solve_line(line.trim_end_matches(['\n', '\r']), tol);
    let json = match result {
        Ok(a) => serde_json::to_string(&a),
        Err(reason) => serde_json::to_string(&Failure {
            error: format!("line {line_no}: {reason}"),
        }),
    };
    json.unwrap_or_else(|e| format!("{{\"error\":\"line {line_no}: cannot serialise: {e}\"}}"))
}

fn solve_line(line: &str, tol: f64) -> Result<Answer, String> {
    if line.trim().is_empty() {
        return Err("empty line".into());
    }
    let r: Record = serde_json::from_str(line).map_err(|e| format!("bad JSON record: {e}"))?;
    let v = |a: [f64; 3]| DVec3::from(a);
    let h = interpolate(v(r.p0), v(r.t0), v(r.p1), v(r.t1), tol).map_err(|e| e.to_string())?;
    Ok(Answer {
        length: h.element.length,
        curvature: h.element.curvature,
        torsion: h.element.torsion,
        phi: h.phi,
        axis: h.axis.to_array(),
    })
}
