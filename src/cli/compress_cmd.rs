//! `strandfit compress IN -o OUT.sfh`: curves from any supported file into
//! the container, each fitted with the fewest helices within the tolerance
//! (or a fixed count or element length), in parallel, streamed in batches.
//! `decompress` is the way back.

use std::time::Instant;

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;

use super::inspect_cmd::parse_format;
use super::io_util::{check_losses, report_skipped, write_failed};
use super::{CompressArgs, DistanceArg, StorageArg};
use crate::adaptive::{Distance, ElementCount};
use crate::compress::{compress_curve, CompressOptions};
use crate::io::container::{ContainerWriter, Header, Shape, SourceMeta, Storage, StoredCurve};
use crate::io::{data_losses, open_reader_with, source_losses, BadCurves, Curve};

/// Curves fitted per parallel batch (bounds memory; keeps order).
const BATCH: usize = 4096;

/// The `--json` report (also printed as text).
#[derive(Debug, Default, Serialize)]
pub struct CompressReport {
    pub input: String,
    pub output: String,
    pub curves: u64,
    pub points: u64,
    pub elements: u64,
    pub bytes_in: u64,
    pub bytes_out: u64,
    /// bytes in / bytes out.
    pub ratio: f64,
    pub distance: &'static str,
    pub tolerance: Option<f64>,
    pub mean_distance: f64,
    pub max_distance: f64,
    /// Curves whose decoded chain is not within the tolerance (the search
    /// hit `--max-elements`).
    pub over_tolerance: u64,
    /// Curves stored verbatim (empty, one point, unfittable).
    pub verbatim: u64,
    /// Curves stored as their points because that is smaller.
    pub points_cheaper: u64,
    /// Indices (in the input) of the curves `--skip-bad` left out.
    pub skipped: Vec<u64>,
    /// What the container does not hold (warned about on stderr).
    pub dropped: Vec<String>,
    pub seconds: f64,
    pub curves_per_second: f64,
}

pub fn run(args: &CompressArgs) -> Result<()> {
    let count = match (args.tolerance, args.elements, args.element_length) {
        (Some(t), None, None) => ElementCount::Tolerance(t),
        (None, Some(n), None) => ElementCount::Fixed(n),
        (None, None, Some(s)) => ElementCount::ElementLength(s),
        _ => bail!("give exactly one of --tolerance, --elements, --element-length"),
    };
    match count {
        ElementCount::Tolerance(t) | ElementCount::ElementLength(t)
            if !(t > 0.0 && t.is_finite()) =>
        {
            bail!("--tolerance and --element-length must be positive, got {t}")
        }
        ElementCount::Fixed(0) => bail!("--elements must be at least 1"),
        _ => {}
    }
    for (name, v) in [
        ("--fit-share", args.fit_share),
        ("--smoothing-share", args.smoothing_share),
    ] {
        if !(v > 0.0 && v <= 1.0) {
            bail!("{name} must be in (0, 1], got {v}");
        }
    }
    let storage = match args.storage {
        StorageArg::Compact => Storage::Compact,
        StorageArg::F32 => Storage::F32,
        StorageArg::F64 => Storage::F64,
    };
    let distance = match args.distance {
        DistanceArg::Ordered => Distance::Ordered,
        DistanceArg::Frechet => Distance::Frechet,
    };
    let opts = CompressOptions {
        max_elements: args.max_elements,
        distance,
        fit_share: args.fit_share,
        smoothing_share: args.smoothing_share,
        ..CompressOptions::new(count, storage)
    };
    let from = args.from.as_deref().map(parse_format).transpose()?;
    let started = Instant::now();
    let bad = if args.care.skip_bad {
        BadCurves::Skip
    } else {
        BadCurves::Fail
    };
    let mut reader = open_reader_with(&args.input, from, bad)?;
    let meta = reader.metadata().clone();
    // The container keeps per-curve data, not per-point data.
    let mut dropped = source_losses(&meta);
    dropped.extend(data_losses(&meta, |_| false, true, "sfh"));
    check_losses(&args.input, &args.output, &dropped, args.care.strict)?;
    let header = Header {
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
            let index = report.curves;
            report.curves += 1;
            report.points += c.points.len() as u64;
            report.elements += o.elements as u64;
            if let Some(why) = &o.verbatim {
                report.verbatim += 1;
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
                report.points_cheaper += 1;
            }
            if !o.within {
                report.over_tolerance += 1;
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
                report.verbatim += 1;
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
    report.mean_distance = if fitted > 0 {
        sum_distance / fitted as f64
    } else {
        0.0
    };
    report.seconds = started.elapsed().as_secs_f64();
    report.curves_per_second = report.curves as f64 / report.seconds.max(1e-9);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        eprintln!(
            "{} -> {}: {} curves, {} points -> {} elements; {} -> {} bytes (ratio {:.2}); \
             {} distance mean {:.4} max {:.4}{}; {} verbatim, {} as points (smaller), {} over tolerance; \
             {:.0} curves/s",
            report.input,
            report.output,
            report.curves,
            report.points,
            report.elements,
            report.bytes_in,
            report.bytes_out,
            report.ratio,
            report.distance,
            report.mean_distance,
            report.max_distance,
            args.tolerance
                .map(|t| format!(" (tolerance {t})"))
                .unwrap_or_default(),
            report.verbatim,
            report.points_cheaper,
            report.over_tolerance,
            report.curves_per_second
        );
    }
    Ok(())
}
