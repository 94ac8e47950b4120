//! The `.sfh` container (version 1): piecewise helices, compressed, with the
//! source's metadata. The layout is described on `ContainerWriter`, the
//! reader's checks on `ContainerReader` (and in `docs/container.md`, in full).

use std::io::{Read, Write};
use std::path::Path;

use glam::{DMat4, DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::bytes::{ByteSource, Endian};
use super::{AtomicFile, Format, IoError, Metadata};
use crate::helix::{ChainParams, ElementParams};

/// File magic: non-ASCII first byte, then "SFH", then CR LF SUB LF (as PNG
/// does), so text-mode transfers and truncated-to-text files are caught.
pub const MAGIC: [u8; 8] = *b"\x89SFH\r\n\x1a\n";
/// The container format version written.
pub const VERSION: u16 = 1;
const BLOCK_MAGIC: [u8; 4] = *b"SFHB";
const END_MAGIC: [u8; 4] = *b"SFHE";
/// Curves per block: small enough to bound memory and to localise damage,
/// large enough for deflate to find the repetition between curves.
pub const BLOCK_CURVES: usize = 4096;
/// Largest header or block accepted (a guard against absurd lengths).
const MAX_SECTION: u32 = 1 << 30;

const KIND_EMPTY: u8 = 0;
const KIND_POINTS: u8 = 1;
const KIND_CHAIN: u8 = 2;
const KIND_QCHAIN: u8 = 3;

/// How chain parameters are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Storage {
    /// `f64` chain parameters.
    F64,
    /// `f32` chain parameters.
    F32,
    /// Quantised on per-curve power-of-two grids, delta- and varint-coded.
    Compact,
}

/// The container header (stored as JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// How the chain parameters are stored.
    pub storage: Storage,
    /// The Fréchet tolerance the curves were compressed to, if one was set.
    pub tolerance: Option<f64>,
    /// How element counts were chosen, for the record ("tolerance 0.5").
    pub mode: String,
    /// The input's metadata (format, affine, units, per-curve data names).
    pub source: SourceMeta,
    /// Per-point data names of the input that are not stored (the points
    /// themselves are replaced by helices).
    pub dropped_point_data: Vec<String>,
    /// The program that wrote the file.
    pub written_by: String,
}

/// [`Metadata`] in a serialisable form. Fields at their defaults (no file
/// name, the identity affine, no sizes, no names) are left out of the JSON:
/// on a small tractogram the header is a noticeable share of the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceMeta {
    /// The input's format (e.g. "tck").
    pub format: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// The input's file name, if recorded.
    pub file: Option<String>,
    /// Row-major 4×4.
    #[serde(default = "identity", skip_serializing_if = "is_identity")]
    pub vox_to_world: [[f64; 4]; 4],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// Voxel sizes of the reference image.
    pub voxel_size: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// Dimensions of the reference image.
    pub dimensions: Option<[u32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// Length unit of the coordinates.
    pub units: Option<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    /// Names of the per-curve values.
    pub curve_data_names: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    /// Other header fields of the input, as key–value pairs.
    pub extra: Vec<(String, String)>,
}

fn identity() -> [[f64; 4]; 4] {
    DMat4::IDENTITY.to_cols_array_2d()
}

fn is_identity(m: &[[f64; 4]; 4]) -> bool {
    *m == identity()
}

impl SourceMeta {
    /// The serialisable form of `m`, with the input's file name if given.
    ///
    /// The file's name is kept, not its folder; the affine is stored row by
    /// row:
    ///
    /// ```
    /// use std::path::Path;
    /// use strandfit::io::{Format, Metadata, SourceMeta};
    ///
    /// let mut meta = Metadata::new(Format::Trk);
    /// meta.vox_to_world.w_axis.x = 90.0; // the x translation
    /// let source = SourceMeta::from_metadata(&meta, Some(Path::new("/data/sub-01/af.trk")));
    /// assert_eq!((source.format.as_str(), source.file.as_deref()), ("trk", Some("af.trk")));
    /// assert_eq!(source.vox_to_world[0], [1.0, 0.0, 0.0, 90.0]);
    /// ```
    pub fn from_metadata(m: &Metadata, file: Option<&Path>) -> Self {
        SourceMeta {
            format: m.format.extension().to_string(),
            // The name, not the path: where the input lived is the
            // writer's business, and a path is bytes in every file.
            file: file.map(|f| {
                f.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| f.display().to_string())
            }),
            vox_to_world: m.vox_to_world.transpose().to_cols_array_2d(),
            voxel_size: m.voxel_size,
            dimensions: m.dimensions,
            units: m.units.clone(),
            curve_data_names: m.curve_data_names.clone(),
            extra: m.extra.clone(),
        }
    }

    /// Back to [`Metadata`] for a writer: per-point data are gone; an
    /// unknown format name becomes JSON.
    ///
    /// ```
    /// use strandfit::io::{Format, Metadata, SourceMeta};
    ///
    /// let mut meta = Metadata::new(Format::Trk);
    /// meta.voxel_size = Some([2.0, 2.0, 2.5]);
    /// meta.curve_data_names = vec!["weight".into()];
    /// let mut source = SourceMeta::from_metadata(&meta, None);
    /// assert_eq!(source.to_metadata(), meta);
    /// source.format = "nii".into();
    /// assert_eq!(source.to_metadata().format, Format::Json);
    /// ```
    pub fn to_metadata(&self) -> Metadata {
        let mut m = Metadata::new(Format::from_name(&self.format).unwrap_or(Format::Json));
        m.vox_to_world = DMat4::from_cols_array_2d(&self.vox_to_world).transpose();
        m.voxel_size = self.voxel_size;
        m.dimensions = self.dimensions;
        m.units = self.units.clone();
        m.curve_data_names = self.curve_data_names.clone();
        m.extra = self.extra.clone();
        m
    }
}

/// A chain quantised for [`Storage::Compact`]: integers on per-curve grids
/// of step `ΔL = 2^len_exp` (lengths, start point) and `Δθ = 2^angle_exp`
/// (the turning angles `κL`, and the start frame as a unit quaternion's
/// vector part); `τL` and the twist on `Δθ·2^k`, coarser on gently bent
/// elements (see `coarse_shift`). A curved element keeps `κL ≥ Δθ` so
/// that it stays curved: a straight element carries the reference normal
/// on instead of resetting it, which would reinterpret every later twist.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct QuantChain {
    /// Length grid exponent: lengths on steps of `2^len_exp`.
    pub len_exp: i8,
    /// Angle grid exponent.
    pub angle_exp: i8,
    /// Start point on the length grid.
    pub start: [i64; 3],
    /// Quaternion `(x, y, z)` of the start frame (`w ≥ 0` implied).
    pub frame: [i64; 3],
    /// Per element: `L`, `κL`, `τL`, twist.
    pub elements: Vec<[i64; 4]>,
}

