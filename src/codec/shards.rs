//! Shards of a container and back, by copying blocks: [`split`] cuts a
//! container into several, each a valid container of whole blocks;
//! [`merge`] joins containers with the same header into one. Blocks are
//! independently decodable (their models and predictions restart), so
//! neither decodes nor re-encodes anything: the curves, and so the
//! guarantee, are the input's bit for bit, and splitting then merging gives
//! back the input file byte for byte.
//!
//! A shard holds whole blocks (4,096 curves each, the last block of a file
//! fewer), so `curves_per_shard` is rounded down to whole blocks, and at
//! least one block goes into every shard.

use std::path::{Path, PathBuf};

use super::container::{CodecHeader, CodecReader, CodecWriter};
use crate::io::IoError;

/// One output of [`split`] or [`merge`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    /// The shard's file.
    pub path: PathBuf,
    /// Index of its first curve in the input (for [`split`]), or in the
    /// output (for the inputs of [`merge`]).
    pub first: u64,
    /// Number of curves in it (`curve_count` in `split`/`merge --json`).
    #[serde(rename = "curve_count")]
    pub curves: u64,
    /// Number of blocks in it (`block_count`).
    #[serde(rename = "block_count")]
    pub blocks: usize,
    /// Its size in bytes.
    pub bytes: u64,
}

/// The name of shard `k` of `input` in `dir`: `STEM-00000.sfh`, …
pub fn shard_path(input: &Path, dir: &Path, k: usize) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "shard".into());
    dir.join(format!("{stem}-{k:05}.sfh"))
}

/// Cuts the container at `input` into shards of whole blocks holding at
/// most `curves_per_shard` curves each (but at least one block), written
/// atomically into `dir` (made if missing) as [`shard_path`] names them;
/// shards of an earlier, longer split of the same input in `dir` are
/// removed. On an error the shards already written are removed: nothing
/// is left half done.
pub fn split(input: &Path, dir: &Path, curves_per_shard: u64) -> Result<Vec<Shard>, IoError> {
    if curves_per_shard == 0 {
        return Err(IoError::new(input, "curves per shard must be at least 1"));
    }
    // Whole blocks: the capacity is rounded down to them, one at least.
    let block = super::container::BLOCK_CURVES as u64;
    let capacity = (curves_per_shard / block).max(1) * block;
    let mut reader = CodecReader::open(input)?;
    let header = reader.header().clone();
    // The folder is made once the input is known good, and removed again
    // (if it was made here and stays empty) when the split fails.
    let made_dir = !dir.exists();
    std::fs::create_dir_all(dir).map_err(|e| IoError::os(dir, "cannot make the folder", e))?;
    let mut shards: Vec<Shard> = Vec::new();
    let result = (|| -> Result<(), IoError> {
        let mut current: Option<(CodecWriter, Shard)> = None;
        for b in 0..reader.block_count() {
            let (first, count) = reader.block_span(b);
            let full = current
                .as_ref()
                .is_some_and(|(w, _)| w.curves() + count > capacity);
            if full {
                let (w, mut s) = current.take().expect("open shard");
                s.bytes = w.finish()?;
                shards.push(s);
            }
            if current.is_none() {
                let path = shard_path(input, dir, shards.len());
                let w = CodecWriter::create(&path, &header)?;
                let s = Shard {
                    path,
                    first,
                    curves: 0,
                    blocks: 0,
                    bytes: 0,
                };
                current = Some((w, s));
            }
            let block = reader.read_block_bytes(b)?;
            let (w, s) = current.as_mut().expect("open shard");
            w.copy_block(&block)?;
            s.curves += count;
            s.blocks += 1;
        }
        if let Some((w, mut s)) = current.take() {
            s.bytes = w.finish()?;
            shards.push(s);
        }
        if shards.is_empty() {
            // An empty container splits into one empty shard, not nothing.
            let path = shard_path(input, dir, 0);
            let bytes = CodecWriter::create(&path, &header)?.finish()?;
            shards.push(Shard {
                path,
                first: 0,
                curves: 0,
                blocks: 0,
                bytes,
            });
        }
        Ok(())
    })();
    match result {
        Ok(()) => {
            // Shards of an earlier, longer split of the same input would
            // be taken for this one's by `merge DIR/*.sfh`: removed.
            let mut k = shards.len();
            while shard_path(input, dir, k).is_file() {
                let _ = std::fs::remove_file(shard_path(input, dir, k));
                k += 1;
            }
            Ok(shards)
        }
        Err(e) => {
            for s in &shards {
                let _ = std::fs::remove_file(&s.path);
            }
            if made_dir {
                let _ = std::fs::remove_dir(dir);
            }
            Err(e)
        }
    }
}

/// Which header field two containers differ in (`None`: they agree).
fn header_difference(a: &CodecHeader, b: &CodecHeader) -> Option<&'static str> {
    if a.tolerance != b.tolerance {
        Some("tolerance")
    } else if a.model != b.model {
        Some("codec model")
    } else if a.steps != b.steps {
        Some("quantiser steps")
    } else if a.point_data_names != b.point_data_names {
        Some("per-point value names")
    } else if a.source != b.source {
        Some("source metadata (format, affine, units, per-curve value names or header fields)")
    } else {
        None
    }
}

/// Joins the containers `inputs`, in order, into one at `output`
/// (atomically), block by block: the curves in order, each as it was. They
/// must have the same header (tolerance, model, steps, source metadata),
/// as the shards of one [`split`] have; otherwise the error names the
/// first input that differs and how. Returns where each input's curves
/// went.
pub fn merge(inputs: &[PathBuf], output: &Path) -> Result<Vec<Shard>, IoError> {
    let Some(first) = inputs.first() else {
        return Err(IoError::new(
            output,
            "nothing to merge: no input containers",
        ));
    };
    let mut readers = Vec::with_capacity(inputs.len());
    for p in inputs {
        let r = CodecReader::open(p)?;
        if let Some(r0) = readers.first() {
            let r0: &CodecReader = r0;
            if let Some(what) = header_difference(r0.header(), r.header()) {
                return Err(IoError::new(
                    p,
                    format!(
                        "cannot be merged with {}: its {what} differs (merge joins containers \
                         written with the same settings from the same kind of source, e.g. \
                         the shards of one split)",
                        first.display()
                    ),
                ));
            }
        }
        readers.push(r);
    }
    let mut w = CodecWriter::create(output, readers[0].header())?;
    let mut parts = Vec::with_capacity(inputs.len());
    for (p, mut r) in inputs.iter().zip(readers) {
        let first = w.curves();
        for b in 0..r.block_count() {
            let block = r.read_block_bytes(b)?;
            w.copy_block(&block)?;
        }
        parts.push(Shard {
            path: p.clone(),
            first,
            curves: r.curve_count(),
            blocks: r.block_count(),
            bytes: r.size(),
        });
    }
    w.finish()?;
    Ok(parts)
}
