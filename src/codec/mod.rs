//! The curve codec: G1 arc chains within a two-sided tolerance, predicted,
//! quantised and range-coded in independently decodable blocks.
//!
//! # The guarantee
//!
//! For every curve, the polyline that [`decode_block`] returns is within the
//! tolerance `T` of the input polyline in the two-sided vertex-to-segment
//! Hausdorff distance ([`crate::metrics::hausdorff`]): every input vertex is
//! within `T` of an output segment and every output vertex within `T` of an
//! input segment. The encoder accepts an element only by that test
//! (`check.rs`), on exactly the points the decoder will produce, less a
//! margin for writing them as `f32`.
//!
//! # The representation
//!
//! A curve is a start point, then circular arcs, each fixed by its end
//! point (`predict.rs`): a *G1* arc inherits the tangent of the previous
//! one, a *corner* arc carries a bulge that sets its own. An end point is
//! coded as its chord length (against the previous chord's) and two
//! perpendicular offsets from where the previous arc, continued, would have
//! gone ([`Steps`]). Curves too rough for arcs store
//! their points on a body-centred cubic lattice of covering radius `T`,
//! predicted from their own last steps or from a neighbour's
//! (`reference.rs`): the quantise-and-delta baseline's representation on a
//! thinner lattice, so no curve costs more than that. Each point is the
//! lattice point cheapest to code against its prediction among those that
//! keep the two-sided promise (`quantise.rs`: it may slide along the curve,
//! where the prediction's error along it would cost bits). Integers go
//! through adaptive binary contexts, one model per field (`entropy.rs`).
//!
//! Decoding needs no search: it replays the arcs and cuts each into equal
//! pieces whose chords are within `sagitta · T` of it.
//!
//! ```
//! use glam::DVec3;
//! use strandfit::codec::{decode_block, encode_block, CodecParams};
//!
//! // A helix sampled every 0.5 units.
//! let helix: Vec<DVec3> = (0..200)
//!     .map(|k| {
//!         let s = k as f64 * 0.1;
//!         DVec3::new(3.0 * s.cos(), 3.0 * s.sin(), 0.8 * s)
//!     })
//!     .collect();
//! let params = CodecParams::new(0.05);
//! let block = encode_block(&[helix.clone()], &params).unwrap();
//! let back = decode_block(&block.bytes, 1, &params).unwrap();
//! let h = strandfit::metrics::hausdorff(&helix, &back[0]).unwrap();
//! assert!(h <= 0.05);
//! assert!(block.bytes.len() < 200 * 12 / 20); // over 20 times smaller than f32
//! ```
//!
//! # The `.sfh` container
//!
//! Files hold codec blocks with an index at the end ([`CodecWriter`],
//! [`CodecReader`]). The layout of version 3 (`docs/container.md` has the
//! details; `v` is a LEB128 varint, fixed-size integers are little endian):
//!
//! ```text
//! 0   8  magic 89 53 46 48 0D 0A 1A 0A
//! 8   2  version = 3
//! 10  v  header length H, then H bytes: encoding (0 raw, 1 DEFLATE),
//!        the binary header ([`CodecHeader`]), then u32 CRC-32 of the H bytes
//!     …  blocks: v curves, v geometry length, v side length (then v side
//!        inflated length if not 0), the geometry (the codec's range-coded
//!        stream) and the side data (DEFLATE: per curve its id and
//!        per-curve values), u32 CRC-32 of all of the block's bytes before it
//!     …  index: v blocks, per block v bytes and v curves
//! end-12 u32 CRC-32 of the index, u32 index length, "SFHE"
//! ```
//!
//! Every block decodes alone (its entropy models start afresh), so blocks
//! are encoded and decoded in parallel and a range of curves is read by
//! seeking to its blocks through the index. The framing costs about 40
//! bytes and the header about as much again: on a file of a few hundred
//! curves that is a few per cent of the whole.
//!
//! ```
//! use strandfit::codec::{encode_block_bytes, CodecHeader, CodecReader, CodecWriter, CurveIn, CONTAINER_VERSION};
//! use strandfit::io::{Format, Metadata, SourceMeta, CONTAINER_MAGIC};
//! use strandfit::DVec3;
//!
//! // One block of two curves, in memory.
//! let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![]);
//! let helix: Vec<DVec3> = (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s)).collect();
//! let curves = [&helix, &helix].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
//! let mut w = CodecWriter::in_memory(&header);
//! w.write_block(&encode_block_bytes(&curves, &header.params(), 0, 0).unwrap()).unwrap();
//! let bytes = w.finish_bytes().unwrap();
//! // The layout: magic, version; at the end the index, its CRC, its length, "SFHE".
//! let n = bytes.len();
//! assert_eq!((&bytes[..8], &bytes[8..10]), (&CONTAINER_MAGIC[..], &CONTAINER_VERSION.to_le_bytes()[..]));
//! assert_eq!(&bytes[n - 4..], b"SFHE");
//! let index_len = u32::from_le_bytes(bytes[n - 8..n - 4].try_into().unwrap()) as usize;
//! let index = &bytes[n - 12 - index_len..n - 12];
//! assert_eq!(crc32fast::hash(index).to_le_bytes(), bytes[n - 12..n - 8]);
//! assert_eq!((index[0], index[index_len - 1]), (1, 2)); // 1 block, of 2 curves
//! assert_eq!(CodecReader::from_bytes(bytes).unwrap().curve_count(), 2);
//! ```
//!
//! # Whole files
//!
//! [`compress_stream`] reads curves from any
//! [`CurveReader`](crate::io::CurveReader) into a version-3 container, block
//! by block; [`decompress_stream`] writes a container's curves to any
//! [`CurveWriter`](crate::io::CurveWriter), decoding several blocks at once.
//! Memory is bounded by a few blocks whatever the file's size; neither prints
//! (progress goes to a callback).
//!
//! ```
//! use strandfit::codec::{compress_stream, decompress_stream, output_curve, CodecHeader, CodecReader};
//! use strandfit::io::{create_writer, open_reader, read_all, Curve, Format, Metadata, SourceMeta};
//! use strandfit::DVec3;
//!
//! // A .tck file of 50 helices, compressed to 0.01 and back to .tck.
//! let dir = tempfile::tempdir().unwrap();
//! let [input, packed, output] = ["in.tck", "in.sfh", "out.tck"].map(|f| dir.path().join(f));
//! let mut w = create_writer(&input, None, &Metadata::new(Format::Tck)).unwrap();
//! for k in 0..50 {
//!     let s = (0..40).map(|i| 0.2 * i as f64);
//!     w.write_curve(&Curve::from_points(s.map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()))
//!         .unwrap();
//! }
//! w.finish().unwrap();
//!
//! let mut reader = open_reader(&input, None).unwrap();
//! let source = SourceMeta::from_metadata(reader.metadata(), Some(&input));
//! let header = CodecHeader::new(0.01, source, vec![]);
//! let summary = compress_stream(&mut *reader, &input, &packed, &header, None, &mut |_| {}).unwrap();
//! assert_eq!(summary.curves, 50);
//! assert!(summary.bytes * 5 < std::fs::metadata(&input).unwrap().len());
//!
//! let mut container = CodecReader::open(&packed).unwrap();
//! let mut w = create_writer(&output, None, &container.header().source.to_metadata()).unwrap();
//! let as_decoded = |c| output_curve(c, None, None, 0);
//! assert_eq!(decompress_stream(&mut container, &mut *w, &as_decoded, &mut |_| {}).unwrap(), 50);
//! w.finish().unwrap();
//! // Every curve within the tolerance of the one read.
//! let ((_, before), (_, after)) = (read_all(&input, None).unwrap(), read_all(&output, None).unwrap());
//! assert_eq!(after.len(), 50);
//! for (a, b) in before.iter().zip(&after) {
//!     assert!(strandfit::metrics::hausdorff(&a.points, &b.points).unwrap() <= 0.01);
//! }
//! ```

mod batch;
mod check;
mod container;
mod encoder;
// Kept public (hidden) for its doctests, which exercise the range coder by
// its own names (`Encoder`, `Decoder`: too generic to sit flat in `codec`).
#[doc(hidden)]
pub mod entropy;
mod point_data;
mod predict;
mod quantise;
mod reference;
mod shards;
mod stream;

// What a batch checker (the GPU) implements: the types of
// [`encode_block_on`]'s `checker`.
pub use batch::{ArcCandidate, ArcCheckBlock, ArcChecker, BatchStats, Verdict};
// The metrics' preview colours by the encoder's distance.
pub(crate) use check::dist2_to_segment;
// The container's generic names get a `CONTAINER_` prefix here.
pub use container::{
    container_version, encode_block_bytes, encode_block_bytes_on, BlockBytes, CodecHeader,
    CodecReader, CodecWriter, CurveIn, DecodedCurve, RawBlock, ReadSeek,
    BLOCK_CURVES as CONTAINER_BLOCK_CURVES, IN_MEMORY, MODEL, READ_MODELS,
    VERSION as CONTAINER_VERSION,
};
pub use point_data::carry as carry_point_data;
pub use predict::AlongStep;
pub use quantise::Steps;
// (`Effort` is defined below, beside `CodecParams`.)
pub use reference::Reference;
pub use shards::{merge as merge_shards, shard_path, split as split_into_shards, Shard};
pub use stream::{
    compress_blocks, compress_stream, compress_to_bytes, decompress_range, decompress_stream,
    output_curve, read_range, resample_polyline, CompressSummary,
};

use glam::DVec3;
use rayon::prelude::*;

use encoder::{
    acceptance_tolerance, corner_from_code, element_end, first_end, jump_end, next_state,
    CornerChord, CurveEncoder,
};
use entropy::{Adaptation, Bit, Decoder, Encoder, IntModel};
use predict::Arc;
use quantise::Quantiser;
use reference::{Neighbours, Rule};

/// How a block is coded: the tolerance, the steps and the model (stored in
/// the container's header), and how hard the encoder searches (not stored:
/// the decoder does not need it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CodecParams {
    /// The two-sided Hausdorff tolerance `T` every decoded curve is within.
    pub tolerance: f64,
    /// Quantisation steps, as multiples of `T`.
    pub steps: Steps,
    /// The model revision the stream is coded by ([`MODEL`] for
    /// new streams; a container's header says which for old ones).
    pub model: u8,
    /// How hard the encoder searches (the decoder does not need it).
    pub effort: Effort,
}

/// How hard the encoder searches for a smaller stream: the same format and
/// guarantee either way.
///
/// `Best` codes each block twice, with the look-ahead and without, and
/// keeps the smaller, so it is never larger than `Default`. Measured
/// (session 51, `strandfit compress --effort`): the field lines 1.6 %
/// smaller at 0.01 R☉ (2.9 % at 0.001), 10,000 fornix replicas at 0.5 mm
/// 1.6 %, the fornix 0.5 % / 1.6 % (0.1 / 0.5 mm), the hair at 0.5 mm the
/// same; for 3–3.5 times the CPU of `Default`. (Before every element's
/// kinds were searched, the look-ahead alone made the field lines 7–8 %
/// smaller, and the fornix at 0.1 mm 1 % larger: docs/reference.md,
/// "Session 49" and "Session 51".)
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Effort {
    /// Each arc reaches as far along the curve as it can.
    #[default]
    Default,
    /// Each arc is also chosen looking one arc ahead (one a few vertices
    /// shorter where the next then reaches as far for fewer bits), and each
    /// block's smaller coding kept.
    Best,
}

impl Effort {
    /// Its name as the command line's `--effort` and the reports spell it.
    ///
    /// ```
    /// use strandfit::codec::Effort;
    ///
    /// for e in [Effort::Default, Effort::Best] {
    ///     assert_eq!(Effort::from_name(e.name()), Some(e));
    /// }
    /// assert_eq!(Effort::from_name("fast"), None);
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Effort::Default => "default",
            Effort::Best => "best",
        }
    }

    /// The effort named `name` ([`name`](Self::name)), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        [Effort::Default, Effort::Best]
            .into_iter()
            .find(|e| e.name() == name)
    }
}

impl CodecParams {
    /// Parameters for tolerance `T`, with the default steps.
    pub fn new(tolerance: f64) -> Self {
        CodecParams {
            tolerance,
            steps: Steps::default(),
            model: container::MODEL,
            effort: Effort::Default,
        }
    }

    fn quantiser(&self) -> Quantiser {
        Quantiser::new(self.tolerance, self.steps)
    }
}

/// How an element's start tangent is set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ElementKind {
    /// Inherited from the previous element (G1).
    G1 = 0,
    /// Along the chord: a straight segment after a kink.
    Straight = 1,
    /// Set by a coded bulge.
    Corner = 2,
    /// A straight segment to the next input vertex on the start grid
    /// (`jump`, in start steps): where no arc passes, so that a curve is
    /// never given up as a whole.
    Jump = 3,
}

/// One element's code (the geometry is in `src/codec/predict.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ElementCode {
    /// What the element is (G1 arc, corner arc, jump).
    pub kind: ElementKind,
    /// Chord length in length steps, minus the previous element's.
    pub length: i64,
    /// Perpendicular offsets of the end from the prediction, offset steps.
    pub offset: [i64; 2],
    /// Corner bulge (sagitta vector) in offset steps; zero for G1.
    pub bulge: [i64; 2],
    /// A corner's bulge is coded as its difference from this prediction
    /// (not coded: from model 16 on, [`encoder::CornerChord::bulge_prediction`];
    /// zero before, and for the other kinds).
    pub bulge_base: [i64; 2],
    /// A jump's end relative to its start, in start steps (the other
    /// fields are then zero).
    pub jump: [i64; 3],
    /// The previous chord in length steps (not coded: the decoder knows
    /// it; the context of the residuals, which grow with the span).
    pub span: i64,
}

/// One curve's code.
#[derive(Clone, Debug, PartialEq)]
pub enum CurveCode {
    /// A curve without points.
    Empty,
    /// Points on the grid of step `2T/√3` (indices), predicted from their
    /// own last step or from a neighbour's (`src/codec/reference.rs`).
    Points {
        /// Grid indices of the points.
        grid: Vec<[i64; 3]>,
        /// The neighbour whose steps predict this curve's, if any.
        reference: Option<Reference>,
        /// Without a reference: how the curve predicts itself.
        own: OwnPrediction,
        /// From model 10: the coordinate along each step predicted from
        /// the step length ([`AlongStep`]) rather than coded as it is.
        along: bool,
    },
    /// Start point on the start grid, the first element's end relative to
    /// it on the same grid, its bulge, then the elements.
    Arcs {
        /// Start point on the start grid.
        start: [i64; 3],
        /// The first element's end relative to the start.
        first_end: [i64; 3],
        /// The first element's bulge.
        first_bulge: [i64; 2],
        /// The remaining elements.
        elements: Vec<ElementCode>,
    },
    /// The points verbatim (`f64`): values the grids cannot code
    /// (coordinates beyond `2^40` steps).
    Raw(Vec<DVec3>),
}

/// Why a curve cannot be encoded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EncodeError {
    #[error("curve {curve}: point {point} is not finite")]
    /// A point is not finite.
    NonFinite {
        /// Index of the curve in the block.
        curve: usize,
        /// Index of the point in the curve.
        point: usize,
    },
    #[error("curve {curve}: point {point}: {why}")]
    /// A point is finite but beyond what the output formats store
    /// (float32): it would not decode.
    BeyondFloat32 {
        /// Index of the curve in the block.
        curve: usize,
        /// Index of the point in the curve.
        point: usize,
        /// Which coordinate, and its value ([`crate::io::point_problem`]).
        why: String,
    },
    #[error("tolerance {0} is not a positive finite number")]
    /// The tolerance is not a positive finite number.
    BadTolerance(f64),
}

/// Why a block cannot be decoded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DecodeError {
    #[error("curve {curve}: {why}")]
    /// A curve's code is inconsistent.
    Curve {
        /// Index of the curve in the block.
        curve: usize,
        /// What is wrong.
        why: String,
    },
    #[error("the block's coded stream ends early (truncated or corrupt)")]
    /// The coded stream ends early (truncated or corrupt).
    Truncated,
}

/// What [`encode_block`] returns.
#[derive(Debug)]
pub struct EncodedBlock {
    /// The entropy-coded geometry of the block.
    pub bytes: Vec<u8>,
    /// Per curve: how it was coded (0 empty, 1 points, 2 arcs, 3 raw).
    pub kinds: Vec<u8>,
    /// Points the decoder will write, in all.
    pub output_points: usize,
    /// Arc elements (first elements included), in all.
    pub elements: usize,
    /// Per curve, the points the decoder will write (only from
    /// [`encode_block_keeping`]: what per-point values are carried onto).
    pub decoded: Vec<Vec<DVec3>>,
    /// The batched checks, where a checker was given
    /// ([`encode_block_on`]; of every coding where a block was coded more
    /// than once: a small block exploring, `Effort::Best` both efforts).
    pub checks: batch::BatchStats,
}

/// Upper bound of the points one curve may decode to (a corrupt stream
/// must not make the decoder allocate without bound).
pub const MAX_DECODED_POINTS: usize = 1 << 28;

/// The ways one curve can be coded, before the block chooses (the choice
/// depends on the curves before it, through [`reference`](mod@reference)).
///
/// Plumbing of [`encode_block`] (what [`curve_options`] returns), not part
/// of the public API.
#[doc(hidden)]
pub struct CurveOptions {
    /// Grid points (points mode), if every point is codable.
    pub points: Option<Vec<[i64; 3]>>,
    /// Arcs and the points they decode to.
    pub arcs: Option<(CurveCode, Vec<DVec3>)>,
}

/// Fits one curve both ways (no entropy coding; curves in parallel).
///
/// Plumbing of [`encode_block`], not part of the public API: `half` is the
/// block's lattice step, which the block computes from all its curves
/// (the hidden `quantise` module), and `arcs_scale` the factor on the
/// arcs' estimate the block has learned so far ([`Calibration`]), by which
/// the arcs search gives up where the points are cheaper.
#[doc(hidden)]
pub fn curve_options(
    points: &[DVec3],
    params: &CodecParams,
    half: f64,
    arcs_scale: f64,
) -> CurveOptions {
    curve_options_ordered(points, params, half, arcs_scale, false)
}

/// [`curve_options`], the search after a corner trying the corner first
/// where `corner_first` ([`encoder::CurveEncoder::corner_first`]).
fn curve_options_ordered(
    points: &[DVec3],
    params: &CodecParams,
    half: f64,
    arcs_scale: f64,
    corner_first: bool,
) -> CurveOptions {
    match curve_encoder(points, params, half, arcs_scale, corner_first) {
        None => CurveOptions {
            points: None,
            arcs: None,
        },
        Some(enc) => {
            let arcs = if points.len() >= 3 {
                batch::now(enc.arcs())
            } else {
                None
            };
            finish_options(&enc, arcs)
        }
    }
}

