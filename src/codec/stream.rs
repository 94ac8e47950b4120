//! Whole files through the codec: [`compress_stream`] reads curves from any
//! [`CurveReader`] into a version-3 container, block by block;
//! [`decompress_stream`] writes a container's curves to any
//! [`CurveWriter`], decoding several blocks at once. Memory is bounded by a
//! few blocks whatever the file's size; neither prints (progress goes to a
//! callback).

use std::path::Path;

use rayon::prelude::*;

use super::batch::ArcChecker;

use super::container::{
    encode_block_bytes_on, BlockBytes, CodecHeader, CodecReader, CodecWriter, CurveIn,
    DecodedCurve, BLOCK_CURVES,
};
use crate::io::{Curve, CurveReader, CurveWriter, IoError};

/// What [`compress_stream`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CompressSummary {
    /// Curves compressed.
    pub curves: u64,
    /// Input points.
    pub points: u64,
    /// Points the default decompression writes.
    pub output_points: u64,
    /// Curves by how they are coded: empty, points, arcs, raw.
    pub kinds: [u64; 4],
    /// Bytes written.
    pub bytes: u64,
    /// Candidate elements checked in batches by the backend (0 on the
    /// CPU, where each curve checks its own).
    pub batch_checked: u64,
    /// Of those, the verdicts left to the `f64` reference (within rounding
    /// of the tolerance, or the backend failed).
    pub batch_unsure: u64,
    /// Rounds of batched checks, summed over blocks.
    pub batch_rounds: u64,
    /// Blocks the backend could not take (finished on the CPU).
    pub batch_fallbacks: u64,
}

/// [`compress_blocks`] into memory: the bytes of a version-3 container
/// holding every curve of `reader` (`input` names it in errors; `checker`
/// as in [`compress_stream`]).
pub fn compress_to_bytes(
    reader: &mut dyn CurveReader,
    input: &Path,
    header: &CodecHeader,
    checker: Option<&dyn ArcChecker>,
) -> Result<Vec<u8>, IoError> {
    let mut writer = CodecWriter::in_memory(header);
    compress_blocks(reader, input, &mut writer, header, checker, &mut |_| {})?;
    writer.finish_bytes()
}

/// Compresses every curve of `reader` into a version-3 container at `out`
/// (written atomically). `checker`: where the candidate elements are
/// checked ([`crate::backend::Backend::arc_checker`]; `None`: on the CPU,
/// curves in parallel); the bytes are the same either way. `progress` gets
/// the number of curves done after each block. Errors name the input file
/// and curve for bad input, the output for write failures.
pub fn compress_stream(
    reader: &mut dyn CurveReader,
    input: &Path,
    out: &Path,
    header: &CodecHeader,
    checker: Option<&dyn ArcChecker>,
    progress: &mut dyn FnMut(u64),
) -> Result<CompressSummary, IoError> {
    let mut writer = CodecWriter::create(out, header)?;
    let mut summary = compress_blocks(reader, input, &mut writer, header, checker, progress)?;
    summary.bytes = writer.finish()?;
    Ok(summary)
}

