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
//! ([`check`]), on exactly the points the decoder will produce, less a
//! margin for writing them as `f32`.
//!
//! # The representation
//!
//! A curve is a start point, then circular arcs, each fixed by its end
//! point ([`predict`]): a *G1* arc inherits the tangent of the previous
//! one, a *corner* arc carries a bulge that sets its own. An end point is
//! coded as its chord length (against the previous chord's) and two
//! perpendicular offsets from where the previous arc, continued, would have
//! gone ([`quantise`] holds the steps). Curves too rough for arcs store
//! their points on a grid of step `2T/√3` with second-order prediction: the
//! quantise-and-delta baseline's own representation, so no curve costs more
//! than that. Integers go through adaptive binary contexts, one model per
//! field ([`entropy`]).
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

pub mod check;
pub mod container;
pub mod encoder;
pub mod entropy;
pub mod predict;
pub mod quantise;
pub mod stream;

use glam::DVec3;
use rayon::prelude::*;

use encoder::{
    acceptance_tolerance, corner_from_code, element_end, first_end, next_state, CurveEncoder,
};
use entropy::{Bit, Decoder, Encoder, IntModel};
use predict::Arc;
use quantise::{Quantiser, Steps};

/// How a block is coded: the tolerance and the steps (both stored in the
/// container's header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CodecParams {
    pub tolerance: f64,
    pub steps: Steps,
}

impl CodecParams {
    pub fn new(tolerance: f64) -> Self {
        CodecParams {
            tolerance,
            steps: Steps::default(),
        }
    }

    fn quantiser(&self) -> Quantiser {
        Quantiser::new(self.tolerance, self.steps)
    }

    /// Grid step of points-mode curves.
    fn grid(&self) -> f64 {
        self.steps.points * self.tolerance
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
}

/// One element's code (see [`predict`] for the geometry).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ElementCode {
    pub kind: ElementKind,
    /// Chord length in length steps, minus the previous element's.
    pub length: i64,
    /// Perpendicular offsets of the end from the prediction, offset steps.
    pub offset: [i64; 2],
    /// Corner bulge (sagitta vector) in offset steps; zero for G1.
    pub bulge: [i64; 2],
}

/// One curve's code.
#[derive(Clone, Debug, PartialEq)]
pub enum CurveCode {
    Empty,
    /// Points on the grid of step `2T/√3` (indices).
    Points {
        grid: Vec<[i64; 3]>,
    },
    /// Start point on the start grid, the first element's end relative to
    /// it on the same grid, its bulge, then the elements.
    Arcs {
        start: [i64; 3],
        first_end: [i64; 3],
        first_bulge: [i64; 2],
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
    NonFinite { curve: usize, point: usize },
    #[error("tolerance {0} is not a positive finite number")]
    BadTolerance(f64),
}

/// Why a block cannot be decoded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DecodeError {
    #[error("curve {curve}: {why}")]
    Curve { curve: usize, why: String },
    #[error("the block's coded stream ends early (truncated or corrupt)")]
    Truncated,
}

/// What [`encode_block`] returns.
#[derive(Debug)]
pub struct EncodedBlock {
    pub bytes: Vec<u8>,
    /// Per curve: how it was coded (0 empty, 1 points, 2 arcs, 3 raw).
    pub kinds: Vec<u8>,
    /// Points the decoder will write, in all.
    pub output_points: usize,
}

/// Upper bound of the points one curve may decode to (a corrupt stream
/// must not make the decoder allocate without bound).
pub const MAX_DECODED_POINTS: usize = 1 << 28;

/// Encodes one curve (no entropy coding): the code and its decoded point
/// count.
pub fn encode_curve(points: &[DVec3], params: &CodecParams) -> (CurveCode, usize) {
    if points.is_empty() {
        return (CurveCode::Empty, 0);
    }
    let tol = acceptance_tolerance(params.tolerance, points);
    let enc = CurveEncoder {
        points,
        q: params.quantiser(),
        tol2: if tol > 0.0 { tol * tol } else { -1.0 },
        grid: params.grid(),
    };
    let raw = || (CurveCode::Raw(points.to_vec()), points.len());
    if tol <= 0.0 {
        return raw();
    }
    let pts = enc.points_code();
    let arcs = if points.len() >= 3 { enc.arcs() } else { None };
    match (arcs, pts) {
        (Some((a, n)), Some(p)) if estimated_bits(&a) < estimated_bits(&p) => (a, n),
        (_, Some(p)) => (p, points.len()),
        (Some((a, n)), None) => (a, n),
        (None, None) => raw(),
    }
}

