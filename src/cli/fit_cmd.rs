//! `strandfit fit`: Bézier splines in, G1 piecewise helices out.

use anyhow::{Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{self, input_name, read_input, Output};
use super::usage;
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

fn label(index: usize, id: &serde_json::Value) -> String {
    io_util::label("spline", "splines", index, id)
}

/// Read and validate a splines document (`{"splines":[{"id","control_points"}]}`):
/// the ids (absent ids become the index) and the splines. One bad spline
/// fails the whole read, with a message naming the input and the spline.
pub(super) fn read_splines(
    input: &Option<std::path::PathBuf>,
) -> Result<(Vec<serde_json::Value>, Vec<BezierSpline>)> {
    let name = input_name(input);
    let text = read_input(input)?;
    let doc: Input = serde_json::from_str(&text).with_context(|| {
        format!("{name}: expected {{\"splines\":[{{\"id\":…,\"control_points\":[[x,y,z],…]}}]}}")
    })?;
    drop(text);
    let splines = doc
        .splines
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let pts: Vec<DVec3> = s.control_points.iter().map(|&p| DVec3::from(p)).collect();
            let id = s.id.clone().unwrap_or(serde_json::Value::Null);
            BezierSpline::from_control_points(&pts)
                .with_context(|| format!("{name}: {}", label(i, &id)))
        })
        .collect::<Result<Vec<_>>>()?;
    let ids = doc
        .splines
        .into_iter()
        .enumerate()
        .map(|(i, s)| s.id.unwrap_or(serde_json::Value::from(i)))
        .collect();
    Ok((ids, splines))
}

pub fn run(args: &FitArgs, backend: &Backend) -> Result<()> {
    if args.elements == 0 {
        usage!("--elements must be at least 1");
    }
    if args.samples_per_element == 0 {
        usage!("--samples-per-element must be at least 1");
    }
    let (ids, splines) = read_splines(&args.input)?;
    let opts = FitOptions {
        relaxation: args.relaxation.into(),
        ..FitOptions::new(args.elements)
    };
    let samples = args.samples_per_element * args.elements + 1;
    let chains = backend.fit(&splines, &opts)?;
    let name = input_name(&args.input);
    let curves: Vec<CurveOut> = splines
        .par_iter()
        .zip(ids.par_iter())
        .zip(chains.into_par_iter())
        .enumerate()
        .map(|(i, ((spline, id), chain))| {
            let what = || format!("{name}: {}", label(i, id));
            let chain = chain.with_context(what)?;
            let (frechet, hausdorff) = distances(spline, &chain, samples).with_context(what)?;
            Ok(CurveOut {
                id: id.clone(),
                elements: chain.elements().iter().map(element_out).collect(),
                frechet,
                hausdorff,
            })
        })
        .collect::<Result<_>>()?;

    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &super::versioned(&OutputDoc { curves }))
        .context("cannot write output")?;
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
