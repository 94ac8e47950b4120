//! `strandfit compress IN -o OUT.sfh`: curves from any supported file into
//! the container, each fitted with the fewest helices within the tolerance
//! (or a fixed count or element length), in parallel, streamed in batches.
//! `decompress` is the way back.

use std::time::Instant;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;

use super::inspect_cmd::parse_format;
use super::io_util::{check_losses, report_skipped, write_failed, DelayedBar};
use super::usage;
use super::{CompressArgs, DistanceArg, EffortArg, StorageArg};
use crate::adaptive::{Distance, ElementCount};
use crate::backend::Backend;
use crate::codec::{ArcChecker, Effort};
use crate::compress::{compress_curve, CompressOptions};
use crate::io::{
    data_losses, open_reader_with, source_losses, BadCurves, ContainerHeader, ContainerWriter,
    Curve, CurveReader, Metadata, Shape, SourceMeta, Storage, StoredCurve,
};

/// Curves fitted per parallel batch (bounds memory; keeps order).
const BATCH: usize = 4096;

/// The `--json` report (also printed as text); `docs/schemas/compress.schema.json`.
#[derive(Debug, Serialize)]
pub struct CompressReport {
    /// The JSON schema version ([`super::JSON_VERSION`]).
    pub version: u32,
    pub input: String,
    pub output: String,
    pub curve_count: u64,
    /// Points read from the input.
    pub point_count: u64,
    /// Helix elements written (version 1).
    pub element_count: u64,
    pub bytes_in: u64,
    pub bytes_out: u64,
    /// bytes in / bytes out.
    pub ratio: f64,
    pub distance: &'static str,
    /// `--effort`: `default` or `best` (version 1: `default`).
    pub effort: &'static str,
    pub tolerance: Option<f64>,
    /// Container version written (3: the arc codec; 1: helix chains).
    pub container_version: u16,
    /// Mean fitted distance (version 1 only: version 3 checks each curve
    /// against the tolerance, and does not measure below it).
    pub mean_distance: Option<f64>,
    /// Largest distance (version 3: the tolerance, which every curve is
    /// guaranteed to meet at default decompression).
    pub max_distance: f64,
    /// Points the default decompression writes (version 3).
    pub output_point_count: u64,
    /// Curves whose decoded chain is not within the tolerance (the search
    /// hit `--max-elements`).
    pub over_tolerance_count: u64,
    /// Curves stored verbatim (empty, one point, unfittable).
    pub verbatim_count: u64,
    /// Curves stored as their points because that is smaller.
    pub points_cheaper_count: u64,
    /// Curves stored as arcs (version 3).
    pub arc_count: u64,
    /// Indices (in the input) of the curves `--skip-bad` left out.
    pub skipped: Vec<u64>,
    /// What the container does not hold (warned about on stderr).
    pub dropped: Vec<String>,
    pub seconds: f64,
    pub curves_per_second: f64,
    /// The candidate checks the GPU backend ran (`--backend gpu` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_checks: Option<GpuChecks>,
}

impl Default for CompressReport {
    fn default() -> Self {
        CompressReport {
            version: super::JSON_VERSION,
            input: String::new(),
            output: String::new(),
            curve_count: 0,
            point_count: 0,
            element_count: 0,
            bytes_in: 0,
            bytes_out: 0,
            ratio: 0.0,
            distance: "",
            effort: "default",
            tolerance: None,
            container_version: 0,
            mean_distance: None,
            max_distance: 0.0,
            output_point_count: 0,
            over_tolerance_count: 0,
            verbatim_count: 0,
            points_cheaper_count: 0,
            arc_count: 0,
            skipped: Vec::new(),
            dropped: Vec::new(),
            seconds: 0.0,
            curves_per_second: 0.0,
            gpu_checks: None,
        }
    }
}

/// What `compress --backend gpu` did on the GPU.
#[derive(Debug, Default, Serialize)]
pub struct GpuChecks {
    /// Candidate elements checked on the GPU.
    pub candidate_count: u64,
    /// Batches (rounds of the search), summed over blocks.
    pub round_count: u64,
    /// Verdicts within rounding of the tolerance, decided by the CPU.
    pub unsure_count: u64,
    /// Blocks the GPU could not take (finished on the CPU).
    pub cpu_block_count: u64,
}

