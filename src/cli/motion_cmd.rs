//! `strandfit motion IN.json -o OUT.json`: a rigid-body motion through a
//! point stream — the G1 spline of RRMF quintics of paper 001 with its
//! continuous rational rotation-minimising frame ([`crate::rrmf`]).
//!
//! Input `{"points":[[x,y,z],…], "frame":[[u…],[v…],[w…]], "c":0.125,
//! "tangents":[[…],…], "id":…}`: `frame` (optional) is the initial frame,
//! default `u` along the first MinAJ2 reference tangent and any `v`;
//! `c` (optional, default 1/8) is Algorithm 1's parameter; `tangents`
//! (optional, one per point) are reference tangents for analytic data,
//! default MinAJ2 estimates. One stream per document, or one per line with
//! `--lines` (in parallel; each line gets its answer or its error).

use std::path::Path;

use anyhow::{Context, Result};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::io_util::{input_name, map_json_lines, read_input, Output};
use super::usage;
use super::MotionArgs;
use crate::io::{write_framed_paths, FramedPath};
use crate::rrmf::{default_frame, minaj2_references, validate_points, RrmfSpline};

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Stream {
    #[serde(default)]
    id: Option<serde_json::Value>,
    points: Vec<[f64; 3]>,
    #[serde(default)]
    frame: Option<[[f64; 3]; 3]>,
    #[serde(default)]
    c: Option<f64>,
    #[serde(default)]
    tangents: Option<Vec<[f64; 3]>>,
}

#[derive(Serialize)]
struct SegmentOut {
    /// The data segment (points k to k+1) this quintic belongs to.
    data_segment: usize,
    /// Bézier control points r0…r5 (Eq. 2.10).
    control_points: Vec<[f64; 3]>,
    /// Pre-image A0, A1, A2 as (a0, a1, a2, a3) quaternions (Eq. 2.6).
    pre_image: Vec<[f64; 4]>,
    /// W = a + i b in Bernstein form, (a, b) per coefficient: the RMF is
    /// f_k = B e_k B* / |B|², B = A W.
    w: Vec<[f64; 2]>,
    mu: f64,
    length: f64,
}

#[derive(Serialize)]
struct InsertedOut {
    after: usize,
    point: [f64; 3],
    tangent: [f64; 3],
    tau: f64,
}

#[derive(Serialize)]
struct SampleOut {
    u: f64,
    position: [f64; 3],
    f1: [f64; 3],
    f2: [f64; 3],
    f3: [f64; 3],
}

#[derive(Serialize)]
struct MotionOut {
    #[serde(skip_serializing_if = "Option::is_none")]
    id: Option<serde_json::Value>,
    segments: Vec<SegmentOut>,
    inserted: Vec<InsertedOut>,
    /// Total arc length (exact: PH curves).
    length: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    samples: Option<Vec<SampleOut>>,
}

/// Build one stream's motion.
fn solve(s: &Stream) -> Result<RrmfSpline, String> {
    let points: Vec<DVec3> = s.points.iter().map(|p| DVec3::from(*p)).collect();
    validate_points(&points).map_err(|e| e.to_string())?;
    let references = match &s.tangents {
        Some(t) => {
            if t.len() != points.len() {
                return Err(format!("{} points but {} tangents", points.len(), t.len()));
            }
            t.iter().map(|v| DVec3::from(*v)).collect()
        }
        None => minaj2_references(&points),
    };
    let frame = match s.frame {
        Some(f) => checked_frame(f)?,
        None => default_frame(references[0])
            .ok_or("the first reference tangent is zero or not finite")?,
    };
    RrmfSpline::build(&points, &references, frame, s.c.unwrap_or(0.125)).map_err(|e| e.to_string())
}

/// The given frame, re-orthonormalised when within 1e-6 of orthonormal
/// (frames typed with a few digits), refused otherwise.
fn checked_frame(f: [[f64; 3]; 3]) -> Result<[DVec3; 3], String> {
    let [u, v, w] = f.map(DVec3::from);
    if !(u.is_finite() && v.is_finite() && w.is_finite()) {
        return Err("the frame is not finite".into());
    }
    let err = [
        (u.length() - 1.0).abs(),
        (v.length() - 1.0).abs(),
        (w.length() - 1.0).abs(),
        u.dot(v).abs(),
        (u.cross(v) - w).length(),
    ]
    .into_iter()
    .fold(0.0f64, f64::max);
    if err > 1e-6 {
        return Err(format!(
            "the frame [u, v, w] must be orthonormal and right-handed (w = u x v); off by {err:.2e}"
        ));
    }
    let u = u.normalize();
    let v = (v - v.dot(u) * u).normalize();
    Ok([u, v, u.cross(v)])
}

