//! Whole files through the codec, block by block (described in the
//! [`codec`](crate::codec) module documentation, "Whole files").

use std::path::Path;

use super::batch::ArcChecker;

use super::container::{
    encode_block_bytes_on, BlockBytes, CodecHeader, CodecReader, CodecWriter, CurveIn,
    DecodedCurve, RawBlock, BLOCK_CURVES,
};
use crate::io::{Curve, CurveReader, CurveWriter, IoError};

/// What [`compress_stream`] did.
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::{compress_blocks, CodecHeader, CodecWriter};
/// use strandfit::io::{Curve, Format, Metadata, SourceMeta, VecReader};
/// use strandfit::DVec3;
///
/// // An empty curve and a helix: one of each kind counted, every point too.
/// let helix: Vec<DVec3> = (0..40)
///     .map(|k| 0.2 * k as f64)
///     .map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s))
///     .collect();
/// let meta = Metadata::new(Format::Json);
/// let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
/// let mut reader = VecReader::new(meta, vec![Curve::default(), Curve::from_points(helix)]);
/// let mut writer = CodecWriter::in_memory(&header);
/// let summary =
///     compress_blocks(&mut reader, Path::new("in.json"), &mut writer, &header, None, &mut |_| {})
///         .unwrap();
/// assert_eq!((summary.curves, summary.points), (2, 40));
/// assert_eq!(summary.kinds[0], 1); // the empty curve
/// assert_eq!(summary.kinds.iter().sum::<u64>(), 2);
/// assert!(summary.output_points > 0);
/// assert_eq!(summary.batch_checked, 0); // no backend: each curve checked its own
/// ```
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
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::{compress_to_bytes, read_range, CodecHeader, CodecReader};
/// use strandfit::io::{Curve, Format, Metadata, SourceMeta, VecReader};
/// use strandfit::DVec3;
///
/// // Three named helices, and a header for a tolerance of 0.01.
/// let helix = |r: f64| -> Vec<DVec3> {
///     (0..40).map(|k| 0.2 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.1 * s)).collect()
/// };
/// let curves: Vec<Curve> = (1..=3)
///     .map(|k| Curve { id: Some(format!("c{k}")), ..Curve::from_points(helix(k as f64)) })
///     .collect();
/// let meta = Metadata::new(Format::Json);
/// let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
/// let mut reader = VecReader::new(meta.clone(), curves.clone());
/// let bytes = compress_to_bytes(&mut reader, Path::new("in.json"), &header, None).unwrap();
/// // Every curve back, named, within the tolerance.
/// let mut container = CodecReader::from_bytes(bytes).unwrap();
/// let back = read_range(&mut container, 0, 3).unwrap();
/// assert_eq!(back.len(), 3);
/// for (c, b) in curves.iter().zip(&back) {
///     assert_eq!(b.id, c.id);
///     assert!(strandfit::metrics::hausdorff(&c.points, &b.points).unwrap() <= 0.01);
/// }
/// // A bad point is an error naming the input and the curve.
/// let mut bad = curves;
/// bad[1].points[5].y = f64::NAN;
/// let err = compress_to_bytes(&mut VecReader::new(meta, bad), Path::new("in.json"), &header, None)
///     .unwrap_err();
/// assert_eq!((err.path.as_path(), err.curve), (Path::new("in.json"), Some(1)));
/// ```
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
/// checked (the GPU's `arc_check` kernel, as the command line passes it;
/// `None`: on the CPU, curves in parallel); the bytes are the same either way. `progress` gets
/// the number of curves done after each block. Errors name the input file
/// and curve for bad input, the output for write failures.
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::{compress_stream, CodecHeader, CodecReader};
/// use strandfit::io::{Curve, Format, Metadata, SourceMeta, VecReader};
/// use strandfit::DVec3;
///
/// // Three named helices, and a header for a tolerance of 0.01.
/// let helix = |r: f64| -> Vec<DVec3> {
///     (0..40).map(|k| 0.2 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.1 * s)).collect()
/// };
/// let curves: Vec<Curve> = (1..=3)
///     .map(|k| Curve { id: Some(format!("c{k}")), ..Curve::from_points(helix(k as f64)) })
///     .collect();
/// let meta = Metadata::new(Format::Json);
/// let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
/// let dir = tempfile::tempdir().unwrap();
/// let out = dir.path().join("helices.sfh");
/// let mut done = Vec::new();
/// let summary = compress_stream(
///     &mut VecReader::new(meta, curves),
///     Path::new("helices.json"),
///     &out,
///     &header,
///     None,
///     &mut |n| done.push(n),
/// )
/// .unwrap();
/// assert_eq!((summary.curves, summary.points), (3, 120));
/// assert_eq!(summary.bytes, std::fs::metadata(&out).unwrap().len());
/// assert_eq!(done.last(), Some(&3));
/// assert_eq!(CodecReader::open(&out).unwrap().curve_count(), 3);
/// ```
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
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::{compress_blocks, CodecHeader, CodecReader, CodecWriter};
/// use strandfit::io::{Curve, Format, Metadata, SourceMeta, VecReader};
/// use strandfit::DVec3;
///
/// // Three named helices, and a header for a tolerance of 0.01.
/// let helix = |r: f64| -> Vec<DVec3> {
///     (0..40).map(|k| 0.2 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.1 * s)).collect()
/// };
/// let curves: Vec<Curve> = (1..=3)
///     .map(|k| Curve { id: Some(format!("c{k}")), ..Curve::from_points(helix(k as f64)) })
///     .collect();
/// let meta = Metadata::new(Format::Json);
/// let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
/// let mut writer = CodecWriter::in_memory(&header);
/// let summary = compress_blocks(
///     &mut VecReader::new(meta, curves),
///     Path::new("helices.json"),
///     &mut writer,
///     &header,
///     None,
///     &mut |_| {},
/// )
/// .unwrap();
/// // The curves are in the writer, which the caller finishes.
/// assert_eq!((summary.curves, summary.bytes), (3, 0));
/// assert_eq!(writer.curves(), 3);
/// let bytes = writer.finish_bytes().unwrap();
/// assert_eq!(CodecReader::from_bytes(bytes).unwrap().curve_count(), 3);
/// ```
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
    // A stream of blocks: this thread reads them (a reader need not be
    // `Send`) and writes them in order; each is fitted, coded and verified
    // (decoded back) as one task, which a thread takes as soon as it is
    // free, so no block waits for a group's slowest. At most
    // `BLOCKS_PER_THREAD` per thread are read and not yet written (memory
    // bound: about 5 MB each).
    let unwritten_limit = BLOCKS_PER_THREAD * rayon::current_num_threads().max(1);
    // A block's result: the block and its verification, or its error.
    type Done = Result<(BlockBytes, Result<(), (usize, String)>), (usize, String)>;
    let (tx, rx) = std::sync::mpsc::channel::<(usize, Done)>();
    // Each block's curve count, first curve and point count, by its index.
    let mut spans: Vec<(u64, u64, u64)> = Vec::new();
    let mut read = 0u64;
    let mut ended = false;
    let mut read_error: Option<IoError> = None;
    // Blocks handed to the pool whose result has not come back.
    let mut running = 0usize;
    let mut written = 0usize;
    let mut done: std::collections::BTreeMap<usize, Done> = std::collections::BTreeMap::new();
    let params = &params;
    rayon::in_place_scope_fifo(|s| -> Result<(), IoError> {
        loop {
            // (Counted until written, not until done: a slow block holds
            // the reading back, so that the blocks done after it, waiting
            // to be written, stay within the bound.)
            while !ended && read_error.is_none() && spans.len() - written < unwritten_limit {
                let batch = match read_batch(reader, &mut ended) {
                    Ok(b) if b.is_empty() => break,
                    Ok(b) => b,
                    Err(e) => {
                        read_error = Some(e);
                        break;
                    }
                };
                let index = spans.len();
                let points = batch.iter().map(|c| c.points.len() as u64).sum();
                spans.push((batch.len() as u64, read, points));
                read += batch.len() as u64;
                running += 1;
                let tx = tx.clone();
                // (First in, first out: the blocks are started in the order
                // they are written in.)
                s.spawn_fifo(move |_| {
                    let ins: Vec<CurveIn> = batch
                        .iter()
                        .map(|c| CurveIn {
                            id: c.id.as_deref(),
                            points: &c.points,
                            point_data: &c.point_data,
                            curve_data: &c.curve_data,
                        })
                        .collect();
                    // A panic would leave this thread waiting for the
                    // block's result: it becomes the block's error.
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        encode_block_bytes_on(&ins, params, n_cd, n_pd, checker).map(|block| {
                            let verified = block.verify(params);
                            (block, verified)
                        })
                    }))
                    .unwrap_or_else(|_| Err((0, "internal error: the encoder panicked".into())));
                    // (The receiver outlives every task of the scope.)
                    let _ = tx.send((index, result));
                });
            }
            if running == 0 {
                return match read_error.take() {
                    Some(e) => Err(e),
                    None => Ok(()),
                };
            }
            let (index, result) = receive(&rx);
            running -= 1;
            done.insert(index, result);
            // Written in order; the first failure in order is the one
            // reported (the tasks still running end with the scope).
            while let Some(result) = done.remove(&written) {
                let (curves, first, points) = spans[written];
                let (block, verified) = result.map_err(|(k, why)| {
                    IoError::new(input, format!("cannot be compressed: {why}"))
                        .curve(first + k as u64)
                })?;
                verified.map_err(|(k, why)| {
                    IoError::new(input, format!("cannot be compressed: {why}"))
                        .curve(first + k as u64)
                })?;
                summary.curves += curves;
                summary.points += points;
                summary.output_points += block.encoded.output_points as u64;
                for &k in &block.encoded.kinds {
                    summary.kinds[k as usize] += 1;
                }
                let checks = &block.encoded.checks;
                summary.batch_checked += checks.checked;
                summary.batch_unsure += checks.unsure;
                summary.batch_rounds += checks.rounds;
                summary.batch_fallbacks += checks.fell_back as u64;
                writer.write_block(&block)?;
                progress(first + curves);
                written += 1;
            }
        }
    })?;
    Ok(summary)
}