/// The encoder of one curve (`None` for an empty curve, or one so far out
/// that `f32` output leaves no tolerance); its arcs search gives up where
/// the points are cheaper, by the block's `arcs_scale` so far
/// ([`encoder::GiveUp`]); with `corner_first`, an element after a corner
/// searches the corner first ([`encoder::CurveEncoder::corner_first`]).
fn curve_encoder<'a>(
    points: &'a [DVec3],
    params: &CodecParams,
    half: f64,
    arcs_scale: f64,
    corner_first: bool,
) -> Option<CurveEncoder<'a>> {
    if points.is_empty() {
        return None;
    }
    let tol = acceptance_tolerance(params.tolerance, points);
    if tol <= 0.0 {
        return None;
    }
    Some(CurveEncoder {
        points,
        q: params.quantiser(),
        tol2: tol * tol,
        grid: half,
        mailbox: None,
        give_up: Some(encoder::GiveUp::new(arcs_scale)),
        look_ahead: params.effort == Effort::Best,
        bulge_prediction: bulge_predicted(params.model),
        corner_first,
    })
}

/// Second-order estimate of the rounded points `g` up to each vertex (bits;
/// `[0] = 0`, the start not counted).
fn points_bits_to(g: &[[i64; 3]]) -> Vec<u64> {
    let mut out = Vec::with_capacity(g.len());
    let mut bits = 0;
    out.push(0);
    for k in 1..g.len() {
        let p = own_prediction(g, k, OwnPrediction::SecondOrder, screw(MODEL));
        bits += lattice_bits([0, 1, 2].map(|a| g[k][a].wrapping_sub(p[a])));
        out.push(bits);
    }
    out
}

/// Bits per input point under which a curve's arcs are kept without
/// weighing its points ([`finish_options`]).
const ARCS_ALONE_BITS: u64 = 5;

/// A curve's options once its arcs are found: the points too, unless the
/// arcs are cheap enough that the points are not worth weighing.
fn finish_options(enc: &CurveEncoder, arcs: Option<(CurveCode, Vec<DVec3>)>) -> CurveOptions {
    let points = enc.points;
    // Points cost about 4 bits each or more on the lattice, even with a
    // neighbour's prediction (1.3 bits per coordinate on the smoothest
    // shared data): where the arcs take under 5 bits per point, the points
    // are not worth weighing. Measured over the shared data at both
    // tolerances and the fornix replicas at 0.1 and 0.5 mm: the same bytes
    // with 3, 5 or 6 bits (no curve under 6 went to points; 8 lost 0.1 %),
    // and at 5 the replicas compress 12 % faster at 0.5 mm than at 3.
    let arcs_small = arcs
        .as_ref()
        .is_some_and(|(a, _)| estimated_bits(a) < ARCS_ALONE_BITS * points.len() as u64);
    CurveOptions {
        points: if arcs_small {
            None
        } else {
            match enc.points_code() {
                Some(CurveCode::Points { grid, .. }) => Some(grid),
                _ => None,
            }
        },
        arcs,
    }
}

/// Bits of an Exp-Golomb code of `v` with a sign: a static stand-in for the
/// adaptive coder's cost when choosing between representations.
fn eg_bits(v: i64) -> u64 {
    // 1 at 0 too (64 leading zeros), without a branch.
    1 + 2 * (64 - v.unsigned_abs().leading_zeros() as u64)
}

/// [`estimated_bits`] of an arcs curve's header and first element.
fn first_element_bits(first_end: [i64; 3], first_bulge: [i64; 2]) -> u64 {
    8 + first_end
        .into_iter()
        .chain(first_bulge)
        .map(eg_bits)
        .sum::<u64>()
}

/// [`estimated_bits`] of one element of an arcs curve.
fn element_bits(e: &ElementCode) -> u64 {
    if e.kind == ElementKind::Jump {
        return 2 + e.jump.iter().map(|&v| eg_bits(v)).sum::<u64>();
    }
    let mut bits = 1 + eg_bits(e.length) + eg_bits(e.offset[0]) + eg_bits(e.offset[1]);
    if e.kind != ElementKind::G1 {
        bits += 1;
    }
    if e.kind == ElementKind::Corner {
        bits += eg_bits(e.bulge[0] - e.bulge_base[0]) + eg_bits(e.bulge[1] - e.bulge_base[1]);
    }
    bits
}

fn estimated_bits(code: &CurveCode) -> u64 {
    match code {
        CurveCode::Empty => 2,
        CurveCode::Raw(p) => 192 * p.len() as u64,
        CurveCode::Points { grid, own, .. } => {
            let mut bits = 8;
            for k in 1..grid.len() {
                let p = own_prediction(grid, k, *own, screw(MODEL));
                bits += lattice_bits([0, 1, 2].map(|a| grid[k][a] - p[a]));
            }
            bits
        }
        CurveCode::Arcs {
            first_end,
            first_bulge,
            elements,
            ..
        } => {
            first_element_bits(*first_end, *first_bulge)
                + elements.iter().map(element_bits).sum::<u64>()
        }
    }
}

/// An arcs curve's first and last chords ([`reference::ArcChords`]): the
/// last is the last element's where that is not a jump.
fn arc_chords(code: &CurveCode) -> reference::ArcChords {
    match code {
        CurveCode::Arcs {
            first_end,
            elements,
            ..
        } => reference::ArcChords {
            first: Some(*first_end),
            last: elements
                .last()
                .filter(|e| e.kind != ElementKind::Jump)
                .map(|e| e.span.wrapping_add(e.length)),
        },
        _ => reference::ArcChords::default(),
    }
}

/// Prediction of an arcs curve's first chord (on the start grid) and the
/// walked stretch its first bulge is predicted from (its end and middle,
/// relative to the start): without an anchor, the previous arcs curve's
/// first chord (no stretch); with one, the anchoring neighbour (it runs
/// beside this curve) walked from the anchor as far as the previous arcs
/// curve's first chord is long (models 6 to 13) or, from model 14, as far
/// as the anchor's own first chord (or, anchored at its end, its last)
/// where it is an arcs curve: a curve's first element ends where a single
/// arc stops fitting, which a neighbour beside it shares and the curve
/// coded before need not (field lines of `../shared/data` at 0.01 solar
/// radii: the first elements 9 % cheaper, the file 2.8 %). From model 15,
/// in a block with its fit flag (`fit`: the start, on the starts'
/// lattice), the [`NEAR`](reference::NEAR) anchors nearest the start are
/// walked as far, and their stretches fitted linearly in the anchors'
/// places and taken at the start ([`predict::fit_at_origin`]): a
/// neighbour's first stretch is a smooth function of where it starts
/// (field lines from a star's surface), so the fit follows the field
/// between the neighbours where one neighbour's walk misses by its
/// distance times the field's gradient.
fn first_end_prediction(
    neighbours: &Neighbours,
    before: usize,
    anchor: Option<(usize, bool)>,
    prev: &Previous,
    q: &Quantiser,
    model: u8,
    fit: Option<[i64; 3]>,
) -> ([i64; 3], Option<(DVec3, DVec3)>) {
    let step = q.first;
    let norm = |f: [i64; 3]| {
        let f = f.map(|v| v as f64);
        (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt() * step
    };
    let walk = anchor.and_then(|(back, at_end)| {
        let k = before - back;
        let mut length = norm(prev.first_end);
        if model >= 14 {
            let c = neighbours.chords(k);
            let own = if at_end {
                c.last.map(|l| l as f64 * q.length)
            } else {
                c.first.map(norm)
            };
            length = own.unwrap_or(length);
        }
        let Some(start) = fit else {
            return neighbours.walk_with_middle(k, at_end, length);
        };
        // Model 15, in a block with its fit flag: the walks of the anchors
        // nearest the start, fitted linearly in their places.
        let (near, n) = neighbours.nearest_anchors(start, before);
        let mut walks = [predict::Walked::default(); reference::NEAR];
        let mut m = 0;
        for a in &near[..n] {
            let (Some((end, middle)), Some(r)) = (
                neighbours.walk_with_middle(a.curve, a.at_end, length),
                neighbours.anchor(a.curve, a.at_end),
            ) else {
                continue;
            };
            walks[m] = predict::Walked {
                end,
                middle,
                at: [0, 1, 2].map(|i| (r[i] as f64) - (start[i] as f64)),
                weight: 1.0 / (a.d2 + 1.0),
            };
            m += 1;
        }
        predict::fit_at_origin(&walks[..m])
            .or_else(|| neighbours.walk_with_middle(k, at_end, length))
    });
    let walked = walk.and_then(|(v, _)| {
        let k = [v.x / step, v.y / step, v.z / step].map(f64::round);
        k.iter()
            .all(|x| x.is_finite() && x.abs() < (1u64 << entropy::MAX_BITS) as f64)
            .then(|| k.map(|x| x as i64))
    });
    (walked.unwrap_or(prev.first_end), walk)
}

/// Prediction of an anchored curve's first bulge: the bulge of the
/// anchoring neighbour's walked stretch (`walk`: its end and middle,
/// relative to the anchor; [`first_end_prediction`]), the parabola through
/// them `y = 4hλ(1 − λ)` as the encoder estimates its own, scaled to this
/// chord (a bulge grows with the chord squared) and put in this element's
/// bulge frame. Neighbouring curves bend alike where they start together.
fn first_bulge_prediction(
    walk: Option<(DVec3, DVec3)>,
    q0: DVec3,
    end: DVec3,
    step: f64,
) -> [i64; 2] {
    let predict = || -> Option<[i64; 2]> {
        let (e, m) = walk?;
        let c2 = e.length_squared();
        let lambda = m.dot(e) / c2;
        if !(c2 > 0.0 && (0.1..=0.9).contains(&lambda)) {
            return None;
        }
        let h = (m - e * lambda) / (4.0 * lambda * (1.0 - lambda));
        let scale = ((end - q0).length_squared() / c2).min(4.0);
        let (f1, f2) = encoder::bulge_frame(q0, end, DVec3::ZERO)?;
        let b = [h.dot(f1) * scale / step, h.dot(f2) * scale / step].map(f64::round);
        b.iter()
            .all(|x| x.is_finite() && x.abs() < (1u64 << 20) as f64)
            .then(|| b.map(|x| x as i64))
    };
    predict().unwrap_or([0, 0])
}

/// Codes a difference of two lattice points (coordinates of one parity):
/// the parity, then each coordinate halved.
fn put_lattice(enc: &mut Encoder, parity: &mut Bit, m: &mut [IntModel; 3], d: [i64; 3]) {
    let b = d[0] & 1;
    enc.bit(parity, b != 0);
    for a in 0..3 {
        m[a].put(enc, (d[a] - b) / 2);
    }
}

#[inline]
fn get_lattice(dec: &mut Decoder, parity: &mut Bit, m: &mut [IntModel; 3]) -> [i64; 3] {
    let b = dec.bit(parity) as i64;
    let x = m[0].get(dec);
    let y = m[1].get(dec);
    let z = m[2].get(dec);
    [x, y, z].map(|v| v.wrapping_mul(2).wrapping_add(b))
}

/// Static cost of a lattice difference (for the encoder's choices).
fn lattice_bits(d: [i64; 3]) -> u64 {
    let b = d[0] & 1;
    // `d − b` even on every axis (one parity): the shift is the division.
    1 + (0..3)
        .map(|a| eg_bits(d[a].wrapping_sub(b) >> 1))
        .sum::<u64>()
}

/// [`lattice_bits`] without its steps at powers of two: choosing among
/// nearby lattice points, the smaller residual is the cheaper one.
/// (The residual of two lattice points has one parity on all three axes,
/// so each axis's part is its own: [`quantise::AxisCost`].)
fn smooth_lattice_bits() -> quantise::AxisCost<impl Fn(i64) -> f64 + Copy> {
    quantise::AxisCost {
        base: 1.0,
        axis: smooth_axis_bits,
    }
}

/// One axis's part of [`smooth_lattice_bits`]: the zero flag, and the
/// magnitude of the half residual as a log.
fn smooth_axis_bits(v: i64) -> f64 {
    // The slide asks three of these per candidate point of a vertex for
    // every partial choice, nearly all of small residuals: those from a
    // table (the same values, made by the same
    // function at compile time).
    let i = v.wrapping_add(SMOOTH_AXIS_SMALL) as u64;
    if i < SMOOTH_AXIS_TABLE.len() as u64 {
        SMOOTH_AXIS_TABLE[i as usize]
    } else {
        smooth_axis_bits_of(v)
    }
}

/// [`smooth_axis_bits`] computed.
const fn smooth_axis_bits_of(v: i64) -> f64 {
    // log₂(1 + x) with the mantissa taken linearly: a libm log₂ here was a
    // tenth of the encoder's time.
    let x = ((v - (v & 1)) / 2).unsigned_abs();
    1.0 + 2.0 * entropy::linear_log2(x.saturating_add(1) as f64)
}

/// The residuals [`smooth_axis_bits`] has in its table: `-64..=64`.
const SMOOTH_AXIS_SMALL: i64 = 64;
const SMOOTH_AXIS_TABLE: [f64; 2 * SMOOTH_AXIS_SMALL as usize + 1] = {
    let mut t = [0.0; 2 * SMOOTH_AXIS_SMALL as usize + 1];
    let mut i = 0;
    while i < t.len() {
        t[i] = smooth_axis_bits_of(i as i64 - SMOOTH_AXIS_SMALL);
        i += 1;
    }
    t
};

/// The adaptive models of one kind of points residual (own or a
/// neighbour's prediction), in [`RESIDUAL_CONTEXTS`] contexts.
#[derive(Default)]
struct ResidualModels {
    parity: [Bit; RESIDUAL_CONTEXTS],
    axes: [[IntModel; 3]; RESIDUAL_CONTEXTS],
    /// From model 10: the along-step coordinate less its prediction
    /// ([`AlongStep`]).
    along: [IntModel; RESIDUAL_CONTEXTS],
    /// From model 11: a coordinate's sign is coded in a context of the
    /// sign of the same axis's coordinate in the residual before (`signs`
    /// across the step, [`IntModel::put_after`] along it): a curve's
    /// prediction errs the same way for a stretch (where it bends more or
    /// less than predicted).
    sign_after: bool,
    /// Model 11's sign contexts across the step: by residual context, axis
    /// and the sign before (−, 0, +).
    signs: [[[Bit; 3]; 3]; RESIDUAL_CONTEXTS],
    /// From model 11, a block's choice: the magnitudes across the step in
    /// one model for all axes (`axes[ctx][0]`) instead of one per axis.
    shared: bool,
}

impl ResidualModels {
    /// The magnitude model and the sign context of coordinate `a` across
    /// the step in residual context `ctx`, after `before` on that axis.
    #[inline]
    fn across(&mut self, ctx: usize, a: usize, before: i64) -> (&mut IntModel, &mut Bit) {
        let axis = if self.shared { 0 } else { a };
        (
            &mut self.axes[ctx][axis],
            &mut self.signs[ctx][a][(before.signum() + 1) as usize],
        )
    }
}

/// Whether codec `model` codes a points residual's signs after the signs
/// before, and has a block's choice of shared magnitudes
/// ([`ResidualModels::sign_after`], [`ResidualModels::shared`]).
fn sign_after(model: u8) -> bool {
    model >= 11
}

/// Whether a corner's bulge is coded against half the G1 arc's
/// ([`encoder::CornerChord::bulge_prediction`]; model 16 on).
pub(crate) fn bulge_predicted(model: u8) -> bool {
    model >= 16
}

/// The two axes other than each, in order: coded before the along axis.
const OTHER_AXES: [[usize; 2]; 3] = [[1, 2], [0, 2], [0, 1]];

/// [`AlongStep::at`]'s axis alone.
fn along_axis(g: &[[i64; 3]], k: usize, pred: [i64; 3]) -> usize {
    AlongStep::axis_of([0, 1, 2].map(|a| pred[a].wrapping_sub(g[k - 1][a])))
}

/// Codes the residuals of a points curve's `grid` after its start against
/// `predict(k)`, each in the contexts of the one before
/// ([`residual_context`]); with `along` (model 10) the coordinate along
/// the step against [`AlongStep`]'s prediction, after the other two; from
/// model 11 each sign in the context of the sign before on its axis
/// ([`ResidualModels::sign_after`]).
fn put_residuals(
    enc: &mut Encoder,
    models: &mut ResidualModels,
    along: Option<bool>,
    plan: &[Residual],
) {
    let mut ctx = RESIDUAL_CONTEXTS - 1;
    let mut before = [0i64; 3];
    for (i, r) in plan.iter().enumerate() {
        let (d, m) = (r.d, r.axis);
        match along.filter(|_| i + 1 >= 2) {
            Some(_) => {
                let b = d[0] & 1;
                enc.bit(&mut models.parity[ctx], b != 0);
                for a in OTHER_AXES[m] {
                    let v = (d[a] - b) / 2;
                    if models.sign_after {
                        let (model, sign) = models.across(ctx, a, before[a]);
                        model.put_signed_in(enc, v, sign);
                    } else {
                        models.axes[ctx][a].put(enc, v);
                    }
                }
                models.along[ctx].put_after(enc, (d[m] - b) / 2 - r.half, before[m]);
            }
            None => put_lattice(enc, &mut models.parity[ctx], &mut models.axes[ctx], d),
        }
        ctx = residual_context(d);
        if models.sign_after {
            before = halves(d);
        }
    }
}

/// One residual of a points curve as [`put_residuals`] codes it: the
/// lattice difference from the prediction, the axis coded last and, with
/// the along-step prediction, its predicted half (what the streams of a
/// block share: [`plan_residuals`]).
struct Residual {
    d: [i64; 3],
    axis: usize,
    half: i64,
}

/// The residuals of points `1..` of `grid` against `predict`, with what
/// coding them needs besides the models.
fn plan_residuals(
    along: Option<bool>,
    grid: &[[i64; 3]],
    predict: impl Fn(usize) -> [i64; 3],
) -> Vec<Residual> {
    let mut window = 0;
    let mut out = Vec::with_capacity(grid.len().saturating_sub(1));
    for k in 1..grid.len() {
        let pred = predict(k);
        let d = [0, 1, 2].map(|a| grid[k][a] - pred[a]);
        if along == Some(true) {
            window = predict::step_window(grid, k, window);
        }
        let (axis, half) = match along.filter(|_| k >= 2) {
            Some(flag) => {
                let b = d[0] & 1;
                let step = flag.then(|| AlongStep::at(grid, k, pred, window));
                let m = step.map_or_else(|| along_axis(grid, k, pred), |s| s.axis());
                (m, step.map_or(0, |s| s.half_prediction(d, b)))
            }
            None => (0, 0),
        };
        out.push(Residual { d, axis, half });
    }
    out
}

/// The decoder's [`put_residuals`]: points `g.len()..n` of a points curve
/// whose start `g` holds, each `predict(points so far, k, recent)` plus
/// its residual, where `recent` is `[g[k − 2], g[k − 1]]` (`g[0]` twice at
/// `k = 1`), kept in registers: the point just decoded, read back from
/// `g` as a whole, waits for its stores to reach the cache (a stall of
/// about 2 % in the profile of decoding the fornix replicas; the time
/// moved within the spread).
fn get_residuals(
    dec: &mut Decoder,
    models: &mut ResidualModels,
    along: Option<bool>,
    g: &mut Vec<[i64; 3]>,
    n: usize,
    predict: impl Fn(&[[i64; 3]], usize, [[i64; 3]; 2]) -> [i64; 3],
) {
    let mut recent = match g.len() {
        0 => [[0; 3]; 2],
        1 => [g[0]; 2],
        l => [g[l - 2], g[l - 1]],
    };
    let mut ctx = RESIDUAL_CONTEXTS - 1;
    let mut window = 0u64;
    // The squared step lengths in the window, step `i` at `i % WINDOW`:
    // `predict::step_window` with each step measured once.
    const WINDOW: usize = AlongStep::STEPS + 1;
    let mut steps = [0u64; WINDOW];
    for i in 1..g.len() {
        steps[i % WINDOW] = predict::step_length2(g, i);
    }
    let mut before = [0i64; 3];
    for k in g.len()..n {
        let pred = predict(g, k, recent);
        if along == Some(true) && k >= 2 {
            let step = predict::step_length2(g, k - 1);
            window = window.saturating_add(step);
            if k - 1 > AlongStep::STEPS {
                window = window.saturating_sub(steps[(k - 1 - AlongStep::STEPS) % WINDOW]);
            }
            steps[(k - 1) % WINDOW] = step;
        }
        let d = match along.filter(|_| k >= 2) {
            Some(flag) => {
                let b = dec.bit(&mut models.parity[ctx]) as i64;
                let step = flag.then(|| AlongStep::at(g, k, pred, window));
                let m = step.map_or_else(|| along_axis(g, k, pred), |s| s.axis());
                let [a0, a1] = OTHER_AXES[m];
                let o0 = across_residual(dec, models, ctx, a0, before[a0], b);
                let o1 = across_residual(dec, models, ctx, a1, before[a1], b);
                // The point assembled by selects, not by stores at the
                // axes' indices: a whole-array read right after stores to
                // parts of it waits for them to reach the cache (the
                // profile's largest stall; 8 % less decoder CPU without it).
                let with = |along: i64| -> [i64; 3] {
                    match m {
                        0 => [along, o0, o1],
                        1 => [o0, along, o1],
                        _ => [o0, o1, along],
                    }
                };
                let h = step.map_or(0, |s| s.half_prediction(with(0), b));
                with(
                    models.along[ctx]
                        .get_after(dec, before[m])
                        .wrapping_add(h)
                        .wrapping_mul(2)
                        .wrapping_add(b),
                )
            }
            None => get_lattice(dec, &mut models.parity[ctx], &mut models.axes[ctx]),
        };
        ctx = residual_context(d);
        if models.sign_after {
            before = halves(d);
        }
        let point = [0, 1, 2].map(|a| pred[a].wrapping_add(d[a]));
        g.push(point);
        recent = [recent[1], point];
    }
}

/// One across-axis coordinate of an along-coded residual (axis `a`, the
/// residual before's half `before` on it, parity `b`). Forced inline: a
/// call on the chain from one point to the next costs more than its
/// instructions.
#[inline(always)]
fn across_residual(
    dec: &mut Decoder,
    models: &mut ResidualModels,
    ctx: usize,
    a: usize,
    before: i64,
    b: i64,
) -> i64 {
    let v = if models.sign_after {
        let (model, sign) = models.across(ctx, a, before);
        model.get_signed_in(dec, sign)
    } else {
        models.axes[ctx][a].get(dec)
    };
    v.wrapping_mul(2).wrapping_add(b)
}

/// Whether codec `model` codes the along-step coordinate last, in a model
/// of its own, and has a per-curve flag for its [`AlongStep`] prediction.
fn along(model: u8) -> bool {
    model >= 10
}

/// The estimated bits of the lattice points `g` against `predict` from
/// their third point on, with the along-step prediction and without (the
/// start and the second point are coded alike either way).
/// (Generic, not `&dyn`: each prediction inlined into its own instance.)
#[inline]
fn along_bits(g: &[[i64; 3]], predict: impl Fn(usize) -> [i64; 3]) -> (u64, u64) {
    let (mut on, mut off) = (0u64, 0u64);
    let mut window = 0;
    for k in 2..g.len() {
        let p = predict(k);
        let d = [0, 1, 2].map(|a| g[k][a].wrapping_sub(p[a]));
        window = predict::step_window(g, k, window);
        on += lattice_bits(AlongStep::at(g, k, p, window).coded(d));
        off += lattice_bits(d);
    }
    (on, off)
}

/// The halved coordinates `(d − b)/2` of a lattice residual `d` of parity
/// `b`, as coded.
fn halves(d: [i64; 3]) -> [i64; 3] {
    let b = d[0] & 1;
    // `v − b` is even (a lattice residual's coordinates share a parity),
    // so the shift is the division.
    d.map(|v| v.wrapping_sub(b) >> 1)
}

/// Contexts of a points-mode residual: the size of the one before (a curve's
/// noise comes in stretches).
const RESIDUAL_CONTEXTS: usize = 4;

fn residual_context(d: [i64; 3]) -> usize {
    let m = d.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0) / 2;
    (64 - m.leading_zeros() as usize).min(RESIDUAL_CONTEXTS - 1)
}

