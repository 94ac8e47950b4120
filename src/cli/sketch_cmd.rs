//! `strandfit sketch IN -o OUT.json`: a 2D drawing lifted to a 3D piecewise
//! helix (paper 003, [`crate::sketch`]).
//!
//! Input: a polyline as JSON (`[[x,y],…]` or `{"points":[…]}`), CSV/TXT
//! (`x,y` per line) or SVG (the first path, polyline or polygon; curves
//! flattened), by extension ([`crate::io::read_sketch`]). Output: the helices
//! (`a`, `b`, `c`, placement, mirror, `z0`, parameter and vertex ranges,
//! worst vertex distance), the 3D polyline (the drawing's `x, y` with the
//! lifted `z`), per junction the tangent angle and position gap left, and
//! the projection error; `--preview` writes an SVG of the drawing with the
//! projected fit over it. `--g1` adds the lift re-fitted exactly G1 by the
//! floating-tangents fitter ([`crate::sketch::refit_g1`]): its chain in compact
//! form, samples of it, and how far its projection moved from the drawing.

use std::f64::consts::PI;

use anyhow::{Context, Result};
use glam::DVec2;
use serde::Serialize;

use super::io_util::Output;
use super::usage;
use super::{ResampleArg, SketchArgs};
use crate::io::{read_sketch, write_preview_svg};
use crate::sketch::{lift_sketch, refit_g1, G1Refit, Resampling, SketchLift, SketchOptions};

#[derive(Serialize)]
struct HelixOut {
    a: f64,
    b: f64,
    c: f64,
    radius: f64,
    pitch_per_turn: f64,
    theta: f64,
    origin: [f64; 2],
    reflect: bool,
    mirror: bool,
    z0: f64,
    t_start: f64,
    t_end: f64,
    first_vertex: usize,
    last_vertex: usize,
    /// The largest distance of its vertices from the projected helix.
    max_distance: f64,
}

#[derive(Serialize)]
struct JunctionOut {
    vertex: usize,
    tangent_angle_deg: f64,
    position_gap: f64,
}

#[derive(Serialize)]
struct SketchOut {
    input: String,
    length: f64,
    resampled: bool,
    /// `densify` or `uniform`; applied only where `resampled`.
    resampling: &'static str,
    /// E_max as a distance: `--emax` times the drawing's length, or (by
    /// default) the larger of 0.1 % of it and 5 times the noise.
    emax_distance: f64,
    /// The drawing's noise as estimated (standard deviation per
    /// coordinate, in the drawing's units).
    noise_distance: f64,
    /// Whether the drawing was denoised before the fit (`--no-denoise`).
    denoised: bool,
    alpha_t: f64,
    helices: Vec<HelixOut>,
    junctions: Vec<JunctionOut>,
    max_tangent_angle_deg: f64,
    /// How far the drawing is from the projected helices.
    projection: ProjectionOut,
    fine_fit: FineOut,
    points_3d: Vec<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    g1: Option<G1Out>,
}

#[derive(Serialize)]
struct G1Out {
    tolerance: f64,
    within_tolerance: bool,
    element_count: usize,
    /// The chain's distance from the lifted polyline (3D).
    distance_3d: f64,
    /// How far the chain's projection is from the drawing (in order).
    projection_distance: f64,
    continuity_gap: f64,
    continuity_angle_deg: f64,
    chain: ChainOut,
    /// Samples of the chain, 4 per vertex of the drawing.
    points_3d: Vec<[f64; 3]>,
}

#[derive(Serialize)]
struct ChainOut {
    start: [f64; 3],
    tangent: [f64; 3],
    normal: [f64; 3],
    /// `[length, curvature, torsion, twist]` per element.
    elements: Vec<[f64; 4]>,
}

fn g1_answer(g: &G1Refit, vertices: usize) -> G1Out {
    let params = g.chain.to_params();
    G1Out {
        tolerance: g.tolerance,
        within_tolerance: g.within_tolerance,
        element_count: g.chain.len(),
        distance_3d: g.distance_3d,
        projection_distance: g.projection_distance,
        continuity_gap: g.continuity.0,
        continuity_angle_deg: g.continuity.1.to_degrees(),
        chain: ChainOut {
            start: params.as_ref().map_or([0.0; 3], |p| p.start.to_array()),
            tangent: params.as_ref().map_or([0.0; 3], |p| p.tangent.to_array()),
            normal: params.as_ref().map_or([0.0; 3], |p| p.normal.to_array()),
            elements: params.map_or(Vec::new(), |p| {
                p.elements
                    .iter()
                    .map(|e| [e.length, e.curvature, e.torsion, e.twist])
                    .collect()
            }),
        },
        points_3d: g
            .chain
            .sample(4 * vertices.max(1))
            .iter()
            .map(|p| p.to_array())
            .collect(),
    }
}

