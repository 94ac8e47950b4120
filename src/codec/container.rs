//! The `.sfh` container, version 3: codec blocks with an index at the end.
//! Its layout is described in the [`codec`](crate::codec) module
//! documentation (and in `docs/container.md`, in full).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::quantise::Steps;
use super::{decode_block, CodecParams, EncodedBlock};
use crate::io::{AtomicFile, IoError, SourceMeta, CONTAINER_MAGIC as MAGIC};

/// The container format version this crate reads and writes.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
/// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
/// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
/// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
/// #     w.finish_bytes().unwrap()
/// # }
///
/// // A container says its version in bytes 8–9, after the magic number.
/// let bytes = container(1);
/// assert_eq!(bytes[8..10], CONTAINER_VERSION.to_le_bytes());
/// ```
pub const VERSION: u16 = 3;
/// The revision of the codec's model (what the geometry streams mean),
/// written by this build. A stream coded by another model would decode to
/// other curves, so a decoder reads only the models it knows
/// ([`READ_MODELS`]) and refuses the others by name.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// use strandfit::codec::CodecParams;
///
/// // New headers and parameters are for this model, which this build reads.
/// assert_eq!(header().model, MODEL);
/// assert_eq!(CodecParams::new(0.01).model, MODEL);
/// assert!(READ_MODELS.contains(&MODEL));
/// ```
pub const MODEL: u8 = 16;
/// The models this build decodes: 15, whose corners' bulges were coded
/// without a prediction (model 16 predicts them from the G1 arc's); 12, whose points curves without a
/// reference had no mean-step prediction (model 13 may take it); 11, whose references predicted a step
/// by matching point indices alone (model 12 may walk them); 10, which coded every residual sign in
/// one context per axis; 9; 8, whose screw prediction turned the
/// last step alone ([`super::decode_block`]'s own prediction); 7, whose range coder's contexts
/// adapted at a fixed rate with 11-bit probabilities
/// ([`super::entropy::Adaptation`]); and 6, which also took the screw
/// prediction's rotation from the last two step pairs' frames
/// ([`CodecParams::model`] carries the differences).
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
///
/// // Containers of these models open; one of another is refused by name.
/// let with_model = |model: u8| {
///     let mut h = header();
///     h.model = model;
///     CodecReader::from_bytes(CodecWriter::in_memory(&h).finish_bytes().unwrap())
/// };
/// for model in READ_MODELS {
///     assert_eq!(with_model(model).unwrap().header().model, model);
/// }
/// let err = with_model(99).err().unwrap();
/// assert!(err.to_string().contains("codec model 99"), "{err}");
/// ```
pub const READ_MODELS: [u8; 11] = [6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16];
const END_MAGIC: [u8; 4] = *b"SFHE";
const END_LEN: u64 = 12;
/// Curves per block: the entropy models learn within a block, so larger
/// blocks code a little smaller; 4,096 bounds memory and keeps two cores
/// busy on files of a few blocks.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// use std::path::Path;
/// use strandfit::codec::compress_to_bytes;
/// use strandfit::io::{Curve, VecReader};
///
/// // One curve more than a block holds: two blocks.
/// let curves = vec![Curve::default(); CONTAINER_BLOCK_CURVES + 1];
/// let mut reader = VecReader::new(Metadata::new(Format::Json), curves);
/// let bytes = compress_to_bytes(&mut reader, Path::new("in.json"), &header(), None).unwrap();
/// let r = CodecReader::from_bytes(bytes).unwrap();
/// assert_eq!(r.block_count(), 2);
/// assert_eq!(r.block_span(1), (CONTAINER_BLOCK_CURVES as u64, 1));
/// ```
pub const BLOCK_CURVES: usize = 4096;
/// Largest header, block part or index accepted.
const MAX_SECTION: u32 = 1 << 30;

/// The header of a version-3 container.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// use std::path::Path;
///
/// // A header is read back as it was written.
/// let mut meta = Metadata::new(Format::Trk);
/// meta.units = Some("mm".into());
/// meta.curve_data_names = vec!["weight".into()];
/// let source = SourceMeta::from_metadata(&meta, Some(Path::new("af.trk")));
/// let h = CodecHeader::new(0.05, source, vec!["fa".into()]);
/// let bytes = CodecWriter::in_memory(&h).finish_bytes().unwrap();
/// assert_eq!(CodecReader::from_bytes(bytes).unwrap().header(), &h);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CodecHeader {
    /// The revision of the codec model that wrote the geometry ([`MODEL`]).
    pub model: u8,
    /// The two-sided Hausdorff tolerance every curve was compressed to.
    pub tolerance: f64,
    /// The codec's quantisation steps (multiples of the tolerance).
    pub steps: Steps,
    /// The input's metadata (format, affine, units, per-curve data names).
    pub source: SourceMeta,
    /// Names of the per-point values stored with each curve (on its decoded
    /// points: [`carry_point_data`](super::carry_point_data)).
    pub point_data_names: Vec<String>,
    /// The version of strandfit that wrote the file.
    pub written_by: String,
    /// How hard the writer searches ([`super::Effort`]): a setting of the
    /// encoder, not stored. A header read back has the default, so one
    /// written with `Best` does not compare equal to itself read back.
    #[serde(skip)]
    pub effort: super::Effort,
}

impl CodecHeader {
    /// A header for the current model with the default steps. A `.tck`
    /// source's last extra field, `datatype: Float32LE`, is left out: it
    /// is what the `.tck` writer writes there anyway.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// use strandfit::codec::Steps;
    ///
    /// let mut meta = Metadata::new(Format::Tck);
    /// meta.extra = vec![("datatype".into(), "Float32LE".into())];
    /// let h = CodecHeader::new(0.2, SourceMeta::from_metadata(&meta, None), vec![]);
    /// assert_eq!((h.model, h.tolerance, h.steps), (MODEL, 0.2, Steps::default()));
    /// assert!(h.source.extra.is_empty());
    /// ```
    pub fn new(tolerance: f64, source: SourceMeta, point_data_names: Vec<String>) -> Self {
        // A .tck source's datatype is left out where it is what the .tck
        // writer writes by default in the same place (Float32LE, after the
        // other lines): 20 bytes of every such file. Here, not when the
        // header is written, so that a header read back (split, merge) is
        // written as it was.
        let mut source = source;
        if source.format == "tck"
            && source
                .extra
                .last()
                .is_some_and(|(k, v)| k == "datatype" && v == "Float32LE")
        {
            source.extra.pop();
        }
        CodecHeader {
            model: MODEL,
            tolerance,
            steps: Steps::default(),
            source,
            point_data_names,
            written_by: env!("CARGO_PKG_VERSION").into(),
            effort: super::Effort::Default,
        }
    }

    /// The codec parameters the geometry was written with.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// use strandfit::codec::CodecParams;
    ///
    /// let mut h = header();
    /// assert_eq!(h.params(), CodecParams::new(0.01));
    /// h.tolerance = 0.5;
    /// assert_eq!(h.params().tolerance, 0.5);
    /// ```
    pub fn params(&self) -> CodecParams {
        CodecParams {
            tolerance: self.tolerance,
            steps: self.steps,
            model: self.model,
            effort: self.effort,
        }
    }

