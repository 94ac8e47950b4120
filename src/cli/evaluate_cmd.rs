//! `strandfit evaluate`: piecewise helices (the output of `fit`) back to
//! polylines — decompression — on the chosen backend.

use anyhow::{bail, Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{self, input_name, read_input, Output};
use super::usage;
use super::EvaluateArgs;
use crate::backend::Backend;
use crate::helix::{HelixElement, PiecewiseHelix};

#[derive(Deserialize)]
struct Input {
    curves: Vec<CurveIn>,
}

#[derive(Deserialize)]
struct CurveIn {
    id: Option<serde_json::Value>,
    elements: Vec<ElementIn>,
}

/// One element as `fit` writes it (extra fields such as `axis` are ignored).
#[derive(Deserialize)]
struct ElementIn {
    start: [f64; 3],
    tangent: [f64; 3],
    normal: [f64; 3],
    curvature: f64,
    torsion: f64,
    length: f64,
}

#[derive(Serialize)]
struct OutputDoc {
    curves: Vec<CurveOut>,
}

#[derive(Serialize)]
struct CurveOut {
    id: serde_json::Value,
    points: Vec<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tangents: Option<Vec<[f64; 3]>>,
}

/// How far from unit length and orthogonality a written frame may be: `fit`
/// writes unit vectors to ~1e-16; JSON round trips are exact; hand-edited or
/// single-precision sources get some slack.
const FRAME_TOL: f64 = 1e-6;

fn label(index: usize, id: &Option<serde_json::Value>) -> String {
    io_util::label(
        "curve",
        "curves",
        index,
        id.as_ref().unwrap_or(&serde_json::Value::Null),
    )
}

/// A validated element; the reason names what is wrong.
fn element(e: &ElementIn) -> Result<HelixElement, String> {
    let v = |a: [f64; 3]| DVec3::from(a);
    let (start, t, n) = (v(e.start), v(e.tangent), v(e.normal));
    let finite = start.is_finite()
        && t.is_finite()
        && n.is_finite()
        && e.curvature.is_finite()
        && e.torsion.is_finite()
        && e.length.is_finite();
    if !finite {
        return Err("a value is not finite".into());
    }
    if e.curvature < 0.0 {
        return Err(format!("negative curvature {}", e.curvature));
    }
    if e.length < 0.0 {
        return Err(format!("negative length {}", e.length));
    }
    if (t.length() - 1.0).abs() > FRAME_TOL || (n.length() - 1.0).abs() > FRAME_TOL {
        return Err("tangent and normal must be unit vectors".into());
    }
    if t.dot(n).abs() > FRAME_TOL {
        return Err("normal is not orthogonal to the tangent".into());
    }
    Ok(HelixElement {
        start,
        tangent: t.normalize(),
        // Re-orthogonalise so the frame is exact for the evaluation.
        normal: (n - t.dot(n) * t).normalize(),
        curvature: e.curvature,
        torsion: e.torsion,
        length: e.length,
    })
}

pub fn run(args: &EvaluateArgs, backend: &Backend) -> Result<()> {
    if args.points < 2 {
        usage!("--points must be at least 2 (both ends are included)");
    }
    let name = input_name(&args.input);
    let text = read_input(&args.input)?;
    let input: Input = serde_json::from_str(&text).with_context(|| {
        format!(
            "{name}: expected the output of `strandfit fit`: \
             {{\"curves\":[{{\"id\":…,\"elements\":[{{\"start\",\"tangent\",\"normal\",\
             \"curvature\",\"torsion\",\"length\"}}]}}]}}"
        )
    })?;
    drop(text);

    let chains: Vec<PiecewiseHelix> = input
        .curves
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            if c.elements.is_empty() {
                bail!("{name}: {}: no elements", label(i, &c.id));
            }
            let elements = c
                .elements
                .iter()
                .enumerate()
                .map(|(k, e)| {
                    element(e).map_err(|why| {
                        anyhow::anyhow!("{name}: {}: elements[{k}]: {why}", label(i, &c.id))
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(PiecewiseHelix::new(elements))
        })
        .collect::<Result<_>>()?;

    let samples = backend.evaluate(&chains, args.points)?;
    let curves: Vec<CurveOut> = input
        .curves
        .into_par_iter()
        .zip(samples.into_par_iter())
        .enumerate()
        .map(|(i, (c, s))| CurveOut {
            id: c.id.unwrap_or(serde_json::Value::from(i)),
            points: s.points.iter().map(|p| p.to_array()).collect(),
            tangents: args
                .tangents
                .then(|| s.tangents.iter().map(|t| t.to_array()).collect()),
        })
        .collect();

    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &super::versioned(&OutputDoc { curves }))
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}
