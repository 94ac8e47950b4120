//! `strandfit split` and `strandfit merge`: containers cut into shards of
//! whole blocks and joined again ([`crate::codec::split_into_shards`], [`crate::codec::merge_shards`]).

use anyhow::Result;
use serde::Serialize;

use super::{MergeArgs, SplitArgs};
use crate::codec::{merge_shards, split_into_shards, Shard};

#[derive(Serialize)]
struct Report<'a> {
    version: u32,
    inputs: Vec<String>,
    output: String,
    curve_count: u64,
    shards: &'a [Shard],
}

pub fn split(args: &SplitArgs) -> Result<()> {
    let out = split_into_shards(&args.input, &args.output, args.curves_per_shard)?;
    let curves = out.iter().map(|s| s.curves).sum();
    if args.json {
        let r = Report {
            version: super::JSON_VERSION,
            inputs: vec![args.input.display().to_string()],
            output: args.output.display().to_string(),
            curve_count: curves,
            shards: &out,
        };
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        eprintln!(
            "{} -> {}: {curves} curves in {} shards ({} .. {})",
            args.input.display(),
            args.output.display(),
            out.len(),
            out.first()
                .map(|s| s.path.display().to_string())
                .unwrap_or_default(),
            out.last()
                .map(|s| s.path.display().to_string())
                .unwrap_or_default(),
        );
    }
    Ok(())
}

pub fn merge(args: &MergeArgs) -> Result<()> {
    let parts = merge_shards(&args.inputs, &args.output)?;
    let curves = parts.iter().map(|s| s.curves).sum();
    if args.json {
        let r = Report {
            version: super::JSON_VERSION,
            inputs: args
                .inputs
                .iter()
                .map(|p| p.display().to_string())
                .collect(),
            output: args.output.display().to_string(),
            curve_count: curves,
            shards: &parts,
        };
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        eprintln!(
            "{} containers -> {}: {curves} curves",
            parts.len(),
            args.output.display()
        );
    }
    Ok(())
}