    /// The binary form (before the optional DEFLATE): model, tolerance,
    /// steps (a flag, then five `f64` unless the defaults), the writer's
    /// version, the source's metadata and the per-point value names. Strings are a
    /// varint length and UTF-8; optional fields follow a presence bit.
    fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(64);
        b.push(self.model);
        if self.model >= 8 {
            // The shortest decimal that reads back as the same f64, in
            // exponent form ("1e-1": 5 bytes with its length, not 8).
            put_str(&mut b, &format!("{:e}", self.tolerance));
        } else {
            b.extend_from_slice(&self.tolerance.to_le_bytes());
        }
        let st = self.steps;
        if st == Steps::default() {
            b.push(0);
        } else {
            b.push(1);
            for v in [st.offset, st.length, st.start, st.first, st.sagitta] {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        put_str(&mut b, &self.written_by);
        let m = &self.source;
        put_str(&mut b, &m.format);
        let identity = glam::DMat4::IDENTITY.to_cols_array_2d();
        let present = [
            m.file.is_some(),
            m.vox_to_world != identity,
            m.voxel_size.is_some(),
            m.dimensions.is_some(),
            m.units.is_some(),
        ];
        b.push(
            present
                .iter()
                .enumerate()
                .fold(0u8, |acc, (k, &p)| acc | (p as u8) << k),
        );
        if let Some(f) = &m.file {
            put_str(&mut b, f);
        }
        if present[1] {
            for v in m.vox_to_world.iter().flatten() {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        if let Some(v) = m.voxel_size {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        if let Some(d) = m.dimensions {
            for x in d {
                put_varint(&mut b, x as u64);
            }
        }
        if let Some(u) = &m.units {
            put_str(&mut b, u);
        }
        put_varint(&mut b, m.curve_data_names.len() as u64);
        for n in &m.curve_data_names {
            put_str(&mut b, n);
        }
        put_varint(&mut b, m.extra.len() as u64);
        for (k, v) in &m.extra {
            put_str(&mut b, k);
            put_str(&mut b, v);
        }
        put_varint(&mut b, self.point_data_names.len() as u64);
        for n in &self.point_data_names {
            put_str(&mut b, n);
        }
        b
    }

    fn from_bytes(b: &[u8]) -> Result<Self, String> {
        let mut c = Cursor { b, pos: 0 };
        let model = c.take(1)?[0];
        let tolerance = if model >= 8 {
            let t = c.str()?;
            t.parse::<f64>()
                .map_err(|_| format!("a tolerance {t:?} that is not a number"))?
        } else {
            c.f64()?
        };
        let steps = match c.take(1)?[0] {
            0 => Steps::default(),
            1 => Steps {
                offset: c.f64()?,
                length: c.f64()?,
                start: c.f64()?,
                first: c.f64()?,
                sagitta: c.f64()?,
            },
            f => return Err(format!("unknown steps flag {f}")),
        };
        let written_by = c.str()?;
        let format = c.str()?;
        let present = c.take(1)?[0];
        if present >> 5 != 0 {
            return Err(format!("unknown metadata flags {present:#x}"));
        }
        let has = |k: u32| present >> k & 1 == 1;
        let file = if has(0) { Some(c.str()?) } else { None };
        let mut vox_to_world = glam::DMat4::IDENTITY.to_cols_array_2d();
        if has(1) {
            for v in vox_to_world.iter_mut().flatten() {
                *v = c.f64()?;
            }
        }
        let voxel_size = if has(2) {
            Some([c.f64()?, c.f64()?, c.f64()?])
        } else {
            None
        };
        let dimensions = if has(3) {
            let mut d = [0u32; 3];
            for x in &mut d {
                *x = u32::try_from(c.varint()?).map_err(|_| "a dimension beyond u32")?;
            }
            Some(d)
        } else {
            None
        };
        let units = if has(4) { Some(c.str()?) } else { None };
        let curve_data_names = c.strs()?;
        let n = c.count()?;
        let mut extra = Vec::with_capacity(n);
        for _ in 0..n {
            extra.push((c.str()?, c.str()?));
        }
        let point_data_names = c.strs()?;
        if c.pos != b.len() {
            return Err("bytes left over after the header".into());
        }
        Ok(CodecHeader {
            model,
            tolerance,
            steps,
            source: SourceMeta {
                format,
                file,
                vox_to_world,
                voxel_size,
                dimensions,
                units,
                curve_data_names,
                extra,
            },
            point_data_names,
            written_by,
            effort: super::Effort::Default,
        })
    }
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_varint(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}

/// One decoded curve.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// // A curve with an id, a per-curve value and a per-point value, stored
/// // and read back.
/// let mut meta = Metadata::new(Format::Json);
/// meta.curve_data_names = vec!["weight".into()];
/// let h = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec!["s".into()]);
/// let points = helix(0);
/// let values: Vec<f32> = (0..30).map(|i| i as f32).collect();
/// let c = CurveIn { id: Some("a"), points: &points, point_data: &values, curve_data: &[2.5] };
/// let mut w = CodecWriter::in_memory(&h);
/// w.write_block(&encode_block_bytes(&[c], &h.params(), 1, 1).unwrap()).unwrap();
/// let mut r = CodecReader::from_bytes(w.finish_bytes().unwrap()).unwrap();
/// let d = r.read_block_bytes(0).unwrap().decode(r.path(), r.header()).unwrap().remove(0);
/// assert_eq!((d.id.as_deref(), &d.curve_data[..]), (Some("a"), &[2.5][..]));
/// assert_eq!(d.point_data.len(), d.points.len()); // one value per decoded point
/// assert!(strandfit::metrics::hausdorff(&points, &d.points).unwrap() <= 0.01);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedCurve {
    /// The curve's identifier, if the input had one.
    pub id: Option<String>,
    /// The decoded points (`f32` values, within the tolerance of the input).
    pub points: Vec<DVec3>,
    /// Per decoded point, the values named in the header (row-major).
    pub point_data: Vec<f32>,
    /// Per-curve values named in the header.
    pub curve_data: Vec<f32>,
}

/// A curve to store.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// // Per-curve values: as many as the header names; per-point values: as
/// // many per point. A curve that has other counts is named.
/// let points = helix(0);
/// let curve = |point_data| CurveIn { id: Some("a"), points: &points, point_data, curve_data: &[1.0] };
/// let ones = vec![1.0f32; 30];
/// assert!(encode_block_bytes(&[curve(&ones)], &header().params(), 1, 1).is_ok());
/// let (k, why) = encode_block_bytes(&[curve(&ones), curve(&ones[1..])], &header().params(), 1, 1)
///     .err()
///     .unwrap();
/// assert_eq!(k, 1);
/// assert!(why.contains("per-point values"), "{why}");
/// ```
pub struct CurveIn<'a> {
    /// The curve's identifier, if any.
    pub id: Option<&'a str>,
    /// The input points.
    pub points: &'a [DVec3],
    /// Per input point, the values named in the header (row-major).
    pub point_data: &'a [f32],
    /// Per-curve values named in the header.
    pub curve_data: &'a [f32],
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        if n > self.b.len() - self.pos {
            return Err("ends early".into());
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn varint(&mut self) -> Result<u64, String> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.take(1)?[0];
            v |= ((b & 0x7f) as u64) << shift;
            if b < 0x80 {
                return Ok(v);
            }
        }
        Err("a varint longer than 64 bits".into())
    }
    fn f64(&mut self) -> Result<f64, String> {
        let b = self.take(8)?;
        Ok(f64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
    /// A count of items that each take at least one byte (so a corrupt
    /// count cannot allocate more than the bytes left).
    fn count(&mut self) -> Result<usize, String> {
        let n = self.varint()?;
        if n > (self.b.len() - self.pos) as u64 {
            return Err(format!(
                "a count of {n} in {} bytes",
                self.b.len() - self.pos
            ));
        }
        Ok(n as usize)
    }
    fn str(&mut self) -> Result<String, String> {
        let n = self.count()?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| "a string that is not UTF-8".into())
    }
    fn strs(&mut self) -> Result<Vec<String>, String> {
        let n = self.count()?;
        (0..n).map(|_| self.str()).collect()
    }
}

fn deflate(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(raw)?;
    z.finish()
}

fn inflate(stored: &[u8], len: usize) -> Result<Vec<u8>, String> {
    // Capacity from the stored size, not from the claimed length.
    let mut out = Vec::with_capacity(len.min(16 * stored.len() + 1024));
    flate2::read::DeflateDecoder::new(stored)
        .take(len as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("cannot inflate: {e}"))?;
    if out.len() != len {
        return Err(format!("inflates to {} bytes, not {len}", out.len()));
    }
    Ok(out)
}

/// One encoded block, ready to write.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// let b = blocks(&header(), 1).remove(0);
/// assert_eq!(b.curves, 2);
/// assert_eq!(b.geometry, b.encoded.bytes);
/// // No ids and no values: no side data at all.
/// assert!(b.side.is_empty() && b.side_len == 0);
/// ```
pub struct BlockBytes {
    /// Number of curves in the block.
    pub curves: u32,
    /// Compressed geometry bytes.
    pub geometry: Vec<u8>,
    /// Compressed side data (identifiers, per-point and per-curve values).
    pub side: Vec<u8>,
    /// Length of the side data before compression.
    pub side_len: u32,
    /// The encoded geometry (kept for verification).
    pub encoded: EncodedBlock,
    /// Which input curves were empty (for [`verify`](Self::verify)).
    empty: Vec<bool>,
    /// Per curve, the decoded points its per-point values are for (empty
    /// without per-point values).
    point_counts: Vec<usize>,
}

impl BlockBytes {
    /// Never write what cannot be read back: the block is decoded, and must
    /// give every curve (empty exactly where the input was) and the point
    /// count the encoder checked. Separate from encoding so that a writer
    /// can verify one block while the next is fitted.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    ///
    /// // A block decodes to the curves and points its encoder checked.
    /// let h = header();
    /// for b in blocks(&h, 2) {
    ///     assert_eq!(b.verify(&h.params()), Ok(()));
    /// }
    /// ```
    pub fn verify(&self, params: &CodecParams) -> Result<(), (usize, String)> {
        let back =
            decode_block(&self.geometry, self.curves as usize, params).map_err(|e| match e {
                super::DecodeError::Curve { curve, why } => {
                    (curve, format!("the block would not decode: {why}"))
                }
                e => (0, format!("the block would not decode: {e}")),
            })?;
        for (k, (b, &e)) in back.iter().zip(&self.empty).enumerate() {
            if b.is_empty() != e {
                return Err((k, "the curve would not decode".into()));
            }
            if self.point_counts.get(k).is_some_and(|&n| n != b.len()) {
                return Err((k, "per-point values for other points than decode".into()));
            }
        }
        if back.iter().map(Vec::len).sum::<usize>() != self.encoded.output_points {
            return Err((
                0,
                "the block decodes to other points than were checked".into(),
            ));
        }
        Ok(())
    }
}

/// Encodes a block of curves (geometry in parallel over curves); call
/// [`BlockBytes::verify`] before writing it.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// let h = header();
/// let (p, mut q) = (helix(0), helix(1));
/// let curves = [&p, &q].map(|c| CurveIn { id: None, points: c, point_data: &[], curve_data: &[] });
/// let block = encode_block_bytes(&curves, &h.params(), 0, 0).unwrap();
/// assert_eq!((block.curves, block.encoded.kinds.len()), (2, 2));
/// // A point that is not finite: the error names the curve and the point.
/// q[4].z = f64::INFINITY;
/// let curves = [&p, &q].map(|c| CurveIn { id: None, points: c, point_data: &[], curve_data: &[] });
/// let (k, why) = encode_block_bytes(&curves, &h.params(), 0, 0).err().unwrap();
/// assert_eq!((k, why.as_str()), (1, "point 4 is not finite"));
/// ```
pub fn encode_block_bytes(
    curves: &[CurveIn],
    params: &CodecParams,
    n_curve_data: usize,
    n_point_data: usize,
) -> Result<BlockBytes, (usize, String)> {
    encode_block_bytes_on(curves, params, n_curve_data, n_point_data, None)
}

/// [`encode_block_bytes`], the candidate elements checked in batches on
/// `checker` where one is given (the same bytes;
/// [`super::encode_block_on`]).
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// // Without a checker (the CPU), the bytes of `encode_block_bytes`.
/// let h = header();
/// let p = helix(0);
/// let curves = [CurveIn { id: Some("a"), points: &p, point_data: &[], curve_data: &[] }];
/// let on = encode_block_bytes_on(&curves, &h.params(), 0, 0, None).unwrap();
/// let plain = encode_block_bytes(&curves, &h.params(), 0, 0).unwrap();
/// assert_eq!((on.geometry, on.side), (plain.geometry, plain.side));
/// ```
pub fn encode_block_bytes_on(
    curves: &[CurveIn],
    params: &CodecParams,
    n_curve_data: usize,
    n_point_data: usize,
    checker: Option<&dyn super::batch::ArcChecker>,
) -> Result<BlockBytes, (usize, String)> {
    for (k, c) in curves.iter().enumerate() {
        if c.curve_data.len() != n_curve_data {
            return Err((
                k,
                format!(
                    "{} per-curve values where the header names {n_curve_data}",
                    c.curve_data.len()
                ),
            ));
        }
        if c.point_data.len() != c.points.len() * n_point_data {
            return Err((
                k,
                format!(
                    "{} per-point values for {} points where the header names {n_point_data} per point",
                    c.point_data.len(),
                    c.points.len()
                ),
            ));
        }
    }
    let pts: Vec<&[DVec3]> = curves.iter().map(|c| c.points).collect();
    let encoded =
        super::encode_block_on(&pts, params, n_point_data > 0, checker).map_err(|e| match e {
            super::EncodeError::NonFinite { curve, point } => {
                (curve, format!("point {point} is not finite"))
            }
            super::EncodeError::BeyondFloat32 { curve, point, why } => {
                (curve, format!("point {point}: {why}"))
            }
            e => (0, e.to_string()),
        })?;
    let mut side = Vec::new();
    for c in curves {
        match c.id {
            None => put_varint(&mut side, 0),
            Some(s) => {
                put_varint(&mut side, s.len() as u64 + 1);
                side.extend_from_slice(s.as_bytes());
            }
        }
        for v in c.curve_data {
            side.extend_from_slice(&v.to_le_bytes());
        }
    }
    // Per-point values on the decoded points: per curve their count, then
    // the values' bytes in four planes (first bytes of all, then second
    // bytes, …), which DEFLATE finds far more repetition in than in
    // interleaved floats.
    let mut point_counts = Vec::new();
    if n_point_data > 0 {
        let mut all = Vec::new();
        for (c, out) in curves.iter().zip(&encoded.decoded) {
            put_varint(&mut side, out.len() as u64);
            point_counts.push(out.len());
            all.extend(super::point_data::carry(
                c.points,
                c.point_data,
                n_point_data,
                out,
            ));
        }
        for plane in 0..4 {
            side.extend(all.iter().map(|v| v.to_le_bytes()[plane]));
        }
    }
    // No ids and no per-curve or per-point values (.tck, .vtk, .hair): no
    // side data at all, rather than a deflated run of zeros and its lengths.
    let (side_len, stored) =
        if n_curve_data == 0 && n_point_data == 0 && side.iter().all(|&b| b == 0) {
            (0, Vec::new())
        } else {
            let stored = deflate(&side).map_err(|e| (0, e.to_string()))?;
            (side.len() as u32, stored)
        };
    Ok(BlockBytes {
        curves: curves.len() as u32,
        geometry: encoded.bytes.clone(),
        side: stored,
        side_len,
        encoded,
        empty: curves.iter().map(|c| c.points.is_empty()).collect(),
        point_counts,
    })
}

/// Writes a version-3 container; [`finish`](Self::finish) writes the index
/// and end record and renames the file into place.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
///
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("out.sfh");
/// let h = header();
/// let mut w = CodecWriter::create(&path, &h).unwrap();
/// for b in blocks(&h, 3) {
///     b.verify(&h.params()).unwrap();
///     w.write_block(&b).unwrap();
/// }
/// w.finish().unwrap();
/// let r = CodecReader::open(&path).unwrap();
/// assert_eq!((r.block_count(), r.curve_count()), (3, 6));
/// ```
pub struct CodecWriter {
    out: Sink,
    offset: u64,
    /// Per block: its bytes and curves.
    index: Vec<(u64, u32)>,
}

/// Where a [`CodecWriter`] writes: a file committed atomically at the end,
/// or memory.
enum Sink {
    File(AtomicFile),
    Memory(Vec<u8>),
}

/// The name a container in memory goes by in messages.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// use std::path::Path;
///
/// // Messages about a container in memory name it so.
/// assert_eq!(CodecWriter::in_memory(&header()).target(), Path::new(IN_MEMORY));
/// let err = CodecReader::from_bytes(b"too short".to_vec()).err().unwrap();
/// assert_eq!(err.path, Path::new(IN_MEMORY));
/// assert!(err.to_string().starts_with(IN_MEMORY));
/// ```
pub const IN_MEMORY: &str = "<container in memory>";

impl Sink {
    fn write_all(&mut self, b: &[u8]) -> Result<(), IoError> {
        match self {
            Sink::File(f) => f.write_all(b).map_err(|e| f.err(e)),
            Sink::Memory(v) => {
                v.extend_from_slice(b);
                Ok(())
            }
        }
    }
}

impl CodecWriter {
    /// A container written to `path` (atomically: under a temporary name
    /// until [`finish`](Self::finish)).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    ///
    /// // Nothing at `path` until the container is finished.
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.sfh");
    /// let w = CodecWriter::create(&path, &header()).unwrap();
    /// assert!(!path.exists());
    /// w.finish().unwrap();
    /// assert_eq!(CodecReader::open(&path).unwrap().curve_count(), 0);
    /// // A folder that is not there is an error at once.
    /// assert!(CodecWriter::create(&dir.path().join("no/out.sfh"), &header()).is_err());
    /// ```
    pub fn create(path: &Path, header: &CodecHeader) -> Result<Self, IoError> {
        Self::start(Sink::File(AtomicFile::create(path)?), header)
    }

    /// A container built in memory ([`finish_bytes`](Self::finish_bytes)).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    ///
    /// let h = header();
    /// let mut w = CodecWriter::in_memory(&h);
    /// for b in blocks(&h, 2) {
    ///     w.write_block(&b).unwrap();
    /// }
    /// let bytes = w.finish_bytes().unwrap();
    /// assert_eq!(bytes[..8], strandfit::io::CONTAINER_MAGIC);
    /// assert_eq!(CodecReader::from_bytes(bytes).unwrap().curve_count(), 4);
    /// ```
    pub fn in_memory(header: &CodecHeader) -> Self {
        Self::start(Sink::Memory(Vec::new()), header).expect("memory does not fail")
    }

    fn start(mut out: Sink, header: &CodecHeader) -> Result<Self, IoError> {
        let raw = header.to_bytes();
        // A .trk source's 1000-byte header, or long titles, deflate well;
        // the usual few dozen bytes do not.
        let target = match &out {
            Sink::File(f) => f.target().to_path_buf(),
            Sink::Memory(_) => PathBuf::from(IN_MEMORY),
        };
        let packed = deflate(&raw).map_err(|e| IoError::new(&target, format!("deflate: {e}")))?;
        let mut body = Vec::with_capacity(raw.len() + 1);
        if packed.len() + 4 < raw.len() {
            body.push(1);
            put_varint(&mut body, raw.len() as u64);
            body.extend_from_slice(&packed);
        } else {
            body.push(0);
            body.extend_from_slice(&raw);
        }
        let mut head = Vec::with_capacity(body.len() + 20);
        head.extend_from_slice(&MAGIC);
        head.extend_from_slice(&VERSION.to_le_bytes());
        put_varint(&mut head, body.len() as u64);
        head.extend_from_slice(&body);
        head.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
        out.write_all(&head)?;
        Ok(CodecWriter {
            out,
            offset: head.len() as u64,
            index: Vec::new(),
        })
    }

    /// Where the container is written (a placeholder path in memory).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.sfh");
    /// assert_eq!(CodecWriter::create(&path, &header()).unwrap().target(), path);
    /// assert_eq!(CodecWriter::in_memory(&header()).target(), std::path::Path::new(IN_MEMORY));
    /// ```
    pub fn target(&self) -> &Path {
        match &self.out {
            Sink::File(f) => f.target(),
            Sink::Memory(_) => Path::new(IN_MEMORY),
        }
    }

    /// Appends an encoded block.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    ///
    /// let h = header();
    /// let mut w = CodecWriter::in_memory(&h);
    /// for (k, b) in blocks(&h, 3).iter().enumerate() {
    ///     w.write_block(b).unwrap();
    ///     assert_eq!(w.curves(), 2 * (k as u64 + 1));
    /// }
    /// let r = CodecReader::from_bytes(w.finish_bytes().unwrap()).unwrap();
    /// assert_eq!(r.block_span(2), (4, 2));
    /// ```
    pub fn write_block(&mut self, b: &BlockBytes) -> Result<(), IoError> {
        self.write_parts(b.curves, &b.geometry, &b.side, b.side_len)
    }

    /// Appends a block read from another container with the same header,
    /// as it was (no decoding, no re-encoding): its bytes are the same.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// // Every block copied into a container of the same header: the same bytes.
    /// let bytes = container(3);
    /// let mut r = CodecReader::from_bytes(bytes.clone()).unwrap();
    /// let mut w = CodecWriter::in_memory(r.header());
    /// for k in 0..r.block_count() {
    ///     w.copy_block(&r.read_block_bytes(k).unwrap()).unwrap();
    /// }
    /// assert_eq!(w.finish_bytes().unwrap(), bytes);
    /// ```
    pub fn copy_block(&mut self, b: &RawBlock) -> Result<(), IoError> {
        self.write_parts(b.curves, b.geometry(), b.side(), b.side_len)
    }

    fn write_parts(
        &mut self,
        curves: u32,
        geometry: &[u8],
        side: &[u8],
        side_len: u32,
    ) -> Result<(), IoError> {
        let mut head = Vec::with_capacity(16);
        put_varint(&mut head, curves as u64);
        put_varint(&mut head, geometry.len() as u64);
        put_varint(&mut head, side.len() as u64);
        if !side.is_empty() {
            put_varint(&mut head, side_len as u64);
        }
        let mut crc = crc32fast::Hasher::new();
        crc.update(&head);
        crc.update(geometry);
        crc.update(side);
        let crc = crc.finalize().to_le_bytes();
        for part in [&head[..], geometry, side, &crc] {
            self.out.write_all(part)?;
        }
        let len = (head.len() + geometry.len() + side.len() + 4) as u64;
        self.index.push((len, curves));
        self.offset += len;
        Ok(())
    }

    /// Curves written so far.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    ///
    /// let h = header();
    /// let mut w = CodecWriter::in_memory(&h);
    /// assert_eq!(w.curves(), 0);
    /// for b in blocks(&h, 2) {
    ///     w.write_block(&b).unwrap();
    /// }
    /// assert_eq!(w.curves(), 4);
    /// ```
    pub fn curves(&self) -> u64 {
        self.index.iter().map(|&(_, n)| n as u64).sum()
    }

    /// Completes and commits the file; returns its size in bytes.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.sfh");
    /// let h = header();
    /// let mut w = CodecWriter::create(&path, &h).unwrap();
    /// w.write_block(&blocks(&h, 1)[0]).unwrap();
    /// let size = w.finish().unwrap();
    /// assert_eq!(size, std::fs::metadata(&path).unwrap().len());
    /// ```
    pub fn finish(self) -> Result<u64, IoError> {
        let (sink, size) = self.complete()?;
        if let Sink::File(f) = sink {
            f.commit()?;
        }
        Ok(size)
    }

    /// Completes a container built [`in_memory`](Self::in_memory) and
    /// returns its bytes (a file-backed writer is committed, and its bytes
    /// read back).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// // From a file-backed writer: the file is written, and its bytes are
    /// // those of the same container built in memory.
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("out.sfh");
    /// let h = header();
    /// let mut w = CodecWriter::create(&path, &h).unwrap();
    /// w.write_block(&blocks(&h, 1)[0]).unwrap();
    /// let bytes = w.finish_bytes().unwrap();
    /// assert_eq!(bytes, std::fs::read(&path).unwrap());
    /// assert_eq!(bytes, container(1));
    /// ```
    pub fn finish_bytes(self) -> Result<Vec<u8>, IoError> {
        match self.complete()? {
            (Sink::Memory(v), _) => Ok(v),
            (Sink::File(f), _) => {
                let path = f.target().to_path_buf();
                f.commit()?;
                std::fs::read(&path).map_err(|e| IoError::os(&path, "cannot read", e))
            }
        }
    }

    /// Writes the index and end record.
    fn complete(mut self) -> Result<(Sink, u64), IoError> {
        let mut idx = Vec::with_capacity(4 * self.index.len() + 16);
        put_varint(&mut idx, self.index.len() as u64);
        for (len, n) in &self.index {
            put_varint(&mut idx, *len);
            put_varint(&mut idx, *n as u64);
        }
        let mut end = Vec::with_capacity(END_LEN as usize);
        end.extend_from_slice(&crc32fast::hash(&idx).to_le_bytes());
        end.extend_from_slice(&(idx.len() as u32).to_le_bytes());
        end.extend_from_slice(&END_MAGIC);
        self.out.write_all(&idx)?;
        self.out.write_all(&end)?;
        Ok((self.out, self.offset + idx.len() as u64 + END_LEN))
    }
}

/// Reads a version-3 container: the header and index at open, any block on
/// demand.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
/// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
/// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
/// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
/// #     w.finish_bytes().unwrap()
/// # }
///
/// // Open, then decode block by block.
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("in.sfh");
/// std::fs::write(&path, container(3)).unwrap();
/// let mut r = CodecReader::open(&path).unwrap();
/// let mut curves = Vec::new();
/// for k in 0..r.block_count() {
///     curves.extend(r.read_block_bytes(k).unwrap().decode(r.path(), r.header()).unwrap());
/// }
/// assert_eq!(curves.len(), 6);
/// for (k, c) in curves.iter().enumerate() {
///     assert!(strandfit::metrics::hausdorff(&helix(k), &c.points).unwrap() <= 0.01);
/// }
/// ```
pub struct CodecReader {
    path: PathBuf,
    file: Box<dyn ReadSeek>,
    header: CodecHeader,
    /// Per block: offset, length in bytes, curves, first curve.
    blocks: Vec<(u64, u64, u32, u64)>,
    curves: u64,
    /// Bytes read from the source so far (header, end record, index and
    /// the blocks read).
    bytes_read: u64,
    size: u64,
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Reads a varint from `file` (at most 10 bytes).
fn read_varint(file: &mut impl Read) -> std::io::Result<(u64, Vec<u8>)> {
    let mut v = 0u64;
    let mut bytes = Vec::with_capacity(4);
    for shift in (0..64).step_by(7) {
        let mut b = [0u8];
        file.read_exact(&mut b)?;
        bytes.push(b[0]);
        v |= ((b[0] & 0x7f) as u64) << shift;
        if b[0] < 0x80 {
            return Ok((v, bytes));
        }
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        "a varint longer than 64 bits",
    ))
}

/// What a [`CodecReader`] reads from: a file or bytes in memory.
///
/// ```
/// use std::io::{Read, Seek, SeekFrom};
/// use strandfit::codec::ReadSeek;
///
/// // Anything that reads and seeks (and can move between threads).
/// let mut source: Box<dyn ReadSeek> = Box::new(std::io::Cursor::new(vec![1u8, 2, 3]));
/// source.seek(SeekFrom::End(-1)).unwrap();
/// let mut last = [0u8];
/// source.read_exact(&mut last).unwrap();
/// assert_eq!(last, [3]);
/// ```
pub trait ReadSeek: Read + Seek + Send {}
impl<T: Read + Seek + Send> ReadSeek for T {}

impl CodecReader {
    /// Opens a version-3 container (other versions are an error here; the
    /// caller's dispatch sends version 1 elsewhere).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("in.sfh");
    /// std::fs::write(&path, container(2)).unwrap();
    /// assert_eq!(CodecReader::open(&path).unwrap().curve_count(), 4);
    /// // Other files are errors that say why.
    /// std::fs::write(&path, b"{\"curves\": []} and some more bytes").unwrap();
    /// let err = CodecReader::open(&path).err().unwrap();
    /// assert!(err.to_string().contains("wrong magic number"), "{err}");
    /// assert!(CodecReader::open(&dir.path().join("missing.sfh")).is_err());
    /// ```
    pub fn open(path: &Path) -> Result<Self, IoError> {
        let f = File::open(path).map_err(|e| IoError::os(path, "cannot read", e))?;
        let size = f
            .metadata()
            .map_err(|e| IoError::os(path, "cannot read", e))?
            .len();
        Self::from_source(Box::new(BufReader::new(f)), size, path)
    }

    /// Opens a version-3 container held in memory; messages name it
    /// [`IN_MEMORY`].
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let bytes = container(1);
    /// assert_eq!(CodecReader::from_bytes(bytes.clone()).unwrap().curve_count(), 2);
    /// // A damaged header, or a missing end, is found at opening.
    /// let mut bad = bytes.clone();
    /// bad[12] ^= 1;
    /// let err = CodecReader::from_bytes(bad).err().unwrap();
    /// assert!(err.to_string().contains("checksum mismatch"), "{err}");
    /// let err = CodecReader::from_bytes(bytes[..bytes.len() - 1].to_vec()).err().unwrap();
    /// assert!(err.to_string().contains("no end record"), "{err}");
    /// ```
    pub fn from_bytes(bytes: Vec<u8>) -> Result<Self, IoError> {
        let size = bytes.len() as u64;
        Self::from_source(
            Box::new(std::io::Cursor::new(bytes)),
            size,
            Path::new(IN_MEMORY),
        )
    }

    fn from_source(mut file: Box<dyn ReadSeek>, size: u64, path: &Path) -> Result<Self, IoError> {
        let err = |why: String| IoError::new(path, why);
        let mut head = [0u8; 10];
        if size < 10 + END_LEN {
            return Err(err(format!(
                "file truncated: {size} bytes is too short for a container"
            )));
        }
        file.read_exact(&mut head)
            .map_err(|e| IoError::os(path, "cannot read", e))?;
        if head[..8] != MAGIC {
            return Err(err("not a strandfit container (wrong magic number)".into()).at("byte 0"));
        }
        let version = u16::from_le_bytes([head[8], head[9]]);
        if version == 2 {
            return Err(err(
                "container version 2 was written by a development build of strandfit 0.1.0 \
                 (November 2026); this build reads versions 1 and 3: compress the input again"
                    .into(),
            ));
        }
        if version != VERSION {
            return Err(err(format!(
                "container version {version}, expected {VERSION}"
            )));
        }
        let (len, len_bytes) = read_varint(&mut file)
            .map_err(|e| err(format!("cannot read the header length: {e}")).at("header"))?;
        let data_start = 10 + len_bytes.len() as u64 + len + 4;
        if len > MAX_SECTION as u64 || data_start + END_LEN > size {
            return Err(err(format!(
                "header length {len} exceeds the file ({size} bytes)"
            ))
            .at("header"));
        }
        let mut body = vec![0u8; len as usize + 4];
        file.read_exact(&mut body)
            .map_err(|e| IoError::os(path, "cannot read", e))?;
        let (body, crc) = body.split_at(len as usize);
        if crc32fast::hash(body) != u32_at(crc, 0) {
            return Err(err("header checksum mismatch (the file is corrupt)".into()).at("header"));
        }
        let raw = match body.first() {
            Some(0) => body[1..].to_vec(),
            Some(1) => {
                let mut c = Cursor { b: body, pos: 1 };
                let n = c.varint().map_err(|e| err(format!("header: {e}")))?;
                if n > MAX_SECTION as u64 {
                    return Err(err(format!("header of {n} bytes")).at("header"));
                }
                inflate(&body[c.pos..], n as usize).map_err(|e| err(format!("header: {e}")))?
            }
            other => {
                return Err(err(format!("unknown header encoding {other:?}")).at("header"));
            }
        };
        let header = CodecHeader::from_bytes(&raw)
            .map_err(|e| err(format!("unreadable header: {e}")).at("header"))?;
        if !READ_MODELS.contains(&header.model) {
            return Err(err(format!(
                "codec model {} (written by strandfit {}); this build reads models {READ_MODELS:?}",
                header.model, header.written_by
            )));
        }
        if !(header.tolerance.is_finite() && header.tolerance > 0.0) {
            return Err(err(format!(
                "header tolerance {} is not positive",
                header.tolerance
            )));
        }
        let st = header.steps;
        if ![st.offset, st.length, st.start, st.first, st.sagitta]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0 && *v < 1e6)
        {
            return Err(err("header steps out of range (corrupt file)".into()));
        }
        // End record and index.
        let mut end = [0u8; END_LEN as usize];
        file.seek(SeekFrom::Start(size - END_LEN))
            .and_then(|_| file.read_exact(&mut end))
            .map_err(|e| IoError::os(path, "cannot read", e))?;
        if end[8..] != END_MAGIC {
            return Err(err("no end record (truncated file?)".into()).at("end"));
        }
        let idx_len = u32_at(&end, 4) as u64;
        if idx_len == 0 || data_start + idx_len + END_LEN > size {
            return Err(err(format!("index of {idx_len} bytes outside the file")).at("end"));
        }
        let index_at = size - END_LEN - idx_len;
        let mut idx = vec![0u8; idx_len as usize];
        file.seek(SeekFrom::Start(index_at))
            .and_then(|_| file.read_exact(&mut idx))
            .map_err(|e| IoError::os(path, "cannot read", e))?;
        if crc32fast::hash(&idx) != u32_at(&end, 0) {
            return Err(err("index checksum mismatch (the file is corrupt)".into()).at("index"));
        }
        let bad_index = |why: String| err(format!("{why} (corrupt file)")).at("index");
        let mut c = Cursor { b: &idx, pos: 0 };
        let n = c.count().map_err(bad_index)?;
        let mut blocks = Vec::with_capacity(n);
        let (mut first, mut at) = (0u64, data_start);
        for k in 0..n {
            let len = c.varint().map_err(bad_index)?;
            let curves = c.varint().map_err(bad_index)?;
            if len < 7 || len > index_at - at || curves == 0 || curves > u32::MAX as u64 {
                return Err(bad_index(format!("index entry {k} is inconsistent")));
            }
            blocks.push((at, len, curves as u32, first));
            at += len;
            first += curves;
        }
        if c.pos != idx.len() || at != index_at {
            return Err(bad_index(
                "the index does not account for the blocks".into(),
            ));
        }
        Ok(CodecReader {
            path: path.to_path_buf(),
            file,
            header,
            blocks,
            curves: first,
            bytes_read: data_start + END_LEN + idx_len,
            size,
        })
    }

    /// The container's header.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let r = CodecReader::from_bytes(container(1)).unwrap();
    /// assert_eq!(r.header(), &header());
    /// assert_eq!(r.header().tolerance, 0.01);
    /// ```
    pub fn header(&self) -> &CodecHeader {
        &self.header
    }

    /// The file read (a placeholder for bytes in memory).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("in.sfh");
    /// std::fs::write(&path, container(1)).unwrap();
    /// assert_eq!(CodecReader::open(&path).unwrap().path(), path);
    /// let r = CodecReader::from_bytes(container(1)).unwrap();
    /// assert_eq!(r.path(), std::path::Path::new(IN_MEMORY));
    /// ```
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Number of curves in the container.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// assert_eq!(CodecReader::from_bytes(container(3)).unwrap().curve_count(), 6);
    /// assert_eq!(CodecReader::from_bytes(container(0)).unwrap().curve_count(), 0);
    /// ```
    pub fn curve_count(&self) -> u64 {
        self.curves
    }

    /// Number of blocks in the container.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// assert_eq!(CodecReader::from_bytes(container(3)).unwrap().block_count(), 3);
    /// ```
    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }

    /// Bytes read from the container so far: its header, end record and
    /// index at opening, then each block read.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// // Opening reads the ends of the container; each block is read on demand.
    /// let mut r = CodecReader::from_bytes(container(3)).unwrap();
    /// let mut read = r.bytes_read();
    /// for k in 0..3 {
    ///     assert!(read < r.size());
    ///     r.read_block_bytes(k).unwrap();
    ///     assert!(r.bytes_read() > read);
    ///     read = r.bytes_read();
    /// }
    /// assert_eq!(r.bytes_read(), r.size());
    /// ```
    pub fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// Size of the container in bytes.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let bytes = container(2);
    /// assert_eq!(CodecReader::from_bytes(bytes.clone()).unwrap().size(), bytes.len() as u64);
    /// ```
    pub fn size(&self) -> u64 {
        self.size
    }

    /// First curve and curve count of block `k`.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let r = CodecReader::from_bytes(container(3)).unwrap();
    /// let spans: Vec<_> = (0..r.block_count()).map(|k| r.block_span(k)).collect();
    /// assert_eq!(spans, [(0, 2), (2, 2), (4, 2)]);
    /// ```
    pub fn block_span(&self, k: usize) -> (u64, u64) {
        (self.blocks[k].3, self.blocks[k].2 as u64)
    }

    /// The raw bytes of block `k` (geometry, side), checked against their
    /// CRC; cheap enough to call from one thread while others decode.
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let mut bytes = container(1);
    /// let b = CodecReader::from_bytes(bytes.clone()).unwrap().read_block_bytes(0).unwrap();
    /// assert_eq!((b.index, b.first, b.curves), (0, 0, 2));
    /// // A damaged block (the byte 20 from the end is in the block, before the
    /// // index and the end record) opens, but does not read.
    /// let at = bytes.len() - 20;
    /// bytes[at] ^= 1;
    /// let mut r = CodecReader::from_bytes(bytes).unwrap();
    /// let err = r.read_block_bytes(0).err().unwrap();
    /// assert!(err.to_string().contains("block checksum mismatch"), "{err}");
    /// ```
    pub fn read_block_bytes(&mut self, k: usize) -> Result<RawBlock, IoError> {
        let (off, len, curves, first) = self.blocks[k];
        let path = self.path.clone();
        let err = |why: String| {
            IoError::new(&path, why)
                .curve(first)
                .at(format!("block {k}"))
        };
        if len > MAX_SECTION as u64 * 3 {
            return Err(err(format!("a block of {len} bytes")));
        }
        let mut b = vec![0u8; len as usize];
        self.file
            .seek(SeekFrom::Start(off))
            .and_then(|_| self.file.read_exact(&mut b))
            .map_err(|e| err(format!("cannot read the block: {e}")))?;
        self.bytes_read += len;
        let (body, crc) = b.split_at(b.len() - 4);
        if crc32fast::hash(body) != u32_at(crc, 0) {
            return Err(err("block checksum mismatch (the file is corrupt)".into()));
        }
        let mut c = Cursor { b: body, pos: 0 };
        let mut field = || c.varint().map_err(|e| err(format!("block head: {e}")));
        let (n, g, s) = (field()?, field()?, field()?);
        let s_raw = if s > 0 { field()? } else { 0 };
        if n != curves as u64 {
            return Err(err(
                "block header does not match the index (corrupt file)".into()
            ));
        }
        if s_raw > MAX_SECTION as u64 || g.checked_add(s) != Some((body.len() - c.pos) as u64) {
            return Err(err(
                "block lengths do not add up to the block (corrupt file)".into(),
            ));
        }
        // The parts stay in the buffer read: no copies (measured no faster
        // on 2 cores, but two fresh allocations fewer per block).
        let geometry = c.pos..c.pos + g as usize;
        let side = geometry.end..body.len();
        Ok(RawBlock {
            index: k,
            first,
            curves,
            bytes: b,
            geometry,
            side,
            side_len: s_raw as u32,
        })
    }
}

/// A block's checked bytes, decoded by [`RawBlock::decode`].
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
/// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
/// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
/// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
/// #     w.finish_bytes().unwrap()
/// # }
///
/// let mut r = CodecReader::from_bytes(container(3)).unwrap();
/// let b = r.read_block_bytes(2).unwrap();
/// assert_eq!((b.index, b.first, b.curves), (2, 4, 2));
/// ```
pub struct RawBlock {
    /// Index of the block in the container.
    pub index: usize,
    /// Index of the block's first curve.
    pub first: u64,
    /// Number of curves in the block.
    pub curves: u32,
    /// The block as read, checksum included; the parts are ranges of it.
    bytes: Vec<u8>,
    geometry: std::ops::Range<usize>,
    side: std::ops::Range<usize>,
    side_len: u32,
}

impl RawBlock {
    /// The geometry stream.
    fn geometry(&self) -> &[u8] {
        &self.bytes[self.geometry.clone()]
    }

