//! `strandfit bench`: throughput on synthetic splines, on the chosen backend:
//! Ghosh interpolation alone and the whole fit (elements/s), arc-length
//! sampling of the splines and evaluation of the fitted chains (points/s),
//! Frenet–Serret integration (spirals/s), with the GPU time of each split
//! into prepare / upload / wait / readback, and Euler-spiral completion
//! (completions/s: the default solver on the chosen backend, the paper's
//! Algorithm 1 on a few pairs on the CPU), ATPH Hermite interpolation
//! (interpolations/s, on the backend) and RRMF motions on the CPU (local
//! interpolations/s, whole-spline points/s). `--json`: the same rows on
//! standard output instead of the table (`docs/schemas/bench.schema.json`).

use std::time::Instant;

use super::BenchArgs;
use crate::backend::Backend;
use crate::euler::{paper_spiral, solve_spirals, FrenetProblem, PaperOptions, SolveOptions};
use crate::fit::{relaxed_pairs, FitOptions, FitScratch};
use crate::gpu::Timings;
use crate::helix::HermitePair;
use crate::rrmf::{default_frame, interpolate_local, minaj2_references, RrmfSpline};
use crate::synthetic::{
    random_spirals, spiral_end_pairs, synthetic_hermite_pairs, synthetic_local_motions,
    synthetic_splines, synthetic_streams,
};
use anyhow::Result;
use rayon::prelude::*;
use serde::Serialize;

/// Steps per spiral in the Frenet–Serret benchmark.
const FRENET_STEPS: usize = 64;

/// Deterministic Euler spirals with up to about two turns.
fn synthetic_spirals(n: usize) -> Vec<FrenetProblem> {
    (0..n)
        .map(|i| {
            let x = (i as f64 * 0.618_033_988_749_895).fract();
            let y = (i as f64 * 0.754_877_666_246_693).fract();
            FrenetProblem::new(
                crate::DVec3::new(x, y, 0.0),
                crate::DVec3::X,
                crate::DVec3::Y,
                0.5 + x,
                0.4 * (y - 0.5),
                2.0 * (x - 0.5),
                0.2 * y,
                2.0 + 4.0 * y,
            )
        })
        .collect()
}

/// Pairs the paper's Algorithm 1 is timed on (it is slow).
const PAPER_PAIRS: usize = 20;

/// Points per stream and samples per stream in the motion benchmark.
const MOTION_STREAM_POINTS: usize = 30;
const MOTION_SAMPLES: usize = 200;

/// Vertices of the drawing in the sketch benchmark.
const SKETCH_VERTICES: usize = 500;

/// Points per element in the decompression benchmark.
const EVAL_POINTS_PER_ELEMENT: usize = 8;

/// The `--json` report; `docs/schemas/bench.schema.json`.
#[derive(Debug, Serialize)]
pub struct BenchReport {
    /// The JSON schema version ([`super::JSON_VERSION`]).
    pub version: u32,
    /// The chosen backend: `cpu` or `gpu`.
    pub backend: &'static str,
    /// Its precision (the CPU's is `f64`).
    pub precision: &'static str,
    /// The GPU adapter (name, type, driver); `null` on the CPU.
    pub adapter: Option<String>,
    /// Worker threads (rayon).
    pub thread_count: usize,
    /// `--splines`.
    pub spline_count: usize,
    /// `--elements`.
    pub elements_per_curve: usize,
    /// `--segments`.
    pub segments_per_spline: usize,
    /// `--repeat`: timed runs per stage.
    pub run_count: usize,
    /// One per stage, in the order of the table.
    pub stages: Vec<Stage>,
}

/// One stage measured: a row of the table.
#[derive(Debug, Serialize)]
pub struct Stage {
    /// Its name, without the parameters (`whole_fit`, `sketch_lift`, …).
    pub stage: &'static str,
    /// The row's label in the table, with its parameters.
    pub label: String,
    /// Where it ran: the chosen backend, or `cpu` for the CPU-only stages.
    pub backend: &'static str,
    pub precision: &'static str,
    /// Items processed per run, in `unit`.
    pub item_count: u64,
    /// What an item is: `elements`, `points`, `spirals`, `completions`,
    /// `interpolations`, `vertices`.
    pub unit: &'static str,
    pub best_seconds: f64,
    pub median_seconds: f64,
    pub best_items_per_second: f64,
    pub median_items_per_second: f64,
    /// Items that failed (curves not fitted, pairs not converged or not
    /// interpolated), where the stage counts them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed_count: Option<u64>,
    /// The GPU time of the best run, where the stage ran on the GPU.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_split: Option<GpuSplit>,
}