/// Step pairs the screw prediction's rotation is fitted to (model 7): the
/// lattice's error in each step is up to `T` in steps of a few `T`, so one
/// pair's rotation is noisy; fitted to five (fewer near the start), the
/// hair at 0.1 mm codes 6 % smaller (three pairs: 4 %, eight: 5 %; curls
/// change pitch and radius along a strand, so longer is not better).
const HELIX_PAIRS: usize = 5;

/// How [`helix_prediction`] runs under a codec model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Screw {
    /// Step pairs its rotation is fitted to (0: model 6's rotation from the
    /// frames of the last two pairs).
    pairs: usize,
    /// Whether the step it turns is the mean of the last step and the one
    /// before it turned forward (model 9 on): each step carries the
    /// lattice's error of both its ends, and the two steps' errors are
    /// independent but for their shared point, while one rotation of a
    /// curl's few-degree change apart hardly separates them. Measured: the
    /// hair 1.1 % / 1.6 % smaller at 0.1 / 0.5 mm, no other shared file
    /// changed (a weight of 0.4 or 0.6 on the last step: within 0.2 % of
    /// the mean; three steps: 0.3 % larger at 0.1 mm, 0.05 % smaller at 0.5;
    /// polynomial extrapolation through the last 5–8 points, measured
    /// offline on the hair: 1.5–7× the screw's error).
    smooth: bool,
}

/// The screw prediction of codec `model`.
fn screw(model: u8) -> Screw {
    Screw {
        pairs: if model >= 7 { HELIX_PAIRS } else { 0 },
        smooth: model >= 9,
    }
}

/// How a points curve without a reference predicts its next point from
/// its own points before it ([`own_prediction`]); chosen per curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OwnPrediction {
    /// The last point plus the last step.
    SecondOrder,
    /// The screw continuation of the last steps ([`helix_prediction`]).
    Screw,
    /// From codec model 13: the last point plus the mean of the last
    /// [`MEAN_STEPS`] steps ([`mean_step_prediction`]).
    MeanStep,
}

/// Prediction of grid point `k ≥ 1` from the curve's own previous points:
/// second order (first order for the second point), or the screw
/// continuation of the last steps ([`helix_prediction`] as `screw` says),
/// or the mean step ([`mean_step_prediction`]), as `own` says.
/// (Inlined into the slide and the estimates, the screw's rotation fit
/// called out of line: the common predictions then cost no call.)
#[inline(always)]
fn own_prediction(g: &[[i64; 3]], k: usize, own: OwnPrediction, screw: Screw) -> [i64; 3] {
    if own == OwnPrediction::Screw && k >= 4 {
        if let Some(p) = helix_prediction(g, k, screw) {
            return p;
        }
    }
    if own == OwnPrediction::MeanStep && k >= 3 {
        if let Some(p) = mean_step_prediction(g, k) {
            return p;
        }
    }
    second_order(g, k)
}

/// The second-order prediction of grid point `k ≥ 1`: `2g[k−1] − g[k−2]`
/// (`g[0]` for the second point).
#[inline]
fn second_order(g: &[[i64; 3]], k: usize) -> [i64; 3] {
    second_order_of(k, [g[k.saturating_sub(2)], g[k - 1]])
}

/// [`second_order`] from `[g[k − 2], g[k − 1]]` (`g[0]` twice at `k = 1`).
#[inline]
fn second_order_of(k: usize, [before, last]: [[i64; 3]; 2]) -> [i64; 3] {
    if k >= 2 {
        [0, 1, 2].map(|a| last[a].wrapping_mul(2).wrapping_sub(before[a]))
    } else {
        last
    }
}

/// Steps a mean-step prediction averages ([`mean_step_prediction`]).
const MEAN_STEPS: usize = 4;

/// The lattice point nearest `g[k−1] + (g[k−1] − g[k−1−w]) / w`, the last
/// point plus the mean of the last `w = min(MEAN_STEPS, k − 1)` steps (in
/// `f64`, then [`quantise::bcc_nearest`]); `None` where not codable.
///
/// Where the input's noise is as large as the tolerance (tracked fibres
/// jittered by it), second order `2g[k−1] − g[k−2]` carries the noise of
/// two points twice over (a residual's variance six times a point's); the
/// mean step carries about two points' and lags a bend by a step and a
/// half, which the tolerance's scale hides. Measured (`benches/make_unseen.py`
/// heart fibres, all own-predicted at 0.1 mm): 0.1 mm of noise on a 1 mm
/// step 8.6 % smaller with the mean of 4 steps (2: 4.5 %, 3: 8.5 %, 6:
/// 7.5 %), 0.05 mm on 0.5 mm 7.1 % (6: 7.6 %). For every curve, not chosen,
/// it made 10,000 fornix replicas at 0.1 mm 1.8 % larger: hence a flag.
///
/// In integers where that is exact (`w` of 1, 2 or 4, coordinates under
/// 2⁵⁰: [`mean_step_exact`]): the slide asks it of every partial choice,
/// and in integers the encoder took 4.7 % fewer instructions on noisy heart
/// fibres at 0.1 mm.
#[inline]
fn mean_step_prediction(g: &[[i64; 3]], k: usize) -> Option<[i64; 3]> {
    let w = MEAN_STEPS.min(k - 1);
    if let Some(p) = mean_step_exact(g[k - 1], g[k - 1 - w], w) {
        return p;
    }
    mean_step_float(g, k, w)
}

/// [`mean_step_prediction`] through `f64` and [`quantise::bcc_nearest`]:
/// its definition (rarely asked: out of line).
#[inline(never)]
fn mean_step_float(g: &[[i64; 3]], k: usize, w: usize) -> Option<[i64; 3]> {
    let p = [0, 1, 2].map(|a| {
        let last = g[k - 1][a] as f64;
        last + (last - g[k - 1 - w][a] as f64) / w as f64
    });
    quantise::bcc_nearest(DVec3::from_array(p), 1.0)
}

/// [`mean_step_float`] in integers, the same answer wherever it gives one:
/// `None` where it cannot promise that (`w` other than 1, 2 or 4, whose
/// division `f64` rounds or which no shift divides by, or a coordinate of
/// 2⁵⁰ or more).
///
/// With `w ∈ {1, 2, 4}` and coordinates under 2⁵⁰, `f64` holds the point
/// `x = N / w` exactly (`N = w·last + last − back`; `|x|` under 1.5·2⁵⁰ in
/// quarters for `w = 4`, under 2⁵¹ in halves for 2, under 3·2⁵⁰ for 1), so
/// `bcc_nearest`'s roundings of `x / 2` are those of the fraction `N / 2w`
/// (half away from zero; down), and its squared distances, multiples of
/// `1/w²` under 16, are exact: compared times `w²` here, ties to the even
/// lattice as there.
#[inline]
fn mean_step_exact(last: [i64; 3], back: [i64; 3], w: usize) -> Option<Option<[i64; 3]>> {
    const EXACT: i64 = 1 << 50;
    // (Loops over the axes, not `map`s of arrays: one build left the
    // `map`s out of line, and the encoder took 6 % more instructions on
    // 3,000 noisy heart fibres at 0.1 mm; the slide asks this of every
    // partial choice.)
    let inside = |v: i64| -EXACT < v && v < EXACT;
    if !matches!(w, 1 | 2 | 4) || !(0..3).all(|a| inside(last[a]) && inside(back[a])) {
        return None;
    }
    let w = w as i64;
    // `bcc_nearest`'s bound: |x| < 2^MAX_BITS.
    let limit = (1i64 << entropy::MAX_BITS) * w;
    // With `N = 2w·q + m` (`0 ≤ m < 2w`; 2w a power of two: a shift and a
    // mask, the shift the floor), `x / 2 = q + m / 2w`: the odd lattice's
    // coordinate is `2q + 1`, `w` times it less `N` is `w − m`; the even
    // one's `2(q + e)`, rounded half away from zero (`e = 1` past the
    // half, and at it where `N ≥ 0`), `2w·e − m`.
    let shift = w.trailing_zeros() + 1;
    let mask = 2 * w - 1;
    let (mut even, mut odd) = ([0i64; 3], [0i64; 3]);
    let (mut d_even, mut d_odd) = (0i64, 0i64);
    let mut beyond = false;
    for a in 0..3 {
        let n = w * last[a] + (last[a] - back[a]);
        beyond |= n.abs() >= limit;
        let (q, m) = (n >> shift, n & mask);
        let e = ((m > w) | ((m == w) & (n >= 0))) as i64;
        even[a] = 2 * (q + e);
        odd[a] = 2 * q + 1;
        let (de, dd) = (2 * w * e - m, w - m);
        d_even += de * de;
        d_odd += dd * dd;
    }
    if beyond {
        return Some(None);
    }
    Some(Some(if d_even <= d_odd { even } else { odd }))
}

/// The last step `g[k−1] − g[k−2]` turned by the rotation that takes each
/// step to the next: on a helix sampled at equal arc lengths every step is
/// the one before it screwed by the same rotation, so this is exact there
/// (up to the lattice), where second-order prediction misses by the
/// curvature. Coarsely sampled curls (hair) are where it pays; the encoder
/// chooses per curve. With `pairs ≥ 2` (and `k ≥ 5`) the rotation is the
/// least-squares one over the last `min(pairs, k − 3)` step pairs
/// ([`predict::best_rotation`]), which averages the lattice's error, and
/// with [`Screw::smooth`] the step it turns is `(d_last + R·d_before) / 2`;
/// otherwise, or where that is undefined, the one that took the pair
/// `(d₀, d₁)` to `(d₁, d₂)` of the last three steps. `None` where the steps
/// are (nearly) collinear and the rotation is undefined.
#[inline(never)]
fn helix_prediction(g: &[[i64; 3]], k: usize, screw: Screw) -> Option<[i64; 3]> {
    let v = |i: usize| DVec3::new(g[i][0] as f64, g[i][1] as f64, g[i][2] as f64);
    if screw.pairs >= 2 && k >= 5 {
        let pairs = screw.pairs.min(k - 3).min(HELIX_PAIRS);
        let mut d = [DVec3::ZERO; HELIX_PAIRS + 1];
        for (j, dj) in d.iter_mut().take(pairs + 1).enumerate() {
            let i = k - pairs - 2 + j;
            *dj = v(i + 1) - v(i);
        }
        if let Some(r) = predict::best_rotation(&d[..pairs], &d[1..=pairs]) {
            let step = if screw.smooth {
                (d[pairs] + r * d[pairs - 1]) * 0.5
            } else {
                d[pairs]
            };
            return quantise::bcc_nearest(v(k - 1) + r * step, 1.0);
        }
    }
    let (d0, d1, d2) = (
        v(k - 3) - v(k - 4),
        v(k - 2) - v(k - 3),
        v(k - 1) - v(k - 2),
    );
    let frame = |a: DVec3, b: DVec3| -> Option<glam::DMat3> {
        let n = a.cross(b);
        let (la, ln) = (a.length(), n.length());
        if !(ln > 1e-6 * la * b.length() && la > 0.0) {
            return None;
        }
        let e1 = a / la;
        let e3 = n / ln;
        Some(glam::DMat3::from_cols(e1, e3.cross(e1), e3))
    };
    let (f0, f1) = (frame(d0, d1)?, frame(d1, d2)?);
    let p = v(k - 1) + f1 * (f0.transpose() * d2);
    quantise::bcc_nearest(p, 1.0)
}

/// Partial choices the slide keeps from vertex to vertex
/// ([`quantise::cheapest_points`]). Measured (2 cores, hair at 0.1 mm /
/// fornix replicas at 0.1 mm): greedy 155,100 B in 0.58 s / 990 kB in
/// 1.9 s; 2: 148,080 B in 0.78 s / 954 kB in 2.5 s; 4: 144,490 B in 1.17 s
/// / 930 kB in 3.7 s; 8: 143,042 B in 1.8 s.
const SLIDE_BEAM: usize = 2;

/// The slide's partial choices in a block of fewer than
/// [`SMALL_BLOCK_POINTS`] points, whose time is a fraction of a second
/// at most: there the bytes are worth the wider search. Measured against
/// [`SLIDE_BEAM`] (session 51, model 16, `examples/codec_probe`): the
/// resampled bundles AF_L, CST_R and CC 1.1–3.1 % smaller at 0.1 / 0.5 mm,
/// bundles of 50 tracked streamlines resampled to 20 points 3–5 %, the
/// EuDX and fornix files (arcs) the same; 4 gave about half of that.
const SMALL_BLOCK_SLIDE_BEAM: usize = 8;