/// Blocks per thread that [`compress_blocks`] has read and not yet
/// written: a thread that finishes a block takes the next at once, and the
/// blocks come back in any order (each holds about 5 MB). Against groups
/// of two blocks per thread coded together and verified while the next
/// group was coded (session 34's pipeline), measured on 100,000 fornix
/// replicas at 0.1 mm (2 cores, alternated runs): 4.81 and 4.96 s against
/// 5.16 and 5.44 s, the same bytes; at 0.5 mm the same time.
const BLOCKS_PER_THREAD: usize = 3;

/// The next block of curves from `reader` (up to [`BLOCK_CURVES`]; empty
/// once it has no more, `ended` then set).
fn read_batch(reader: &mut dyn CurveReader, ended: &mut bool) -> Result<Vec<Curve>, IoError> {
    let mut batch: Vec<Curve> = Vec::with_capacity(BLOCK_CURVES);
    while !*ended && batch.len() < BLOCK_CURVES {
        match reader.next() {
            Some(c) => batch.push(c?),
            None => *ended = true,
        }
    }
    Ok(batch)
}

/// Blocks [`decompress_stream`] decodes at once, at least (one per thread
/// where there are more): up to twice as many are decoded or decoding and
/// not yet written (a window of 4 or 16 on 2 cores measured no faster).
const BLOCKS_AT_ONCE: usize = 4;

