//! `strandfit helix`: one Ghosh short helix per JSON Lines record.

use anyhow::Result;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::io_util::map_json_lines;
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

pub fn run(args: &HelixArgs, backend: &Backend) -> Result<()> {
    if !(args.cohelical_tolerance >= 0.0) {
        super::usage!(
            "--cohelical-tolerance must be a non-negative number, got {}",
            args.cohelical_tolerance
        );
    }
    map_json_lines(&args.input, &args.output, parse_line, |pairs| {
        Ok(backend
            .interpolate(pairs, args.cohelical_tolerance)?
            .into_iter()
            .map(|h| h.map(|h| answer(&h)).map_err(|e| e.to_string()))
            .collect())
    })
}

fn parse_line(line: &str) -> Result<HermitePair, String> {
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