/// The most, in tolerances, that the slide moves a vertex on
/// ([`quantise::Search::reach`]). Measured at 16, 3, 2.5 and 2 (session
/// 52, `examples/codec_probe` over the shared data at both tolerances,
/// 10,000 fornix replicas, the files of `benches/make_unseen.py` and
/// `benches/resample_bundles.py`): 3 against 16 took 10 % fewer
/// instructions on the replicas at 0.1 mm (0.86 mm steps) for the same
/// bytes (+0.04 %), made the hair 0.8 % smaller and the bundles of 20
/// points 0.2–1.7 % at 0.1 mm; 2 took 18 % fewer for 0.8 % more on the
/// replicas and up to 2.4 % on the bundles of 20 points at 0.5 mm. Session
/// 55, large blocks only (whole processes, 2 cores; 100,000 fornix
/// replicas and `make_unseen.py --heart 30000 --dipole 20000 --bundles
/// 30000`): against 3, 2.5 / 2 / 1.5 cost the replicas at 0.1 mm 0.2 /
/// 0.7 / 1.7 % more bytes for 7 / 13 / 21 % less CPU, the noisy heart
/// fibres 0.3 / 1.0 / 2.4 % (2: 9 % less CPU); every other set, the hair
/// and the field lines at both tolerances the same within 0.1 % (their
/// steps reach less). The replicas at 0.1 mm are where `compress` is
/// slower than DIPY: 2 was the knee. Session 56, against 2 (single-thread
/// CPU on the 100,000 replicas at 0.1 mm, least of 6 runs alternated):
/// 1.75 / 1.5 took 5 % / 8 % less CPU for 0.42 % / 1.03 % more bytes there
/// and 0.58 % / 1.30 % on the 30,000 heart fibres; every other set the
/// same within 0.1 %. The chosen points of the replicas lie all along the
/// reach (as many from 1.5 to 2 tolerances on as from 0.5 to 1), so the
/// bytes are the reach's; centring the reach on the prediction's place
/// along the curve instead was 2.4 % larger at the same length.
/// `compress` was still slower than DIPY on the replicas at 2, and at 1.5
/// no set comes within 5 % of issue 19's goal (2/3 of the best
/// baseline's bytes): 1.5.
const SLIDE_REACH_TOLERANCES: f64 = 1.5;

/// The slide's reach in a small block (as [`SMALL_BLOCK_SLIDE_BEAM`]):
/// there 2 cost the bundles of 20 points up to 2.4 % at 0.5 mm (session
/// 52), and the time is a fraction of a second.
const SMALL_BLOCK_SLIDE_REACH_TOLERANCES: f64 = 3.0;

/// Blocks of fewer points than this slide with [`SMALL_BLOCK_SLIDE_BEAM`]
/// and [`SMALL_BLOCK_SLIDE_REACH_TOLERANCES`] (at most about 0.1 s of
/// compress on 2 cores); a large file's blocks of 4,096 curves are over it
/// unless its curves are of a few points.
const SMALL_BLOCK_POINTS: usize = 32_768;

/// What a block has counted of an option its curves may try (a second
/// slide, an estimate): curves seen, curves that tried it, and how often it
/// won. The votes below ask every curve to try it for a first stretch and
/// every [`Tally::EVERY`]th curve after, so that a block whose curves
/// change kind midway finds it again.
#[derive(Default)]
struct Tally {
    seen: usize,
    tried: usize,
    won: usize,
}

impl Tally {
    /// Measured at 16, 32 and 64 (session 52, with every vote on it):
    /// 10,000 fornix replicas at 0.1 mm 3.9 % and 5.7 % fewer instructions
    /// than at 16 for 0.05 % and 0.08 % more bytes; the shared data and
    /// the unseen files of `benches/` the same bytes (±0.01 %).
    const EVERY: usize = 64;

    /// Whether the next curve (counted as seen) must try the option: one of
    /// the first `trials`, or an [`Tally::EVERY`]th.
    fn must_try(&mut self, trials: usize) -> bool {
        let seen = self.seen;
        self.seen += 1;
        seen < trials || seen.is_multiple_of(Self::EVERY)
    }

    /// A curve tried it, and it won or not.
    fn count(&mut self, won: bool) {
        self.tried += 1;
        self.won += won as usize;
    }
}

/// Which own prediction a block's mean-step curves are slid for
/// ([`slid_points`]): where the mean step is a points curve's cheapest own
/// prediction by the rounded points, the slide ran for it and for second
/// order and kept the cheaper, which is right most of the time for one of
/// them in a given block (noisy fibres: the mean step; smoother ones:
/// second order). The block slides both for its first
/// [`TRIALS`](Self::TRIALS) such curves and every [`Tally::EVERY`]th
/// after, counting which won (the mean step's wins in its [`Tally`]); the
/// others are slid only for a kind that won at least
/// [`SHARE`](Self::SHARE) of the counted ones (both while neither has).
/// Measured: 2,000 fornix replicas at 0.1 mm 11 % fewer instructions for
/// 0.1 % more bytes; 3,000 noisy heart fibres (`benches/make_unseen.py`)
/// 35 % fewer, 42 B fewer. With the slide's beam and reach for the block
/// ([`SLIDE_BEAM`] and [`SLIDE_REACH_TOLERANCES`], or
/// [`SMALL_BLOCK_SLIDE_BEAM`] and [`SMALL_BLOCK_SLIDE_REACH_TOLERANCES`] in
/// a small block).
struct SlideVote {
    tally: Tally,
    search: quantise::Search,
}

impl Default for SlideVote {
    fn default() -> Self {
        SlideVote {
            tally: Tally::default(),
            search: quantise::Search {
                beam: SLIDE_BEAM,
                reach: SLIDE_REACH_TOLERANCES,
            },
        }
    }
}

impl SlideVote {
    const TRIALS: usize = 32;
    const SHARE: f64 = 0.9;

    /// The kinds to slide for the block's next mean-step curve.
    fn kinds(&mut self) -> &'static [OwnPrediction] {
        const BOTH: &[OwnPrediction] = &[OwnPrediction::SecondOrder, OwnPrediction::MeanStep];
        if self.tally.must_try(Self::TRIALS) {
            return BOTH;
        }
        let share = self.tally.won as f64 / self.tally.tried.max(1) as f64;
        if share >= Self::SHARE {
            &[OwnPrediction::MeanStep]
        } else if 1.0 - share >= Self::SHARE {
            &[OwnPrediction::SecondOrder]
        } else {
            BOTH
        }
    }

    /// Both kinds were slid and `kind` won.
    fn count(&mut self, kind: OwnPrediction) {
        self.tally.count(kind == OwnPrediction::MeanStep);
    }
}

/// Whether a block still tries, for its next points curve, an option that
/// costs time and rarely wins on some data: where it has won under
/// [`SHARE`](Self::SHARE) of its trials (the first [`TRIALS`](Self::TRIALS)
/// curves and every [`Tally::EVERY`]th after), only the trials try it, so
/// that a block whose curves change kind midway finds it again. The screw
/// prediction (a rotation fitted at every point, [`helix_prediction`]) is
/// so voted on. It wins most curves of curly hair (1,360 of the 2,000
/// strands at 0.1 mm; without it the hair is 25 % larger) and few fibres.
///
/// A trial counts as won only where the screw is the cheapest own
/// prediction of the rounded points *and* its points slid are estimated
/// under those of the best other own prediction slid (both are slid; the
/// cheaper is kept, the other on a tie: it decodes faster), and only where
/// the curve goes as points by its own prediction and no reference was the
/// cheaper of the rounded points (a [`ReferenceVote`] trial's own
/// alternative is not counted). Until session 53 the rounded points alone
/// decided: the screw won over a tenth of the trials of 3,000 noisy heart
/// fibres (`benches/make_unseen.py`) at 0.1 mm and was estimated for every
/// curve (a sixth of the encoder's instructions), yet without it their
/// container was 0.4 % smaller: the slide takes the noise out that the
/// screw's rotations fit. Judged slid, those fibres took 15.5 % fewer
/// instructions for 0.37 % fewer bytes (30,000 of them 10–20 % less time),
/// the hair and the field lines the same bytes (±7 B), the hair 1.2 % more
/// instructions (its trials slid twice). (The search for a reference was
/// voted on so until session 52: [`ReferenceVote`]. It won 62 of 3,000
/// noisy heart fibres, 11 of the hair's 2,000 strands and 1 of 5,800 field
/// lines, where it was a tenth of the instructions.)
#[derive(Default)]
struct RareVote(Tally);

impl RareVote {
    /// The first curves always try it.
    const TRIALS: usize = 64;
    /// The share of wins under which the block stops trying it.
    const SHARE: f64 = 0.1;

    /// Whether the block's next points curve tries it, and if so whether
    /// as a trial (whose outcome the block counts).
    fn tries(&mut self) -> Option<bool> {
        let trial = self.0.must_try(Self::TRIALS);
        (trial || self.0.won as f64 >= Self::SHARE * self.0.tried as f64).then_some(trial)
    }

    /// A trial's outcome: it won or not.
    fn count(&mut self, won: bool) {
        self.0.count(won);
    }
}

/// Whether a block searches, for its next points curve, a reference among
/// the curves before it ([`reference::best_reference`]), by what the search
/// saved slid: its trials (the first [`TRIALS`](Self::TRIALS) curves and
/// every [`Tally::EVERY`]th after) slide both the reference's points and
/// their own prediction's where the reference is estimated the cheaper of
/// the rounded points (and keep the cheaper slid), and the block goes on
/// searching for the others only while the trials' slid points were
/// estimated at least [`SHARE`](Self::SHARE) smaller for it.
///
/// A share of wins, as [`RareVote`] counts them, did not tell where the
/// search pays: 10,000 fornix replicas at 0.1 mm won 81 % of their trials,
/// slid, for 2.5–4.0 % of the trials' bits (the search a sixth of the
/// encoder's instructions for 0.7 % of the bytes); 3,000 tracked
/// streamlines resampled to 20 points 6.6 % / 8.5 % at 0.1 / 0.5 mm (the
/// search a quarter of the instructions for 2.2 % / 2.1 %); the resampled
/// bundles of the shared data 32–38 %; the other files measured (hair,
/// heart fibres, tracker's streamlines) under 1 %. At a
/// [`SHARE`](Self::SHARE) of 0.1 the 20-point streamlines went without
/// it.
#[derive(Default)]
struct ReferenceVote {
    tally: Tally,
    /// The trials' slid estimates without a reference (what their points,
    /// or the arcs they went to, would have cost without the search), and
    /// what the references saved of them.
    bits: u64,
    saved: u64,
}

impl ReferenceVote {
    const TRIALS: usize = 64;
    /// Measured at 0.1 and 0.05: the same bytes on every file but the
    /// 20-point streamlines above.
    const SHARE: f64 = 0.05;

    /// Whether the block's next points curve searches, and if so whether as
    /// a trial. (Nothing counted, not searched but for the trials.)
    fn searches(&mut self) -> Option<bool> {
        let trial = self.tally.must_try(Self::TRIALS);
        let pays = self.bits > 0 && self.saved as f64 >= Self::SHARE * self.bits as f64;
        (trial || pays).then_some(trial)
    }

    /// A trial's points, estimated at `bits` slid, were `saved` smaller for
    /// the reference.
    fn count(&mut self, bits: u64, saved: u64) {
        self.bits += bits + saved;
        self.saved += saved;
    }
}

/// [`slid_points`]' result: the points, the along-step flag, the own
/// prediction's kind, the predictions of the points where they were
/// slid ([`quantise::cheapest_points`]), and the points' estimated bits
/// (start included) as so coded.
type SlidCurve = (
    Vec<[i64; 3]>,
    bool,
    OwnPrediction,
    Option<Vec<[i64; 3]>>,
    u64,
);

/// A points curve's lattice points `g` (rounded, estimated at `bits`)
/// slid along the curve to where they are cheapest against the chosen
/// prediction ([`quantise::cheapest_points`]), where that is estimated
/// cheaper than `bits` (of which `own_start_bits` is the start's, without a
/// reference; `second_order_bits` the rounded points' estimate with
/// second order, start included); `neighbours` does not hold the curve
/// yet.
#[allow(clippy::too_many_arguments)]
fn slid_points(
    points: &[DVec3],
    g: Vec<[i64; 3]>,
    reference: Option<reference::Reference>,
    reference_predicted: &[[i64; 3]],
    own_kind: OwnPrediction,
    bits: u64,
    own_start_bits: u64,
    second_order_bits: u64,
    tolerance: f64,
    half: f64,
    screw: Screw,
    rule: Rule,
    along: bool,
    mean_step: bool,
    vote: &mut SlideVote,
    neighbours: &mut Neighbours,
) -> SlidCurve {
    let tol = encoder::acceptance_tolerance(tolerance, points);
    // With `along` (model 10) the curve's flag: whether the rounded points
    // are estimated at least 5 % cheaper with the along-step prediction
    // (`bits` then becomes their estimate as so coded). The slide gains
    // less with it on noisy fibres than the rounded points' estimate says:
    // measured at margins of 0, 2, 3, 5, 10 and 20 % (shared data at both
    // tolerances, 10,000 fornix replicas at 0.1 mm), 5 % kept the resampled
    // bundles' gain (7–9 % at 0.1 mm) and most of the hair's, and made the
    // replicas 0.7 % smaller where no margin made them 0.2 % larger.
    // (A generic function, not a closure taking `&dyn Fn`: the prediction
    // inlined into each instance of `along_bits`.)
    fn flag(
        along: bool,
        g: &[[i64; 3]],
        predict: impl Fn(usize) -> [i64; 3],
        bits: u64,
    ) -> (bool, u64) {
        if !along {
            return (false, bits);
        }
        let (on, off) = along_bits(g, predict);
        if on.saturating_mul(21) < off.saturating_mul(20) {
            (true, bits - off + on)
        } else {
            (false, bits)
        }
    }
    // The slide against `predict`, kept where its residuals are estimated
    // under `limit` (the rounded points' residuals). The start stays: the
    // residuals' estimates decide.
    //
    // (A macro, not a closure taking `&dyn Fn`: each prediction is its
    // own instance of the slide, the prediction inlined into it; through
    // the `dyn` call the encoder took 0.6 % more instructions on 10,000
    // fornix replicas at 0.1 mm.)
    let search = vote.search;
    macro_rules! slide {
        ($predict:expr, $flag:expr, $limit:expr) => {{
            let limit: u64 = $limit;
            quantise::cheapest_points(
                points,
                half,
                tol * tol,
                g[0],
                search,
                $predict,
                smooth_lattice_bits(),
                lattice_bits,
                $flag,
                // The rounded points are the nearest lattice points
                // (`CurveEncoder::points_code`, the same lattice and test).
                Some(&g),
            )
            .filter(|(_, residuals, _)| *residuals < limit)
        }};
    }
    let (slid, flag, start_bits, rounded) = match reference {
        // Where the mean step (model 13) is the rounded points' cheapest
        // prediction: it and second order each slid, and the one whose slid
        // points are estimated cheaper kept. The rounded points' estimates
        // alone do not tell them apart: the slide smooths what second order
        // predicts from, the more so the noisier the curve (chosen by the
        // rounded points, 10,000 fornix replicas at 0.1 mm were 1.3 %
        // larger, 0.6 % with a 5 % margin; slid, 1.2 % smaller, at 12 % more
        // instructions; sliding both for every curve: 18 %, same bytes).
        None if mean_step && own_kind == OwnPrediction::MeanStep => {
            type Kept = (
                u64,
                Vec<[i64; 3]>,
                bool,
                OwnPrediction,
                Option<Vec<[i64; 3]>>,
            );
            let mut best: Option<Kept> = None;
            let kinds = vote.kinds();
            for &kind in kinds {
                let predict = |k| own_prediction(&g, k, kind, screw);
                // The rounded points' estimates without the start, as the
                // caller summed them (`bits` is the mean step's).
                let rounded = match kind {
                    OwnPrediction::SecondOrder => second_order_bits,
                    _ => bits,
                } - own_start_bits;
                let (flag, rounded) = flag(along, &g, predict, rounded);
                let own = |g: &[[i64; 3]], k| own_prediction(g, k, kind, screw);
                let (grid, bits, predicted) = match slide!(own, flag, rounded) {
                    Some((grid, bits, predicted)) => (grid, bits, Some(predicted)),
                    None => (g.clone(), rounded, None),
                };
                if best.as_ref().is_none_or(|b| bits < b.0) {
                    best = Some((bits, grid, flag, kind, predicted));
                }
            }
            let (bits, grid, flag, kind, predicted) = best.expect("a kind was tried");
            if kinds.len() == 2 {
                vote.count(kind);
            }
            return (grid, flag, kind, predicted, own_start_bits + bits);
        }
        None => {
            let (flag, bits) = flag(along, &g, |k| own_prediction(&g, k, own_kind, screw), bits);
            let own = |g: &[[i64; 3]], k| own_prediction(g, k, own_kind, screw);
            let rounded = bits - own_start_bits;
            (slide!(own, flag, rounded), flag, own_start_bits, rounded)
        }
        Some(rf) => {
            let res = rf.resolve(neighbours.window(), rule);
            let n = g.len();
            // The estimate's part before the residuals (a one-point curve's).
            let start_bits = reference::reference_bits(&g[..1], &res, lattice_bits);
            let foot = reference::PredictionCache::default();
            // The search's predictions of these points where it kept them
            // all (the same values: a prediction depends on the points
            // before it only).
            let (flag, bits) = if reference_predicted.len() == n {
                flag(along, &g, |k| reference_predicted[k], bits)
            } else {
                flag(along, &g, |k| res.predict_next(&g, k, n, &foot), bits)
            };
            let predict = |g: &[[i64; 3]], k| res.predict_next(g, k, n, &foot);
            let rounded = bits - start_bits;
            (slide!(predict, flag, rounded), flag, start_bits, rounded)
        }
    };
    match slid {
        Some((grid, residuals, predicted)) => (
            grid,
            flag,
            own_kind,
            Some(predicted),
            start_bits + residuals,
        ),
        None => (g, flag, own_kind, None, start_bits + rounded),
    }
}