/// The blocks of [`compress_stream`], written to `writer` (a file or
/// memory, [`CodecWriter::in_memory`]) made with the same `header`; the
/// caller finishes it. `summary.bytes` is left 0.
pub fn compress_blocks(
    reader: &mut dyn CurveReader,
    input: &Path,
    writer: &mut CodecWriter,
    header: &CodecHeader,
    checker: Option<&dyn ArcChecker>,
    progress: &mut dyn FnMut(u64),
) -> Result<CompressSummary, IoError> {
    let params = header.params();
    let n_cd = header.source.curve_data_names.len();
    let n_pd = header.point_data_names.len();
    let mut summary = CompressSummary::default();
    // Blocks go in groups of one per thread: a group is fitted and coded in
    // parallel (each block's entropy coding is sequential), while the
    // group before it is verified (decoded back) before being written.
    let group = rayon::current_num_threads().max(2);
    let mut pending: Vec<(BlockBytes, u64)> = Vec::new();
    let mut ended = false;
    while !ended || !pending.is_empty() {
        let mut batches: Vec<(Vec<Curve>, u64)> = Vec::with_capacity(group);
        let mut next = summary.curves;
        while !ended && batches.len() < group {
            let mut batch: Vec<Curve> = Vec::with_capacity(BLOCK_CURVES);
            while batch.len() < BLOCK_CURVES {
                match reader.next() {
                    Some(c) => batch.push(c?),
                    None => {
                        ended = true;
                        break;
                    }
                }
            }
            if !batch.is_empty() {
                let n = batch.len() as u64;
                batches.push((batch, next));
                next += n;
            }
        }
        let (verified, encoded): (Vec<_>, Vec<_>) = rayon::join(
            || pending.par_iter().map(|(b, _)| b.verify(&params)).collect(),
            || {
                batches
                    .par_iter()
                    .map(|(batch, _)| {
                        let ins: Vec<CurveIn> = batch
                            .iter()
                            .map(|c| CurveIn {
                                id: c.id.as_deref(),
                                points: &c.points,
                                point_data: &c.point_data,
                                curve_data: &c.curve_data,
                            })
                            .collect();
                        encode_block_bytes_on(&ins, &params, n_cd, n_pd, checker)
                    })
                    .collect()
            },
        );
        for (check, (block, at)) in verified.into_iter().zip(pending.drain(..)) {
            check.map_err(|(k, why)| {
                IoError::new(input, format!("cannot be compressed: {why}")).curve(at + k as u64)
            })?;
            writer.write_block(&block)?;
            progress(at + block.curves as u64);
        }
        for (result, (batch, first)) in encoded.into_iter().zip(&batches) {
            let block = result.map_err(|(k, why)| {
                IoError::new(input, format!("cannot be compressed: {why}")).curve(first + k as u64)
            })?;
            summary.curves += batch.len() as u64;
            summary.points += batch.iter().map(|c| c.points.len() as u64).sum::<u64>();
            summary.output_points += block.encoded.output_points as u64;
            for &k in &block.encoded.kinds {
                summary.kinds[k as usize] += 1;
            }
            let checks = &block.encoded.checks;
            summary.batch_checked += checks.checked;
            summary.batch_unsure += checks.unsure;
            summary.batch_rounds += checks.rounds;
            summary.batch_fallbacks += checks.fell_back as u64;
            pending.push((block, *first));
        }
    }
    Ok(summary)
}

/// Blocks decoded at once (in parallel) by [`decompress_stream`].
const BLOCKS_AT_ONCE: usize = 8;

/// Writes every curve of the container to `writer` (which the caller
/// finishes), `map` turning each decoded curve into the curve written
/// (e.g. resampling it). Returns the number of curves written.
pub fn decompress_stream(
    reader: &mut CodecReader,
    writer: &mut dyn CurveWriter,
    map: &(dyn Fn(DecodedCurve) -> Curve + Sync),
    progress: &mut dyn FnMut(u64),
) -> Result<u64, IoError> {
    let all = 0..reader.curve_count();
    decompress_range(reader, writer, map, all, progress)
}

