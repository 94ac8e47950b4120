//! `strandfit decompress IN.sfh -o OUT`: the container's helices back to
//! polylines in any supported format, in the source's coordinate convention
//! (the writer gets the source's affine and header back). `--json`: the
//! report on standard output (`docs/schemas/decompress.schema.json`).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use anyhow::{bail, Result};
use serde::Serialize;

use super::inspect_cmd::parse_format;
use super::io_util::{carried_data, check_losses, failure_report, size_on_disk, write_failed};
use super::usage;
use super::DecompressArgs;
use crate::io::{create_writer, ContainerReader, Curve, Format, Metadata, Shape};

/// The `--json` report; `docs/schemas/decompress.schema.json`.
#[derive(Debug, Serialize)]
pub struct DecompressReport {
    /// The JSON schema version ([`super::JSON_VERSION`]).
    pub version: u32,
    pub input: String,
    pub output: String,
    /// Always `sfh`.
    pub input_format: &'static str,
    pub output_format: &'static str,
    /// 3: the arc codec; 1: helix chains.
    pub container_version: u16,
    /// The container's tolerance (version 3: two-sided Hausdorff; version
    /// 1: as compressed, absent with a fixed element count).
    pub tolerance: Option<f64>,
    /// Every curve written is within `tolerance` of its input, two-sided:
    /// a version-3 container at its default points (not with
    /// `--points`/`--step`, nor for version 1).
    pub guaranteed: bool,
    /// `--points`, when given.
    pub points_per_curve: Option<usize>,
    /// `--step`, when given.
    pub step: Option<f64>,
    /// Index in the container of the first curve written (`--curves A:`).
    pub first: u64,
    /// Curves written.
    pub curve_count: u64,
    /// Curves in the container.
    pub container_curve_count: u64,
    /// Points written.
    pub output_point_count: u64,
    /// Per-point and per-curve values written to the output, by name.
    pub point_data_carried: Vec<String>,
    pub curve_data_carried: Vec<String>,
    /// What the output format does not hold (warned about on stderr).
    pub dropped: Vec<String>,
    /// Bytes read from the container (with `--curves`, only the blocks
    /// holding the range, its header and its index).
    pub bytes_in: u64,
    pub bytes_out: u64,
    pub seconds: f64,
    pub curves_per_second: f64,
    pub points_per_second: f64,
}

pub fn run(args: &DecompressArgs) -> Result<()> {
    let result = decompress(args);
    failure_report(result, args.json, Some(&args.input), Some(&args.output))
}

fn decompress(args: &DecompressArgs) -> Result<()> {
    if let Some(s) = args.step {
        if !(s > 0.0 && s.is_finite()) {
            usage!("--step must be positive, got {s}");
        }
    }
    if matches!(args.points, Some(m) if m < 2) {
        usage!("--points must be at least 2");
    }
    let to = args.to.as_deref().map(parse_format).transpose()?;
    if crate::codec::container_version(&args.input).is_some_and(|v| v >= 2) {
        return run_codec(args, to);
    }
    let started = Instant::now();
    let reader = ContainerReader::open(&args.input)?;
    if args.curves.is_some() {
        bail!(
            "{}: --curves reads version-3 containers (blocks and an index); this is a \
             version-1 container",
            args.input.display()
        );
    }
    let header = reader.header().clone();
    let meta = header.source.to_metadata();
    let (mut writer, target, dropped) = output_writer(args, to, &meta)?;
    let mut n = 0u64;
    let mut points_out = 0u64;
    for c in reader {
        let c = c?;
        let points = shape_points(&c.shape, args.points, args.step, c.source_points);
        points_out += points.len() as u64;
        writer
            .write_curve(&Curve {
                id: c.id,
                points,
                point_data: Vec::new(),
                curve_data: c.curve_data,
            })
            .map_err(|e| write_failed(&args.input, n, &[], e))?;
        n += 1;
    }
    writer.finish()?;
    let (point_data_carried, curve_data_carried) = carried_data(&meta, target);
    let report = DecompressReport {
        container_version: 1,
        tolerance: header.tolerance,
        guaranteed: false,
        first: 0,
        curve_count: n,
        container_curve_count: n,
        output_point_count: points_out,
        point_data_carried,
        curve_data_carried,
        dropped,
        bytes_in: size_on_disk(&args.input),
        ..base_report(args, target, started)
    };
    finish(args, report, format!("{n} curves"))
}

/// A report with the paths, formats, sampling and output size filled in
/// (and the clock read); the counts are the caller's.
fn base_report(args: &DecompressArgs, target: Format, started: Instant) -> DecompressReport {
    DecompressReport {
        version: super::JSON_VERSION,
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        input_format: "sfh",
        output_format: target.extension(),
        container_version: 0,
        tolerance: None,
        guaranteed: false,
        points_per_curve: args.points,
        step: args.step,
        first: 0,
        curve_count: 0,
        container_curve_count: 0,
        output_point_count: 0,
        point_data_carried: Vec::new(),
        curve_data_carried: Vec::new(),
        dropped: Vec::new(),
        bytes_in: 0,
        bytes_out: size_on_disk(&args.output),
        seconds: started.elapsed().as_secs_f64(),
        curves_per_second: 0.0,
        points_per_second: 0.0,
    }
}