/// A curve's points as [`choose`] weighs them against its arcs: the rounded
/// points, their prediction and estimate, and what the votes' trials slide
/// besides.
struct PointsChoice {
    grid: Vec<[i64; 3]>,
    /// The neighbour predicting them, or `None` (their own prediction).
    reference: Option<reference::Reference>,
    /// Their own prediction (second order where a reference predicts).
    own: OwnPrediction,
    /// Their estimate (bits), the start's included.
    bits: u64,
    /// The start's part of `bits`.
    start_bits: u64,
    /// Their second-order estimate (bits).
    second_order_bits: u64,
    /// A [`ReferenceVote`] trial.
    trial: bool,
    /// At such a trial won by a reference: the own prediction (kind,
    /// estimate, start's bits) to slide as well.
    own_trial: Option<(OwnPrediction, u64, u64)>,
    /// A [`RareVote`] trial of the screw: `Some(None)` where the screw was
    /// not the cheapest own prediction, `Some(Some((kind, estimate)))` where
    /// it was, with the best other own prediction to slide as well; `None`
    /// where it is no trial or a reference was the cheaper of the rounded
    /// points.
    screw_trial: Option<Option<(OwnPrediction, u64)>>,
}

/// [`choose`]'s result: the code, its decoded point count, its estimate and
/// what the arcs saved, and for a slid points curve the predictions its
/// residuals are from ([`quantise::cheapest_points`]).
type Chosen = (CurveCode, usize, u64, u64, Option<Vec<[i64; 3]>>);

/// Chooses one curve's code given the block so far: arcs, or points with
/// their own or a neighbour's prediction, whichever is estimated cheaper
/// (with `explore_points`, points also where arcs are estimated at least
/// [`Calibration::EXPLORE`] of them; such a call gone to arcs is counted
/// in `close_calls` where given);
/// returns the code and its decoded point count, and adds the decoded curve
/// to the `neighbours` of the curves after it.
#[allow(clippy::too_many_arguments)]
fn choose(
    points: &[DVec3],
    opt: CurveOptions,
    tolerance: f64,
    half: f64,
    screw: Screw,
    rule: Rule,
    along: bool,
    neighbours: &mut Neighbours,
    prev: &Previous,
    arcs_scale: f64,
    explore_points: bool,
    mean_step: bool,
    vote: &mut SlideVote,
    screw_vote: &mut RareVote,
    reference_vote: &mut ReferenceVote,
    close_calls: Option<&mut usize>,
) -> Chosen {
    if points.is_empty() {
        neighbours.push_empty();
        return (CurveCode::Empty, 0, 0, 0, None);
    }
    // The arcs' estimate, scaled by what arcs have really cost against
    // points so far in the block ([`Calibration`]).
    let arc_estimate = opt.arcs.as_ref().map(|(a, _)| estimated_bits(a));
    let arc_bits = arc_estimate.map(|e| (e as f64 * arcs_scale).round() as u64);
    // The chosen reference's predictions of the rounded points, for the
    // slide's along-step flag (a pass over the curve the search made).
    let mut predicted = Vec::new();
    let pts = opt.points.map(|g| {
        let own_start = lattice_bits([0, 1, 2].map(|a| g[0][a].wrapping_sub(prev.point_start[a])));
        // The own prediction's estimate, summed until it passes `bound`
        // (then some value above it).
        let own_with = |kind: OwnPrediction, bound: u64| {
            let mut bits = own_start;
            for k in 1..g.len() {
                if bits > bound {
                    break;
                }
                let p = own_prediction(&g, k, kind, screw);
                bits += lattice_bits([0, 1, 2].map(|a| g[k][a].wrapping_sub(p[a])));
            }
            bits
        };
        // The screw prediction (a rotation fitted per point) is summed only
        // while it can still decide something: it is kept only under the
        // second-order one and under the arcs' estimate (above that the
        // arcs win, unless a neighbour does, which is searched under the
        // arcs' estimate whatever the screw costs). Stopped early, it is
        // not kept, and the second-order estimate stands: the choice is the
        // one the whole sums make, but that the neighbours are not searched
        // where the second-order estimate alone is over twice the arcs'.
        // (Bounded at twice the arcs' estimate instead: the same bytes on
        // every shared file and 10,000 fornix replicas with and without
        // jitter, 6 % more CPU on the unjittered ones at 0.1 mm.)
        let linear = own_with(OwnPrediction::SecondOrder, u64::MAX);
        let bound = linear.saturating_sub(1).min(arc_bits.unwrap_or(u64::MAX));
        let tries = screw_vote.tries();
        let screw_bits = if tries.is_some() {
            own_with(OwnPrediction::Screw, bound)
        } else {
            u64::MAX
        };
        let (mut own_kind, mut own) = if screw_bits > bound {
            (OwnPrediction::SecondOrder, linear)
        } else if screw_bits < linear {
            (OwnPrediction::Screw, screw_bits)
        } else {
            (OwnPrediction::SecondOrder, linear)
        };
        // The mean step likewise, under the better of the two (model 13).
        if mean_step {
            let bound = own.saturating_sub(1).min(arc_bits.unwrap_or(u64::MAX));
            let mean = own_with(OwnPrediction::MeanStep, bound);
            if mean <= bound {
                (own_kind, own) = (OwnPrediction::MeanStep, mean);
            }
        }
        // A screw trial: where the screw is the cheapest own prediction of
        // the rounded points, the best of the others (and its estimate) to
        // slide as well ([`RareVote`]'s note on the screw).
        let screw_trial = (tries == Some(true)).then(|| {
            (own_kind == OwnPrediction::Screw).then(|| {
                let mean = if mean_step {
                    own_with(OwnPrediction::MeanStep, u64::MAX)
                } else {
                    u64::MAX
                };
                if mean < linear {
                    (OwnPrediction::MeanStep, mean)
                } else {
                    (OwnPrediction::SecondOrder, linear)
                }
            })
        });
        // The points by their own prediction.
        let own_choice = |grid, trial| PointsChoice {
            grid,
            reference: None,
            own: own_kind,
            bits: own,
            start_bits: own_start,
            second_order_bits: linear,
            trial,
            own_trial: None,
            screw_trial,
        };
        // A neighbour saves at most about a third on bundles: where arcs
        // cost under half the own prediction, it is not looked for.
        let arcs_far_cheaper = arc_bits.is_some_and(|a| 2 * a < own);
        if arcs_far_cheaper {
            return own_choice(g, false);
        }
        // A reference is used only under the own prediction and the arcs,
        // and costed only that far ([`reference::best_reference`]):
        // measured on 100,000 unjittered fornix replicas at 0.1 mm, 8 % less
        // CPU, the same bytes; 260 bytes fewer over the shared data and
        // 10,000 jittered replicas (a bundle's file ±3 bytes: the pairs are
        // tried among singles ranked by partial sums past the limit).
        // (Voted on only where a reference can be found: a curve of two
        // points or more after another in the block.)
        let trial = if g.len() < 2 || neighbours.is_empty() {
            None
        } else {
            reference_vote.searches()
        };
        let Some(trial) = trial else {
            return own_choice(g, false);
        };
        let limit = arc_bits.map_or(own, |a| a.min(own));
        let found = reference::best_reference(
            &g,
            neighbours.window(),
            rule,
            lattice_bits,
            limit,
            &mut predicted,
        );
        let won = found.is_some_and(|(_, bits)| bits < limit);
        match found {
            // A trial's own prediction is slid too, and the vote is on
            // which is cheaper slid.
            // (Where the own prediction's points cost more than the arcs,
            // not: kept, they would be coded where the arcs are cheaper,
            // and the trial is not counted.)
            Some((rf, bits)) if won => {
                let own = (trial && arc_bits.is_none_or(|a| own <= a))
                    .then_some((own_kind, own, own_start));
                PointsChoice {
                    grid: g,
                    reference: Some(rf),
                    own: OwnPrediction::SecondOrder,
                    bits,
                    start_bits: 0,
                    second_order_bits: linear,
                    trial,
                    own_trial: own,
                    screw_trial: None,
                }
            }
            _ => own_choice(g, trial),
        }
    });
    match (opt.arcs, pts) {
        (Some((a, decoded)), Some(PointsChoice { bits, trial, .. }))
            if arc_bits.is_some_and(|e| {
                e < bits && !(explore_points && Calibration::close_call(e, bits))
            }) =>
        {
            // A trial gone to arcs: the search saved nothing (a reference
            // cheaper than the points is cheaper than the arcs).
            if trial {
                reference_vote.count(arc_bits.unwrap_or(0), 0);
            }
            let n = decoded.len();
            neighbours.push_points(decoded);
            neighbours.set_chords(arc_chords(&a));
            let e = arc_bits.unwrap_or(0);
            // A call an exploring block would have sent to points.
            if let Some(c) = close_calls {
                *c += Calibration::close_call(e, bits) as usize;
            }
            (a, n, arc_estimate.unwrap_or(0), bits - e, None)
        }
        (
            _,
            Some(PointsChoice {
                grid: g,
                reference,
                own,
                bits,
                start_bits,
                second_order_bits,
                trial,
                own_trial,
                screw_trial,
            }),
        ) => {
            // Arcs and points are weighed by the rounded points' estimate:
            // the slid points' is optimistic (they were chosen by the same
            // static cost; weighed by it, the fornix at 0.1 mm went from 2
            // to 19 points curves and grew 0.7 %).
            let mut slide = |g, reference, predicted: &[[i64; 3]], kind, bits, start_bits| {
                slid_points(
                    points,
                    g,
                    reference,
                    predicted,
                    kind,
                    bits,
                    start_bits,
                    second_order_bits,
                    tolerance,
                    half,
                    screw,
                    rule,
                    along,
                    mean_step,
                    vote,
                    neighbours,
                )
            };
            // A reference vote's trial (the reference the cheaper of the
            // rounded points): the own prediction's points slid as well,
            // the cheaper slid kept, and the vote told what the reference
            // saved ([`ReferenceVote`]). (That slide is counted in the
            // block's `SlideVote` as any own prediction's is: it measures
            // which own kind slides cheaper either way.)
            let own_alternative = own_trial.map(|(kind, bits, start_bits)| {
                slide(g.clone(), None, &[], kind, bits, start_bits)
            });
            // A screw trial coded by its own prediction: the best other
            // own prediction slid as well, the cheaper slid kept (the other
            // on a tie), and the screw counted as won only where it slid
            // cheaper. (A mean-step alternative counts in the block's
            // `SlideVote` as any own prediction's slide does. A screw trial
            // is only ever an own prediction's: no reference, no reference
            // trial.)
            let screw_alternative = match screw_trial {
                Some(Some((kind, alt_bits))) => Some((
                    alt_bits,
                    slide(g.clone(), None, &[], kind, alt_bits, start_bits),
                )),
                _ => None,
            };
            let slid = slide(g, reference, &predicted, own, bits, start_bits);
            let (reference, bits, (g, along, own, predicted, slid_bits)) =
                match own_alternative.zip(own_trial) {
                    Some((alt, (_, own_bits, _))) if slid.4 >= alt.4 => (None, own_bits, alt),
                    Some((alt, _)) => {
                        reference_vote.count(slid.4, alt.4 - slid.4);
                        (reference, bits, slid)
                    }
                    None => match screw_alternative {
                        Some((alt_bits, alt)) => {
                            screw_vote.count(slid.4 < alt.4);
                            if alt.4 <= slid.4 {
                                (reference, alt_bits, alt)
                            } else {
                                (reference, bits, slid)
                            }
                        }
                        None => {
                            if screw_trial == Some(None) {
                                screw_vote.count(false);
                            }
                            (reference, bits, slid)
                        }
                    },
                };
            if trial && reference.is_none() {
                reference_vote.count(slid_bits, 0);
            }
            let n = g.len();
            neighbours.push_lattice(g.clone());
            (
                CurveCode::Points {
                    grid: g,
                    reference,
                    own,
                    along,
                },
                n,
                bits,
                0,
                predicted,
            )
        }
        (Some((a, decoded)), None) => {
            // Points impossible: the arcs save all (as far as worth goes).
            let n = decoded.len();
            neighbours.push_points(decoded);
            neighbours.set_chords(arc_chords(&a));
            let e = arc_estimate.unwrap_or(0);
            (a, n, e, e, None)
        }
        (None, None) => {
            neighbours.push_points(points.to_vec());
            (CurveCode::Raw(points.to_vec()), points.len(), 0, 0, None)
        }
    }
}

/// What the arcs search has been worth in a block so far: the points'
/// estimated bits it saved (where arcs were chosen) against the estimated
/// bits of the curves it ran for. Where it saves under
/// [`ArcsWorth::SHARE`] of them, the next chunk searches only every
/// [`ArcsWorth::SAMPLE`]th curve's arcs (the rest go as points) and keeps
/// measuring on those, unless the last chunk's sample saved at least
/// [`ArcsWorth::TURN`] of its own; a block's first chunk always searches
/// all.
///
/// On noisy fibres at fine tolerances points win almost everywhere, and the
/// search was a quarter of `compress` for arcs that, once coded, were no
/// cheaper than points (10,000 fornix replicas at 0.1 mm: 36 curves as
/// arcs, 341,801 B; with no arcs at all 341,279 B in three quarters of the
/// time). Smooth curves (hair, field lines, bundles at 0.5 mm) save far
/// more than the share and are searched in full.
///
/// The estimated share overstates what arcs save once coded (the points are
/// slid and cost less than their rounded estimate): the noisy heart fibres
/// of `benches/make_unseen.py --heart 30000 --seed 7` at 0.1 mm estimate
/// 1.1–1.4 % per block and save 0.09 % coded (1,851,253 B against
/// 1,852,843 B sampled at a share of 0.03), the hair at 0.1 mm estimates
/// 13 % and saves 6 %. Measured per block over the shared data at both
/// tolerances, the files of `benches/make_unseen.py`,
/// `benches/resample_bundles.py` and 10,000 fornix replicas: every share
/// under 0.015 or over 0.066. At 0.005 (until session 54) the heart fibres
/// were searched in full: 4.0 s to compress against 1.9 s at 0.03 (2 cores,
/// alternated runs), the same bytes elsewhere but 17 B on 3,000 of them.
#[derive(Default)]
struct ArcsWorth {
    saved: f64,
    total: f64,
    /// `(total, saved)` of the chunk being coded, and of the one before it.
    chunk: (f64, f64),
    last: (f64, f64),
}

impl ArcsWorth {
    /// Below this share of the estimated bits, the search is sampled.
    const SHARE: f64 = 0.03;
    /// One curve in this many is searched while sampled. Measured against
    /// 16 (session 55): the same bytes within 14 B on every set, 2 % less
    /// time on the replicas at 0.1 mm.
    const SAMPLE: usize = 32;
    /// The share of the last chunk's searched estimates that turns the
    /// full search back on whatever the block's share: in a block whose
    /// curves turn smooth midway, a chunk's sample of them saves too little
    /// against the block's noisy total (at a [`SAMPLE`](Self::SAMPLE) of
    /// 32, 8 smooth curves against the 88 noisy ones searched of 832:
    /// `the_arcs_search_is_sampled_where_it_saves_nothing_and_resumes_where_it_does`).
    /// Eight times the block's share: at four, the samples of 3,000 noisy
    /// heart fibres (`benches/make_unseen.py`, 0.1 mm), whose arcs win now
    /// and then, passed it often enough that full searches took 11 % more
    /// cycles, for 99 B (0.05 %); at eight, as without it. A sample that
    /// saves between the two waits for the block's share (8 curves a
    /// chunk).
    /// Measured with `SAMPLE` (session 56): the bytes within 21 B of
    /// session 55's on every set, 1.5–1.8 % fewer cycles on the replicas
    /// and the heart fibres at 0.1 mm.
    const TURN: f64 = 8.0 * Self::SHARE;

    /// A curve whose arcs were searched was estimated at `estimate` bits
    /// as coded, and the arcs saved `saving` of the points' estimate.
    fn add(&mut self, estimate: u64, saving: u64) {
        let (total, saved) = ((estimate + saving) as f64, saving as f64);
        self.total += total;
        self.saved += saved;
        self.chunk.0 += total;
        self.chunk.1 += saved;
    }

    /// The chunk being coded ends.
    fn end_chunk(&mut self) {
        self.last = std::mem::take(&mut self.chunk);
    }

    /// Whether any curve's arcs have been searched and counted.
    fn measured(&self) -> bool {
        self.total > 0.0
    }

    /// Whether the next chunk searches every curve's arcs.
    fn pays(&self) -> bool {
        let (last_total, last_saved) = self.last;
        self.total == 0.0
            || self.saved >= Self::SHARE * self.total
            || (last_total > 0.0 && last_saved >= Self::TURN * last_total)
    }
}

/// What arcs and points curves have really cost in a block so far against
/// their static estimates. Those estimates decide between the two
/// ([`choose`]), but the adaptive coder does not pay them alike: on noisy
/// fibres (the fornix replicas at 0.1 mm) arcs cost about a third more
/// than estimated next to points, and the block came out 11 % larger than
/// with no arcs at all. The arcs' estimate is scaled by the ratio of the
/// two (from even odds: `PRIOR` bits of each at their estimate).
#[derive(Default)]
struct Calibration {
    arcs: (f64, f64),
    points: (f64, f64),
    /// Whether close calls go to points at first ([`Self::explores_points`]).
    explore: bool,
}

impl Calibration {
    /// Measured: 500, 1,000, 2,000 and 4,000 within 0.1 % of each other
    /// on every shared file and the replicas.
    const PRIOR: f64 = 2000.0;

    /// Curve `kind` (1 points, 2 arcs) was estimated at `estimate` bits
    /// and cost `actual`.
    fn add(&mut self, kind: u8, estimate: u64, actual: f64) {
        let slot = match kind {
            1 => &mut self.points,
            2 => &mut self.arcs,
            _ => return,
        };
        slot.0 += actual;
        slot.1 += estimate as f64;
    }

    /// Where arcs are estimated cheaper than points but not below this
    /// share of them, a curve goes as points while the block is still
    /// learning what points cost ([`explores_points`](Self::explores_points)).
    ///
    /// The choice has two stable states: a block that codes no points never
    /// learns that they cost about 0.6 of their estimate (0.59–0.68 measured
    /// on the hair, the fornix replicas and the heart fibres), so its arcs
    /// keep winning. Noisy heart fibres (`benches/make_unseen.py
    /// --heart-noise 0.045`, 3,000 fibres at 0.1 mm) sat in the wrong one
    /// at 0.8: 2,996 as arcs, 193,850 B, larger than the noisier default
    /// set's 189,033 B; at 0.7, 2,469 go as points in 180,796 B (−6.7 %).
    /// Measured with 0.6, 0.7 and 0.8 (and, instead, a prior on the points'
    /// factor of 0.65–0.95, which tipped the heart fibres too but made
    /// short noisy fibres up to 1.5 % larger where it was wrong): at 0.7
    /// the shared data's bytes move by +0.07 % at most (the field lines at
    /// 0.001 R☉; a block pays at most about `(1 − EXPLORE) · PRIOR` bits),
    /// 1,100 noisy 30-point wall fibres −1.5 to +0.2 % over five noise
    /// levels; 0.6 sent more of the field lines to points (+0.1–0.2 %).
    const EXPLORE: f64 = 0.7;
    /// Blocks of at least this many curves explore; a smaller one is coded
    /// again exploring where its arcs won a close call it would have
    /// explored, and the smaller coding kept ([`encode_block_with`]): the
    /// exploration costs up to about `(1 − EXPLORE) · PRIOR` bits, which
    /// many curves pay back and a few may not (the 60-curve EuDX file at
    /// 0.5 mm: 158 B without, 177 B with; the 300-curve fornix at 0.1 mm:
    /// 8,225 B without, 7,833 B with).
    const EXPLORE_MIN_CURVES: usize = 1024;

