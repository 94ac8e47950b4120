//! `strandfit integrate`: Frenet–Serret integration of curves whose
//! curvature and torsion are linear in arc length (3D Euler spirals), one
//! JSON Lines record per curve, on the chosen backend.

use anyhow::Result;
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::io_util::map_json_lines;
use super::usage;
use super::IntegrateArgs;
use crate::backend::Backend;
use crate::euler::{FrenetEnd, FrenetProblem};
use crate::kernels::frenet_integrate::SpiralSamples;

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

pub fn run(args: &IntegrateArgs, backend: &Backend) -> Result<()> {
    if args.steps == 0 {
        usage!("--steps must be at least 1");
    }
    if args.points == 1 {
        usage!("--points must be 0 (none) or at least 2 (both ends are included)");
    }
    map_json_lines(&args.input, &args.output, parse_line, |problems| {
        let ends = backend.integrate(problems, args.steps)?;
        let mut samples = if args.points >= 2 {
            let per = args.steps.div_ceil(args.points - 1);
            let s = backend.integrate_samples(problems, args.points, per)?;
            Some(s.into_iter())
        } else {
            None
        };
        Ok(ends
            .into_iter()
            .map(|end| {
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
            .collect())
    })
}

fn parse_line(line: &str) -> Result<FrenetProblem, String> {
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