    /// The side data, compressed.
    fn side(&self) -> &[u8] {
        &self.bytes[self.side.clone()]
    }

    /// The block's curves (pure computation: run blocks in parallel).
    ///
    /// ```
    /// # use strandfit::codec::*;
    /// # use strandfit::io::{Format, Metadata, SourceMeta};
    /// # use strandfit::DVec3;
    /// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
    /// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
    /// # }
    /// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
    /// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
    /// # }
    /// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
    /// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
    /// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
    /// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
    /// #     }).collect()
    /// # }
    /// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
    /// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
    /// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
    /// #     w.finish_bytes().unwrap()
    /// # }
    ///
    /// let mut r = CodecReader::from_bytes(container(2)).unwrap();
    /// let b = r.read_block_bytes(1).unwrap();
    /// let curves = b.decode(r.path(), r.header()).unwrap();
    /// assert_eq!(curves.len(), 2);
    /// // Curves 2 and 3 of the container, within the tolerance.
    /// for (k, c) in curves.iter().enumerate() {
    ///     let h = strandfit::metrics::hausdorff(&helix(2 + k), &c.points).unwrap();
    ///     assert!(h <= 0.01, "{h}");
    ///     assert!(c.id.is_none() && c.point_data.is_empty() && c.curve_data.is_empty());
    /// }
    /// ```
    pub fn decode(&self, path: &Path, header: &CodecHeader) -> Result<Vec<DecodedCurve>, IoError> {
        let err = |curve: u64, why: String| {
            IoError::new(path, why)
                .curve(curve)
                .at(format!("block {}", self.index))
        };
        let n = self.curves as usize;
        let pts = decode_block(self.geometry(), n, &header.params()).map_err(|e| match e {
            super::DecodeError::Curve { curve, why } => err(self.first + curve as u64, why),
            e => err(self.first, e.to_string()),
        })?;
        let n_cd = header.source.curve_data_names.len();
        let n_pd = header.point_data_names.len();
        let side = if self.side_len == 0 && self.side().is_empty() {
            // No side data: no ids, and no per-curve or per-point values.
            if n_cd > 0 || n_pd > 0 {
                return Err(err(
                    self.first,
                    "per-curve or per-point values missing from the block".into(),
                ));
            }
            vec![0u8; n]
        } else {
            inflate(self.side(), self.side_len as usize)
                .map_err(|e| err(self.first, format!("side data: {e}")))?
        };
        let mut c = Cursor { b: &side, pos: 0 };
        let mut out = Vec::with_capacity(n.min(1 << 16));
        for (k, points) in pts.into_iter().enumerate() {
            let curve = self.first + k as u64;
            let read = || -> Result<DecodedCurve, String> {
                let id_len = c.varint()?;
                let id = if id_len == 0 {
                    None
                } else {
                    let b = c.take((id_len - 1).min(usize::MAX as u64) as usize)?;
                    Some(String::from_utf8(b.to_vec()).map_err(|_| "an id that is not UTF-8")?)
                };
                let mut curve_data = Vec::with_capacity(n_cd);
                for _ in 0..n_cd {
                    let b = c.take(4)?;
                    curve_data.push(f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                }
                Ok(DecodedCurve {
                    id,
                    points,
                    point_data: Vec::new(),
                    curve_data,
                })
            };
            out.push(read().map_err(|e| err(curve, format!("side data: {e}")))?);
        }
        if n_pd > 0 {
            let mut total = 0usize;
            for (k, d) in out.iter().enumerate() {
                let m = c
                    .varint()
                    .map_err(|e| err(self.first + k as u64, format!("side data: {e}")))?;
                if m != d.points.len() as u64 {
                    return Err(err(
                        self.first + k as u64,
                        format!(
                            "per-point values for {m} points, but {} decode",
                            d.points.len()
                        ),
                    ));
                }
                total += d.points.len() * n_pd;
            }
            let left = side.len() - c.pos;
            if left != 4 * total {
                return Err(err(
                    self.first,
                    format!(
                        "side data: {left} bytes of per-point values where {} are due",
                        4 * total
                    ),
                ));
            }
            let planes = &side[c.pos..];
            let mut v = 0usize;
            for d in &mut out {
                d.point_data.reserve(d.points.len() * n_pd);
                for _ in 0..d.points.len() * n_pd {
                    let b = [0, 1, 2, 3].map(|p| planes[p * total + v]);
                    d.point_data.push(f32::from_le_bytes(b));
                    v += 1;
                }
            }
            c.pos = side.len();
        }
        if c.pos != side.len() {
            return Err(err(
                self.first,
                "side data left over after the block's last curve".into(),
            ));
        }
        Ok(out)
    }
}

/// The version of the container at `path` (its bytes 8–9), if it is one.
///
/// ```
/// # use strandfit::codec::*;
/// # use strandfit::io::{Format, Metadata, SourceMeta};
/// # use strandfit::DVec3;
/// # fn header() -> CodecHeader { // tolerance 0.01, nothing else
/// #     CodecHeader::new(0.01, SourceMeta::from_metadata(&Metadata::new(Format::Json), None), vec![])
/// # }
/// # fn helix(k: usize) -> Vec<DVec3> { // 30 points, raised by k
/// #     (0..30).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s + k as f64)).collect()
/// # }
/// # fn blocks(h: &CodecHeader, n: usize) -> Vec<BlockBytes> { // block b: helices 2b and 2b + 1
/// #     (0..n).map(|b| [helix(2 * b), helix(2 * b + 1)]).map(|[p, q]| {
/// #         let c = [&p, &q].map(|points| CurveIn { id: None, points, point_data: &[], curve_data: &[] });
/// #         encode_block_bytes(&c, &h.params(), 0, 0).unwrap()
/// #     }).collect()
/// # }
/// # fn container(n: usize) -> Vec<u8> { // n blocks, in memory
/// #     let (h, mut w) = (header(), CodecWriter::in_memory(&header()));
/// #     blocks(&h, n).iter().for_each(|b| w.write_block(b).unwrap());
/// #     w.finish_bytes().unwrap()
/// # }
///
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("in.sfh");
/// std::fs::write(&path, container(1)).unwrap();
/// assert_eq!(container_version(&path), Some(CONTAINER_VERSION));
/// std::fs::write(&path, "not a container").unwrap();
/// assert_eq!(container_version(&path), None);
/// assert_eq!(container_version(&dir.path().join("missing.sfh")), None);
/// ```
pub fn container_version(path: &Path) -> Option<u16> {
    let mut b = [0u8; 10];
    File::open(path)
        .and_then(|mut f| f.read_exact(&mut b))
        .ok()?;
    (b[..8] == MAGIC).then(|| u16::from_le_bytes([b[8], b[9]]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::stream::read_range;
    use crate::io::SourceMeta;
    use crate::io::{Format, Metadata};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn header(names: usize) -> CodecHeader {
        let mut m = Metadata::new(Format::Json);
        m.curve_data_names = (0..names).map(|k| format!("v{k}")).collect();
        CodecHeader::new(0.1, SourceMeta::from_metadata(&m, None), vec!["s".into()])
    }

    /// Per point, its arc length (the curves' points are 0.3 apart along
    /// a helix of pitch 0.2: 0.3·√1.04 in space, near enough).
    fn arc_values(p: &[DVec3]) -> Vec<f32> {
        (0..p.len()).map(|i| i as f32 * 0.3).collect()
    }

    fn curves(n: usize, rng: &mut ChaCha8Rng) -> Vec<(Option<String>, Vec<DVec3>, Vec<f32>)> {
        (0..n)
            .map(|k| {
                let r = rng.gen_range(1.0..10.0);
                let m = rng.gen_range(0..40);
                let pts = (0..m)
                    .map(|i| {
                        let s = i as f64 * 0.3;
                        DVec3::new(r * (s / r).cos(), r * (s / r).sin(), 0.2 * s + k as f64)
                    })
                    .collect();
                let id = (k % 3 != 0).then(|| format!("c{k}"));
                (id, pts, vec![k as f32, -1.5])
            })
            .collect()
    }

    /// Writes `cs` in blocks of `per_block` curves.
    fn write(path: &Path, cs: &[(Option<String>, Vec<DVec3>, Vec<f32>)], per_block: usize) -> u64 {
        let h = header(2);
        let mut w = CodecWriter::create(path, &h).unwrap();
        write_blocks(&mut w, &h, cs, per_block);
        w.finish().unwrap()
    }

    /// Encodes `cs` in blocks of `per_block` curves into `w`.
    fn write_blocks(
        w: &mut CodecWriter,
        h: &CodecHeader,
        cs: &[(Option<String>, Vec<DVec3>, Vec<f32>)],
        per_block: usize,
    ) {
        for chunk in cs.chunks(per_block) {
            let values: Vec<Vec<f32>> = chunk.iter().map(|(_, p, _)| arc_values(p)).collect();
            let ins: Vec<CurveIn> = chunk
                .iter()
                .zip(&values)
                .map(|((id, p, d), v)| CurveIn {
                    id: id.as_deref(),
                    points: p,
                    point_data: v,
                    curve_data: d,
                })
                .collect();
            let b = encode_block_bytes(&ins, &h.params(), 2, 1).unwrap();
            b.verify(&h.params()).unwrap();
            w.write_block(&b).unwrap();
        }
    }

    #[test]
    fn a_container_in_memory_is_the_file_and_reads_back_the_same() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let cs = curves(30, &mut rng);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.sfh");
        write(&p, &cs, 7);
        let file = std::fs::read(&p).unwrap();
        // The same blocks into memory.
        let h = header(2);
        let mut w = CodecWriter::in_memory(&h);
        assert_eq!(w.target(), Path::new(IN_MEMORY));
        write_blocks(&mut w, &h, &cs, 7);
        let memory = w.finish_bytes().unwrap();
        assert_eq!(memory, file);
        let mut from_file = CodecReader::open(&p).unwrap();
        let mut from_bytes = CodecReader::from_bytes(memory.clone()).unwrap();
        assert_eq!(from_bytes.block_count(), 5);
        let a = read_range(&mut from_file, 3, 20).unwrap();
        let b = read_range(&mut from_bytes, 3, 20).unwrap();
        assert_eq!(a, b);
        // Damage in memory is named as such.
        let mut bad = memory;
        let k = bad.len() / 2;
        bad[k] ^= 0x55;
        let e = CodecReader::from_bytes(bad)
            .and_then(|mut r| {
                let n = r.curve_count();
                read_range(&mut r, 0, n)
            })
            .unwrap_err();
        assert!(e.to_string().starts_with(IN_MEMORY), "{e}");
        assert!(CodecReader::from_bytes(b"short".to_vec()).is_err());
    }

    #[test]
    fn blocks_round_trip_and_ranges_read_only_their_blocks() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let cs = curves(50, &mut rng);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.sfh");
        let bytes = write(&p, &cs, 7);
        assert_eq!(bytes, std::fs::metadata(&p).unwrap().len());
        let mut r = CodecReader::open(&p).unwrap();
        assert_eq!(r.curve_count(), 50);
        assert_eq!(r.block_count(), 8);
        let all = read_range(&mut r, 0, 50).unwrap();
        for (k, (c, (id, pts, d))) in all.iter().zip(&cs).enumerate() {
            assert_eq!(&c.id, id, "curve {k}");
            assert_eq!(&c.curve_data, d);
            if pts.is_empty() {
                assert!(c.points.is_empty());
            } else {
                assert!(crate::metrics::hausdorff(pts, &c.points).unwrap() <= 0.1);
            }
            // The per-point values came along onto the decoded points: one
            // each, rising along the curve from the first value to the last.
            assert_eq!(c.point_data.len(), c.points.len(), "curve {k}");
            let want = arc_values(pts);
            if let (Some(a), Some(b)) = (c.point_data.first(), want.first()) {
                assert!((a - b).abs() <= 0.35, "curve {k}: starts at {a}");
                let (a, b) = (c.point_data.last().unwrap(), want.last().unwrap());
                assert!((a - b).abs() <= 0.35, "curve {k}: ends at {a}, not {b}");
            }
            assert!(c.point_data.windows(2).all(|w| w[1] >= w[0]), "curve {k}");
        }
        let mid = read_range(&mut r, 13, 9).unwrap();
        assert_eq!(mid.len(), 9);
        assert_eq!(mid[0], all[13]);
        assert_eq!(mid[8], all[21]);
        assert!(read_range(&mut r, 60, 5).unwrap().is_empty());
    }

    #[test]
    fn an_empty_container_is_valid() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.sfh");
        write(&p, &[], 4);
        let r = CodecReader::open(&p).unwrap();
        assert_eq!((r.curve_count(), r.block_count()), (0, 0));
    }