    /// Whether arcs estimated at `arcs` bits against points at `points`
    /// are a close call: at least [`EXPLORE`](Self::EXPLORE) of them.
    fn close_call(arcs: u64, points: u64) -> bool {
        arcs as f64 >= Self::EXPLORE * points as f64
    }

    /// A calibration that explores or not.
    fn exploring(explore: bool) -> Self {
        Calibration {
            explore,
            ..Calibration::default()
        }
    }

    /// Whether a close call (arcs estimated at [`EXPLORE`](Self::EXPLORE)
    /// of points or more) goes to points: until the block has coded
    /// [`PRIOR`](Self::PRIOR) estimated bits of points. Where arcs win
    /// nearly every call, the points' factor would otherwise stay at its
    /// prior, which leaves out what the slide saves. When it was added
    /// (codec model 12, with close calls from 0.8): on 3,000 noisy heart
    /// fibres (`benches/make_unseen.py`) at 0.1 mm, 2,999 curves went as
    /// arcs in 218,233 B; exploring, 2,990 went as points in 200,456 B
    /// (211,159 B with no arcs at all); the shared data's large files
    /// coded the same bytes, 10,000 fornix replicas at 0.1 mm 0.06 % fewer;
    /// a 60-curve file 5 % more (hence [`EXPLORE_MIN_CURVES`](Self::EXPLORE_MIN_CURVES)).
    fn explores_points(&self) -> bool {
        self.explore && self.learning()
    }

    /// Whether the block has coded fewer than [`PRIOR`](Self::PRIOR)
    /// estimated bits of points (an exploring block explores then).
    fn learning(&self) -> bool {
        self.points.1 < Self::PRIOR
    }

    /// The factor on the arcs' estimate.
    fn arcs_scale(&self) -> f64 {
        let ratio =
            |(actual, estimate): (f64, f64)| (actual + Self::PRIOR) / (estimate + Self::PRIOR);
        ratio(self.arcs) / ratio(self.points)
    }
}

/// Mantissa bits of a curve's count (points or elements) coded in
/// contexts from model 8 on: a resampled file's counts recur (20 points
/// each in the bundles, 100 in the hair), and with all their bits modelled
/// a recurring count costs a fraction of a bit instead of the two raw bits
/// below the modelled ones (bundles 0.6–1.2 % smaller, the hair 0.2–0.4 %;
/// 4 bits gain about as much on the bundles, half on the hair).
const COUNT_MANTISSA: usize = 6;

impl Models {
    /// The models of a block coded by codec `model`.
    fn for_model(model: u8) -> Self {
        let mut m = Models::default();
        if model >= 8 {
            m.count = IntModel::with_mantissa(COUNT_MANTISSA);
        }
        m.residual.sign_after = sign_after(model);
        m.ref_residual.sign_after = sign_after(model);
        m
    }
}

/// The adaptive models of one block: one per coded field.
#[derive(Default)]
struct Models {
    kind: [Bit; 4],
    count: IntModel,
    start: [IntModel; 3],
    first_end: [IntModel; 3],
    first_bulge: [IntModel; 2],
    kink: [Bit; 4],
    corner: [Bit; 4],
    jump_kind: [Bit; 4],
    jump: [IntModel; 3],
    /// By [`span_context`].
    length: [IntModel; SPANS],
    offset: [[IntModel; 2]; SPANS],
    bulge: [IntModel; 2],
    /// By [`residual_context`] of the residual before.
    residual: ResidualModels,
    raw_count: IntModel,
    has_reference: Bit,
    /// A second reference, averaged with the first.
    has_second: Bit,
    /// Own prediction by screw continuation ([`helix_prediction`]).
    helix: Bit,
    /// From model 13, after a 0 there: own prediction by the mean step
    /// ([`mean_step_prediction`]).
    mean_step: Bit,
    /// From model 10: a points curve's along-step flag.
    along: Bit,
    point_start: [IntModel; 3],
    /// Parity of lattice differences of a points curve's start: from its
    /// reference's, from the previous points curve's (the residuals'
    /// parities are in their context sets).
    parity: [Bit; 2],
    back: IntModel,
    reversed: Bit,
    /// From model 12: whether a reference's steps are walked.
    walk: Bit,
    ref_start: [IntModel; 3],
    has_anchor: Bit,
    /// Parity of start differences: from an anchor, from the previous start.
    start_parity: [Bit; 2],
    back_anchor: IntModel,
    anchor_end: Bit,
    anchor_start: [IntModel; 3],
    ref_residual: ResidualModels,
}

/// Contexts of an element's length and offsets: the bit length of the
/// previous chord in length steps. The prediction misses by more over a
/// longer span (the curvature's change acts over the span squared), so
/// residuals of short and long elements are modelled apart.
const SPANS: usize = 8;

fn span_context(chord_steps: i64) -> usize {
    let bits = 64 - chord_steps.unsigned_abs().leading_zeros() as usize;
    bits.min(SPANS - 1)
}

/// Cross-curve predictions: the previous curve's start and first end.
#[derive(Default)]
struct Previous {
    arc_start: [i64; 3],
    first_end: [i64; 3],
    point_start: [i64; 3],
}

fn put_kind(enc: &mut Encoder, m: &mut Models, kind: u8) {
    enc.bit(&mut m.kind[0], kind & 2 != 0);
    enc.bit(&mut m.kind[1 + (kind >> 1) as usize], kind & 1 != 0);
}

fn get_kind(dec: &mut Decoder, m: &mut Models) -> u8 {
    let hi = dec.bit(&mut m.kind[0]) as u8;
    let lo = dec.bit(&mut m.kind[1 + hi as usize]) as u8;
    hi << 1 | lo
}

fn put_element_kind(enc: &mut Encoder, m: &mut Models, prev: ElementKind, kind: ElementKind) {
    let p = prev as usize;
    enc.bit(&mut m.kink[p], kind != ElementKind::G1);
    if kind != ElementKind::G1 {
        let rare = matches!(kind, ElementKind::Corner | ElementKind::Jump);
        enc.bit(&mut m.corner[p], rare);
        if rare {
            enc.bit(&mut m.jump_kind[p], kind == ElementKind::Jump);
        }
    }
}

fn get_element_kind(dec: &mut Decoder, m: &mut Models, prev: ElementKind) -> ElementKind {
    let p = prev as usize;
    if !dec.bit(&mut m.kink[p]) {
        ElementKind::G1
    } else if !dec.bit(&mut m.corner[p]) {
        ElementKind::Straight
    } else if dec.bit(&mut m.jump_kind[p]) {
        ElementKind::Jump
    } else {
        ElementKind::Corner
    }
}

fn kind_of(code: &CurveCode) -> u8 {
    match code {
        CurveCode::Empty => 0,
        CurveCode::Points { .. } => 1,
        CurveCode::Arcs { .. } => 2,
        CurveCode::Raw(_) => 3,
    }
}

/// The fields of a block's stream, for [`encode_block_tallied`].
pub const FIELDS: [&str; 13] = [
    "curve kind",
    "count",
    "start",
    "first end",
    "first bulge",
    "element kind",
    "length",
    "offset",
    "bulge",
    "jump",
    "points start",
    "points residual",
    "raw",
];

/// Encodes curves into one block (curves fitted in parallel, then coded in
/// order).
///
/// ```
/// use strandfit::codec::{decode_block, encode_block, CodecParams, EncodeError};
/// # use strandfit::DVec3;
/// # fn helix(r: f64) -> Vec<DVec3> { // a helix of radius r, a point every 0.1 radian
/// #     (0..100).map(|k| 0.1 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.8 * s)).collect()
/// # }
///
/// let params = CodecParams::new(0.05);
/// let curves = [helix(3.0), vec![], helix(5.0)];
/// let block = encode_block(&curves, &params).unwrap();
/// assert_eq!(block.kinds, [2, 0, 2]); // arcs, empty, arcs
/// assert_eq!(decode_block(&block.bytes, 3, &params).unwrap().len(), 3);
/// // A point that is not finite is refused, naming the curve and point.
/// let mut bad = helix(3.0);
/// bad[7].y = f64::NAN;
/// let err = encode_block(&[helix(1.0), bad], &params).unwrap_err();
/// assert!(matches!(err, EncodeError::NonFinite { curve: 1, point: 7 }));
/// ```
pub fn encode_block<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
) -> Result<EncodedBlock, EncodeError> {
    encode_block_with(curves, params, false, false, None).map(|(b, _)| b)
}

/// [`encode_block`], keeping each curve's decoded points in
/// [`EncodedBlock::decoded`].
///
/// The points kept are those [`decode_block`] gives back:
///
/// ```
/// use strandfit::codec::{decode_block, encode_block, encode_block_keeping, CodecParams};
/// # use strandfit::DVec3;
/// # fn helix(r: f64) -> Vec<DVec3> { // a helix of radius r, a point every 0.1 radian
/// #     (0..100).map(|k| 0.1 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.8 * s)).collect()
/// # }
///
/// let params = CodecParams::new(0.05);
/// let curves = [helix(3.0), helix(5.0)];
/// let block = encode_block_keeping(&curves, &params).unwrap();
/// assert_eq!(block.decoded, decode_block(&block.bytes, 2, &params).unwrap());
/// assert_eq!(block.output_points, block.decoded.iter().map(Vec::len).sum::<usize>());
/// // The same bytes as without keeping.
/// assert_eq!(block.bytes, encode_block(&curves, &params).unwrap().bytes);
/// ```
pub fn encode_block_keeping<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
) -> Result<EncodedBlock, EncodeError> {
    encode_block_with(curves, params, false, true, None).map(|(b, _)| b)
}

/// [`encode_block`], and with `tally` the ideal bits spent on each of
/// [`FIELDS`] (to see where a file's bytes go).
///
/// ```
/// use strandfit::codec::{encode_block, encode_block_tallied, CodecParams, FIELDS};
/// # use strandfit::DVec3;
/// # fn helix(r: f64) -> Vec<DVec3> { // a helix of radius r, a point every 0.1 radian
/// #     (0..100).map(|k| 0.1 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.8 * s)).collect()
/// # }
///
/// let params = CodecParams::new(0.05);
/// let curves = [helix(3.0), helix(5.0)];
/// let (block, bits) = encode_block_tallied(&curves, &params, true).unwrap();
/// let bits = bits.unwrap();
/// assert_eq!(bits.len(), FIELDS.len());
/// // The range coder spends within a few bytes of the ideal bits.
/// let ideal = bits.iter().sum::<f64>() / 8.0;
/// assert!((block.bytes.len() as f64 - ideal).abs() < 8.0, "{} B, ideal {ideal:.1} B", block.bytes.len());
/// // Arcs only: no points-mode field is spent on.
/// assert_eq!(bits[FIELDS.iter().position(|f| *f == "points residual").unwrap()], 0.0);
/// // Without the tally: no bits, the same bytes.
/// let (plain, none) = encode_block_tallied(&curves, &params, false).unwrap();
/// assert!(none.is_none());
/// assert_eq!(plain.bytes, block.bytes);
/// ```
pub fn encode_block_tallied<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    tally: bool,
) -> Result<(EncodedBlock, Option<Vec<f64>>), EncodeError> {
    encode_block_with(curves, params, tally, false, None)
}

/// [`encode_block`] (with `keep`, [`encode_block_keeping`]), every curve's
/// candidate elements checked in batches on `checker` where one is given
/// ([`ArcChecker`]): the same bytes as without, as the checker's sure verdicts
/// are the reference's and the reference decides the rest.
///
/// Without a checker (the GPU's is the command line's plumbing), every
/// curve's search checks its own candidates on the CPU:
///
/// ```
/// use strandfit::codec::{encode_block, encode_block_on, CodecParams};
/// # use strandfit::DVec3;
/// # fn helix(r: f64) -> Vec<DVec3> { // a helix of radius r, a point every 0.1 radian
/// #     (0..100).map(|k| 0.1 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.8 * s)).collect()
/// # }
///
/// let params = CodecParams::new(0.05);
/// let curves = [helix(3.0), helix(5.0)];
/// let block = encode_block_on(&curves, &params, true, None).unwrap();
/// assert_eq!(block.bytes, encode_block(&curves, &params).unwrap().bytes);
/// assert_eq!(block.decoded.len(), 2); // `keep`
/// assert_eq!(block.checks.checked, 0); // nothing asked of a checker
/// ```
pub fn encode_block_on<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    keep: bool,
    checker: Option<&dyn batch::ArcChecker>,
) -> Result<EncodedBlock, EncodeError> {
    encode_block_with(curves, params, false, keep, checker).map(|(b, _)| b)
}

/// Curves whose searches run together between two updates of the arcs'
/// calibration: the give-up of a chunk's searches knows the block's
/// calibration from the curves before it ([`encoder::GiveUp`]). Small
/// enough that the first chunks teach the rest, large enough to keep both
/// cores and a GPU batch busy.
const CALIBRATION_CHUNK: usize = 256;

/// A block's first chunk, shorter: it searches every curve's arcs
/// ([`ArcsWorth`] has seen nothing yet), and on noisy fibres at fine
/// tolerances, where arcs almost never win, that search was 6 % of the
/// encoder. Measured against a first chunk of 256 (10,000 replicas at
/// 0.1 mm: 3.5 % fewer instructions, 32 curves 4 %; bytes within 10 of
/// 330,010 on the replicas, 133,831 on the hair at 0.1 mm and 189,027 on
/// the heart fibres at 0.1 mm, and equal on the hair at 0.5 mm, the field
/// lines, the dipole lines, CC and the fornix at 0.5 mm).
const FIRST_CHUNK: usize = 64;

/// The options of a chunk of a block's curves, searched in parallel (or
/// with `checker`, all together, their checks in batches).
#[allow(clippy::too_many_arguments)]
fn chunk_options<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    half: f64,
    arcs_scale: f64,
    checker: Option<&dyn batch::ArcChecker>,
    search_arcs: impl Fn(usize) -> bool + Sync,
    corner_first: bool,
) -> (Vec<CurveOptions>, batch::BatchStats) {
    // A curve whose arcs are not searched goes as points where it can.
    let points_only = |i: usize, pts: &[DVec3]| -> Option<CurveOptions> {
        if search_arcs(i) {
            return None;
        }
        let grid = match curve_encoder(pts, params, half, arcs_scale, false)?.points_code() {
            Some(CurveCode::Points { grid, .. }) => grid,
            _ => return None,
        };
        Some(CurveOptions {
            points: Some(grid),
            arcs: None,
        })
    };
    let Some(checker) = checker else {
        let options = curves
            .par_iter()
            .enumerate()
            .map(|(i, pts)| {
                points_only(i, pts.as_ref()).unwrap_or_else(|| {
                    curve_options_ordered(pts.as_ref(), params, half, arcs_scale, corner_first)
                })
            })
            .collect();
        return (options, batch::BatchStats::default());
    };
    let only: Vec<Option<CurveOptions>> = curves
        .par_iter()
        .enumerate()
        .map(|(i, pts)| points_only(i, pts.as_ref()))
        .collect();
    let encoders: Vec<Option<CurveEncoder>> = curves
        .iter()
        .zip(&only)
        .map(|(pts, only)| match only {
            Some(_) => None,
            None => curve_encoder(pts.as_ref(), params, half, arcs_scale, corner_first),
        })
        .collect();
    let (arcs, stats) = batch::search_block(&encoders, checker);
    drop(encoders);
    let options = curves
        .par_iter()
        .zip(arcs)
        .zip(only)
        .map(|((pts, arcs), only)| {
            only.unwrap_or_else(|| {
                match curve_encoder(pts.as_ref(), params, half, arcs_scale, corner_first) {
                    Some(enc) => finish_options(&enc, arcs),
                    None => CurveOptions {
                        points: None,
                        arcs: None,
                    },
                }
            })
        })
        .collect();
    (options, stats)
}

/// One coding of a block's curves: the stream, its models and the curve
/// before's starts.
/// What coding an arcs curve's start needs of the curves before it (its
/// anchor, the predictions of its first end and bulge): the same for every
/// stream of a block ([`BlockStream::put_curve`]), so found once per curve
/// (the anchor search and the neighbour's walk were coded twice, a tenth of
/// compress at 0.5 mm).
struct ArcsPlan {
    /// Whether the anchor flag is coded (there is a curve before).
    anchor_flag: bool,
    /// The anchor: curves back, at its end, its lattice point.
    anchor: Option<(usize, bool, [i64; 3])>,
    /// The first end's and bulge's predictions, without and with the
    /// neighbours' fit (model 15; the same without an anchor).
    first_end: [[i64; 3]; 2],
    first_bulge: [[i64; 2]; 2],
}

/// What coding a curve needs of the curves before it, the same for every
/// stream of a block (the streams differ in their models only).
enum CurvePlan {
    Arcs(ArcsPlan),
    /// A points curve's start, less its prediction, and its residuals;
    /// and whether its reference flag is coded (there is a curve before
    /// it). The flag is the plan's, not the neighbours' count when the
    /// curve is put: a stream opened later (the fit's) codes the held
    /// curves again after the block has moved on, and a first curve coded
    /// as points then wrote a flag its decoder does not read.
    Points {
        start: [i64; 3],
        residuals: Vec<Residual>,
        reference_flag: bool,
    },
    /// Empty and raw curves need nothing.
    Nothing,
}