pub fn run(args: &CompressArgs, backend: &Backend) -> Result<()> {
    if args.distance == DistanceArg::Hausdorff {
        let v1_only = [
            (args.elements.is_some(), "--elements"),
            (args.element_length.is_some(), "--element-length"),
            (args.storage != StorageArg::Compact, "--storage f32|f64"),
        ];
        if let Some((_, what)) = v1_only.iter().find(|(given, _)| *given) {
            usage!(
                "{what} writes a version-1 helix container, which measures the ordered or \
                 Fréchet distance: add --distance ordered (or frechet)"
            );
        }
        return run_codec(args, backend);
    }
    if args.effort != EffortArg::Default {
        usage!("--effort is the arc codec's (--distance hausdorff), not the version-1 helix container's");
    }
    let count = match (args.tolerance, args.elements, args.element_length) {
        (Some(t), None, None) => ElementCount::Tolerance(t),
        (None, Some(n), None) => ElementCount::Fixed(n),
        (None, None, Some(s)) => ElementCount::ElementLength(s),
        _ => usage!("give exactly one of --tolerance, --elements, --element-length"),
    };
    match count {
        ElementCount::Tolerance(t) | ElementCount::ElementLength(t)
            if !(t > 0.0 && t.is_finite()) =>
        {
            usage!("--tolerance and --element-length must be positive, got {t}")
        }
        ElementCount::Fixed(0) => usage!("--elements must be at least 1"),
        _ => {}
    }
    for (name, v) in [
        ("--fit-share", args.fit_share),
        ("--smoothing-share", args.smoothing_share),
    ] {
        if !(v > 0.0 && v <= 1.0) {
            usage!("{name} must be in (0, 1], got {v}");
        }
    }
    let storage = match args.storage {
        StorageArg::Compact => Storage::Compact,
        StorageArg::F32 => Storage::F32,
        StorageArg::F64 => Storage::F64,
    };
    let distance = match args.distance {
        // Hausdorff is version 3, handled above.
        DistanceArg::Ordered | DistanceArg::Hausdorff => Distance::Ordered,
        DistanceArg::Frechet => Distance::Frechet,
    };
    let opts = CompressOptions {
        max_elements: args.max_elements,
        distance,
        fit_share: args.fit_share,
        smoothing_share: args.smoothing_share,
        ..CompressOptions::new(count, storage)
    };
    let started = Instant::now();
    let (mut reader, meta, dropped) = open_input(args, false)?;
    let header = ContainerHeader {
        storage,
        tolerance: args.tolerance,
        mode: match count {
            ElementCount::Tolerance(t) => format!("tolerance {t} ({distance:?})"),
            ElementCount::Fixed(n) => format!("elements {n}"),
            ElementCount::ElementLength(s) => format!("element length {s}"),
        },
        source: SourceMeta::from_metadata(&meta, Some(&args.input)),
        dropped_point_data: meta.point_data_names.clone(),
        written_by: format!("strandfit {}", env!("CARGO_PKG_VERSION")),
    };
    let mut writer = ContainerWriter::create(&args.output, header)?;
    let bar = match meta.count {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {pos}/{len} curves {per_sec} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut report = CompressReport {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        distance: match distance {
            Distance::Ordered => "ordered",
            Distance::Frechet => "frechet",
        },
        tolerance: args.tolerance,
        container_version: 1,
        dropped,
        ..Default::default()
    };
    let mut sum_distance = 0.0;
    let mut fitted = 0u64;
    let mut notes = 0;
    let mut batch: Vec<Curve> = Vec::with_capacity(BATCH);
    let mut done = false;
    while !done {
        batch.clear();
        while batch.len() < BATCH {
            match reader.next() {
                Some(c) => batch.push(c?),
                None => {
                    done = true;
                    break;
                }
            }
        }
        let outcomes: Vec<_> = batch
            .par_iter()
            .map(|c| compress_curve(&c.points, &opts))
            .collect();
        for (c, o) in batch.iter().zip(outcomes) {
            let index = report.curve_count;
            report.curve_count += 1;
            report.point_count += c.points.len() as u64;
            report.element_count += o.elements as u64;
            if let Some(why) = &o.verbatim {
                report.verbatim_count += 1;
                if notes < 10 {
                    eprintln!("note: {}, curve {index}: {why}", args.input.display());
                    notes += 1;
                }
            } else {
                fitted += 1;
                sum_distance += o.frechet;
            }
            // Verbatim points carry their float32 rounding (0 for float32
            // sources): the maximum is over every curve.
            report.max_distance = report.max_distance.max(o.frechet);
            if o.points_cheaper {
                report.points_cheaper_count += 1;
            }
            if !o.within {
                report.over_tolerance_count += 1;
            }
            let mut record = StoredCurve {
                id: c.id.clone(),
                source_points: c.points.len() as u64,
                curve_data: c.curve_data.clone(),
                shape: o.shape,
            };
            if let Err(e) = writer.write(&record) {
                // A chain the container refuses (it would not decode to
                // usable points: degenerate scales) is stored as its
                // points; anything else is an error.
                if matches!(record.shape, Shape::Points(_) | Shape::Empty) {
                    return Err(write_failed(&args.input, index, reader.skipped(), e));
                }
                record.shape = Shape::Points(c.points.clone());
                writer
                    .write(&record)
                    .map_err(|e| write_failed(&args.input, index, reader.skipped(), e))?;
                report.verbatim_count += 1;
                if notes < 10 {
                    eprintln!(
                        "note: {}, curve {index}: stored verbatim: {}",
                        args.input.display(),
                        e.reason
                    );
                    notes += 1;
                }
            }
        }
        bar.inc(batch.len() as u64);
    }
    report.skipped = reader.skipped().iter().map(|s| s.index).collect();
    report_skipped(&args.input, reader.skipped());
    report.bytes_out = writer.finish()?;
    bar.finish_and_clear();
    report.bytes_in = std::fs::metadata(&args.input).map(|m| m.len()).unwrap_or(0);
    report.ratio = report.bytes_in as f64 / report.bytes_out.max(1) as f64;
    report.mean_distance = Some(if fitted > 0 {
        sum_distance / fitted as f64
    } else {
        0.0
    });
    report.seconds = started.elapsed().as_secs_f64();
    report.curves_per_second = report.curve_count as f64 / report.seconds.max(1e-9);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        eprintln!(
            "{} -> {}: {} curves, {} points -> {} elements; {} -> {} bytes (ratio {:.2}); \
             {} distance mean {:.4} max {:.4}{}; {} verbatim, {} as points (smaller), {} over tolerance; \
             {:.0} curves/s",
            report.input,
            report.output,
            report.curve_count,
            report.point_count,
            report.element_count,
            report.bytes_in,
            report.bytes_out,
            report.ratio,
            report.distance,
            report.mean_distance.unwrap_or(0.0),
            report.max_distance,
            args.tolerance
                .map(|t| format!(" (tolerance {t})"))
                .unwrap_or_default(),
            report.verbatim_count,
            report.points_cheaper_count,
            report.over_tolerance_count,
            report.curves_per_second
        );
    }
    Ok(())
}