fn arr(v: DVec3) -> [f64; 3] {
    v.to_array()
}

fn answer(id: Option<serde_json::Value>, m: &RrmfSpline, samples: usize) -> MotionOut {
    let segments = m
        .segments
        .iter()
        .map(|s| SegmentOut {
            data_segment: s.data_segment,
            control_points: s
                .curve
                .curve
                .control_points()
                .iter()
                .map(|p| arr(*p))
                .collect(),
            pre_image: s
                .curve
                .curve
                .pre_image
                .iter()
                .map(|q| q.to_array())
                .collect(),
            w: s.curve.w.iter().map(|q| [q.s, q.v.x]).collect(),
            mu: s.mu,
            length: s.curve.curve.length(),
        })
        .collect();
    let inserted = m
        .inserted
        .iter()
        .map(|i| InsertedOut {
            after: i.after,
            point: arr(i.point),
            tangent: arr(i.tangent),
            tau: i.tau,
        })
        .collect();
    let last = *m.knots.last().unwrap_or(&0.0);
    let samples = (samples >= 2).then(|| {
        m.sample(samples)
            .into_iter()
            .enumerate()
            .map(|(k, (p, f))| SampleOut {
                u: last * k as f64 / (samples - 1) as f64,
                position: arr(p),
                f1: arr(f[0]),
                f2: arr(f[1]),
                f3: arr(f[2]),
            })
            .collect()
    });
    MotionOut {
        id,
        segments,
        inserted,
        length: m.segments.iter().map(|s| s.curve.curve.length()).sum(),
        samples,
    }
}

fn framed(m: &RrmfSpline, samples: usize) -> FramedPath {
    let n = if samples >= 2 {
        samples
    } else {
        20 * m.segments.len() + 1
    };
    let (points, frames) = m.sample(n).into_iter().unzip();
    FramedPath { points, frames }
}

fn write_vtk(path: &Path, paths: &[FramedPath]) -> Result<()> {
    write_framed_paths(
        path,
        "strandfit motion: RRMF quintic splines with f1 f2 f3",
        paths,
    )
    .map_err(anyhow::Error::from)
}

pub fn run(args: &MotionArgs) -> Result<()> {
    if args.points == 1 {
        usage!("--points must be 0 (none) or at least 2");
    }
    let lines = args.lines
        || args.input.as_ref().is_some_and(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("jsonl" | "ndjson")
            )
        });
    let name = input_name(&args.input);
    if lines {
        let mut paths = Vec::new();
        map_json_lines(
            &args.input,
            &args.output,
            |line| serde_json::from_str::<Stream>(line).map_err(|e| format!("bad stream: {e}")),
            |streams| {
                let built: Vec<Result<RrmfSpline, String>> =
                    streams.par_iter().map(solve).collect();
                if args.vtk.is_some() {
                    paths.extend(built.iter().flatten().map(|m| framed(m, args.points)));
                }
                Ok(built
                    .into_iter()
                    .zip(streams)
                    .map(|(r, s)| r.map(|m| answer(s.id.clone(), &m, args.points)))
                    .collect())
            },
        )?;
        if let Some(v) = &args.vtk {
            write_vtk(v, &paths)?;
        }
        return Ok(());
    }
    let text = read_input(&args.input)?;
    let stream: Stream = serde_json::from_str(&text).with_context(|| {
        format!("{name}: expected {{\"points\":[[x,y,z],…], \"frame\"?, \"c\"?, \"tangents\"?}} (use --lines for JSON Lines)")
    })?;
    let motion = solve(&stream).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let out_doc = answer(stream.id.clone(), &motion, args.points);
    let mut out = Output::create(&args.output)?;
    serde_json::to_writer(out.writer(), &super::versioned(&out_doc))
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    if let Some(v) = &args.vtk {
        write_vtk(v, &[framed(&motion, args.points)])?;
    }
    out.commit()
}
