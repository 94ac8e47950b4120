//! `strandfit convert IN -o OUT`: curves from one file format to another,
//! streamed, in world coordinates (the writer maps them back into its
//! format's convention). Per-point and per-curve data the target format
//! cannot hold are dropped with a note on stderr.

use anyhow::Result;

use super::inspect_cmd::parse_format;
use super::ConvertArgs;
use crate::io::{create_writer, open_reader};

pub fn run(args: &ConvertArgs) -> Result<()> {
    let from = args.from.as_deref().map(parse_format).transpose()?;
    let to = args.to.as_deref().map(parse_format).transpose()?;
    let mut reader = open_reader(&args.input, from)?;
    let meta = reader.metadata().clone();
    let mut writer = create_writer(&args.output, to, &meta)?;
    let mut n = 0u64;
    for c in reader.by_ref() {
        writer.write_curve(&c?)?;
        n += 1;
    }
    writer.finish()?;
    eprintln!(
        "{} -> {}: {n} curves",
        args.input.display(),
        args.output.display()
    );
    Ok(())
}