/// Rotation taking the x, y, z axes to the tangent, normal and binormal.
fn frame_quat(t: DVec3, n: DVec3) -> DQuat {
    let b = t.cross(n);
    DQuat::from_mat3(&glam::DMat3::from_cols(t, n, b)).normalize()
}

fn q(x: f64, step: f64) -> i64 {
    (x / step).round() as i64
}

/// How many times coarser than `Δθ` the grid of an element's `τL` and
/// twist is: `2^k` with `k = ⌊log₂(1/φ)⌋` clamped to `[0, 10]`, `φ = κL` the
/// element's (quantised) turning angle. Both move the element's end
/// tangent by about `φ` times their own error (a twist turns the bend's
/// plane; a torsion change tilts it), so on a gently bent element they can
/// be coarser by `1/φ` for the same effect down the chain. Integer
/// arithmetic on the stored `κL`, so encoder and decoder agree exactly.
fn coarse_shift(k_quant: i64, angle_exp: i8) -> i32 {
    if k_quant <= 0 {
        return 10;
    }
    let log2_phi = (63 - k_quant.leading_zeros() as i32) + angle_exp as i32;
    (-log2_phi).clamp(0, 10)
}

impl QuantChain {
    /// Quantise `c` on the grids `2^len_exp` and `2^angle_exp`.
    ///
    /// Lengths on the grid `2⁻⁴`, angles on `2⁻¹⁰`; `τL` of an element
    /// turning by half a radian on a grid twice as coarse:
    ///
    /// ```
    /// use strandfit::io::QuantChain;
    /// use strandfit::helix::{ChainParams, ElementParams};
    /// use strandfit::DVec3;
    ///
    /// let element = ElementParams { length: 1.0, curvature: 0.5, torsion: 0.25, twist: 0.0 };
    /// let chain = ChainParams {
    ///     start: DVec3::new(1.0, 2.0, 3.0),
    ///     tangent: DVec3::X,
    ///     normal: DVec3::Y,
    ///     elements: vec![element; 3],
    /// };
    /// let q = QuantChain::quantize(&chain, -4, -10);
    /// assert_eq!(q.start, [16, 32, 48]);
    /// assert_eq!(q.frame, [0, 0, 0]); // the start frame is the axes
    /// assert_eq!(q.elements[0], [16, 512, 128, 0]); // L, κL, τL, twist
    /// ```
    pub fn quantize(c: &ChainParams, len_exp: i8, angle_exp: i8) -> Self {
        let dl = 2f64.powi(len_exp as i32);
        let da = 2f64.powi(angle_exp as i32);
        let mut rot = frame_quat(c.tangent.normalize(), c.normal.normalize());
        if rot.w < 0.0 {
            rot = -rot;
        }
        let elements = c
            .elements
            .iter()
            .map(|e| {
                let mut k = q(e.curvature * e.length, da);
                if e.curvature > 0.0 && k == 0 {
                    k = 1;
                }
                let dc = da * 2f64.powi(coarse_shift(k, angle_exp));
                [
                    q(e.length, dl),
                    k,
                    q(e.torsion * e.length, dc),
                    q(e.twist, dc),
                ]
            })
            .collect();
        QuantChain {
            len_exp,
            angle_exp,
            start: [q(c.start.x, dl), q(c.start.y, dl), q(c.start.z, dl)],
            frame: [q(rot.x, da), q(rot.y, da), q(rot.z, da)],
            elements,
        }
    }

    /// The chain these integers stand for.
    ///
    /// ```
    /// use strandfit::io::QuantChain;
    /// use strandfit::helix::{ChainParams, ElementParams};
    /// use strandfit::DVec3;
    ///
    /// let element = ElementParams { length: 1.0, curvature: 0.5, torsion: 0.25, twist: 0.0 };
    /// let chain = ChainParams {
    ///     start: DVec3::new(1.0, 2.0, 3.0),
    ///     tangent: DVec3::X,
    ///     normal: DVec3::Y,
    ///     elements: vec![element; 3],
    /// };
    /// let mut bent = chain.clone();
    /// bent.elements[1].length = 1.01; // off the length grid 2⁻⁴
    /// let back = QuantChain::quantize(&bent, -4, -10).dequantize();
    /// assert_eq!(back.start, chain.start);
    /// assert!(back.tangent.distance(DVec3::X) < 1e-12);
    /// let e = back.elements[1];
    /// assert_eq!(e.length, 1.0);
    /// assert!((e.curvature * e.length - 0.505).abs() < 1e-3); // the turning angle κL is kept
    /// ```
    pub fn dequantize(&self) -> ChainParams {
        let dl = 2f64.powi(self.len_exp as i32);
        let da = 2f64.powi(self.angle_exp as i32);
        let v = DVec3::new(
            self.frame[0] as f64 * da,
            self.frame[1] as f64 * da,
            self.frame[2] as f64 * da,
        );
        let w = (1.0 - v.length_squared()).max(0.0).sqrt();
        let rot = DQuat::from_xyzw(v.x, v.y, v.z, w).normalize();
        let elements = self
            .elements
            .iter()
            .map(|&[l, k, t, tw]| {
                let length = l as f64 * dl;
                let dc = da * 2f64.powi(coarse_shift(k, self.angle_exp));
                let (curvature, torsion) = if length > 0.0 {
                    (k as f64 * da / length, t as f64 * dc / length)
                } else {
                    (0.0, 0.0)
                };
                ElementParams {
                    length,
                    curvature,
                    torsion,
                    twist: tw as f64 * dc,
                }
            })
            .collect();
        ChainParams {
            start: DVec3::new(
                self.start[0] as f64 * dl,
                self.start[1] as f64 * dl,
                self.start[2] as f64 * dl,
            ),
            tangent: rot * DVec3::X,
            normal: rot * DVec3::Y,
            elements,
        }
    }
}

/// What a curve record holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A curve without points.
    Empty,
    /// Stored verbatim (one-point curves, curves that could not be fitted).
    Points(Vec<DVec3>),
    /// A chain (`f64`/`f32` storage, or dequantised on reading).
    Chain(ChainParams),
    /// A quantised chain (writing in [`Storage::Compact`] only).
    Quantized(QuantChain),
}

/// One curve of the container.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredCurve {
    /// The curve's identifier, if the input had one.
    pub id: Option<String>,
    /// Points of the input curve, so that decompression can give back as
    /// many by default.
    pub source_points: u64,
    /// Per-curve values named in the header.
    pub curve_data: Vec<f32>,
    /// The curve's geometry.
    pub shape: Shape,
}

