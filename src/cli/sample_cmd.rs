//! `strandfit sample`: N + 1 points with unit tangents equally spaced in arc
//! length on each Bézier spline (step 1 of the fit), on the chosen backend.

use anyhow::{Context, Result};
use rayon::prelude::*;
use serde::Serialize;

use super::fit_cmd::read_splines;
use super::io_util::Output;
use super::usage;
use super::SampleArgs;
use crate::backend::Backend;

#[derive(Serialize)]
struct OutputDoc {
    splines: Vec<SplineOut>,
}

#[derive(Serialize)]
struct SplineOut {
    id: serde_json::Value,
    points: Vec<[f64; 3]>,
    tangents: Vec<[f64; 3]>,
}

pub fn run(args: &SampleArgs, backend: &Backend) -> Result<()> {
    if args.intervals == 0 {
        usage!("--intervals must be at least 1");
    }
    let (ids, splines) = read_splines(&args.input)?;
    let samples = backend.sample(&splines, args.intervals)?;
    let splines: Vec<SplineOut> = ids
        .into_par_iter()
        .zip(samples.into_par_iter())
        .map(|(id, s)| SplineOut {
            id,
            points: s.points.iter().map(|p| p.to_array()).collect(),
            tangents: s.tangents.iter().map(|t| t.to_array()).collect(),
        })
        .collect();
    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &super::versioned(&OutputDoc { splines }))
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}