impl CurvePlan {
    /// The plan of curve `code`, with `neighbours` holding it last and
    /// `prev` the streams' (equal) cross-curve predictions (with `fit`,
    /// the neighbours' fit's as well).
    fn of(
        code: &CurveCode,
        neighbours: &mut Neighbours,
        prev: &Previous,
        q: &Quantiser,
        params: &CodecParams,
        fit: bool,
        predicted: Option<&[[i64; 3]]>,
    ) -> Self {
        match code {
            CurveCode::Arcs {
                start, first_end, ..
            } => CurvePlan::Arcs(ArcsPlan::of(
                *start,
                *first_end,
                neighbours,
                prev,
                q,
                params.model,
                fit,
            )),
            CurveCode::Points {
                grid,
                reference,
                own,
                along: along_flag,
            } => {
                let along = along(params.model).then_some(*along_flag);
                // `neighbours` holds this curve last.
                let reference_flag = neighbours.len() > 1;
                match reference {
                    Some(rf) => {
                        // `neighbours` holds this curve last: its reference
                        // is `back` before that.
                        let grids = neighbours.window();
                        let res =
                            rf.resolve(&grids[..grids.len() - 1], Rule::of_model(params.model));
                        let start = res.start();
                        let n = grid.len();
                        let foot = reference::PredictionCache::default();
                        CurvePlan::Points {
                            start: [0, 1, 2].map(|a| grid[0][a] - start[a]),
                            residuals: plan_residuals(along, grid, |k| match predicted {
                                // The slide's, of these same points.
                                Some(p) => p[k],
                                None => res.predict_next(grid, k, n, &foot),
                            }),
                            reference_flag,
                        }
                    }
                    None => CurvePlan::Points {
                        start: [0, 1, 2].map(|a| grid[0][a] - prev.point_start[a]),
                        residuals: plan_residuals(along, grid, |k| match predicted {
                            Some(p) => p[k],
                            None => own_prediction(grid, k, *own, screw(params.model)),
                        }),
                        reference_flag,
                    },
                }
            }
            CurveCode::Empty | CurveCode::Raw(_) => CurvePlan::Nothing,
        }
    }
}

impl ArcsPlan {
    /// The plan of an arcs curve starting at `start` (its first end
    /// `first_end`).
    fn of(
        start: [i64; 3],
        first_end: [i64; 3],
        neighbours: &Neighbours,
        prev: &Previous,
        q: &Quantiser,
        model: u8,
        fit: bool,
    ) -> Self {
        let (start, first_end) = (&start, &first_end);
        // `neighbours` holds this curve last; its anchors are the curves
        // before it.
        let before = neighbours.len() - 1;
        let own = lattice_bits([0, 1, 2].map(|a| start[a] - prev.arc_start[a]));
        let anchor = if before > 0 {
            neighbours
                .best_anchor(*start, before)
                .filter(|&(_, _, bits)| bits < own)
        } else {
            None
        };
        let q0 = DVec3::new(start[0] as f64, start[1] as f64, start[2] as f64) * q.start;
        let end = encoder::first_end(q0, *first_end, q.first);
        let predict = |fit: Option<[i64; 3]>| {
            let (fe, walk) = first_end_prediction(
                neighbours,
                before,
                anchor.map(|a| (a.0, a.1)),
                prev,
                q,
                model,
                fit,
            );
            (fe, first_bulge_prediction(walk, q0, end, q.offset))
        };
        let plain = predict(None);
        let fitted = if fit && model >= 15 && anchor.is_some() {
            predict(Some(*start))
        } else {
            plain
        };
        ArcsPlan {
            anchor_flag: before > 0,
            anchor: anchor.map(|(back, at_end, _)| {
                let r = neighbours.anchor(before - back, at_end).unwrap_or([0; 3]);
                (back, at_end, r)
            }),
            first_end: [plain.0, fitted.0],
            first_bulge: [plain.1, fitted.1],
        }
    }
}

/// Anchored arcs curves a block needs before its neighbours'-fit streams
/// are begun ([`encode_block_with`]).
const FIT_OPENS: usize = 16;

/// Whether a block's streams with the neighbours' fit are yet to begin,
/// coding, or dropped (or the model has none).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fit {
    Pending,
    Open,
    Dropped,
}

/// After so many anchored arcs curves, a block's neighbours'-fit streams
/// are dropped where they are not ahead by most of [`FIT_MARGIN`].
const FIT_CHECK: usize = 1024;

/// How much smaller a block's stream with the neighbours' fit must be to
/// be kept: the fit's search costs the decoder about a quarter more time
/// on a block of arcs (100,000 fornix replicas at 0.5 mm, where it saves
/// 0.7 %; the field lines of `../shared/data` at 0.01 solar radii 2 %).
const FIT_MARGIN: f64 = 0.01;

/// After so many points curves, a block keeps only the streams of the
/// magnitude models (per axis or shared, [`ResidualModels::shared`]) that
/// are ahead, instead of coding both to the block's end. Logged every
/// doubling from 64 points curves (100,000 fornix replicas at 0.1 mm, 25
/// blocks; the hair, the heart fibres of `benches/make_unseen.py`, the
/// fornix): the lead changes hands until about 256, as the per-axis
/// models learn, and then only widens (the shared stream behind on the
/// replicas by 0.15–0.26 % at 1,024 and 0.19–0.28 % at the end; ahead on
/// the hair by 0.12 % and 0.10 %; behind on the heart by 0.08 % and
/// 0.09 %). The second stream to the end was about 3 % of the encoder's
/// instructions on 10,000 replicas at 0.1 mm. Session 56, against 1,024:
/// 512 / 256 made the 100,000 replicas at 0.1 mm 250 B / 1,721 B larger
/// (+0.007 % / +0.05 %) and the 30,000 heart fibres 0 B / 453 B (+0.02 %),
/// the hair, the tracker's and the dense streamlines the same bytes, for
/// 1.5 % / 2.1 % fewer cycles on 10,000 replicas (instructions and
/// mispredicted branches counted by cachegrind).
const SHARED_CHECK: usize = 256;

struct BlockStream {
    enc: Encoder,
    m: Models,
    prev: Previous,
    /// The block's quantisation steps (once, not per curve).
    q: Quantiser,
    /// From model 15: anchored arcs curves' first elements predicted by
    /// the neighbours' fit ([`first_end_prediction`]).
    fit: bool,
}

impl BlockStream {
    /// A stream of codec `model` with the lattice exponent `scale_exp`,
    /// (from model 11) the shared-magnitudes flag and (from model 15) the
    /// neighbours' fit flag.
    fn new(params: &CodecParams, scale_exp: i32, tally: bool, shared: bool, fit: bool) -> Self {
        let mut enc = if tally {
            Encoder::with_tally(FIELDS.len(), Adaptation::of_model(params.model))
        } else {
            Encoder::with_adaptation(Adaptation::of_model(params.model))
        };
        enc.direct((scale_exp + 128) as u64, 8);
        let mut m = Models::for_model(params.model);
        if sign_after(params.model) {
            enc.direct(shared as u64, 1);
            m.residual.shared = shared;
            m.ref_residual.shared = shared;
        }
        let fit = fit && params.model >= 15;
        if params.model >= 15 {
            enc.direct(fit as u64, 1);
        }
        BlockStream {
            enc,
            m,
            prev: Previous::default(),
            q: params.quantiser(),
            fit,
        }
    }

    /// Codes a curve by its plan ([`CurvePlan::of`], made when the
    /// neighbours held it last: a curve held and coded again into a stream
    /// opened later is coded as it was).
    fn put_curve(&mut self, code: &CurveCode, params: &CodecParams, plan: &CurvePlan) {
        let (enc, m, prev) = (&mut self.enc, &mut self.m, &mut self.prev);
        let fit = self.fit as usize;
        let kind = kind_of(code);
        enc.set_tag(0);
        put_kind(enc, m, kind);
        match code {
            CurveCode::Empty => {}
            CurveCode::Raw(p) => {
                enc.set_tag(12);
                m.raw_count.put_unsigned(enc, p.len() as u64);
                for v in p.iter().flat_map(|v| v.to_array()) {
                    enc.direct(v.to_bits(), 64);
                }
            }
            CurveCode::Points {
                grid,
                reference,
                own,
                along: along_flag,
            } => {
                enc.set_tag(1);
                m.count.put_unsigned(enc, grid.len() as u64 - 1);
                enc.set_tag(10);
                let CurvePlan::Points {
                    start,
                    residuals,
                    reference_flag,
                } = plan
                else {
                    unreachable!("a points curve is put with its plan")
                };
                if *reference_flag {
                    enc.bit(&mut m.has_reference, reference.is_some());
                }
                let along = along(params.model).then_some(*along_flag);
                if along.is_some() && grid.len() > 2 {
                    enc.bit(&mut m.along, *along_flag);
                }
                match reference {
                    Some(rf) => {
                        m.back.put_unsigned(enc, rf.back as u64 - 1);
                        enc.bit(&mut m.reversed, rf.reversed);
                        enc.bit(&mut m.has_second, rf.second.is_some());
                        if let Some((back, reversed)) = rf.second {
                            m.back.put_unsigned(enc, back as u64 - 1);
                            enc.bit(&mut m.reversed, reversed);
                        }
                        if Rule::of_model(params.model).walk {
                            enc.bit(&mut m.walk, rf.walk);
                        }
                        put_lattice(enc, &mut m.parity[0], &mut m.ref_start, *start);
                        enc.set_tag(11);
                        put_residuals(enc, &mut m.ref_residual, along, residuals);
                    }
                    None => {
                        enc.bit(&mut m.helix, *own == OwnPrediction::Screw);
                        if params.model >= 13 && *own != OwnPrediction::Screw {
                            enc.bit(&mut m.mean_step, *own == OwnPrediction::MeanStep);
                        }
                        put_lattice(enc, &mut m.parity[1], &mut m.point_start, *start);
                        enc.set_tag(11);
                        put_residuals(enc, &mut m.residual, along, residuals);
                    }
                }
                prev.point_start = grid[0];
            }
            CurveCode::Arcs {
                start,
                first_end,
                first_bulge,
                elements,
            } => {
                enc.set_tag(1);
                m.count.put_unsigned(enc, elements.len() as u64);
                enc.set_tag(2);
                let CurvePlan::Arcs(plan) = plan else {
                    unreachable!("an arcs curve is put with its plan")
                };
                if plan.anchor_flag {
                    enc.bit(&mut m.has_anchor, plan.anchor.is_some());
                }
                match plan.anchor {
                    Some((back, at_end, r)) => {
                        m.back_anchor.put_unsigned(enc, back as u64 - 1);
                        enc.bit(&mut m.anchor_end, at_end);
                        let d = [0, 1, 2].map(|a| start[a] - r[a]);
                        put_lattice(enc, &mut m.start_parity[0], &mut m.anchor_start, d);
                    }
                    None => {
                        let d = [0, 1, 2].map(|a| start[a] - prev.arc_start[a]);
                        put_lattice(enc, &mut m.start_parity[1], &mut m.start, d);
                    }
                }
                enc.set_tag(3);
                for a in 0..3 {
                    m.first_end[a].put(enc, first_end[a] - plan.first_end[fit][a]);
                }
                enc.set_tag(4);
                prev.arc_start = *start;
                prev.first_end = *first_end;
                for a in 0..2 {
                    m.first_bulge[a].put(enc, first_bulge[a] - plan.first_bulge[fit][a]);
                }
                let mut prev_kind = ElementKind::Corner;
                let mut last = [0i64; 3];
                for e in elements {
                    let ctx = span_context(e.span);
                    enc.set_tag(5);
                    put_element_kind(enc, m, prev_kind, e.kind);
                    prev_kind = e.kind;
                    if e.kind == ElementKind::Jump {
                        enc.set_tag(9);
                        for a in 0..3 {
                            m.jump[a].put(enc, e.jump[a]);
                        }
                        continue;
                    }
                    enc.set_tag(6);
                    m.length[ctx].put_after(enc, e.length, last[0]);
                    enc.set_tag(7);
                    m.offset[ctx][0].put_after(enc, e.offset[0], last[1]);
                    m.offset[ctx][1].put_after(enc, e.offset[1], last[2]);
                    if sign_after(params.model) {
                        last = [e.length, e.offset[0], e.offset[1]];
                    }
                    if e.kind == ElementKind::Corner {
                        enc.set_tag(8);
                        m.bulge[0].put(enc, e.bulge[0] - e.bulge_base[0]);
                        m.bulge[1].put(enc, e.bulge[1] - e.bulge_base[1]);
                    }
                }
            }
        }
    }
}

fn encode_block_with<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    tally: bool,
    keep: bool,
    checker: Option<&dyn batch::ArcChecker>,
) -> Result<(EncodedBlock, Option<Vec<f64>>), EncodeError> {
    if params.effort == Effort::Default {
        return encode_block_searched(curves, params, tally, keep, checker);
    }
    // `Best`: the block coded with the look-ahead and without, the smaller
    // kept, so that it is never larger than `Default`'s (the look-ahead's
    // chains, each estimated cheaper, came out larger on some blocks: the
    // hair at 0.5 mm 3 %, session 51).
    let default = CodecParams {
        effort: Effort::Default,
        ..*params
    };
    let plain = encode_block_searched(curves, &default, tally, keep, checker)?;
    let ahead = encode_block_searched(curves, params, tally, keep, checker)?;
    Ok(smaller_coding(plain, ahead))
}

/// Of two codings of one block, `second` where it is strictly smaller,
/// else `first`; the kept one's batched checks count both's.
fn smaller_coding(
    first: (EncodedBlock, Option<Vec<f64>>),
    second: (EncodedBlock, Option<Vec<f64>>),
) -> (EncodedBlock, Option<Vec<f64>>) {
    let (mut kept, other) = if second.0.bytes.len() < first.0.bytes.len() {
        (second, first)
    } else {
        (first, second)
    };
    kept.0.checks.add(&other.0.checks);
    kept
}

/// [`encode_block_with`] at `params`' effort alone.
fn encode_block_searched<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    tally: bool,
    keep: bool,
    checker: Option<&dyn batch::ArcChecker>,
) -> Result<(EncodedBlock, Option<Vec<f64>>), EncodeError> {
    let large = curves.len() >= Calibration::EXPLORE_MIN_CURVES;
    let (block, tallied, close_calls) =
        encode_block_once(curves, params, tally, keep, checker, large)?;
    if large || close_calls == 0 {
        return Ok((block, tallied));
    }
    // A small block whose arcs won close calls: coded again exploring
    // them, the smaller kept (the time of such a block twice; one of
    // smooth curves has none).
    let (again, again_tallied, _) = encode_block_once(curves, params, tally, keep, checker, true)?;
    Ok(smaller_coding((block, tallied), (again, again_tallied)))
}