/// The report's rates; then the report on standard output (`--json`) or
/// the summary `{input} -> {output}: {what}` on stderr.
fn finish(args: &DecompressArgs, mut report: DecompressReport, what: String) -> Result<()> {
    let s = report.seconds.max(1e-9);
    report.curves_per_second = report.curve_count as f64 / s;
    report.points_per_second = report.output_point_count as f64 / s;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        eprintln!("{} -> {}: {what}", report.input, report.output);
    }
    Ok(())
}

/// The chain of a stored curve, or its verbatim points, as points: `m`
/// samples equally spaced in arc length, or at `step` apart (both ends
/// included).
fn shape_points(
    shape: &Shape,
    m: Option<usize>,
    step: Option<f64>,
    source_points: u64,
) -> Vec<glam::DVec3> {
    match shape {
        Shape::Empty => Vec::new(),
        Shape::Points(p) => p.clone(),
        Shape::Chain(c) => sample_chain(
            &crate::helix::PiecewiseHelix::from_params(c),
            m,
            step,
            source_points,
        ),
        Shape::Quantized(q) => sample_chain(
            &crate::helix::PiecewiseHelix::from_params(&q.dequantize()),
            m,
            step,
            source_points,
        ),
    }
}

fn sample_chain(
    chain: &crate::helix::PiecewiseHelix,
    m: Option<usize>,
    step: Option<f64>,
    source_points: u64,
) -> Vec<glam::DVec3> {
    let m = match (m, step) {
        (Some(m), _) => m,
        (None, Some(s)) => ((chain.length() / s).ceil() as usize + 1).min(1 << 24),
        (None, None) => (source_points as usize).clamp(2, 1 << 24),
    };
    chain.sample(m.max(2))
}

/// The writer of the output, in the source's convention, after the check of
/// what the target format cannot hold (warned about, or an error with
/// `--strict`); with the target format and what it drops.
fn output_writer(
    args: &DecompressArgs,
    to: Option<Format>,
    meta: &Metadata,
) -> Result<(Box<dyn crate::io::CurveWriter>, Format, Vec<String>)> {
    let target = match to {
        Some(f) => f,
        None => Format::from_path(&args.output)?,
    };
    let dropped = target.losses(meta);
    check_losses(&args.input, &args.output, &dropped, args.strict)?;
    Ok((
        create_writer(&args.output, Some(target), meta)?,
        target,
        dropped,
    ))
}

/// A version-3 container: the codec's points (the guarantee's), or a
/// resampling of them when asked.
fn run_codec(args: &DecompressArgs, to: Option<Format>) -> Result<()> {
    use crate::codec::{decompress_range, CodecReader};

    let started = Instant::now();
    let mut reader = CodecReader::open(&args.input)?;
    let header = reader.header().clone();
    let resampled = args.points.is_some() || args.step.is_some();
    if resampled {
        eprintln!(
            "warning: {}: resampling with --points/--step gives up the guarantee that every \
             curve is within {} of its input (it holds for the default points)",
            args.input.display(),
            header.tolerance
        );
    }
    let mut meta = header.source.to_metadata();
    meta.point_data_names = header.point_data_names.clone();
    let (mut writer, target, dropped) = output_writer(args, to, &meta)?;
    let (points, step) = (args.points, args.step);
    let width = header.point_data_names.len();
    let points_out = AtomicU64::new(0);
    let map = |c: crate::codec::DecodedCurve| {
        let c = crate::codec::output_curve(c, points, step, width);
        points_out.fetch_add(c.points.len() as u64, Ordering::Relaxed);
        c
    };
    let total = reader.curve_count();
    let range = match args.curves {
        None => 0..total,
        Some((a, b)) => a.unwrap_or(0).min(total)..b.unwrap_or(total).min(total),
    };
    let mut bar = super::io_util::DelayedBar::new(Some(range.end - range.start));
    let n = decompress_range(&mut reader, &mut *writer, &map, range.clone(), &mut |n| {
        bar.set(n)
    })
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    bar.finish();
    writer.finish()?;
    let (point_data_carried, curve_data_carried) = carried_data(&meta, target);
    let report = DecompressReport {
        container_version: crate::codec::CONTAINER_VERSION,
        tolerance: Some(header.tolerance),
        guaranteed: !resampled,
        first: range.start,
        curve_count: n,
        container_curve_count: total,
        output_point_count: points_out.into_inner(),
        point_data_carried,
        curve_data_carried,
        dropped,
        bytes_in: reader.bytes_read(),
        ..base_report(args, target, started)
    };
    let what = if args.curves.is_some() {
        format!(
            "curves {}..{} of {total} ({n} curves; read {} of {} bytes)",
            range.start,
            range.end,
            reader.bytes_read(),
            reader.size()
        )
    } else {
        format!("{n} curves")
    };
    finish(args, report, what)
}