/// Writes every curve of the container to `writer` (which the caller
/// finishes), `map` turning each decoded curve into the curve written
/// (e.g. resampling it). Returns the number of curves written.
///
/// ```
/// use strandfit::codec::{decompress_stream, output_curve};
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecReader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container in memory of three blocks, one helix each, named c0, c1, c2.
/// # fn three_blocks() -> CodecReader {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(0.01, meta, vec![]);
/// #     let mut w = CodecWriter::in_memory(&header);
/// #     for k in 0..3 {
/// #         let points: Vec<DVec3> = (0..30)
/// #             .map(|i| DVec3::new((0.2 * i as f64).cos(), (0.2 * i as f64).sin(), 0.02 * i as f64 + k as f64))
/// #             .collect();
/// #         let id = format!("c{k}");
/// #         let c = CurveIn { id: Some(&id), points: &points, point_data: &[], curve_data: &[] };
/// #         w.write_block(&encode_block_bytes(&[c], &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     CodecReader::from_bytes(w.finish_bytes().unwrap()).unwrap()
/// # }
/// # use strandfit::io::{Curve, CurveWriter, IoError};
/// # /// A writer that keeps the curves.
/// # struct Collect(Vec<Curve>);
/// # impl CurveWriter for Collect {
/// #     fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
/// #         self.0.push(c.clone());
/// #         Ok(())
/// #     }
/// #     fn finish(self: Box<Self>) -> Result<(), IoError> {
/// #         Ok(())
/// #     }
/// # }
///
/// // Every curve, resampled to 10 points on the way out.
/// let mut container = three_blocks();
/// let mut out = Collect(Vec::new());
/// let map = |c| output_curve(c, Some(10), None, 0);
/// let n = decompress_stream(&mut container, &mut out, &map, &mut |_| {}).unwrap();
/// assert_eq!(n, 3);
/// assert_eq!(out.0.iter().map(|c| c.id.as_deref().unwrap()).collect::<Vec<_>>(), ["c0", "c1", "c2"]);
/// assert!(out.0.iter().all(|c| c.points.len() == 10));
/// ```
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
///
/// ```
/// use strandfit::codec::{decompress_range, output_curve};
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecReader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container in memory of three blocks, one helix each, named c0, c1, c2.
/// # fn three_blocks() -> CodecReader {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(0.01, meta, vec![]);
/// #     let mut w = CodecWriter::in_memory(&header);
/// #     for k in 0..3 {
/// #         let points: Vec<DVec3> = (0..30)
/// #             .map(|i| DVec3::new((0.2 * i as f64).cos(), (0.2 * i as f64).sin(), 0.02 * i as f64 + k as f64))
/// #             .collect();
/// #         let id = format!("c{k}");
/// #         let c = CurveIn { id: Some(&id), points: &points, point_data: &[], curve_data: &[] };
/// #         w.write_block(&encode_block_bytes(&[c], &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     CodecReader::from_bytes(w.finish_bytes().unwrap()).unwrap()
/// # }
/// # use strandfit::io::{Curve, CurveWriter, IoError};
/// # /// A writer that keeps the curves.
/// # struct Collect(Vec<Curve>);
/// # impl CurveWriter for Collect {
/// #     fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
/// #         self.0.push(c.clone());
/// #         Ok(())
/// #     }
/// #     fn finish(self: Box<Self>) -> Result<(), IoError> {
/// #         Ok(())
/// #     }
/// # }
///
/// // Curve 1 only: one block of three read.
/// let mut container = three_blocks();
/// let opened = container.bytes_read();
/// let mut out = Collect(Vec::new());
/// let map = |c| output_curve(c, None, None, 0);
/// let n = decompress_range(&mut container, &mut out, &map, 1..2, &mut |_| {}).unwrap();
/// assert_eq!(n, 1);
/// assert_eq!(out.0[0].id.as_deref(), Some("c1"));
/// let one_block = container.bytes_read() - opened;
/// assert!(one_block > 0 && opened + one_block < container.size());
/// // The range is clamped to the container.
/// assert_eq!(decompress_range(&mut container, &mut out, &map, 2..100, &mut |_| {}).unwrap(), 1);
/// ```
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
    let decode = |b: RawBlock| -> Result<Vec<Curve>, IoError> {
        b.decode(&path, &header).map(|cs| {
            cs.into_iter()
                .enumerate()
                .filter(|(k, _)| range.contains(&(b.first + *k as u64)))
                .map(|(_, c)| map(c))
                .collect()
        })
    };
    let decode = &decode;
    // A window of blocks decodes on the pool, each block as soon as a
    // thread is free, while this thread writes them in order: with groups
    // of blocks between barriers, a group's last block left a core idle
    // (a twentieth of the run on 2 cores). At most `window` blocks are
    // decoded and not yet written, which bounds the memory.
    let window = 2 * BLOCKS_AT_ONCE.max(rayon::current_num_threads());
    let (sender, receiver) = std::sync::mpsc::channel::<(usize, Result<Vec<Curve>, IoError>)>();
    let mut waiting: Vec<Option<Result<Vec<Curve>, IoError>>> = Vec::new();
    waiting.resize_with(wanted.len(), || None);
    let mut outcome = Ok(());
    rayon::in_place_scope_fifo(|s| {
        let mut spawned = 0;
        let mut unreadable: Option<IoError> = None;
        for i in 0..wanted.len() {
            while unreadable.is_none() && spawned < wanted.len() && spawned < i + window {
                match reader.read_block_bytes(wanted[spawned]) {
                    Ok(raw) => {
                        let (sender, k) = (sender.clone(), spawned);
                        let path = &path;
                        s.spawn_fifo(move |_| {
                            // A panic would leave this thread waiting for
                            // the block: it becomes the block's error.
                            let decoded =
                                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                                    decode(raw)
                                }))
                                .unwrap_or_else(|_| {
                                    Err(IoError::new(path, "internal error: the decoder panicked"))
                                });
                            // The receiver is gone only after an error.
                            let _ = sender.send((k, decoded));
                        });
                        spawned += 1;
                    }
                    Err(e) => unreadable = Some(e),
                }
            }
            if i == spawned {
                // The curves before the unreadable block are written.
                outcome = Err(unreadable.take().expect("stopped at an unreadable block"));
                return;
            }
            while waiting[i].is_none() {
                let (k, decoded) = receive(&receiver);
                waiting[k] = Some(decoded);
            }
            let written_block = waiting[i].take().expect("received").and_then(|curves| {
                for c in curves {
                    writer.write_curve(&c)?;
                    written += 1;
                }
                Ok(())
            });
            if let Err(e) = written_block {
                outcome = Err(e);
                return;
            }
            progress(written);
        }
    });
    outcome?;
    Ok(written)
}