/// Bits of an Exp-Golomb code of `v` with a sign: a static stand-in for the
/// adaptive coder's cost when choosing between representations.
fn eg_bits(v: i64) -> u64 {
    if v == 0 {
        1
    } else {
        let n = 64 - v.unsigned_abs().leading_zeros() as u64;
        1 + 2 * n
    }
}

fn estimated_bits(code: &CurveCode) -> u64 {
    match code {
        CurveCode::Empty => 2,
        CurveCode::Raw(p) => 192 * p.len() as u64,
        CurveCode::Points { grid } => {
            let mut bits = 8;
            for k in 1..grid.len() {
                for a in 0..3 {
                    let pred = if k >= 2 {
                        2 * grid[k - 1][a] - grid[k - 2][a]
                    } else {
                        grid[k - 1][a]
                    };
                    bits += eg_bits(grid[k][a] - pred);
                }
            }
            bits
        }
        CurveCode::Arcs {
            first_end,
            first_bulge,
            elements,
            ..
        } => {
            let mut bits = 8 + first_end.iter().map(|&v| eg_bits(v)).sum::<u64>();
            bits += first_bulge.iter().map(|&v| eg_bits(v)).sum::<u64>();
            for e in elements {
                bits += 1 + eg_bits(e.length) + eg_bits(e.offset[0]) + eg_bits(e.offset[1]);
                if e.kind != ElementKind::G1 {
                    bits += 1;
                }
                if e.kind == ElementKind::Corner {
                    bits += eg_bits(e.bulge[0]) + eg_bits(e.bulge[1]);
                }
            }
            bits
        }
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
    kink: [Bit; 3],
    corner: [Bit; 3],
    length: IntModel,
    offset: [IntModel; 2],
    bulge: [IntModel; 2],
    residual: [IntModel; 3],
    raw_count: IntModel,
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
    enc.bit(&mut m.kink[prev as usize], kind != ElementKind::G1);
    if kind != ElementKind::G1 {
        enc.bit(&mut m.corner[prev as usize], kind == ElementKind::Corner);
    }
}

fn get_element_kind(dec: &mut Decoder, m: &mut Models, prev: ElementKind) -> ElementKind {
    if !dec.bit(&mut m.kink[prev as usize]) {
        ElementKind::G1
    } else if dec.bit(&mut m.corner[prev as usize]) {
        ElementKind::Corner
    } else {
        ElementKind::Straight
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

/// Encodes curves into one block (curves fitted in parallel, then coded in
/// order).
pub fn encode_block(
    curves: &[Vec<DVec3>],
    params: &CodecParams,
) -> Result<EncodedBlock, EncodeError> {
    if !(params.tolerance.is_finite() && params.tolerance > 0.0) {
        return Err(EncodeError::BadTolerance(params.tolerance));
    }
    for (c, pts) in curves.iter().enumerate() {
        if let Some(k) = pts.iter().position(|p| !p.is_finite()) {
            return Err(EncodeError::NonFinite { curve: c, point: k });
        }
    }
    let codes: Vec<(CurveCode, usize)> = curves
        .par_iter()
        .map(|pts| encode_curve(pts, params))
        .collect();
    let mut enc = Encoder::new();
    let mut m = Models::default();
    let mut prev = Previous::default();
    let mut kinds = Vec::with_capacity(codes.len());
    let mut output_points = 0;
    for (code, n) in &codes {
        output_points += n;
        let kind = kind_of(code);
        kinds.push(kind);
        put_kind(&mut enc, &mut m, kind);
        match code {
            CurveCode::Empty => {}
            CurveCode::Raw(p) => {
                m.raw_count.put_unsigned(&mut enc, p.len() as u64);
                for v in p.iter().flat_map(|v| v.to_array()) {
                    enc.direct(v.to_bits(), 64);
                }
            }
            CurveCode::Points { grid } => {
                m.count.put_unsigned(&mut enc, grid.len() as u64 - 1);
                for a in 0..3 {
                    m.start[a].put(&mut enc, grid[0][a] - prev.point_start[a]);
                }
                prev.point_start = grid[0];
                for k in 1..grid.len() {
                    for a in 0..3 {
                        let pred = if k >= 2 {
                            2 * grid[k - 1][a] - grid[k - 2][a]
                        } else {
                            grid[k - 1][a]
                        };
                        m.residual[a].put(&mut enc, grid[k][a] - pred);
                    }
                }
            }
            CurveCode::Arcs {
                start,
                first_end,
                first_bulge,
                elements,
            } => {
                m.count.put_unsigned(&mut enc, elements.len() as u64);
                for a in 0..3 {
                    m.start[a].put(&mut enc, start[a] - prev.arc_start[a]);
                    m.first_end[a].put(&mut enc, first_end[a] - prev.first_end[a]);
                }
                prev.arc_start = *start;
                prev.first_end = *first_end;
                for a in 0..2 {
                    m.first_bulge[a].put(&mut enc, first_bulge[a]);
                }
                let mut prev_kind = ElementKind::Corner;
                for e in elements {
                    put_element_kind(&mut enc, &mut m, prev_kind, e.kind);
                    prev_kind = e.kind;
                    m.length.put(&mut enc, e.length);
                    m.offset[0].put(&mut enc, e.offset[0]);
                    m.offset[1].put(&mut enc, e.offset[1]);
                    if e.kind == ElementKind::Corner {
                        m.bulge[0].put(&mut enc, e.bulge[0]);
                        m.bulge[1].put(&mut enc, e.bulge[1]);
                    }
                }
            }
        }
    }
    Ok(EncodedBlock {
        bytes: enc.finish(),
        kinds,
        output_points,
    })
}

/// Decodes the `count` curves of a block into the points the guarantee is
/// about.
pub fn decode_block(
    bytes: &[u8],
    count: usize,
    params: &CodecParams,
) -> Result<Vec<Vec<DVec3>>, DecodeError> {
    let mut dec = Decoder::new(bytes);
    let mut m = Models::default();
    let mut prev = Previous::default();
    let q = params.quantiser();
    let grid = params.grid();
    let mut out = Vec::with_capacity(count);
    for curve in 0..count {
        let bad = |why: String| DecodeError::Curve { curve, why };
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
                let mut p = Vec::with_capacity(n);
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
                let mut g = [[0i64; 3]; 2];
                let mut p = Vec::with_capacity(n);
                for a in 0..3 {
                    g[1][a] = prev.point_start[a].wrapping_add(m.start[a].get(&mut dec));
                }
                prev.point_start = g[1];
                p.push(g[1]);
                for k in 1..n {
                    let mut next = [0i64; 3];
                    for a in 0..3 {
                        let pred = if k >= 2 {
                            (2 * g[1][a]).wrapping_sub(g[0][a])
                        } else {
                            g[1][a]
                        };
                        next[a] = pred.wrapping_add(m.residual[a].get(&mut dec));
                    }
                    g = [g[1], next];
                    p.push(next);
                }
                p.iter()
                    .map(|k| DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * grid)
                    .collect()
            }
            2 => {
                let n = m.count.get_unsigned(&mut dec) as usize;
                if n > 8 * bytes.len() + 8 {
                    return Err(bad(format!(
                        "{n} elements in a block of {} bytes",
                        bytes.len()
                    )));
                }
                let mut start = [0i64; 3];
                let mut fe = [0i64; 3];
                for a in 0..3 {
                    start[a] = prev.arc_start[a].wrapping_add(m.start[a].get(&mut dec));
                    fe[a] = prev.first_end[a].wrapping_add(m.first_end[a].get(&mut dec));
                }
                prev.arc_start = start;
                prev.first_end = fe;
                let fb = [
                    m.first_bulge[0].get(&mut dec),
                    m.first_bulge[1].get(&mut dec),
                ];
                let q0 = DVec3::new(start[0] as f64, start[1] as f64, start[2] as f64) * q.start;
                let end = first_end(q0, fe, q.start);
                let t = corner_from_code(q0, end, DVec3::ZERO, fb, q.offset)
                    .ok_or_else(|| bad("a first element of zero length".into()))?;
                let arc = Arc::new(q0, t, end).map_err(|e| bad(format!("first element: {e:?}")))?;
                let mut p = vec![q0];
                arc.sample_into(q.sagitta, &mut p);
                let mut state = arc.next_state(q.length);
                let mut prev_kind = ElementKind::Corner;
                for k in 0..n {
                    let kind = get_element_kind(&mut dec, &mut m, prev_kind);
                    prev_kind = kind;
                    let dl = m.length.get(&mut dec);
                    let a1 = m.offset[0].get(&mut dec);
                    let a2 = m.offset[1].get(&mut dec);
                    let steps = state.chord_steps.wrapping_add(dl);
                    let end = element_end(&state, steps, a1, a2, &q);
                    let tangent = match kind {
                        ElementKind::Corner => {
                            let b = [m.bulge[0].get(&mut dec), m.bulge[1].get(&mut dec)];
                            corner_from_code(state.point, end, state.normal, b, q.offset)
                                .ok_or_else(|| bad(format!("element {k} has zero length")))?
                        }
                        ElementKind::Straight => (end - state.point).normalize(),
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
                p
            }
            _ => unreachable!("two bits"),
        };
        if dec.overrun() {
            return Err(DecodeError::Truncated);
        }
        if let Some(k) = pts.iter().position(|p| !p.is_finite()) {
            return Err(bad(format!("point {k} decodes to a non-finite value")));
        }
        out.push(pts);
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
