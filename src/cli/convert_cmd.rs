//! `strandfit convert IN -o OUT`: curves from one file format to another,
//! streamed, in world coordinates (the writer maps them back into its
//! format's convention). Per-point and per-curve data the target format
//! cannot hold, and source content the reader does not carry, are named in
//! a warning on stderr before anything is written (`--strict`: an error).

use anyhow::Result;

use super::inspect_cmd::parse_format;
use super::io_util::{check_losses, report_skipped, write_failed};
use super::ConvertArgs;
use crate::io::{create_writer, open_reader_with, source_losses, BadCurves, Format};

pub fn run(args: &ConvertArgs) -> Result<()> {
    let from = args.from.as_deref().map(parse_format).transpose()?;
    let to = args.to.as_deref().map(parse_format).transpose()?;
    let bad = if args.care.skip_bad {
        BadCurves::Skip
    } else {
        BadCurves::Fail
    };
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
    let mut n = 0u64;
    while let Some(c) = reader.next() {
        writer
            .write_curve(&c?)
            .map_err(|e| write_failed(&args.input, n, reader.skipped(), e))?;
        n += 1;
    }
    report_skipped(&args.input, reader.skipped());
    writer.finish()?;
    eprintln!(
        "{} -> {}: {n} curves",
        args.input.display(),
        args.output.display()
    );
    Ok(())
}
