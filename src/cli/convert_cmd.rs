//! `strandfit convert IN -o OUT`: curves from one file format to another,
//! streamed, in world coordinates (the writer maps them back into its
//! format's convention). Per-point and per-curve data the target format
//! cannot hold, and source content the reader does not carry, are named in
//! a warning on stderr before anything is written (`--strict`: an error).
//! `--json`: the report on standard output
//! (`docs/schemas/convert.schema.json`).

use std::time::Instant;

use anyhow::Result;
use serde::Serialize;

use super::inspect_cmd::parse_format;
use super::io_util::{
    carried_data, check_losses, failure_report, report_skipped, size_on_disk, write_failed,
};
use super::ConvertArgs;
use crate::io::{create_writer, open_reader_with, source_losses, BadCurves, Format};

/// The `--json` report; `docs/schemas/convert.schema.json`.
#[derive(Debug, Serialize)]
pub struct ConvertReport {
    /// The JSON schema version ([`super::JSON_VERSION`]).
    pub version: u32,
    pub input: String,
    pub output: String,
    pub input_format: &'static str,
    pub output_format: &'static str,
    /// Curves written.
    pub curve_count: u64,
    /// Points written (those read, less the curves `--skip-bad` left out).
    pub point_count: u64,
    /// Per-point and per-curve values written to the output, by name.
    pub point_data_carried: Vec<String>,
    pub curve_data_carried: Vec<String>,
    /// What the output does not hold (warned about on stderr).
    pub dropped: Vec<String>,
    /// Indices (in the input) of the curves `--skip-bad` left out.
    pub skipped: Vec<u64>,
    pub bytes_in: u64,
    pub bytes_out: u64,
    pub seconds: f64,
    pub curves_per_second: f64,
    pub points_per_second: f64,
}

pub fn run(args: &ConvertArgs) -> Result<()> {
    let result = convert(args);
    failure_report(result, args.json, Some(&args.input), Some(&args.output))
}

fn convert(args: &ConvertArgs) -> Result<()> {
    let from = args.from.as_deref().map(parse_format).transpose()?;
    let to = args.to.as_deref().map(parse_format).transpose()?;
    let bad = if args.care.skip_bad {
        BadCurves::Skip
    } else {
        BadCurves::Fail
    };
    let started = Instant::now();
    let mut reader = open_reader_with(&args.input, from, bad)?;
    let meta = reader.metadata().clone();
    let target = match to {
        Some(f) => f,
        None => Format::from_path(&args.output)?,
    };
    let mut dropped = source_losses(&meta);
    dropped.extend(target.losses(&meta));
    check_losses(&args.input, &args.output, &dropped, args.care.strict)?;
    let mut writer = create_writer(&args.output, Some(target), &meta)?;
    let (mut n, mut points) = (0u64, 0u64);
    while let Some(c) = reader.next() {
        let c = c?;
        writer
            .write_curve(&c)
            .map_err(|e| write_failed(&args.input, n, reader.skipped(), e))?;
        n += 1;
        points += c.points.len() as u64;
    }
    report_skipped(&args.input, reader.skipped());
    writer.finish()?;
    let seconds = started.elapsed().as_secs_f64();
    let (point_data_carried, curve_data_carried) = carried_data(&meta, target);
    let report = ConvertReport {
        version: super::JSON_VERSION,
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        input_format: meta.format.extension(),
        output_format: target.extension(),
        curve_count: n,
        point_count: points,
        point_data_carried,
        curve_data_carried,
        dropped,
        skipped: reader.skipped().iter().map(|s| s.index).collect(),
        bytes_in: size_on_disk(&args.input),
        bytes_out: size_on_disk(&args.output),
        seconds,
        curves_per_second: n as f64 / seconds.max(1e-9),
        points_per_second: points as f64 / seconds.max(1e-9),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        eprintln!("{} -> {}: {n} curves", report.input, report.output);
    }
    Ok(())
}