    #[test]
    fn damage_is_an_error_never_a_panic() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let cs = curves(30, &mut rng);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.sfh");
        write(&p, &cs, 8);
        let good = std::fs::read(&p).unwrap();
        let q = dir.path().join("bad.sfh");
        let (mut opened, mut decoded) = (0, 0);
        for trial in 0..600 {
            let mut b = good.clone();
            if trial % 4 == 0 {
                b.truncate(rng.gen_range(0..b.len()));
            } else {
                for _ in 0..rng.gen_range(1..4) {
                    let at = rng.gen_range(0..b.len());
                    b[at] ^= 1 << rng.gen_range(0..8);
                }
            }
            std::fs::write(&q, &b).unwrap();
            let Ok(mut r) = CodecReader::open(&q) else {
                continue;
            };
            opened += 1;
            let h = r.header().clone();
            let ok = (0..r.block_count()).all(|k| {
                r.read_block_bytes(k)
                    .and_then(|raw| raw.decode(&q, &h))
                    .is_ok()
            });
            decoded += ok as usize;
        }
        // Flips inside the CRC-covered parts are caught: only flips that
        // change nothing checked (none here) could decode.
        assert!(opened > 0);
        assert!(decoded < 600 / 4, "{decoded} damaged files decoded");
    }

    #[test]
    fn the_writer_refuses_mismatched_curve_and_point_data() {
        let h = header(2);
        let p = [DVec3::ZERO, DVec3::X];
        let ins = [CurveIn {
            id: None,
            points: &p,
            point_data: &[0.0, 1.0],
            curve_data: &[1.0],
        }];
        let e = encode_block_bytes(&ins, &h.params(), 2, 1).err().unwrap();
        assert!(e.1.contains("per-curve values"), "{}", e.1);
        let ins = [CurveIn {
            id: None,
            points: &p,
            point_data: &[0.0],
            curve_data: &[1.0, 2.0],
        }];
        let e = encode_block_bytes(&ins, &h.params(), 2, 1).err().unwrap();
        assert!(e.1.contains("per-point values"), "{}", e.1);
    }
}
