//! `strandfit fit`: Bézier splines in, G1 piecewise helices out.

use anyhow::{bail, Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{input_name, read_input, Output};
use super::FitArgs;
use crate::backend::Backend;
use crate::fit::FitOptions;
use crate::helix::PiecewiseHelix;
use crate::metrics;
use crate::spline::BezierSpline;

#[derive(Deserialize)]
struct Input {
    splines: Vec<SplineIn>,
}

#[derive(Deserialize)]
struct SplineIn {
    id: Option<serde_json::Value>,
    control_points: Vec<[f64; 3]>,
}

#[derive(Serialize)]
struct OutputDoc {
    curves: Vec<CurveOut>,
}

#[derive(Serialize)]
struct CurveOut {
    id: serde_json::Value,
    elements: Vec<ElementOut>,
    frechet: f64,
    hausdorff: f64,
}

#[derive(Serialize)]
struct ElementOut {
    start: [f64; 3],
    tangent: [f64; 3],
    normal: [f64; 3],
    axis: [f64; 3],
    curvature: f64,
    torsion: f64,
    length: f64,
}

/// How a spline is named in messages: its id, else its index.
fn label(index: usize, id: &Option<serde_json::Value>) -> String {
    match id {
        Some(serde_json::Value::String(s)) => format!("spline \"{s}\" (splines[{index}])"),
        Some(v) => format!("spline {v} (splines[{index}])"),
        None => format!("splines[{index}]"),
    }
}

pub fn run(args: &FitArgs, backend: &Backend) -> Result<()> {
    if args.elements == 0 {
        bail!("--elements must be at least 1");
    }
    if args.samples_per_element == 0 {
        bail!("--samples-per-element must be at least 1");
    }
    let name = input_name(&args.input);
    let text = read_input(&args.input)?;
    let input: Input = serde_json::from_str(&text).with_context(|| {
        format!("{name}: expected {{\"splines\":[{{\"id\":…,\"control_points\":[[x,y,z],…]}}]}}")
    })?;
    drop(text);

    // Validate everything before any work: one bad spline fails the run.
    let splines: Vec<BezierSpline> = input
        .splines
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let pts: Vec<DVec3> = s.control_points.iter().map(|&p| DVec3::from(p)).collect();
            BezierSpline::from_control_points(&pts)
                .with_context(|| format!("{name}: {}", label(i, &s.id)))
        })
        .collect::<Result<_>>()?;

    let opts = FitOptions {
        relaxation: args.relaxation.into(),
        ..FitOptions::new(args.elements)
    };
    let samples = args.samples_per_element * args.elements + 1;
    let chains = backend.fit(&splines, &opts)?;
    let curves: Vec<CurveOut> = splines
        .par_iter()
        .zip(input.splines.par_iter())
        .zip(chains.into_par_iter())
        .enumerate()
        .map(|(i, ((spline, src), chain))| {
            let what = || format!("{name}: {}", label(i, &src.id));
            let chain = chain.with_context(what)?;
            let (frechet, hausdorff) = distances(spline, &chain, samples).with_context(what)?;
            Ok(CurveOut {
                id: src.id.clone().unwrap_or(serde_json::Value::from(i)),
                elements: chain.elements().iter().map(element_out).collect(),
                frechet,
                hausdorff,
            })
        })
        .collect::<Result<_>>()?;

    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &OutputDoc { curves }).context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}

/// Discrete Fréchet and (vertex-to-polyline) Hausdorff distances between the
/// spline and the helix chain, each sampled at `m` points equally spaced in
/// its own arc length.
fn distances(spline: &BezierSpline, chain: &PiecewiseHelix, m: usize) -> Result<(f64, f64)> {
    let a = spline.sample_points(m)?;
    let b = chain.sample(m);
    Ok((
        metrics::discrete_frechet(&a, &b)?,
        metrics::hausdorff(&a, &b)?,
    ))
}

fn element_out(e: &crate::helix::HelixElement) -> ElementOut {
    ElementOut {
        start: e.start.to_array(),
        tangent: e.tangent.to_array(),
        normal: e.normal.to_array(),
        axis: e.axis().to_array(),
        curvature: e.curvature,
        torsion: e.torsion,
        length: e.length,
    }
}