/// The input's reader (bad curves failing or skipped as asked), its
/// metadata, and what the container will not hold (warned about, or an
/// error with `--strict`): per-point data (in a version-1 container) and
/// source content the reader does not carry.
fn open_input(
    args: &CompressArgs,
    keeps_point_data: bool,
) -> Result<(Box<dyn CurveReader>, Metadata, Vec<String>)> {
    let from = args.from.as_deref().map(parse_format).transpose()?;
    let bad = if args.care.skip_bad {
        BadCurves::Skip
    } else {
        BadCurves::Fail
    };
    let reader = open_reader_with(&args.input, from, bad)?;
    let meta = reader.metadata().clone();
    let mut dropped = source_losses(&meta);
    dropped.extend(data_losses(&meta, |_| keeps_point_data, true, "sfh"));
    check_losses(&args.input, &args.output, &dropped, args.care.strict)?;
    Ok((reader, meta, dropped))
}

/// `compress` with the arc codec into a version-3 container: every curve
/// within `--tolerance` in the two-sided Hausdorff distance at default
/// decompression.
fn run_codec(args: &CompressArgs, backend: &Backend) -> Result<()> {
    use crate::codec::{compress_stream, CodecHeader};

    let Some(tolerance) = args.tolerance else {
        usage!("give --tolerance (or --elements / --element-length with --distance ordered)");
    };
    if !(tolerance > 0.0 && tolerance.is_finite()) {
        usage!("--tolerance must be positive, got {tolerance}");
    }
    let started = Instant::now();
    let (mut reader, meta, dropped) = open_input(args, true)?;
    // The input's name is not stored: the output's name says what it was,
    // and in a farm the name is bytes in every file.
    let mut header = CodecHeader::new(
        tolerance,
        SourceMeta::from_metadata(&meta, None),
        meta.point_data_names.clone(),
    );
    header.effort = match args.effort {
        EffortArg::Default => Effort::Default,
        EffortArg::Best => Effort::Best,
    };
    let mut bar = DelayedBar::new(meta.count);
    let checker = backend.arc_checker()?;
    let checker = checker.as_ref().map(|c| c as &dyn ArcChecker);
    let summary = compress_stream(
        &mut *reader,
        &args.input,
        &args.output,
        &header,
        checker,
        &mut |n| bar.set(n),
    )
    .map_err(|mut e| {
        // An error about the input names its curve as counted in the
        // input, skipped curves included.
        if e.path == args.input {
            if let Some(mut c) = e.curve {
                for s in reader.skipped() {
                    if s.index <= c {
                        c += 1;
                    }
                }
                e.curve = Some(c);
            }
        }
        anyhow::Error::from(e)
    })?;
    bar.finish();
    report_skipped(&args.input, reader.skipped());
    let bytes_in = std::fs::metadata(&args.input).map(|m| m.len()).unwrap_or(0);
    let seconds = started.elapsed().as_secs_f64();
    let report = CompressReport {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        curve_count: summary.curves,
        point_count: summary.points,
        element_count: 0,
        bytes_in,
        bytes_out: summary.bytes,
        ratio: bytes_in as f64 / summary.bytes.max(1) as f64,
        distance: "hausdorff",
        effort: header.effort.name(),
        tolerance: Some(tolerance),
        container_version: 3,
        mean_distance: None,
        max_distance: tolerance,
        output_point_count: summary.output_points,
        over_tolerance_count: 0,
        verbatim_count: summary.kinds[3],
        points_cheaper_count: summary.kinds[1],
        arc_count: summary.kinds[2],
        skipped: reader.skipped().iter().map(|s| s.index).collect(),
        dropped,
        seconds,
        curves_per_second: summary.curves as f64 / seconds.max(1e-9),
        gpu_checks: matches!(backend, Backend::Gpu(_)).then_some(GpuChecks {
            candidate_count: summary.batch_checked,
            round_count: summary.batch_rounds,
            unsure_count: summary.batch_unsure,
            cpu_block_count: summary.batch_fallbacks,
        }),
        ..Default::default()
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        eprintln!(
            "{} -> {}: {} curves, {} points; {} -> {} bytes (ratio {:.2}); every curve within \
             {tolerance} (two-sided Hausdorff) at default decompression ({} points); {} as arcs, \
             {} as points, {} verbatim; {:.0} curves/s",
            report.input,
            report.output,
            report.curve_count,
            report.point_count,
            report.bytes_in,
            report.bytes_out,
            report.ratio,
            report.output_point_count,
            report.arc_count,
            report.points_cheaper_count,
            report.verbatim_count,
            report.curves_per_second
        );
        if let Some(g) = &report.gpu_checks {
            eprintln!(
                "GPU: {} candidate elements checked in {} rounds, {} too near the tolerance \
                 (decided on the CPU), {} blocks on the CPU",
                g.candidate_count, g.round_count, g.unsure_count, g.cpu_block_count
            );
        }
    }
    Ok(())
}