/// The next block (decoded, or encoded and verified) from the pool:
/// blocking where this thread is not one of the pool's, else running the pool's queued work while it waits
/// (a blocked worker could leave the blocks it waits for undecoded).
fn receive<T>(receiver: &std::sync::mpsc::Receiver<T>) -> T {
    if rayon::current_thread_index().is_none() {
        return receiver
            .recv()
            .expect("a sender is held while blocks are pending");
    }
    loop {
        if let Ok(v) = receiver.try_recv() {
            return v;
        }
        if rayon::yield_now() != Some(rayon::Yield::Executed) {
            std::thread::yield_now();
        }
    }
}

/// Curves `first..first + count` of the container, reading only the
/// blocks that hold them (random access through the index).
///
/// ```
/// use strandfit::codec::read_range;
/// # use strandfit::codec::{encode_block_bytes, CodecHeader, CodecReader, CodecWriter, CurveIn};
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # /// A container in memory of three blocks, one helix each, named c0, c1, c2.
/// # fn three_blocks() -> CodecReader {
/// #     let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
/// #     let header = CodecHeader::new(0.01, meta, vec![]);
/// #     let mut w = CodecWriter::in_memory(&header);
/// #     for k in 0..3 {
/// #         let points: Vec<DVec3> = (0..30)
/// #             .map(|i| DVec3::new((0.2 * i as f64).cos(), (0.2 * i as f64).sin(), 0.02 * i as f64 + k as f64))
/// #             .collect();
/// #         let id = format!("c{k}");
/// #         let c = CurveIn { id: Some(&id), points: &points, point_data: &[], curve_data: &[] };
/// #         w.write_block(&encode_block_bytes(&[c], &header.params(), 0, 0).unwrap()).unwrap();
/// #     }
/// #     CodecReader::from_bytes(w.finish_bytes().unwrap()).unwrap()
/// # }
///
/// let mut container = three_blocks();
/// let ids = |r: Vec<strandfit::codec::DecodedCurve>| {
///     r.into_iter().map(|c| c.id.unwrap()).collect::<Vec<_>>()
/// };
/// assert_eq!(ids(read_range(&mut container, 1, 2).unwrap()), ["c1", "c2"]);
/// // Past the end: what there is.
/// assert_eq!(ids(read_range(&mut container, 2, 10).unwrap()), ["c2"]);
/// assert!(read_range(&mut container, 3, 1).unwrap().is_empty());
/// ```
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
///
/// ```
/// use strandfit::codec::{output_curve, DecodedCurve};
/// use strandfit::DVec3;
///
/// // A straight curve of 3 points whose one per-point value is x.
/// let c = DecodedCurve {
///     id: Some("a".into()),
///     points: vec![DVec3::ZERO, DVec3::X, 2.0 * DVec3::X],
///     point_data: vec![0.0, 1.0, 2.0],
///     curve_data: vec![5.0],
/// };
/// // As decoded: the same points and values.
/// let same = output_curve(c.clone(), None, None, 1);
/// assert_eq!((&same.points, &same.point_data), (&c.points, &c.point_data));
/// // Resampled to 5 points: the values follow.
/// let five = output_curve(c.clone(), Some(5), None, 1);
/// assert_eq!(five.point_data, [0.0, 0.5, 1.0, 1.5, 2.0]);
/// assert_eq!((five.id.as_deref(), five.curve_data), (Some("a"), vec![5.0]));
/// // Every 0.25: 9 points.
/// assert_eq!(output_curve(c, None, Some(0.25), 1).points.len(), 9);
/// ```
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
///
/// ```
/// use strandfit::codec::resample_polyline;
/// use strandfit::DVec3;
///
/// // An L of length 4: 5 points are a point every unit, the corner among them.
/// let l = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 3.0, 0.0)];
/// let r = resample_polyline(&l, Some(5), None);
/// assert_eq!(r.len(), 5);
/// assert_eq!((r[1], r[4]), (DVec3::X, DVec3::new(1.0, 3.0, 0.0)));
/// // Every 0.5: 9 points; fewer than 2 points: as they are.
/// assert_eq!(resample_polyline(&l, None, Some(0.5)).len(), 9);
/// assert_eq!(resample_polyline(&l[..1], Some(5), None), [DVec3::ZERO]);
/// ```
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::{encode_block_bytes, output_curve, CodecWriter};
    use crate::io::{Format, Metadata, SourceMeta};
    use glam::DVec3;

    /// A writer that keeps the curves' ids.
    struct Ids(Vec<String>);
    impl CurveWriter for Ids {
        fn write_curve(&mut self, c: &Curve) -> Result<(), IoError> {
            self.0.push(c.id.clone().unwrap_or_default());
            Ok(())
        }
        fn finish(self: Box<Self>) -> Result<(), IoError> {
            Ok(())
        }
    }

    /// A container of `blocks` one-curve blocks (curve `k` named `c{k}`)
    /// and each block's geometry bytes.
    fn container(blocks: usize) -> (Vec<u8>, Vec<Vec<u8>>) {
        let meta = SourceMeta::from_metadata(&Metadata::new(Format::Json), None);
        let header = CodecHeader::new(0.01, meta, vec![]);
        let mut w = CodecWriter::in_memory(&header);
        let mut geometry = Vec::new();
        for k in 0..blocks {
            // Helices of different pitch and length: distinct streams.
            let points: Vec<DVec3> = (0..20 + k)
                .map(|i| 0.3 * i as f64)
                .map(|s| DVec3::new(s.cos(), s.sin(), (0.05 + 0.01 * k as f64) * s))
                .collect();
            let id = format!("c{k}");
            let c = CurveIn {
                id: Some(&id),
                points: &points,
                point_data: &[],
                curve_data: &[],
            };
            let b = encode_block_bytes(&[c], &header.params(), 0, 0).unwrap();
            geometry.push(b.geometry.clone());
            w.write_block(&b).unwrap();
        }
        (w.finish_bytes().unwrap(), geometry)
    }

    fn decompress_ids(bytes: Vec<u8>) -> (Ids, Result<u64, IoError>) {
        let mut reader = CodecReader::from_bytes(bytes).unwrap();
        let mut out = Ids(Vec::new());
        let map = |c| output_curve(c, None, None, 0);
        let n = decompress_stream(&mut reader, &mut out, &map, &mut |_| {});
        (out, n)
    }

    #[test]
    fn blocks_come_out_in_order_past_the_window() {
        let blocks = 5 * 2 * BLOCKS_AT_ONCE.max(rayon::current_num_threads());
        let (bytes, _) = container(blocks);
        let (out, n) = decompress_ids(bytes);
        assert_eq!(n.unwrap(), blocks as u64);
        assert_eq!(
            out.0,
            (0..blocks).map(|k| format!("c{k}")).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_corrupt_block_ends_the_output_after_every_curve_before_it() {
        let blocks = 40;
        let (mut bytes, geometry) = container(blocks);
        let bad = 25;
        let g = &geometry[bad];
        let at: Vec<usize> = (0..bytes.len() - g.len())
            .filter(|&i| bytes[i..i + g.len()] == g[..])
            .collect();
        assert_eq!(at.len(), 1, "block {bad}'s stream is found once");
        bytes[at[0] + g.len() / 2] ^= 0x5a;
        let (out, n) = decompress_ids(bytes);
        let e = n.unwrap_err().to_string();
        assert!(e.contains("checksum") || e.contains("corrupt"), "{e}");
        assert_eq!(out.0, (0..bad).map(|k| format!("c{k}")).collect::<Vec<_>>());
    }

    #[test]
    fn decoding_from_a_worker_of_a_one_thread_pool_finishes() {
        // The waiting thread is the pool's only worker: it must decode the
        // blocks it waits for itself.
        let (bytes, _) = container(20);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let (out, n) = pool.install(|| decompress_ids(bytes));
        assert_eq!(n.unwrap(), 20);
        assert_eq!(out.0.len(), 20);
        assert_eq!(out.0[19], "c19");
    }

    /// `count` short curves (three points each, curve `k` named `c{k}`),
    /// curves `bad` with a coordinate no lattice codes.
    fn short_curves(count: usize, bad: &[usize]) -> Vec<Curve> {
        (0..count)
            .map(|k| {
                let x = if bad.contains(&k) { 1e300 } else { k as f64 };
                let points = vec![
                    DVec3::new(x, 0.0, 0.0),
                    DVec3::new(x, 0.5, 0.1),
                    DVec3::new(x + 0.2, 1.0, 0.3),
                ];
                Curve {
                    id: Some(format!("c{k}")),
                    ..Curve::from_points(points)
                }
            })
            .collect()
    }

    /// The bytes [`compress_blocks`] writes for `curves`, or its error.
    fn compressed(curves: Vec<Curve>) -> Result<Vec<u8>, IoError> {
        let meta = Metadata::new(Format::Json);
        let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
        let mut writer = CodecWriter::in_memory(&header);
        let mut seen = Vec::new();
        let summary = compress_blocks(
            &mut crate::io::VecReader::new(meta, curves),
            Path::new("in.json"),
            &mut writer,
            &header,
            None,
            &mut |n| seen.push(n),
        )?;
        // Progress reports every block once, in order, ending at the count.
        assert_eq!(seen.last().copied(), Some(summary.curves));
        assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
        Ok(writer.finish_bytes().unwrap())
    }

    #[test]
    fn compressed_blocks_are_the_same_on_any_pool_and_in_order() {
        // Three blocks, taken by whichever thread is free: the container is
        // the same byte for byte on one, two and three threads (one of
        // them the pool's only worker, waiting for the blocks it encodes),
        // and decodes to the curves in order.
        let count = 2 * BLOCK_CURVES + 17;
        let mut all = Vec::new();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            all.push(
                pool.install(|| compressed(short_curves(count, &[])))
                    .unwrap(),
            );
        }
        assert!(all.iter().all(|b| *b == all[0]));
        let (out, n) = decompress_ids(all[0].clone());
        assert_eq!(n.unwrap(), count as u64);
        let want: Vec<String> = (0..count).map(|k| format!("c{k}")).collect();
        assert_eq!(out.0, want);
    }

    #[test]
    fn blocks_read_and_not_yet_written_stay_within_the_bound() {
        // At every block written, the curves read past it are at most
        // BLOCKS_PER_THREAD blocks per thread: memory stays bounded
        // however slow one block is against the others (counted until
        // done instead of written, this read every block ahead).
        struct Counting(
            std::vec::IntoIter<Curve>,
            std::sync::Arc<std::sync::atomic::AtomicU64>,
            Metadata,
        );
        impl Iterator for Counting {
            type Item = Result<Curve, IoError>;
            fn next(&mut self) -> Option<Self::Item> {
                let c = self.0.next()?;
                self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                Some(Ok(c))
            }
        }
        impl CurveReader for Counting {
            fn metadata(&self) -> &Metadata {
                &self.2
            }
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let blocks = 8;
        let read = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
        let meta = Metadata::new(Format::Json);
        let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
        // The first block's curves ten times as long: it takes longer than
        // the others, which are done while it runs and wait to be written.
        let mut curves = short_curves(blocks * BLOCK_CURVES, &[]);
        for c in &mut curves[..BLOCK_CURVES] {
            let p = c.points.clone();
            c.points = (0..30)
                .map(|i| p[i % 3] + DVec3::new(0.0, 0.0, 0.3 * (i / 3) as f64))
                .collect();
        }
        let mut reader = Counting(curves.into_iter(), read.clone(), meta);
        let mut writer = CodecWriter::in_memory(&header);
        let mut worst = 0u64;
        let mut calls = 0;
        pool.install(|| {
            compress_blocks(
                &mut reader,
                Path::new("in.json"),
                &mut writer,
                &header,
                None,
                &mut |written| {
                    calls += 1;
                    let now = read.load(std::sync::atomic::Ordering::Relaxed);
                    worst = worst.max(now - written);
                },
            )
        })
        .unwrap();
        assert_eq!(calls, blocks);
        let bound = (BLOCKS_PER_THREAD * 2 * BLOCK_CURVES) as u64;
        assert!(worst <= bound, "{worst} curves read ahead, bound {bound}");
        // (And it does read ahead: blocks are coded while others are read.)
        assert!(worst >= BLOCK_CURVES as u64, "{worst}");
    }

    #[test]
    fn a_panicking_block_is_an_error_not_a_hang() {
        // A checker that panics (a backend's bug): the block's task ends
        // with an error the writing thread reports, instead of leaving it
        // waiting for the block forever.
        struct Panics;
        impl crate::codec::ArcChecker for Panics {
            fn open(
                &self,
                _: &[DVec3],
            ) -> Result<Box<dyn crate::codec::ArcCheckBlock + '_>, String> {
                panic!("a checker's bug");
            }
        }
        let meta = Metadata::new(Format::Json);
        let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut writer = CodecWriter::in_memory(&header);
            let e = pool
                .install(|| {
                    compress_blocks(
                        &mut crate::io::VecReader::new(
                            meta.clone(),
                            short_curves(BLOCK_CURVES + 9, &[]),
                        ),
                        Path::new("in.json"),
                        &mut writer,
                        &header,
                        Some(&Panics),
                        &mut |_| {},
                    )
                })
                .unwrap_err();
            assert!(e.to_string().contains("panicked"), "{e}");
            assert_eq!(e.curve, Some(0), "{e}");
        }
    }

    #[test]
    fn the_first_failing_block_in_order_is_reported() {
        // Bad curves in blocks 1 and 2: whichever finishes first, the
        // error names block 1's (and the file, the point, the reason).
        let first_bad = BLOCK_CURVES + 5;
        let curves = short_curves(3 * BLOCK_CURVES, &[first_bad, 2 * BLOCK_CURVES + 2]);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let e = pool.install(|| compressed(curves.clone())).unwrap_err();
            assert_eq!(e.curve, Some(first_bad as u64), "{e}");
            let text = e.to_string();
            assert!(text.contains("in.json") && text.contains("point 0"), "{e}");
            assert!(text.contains("beyond the float32 range"), "{e}");
        }
        // A reader that fails in block 2, after a bad curve in block 0: the
        // bad curve is reported; with only the reader's failure, that.
        struct Failing(std::vec::IntoIter<Curve>, usize);
        impl Iterator for Failing {
            type Item = Result<Curve, IoError>;
            fn next(&mut self) -> Option<Self::Item> {
                if self.1 == 0 {
                    return Some(Err(IoError::new(Path::new("in.json"), "truncated")));
                }
                self.1 -= 1;
                self.0.next().map(Ok)
            }
        }
        impl CurveReader for Failing {
            fn metadata(&self) -> &Metadata {
                unreachable!("not asked")
            }
        }
        let meta = Metadata::new(Format::Json);
        let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec![]);
        for (bad, want) in [(vec![7usize], Some(7)), (vec![], None)] {
            let curves = short_curves(3 * BLOCK_CURVES, &bad);
            let mut writer = CodecWriter::in_memory(&header);
            let e = compress_blocks(
                &mut Failing(curves.into_iter(), 2 * BLOCK_CURVES + 3),
                Path::new("in.json"),
                &mut writer,
                &header,
                None,
                &mut |_| {},
            )
            .unwrap_err();
            assert_eq!(e.curve, want, "{e}");
            if want.is_none() {
                assert!(e.to_string().contains("truncated"), "{e}");
            }
        }
    }
}