/// [`encode_block_with`] once, the block's close calls explored or not
/// ([`Calibration::explores_points`]); with the close calls that went to
/// arcs unexplored.
fn encode_block_once<C: AsRef<[DVec3]> + Sync>(
    curves: &[C],
    params: &CodecParams,
    tally: bool,
    keep: bool,
    checker: Option<&dyn batch::ArcChecker>,
    explore: bool,
) -> Result<(EncodedBlock, Option<Vec<f64>>, usize), EncodeError> {
    let mut checks = batch::BatchStats::default();
    if !(params.tolerance.is_finite() && params.tolerance > 0.0) {
        return Err(EncodeError::BadTolerance(params.tolerance));
    }
    // Every point finite and within float32's range (the output formats'),
    // the first that is not named.
    for (c, pts) in curves.iter().enumerate() {
        if let Some(k) = pts.as_ref().iter().position(|&p| !crate::io::fits_f32(p)) {
            let p = pts.as_ref()[k];
            return Err(if p.is_finite() {
                EncodeError::BeyondFloat32 {
                    curve: c,
                    point: k,
                    why: crate::io::point_problem(p).unwrap_or_default(),
                }
            } else {
                EncodeError::NonFinite { curve: c, point: k }
            });
        }
    }
    // The points lattice of this block, sized by its largest coordinate
    // rounded up to a power of two (whose exponent is the stream's first
    // byte); 0 when no lattice fits: raw points then.
    let scale = curves
        .iter()
        .flat_map(|c| c.as_ref().iter())
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    let scale_exp = quantise::scale_exponent(scale);
    let half = quantise::lattice_half(params.tolerance, 2f64.powi(scale_exp)).unwrap_or(0.0);
    // From model 11 the block is coded twice, its points residuals'
    // magnitudes in models per axis and in one shared by the axes (a flag
    // says which): sharing learns three times as fast, which a small
    // block needs, and a large one codes its axes' statistics apart. The
    // smaller is kept (the choices are the same). The shared stream is
    // begun at the block's first points curve: until then both code the
    // same but for the flag, so the curves before are put into it then,
    // from their codes and plans kept meanwhile, and a block without
    // points curves is coded once (a thirtieth of compress at 0.5 mm; such
    // a block keeps the per-axis stream, which the shared one could beat
    // by a byte at most, in its last bytes' carries; no file measured
    // changed).
    //
    // From model 15 the block is also coded with its anchored arcs curves'
    // first elements predicted by the neighbours' fit (a flag says so;
    // [`first_end_prediction`]), begun likewise once a block has
    // [`FIT_OPENS`] anchored arcs curves, an eighth of its curves so far
    // at least, and kept only where it codes [`FIT_MARGIN`] smaller: the
    // fit's search for the nearest anchors costs the decoder about a
    // quarter more time on a block of arcs.
    let mut streams = vec![BlockStream::new(params, scale_exp, tally, false, false)];
    let mut shared_pending = sign_after(params.model);
    let mut points_curves = 0usize;
    let mut fit = if params.model >= 15 {
        Fit::Pending
    } else {
        Fit::Dropped
    };
    let mut anchored = 0usize;
    let mut seen = 0usize;
    let mut held: Vec<(CurveCode, CurvePlan)> = Vec::new();
    let grid_step = half;
    let q_start = params.quantiser().start;
    let mut kinds = Vec::with_capacity(curves.len());
    let mut output_points = 0;
    let mut decoded = Vec::with_capacity(if keep { curves.len() } else { 0 });
    let mut n_elements = 0;
    let mut calibration = Calibration::exploring(explore);
    let mut close_calls = 0;
    // The block's decoded curves: the references.
    let mut neighbours = Neighbours::new(grid_step, q_start, curves.len());
    let mut worth = ArcsWorth::default();
    let mut vote = SlideVote::default();
    if curves.iter().map(|c| c.as_ref().len()).sum::<usize>() < SMALL_BLOCK_POINTS {
        vote.search = quantise::Search {
            beam: SMALL_BLOCK_SLIDE_BEAM,
            reach: SMALL_BLOCK_SLIDE_REACH_TOLERANCES,
        };
    }
    let mut screw_vote = RareVote::default();
    let mut reference_vote = ReferenceVote::default();
    let (head, tail) = curves.split_at(FIRST_CHUNK.min(curves.len()));
    let chunks = std::iter::once(head)
        .filter(|h| !h.is_empty())
        .chain(tail.chunks(CALIBRATION_CHUNK));
    for chunk in chunks {
        // Each chunk's searches with what the curves before it taught
        // ([`encoder::GiveUp`], [`ArcsWorth`]).
        let sampled = !worth.pays();
        let searched = |i: usize| !sampled || i.is_multiple_of(ArcsWorth::SAMPLE);
        // The corner first after a corner only where the arcs are known to
        // pay: a block's first chunk, and a sample, measure what they save
        // with the cheapest kind first, as `ArcsWorth::SHARE` was measured
        // (`encoder::CurveEncoder::corner_first`). (A chunk searched in full
        // is counted in `worth` too, as searched: corner first. A block
        // near the share may so stay searched in full a chunk longer; on
        // the sets measured, the heart fibres and the replicas at 0.1 mm
        // kept the same containers.)
        let corner_first = !sampled && worth.measured();
        let options = chunk_options(
            chunk,
            params,
            half,
            calibration.arcs_scale(),
            checker,
            searched,
            corner_first,
        );
        checks.add(&options.1);
        for (i, (points, opt)) in chunk.iter().zip(options.0).enumerate() {
            let arcs_searched = searched(i);
            // The choice, in order: a points-mode curve may lean on those
            // before.
            let before = streams[0].enc.position_bits();
            let (code, n, estimate, saving, predicted) = choose(
                points.as_ref(),
                opt,
                params.tolerance,
                half,
                screw(params.model),
                Rule::of_model(params.model),
                along(params.model),
                &mut neighbours,
                &streams[0].prev,
                calibration.arcs_scale(),
                calibration.explores_points(),
                params.model >= 13,
                &mut vote,
                &mut screw_vote,
                &mut reference_vote,
                // Counted where an exploring coding would have explored
                // (it would still be learning): from the first such call
                // on, the two codings differ; until then they are one.
                (!calibration.explores_points() && calibration.learning())
                    .then_some(&mut close_calls),
            );
            if arcs_searched {
                worth.add(estimate, saving);
            }
            if keep {
                decoded.push(neighbours.last_decoded());
            }
            output_points += n;
            let kind = kind_of(&code);
            kinds.push(kind);
            let plan = CurvePlan::of(
                &code,
                &mut neighbours,
                &streams[0].prev,
                &streams[0].q,
                params,
                fit != Fit::Dropped,
                predicted.as_deref(),
            );
            seen += 1;
            if shared_pending && matches!(code, CurveCode::Points { .. }) {
                let fits: Vec<bool> = streams.iter().map(|s| s.fit).collect();
                for fit in fits {
                    let mut shared = BlockStream::new(params, scale_exp, tally, true, fit);
                    for (c, p) in &held {
                        shared.put_curve(c, params, p);
                    }
                    streams.push(shared);
                }
                shared_pending = false;
            }
            if matches!(&plan, CurvePlan::Arcs(a) if a.anchor.is_some()) {
                anchored += 1;
                if fit == Fit::Pending && anchored >= FIT_OPENS && 8 * anchored >= seen {
                    let variants: Vec<bool> = streams.iter().map(|s| s.m.residual.shared).collect();
                    for shared in variants {
                        let mut fitted = BlockStream::new(params, scale_exp, tally, shared, true);
                        for (c, p) in &held {
                            fitted.put_curve(c, params, p);
                        }
                        streams.push(fitted);
                    }
                    fit = Fit::Open;
                } else if fit == Fit::Open && anchored == FIT_CHECK {
                    // The fit's streams dropped where they are not ahead by
                    // most of the margin by then (their predictions are
                    // the encoder's cost too): measured every 256 anchored
                    // curves, the fit's gain grows over the first few
                    // hundred (the window fills) and then holds (fornix
                    // replicas at 0.5 mm 0.5 % from 1,024 on; the field
                    // lines at 0.01 R☉ 1.2 % at 1,024, 1.7–1.9 % after).
                    let best = |f: bool| {
                        streams
                            .iter()
                            .filter(|s| s.fit == f)
                            .map(|s| s.enc.position_bits())
                            .min_by(f64::total_cmp)
                    };
                    if let (Some(a), Some(b)) = (best(false), best(true)) {
                        if b >= (1.0 - 0.7 * FIT_MARGIN) * a {
                            streams.retain(|s| !s.fit);
                            fit = Fit::Dropped;
                        }
                    }
                }
            }
            let fit_pending = fit == Fit::Pending;
            if !shared_pending && !fit_pending {
                held.clear();
            }
            for s in streams.iter_mut() {
                s.put_curve(&code, params, &plan);
            }
            if let CurveCode::Arcs { elements, .. } = &code {
                n_elements += 1 + elements.len();
            }
            calibration.add(kind, estimate, streams[0].enc.position_bits() - before);
            if matches!(code, CurveCode::Points { .. }) {
                points_curves += 1;
                if points_curves == SHARED_CHECK {
                    // Both kinds are there (the shared streams began at the
                    // first points curve): the kind of the stream ahead is
                    // kept, with or without the fit.
                    let ahead = streams
                        .iter()
                        .min_by(|a, b| a.enc.position_bits().total_cmp(&b.enc.position_bits()))
                        .map(|s| s.m.residual.shared);
                    streams.retain(|s| Some(s.m.residual.shared) == ahead);
                }
            }
            if shared_pending || fit == Fit::Pending {
                held.push((code, plan));
            }
        }
        worth.end_chunk();
    }
    let finished: Vec<(bool, Vec<u8>, Option<Vec<f64>>)> = streams
        .into_iter()
        .map(|s| {
            let tallied = s.enc.tally().map(<[f64]>::to_vec);
            (s.fit, s.enc.finish(), tallied)
        })
        .collect();
    let best = |fit: bool| {
        finished
            .iter()
            .filter(|f| f.0 == fit)
            .min_by_key(|f| f.1.len())
    };
    let plain = best(false).expect("the plain stream");
    let chosen = match best(true) {
        Some(f) if (f.1.len() as f64) < (1.0 - FIT_MARGIN) * plain.1.len() as f64 => f,
        _ => plain,
    };
    let (bytes, tallied) = (chosen.1.clone(), chosen.2.clone());
    Ok((
        EncodedBlock {
            bytes,
            kinds,
            output_points,
            elements: n_elements,
            decoded,
            checks,
        },
        tallied,
        close_calls,
    ))
}

/// Decodes the `count` curves of a block into the points the guarantee is
/// about.
///
/// ```
/// use strandfit::codec::{decode_block, encode_block, CodecParams, DecodeError};
/// use strandfit::metrics::hausdorff;
/// # use strandfit::DVec3;
/// # fn helix(r: f64) -> Vec<DVec3> { // a helix of radius r, a point every 0.1 radian
/// #     (0..100).map(|k| 0.1 * k as f64).map(|s| DVec3::new(r * s.cos(), r * s.sin(), 0.8 * s)).collect()
/// # }
///
/// let params = CodecParams::new(0.05);
/// let curves = [helix(3.0), helix(5.0)];
/// let block = encode_block(&curves, &params).unwrap();
/// let back = decode_block(&block.bytes, 2, &params).unwrap();
/// for (a, b) in curves.iter().zip(&back) {
///     assert!(hausdorff(a, b).unwrap() <= 0.05);
/// }
/// // The count is the caller's (the container stores it): the curves
/// // decode in order, so the first `k` come out alone. (A count larger than
/// // was coded is not always caught here, as the decoder reads a few zero
/// // bytes past the end; far past it, the stream is `Truncated` or a curve
/// // decodes badly, an error either way. Damaged bytes are caught by the
/// // container's CRC-32.)
/// assert_eq!(decode_block(&block.bytes, 1, &params).unwrap()[..], back[..1]);
/// assert!(matches!(
///     decode_block(&block.bytes, 100_000, &params),
///     Err(DecodeError::Truncated | DecodeError::Curve { .. })
/// ));
/// ```
pub fn decode_block(
    bytes: &[u8],
    count: usize,
    params: &CodecParams,
) -> Result<Vec<Vec<DVec3>>, DecodeError> {
    let mut dec = Decoder::with_adaptation(bytes, Adaptation::of_model(params.model));
    let mut m = Models::for_model(params.model);
    let mut prev = Previous::default();
    let q = params.quantiser();
    let scale_exp = dec.direct(8) as i32 - 128;
    if sign_after(params.model) {
        let shared = dec.direct(1) == 1;
        m.residual.shared = shared;
        m.ref_residual.shared = shared;
    }
    let fit = params.model >= 15 && dec.direct(1) == 1;
    let grid = quantise::lattice_half(params.tolerance, 2f64.powi(scale_exp)).unwrap_or(0.0);
    // Capacities from counts read off the stream are capped: a count is
    // only trusted as far as the points it actually decodes.
    let mut out = Vec::with_capacity(count.min(1 << 16));
    // Decoded curves on the points grid, for points-mode references.
    let mut neighbours = Neighbours::new(grid, q.start, count);
    for curve in 0..count {
        let bad = |why: String| DecodeError::Curve { curve, why };
        let mut pushed = false;
        let mut chords = reference::ArcChords::default();
        let kind = get_kind(&mut dec, &mut m);
        let pts = match kind {
            0 => Vec::new(),
            3 => {
                let n = m.raw_count.get_unsigned(&mut dec) as usize;
                if n > bytes.len() {
                    return Err(bad(format!(
                        "{n} raw points in a block of {} bytes",
                        bytes.len()
                    )));
                }
                let mut p = Vec::with_capacity(n.min(1 << 16));
                for _ in 0..n {
                    let mut v = [0f64; 3];
                    for x in &mut v {
                        *x = f64::from_bits(dec.direct(64));
                    }
                    p.push(DVec3::from_array(v));
                }
                p
            }
            1 => {
                let n = m.count.get_unsigned(&mut dec) as usize + 1;
                if n > MAX_DECODED_POINTS || n > 8 * bytes.len() + 8 {
                    return Err(bad(format!(
                        "{n} points in a block of {} bytes",
                        bytes.len()
                    )));
                }
                if grid == 0.0 {
                    return Err(bad("points in a block without a lattice".into()));
                }
                let with_reference = !neighbours.is_empty() && dec.bit(&mut m.has_reference);
                let along = along(params.model).then(|| n > 2 && dec.bit(&mut m.along));
                let mut g = neighbours.spare_grid();
                g.reserve(n.min(1 << 16));
                if with_reference {
                    let mut read_ref = |dec: &mut Decoder| -> Result<(usize, bool), DecodeError> {
                        let back = m.back.get_unsigned(dec) as usize + 1;
                        let reversed = dec.bit(&mut m.reversed);
                        if back > neighbours.len() || back > reference::MAX_BACK {
                            return Err(bad(format!("reference {back} curves back")));
                        }
                        Ok((back, reversed))
                    };
                    let first = read_ref(&mut dec)?;
                    let second = if dec.bit(&mut m.has_second) {
                        Some(read_ref(&mut dec)?)
                    } else {
                        None
                    };
                    let walk = Rule::of_model(params.model).walk && dec.bit(&mut m.walk);
                    let grids = neighbours.window();
                    let at_back = |b: usize| &grids[grids.len() - b][..];
                    if at_back(first.0).len() < 2
                        || second.is_some_and(|(b, _)| at_back(b).len() < 2)
                    {
                        return Err(bad("a reference of fewer than two points".into()));
                    }
                    let rf = reference::Reference {
                        back: first.0,
                        reversed: first.1,
                        second,
                        walk,
                    };
                    let res = rf.resolve(grids, Rule::of_model(params.model));
                    let start = res.start();
                    let d = get_lattice(&mut dec, &mut m.parity[0], &mut m.ref_start);
                    g.push([0, 1, 2].map(|a| start[a].wrapping_add(d[a])));
                    let foot = reference::PredictionCache::default();
                    get_residuals(
                        &mut dec,
                        &mut m.ref_residual,
                        along,
                        &mut g,
                        n,
                        |g, k, _| res.predict_next(g, k, n, &foot),
                    );
                } else {
                    let own = if dec.bit(&mut m.helix) {
                        OwnPrediction::Screw
                    } else if params.model >= 13 && dec.bit(&mut m.mean_step) {
                        OwnPrediction::MeanStep
                    } else {
                        OwnPrediction::SecondOrder
                    };
                    let d = get_lattice(&mut dec, &mut m.parity[1], &mut m.point_start);
                    g.push([0, 1, 2].map(|a| prev.point_start[a].wrapping_add(d[a])));
                    // Second order, the commonest, as a loop of its own (its
                    // prediction inlined: a call per point was 3 % of
                    // decoding the fornix replicas).
                    if own == OwnPrediction::SecondOrder {
                        get_residuals(&mut dec, &mut m.residual, along, &mut g, n, |_, k, r| {
                            second_order_of(k, r)
                        });
                    } else {
                        let screw = screw(params.model);
                        get_residuals(&mut dec, &mut m.residual, along, &mut g, n, |g, k, _| {
                            own_prediction(g, k, own, screw)
                        });
                    }
                }
                prev.point_start = g[0];
                let p = g.iter().map(|&k| quantise::bcc_point(k, grid)).collect();
                neighbours.push_lattice(g);
                pushed = true;
                p
            }
            2 => {
                let n = m.count.get_unsigned(&mut dec) as usize;
                if n > 8 * bytes.len() + 8 {
                    return Err(bad(format!(
                        "{n} elements in a block of {} bytes",
                        bytes.len()
                    )));
                }
                let start;
                let mut fe = [0i64; 3];
                let before = neighbours.len();
                let mut anchor = None;
                if before > 0 && dec.bit(&mut m.has_anchor) {
                    let back = m.back_anchor.get_unsigned(&mut dec) as usize + 1;
                    let at_end = dec.bit(&mut m.anchor_end);
                    anchor = Some((back, at_end));
                    if back > before || back > reference::MAX_BACK {
                        return Err(bad(format!("anchor {back} curves back")));
                    }
                    let r = neighbours
                        .anchor(before - back, at_end)
                        .ok_or_else(|| bad("an anchor on an empty curve".into()))?;
                    let d = get_lattice(&mut dec, &mut m.start_parity[0], &mut m.anchor_start);
                    start = [0, 1, 2].map(|a| r[a].wrapping_add(d[a]));
                } else {
                    let d = get_lattice(&mut dec, &mut m.start_parity[1], &mut m.start);
                    start = [0, 1, 2].map(|a| prev.arc_start[a].wrapping_add(d[a]));
                }
                let (fe_pred, walk) = first_end_prediction(
                    &neighbours,
                    before,
                    anchor,
                    &prev,
                    &q,
                    params.model,
                    (fit && anchor.is_some()).then_some(start),
                );
                for a in 0..3 {
                    fe[a] = fe_pred[a].wrapping_add(m.first_end[a].get(&mut dec));
                }
                prev.arc_start = start;
                prev.first_end = fe;
                let q0 = DVec3::new(start[0] as f64, start[1] as f64, start[2] as f64) * q.start;
                let end = first_end(q0, fe, q.first);
                let fb_pred = first_bulge_prediction(walk, q0, end, q.offset);
                let fb = [0, 1].map(|a| fb_pred[a].wrapping_add(m.first_bulge[a].get(&mut dec)));
                let t = corner_from_code(q0, end, DVec3::ZERO, fb, q.offset)
                    .ok_or_else(|| bad("a first element of zero length".into()))?;
                let arc = Arc::new(q0, t, end).map_err(|e| bad(format!("first element: {e:?}")))?;
                let mut p = vec![q0];
                arc.sample_into(q.sagitta, &mut p);
                let mut state = arc.next_state(q.length);
                let mut prev_kind = ElementKind::Corner;
                let mut last = [0i64; 3];
                let mut last_chord = None;
                for k in 0..n {
                    let kind = get_element_kind(&mut dec, &mut m, prev_kind);
                    prev_kind = kind;
                    let ctx = span_context(state.chord_steps);
                    let end = if kind == ElementKind::Jump {
                        last_chord = None;
                        let j = [0, 1, 2].map(|a| m.jump[a].get(&mut dec));
                        jump_end(state.point, j, q.first)
                    } else {
                        let dl = m.length[ctx].get_after(&mut dec, last[0]);
                        let a1 = m.offset[ctx][0].get_after(&mut dec, last[1]);
                        let a2 = m.offset[ctx][1].get_after(&mut dec, last[2]);
                        if sign_after(params.model) {
                            last = [dl, a1, a2];
                        }
                        let steps = state.chord_steps.wrapping_add(dl);
                        last_chord = Some(steps);
                        element_end(&state, steps, a1, a2, &q)
                    };
                    let tangent = match kind {
                        ElementKind::Corner => {
                            let chord = CornerChord::new(state.point, end, state.normal);
                            let base = match chord {
                                Some(c) if bulge_predicted(params.model) => {
                                    c.bulge_prediction(state.tangent, q.offset)
                                }
                                _ => [0, 0],
                            };
                            let b = [0, 1].map(|a| base[a].wrapping_add(m.bulge[a].get(&mut dec)));
                            chord
                                .ok_or_else(|| bad(format!("element {k} has zero length")))?
                                .tangent(b, q.offset)
                        }
                        ElementKind::Straight | ElementKind::Jump => {
                            (end - state.point).normalize()
                        }
                        ElementKind::G1 => state.tangent,
                    };
                    let arc = Arc::new(state.point, tangent, end)
                        .map_err(|e| bad(format!("element {k}: {e:?}")))?;
                    if p.len() + arc.pieces(q.sagitta) > MAX_DECODED_POINTS {
                        return Err(bad(format!("more than {MAX_DECODED_POINTS} points")));
                    }
                    arc.sample_into(q.sagitta, &mut p);
                    state = next_state(&arc, &state, kind, q.length);
                }
                chords = reference::ArcChords {
                    first: Some(fe),
                    last: last_chord,
                };
                p
            }
            _ => unreachable!("two bits"),
        };
        if dec.overrun() {
            return Err(DecodeError::Truncated);
        }
        // Usable points only (finite, within float32, as every reader
        // guarantees): a corrupt stream could decode to anything.
        if !pts.iter().fold(true, |ok, p| ok & crate::io::fits_f32(*p)) {
            for (k, p) in pts.iter().enumerate() {
                if let Some(why) = crate::io::point_problem(*p) {
                    return Err(bad(format!("point {k} decodes badly: {why}")));
                }
            }
        }
        if !pushed {
            neighbours.push_points(pts.clone());
            neighbours.set_chords(chords);
        }
        out.push(pts);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