#[derive(Serialize)]
struct ProjectionOut {
    /// Of the vertices fitted (denoised where `denoised`, evened out where
    /// `resampled`).
    max_distance: f64,
    /// Of the drawn vertices.
    drawn_max_distance: f64,
    rms_distance: f64,
    /// `max_distance` over the drawing's length.
    max_relative_distance: f64,
}

#[derive(Serialize)]
struct FineOut {
    iterations: usize,
    objective_before: f64,
    objective_after: f64,
}

fn answer(input: String, r: &SketchLift, opts: &SketchOptions) -> SketchOut {
    let helices = r
        .helices
        .iter()
        .map(|h| HelixOut {
            a: h.helix.a,
            b: h.helix.b,
            c: h.helix.c,
            radius: h.helix.a.abs(),
            pitch_per_turn: 2.0 * PI * h.helix.b.abs(),
            theta: h.theta,
            origin: h.origin.to_array(),
            reflect: h.reflect,
            mirror: h.mirror,
            z0: h.z0,
            t_start: h.t_start,
            t_end: h.t_end,
            first_vertex: h.first,
            last_vertex: h.last,
            max_distance: h.max_error,
        })
        .collect();
    let junctions: Vec<JunctionOut> = r
        .junctions
        .iter()
        .map(|j| JunctionOut {
            vertex: j.vertex,
            tangent_angle_deg: j.tangent_angle.to_degrees(),
            position_gap: j.position_gap,
        })
        .collect();
    SketchOut {
        input,
        length: r.length,
        resampled: r.resampled,
        resampling: match opts.resampling {
            Resampling::Densify => "densify",
            Resampling::Uniform => "uniform",
        },
        emax_distance: r.emax,
        noise_distance: r.noise,
        denoised: r.denoised,
        alpha_t: opts.alpha_t,
        helices,
        max_tangent_angle_deg: junctions
            .iter()
            .map(|j| j.tangent_angle_deg)
            .fold(0.0, f64::max),
        junctions,
        projection: ProjectionOut {
            max_distance: r.max_error,
            drawn_max_distance: r.drawn_error,
            rms_distance: r.rms_error,
            max_relative_distance: r.max_error / r.length,
        },
        fine_fit: FineOut {
            iterations: r.fine_fit.iterations,
            objective_before: r.fine_fit.before,
            objective_after: r.fine_fit.after,
        },
        points_3d: r.points_3d.iter().map(|p| p.to_array()).collect(),
        g1: None,
    }
}

/// The projected fit of each helix, sampled for the preview.
fn projected_pieces(r: &SketchLift) -> Vec<Vec<DVec2>> {
    r.helices
        .iter()
        .map(|h| {
            let m = 8 * (h.last - h.first).max(1) + 1;
            (0..m)
                .map(|k| h.point_2d(h.t_start + (h.t_end - h.t_start) * k as f64 / (m - 1) as f64))
                .collect()
        })
        .collect()
}

pub fn run(args: &SketchArgs) -> Result<()> {
    let opts = SketchOptions {
        emax: args.emax,
        alpha_t: args.alpha_t,
        resampling: match args.resample {
            ResampleArg::Densify => Resampling::Densify,
            ResampleArg::Uniform => Resampling::Uniform,
        },
        denoise: !args.no_denoise,
        ..Default::default()
    };
    if opts.emax.is_some_and(|e| !(e > 0.0 && e < 1.0)) {
        usage!("--emax must be in (0, 1): a fraction of the drawing's length");
    }
    if !(opts.alpha_t >= 0.0 && opts.alpha_t < 1.0) {
        usage!("--alpha-t must be in [0, 1)");
    }
    let points = read_sketch(&args.input)?;
    let name = args.input.display().to_string();
    let r =
        lift_sketch(&points, &opts).with_context(|| format!("{name}: cannot lift the sketch"))?;
    if let Some(preview) = &args.preview {
        let junctions: Vec<DVec2> = r.junctions.iter().map(|j| r.points_2d[j.vertex]).collect();
        write_preview_svg(preview, &points, &projected_pieces(&r), &junctions)?;
    }
    let g1 = if args.g1 {
        let t = args.g1_tolerance.unwrap_or(r.emax);
        if !(t > 0.0 && t.is_finite()) {
            usage!("--g1-tolerance must be positive and finite");
        }
        let g = refit_g1(&r, t).with_context(|| format!("{name}: G1 re-fit failed"))?;
        Some(g1_answer(&g, r.points_2d.len()))
    } else {
        None
    };
    let mut doc = answer(name.clone(), &r, &opts);
    doc.g1 = g1;
    let mut out = Output::create(&args.output)?;
    serde_json::to_writer_pretty(out.writer(), &super::versioned(&doc))
        .context("cannot write output")?;
    out.writer().write_all(b"\n")?;
    out.commit()
}