/// [`decompress_stream`] for curves `range` only (clamped to the
/// container): only the blocks that hold them are read
/// ([`CodecReader::bytes_read`] says how much).
pub fn decompress_range(
    reader: &mut CodecReader,
    writer: &mut dyn CurveWriter,
    map: &(dyn Fn(DecodedCurve) -> Curve + Sync),
    range: std::ops::Range<u64>,
    progress: &mut dyn FnMut(u64),
) -> Result<u64, IoError> {
    let header = reader.header().clone();
    let path = reader.path().to_path_buf();
    let mut written = 0u64;
    let wanted: Vec<usize> = (0..reader.block_count())
        .filter(|&b| {
            let (first, count) = reader.block_span(b);
            first < range.end && first + count > range.start
        })
        .collect();
    for group in wanted.chunks(BLOCKS_AT_ONCE) {
        let raw = group
            .iter()
            .map(|&b| reader.read_block_bytes(b))
            .collect::<Result<Vec<_>, _>>()?;
        let decoded: Vec<Result<Vec<Curve>, IoError>> = raw
            .par_iter()
            .map(|b| {
                b.decode(&path, &header).map(|cs| {
                    cs.into_iter()
                        .enumerate()
                        .filter(|(k, _)| range.contains(&(b.first + *k as u64)))
                        .map(|(_, c)| map(c))
                        .collect()
                })
            })
            .collect();
        for block in decoded {
            for c in block? {
                writer.write_curve(&c)?;
                written += 1;
            }
        }
        progress(written);
    }
    Ok(written)
}

/// Curves `first..first + count` of the container, reading only the
/// blocks that hold them (random access through the index).
pub fn read_range(
    reader: &mut CodecReader,
    first: u64,
    count: u64,
) -> Result<Vec<DecodedCurve>, IoError> {
    let header = reader.header().clone();
    let path = reader.path().to_path_buf();
    let end = first.saturating_add(count).min(reader.curve_count());
    let mut out = Vec::new();
    for b in 0..reader.block_count() {
        let raw = {
            let (b_first, b_count) = reader.block_span(b);
            if b_first + b_count <= first || b_first >= end {
                continue;
            }
            reader.read_block_bytes(b)?
        };
        let curves = raw.decode(&path, &header)?;
        for (k, c) in curves.into_iter().enumerate() {
            let i = raw.first + k as u64;
            if i >= first && i < end {
                out.push(c);
            }
        }
    }
    Ok(out)
}

/// A decoded curve as written: as decoded (`points` and `step` `None`: the
/// points the guarantee is about), or resampled to `points` points or every
/// `step` along its arc length, its per-point values (`width` per point)
/// carried onto the new points ([`super::point_data::carry`]). Resampling
/// gives up the guarantee.
pub fn output_curve(
    c: DecodedCurve,
    points: Option<usize>,
    step: Option<f64>,
    width: usize,
) -> Curve {
    match (points, step) {
        (None, None) => Curve {
            id: c.id,
            points: c.points,
            point_data: c.point_data,
            curve_data: c.curve_data,
        },
        (m, s) => {
            let resampled = resample_polyline(&c.points, m, s);
            Curve {
                id: c.id,
                point_data: super::point_data::carry(&c.points, &c.point_data, width, &resampled),
                points: resampled,
                curve_data: c.curve_data,
            }
        }
    }
}

/// `m` points equally spaced in arc length along the polyline (or points
/// `step` apart, both ends kept).
pub fn resample_polyline(
    p: &[glam::DVec3],
    m: Option<usize>,
    step: Option<f64>,
) -> Vec<glam::DVec3> {
    if p.len() < 2 {
        return p.to_vec();
    }
    let mut cum = Vec::with_capacity(p.len());
    let mut total = 0.0;
    cum.push(0.0);
    for w in p.windows(2) {
        total += w[0].distance(w[1]);
        cum.push(total);
    }
    let m = match (m, step) {
        (Some(m), _) => m.max(2),
        (None, Some(s)) => ((total / s).ceil() as usize + 1).clamp(2, 1 << 24),
        (None, None) => p.len(),
    };
    let mut out = Vec::with_capacity(m);
    let mut seg = 0;
    for k in 0..m {
        let s = total * k as f64 / (m - 1) as f64;
        while seg + 2 < p.len() && cum[seg + 1] < s {
            seg += 1;
        }
        let len = cum[seg + 1] - cum[seg];
        let t = if len > 0.0 {
            ((s - cum[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(p[seg].lerp(p[seg + 1], t));
    }
    out
}