// ---------------------------------------------------------------- encoding

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn unzigzag(u: u64) -> i64 {
    ((u >> 1) as i64) ^ -((u & 1) as i64)
}

fn put_real(out: &mut Vec<u8>, x: f64, storage: Storage) {
    match storage {
        Storage::F64 => out.extend_from_slice(&x.to_le_bytes()),
        _ => out.extend_from_slice(&(x as f32).to_le_bytes()),
    }
}

fn put_vec(out: &mut Vec<u8>, v: DVec3, storage: Storage) {
    for x in v.to_array() {
        put_real(out, x, storage);
    }
}

/// Streams of a block: the record heads (kind, id, counts, per-curve data,
/// verbatim points, grids), the start points and frames, and one stream per
/// element field (length, `κL`, `τL`, twist). Like values side by side
/// compress better than interleaved records: on the fornix at 0.5 mm the
/// file is 3.6 % smaller than with row-wise records (14,007 vs 14,529 B).
const STREAMS: usize = 6;
const S_HEAD: usize = 0;
const S_START: usize = 1;
const S_ELEM: usize = 2;

fn encode(out: &mut [Vec<u8>; STREAMS], c: &StoredCurve, storage: Storage) -> Result<(), String> {
    let kind = match (&c.shape, storage) {
        (Shape::Empty, _) => KIND_EMPTY,
        (Shape::Points(_), _) => KIND_POINTS,
        (Shape::Chain(_), Storage::Compact) => {
            return Err("a compact container stores quantised chains".into())
        }
        (Shape::Chain(_), _) => KIND_CHAIN,
        (Shape::Quantized(_), Storage::Compact) => KIND_QCHAIN,
        (Shape::Quantized(_), _) => return Err("a quantised chain needs compact storage".into()),
    };
    let head = &mut out[S_HEAD];
    head.push(kind);
    match &c.id {
        None => put_varint(head, 0),
        Some(id) => {
            put_varint(head, id.len() as u64 + 1);
            head.extend_from_slice(id.as_bytes());
        }
    }
    put_varint(head, c.source_points);
    for v in &c.curve_data {
        head.extend_from_slice(&v.to_le_bytes());
    }
    // Verbatim points: f64 unless the container is f32 or compact.
    let point_storage = if storage == Storage::F64 {
        Storage::F64
    } else {
        Storage::F32
    };
    match &c.shape {
        Shape::Empty => {}
        Shape::Points(p) => {
            put_varint(head, p.len() as u64);
            for &x in p {
                put_vec(head, x, point_storage);
            }
        }
        Shape::Chain(ch) => {
            put_varint(head, ch.elements.len() as u64);
            put_vec(&mut out[S_START], ch.start, storage);
            put_vec(&mut out[S_START], ch.tangent, storage);
            put_vec(&mut out[S_START], ch.normal, storage);
            for e in &ch.elements {
                for (k, x) in [e.length, e.curvature, e.torsion, e.twist]
                    .into_iter()
                    .enumerate()
                {
                    put_real(&mut out[S_ELEM + k], x, storage);
                }
            }
        }
        Shape::Quantized(qc) => {
            put_varint(head, qc.elements.len() as u64);
            head.push(qc.len_exp as u8);
            head.push(qc.angle_exp as u8);
            for v in qc.start.iter().chain(&qc.frame) {
                put_varint(&mut out[S_START], zigzag(*v));
            }
            // Lengths, κL and τL change slowly along a chain (equal arc-
            // length break points): deltas. Twists do not: raw.
            let mut prev = [0i64; 3];
            for e in &qc.elements {
                for k in 0..3 {
                    put_varint(&mut out[S_ELEM + k], zigzag(e[k].wrapping_sub(prev[k])));
                    prev[k] = e[k];
                }
                put_varint(&mut out[S_ELEM + 3], zigzag(e[3]));
            }
        }
    }
    Ok(())
}

/// Bytes `c` takes in a block before deflate (its record in all streams),
/// to compare ways of storing a curve.
///
/// A two-point verbatim curve: kind, id, source points and point count
/// (a byte each), then 2 × 3 coordinates as `f32` or `f64`:
///
/// ```
/// use strandfit::io::{encoded_size, Shape, Storage, StoredCurve};
/// use strandfit::DVec3;
///
/// let curve = StoredCurve {
///     id: None,
///     source_points: 2,
///     curve_data: vec![],
///     shape: Shape::Points(vec![DVec3::ZERO, DVec3::X]),
/// };
/// assert_eq!(encoded_size(&curve, Storage::F32), Ok(4 + 6 * 4));
/// assert_eq!(encoded_size(&curve, Storage::F64), Ok(4 + 6 * 8));
/// ```
pub fn encoded_size(c: &StoredCurve, storage: Storage) -> Result<usize, String> {
    let mut out: [Vec<u8>; STREAMS] = Default::default();
    encode(&mut out, c, storage)?;
    Ok(out.iter().map(Vec::len).sum())
}