/// A GPU stage's time, split.
#[derive(Debug, Serialize)]
pub struct GpuSplit {
    pub prepare_seconds: f64,
    pub upload_seconds: f64,
    pub wait_seconds: f64,
    pub readback_seconds: f64,
    pub chunk_count: u64,
}

/// The rows measured so far, printed as they come unless `--json`.
struct Table {
    json: bool,
    backend: &'static str,
    precision: &'static str,
    stages: Vec<Stage>,
}

impl Table {
    /// A row: `items` per run, `times` of the runs; `cpu_only` for the
    /// stages that run on the CPU whatever the backend.
    fn report(
        &mut self,
        stage: &'static str,
        label: &str,
        items: f64,
        unit: &'static str,
        cpu_only: bool,
        times: &mut [(f64, Timings)],
    ) {
        times.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (best, bt) = times[0];
        let (median, _) = times[times.len() / 2];
        if !self.json {
            println!(
                "{label}: best {best:.4} s {:>13.0} {unit}/s | median {median:.4} s {:>13.0} {unit}/s",
                items / best,
                items / median
            );
            if bt.chunks > 0 {
                println!(
                    "    gpu split (best run): prepare {:.4} s, upload {:.4} s, wait {:.4} s, readback {:.4} s, {} chunks",
                    bt.prepare.as_secs_f64(),
                    bt.upload.as_secs_f64(),
                    bt.wait.as_secs_f64(),
                    bt.readback.as_secs_f64(),
                    bt.chunks
                );
            }
        }
        let (backend, precision) = if cpu_only {
            ("cpu", "f64")
        } else {
            (self.backend, self.precision)
        };
        self.stages.push(Stage {
            stage,
            label: label.trim_end().to_string(),
            backend,
            precision,
            item_count: items as u64,
            unit,
            best_seconds: best,
            median_seconds: median,
            best_items_per_second: items / best,
            median_items_per_second: items / median,
            failed_count: None,
            gpu_split: (bt.chunks > 0).then_some(GpuSplit {
                prepare_seconds: bt.prepare.as_secs_f64(),
                upload_seconds: bt.upload.as_secs_f64(),
                wait_seconds: bt.wait.as_secs_f64(),
                readback_seconds: bt.readback.as_secs_f64(),
                chunk_count: bt.chunks as u64,
            }),
        });
    }

    /// The last row's failures, and in the table the note `  ({n} {what})`
    /// when there are any.
    fn failed(&mut self, n: usize, what: &str) {
        if let Some(s) = self.stages.last_mut() {
            s.failed_count = Some(n as u64);
        }
        if n > 0 && !self.json {
            println!("  ({n} {what})");
        }
    }
}

/// `repeat` timed runs of `job` (wall time and the GPU split of each).
fn time_runs<T>(
    repeat: usize,
    mut job: impl FnMut(&mut Timings) -> Result<T>,
) -> Result<(Vec<(f64, Timings)>, T)> {
    let mut times = Vec::with_capacity(repeat);
    let mut last = None;
    for _ in 0..repeat {
        let mut t = Timings::default();
        let start = Instant::now();
        let r = job(&mut t)?;
        times.push((start.elapsed().as_secs_f64(), t));
        last = Some(std::hint::black_box(r));
    }
    let last = last.ok_or_else(|| anyhow::anyhow!("--repeat must be at least 1"))?;
    Ok((times, last))
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let result = args.engine.open().and_then(|b| bench(args, &b));
    super::io_util::failure_report(result, args.json, None, None)
}

