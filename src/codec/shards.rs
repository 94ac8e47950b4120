//! Shards of a container and back, by copying blocks: `split`
//! (`codec::split_into_shards`) and `merge` (`codec::merge_shards`), whose
//! documentation describes them.

use std::path::{Path, PathBuf};

use super::container::{CodecHeader, CodecReader, CodecWriter};
use crate::io::IoError;

/// One output of [`split`] or [`merge`].
///
/// ```
/// use strandfit::codec::merge_shards;
/// # use std::path::Path;
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container at `path`, coded to `tolerance`, with a block of `n` curves
/// # /// per entry `n` of `blocks` (three short helices, the rest empty: quick to code).
/// # fn write(path: &Path, tolerance: f64, blocks: &[usize]) -> u64 {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(tolerance, meta, vec![]);
/// #     let helix: Vec<DVec3> = (0..20)
/// #         .map(|k| DVec3::new((0.3 * k as f64).cos(), (0.3 * k as f64).sin(), 0.03 * k as f64))
/// #         .collect();
/// #     let mut w = CodecWriter::create(path, &header).unwrap();
/// #     for &n in blocks {
/// #         let curves: Vec<CurveIn> = (0..n)
/// #             .map(|k| CurveIn {
/// #                 id: None,
/// #                 points: if k < 3 { &helix[..] } else { &[] },
/// #                 point_data: &[],
/// #                 curve_data: &[],
/// #             })
/// #             .collect();
/// #         w.write_block(&encode_block_bytes(&curves, &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     w.finish().unwrap()
/// # }
///
/// // Three containers of 2, 3 and 4 curves, merged: where each one's
/// // curves went, and its size.
/// let dir = tempfile::tempdir().unwrap();
/// let inputs: Vec<_> = (0..3).map(|k| dir.path().join(format!("in{k}.sfh"))).collect();
/// let sizes: Vec<u64> = inputs.iter().zip([2, 3, 4]).map(|(p, n)| write(p, 0.01, &[n])).collect();
/// let parts = merge_shards(&inputs, &dir.path().join("all.sfh")).unwrap();
/// assert_eq!(parts.iter().map(|s| (s.first, s.curves, s.blocks)).collect::<Vec<_>>(),
///            [(0, 2, 1), (2, 3, 1), (5, 4, 1)]);
/// assert_eq!(parts.iter().map(|s| s.bytes).collect::<Vec<_>>(), sizes);
/// ```
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
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::shard_path;
///
/// // The input's stem, then the shard's number in five digits.
/// let p = shard_path(Path::new("/data/sub-01.sfh"), Path::new("/out"), 12);
/// assert_eq!(p, Path::new("/out/sub-01-00012.sfh"));
/// ```
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
///
/// ```
/// use strandfit::codec::{shard_path, split_into_shards, CONTAINER_BLOCK_CURVES};
/// # use std::path::Path;
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container at `path`, coded to `tolerance`, with a block of `n` curves
/// # /// per entry `n` of `blocks` (three short helices, the rest empty: quick to code).
/// # fn write(path: &Path, tolerance: f64, blocks: &[usize]) -> u64 {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(tolerance, meta, vec![]);
/// #     let helix: Vec<DVec3> = (0..20)
/// #         .map(|k| DVec3::new((0.3 * k as f64).cos(), (0.3 * k as f64).sin(), 0.03 * k as f64))
/// #         .collect();
/// #     let mut w = CodecWriter::create(path, &header).unwrap();
/// #     for &n in blocks {
/// #         let curves: Vec<CurveIn> = (0..n)
/// #             .map(|k| CurveIn {
/// #                 id: None,
/// #                 points: if k < 3 { &helix[..] } else { &[] },
/// #                 point_data: &[],
/// #                 curve_data: &[],
/// #             })
/// #             .collect();
/// #         w.write_block(&encode_block_bytes(&curves, &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     w.finish().unwrap()
/// # }
///
/// // Blocks of 4,096, 5 and 6 curves. A shard of at most 1 curve is rounded
/// // up to one whole block; one of 5,000 curves holds one full block too.
/// let dir = tempfile::tempdir().unwrap();
/// let input = dir.path().join("in.sfh");
/// write(&input, 0.01, &[CONTAINER_BLOCK_CURVES, 5, 6]);
/// let parts = dir.path().join("parts");
/// let shards = split_into_shards(&input, &parts, 1).unwrap();
/// assert_eq!(shards.iter().map(|s| (s.first, s.curves)).collect::<Vec<_>>(),
///            [(0, 4096), (4096, 11)]);
/// assert_eq!(shards[1].blocks, 2);
/// assert_eq!(shards[0].path, shard_path(&input, &parts, 0));
/// assert_eq!(split_into_shards(&input, &parts, 5000).unwrap().len(), 2);
/// // No shard can hold no curves; a file that is no container is refused
/// // before anything is made.
/// assert!(split_into_shards(&input, &parts, 0).is_err());
/// std::fs::write(dir.path().join("bad.sfh"), b"not a container").unwrap();
/// assert!(split_into_shards(&dir.path().join("bad.sfh"), &dir.path().join("none"), 10).is_err());
/// assert!(!dir.path().join("none").exists());
/// ```
///
/// # Shards
///
/// Shards of a container and back, by copying blocks:
/// [`split_into_shards`](split) cuts a container into several, each a valid
/// container of whole blocks; [`merge_shards`](merge) joins containers with the
/// same header into one. Blocks are independently decodable (their models and
/// predictions restart), so neither decodes nor re-encodes anything: the
/// curves, and so the guarantee, are the input's bit for bit, and splitting
/// then merging gives back the input file byte for byte.
///
/// A shard holds whole blocks (4,096 curves each, the last block of a file
/// fewer), so `curves_per_shard` is rounded down to whole blocks, and at
/// least one block goes into every shard.
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
/// must have the same header (tolerance, model, steps, per-point value
/// names, source metadata), as the shards of one [`split`] have; otherwise the error names the
/// first input that differs and how. Returns where each input's curves
/// went.
///
/// ```
/// use strandfit::codec::{merge_shards, split_into_shards};
/// # use std::path::Path;
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container at `path`, coded to `tolerance`, with a block of `n` curves
/// # /// per entry `n` of `blocks` (three short helices, the rest empty: quick to code).
/// # fn write(path: &Path, tolerance: f64, blocks: &[usize]) -> u64 {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(tolerance, meta, vec![]);
/// #     let helix: Vec<DVec3> = (0..20)
/// #         .map(|k| DVec3::new((0.3 * k as f64).cos(), (0.3 * k as f64).sin(), 0.03 * k as f64))
/// #         .collect();
/// #     let mut w = CodecWriter::create(path, &header).unwrap();
/// #     for &n in blocks {
/// #         let curves: Vec<CurveIn> = (0..n)
/// #             .map(|k| CurveIn {
/// #                 id: None,
/// #                 points: if k < 3 { &helix[..] } else { &[] },
/// #                 point_data: &[],
/// #                 curve_data: &[],
/// #             })
/// #             .collect();
/// #         w.write_block(&encode_block_bytes(&curves, &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     w.finish().unwrap()
/// # }
///
/// // Split, then merge: the input back, byte for byte.
/// let dir = tempfile::tempdir().unwrap();
/// let input = dir.path().join("in.sfh");
/// write(&input, 0.01, &[strandfit::codec::CONTAINER_BLOCK_CURVES, 7]);
/// let shards = split_into_shards(&input, &dir.path().join("parts"), 1).unwrap();
/// assert_eq!(shards.len(), 2);
/// let paths: Vec<_> = shards.iter().map(|s| s.path.clone()).collect();
/// let joined = dir.path().join("joined.sfh");
/// merge_shards(&paths, &joined).unwrap();
/// assert_eq!(std::fs::read(&joined).unwrap(), std::fs::read(&input).unwrap());
/// // Containers of another tolerance are not merged, nor is nothing.
/// let other = dir.path().join("other.sfh");
/// write(&other, 0.02, &[3]);
/// let err = merge_shards(&[input.clone(), other], &joined).unwrap_err();
/// assert!(err.to_string().contains("tolerance"), "{err}");
/// assert!(merge_shards(&[], &joined).is_err());
/// ```
///
/// Nothing is decoded or re-encoded (see [`split_into_shards`](split),
/// Shards): the output's curves are the inputs' bit for bit.
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