/// A cursor over a decompressed block, with errors that say what was cut.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        if self.b.len() - self.pos < n {
            return Err(format!("record ends inside {what}"));
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.take(1, what)?[0])
    }
    fn varint(&mut self, what: &str) -> Result<u64, String> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8(what)?;
            v |= ((b & 0x7f) as u64) << shift;
            if b < 0x80 {
                return Ok(v);
            }
        }
        Err(format!("{what}: varint longer than 64 bits"))
    }
    /// A count, checked against the bytes left (each item needs at least
    /// `min_bytes`), so a corrupt count cannot size an allocation.
    fn count(&mut self, min_bytes: usize, what: &str) -> Result<usize, String> {
        let n = self.varint(what)?;
        let left = (self.b.len() - self.pos) as u64;
        if n.saturating_mul(min_bytes as u64) > left {
            return Err(format!("{what} {n} exceeds the record"));
        }
        Ok(n as usize)
    }
    /// A count read from `head`, checked against the bytes left in this
    /// stream (each item needs at least `min_bytes` of it).
    fn count_of(&self, head: &mut Cursor, min_bytes: usize, what: &str) -> Result<usize, String> {
        let n = head.varint(what)?;
        let left = (self.b.len() - self.pos) as u64;
        if n.saturating_mul(min_bytes as u64) > left {
            return Err(format!("{what} {n} exceeds the record"));
        }
        Ok(n as usize)
    }

    fn f32(&mut self, what: &str) -> Result<f32, String> {
        let b = self.take(4, what)?;
        Ok(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn real(&mut self, storage: Storage, what: &str) -> Result<f64, String> {
        let x = match storage {
            Storage::F64 => {
                let mut a = [0u8; 8];
                a.copy_from_slice(self.take(8, what)?);
                f64::from_le_bytes(a)
            }
            _ => self.f32(what)? as f64,
        };
        if !x.is_finite() {
            return Err(format!("{what} is not finite"));
        }
        Ok(x)
    }
    fn vec(&mut self, storage: Storage, what: &str) -> Result<DVec3, String> {
        Ok(DVec3::new(
            self.real(storage, what)?,
            self.real(storage, what)?,
            self.real(storage, what)?,
        ))
    }
    fn zz(&mut self, what: &str) -> Result<i64, String> {
        Ok(unzigzag(self.varint(what)?))
    }
}

fn decode(
    cs: &mut [Cursor; STREAMS],
    storage: Storage,
    n_curve_data: usize,
) -> Result<StoredCurve, String> {
    let [c, st, el0, el1, el2, el3] = cs;
    let kind = c.u8("the curve kind")?;
    let id = match c.count(1, "the id length")? {
        0 => None,
        n => Some(
            String::from_utf8(c.take(n - 1, "the id")?.to_vec())
                .map_err(|_| "the id is not UTF-8".to_string())?,
        ),
    };
    let source_points = c.varint("the source point count")?;
    let mut curve_data = Vec::with_capacity(n_curve_data);
    for _ in 0..n_curve_data {
        curve_data.push(c.f32("the per-curve data")?);
    }
    let point_storage = if storage == Storage::F64 {
        Storage::F64
    } else {
        Storage::F32
    };
    let psize = if point_storage == Storage::F64 {
        24
    } else {
        12
    };
    let shape = match kind {
        KIND_EMPTY => Shape::Empty,
        KIND_POINTS => {
            let n = c.count(psize, "the point count")?;
            let mut p = Vec::with_capacity(n);
            for k in 0..n {
                let x = c.vec(point_storage, "a point")?;
                if let Some(why) = crate::io::point_problem(x) {
                    return Err(format!("point {k}: {why}"));
                }
                p.push(x);
            }
            Shape::Points(p)
        }
        KIND_CHAIN if storage != Storage::Compact => {
            let size = if storage == Storage::F64 { 8 } else { 4 };
            let n = el0.count_of(c, size, "the element count")?;
            let start = st.vec(storage, "the start point")?;
            let tangent = st.vec(storage, "the start tangent")?;
            let normal = st.vec(storage, "the start normal")?;
            let mut elements = Vec::with_capacity(n);
            for _ in 0..n {
                let length = el0.real(storage, "an element length")?;
                let curvature = el1.real(storage, "a curvature")?;
                let torsion = el2.real(storage, "a torsion")?;
                let twist = el3.real(storage, "a twist")?;
                if length < 0.0 || curvature < 0.0 {
                    return Err("an element with negative length or curvature".into());
                }
                elements.push(ElementParams {
                    length,
                    curvature,
                    torsion,
                    twist,
                });
            }
            if tangent.length() < 0.5 || normal.length() < 0.5 {
                return Err("a start frame that is not unit".into());
            }
            let ch = ChainParams {
                start,
                tangent,
                normal,
                elements,
            };
            check_chain(&ch)?;
            Shape::Chain(ch)
        }
        KIND_QCHAIN if storage == Storage::Compact => {
            let n = el0.count_of(c, 1, "the element count")?;
            let len_exp = c.u8("the length grid")? as i8;
            let angle_exp = c.u8("the angle grid")? as i8;
            if !(-60..=60).contains(&len_exp) || !(-60..=0).contains(&angle_exp) {
                return Err(format!(
                    "grid exponents {len_exp}, {angle_exp} out of range"
                ));
            }
            let mut start = [0i64; 3];
            let mut frame = [0i64; 3];
            for v in start.iter_mut().chain(frame.iter_mut()) {
                *v = st.zz("the start point and frame")?;
            }
            let mut elements = Vec::with_capacity(n);
            let mut prev = [0i64; 3];
            for _ in 0..n {
                let mut e = [0i64; 4];
                for (k, s) in [&mut *el0, &mut *el1, &mut *el2].into_iter().enumerate() {
                    e[k] = prev[k].wrapping_add(s.zz("an element")?);
                    prev[k] = e[k];
                }
                e[3] = el3.zz("a twist")?;
                if e[0] < 0 || e[1] < 0 {
                    return Err("an element with negative length or curvature".into());
                }
                elements.push(e);
            }
            let qc = QuantChain {
                len_exp,
                angle_exp,
                start,
                frame,
                elements,
            };
            let ch = qc.dequantize();
            if !ch.start.is_finite() || ch.elements.iter().any(|e| !e.length.is_finite()) {
                return Err("a quantised chain out of range".into());
            }
            check_chain(&ch)?;
            Shape::Chain(ch)
        }
        k => return Err(format!("unknown curve kind {k} for {storage:?} storage")),
    };
    Ok(StoredCurve {
        id,
        source_points,
        curve_data,
        shape,
    })
}

/// Largest turning angle (`κL`, `|τL|`, radians) of one element, and
/// largest curvature and torsion: far beyond any fitted chain (a million
/// radians is 160,000 turns in one element), and small enough that the
/// helix formulas (`κ² + τ²`, `sin(ωs)`) stay finite.
const MAX_TURNING: f64 = 1e6;
const MAX_RATE: f64 = 1e150;

/// A decoded chain must sample to usable points (see
/// [`crate::io::point_problem`]): every sample lies within the chain's
/// length of its start, so a start that far inside the float32 range keeps
/// all of them in it; and its elements' rates and turnings must keep the
/// helix formulas finite.
fn check_chain(ch: &ChainParams) -> Result<(), String> {
    let length: f64 = ch.elements.iter().map(|e| e.length).sum();
    let reach = |x: f64| x.abs() + length <= crate::io::MAX_COORDINATE;
    if !ch.start.to_array().into_iter().all(reach) {
        return Err(format!(
            "a chain from {} of length {length:e} reaches beyond the float32 range",
            ch.start
        ));
    }
    for (k, e) in ch.elements.iter().enumerate() {
        let ok = e.curvature <= MAX_RATE
            && e.torsion.abs() <= MAX_RATE
            && e.curvature * e.length <= MAX_TURNING
            && (e.torsion * e.length).abs() <= MAX_TURNING
            && e.twist.is_finite();
        if !ok {
            return Err(format!(
                "element {k} (curvature {:e}, torsion {:e}, length {:e}) turns too fast to evaluate",
                e.curvature, e.torsion, e.length
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------- writing

/// The file head both container versions start with: magic, `version`,
/// flags 0, the header JSON's inflated and stored lengths, the CRC-32 of
/// the stored bytes, and the header itself as raw DEFLATE (a .trk source's
/// 1000-byte header, kept as hex, would otherwise cost 2 KB per file).
pub(crate) fn file_head(version: u16, json: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(json)?;
    let stored = z.finish()?;
    let mut head = Vec::with_capacity(stored.len() + 24);
    head.extend_from_slice(&MAGIC);
    head.extend_from_slice(&version.to_le_bytes());
    head.extend_from_slice(&0u16.to_le_bytes());
    head.extend_from_slice(&(json.len() as u32).to_le_bytes());
    head.extend_from_slice(&(stored.len() as u32).to_le_bytes());
    head.extend_from_slice(&crc32fast::hash(&stored).to_le_bytes());
    head.extend_from_slice(&stored);
    Ok(head)
}

/// Streams curves into a container; [`finish`](Self::finish) writes the
/// last block and the end record and renames the file into place.
///
/// # Layout
///
/// The `.sfh` container: piecewise helices, compressed, with the source's
/// metadata. The layout is documented in `docs/container.md`; in short:
///
/// ```text
/// magic "\x89SFH\r\n\x1a\n" · version u16 · flags u16
/// header: u32 JSON length · u32 stored length · u32 CRC-32 of the stored bytes
///         · deflated JSON (storage, tolerance, source metadata)
/// blocks: "SFHB" · u32 curves · u32 raw length · u32 stored length · u8 encoding
///         · 3 zero bytes · u32 CRC-32 of the stored bytes · stored bytes, which
///         inflate to a table of 6 stream lengths and the 6 streams
/// end:    "SFHE" · u64 curves · u32 CRC-32 of the block CRCs
/// ```
///
/// A block holds up to [`CONTAINER_BLOCK_CURVES`](BLOCK_CURVES) curve records,
/// deflated. A curve is empty, a verbatim polyline (one-point curves and curves
/// that could not be fitted), or a chain in its compact form ([`ChainParams`]:
/// start point and frame, then length, curvature, torsion and twist per
/// element) stored as `f64`, `f32`, or quantised ([`Storage::Compact`], see
/// [`QuantChain`]).
pub struct ContainerWriter {
    out: AtomicFile,
    header: Header,
    raw: [Vec<u8>; STREAMS],
    in_block: u32,
    curves: u64,
    crcs: crc32fast::Hasher,
    /// Bytes written so far (the compressed size, for reports).
    bytes: u64,
}

impl ContainerWriter {
    /// Create a container at `path` with `header`.
    ///
    /// ```
    /// use strandfit::io::{is_container, ContainerHeader, ContainerWriter, Format, Metadata, SourceMeta, Storage};
    ///
    /// let path = std::env::temp_dir().join(format!("strandfit-doc-sfh-create-{}.sfh", std::process::id()));
    /// let header = ContainerHeader {
    ///     storage: Storage::F32,
    ///     tolerance: None,
    ///     mode: "doc".into(),
    ///     source: SourceMeta::from_metadata(&Metadata::new(Format::Tck), None),
    ///     dropped_point_data: vec![],
    ///     written_by: "doc".into(),
    /// };
    /// let bytes = ContainerWriter::create(&path, header).unwrap().finish().unwrap();
    /// assert!(is_container(&path));
    /// assert_eq!(std::fs::metadata(&path).unwrap().len(), bytes);
    /// std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn create(path: &Path, header: Header) -> Result<Self, IoError> {
        let mut out = AtomicFile::create(path)?;
        let json = serde_json::to_vec(&header)
            .map_err(|e| IoError::new(path, format!("cannot encode the header: {e}")))?;
        let head = file_head(VERSION, &json).map_err(|e| out.err(e))?;
        out.write_all(&head).map_err(|e| out.err(e))?;
        Ok(ContainerWriter {
            out,
            bytes: head.len() as u64,
            header,
            raw: Default::default(),
            in_block: 0,
            curves: 0,
            crcs: crc32fast::Hasher::new(),
        })
    }

    /// The header being written.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Append one curve.
    ///
    /// A curve whose per-curve values do not match the header's names is
    /// refused, and the writer goes on:
    ///
    /// ```
    /// use strandfit::io::{ContainerHeader, ContainerWriter, Format, Metadata, Shape, SourceMeta, Storage, StoredCurve};
    ///
    /// let path = std::env::temp_dir().join(format!("strandfit-doc-sfh-write-{}.sfh", std::process::id()));
    /// let header = ContainerHeader {
    ///     storage: Storage::F32,
    ///     tolerance: None,
    ///     mode: "doc".into(),
    ///     source: SourceMeta::from_metadata(&Metadata::new(Format::Tck), None),
    ///     dropped_point_data: vec![],
    ///     written_by: "doc".into(),
    /// };
    /// let mut w = ContainerWriter::create(&path, header).unwrap();
    /// let curve = StoredCurve { id: None, source_points: 0, curve_data: vec![1.0], shape: Shape::Empty };
    /// let err = w.write(&curve).unwrap_err();
    /// assert_eq!(err.reason, "1 per-curve values where the header names 0");
    /// w.write(&StoredCurve { curve_data: vec![], ..curve }).unwrap();
    /// w.finish().unwrap();
    /// std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn write(&mut self, c: &StoredCurve) -> Result<(), IoError> {
        let err = |r: String| IoError::new(self.out.target(), r).curve(self.curves);
        if c.curve_data.len() != self.header.source.curve_data_names.len() {
            return Err(err(format!(
                "{} per-curve values where the header names {}",
                c.curve_data.len(),
                self.header.source.curve_data_names.len()
            )));
        }
        // Never write what cannot be read: the record is decoded back from
        // the bytes just encoded, and on failure taken out again.
        let before: [usize; STREAMS] = std::array::from_fn(|k| self.raw[k].len());
        let checked = encode(&mut self.raw, c, self.header.storage).and_then(|()| {
            let raw = &self.raw;
            let mut cs: [Cursor; STREAMS] = std::array::from_fn(|k| Cursor {
                b: &raw[k],
                pos: before[k],
            });
            let n_cd = self.header.source.curve_data_names.len();
            decode(&mut cs, self.header.storage, n_cd)
                .map_err(|e| format!("the record would not read back ({e})"))?;
            if (0..STREAMS).any(|k| cs[k].pos != raw[k].len()) {
                return Err("the record would not read back (bytes left over)".into());
            }
            Ok(())
        });
        if let Err(e) = checked {
            for (st, &n) in self.raw.iter_mut().zip(&before) {
                st.truncate(n);
            }
            return Err(err(e));
        }
        self.curves += 1;
        self.in_block += 1;
        let size: usize = self.raw.iter().map(Vec::len).sum();
        if self.in_block as usize >= BLOCK_CURVES || size >= 8 << 20 {
            self.flush_block()?;
        }
        Ok(())
    }

    fn flush_block(&mut self) -> Result<(), IoError> {
        if self.in_block == 0 {
            return Ok(());
        }
        // The stream table (each stream's length), then the streams.
        let mut raw =
            Vec::with_capacity(4 * STREAMS + self.raw.iter().map(Vec::len).sum::<usize>());
        for st in &self.raw {
            raw.extend_from_slice(&(st.len() as u32).to_le_bytes());
        }
        for st in &self.raw {
            raw.extend_from_slice(st);
        }
        let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
        z.write_all(&raw).map_err(|e| self.out.err(e))?;
        let stored = z.finish().map_err(|e| self.out.err(e))?;
        let crc = crc32fast::hash(&stored);
        self.crcs.update(&crc.to_le_bytes());
        let mut head = Vec::with_capacity(24);
        head.extend_from_slice(&BLOCK_MAGIC);
        head.extend_from_slice(&self.in_block.to_le_bytes());
        head.extend_from_slice(&(raw.len() as u32).to_le_bytes());
        head.extend_from_slice(&(stored.len() as u32).to_le_bytes());
        head.extend_from_slice(&[1, 0, 0, 0]); // encoding 1 = deflate
        head.extend_from_slice(&crc.to_le_bytes());
        self.out.write_all(&head).map_err(|e| self.out.err(e))?;
        self.out.write_all(&stored).map_err(|e| self.out.err(e))?;
        self.bytes += (head.len() + stored.len()) as u64;
        for st in &mut self.raw {
            st.clear();
        }
        self.in_block = 0;
        Ok(())
    }

    /// Complete and commit the file; returns its size in bytes.
    ///
    /// ```
    /// use strandfit::io::{ContainerHeader, ContainerReader, ContainerWriter, Format, Metadata, Shape, SourceMeta, Storage, StoredCurve};
    /// use strandfit::DVec3;
    ///
    /// let path = std::env::temp_dir().join(format!("strandfit-doc-sfh-finish-{}.sfh", std::process::id()));
    /// let header = ContainerHeader {
    ///     storage: Storage::F32,
    ///     tolerance: None,
    ///     mode: "doc".into(),
    ///     source: SourceMeta::from_metadata(&Metadata::new(Format::Tck), None),
    ///     dropped_point_data: vec![],
    ///     written_by: "doc".into(),
    /// };
    /// let mut w = ContainerWriter::create(&path, header).unwrap();
    /// for k in 0..3 {
    ///     let shape = Shape::Points(vec![DVec3::ZERO, DVec3::splat(k as f64)]);
    ///     w.write(&StoredCurve { id: None, source_points: 2, curve_data: vec![], shape }).unwrap();
    /// }
    /// let bytes = w.finish().unwrap();
    /// assert_eq!(std::fs::metadata(&path).unwrap().len(), bytes);
    /// assert_eq!(ContainerReader::open(&path).unwrap().count(), 3);
    /// std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn finish(mut self) -> Result<u64, IoError> {
        self.flush_block()?;
        let mut end = Vec::with_capacity(16);
        end.extend_from_slice(&END_MAGIC);
        end.extend_from_slice(&self.curves.to_le_bytes());
        end.extend_from_slice(&self.crcs.clone().finalize().to_le_bytes());
        self.out.write_all(&end).map_err(|e| self.out.err(e))?;
        self.out.commit()?;
        Ok(self.bytes + end.len() as u64)
    }
}

// ---------------------------------------------------------------- reading

/// Streams the curves of a container, block by block (the layout is
/// described on [`ContainerWriter`]).
///
/// # Checks
///
/// Every read is checked: magic, version, lengths against the file size,
/// CRC-32 of the header and of every block, the decoded record lengths, and
/// the end record's count. Truncation or corruption is an error naming the
/// file, the block and the curve — never a panic or a wrong curve.
pub struct ContainerReader {
    src: ByteSource,
    header: Header,
    block: Vec<u8>,
    /// Each stream's range in `block`, and the read position in it.
    ranges: [(usize, usize); STREAMS],
    pos: [usize; STREAMS],
    left_in_block: u32,
    block_index: u64,
    curve: u64,
    crcs: crc32fast::Hasher,
    done: bool,
}

impl ContainerReader {
    /// Open a container and read its header.
    ///
    /// ```
    /// use strandfit::io::ContainerReader;
    ///
    /// let path = std::env::temp_dir().join(format!("strandfit-doc-sfh-open-{}.sfh", std::process::id()));
    /// std::fs::write(&path, b"mrtrix tracks\n").unwrap();
    /// let err = ContainerReader::open(&path).err().unwrap();
    /// std::fs::remove_file(&path).unwrap();
    /// assert_eq!(err.reason, "not a strandfit container (wrong magic number)");
    /// ```
    pub fn open(path: &Path) -> Result<Self, IoError> {
        let mut src = ByteSource::open(path)?;
        let magic = src.array::<8>("the magic number")?;
        if magic != MAGIC {
            return Err(
                IoError::new(path, "not a strandfit container (wrong magic number)").at("byte 0"),
            );
        }
        let version = src.u16(Endian::Little, "the version")?;
        if version != VERSION {
            return Err(src.error(format!(
                "container version {version}; this build reads version {VERSION}"
            )));
        }
        let flags = src.u16(Endian::Little, "the flags")?;
        if flags != 0 {
            return Err(src.error(format!("unknown flags {flags:#x} (reserved, must be 0)")));
        }
        let raw_len = src.u32(Endian::Little, "the header length")?;
        let len = src.u32(Endian::Little, "the header length")?;
        let crc = src.u32(Endian::Little, "the header checksum")?;
        if len > MAX_SECTION || raw_len > MAX_SECTION || len as u64 > src.remaining() {
            return Err(src.error(format!(
                "header length {len} ({raw_len} inflated) exceeds the file ({} bytes left)",
                src.remaining()
            )));
        }
        let mut stored = vec![0u8; len as usize];
        src.read_exact(&mut stored, "the header")?;
        if crc32fast::hash(&stored) != crc {
            return Err(
                IoError::new(path, "header checksum mismatch (the file is corrupt)").at("header"),
            );
        }
        let mut json = Vec::new();
        flate2::read::DeflateDecoder::new(&stored[..])
            .take(raw_len as u64 + 1)
            .read_to_end(&mut json)
            .map_err(|e| {
                IoError::new(path, format!("cannot inflate the header: {e}")).at("header")
            })?;
        if json.len() != raw_len as usize {
            return Err(
                IoError::new(path, "header inflates to the wrong length (corrupt file)")
                    .at("header"),
            );
        }
        let header: Header = serde_json::from_slice(&json)
            .map_err(|e| IoError::new(path, format!("unreadable header: {e}")).at("header"))?;
        Ok(ContainerReader {
            src,
            header,
            block: Vec::new(),
            ranges: [(0, 0); STREAMS],
            pos: [0; STREAMS],
            left_in_block: 0,
            block_index: 0,
            curve: 0,
            crcs: crc32fast::Hasher::new(),
            done: false,
        })
    }

    /// The container's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        self.src.path()
    }

    fn err(&self, reason: impl Into<String>) -> IoError {
        IoError::new(self.src.path(), reason)
            .curve(self.curve)
            .at(format!("block {}", self.block_index))
    }

    /// Load the next block; `false` at the end record.
    fn next_block(&mut self) -> Result<bool, IoError> {
        let magic = self.src.array::<4>("the next block").map_err(|e| {
            IoError::new(
                self.src.path(),
                format!("{}: no end record (truncated?)", e.reason),
            )
            .at(format!("block {}", self.block_index))
        })?;
        if magic == END_MAGIC {
            let n = u64::from_le_bytes(self.src.array::<8>("the end record")?);
            let crc = self.src.u32(Endian::Little, "the end record")?;
            if n != self.curve {
                return Err(self.err(format!(
                    "the end record counts {n} curves, the blocks hold {}",
                    self.curve
                )));
            }
            if crc != self.crcs.clone().finalize() {
                return Err(self.err("block checksum list mismatch (blocks reordered or lost?)"));
            }
            return Ok(false);
        }
        if magic != BLOCK_MAGIC {
            return Err(self.err("expected a block or the end record (corrupt file)"));
        }
        let curves = self.src.u32(Endian::Little, "a block header")?;
        let raw_len = self.src.u32(Endian::Little, "a block header")?;
        let stored_len = self.src.u32(Endian::Little, "a block header")?;
        let enc = self.src.array::<4>("a block header")?;
        let crc = self.src.u32(Endian::Little, "a block header")?;
        if stored_len > MAX_SECTION || stored_len as u64 > self.src.remaining() {
            return Err(self.err(format!(
                "block of {stored_len} bytes exceeds the file ({} bytes left)",
                self.src.remaining()
            )));
        }
        if raw_len > MAX_SECTION || curves == 0 || curves as usize > BLOCK_CURVES.max(1 << 20) {
            return Err(self.err(format!(
                "implausible block header ({curves} curves, {raw_len} bytes)"
            )));
        }
        if enc[1..] != [0, 0, 0] {
            return Err(self.err("non-zero reserved bytes in a block header (corrupt file)"));
        }
        let mut stored = vec![0u8; stored_len as usize];
        self.src.read_exact(&mut stored, "a block")?;
        if crc32fast::hash(&stored) != crc {
            return Err(self.err("block checksum mismatch (the file is corrupt)"));
        }
        self.crcs.update(&crc.to_le_bytes());
        self.block.clear();
        match enc[0] {
            0 => self.block = stored,
            1 => {
                let mut z = flate2::read::DeflateDecoder::new(&stored[..]).take(raw_len as u64 + 1);
                z.read_to_end(&mut self.block)
                    .map_err(|e| self.err(format!("cannot inflate the block: {e}")))?;
            }
            e => return Err(self.err(format!("unknown block encoding {e}"))),
        }
        if self.block.len() != raw_len as usize {
            return Err(self.err(format!(
                "block inflates to {} bytes, its header says {raw_len}",
                self.block.len()
            )));
        }
        // The stream table.
        let mut at = 4 * STREAMS;
        if self.block.len() < at {
            return Err(self.err("block shorter than its stream table"));
        }
        for k in 0..STREAMS {
            let b = &self.block[4 * k..4 * k + 4];
            let len = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize;
            if len > self.block.len() - at {
                return Err(self.err("stream table overruns the block"));
            }
            self.ranges[k] = (at, at + len);
            self.pos[k] = at;
            at += len;
        }
        if at != self.block.len() {
            return Err(self.err("stream table does not cover the block"));
        }
        self.left_in_block = curves;
        self.block_index += 1;
        Ok(true)
    }

    fn next_curve(&mut self) -> Result<Option<StoredCurve>, IoError> {
        if self.left_in_block == 0 {
            if (0..STREAMS).any(|k| self.pos[k] != self.ranges[k].1) {
                return Err(self.err("bytes left over after the block's last curve"));
            }
            if !self.next_block()? {
                return Ok(None);
            }
        }
        let block = &self.block;
        let mut cs: [Cursor; STREAMS] = std::array::from_fn(|k| Cursor {
            b: &block[..self.ranges[k].1],
            pos: self.pos[k],
        });
        let n_cd = self.header.source.curve_data_names.len();
        let r = decode(&mut cs, self.header.storage, n_cd);
        let pos: [usize; STREAMS] = std::array::from_fn(|k| cs[k].pos);
        let curve = r.map_err(|e| self.err(e))?;
        self.pos = pos;
        self.left_in_block -= 1;
        self.curve += 1;
        Ok(Some(curve))
    }
}

impl Iterator for ContainerReader {
    type Item = Result<StoredCurve, IoError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.next_curve();
        super::fuse(&mut self.done, r)
    }
}

/// Is `path` a container (by its magic number)?
///
/// ```
/// use strandfit::io::{is_container, CONTAINER_MAGIC};
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-is-container-{}.sfh", std::process::id()));
/// std::fs::write(&path, CONTAINER_MAGIC).unwrap();
/// assert!(is_container(&path)); // by the magic number alone
/// std::fs::write(&path, &CONTAINER_MAGIC[..7]).unwrap();
/// assert!(!is_container(&path));
/// std::fs::remove_file(&path).unwrap();
/// ```
pub fn is_container(path: &Path) -> bool {
    let mut b = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut b))
        .is_ok()
        && b == MAGIC
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::helix::PiecewiseHelix;

    fn chain(seed: u64) -> ChainParams {
        let s = seed as f64;
        ChainParams {
            start: DVec3::new(10.0 + s, -3.0, 7.5),
            tangent: DVec3::new(1.0, 0.2, -0.1).normalize(),
            normal: DVec3::new(-0.2, 1.0, 0.0).normalize(),
            elements: (0..6)
                .map(|k| ElementParams {
                    length: 2.0 + 0.1 * k as f64,
                    curvature: if k == 2 { 0.0 } else { 0.3 + 0.01 * s },
                    torsion: -0.1 * k as f64,
                    twist: if k == 2 { 0.0 } else { 0.2 * k as f64 - 0.5 },
                })
                .collect(),
        }
    }

    fn header(storage: Storage) -> Header {
        let mut m = Metadata::new(Format::Trk);
        m.curve_data_names = vec!["weight".into()];
        m.vox_to_world = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 3.0, 0.0, 4.0, 5.0, 6.0, 1.0,
        ]);
        Header {
            storage,
            tolerance: Some(0.1),
            mode: "test".into(),
            source: SourceMeta::from_metadata(&m, None),
            dropped_point_data: vec![],
            written_by: "test".into(),
        }
    }

    fn curves(storage: Storage) -> Vec<StoredCurve> {
        let mut v = vec![
            StoredCurve {
                id: Some("é-1".into()),
                source_points: 0,
                curve_data: vec![1.5],
                shape: Shape::Empty,
            },
            StoredCurve {
                id: None,
                source_points: 1,
                curve_data: vec![-2.0],
                shape: Shape::Points(vec![DVec3::new(1.0, 2.0, 3.0)]),
            },
        ];
        for s in 0..5000 {
            let c = chain(s);
            v.push(StoredCurve {
                id: Some(format!("c{s}")),
                source_points: 40 + s,
                curve_data: vec![s as f32],
                shape: match storage {
                    Storage::Compact => Shape::Quantized(QuantChain::quantize(&c, -12, -14)),
                    _ => Shape::Chain(c),
                },
            });
        }
        v
    }

    fn write(path: &Path, storage: Storage, cs: &[StoredCurve]) -> u64 {
        let mut w = ContainerWriter::create(path, header(storage)).unwrap();
        for c in cs {
            w.write(c).unwrap();
        }
        w.finish().unwrap()
    }

    #[test]
    fn round_trips_in_every_storage() {
        let dir = tempfile::tempdir().unwrap();
        for storage in [Storage::F64, Storage::F32, Storage::Compact] {
            let path = dir.path().join("x.sfh");
            let cs = curves(storage);
            let bytes = write(&path, storage, &cs);
            assert_eq!(bytes, std::fs::metadata(&path).unwrap().len());
            let r = ContainerReader::open(&path).unwrap();
            assert_eq!(r.header(), &header(storage));
            assert_eq!(
                r.header().source.to_metadata().vox_to_world,
                header(storage).source.to_metadata().vox_to_world
            );
            let back: Vec<StoredCurve> = r.collect::<Result<_, _>>().unwrap();
            assert_eq!(back.len(), cs.len());
            for (a, b) in cs.iter().zip(&back) {
                assert_eq!(
                    (&a.id, a.source_points, &a.curve_data),
                    (&b.id, b.source_points, &b.curve_data)
                );
                match (&a.shape, &b.shape, storage) {
                    (Shape::Chain(x), Shape::Chain(y), Storage::F64) => assert_eq!(x, y),
                    (Shape::Chain(x), Shape::Chain(y), _) => {
                        // f32: each of the ~33 stored numbers is rounded by
                        // ε₃₂/2 ≈ 6e-8 relative; an angle error acts over a
                        // lever of up to 13 units: 33 × 6e-8 × 13 ≈ 2.6e-5.
                        let (px, py) = (
                            PiecewiseHelix::from_params(x),
                            PiecewiseHelix::from_params(y),
                        );
                        let d = px
                            .sample(50)
                            .iter()
                            .zip(py.sample(50))
                            .map(|(a, b)| a.distance(b))
                            .fold(0.0, f64::max);
                        assert!(d < 5e-5, "{d}");
                    }
                    (Shape::Quantized(qc), Shape::Chain(y), Storage::Compact) => {
                        assert_eq!(&qc.dequantize(), y)
                    }
                    (x, y, _) => assert_eq!(x, y),
                }
            }
        }
    }

    #[test]
    fn quantisation_error_is_bounded_by_the_grids() {
        let c = chain(3);
        let exact = PiecewiseHelix::from_params(&c);
        let mut last = f64::INFINITY;
        for p in [4i8, 8, 12, 16, 20] {
            let qc = QuantChain::quantize(&c, -p, -p - 2);
            let back = PiecewiseHelix::from_params(&qc.dequantize());
            let d = exact
                .sample(200)
                .iter()
                .zip(back.sample(200))
                .map(|(a, b)| a.distance(b))
                .fold(0.0, f64::max);
            // Every quantity moves by at most half a grid step; their effect
            // at the far end of a 13-unit chain is bounded by 13 Δθ + 6 ΔL.
            let bound = 13.0 * 2f64.powi(-p as i32 - 2) * 6.0 + 6.0 * 2f64.powi(-p as i32);
            assert!(d <= bound, "p = {p}: {d} > {bound}");
            assert!(d < last, "error falls with the grid");
            last = d;
        }
    }

    #[test]
    fn curved_elements_stay_curved() {
        let mut c = chain(0);
        c.elements[1].curvature = 1e-9;
        let qc = QuantChain::quantize(&c, -10, -10);
        assert!(qc.elements[1][1] >= 1);
        assert_eq!(qc.elements[2][1], 0, "the straight one stays straight");
    }

    #[test]
    fn damage_is_an_error_never_a_panic() {
        use rand::{Rng, SeedableRng};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.sfh");
        let cs: Vec<StoredCurve> = curves(Storage::Compact).into_iter().take(300).collect();
        write(&path, Storage::Compact, &cs);
        let good = std::fs::read(&path).unwrap();
        let bad = dir.path().join("bad.sfh");
        let read = |b: &[u8]| {
            std::fs::write(&bad, b).unwrap();
            ContainerReader::open(&bad).and_then(|r| r.collect::<Result<Vec<_>, _>>())
        };
        // Every truncation is an error (the end record is last).
        for cut in (0..good.len()).step_by(7).chain([good.len() - 1]) {
            let e = read(&good[..cut]).unwrap_err();
            assert!(e.to_string().contains("bad.sfh"), "{e}");
        }
        // Corruption: CRCs catch it (or the magic, lengths, header JSON).
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..500 {
            let mut b = good.clone();
            let i = rng.gen_range(0..b.len());
            let old = b[i];
            b[i] = loop {
                let x: u8 = rng.gen();
                if x != old {
                    break x;
                }
            };
            assert!(read(&b).is_err(), "a flipped byte at {i} went unnoticed");
        }
        let e = read(b"\x89PNG\r\n\x1a\n and more").unwrap_err().to_string();
        assert!(e.contains("wrong magic"), "{e}");
    }

    #[test]
    fn writer_refuses_mismatched_data_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.sfh");
        let mut w = ContainerWriter::create(&path, header(Storage::F32)).unwrap();
        let e = w
            .write(&StoredCurve {
                id: None,
                source_points: 0,
                curve_data: vec![],
                shape: Shape::Empty,
            })
            .unwrap_err();
        assert!(e.to_string().contains("curve 0"), "{e}");
        let e = w
            .write(&StoredCurve {
                id: None,
                source_points: 0,
                curve_data: vec![0.0],
                shape: Shape::Quantized(QuantChain::quantize(&chain(0), -8, -8)),
            })
            .unwrap_err();
        assert!(e.to_string().contains("compact"), "{e}");
        drop(w);
        assert!(!path.exists());
    }
}