fn bench(args: &BenchArgs, backend: &Backend) -> Result<()> {
    if args.splines == 0 || args.elements == 0 || args.segments == 0 || args.repeat == 0 {
        super::usage!("--splines, --elements, --segments and --repeat must be at least 1");
    }
    let splines = synthetic_splines(args.splines, args.segments);
    let opts = FitOptions::new(args.elements);
    let elements = (splines.len() * args.elements) as f64;
    if !args.json {
        println!(
            "{} curves x {} elements ({} cubic segments each); backend {}; {} threads",
            splines.len(),
            args.elements,
            args.segments,
            backend.describe(),
            rayon::current_num_threads()
        );
    }
    let (name, precision, adapter) = match backend {
        Backend::Cpu => ("cpu", "f64", None),
        Backend::Gpu(g) => ("gpu", g.precision.name(), Some(g.ctx.describe())),
    };
    let mut table = Table {
        json: args.json,
        backend: name,
        precision,
        stages: Vec::new(),
    };

    // Interpolation alone, on the relaxed pairs of the synthetic fit.
    let mut pairs: Vec<HermitePair> = Vec::with_capacity(splines.len() * args.elements);
    let mut scratch = FitScratch::default();
    for s in &splines {
        relaxed_pairs(s, &opts, &mut scratch, &mut pairs)?;
    }
    let _ = backend.interpolate(&pairs[..pairs.len().min(1024)], opts.cohelical_tol)?; // warm-up, compile
    let (mut times, _) = time_runs(args.repeat, |t| {
        Ok(backend.interpolate_timed(&pairs, opts.cohelical_tol, t)?)
    })?;
    table.report(
        "ghosh_interpolation",
        "ghosh interpolation",
        pairs.len() as f64,
        "elements",
        false,
        &mut times,
    );
    drop(pairs);

    let (mut times, results) =
        time_runs(args.repeat, |t| Ok(backend.fit_timed(&splines, &opts, t)?))?;
    let failures = results.iter().filter(|r| r.is_err()).count();
    drop(results);
    table.report(
        "whole_fit",
        "whole fit          ",
        elements,
        "elements",
        false,
        &mut times,
    );
    table.failed(failures, "curves failed to fit");

    // Arc-length sampling of the input splines (spline_sample), at the
    // fit's `2N + 1` points.
    let n_samples = 2 * args.elements;
    let _ = backend.sample(&splines[..splines.len().min(16)], n_samples)?; // warm-up, compile
    let (mut times, _) = time_runs(args.repeat, |t| {
        Ok(backend.sample_timed(&splines, n_samples, t)?)
    })?;
    table.report(
        "spline_sampling",
        &format!("spline sampling ({} points/curve)", n_samples + 1),
        (splines.len() * (n_samples + 1)) as f64,
        "points",
        false,
        &mut times,
    );

    // Decompression: the fitted chains back to points (helix_eval), at
    // `EVAL_POINTS_PER_ELEMENT` points per element.
    let chains: Vec<_> = crate::fit::fit_splines(&splines, &opts)
        .into_iter()
        .filter_map(|r| r.ok())
        .collect();
    let m = EVAL_POINTS_PER_ELEMENT * args.elements + 1;
    let _ = backend.evaluate(&chains[..chains.len().min(16)], m)?; // warm-up, compile
    let (mut times, _) = time_runs(args.repeat, |t| Ok(backend.evaluate_timed(&chains, m, t)?))?;
    table.report(
        "helix_evaluation",
        &format!("helix evaluation ({m} points/curve)"),
        (chains.len() * m) as f64,
        "points",
        false,
        &mut times,
    );

    // Frenet–Serret integration of Euler spirals (one per curve), as the
    // Euler-spiral descent uses it: end point and frame after 64 steps.
    let problems = synthetic_spirals(args.splines);
    let _ = backend.integrate(&problems[..problems.len().min(16)], FRENET_STEPS)?;
    let (mut times, _) = time_runs(args.repeat, |t| {
        Ok(backend.integrate_timed(&problems, FRENET_STEPS, t)?)
    })?;
    table.report(
        "frenet_integration",
        &format!("frenet integration ({FRENET_STEPS} steps)"),
        problems.len() as f64,
        "spirals",
        false,
        &mut times,
    );

    // Euler-spiral completion between point–tangent pairs (one pair per
    // curve, from random spirals within one revolution): the default solver
    // on the chosen backend, and the paper's Algorithm 1 on a few of the
    // pairs on the CPU (all cores, rayon over pairs), for comparison.
    let pairs = spiral_end_pairs(&random_spirals(args.splines, 1));
    let opts = SolveOptions::default();
    let _ = solve_spirals(&pairs[..pairs.len().min(16)], &opts, backend)?; // warm-up, compile
    let (mut times, solved) =
        time_runs(args.repeat, |_| Ok(solve_spirals(&pairs, &opts, backend)?))?;
    let missed = solved
        .iter()
        .filter(|r| {
            r.as_ref().map_or(true, |s| {
                s.error > opts.for_backend(backend).converged_below()
            })
        })
        .count();
    drop(solved);
    table.report(
        "euler_completion",
        "euler completion (LM)",
        pairs.len() as f64,
        "completions",
        false,
        &mut times,
    );
    table.failed(missed, "pairs did not converge");
    let few = &pairs[..pairs.len().min(PAPER_PAIRS)];
    let paper = PaperOptions::default();
    let (mut times, _) = time_runs(args.repeat, |_| {
        Ok(few
            .par_iter()
            .map(|p| paper_spiral(p.p0, p.t0, p.p1, p.t1, &paper))
            .collect::<Vec<_>>())
    })?;
    table.report(
        "euler_completion_paper",
        &format!("euler completion (paper Alg. 1, cpu, {} pairs)", few.len()),
        few.len() as f64,
        "completions",
        true,
        &mut times,
    );

    // ATPH Hermite interpolation (paper 002) on the backend: one pair per
    // element, the ends of arcs of wandering helices.
    let atph_pairs = synthetic_hermite_pairs(args.splines * args.elements);
    let _ = backend.interpolate_atph(&atph_pairs[..atph_pairs.len().min(1024)], None)?; // warm-up, compile
    let (mut times, solved) = time_runs(args.repeat, |t| {
        Ok(backend.interpolate_atph_timed(&atph_pairs, None, t)?)
    })?;
    let failed = solved.iter().filter(|r| r.is_err()).count();
    drop(solved);
    table.report(
        "atph_interpolation",
        "atph interpolation",
        atph_pairs.len() as f64,
        "interpolations",
        false,
        &mut times,
    );
    table.failed(failed, "pairs could not be interpolated");
    drop(atph_pairs);

    // RRMF motions (paper 001), on the CPU with rayon whatever the backend:
    // local G1 Hermite interpolations with a one-sided frame (the rational
    // RMF included), and whole splines through 30-point streams sampled at
    // MOTION_SAMPLES points.
    let local = synthetic_local_motions(args.splines);
    let (mut times, _) = time_runs(args.repeat, |_| {
        Ok(local
            .par_iter()
            .filter(|p| interpolate_local(p.0, p.1, p.2, p.3).is_ok())
            .count())
    })?;
    table.report(
        "rrmf_local_interpolation",
        "rrmf local interpolation (cpu)",
        local.len() as f64,
        "interpolations",
        true,
        &mut times,
    );
    let streams = synthetic_streams(args.splines.div_ceil(100), MOTION_STREAM_POINTS);
    let (mut times, _) = time_runs(args.repeat, |_| {
        streams
            .par_iter()
            .map(|p| {
                let r = minaj2_references(p);
                let frame = default_frame(r[0]).ok_or_else(|| anyhow::anyhow!("zero reference"))?;
                let m = RrmfSpline::build(p, &r, frame, 0.125)?;
                Ok(m.sample(MOTION_SAMPLES).len())
            })
            .sum::<Result<usize>>()
    })?;
    table.report(
        "rrmf_spline",
        &format!(
            "rrmf spline ({MOTION_STREAM_POINTS}-point streams, build + {MOTION_SAMPLES} samples, cpu)"
        ),
        (streams.len() * MOTION_SAMPLES) as f64,
        "points",
        true,
        &mut times,
    );

    // Sketch to 3D (paper 003): one 500-vertex drawing at a time (two
    // helices; then four curls), rayon inside the lift (the paper: about a
    // minute in Matlab).
    let drawings = [
        (
            "sketch_lift",
            "",
            crate::synthetic::synthetic_sketch(SKETCH_VERTICES),
        ),
        (
            "sketch_lift_curls",
            "4 curls: ",
            crate::synthetic::synthetic_sketch_curls(SKETCH_VERTICES, 4),
        ),
    ];
    for (stage, kind, drawing) in &drawings {
        let (mut times, lifted) = time_runs(args.repeat, |_| {
            Ok(crate::sketch::lift_sketch(
                drawing,
                &crate::sketch::SketchOptions::default(),
            )?)
        })?;
        table.report(
            stage,
            &format!(
                "sketch lift ({SKETCH_VERTICES} vertices, {kind}{} helices, cpu)",
                lifted.helices.len()
            ),
            SKETCH_VERTICES as f64,
            "vertices",
            true,
            &mut times,
        );
    }
    if args.json {
        let report = BenchReport {
            version: super::JSON_VERSION,
            backend: table.backend,
            precision: table.precision,
            adapter,
            thread_count: rayon::current_num_threads(),
            spline_count: args.splines,
            elements_per_curve: args.elements,
            segments_per_spline: args.segments,
            run_count: args.repeat,
            stages: table.stages,
        };
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    Ok(())
}
