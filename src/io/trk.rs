//! TrackVis `.trk` tractograms: the reader and the writer. The format and
//! what the reader makes of it are described on `open` (`io::open_trk`),
//! the header the writer writes on `create` (`io::create_trk`).

use std::fmt::Write as _;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DVec3};

use super::bytes::{ByteSource, Endian};
use super::format::Format;
use super::{AtomicFile, Curve, CurveReader, CurveWriter, IoError, Metadata};

/// The [`Metadata::extra`] key of the source's 1000-byte header, as 2000
/// lowercase hex digits.
pub const HEADER_KEY: &str = "trk_header";

const HEADER_SIZE: usize = 1000;
const MAGIC: &[u8; 5] = b"TRACK";
const MAX_NAMES: usize = 10;
const NAME_LEN: usize = 20;
/// Bytes per buffered read of points.
const CHUNK_BYTES: usize = 1 << 16;

/// Byte offsets of the header fields.
mod off {
    pub const DIM: usize = 6;
    pub const VOXEL_SIZE: usize = 12;
    pub const N_SCALARS: usize = 36;
    pub const SCALAR_NAME: usize = 38;
    pub const N_PROPERTIES: usize = 238;
    pub const PROPERTY_NAME: usize = 240;
    pub const VOX_TO_RAS: usize = 440;
    pub const VOXEL_ORDER: usize = 948;
    pub const N_COUNT: usize = 988;
    pub const VERSION: usize = 992;
    pub const HDR_SIZE: usize = 996;
}

fn get4(raw: &[u8], at: usize) -> [u8; 4] {
    [raw[at], raw[at + 1], raw[at + 2], raw[at + 3]]
}

fn get_i32(raw: &[u8], at: usize, e: Endian) -> i32 {
    match e {
        Endian::Little => i32::from_le_bytes(get4(raw, at)),
        Endian::Big => i32::from_be_bytes(get4(raw, at)),
    }
}

fn get_f32(raw: &[u8], at: usize, e: Endian) -> f32 {
    match e {
        Endian::Little => f32::from_le_bytes(get4(raw, at)),
        Endian::Big => f32::from_be_bytes(get4(raw, at)),
    }
}

fn get_i16(raw: &[u8], at: usize, e: Endian) -> i16 {
    let b = [raw[at], raw[at + 1]];
    match e {
        Endian::Little => i16::from_le_bytes(b),
        Endian::Big => i16::from_be_bytes(b),
    }
}

fn put(raw: &mut [u8], at: usize, b: &[u8]) {
    raw[at..at + b.len()].copy_from_slice(b);
}

fn i16_bytes(v: i16, e: Endian) -> [u8; 2] {
    match e {
        Endian::Little => v.to_le_bytes(),
        Endian::Big => v.to_be_bytes(),
    }
}

fn i32_bytes(v: i32, e: Endian) -> [u8; 4] {
    match e {
        Endian::Little => v.to_le_bytes(),
        Endian::Big => v.to_be_bytes(),
    }
}

fn f32_bytes(v: f32, e: Endian) -> [u8; 4] {
    match e {
        Endian::Little => v.to_le_bytes(),
        Endian::Big => v.to_be_bytes(),
    }
}

/// For each voxel axis, the world axis (0 = R, 1 = A, 2 = S) it runs along
/// and its direction (±1).
type Orientation = [(usize, f64); 3];

/// The orientation of a `voxel_order` code such as `RAS` or `LPS`.
fn order_orientation(code: &str) -> Option<Orientation> {
    let mut o = [(0, 0.0); 3];
    let mut seen = [false; 3];
    let mut chars = code.chars();
    for slot in &mut o {
        let axis = match chars.next()?.to_ascii_uppercase() {
            'L' => (0, -1.0),
            'R' => (0, 1.0),
            'P' => (1, -1.0),
            'A' => (1, 1.0),
            'I' => (2, -1.0),
            'S' => (2, 1.0),
            _ => return None,
        };
        if std::mem::replace(&mut seen[axis.0], true) {
            return None;
        }
        *slot = axis;
    }
    chars.next().is_none().then_some(o)
}

/// The `voxel_order` code of an orientation.
fn orientation_code(o: &Orientation) -> String {
    o.iter()
        .map(|&(axis, dir)| ["LR", "PA", "IS"][axis].as_bytes()[usize::from(dir > 0.0)] as char)
        .collect()
}

/// The axis directions of an affine's voxel axes, as nibabel's
/// `io_orientation`: columns normalised, the closest orthogonal matrix (polar
/// decomposition), then each voxel axis, strongest first, takes the world
/// axis it moves most along. `None` when the affine is (nearly) singular.
fn affine_orientation(m: &DMat4) -> Option<Orientation> {
    let rzs = DMat3::from_mat4(*m);
    let unit = |c: DVec3| {
        let n = c.length();
        if n > 0.0 {
            c / n
        } else {
            c
        }
    };
    let rs = DMat3::from_cols(unit(rzs.x_axis), unit(rzs.y_axis), unit(rzs.z_axis));
    if !rs.is_finite() || rs.determinant().abs() < 1e-12 {
        return None;
    }
    // Newton's iteration for the orthogonal polar factor; it only has to be
    // good enough for an argmax.
    let mut r = rs;
    for _ in 0..100 {
        let next = (r + r.inverse().transpose()) * 0.5;
        let step = (next - r)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        r = next;
        if !(step > 1e-14) {
            break;
        }
    }
    if !r.is_finite() {
        return None;
    }
    // rows[world][voxel]
    let mut rows = r.transpose().to_cols_array_2d();
    let strength =
        |col: usize, rows: &[[f64; 3]; 3]| (0..3).map(|w| rows[w][col].powi(2)).fold(0.0, f64::max);
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| strength(b, &rows).total_cmp(&strength(a, &rows)));
    let mut o: [Option<(usize, f64)>; 3] = [None; 3];
    for col in axes {
        let c = [rows[0][col], rows[1][col], rows[2][col]];
        if c.iter().all(|v| v.abs() <= 1e-8) {
            continue;
        }
        let mut w = 0;
        for k in 1..3 {
            if c[k].abs() > c[w].abs() {
                w = k;
            }
        }
        o[col] = Some((w, c[w].signum()));
        rows[w] = [0.0; 3];
    }
    Some([o[0]?, o[1]?, o[2]?])
}

/// The voxel-to-voxel affine that takes coordinates in the axis order and
/// directions of `to` back to those of `from` for an image of `dims` voxels
/// (nibabel's `inv_ornt_aff(ornt_transform(from, to), dims)`).
fn reorientation(from: &Orientation, to: &Orientation, dims: [u32; 3]) -> DMat4 {
    let mut rows = [[0.0; 4]; 4];
    rows[3][3] = 1.0;
    for (k, &(axis, dir)) in from.iter().enumerate() {
        // `to` holds every axis once (both come from checked orientations).
        let (j, to_dir) = to
            .iter()
            .enumerate()
            .find(|(_, t)| t.0 == axis)
            .map_or((k, dir), |(j, t)| (j, t.1));
        let flip = if dir == to_dir { 1.0 } else { -1.0 };
        let centre = -(f64::from(dims[k]) - 1.0) / 2.0;
        rows[k][j] = flip;
        rows[k][3] = flip * centre - centre;
    }
    DMat4::from_cols_array_2d(&rows).transpose()
}

/// A parsed header, with what the reader and writer derive from it.
#[derive(Clone, Debug)]
struct Header {
    endian: Endian,
    dims: [u32; 3],
    voxel_size: [f64; 3],
    /// The stored `vox_to_ras`, or the identity where it is not recorded.
    vox_to_ras: DMat4,
    scalar_names: Vec<String>,
    property_names: Vec<String>,
    /// 0 = unknown.
    n_count: u64,
    /// voxmm → RAS+ mm.
    voxmm_to_ras: DMat4,
}

impl Header {
    fn parse(raw: &[u8; HEADER_SIZE], path: &Path) -> Result<Header, IoError> {
        let field = |name: &str, reason: String| {
            IoError::new(path, reason).at(format!("header field `{name}`"))
        };
        if &raw[..MAGIC.len()] != MAGIC {
            return Err(IoError::new(
                path,
                "not a TrackVis .trk file: it does not start with `TRACK`",
            )
            .at("byte 0"));
        }
        let endian = if get_i32(raw, off::HDR_SIZE, Endian::Little) == HEADER_SIZE as i32 {
            Endian::Little
        } else if get_i32(raw, off::HDR_SIZE, Endian::Big) == HEADER_SIZE as i32 {
            Endian::Big
        } else {
            return Err(field(
                "hdr_size",
                format!(
                    "hdr_size is {}, not 1000 in either byte order",
                    get_i32(raw, off::HDR_SIZE, Endian::Little)
                ),
            ));
        };
        let e = endian;
        let version = get_i32(raw, off::VERSION, e);
        if !(1..=3).contains(&version) {
            return Err(field(
                "version",
                format!(
                    "unsupported version {version}; versions 1 and 2 are known (3 is read as 2)"
                ),
            ));
        }
        let mut dims = [0u32; 3];
        for (k, d) in dims.iter_mut().enumerate() {
            let v = get_i16(raw, off::DIM + 2 * k, e);
            *d = u32::try_from(v)
                .map_err(|_| field("dim", format!("dimension {k} is negative ({v})")))?;
        }
        let mut voxel_size = [0.0; 3];
        for (k, s) in voxel_size.iter_mut().enumerate() {
            let v = get_f32(raw, off::VOXEL_SIZE + 4 * k, e);
            if !v.is_finite() || v == 0.0 {
                return Err(field(
                    "voxel_size",
                    format!("voxel size {k} is {v}; it must be finite and non-zero"),
                ));
            }
            *s = f64::from(v);
        }
        let count = |at: usize, name: &str| -> Result<usize, IoError> {
            let v = get_i16(raw, at, e);
            usize::try_from(v).map_err(|_| field(name, format!("{name} is negative ({v})")))
        };
        let n_scalars = count(off::N_SCALARS, "n_scalars")?;
        let n_properties = count(off::N_PROPERTIES, "n_properties")?;
        let scalar_names = decode_names(
            raw,
            off::SCALAR_NAME,
            n_scalars,
            "scalars",
            "scalar_name",
            "n_scalars",
            path,
        )?;
        let property_names = decode_names(
            raw,
            off::PROPERTY_NAME,
            n_properties,
            "properties",
            "property_name",
            "n_properties",
            path,
        )?;

        let mut rows = [[0.0; 4]; 4];
        if version != 1 {
            for (r, row) in rows.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = f64::from(get_f32(raw, off::VOX_TO_RAS + 4 * (4 * r + c), e));
                }
            }
        }
        if rows.iter().flatten().any(|v| !v.is_finite()) {
            return Err(field(
                "vox_to_ras",
                "vox_to_ras has a non-finite entry".into(),
            ));
        }
        let vox_to_ras = if rows[3][3] == 0.0 {
            DMat4::IDENTITY
        } else {
            DMat4::from_cols_array_2d(&rows).transpose()
        };
        let affine_ornt = affine_orientation(&vox_to_ras).ok_or_else(|| {
            field(
                "vox_to_ras",
                "vox_to_ras is singular: its voxel axes have no directions".into(),
            )
        })?;

        let order_bytes = &raw[off::VOXEL_ORDER..off::VOXEL_ORDER + 4];
        let order: String = order_bytes
            .iter()
            .take_while(|&&b| b != 0)
            .map(|&b| b as char)
            .collect();
        let order = if order.is_empty() {
            "LPS".to_string()
        } else {
            order
        };
        let header_ornt = order_orientation(&order).ok_or_else(|| {
            field(
                "voxel_order",
                format!(
                    "voxel_order {order:?} is not three distinct axis letters such as RAS or LPS"
                ),
            )
        })?;

        let n_count = get_i32(raw, off::N_COUNT, e);
        let n_count = u64::try_from(n_count).map_err(|_| {
            field(
                "n_count",
                format!("absurd n_count {n_count}: it is negative"),
            )
        })?;

        let scale = DMat4::from_scale(DVec3::from_array(voxel_size).recip());
        let half = DMat4::from_translation(DVec3::splat(-0.5));
        let reorder = reorientation(&header_ornt, &affine_ornt, dims);
        let voxmm_to_ras = vox_to_ras * reorder * half * scale;

        Ok(Header {
            endian,
            dims,
            voxel_size,
            vox_to_ras,
            scalar_names,
            property_names,
            n_count,
            voxmm_to_ras,
        })
    }
}

/// The value names in ten 20-byte fields at `at`, for `n` values per point
/// (or streamline). The encoding is described on [`open`] (Format).
fn decode_names(
    raw: &[u8],
    at: usize,
    n: usize,
    unnamed: &str,
    field: &str,
    count_field: &str,
    path: &Path,
) -> Result<Vec<String>, IoError> {
    let err = |reason: String| IoError::new(path, reason).at(format!("header field `{field}`"));
    let mut names = Vec::new();
    if n == 0 {
        // nibabel ignores the names then, and so do we.
        return Ok(names);
    }
    for i in 0..MAX_NAMES {
        let b = &raw[at + NAME_LEN * i..at + NAME_LEN * (i + 1)];
        let end = b.iter().rposition(|&c| c != 0).map_or(0, |p| p + 1);
        if end == 0 {
            continue;
        }
        let text: String = b[..end].iter().map(|&c| c as char).collect();
        let parts: Vec<&str> = text.split('\0').collect();
        let (name, k) = match parts.as_slice() {
            [name] => (*name, 1usize),
            [name, k] => (
                *name,
                k.trim().parse::<usize>().map_err(|_| {
                    err(format!(
                        "{field} {i} ({text:?}): the value count after the NUL is not a number"
                    ))
                })?,
            ),
            _ => {
                return Err(err(format!(
                    "{field} {i} ({text:?}) has stray bytes after its NUL"
                )))
            }
        };
        if k > n - names.len() {
            return Err(err(format!(
                "the {field} fields name more than the {n} values {count_field} announces"
            )));
        }
        match k {
            1 => names.push(name.to_string()),
            _ => names.extend((0..k).map(|j| format!("{name}[{j}]"))),
        }
    }
    match n - names.len() {
        0 => {}
        1 => names.push(unnamed.to_string()),
        k => names.extend((0..k).map(|j| format!("{unnamed}[{j}]"))),
    }
    Ok(names)
}

/// Ten 20-byte name fields for `names`, grouping runs `x[0]`, `x[1]`, … into
/// nibabel's `x\0N`.
fn encode_names(
    names: &[String],
    what: &str,
    path: &Path,
) -> Result<[u8; NAME_LEN * MAX_NAMES], IoError> {
    let err = |reason: String| IoError::new(path, reason);
    let mut fields = Vec::new();
    let mut i = 0;
    while i < names.len() {
        let run_base = names[i].strip_suffix("[0]");
        let mut k = 1;
        if let Some(base) = run_base {
            while names.get(i + k) == Some(&format!("{base}[{k}]")) {
                k += 1;
            }
        }
        let text = match (run_base, k) {
            (Some(base), 2..) => format!("{base}\0{k}"),
            _ => names[i].clone(),
        };
        let mut bytes = Vec::new();
        for ch in text.chars() {
            let b = u8::try_from(u32::from(ch)).map_err(|_| {
                err(format!(
                    "{what} name {:?} has a character outside Latin-1",
                    names[i]
                ))
            })?;
            bytes.push(b);
        }
        let plain = run_base.filter(|_| k >= 2).unwrap_or(&names[i]);
        if plain.is_empty() || plain.contains('\0') {
            return Err(err(format!(
                "{what} name {plain:?} must be non-empty and without NUL"
            )));
        }
        if bytes.len() > NAME_LEN {
            return Err(err(format!(
                "{what} name {plain:?} does not fit the 20 bytes of a .trk name field{}",
                if k >= 2 {
                    format!(" with its count {k}")
                } else {
                    String::new()
                }
            )));
        }
        fields.push(bytes);
        i += k;
    }
    if fields.len() > MAX_NAMES {
        return Err(err(format!(
            "a .trk file names at most {MAX_NAMES} {what} groups; these {} names make {}",
            names.len(),
            fields.len()
        )));
    }
    let mut out = [0u8; NAME_LEN * MAX_NAMES];
    for (i, f) in fields.iter().enumerate() {
        put(&mut out, NAME_LEN * i, f);
    }
    Ok(out)
}

fn to_hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(2 * bytes.len());
    for b in bytes {
        let _ = write!(s, "{b:02x}");
    }
    s
}

fn from_hex(s: &str) -> Option<Vec<u8>> {
    let digit = |c: u8| char::from(c).to_digit(16);
    let s = s.as_bytes();
    if !s.len().is_multiple_of(2) {
        return None;
    }
    s.chunks_exact(2)
        .map(|p| Some((digit(p[0])? * 16 + digit(p[1])?) as u8))
        .collect()
}

/// Open a `.trk` file: the header is read and checked now, the streamlines
/// as the iterator is driven.
///
/// A file that is not one is an error naming the file and the place:
///
/// ```
/// use strandfit::io::open_trk;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-trk-open-{}.trk", std::process::id()));
/// std::fs::write(&path, "TRACK").unwrap();
/// let err = open_trk(&path).err().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!((err.path, err.at.as_deref()), (path, Some("byte 0")));
/// assert!(err.reason.starts_with("file truncated: 5 bytes, shorter than the 1000-byte .trk header"));
/// ```
///
/// # Format
///
/// TrackVis `.trk` tractograms (versions 1 and 2; 3 read as 2, as nibabel
/// does): a 1000-byte header, then per streamline an `int32` point count,
/// `x y z` plus `n_scalars` floats per point, and `n_properties` floats.
///
/// Coordinates are "voxmm": millimetres from the *corner* of the reference
/// image's first voxel, along its voxel axes. They are mapped to RAS+ mm
/// exactly as nibabel maps them, so the two agree on every file:
/// `vox = voxmm / voxel_size − 0.5` (the half voxel moves the origin to the
/// voxel centre), then, if the header's `voxel_order` differs from the axis
/// directions of `vox_to_ras`, the flip/permutation between them (nibabel's
/// `inv_ornt_aff`, which uses `dim`), then `ras = vox_to_ras · vox`.
///
/// Header decisions:
/// - Byte order: `hdr_size` must be 1000; if it reads 1000 little endian the
///   file is little endian, if big endian, big endian; otherwise the file is
///   rejected.
/// - `vox_to_ras` with `[3][3] == 0` (not recorded, as in old files) and
///   version 1 files (no matrix) use the identity, as nibabel does: points
///   then come out in voxel units shifted by half a voxel, not millimetres,
///   unless the voxels are 1 mm. An empty `voxel_order` means `LPS`
///   (TrackVis's default, also nibabel's).
/// - `n_count == 0` means "unknown, read to the end". A non-zero `n_count`
///   must match the file: fewer streamlines is a truncation error, bytes
///   after the last one are an error too (nibabel ignores them).
/// - Per-point scalars and per-streamline properties are named by up to ten
///   20-byte fields. A plain name is one value; nibabel's `name\0N` is `N`
///   values, which come out as `name[0]` … `name[N-1]`. Values no field
///   names come out as `scalars` (or `scalars[i]`) and `properties`, as in
///   nibabel.
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Ok(Box::new(TrkReader::open(path)?))
}

/// A streaming `.trk` reader: the header, and a buffer for one chunk of
/// points.
struct TrkReader {
    src: ByteSource,
    meta: Metadata,
    endian: Endian,
    voxmm_to_ras: DMat4,
    n_scalars: usize,
    n_properties: usize,
    /// `n_count`, when the header records it.
    count: Option<u64>,
    index: u64,
    done: bool,
    buf: Vec<u8>,
}

impl TrkReader {
    fn open(path: &Path) -> Result<Self, IoError> {
        let mut src = ByteSource::open(path)?;
        if src.len() < HEADER_SIZE as u64 {
            // Say "not a .trk file" rather than "truncated" when it is not one.
            let mut head = vec![0u8; src.len() as usize];
            src.read_exact(&mut head, "the .trk header")?;
            let reason = if head.starts_with(MAGIC) || MAGIC.starts_with(&head) {
                format!(
                    "file truncated: {} bytes, shorter than the 1000-byte .trk header",
                    head.len()
                )
            } else {
                "not a TrackVis .trk file: it does not start with `TRACK`".to_string()
            };
            return Err(IoError::new(path, reason).at("byte 0"));
        }
        let raw = src.array::<HEADER_SIZE>("the .trk header")?;
        let h = Header::parse(&raw, path)?;
        let n_scalars = h.scalar_names.len();
        let n_properties = h.property_names.len();
        if h.n_count > 0 {
            // Each streamline holds at least its point count and properties.
            let least = h.n_count * (4 + 4 * n_properties as u64);
            if least > src.remaining() {
                return Err(IoError::new(
                    path,
                    format!(
                        "absurd n_count {}: that many streamlines need at least {least} bytes, \
                         but only {} bytes follow the header (n_count corrupted or file truncated)",
                        h.n_count,
                        src.remaining()
                    ),
                )
                .at("header field `n_count`"));
            }
        }
        let mut meta = Metadata::new(Format::Trk);
        meta.count = (h.n_count > 0).then_some(h.n_count);
        meta.vox_to_world = h.vox_to_ras;
        meta.voxel_size = Some(h.voxel_size);
        meta.dimensions = Some(h.dims);
        meta.units = Some("mm".into());
        meta.point_data_names = h.scalar_names;
        meta.curve_data_names = h.property_names;
        meta.extra = vec![(HEADER_KEY.to_string(), to_hex(&raw))];
        Ok(TrkReader {
            src,
            meta,
            endian: h.endian,
            voxmm_to_ras: h.voxmm_to_ras,
            n_scalars,
            n_properties,
            count: (h.n_count > 0).then_some(h.n_count),
            index: 0,
            done: false,
            buf: Vec::new(),
        })
    }

    fn path(&self) -> PathBuf {
        self.src.path().to_path_buf()
    }

    fn read_curve(&mut self) -> Result<Option<Curve>, IoError> {
        let i = self.index;
        let e = self.endian;
        let remaining = self.src.remaining();
        match self.count {
            Some(n) if i == n => {
                if remaining > 0 {
                    return Err(self.src.error(format!(
                        "n_count says {n} streamlines, but {remaining} more bytes follow the last of them"
                    )));
                }
                return Ok(None);
            }
            Some(n) if remaining == 0 => {
                return Err(self.src.error(format!(
                    "file truncated: it ends after {i} of the {n} streamlines n_count announces"
                )));
            }
            None if remaining == 0 => return Ok(None),
            _ => {}
        }
        let at = self.src.pos();
        let n = self
            .src
            .i32(e, "a streamline's point count")
            .map_err(|err| err.curve(i))?;
        let n = u64::try_from(n).map_err(|_| {
            IoError::new(&self.path(), format!("negative point count {n}"))
                .curve(i)
                .at(format!("byte {at}"))
        })?;
        let stride = 4 * (3 + self.n_scalars);
        let need = n * stride as u64 + 4 * self.n_properties as u64;
        if need > self.src.remaining() {
            return Err(IoError::new(
                &self.path(),
                format!(
                    "absurd point count {n}: the streamline needs {need} bytes, but only {} are left \
                     in the file (count corrupted or file truncated)",
                    self.src.remaining()
                ),
            )
            .curve(i)
            .at(format!("byte {at}")));
        }
        let mut points = Vec::new();
        let mut point_data = Vec::new();
        let per_chunk = (CHUNK_BYTES / stride).max(1) as u64;
        let mut left = n;
        while left > 0 {
            let k = left.min(per_chunk) as usize;
            self.buf.resize(k * stride, 0);
            self.src
                .read_exact(&mut self.buf, "points")
                .map_err(|err| err.curve(i))?;
            points.reserve(k);
            point_data.reserve(k * self.n_scalars);
            for rec in self.buf.chunks_exact(stride) {
                let v = DVec3::new(
                    f64::from(get_f32(rec, 0, e)),
                    f64::from(get_f32(rec, 4, e)),
                    f64::from(get_f32(rec, 8, e)),
                );
                // Non-finite points are refused (or skipped) by the one
                // check every reader goes through (`io::open_reader`).
                points.push(self.voxmm_to_ras.transform_point3(v));
                point_data.extend((0..self.n_scalars).map(|s| get_f32(rec, 12 + 4 * s, e)));
            }
            left -= k as u64;
        }
        self.buf.resize(4 * self.n_properties, 0);
        self.src
            .read_exact(&mut self.buf, "properties")
            .map_err(|err| err.curve(i))?;
        let curve_data = self.buf.chunks_exact(4).map(|b| get_f32(b, 0, e)).collect();
        self.index += 1;
        Ok(Some(Curve {
            id: None,
            points,
            point_data,
            curve_data,
        }))
    }
}

impl Iterator for TrkReader {
    type Item = Result<Curve, IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read_curve();
        super::fuse(&mut self.done, r)
    }
}

impl CurveReader for TrkReader {
    fn metadata(&self) -> &Metadata {
        &self.meta
    }
}

/// A little-endian version 2 header: 1 mm voxels, one voxel, identity
/// affine, RAS (nibabel's defaults).
fn default_header() -> [u8; HEADER_SIZE] {
    let e = Endian::Little;
    let mut raw = [0u8; HEADER_SIZE];
    put(&mut raw, 0, b"TRACK\0");
    for k in 0..3 {
        put(&mut raw, off::DIM + 2 * k, &i16_bytes(1, e));
        put(&mut raw, off::VOXEL_SIZE + 4 * k, &f32_bytes(1.0, e));
    }
    for k in 0..4 {
        put(&mut raw, off::VOX_TO_RAS + 4 * (5 * k), &f32_bytes(1.0, e));
    }
    put(&mut raw, off::VOXEL_ORDER, b"RAS\0");
    put(&mut raw, off::VERSION, &i32_bytes(2, e));
    put(&mut raw, off::HDR_SIZE, &i32_bytes(HEADER_SIZE as i32, e));
    raw
}

/// The header to write for curves described by `meta` (see [`create`],
/// Output), with `n_count` 0 until the end.
fn header_for(path: &Path, meta: &Metadata) -> Result<[u8; HEADER_SIZE], IoError> {
    let source = match meta.extra(HEADER_KEY) {
        Some(hex) if meta.format == Format::Trk => Some(
            from_hex(hex)
                .and_then(|b| <[u8; HEADER_SIZE]>::try_from(b).ok())
                .ok_or_else(|| {
                    IoError::new(
                        path,
                        format!("the metadata's `{HEADER_KEY}` is not 2000 hex digits"),
                    )
                })?,
        ),
        _ => None,
    };
    let from_trk = source.is_some();
    let mut raw = source.unwrap_or_else(default_header);
    let base = Header::parse(&raw, path).map_err(|e| {
        IoError::new(
            path,
            format!(
                "the source .trk header in the metadata is invalid: {}",
                e.reason
            ),
        )
    })?;
    let e = base.endian;
    let field = |name: &str, reason: String| {
        IoError::new(path, reason).at(format!("header field `{name}`"))
    };

    if meta.vox_to_world != base.vox_to_ras {
        let rows = meta.vox_to_world.transpose().to_cols_array_2d();
        for (r, row) in rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                put(
                    &mut raw,
                    off::VOX_TO_RAS + 4 * (4 * r + c),
                    &f32_bytes(*v as f32, e),
                );
            }
        }
        // Version 1 has no matrix.
        put(&mut raw, off::VERSION, &i32_bytes(2, e));
        if !from_trk {
            let o = affine_orientation(&meta.vox_to_world).ok_or_else(|| {
                field(
                    "vox_to_ras",
                    "the metadata's vox_to_world is singular: no voxel axis directions".into(),
                )
            })?;
            put(&mut raw, off::VOXEL_ORDER, orientation_code(&o).as_bytes());
        }
    }
    if let Some(vs) = meta.voxel_size.filter(|vs| *vs != base.voxel_size) {
        for (k, v) in vs.iter().enumerate() {
            put(&mut raw, off::VOXEL_SIZE + 4 * k, &f32_bytes(*v as f32, e));
        }
    }
    if let Some(dims) = meta.dimensions.filter(|d| *d != base.dims) {
        for (k, d) in dims.iter().enumerate() {
            let d = i16::try_from(*d).map_err(|_| {
                field(
                    "dim",
                    format!("dimension {k} ({d}) does not fit the header's int16"),
                )
            })?;
            put(&mut raw, off::DIM + 2 * k, &i16_bytes(d, e));
        }
    }
    let groups = [
        (
            &meta.point_data_names,
            &base.scalar_names,
            off::N_SCALARS,
            off::SCALAR_NAME,
            "per-point",
        ),
        (
            &meta.curve_data_names,
            &base.property_names,
            off::N_PROPERTIES,
            off::PROPERTY_NAME,
            "per-curve",
        ),
    ];
    for (names, kept, count_at, names_at, what) in groups {
        if names != kept {
            let n = i16::try_from(names.len()).map_err(|_| {
                IoError::new(
                    path,
                    format!("{} {what} values are too many for .trk", names.len()),
                )
            })?;
            put(&mut raw, count_at, &i16_bytes(n, e));
            put(&mut raw, names_at, &encode_names(names, what, path)?);
        }
    }
    put(&mut raw, off::N_COUNT, &i32_bytes(0, e));
    Ok(raw)
}

/// Create a `.trk` writer for curves in world space (RAS+ mm) described by
/// `meta` (see [Output](create#output) for the header it writes).
///
/// A 1000-byte header, then per streamline its point count and the points
/// (float32); the points read back within float32 rounding.
///
/// ```
/// use strandfit::io::{create_trk, open_trk, Curve, Format, Metadata};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-trk-create-{}.trk", std::process::id()));
/// let p = vec![DVec3::new(10.0, -4.0, 2.0), DVec3::new(11.0, -4.5, 2.25)];
/// let mut w = create_trk(&path, &Metadata::new(Format::Tck)).unwrap();
/// w.write_curve(&Curve::from_points(p.clone())).unwrap();
/// w.finish().unwrap();
/// assert_eq!(std::fs::metadata(&path).unwrap().len(), 1000 + 4 + 2 * 12);
/// let curves: Vec<Curve> = open_trk(&path).unwrap().collect::<Result<_, _>>().unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert!(curves[0].points.iter().zip(&p).all(|(a, b)| a.distance(*b) < 1e-5));
/// ```
///
/// # Output
///
/// The raw header is kept, hex-encoded, in [`Metadata::extra`] under
/// [`TRK_HEADER_KEY`](HEADER_KEY); the writer starts from it for a `.trk`
/// source, so `.trk` → `.trk` reproduces the header byte for byte (byte order
/// included) except `n_count`. Fields [`Metadata`] carries (affine, voxel
/// sizes, dimensions, data names) override it when they differ. A source that
/// is not `.trk` gets a little-endian version 2 header from the metadata: its
/// `vox_to_world` (identity for `.tck` and the other formats, so voxmm = RAS +
/// 0.5 mm), voxel sizes and dimensions where known (else 1 mm and 1), and the
/// `voxel_order` of the affine's axes.
pub fn create(path: &Path, meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    let raw = header_for(path, meta)?;
    // The transform the reader will apply, from the bytes it will read.
    let h = Header::parse(&raw, path)?;
    let from_world = h.voxmm_to_ras.inverse();
    if !(h.voxmm_to_ras.determinant().abs() > 0.0) || !from_world.is_finite() {
        return Err(IoError::new(
            path,
            "the voxmm → RAS transform of the header is not invertible",
        ));
    }
    let mut out = AtomicFile::create(path)?;
    out.write_all(&raw).map_err(|err| out.err(err))?;
    Ok(Box::new(TrkWriter {
        out,
        endian: h.endian,
        from_world,
        n_scalars: h.scalar_names.len(),
        n_properties: h.property_names.len(),
        count: 0,
        buf: Vec::new(),
    }))
}

struct TrkWriter {
    out: AtomicFile,
    endian: Endian,
    from_world: DMat4,
    n_scalars: usize,
    n_properties: usize,
    count: u64,
    buf: Vec<u8>,
}

impl CurveWriter for TrkWriter {
    fn write_curve(&mut self, curve: &Curve) -> Result<(), IoError> {
        let i = self.count;
        let e = self.endian;
        let err = |reason: String| IoError::new(self.out.target(), reason).curve(i);
        let n = curve.points.len();
        let n32 = i32::try_from(n)
            .map_err(|_| err(format!("{n} points do not fit a .trk point count")))?;
        if curve.point_data.len() != n * self.n_scalars {
            return Err(err(format!(
                "{} per-point values for {n} points × {} names",
                curve.point_data.len(),
                self.n_scalars
            )));
        }
        if curve.curve_data.len() != self.n_properties {
            return Err(err(format!(
                "{} per-curve values for {} names",
                curve.curve_data.len(),
                self.n_properties
            )));
        }
        self.buf.clear();
        self.buf.extend_from_slice(&i32_bytes(n32, e));
        for (j, p) in curve.points.iter().enumerate() {
            let v = self.from_world.transform_point3(*p).as_vec3();
            if !p.is_finite() || !v.is_finite() {
                return Err(err(format!(
                    "point {j} ({p}) is not finite, or not in float32 range as voxmm"
                )));
            }
            for x in v.to_array() {
                self.buf.extend_from_slice(&f32_bytes(x, e));
            }
            for s in &curve.point_data[j * self.n_scalars..(j + 1) * self.n_scalars] {
                self.buf.extend_from_slice(&f32_bytes(*s, e));
            }
        }
        for s in &curve.curve_data {
            self.buf.extend_from_slice(&f32_bytes(*s, e));
        }
        self.out
            .write_all(&self.buf)
            .map_err(|err| self.out.err(err).curve(i))?;
        self.count += 1;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), IoError> {
        let mut w = *self;
        let n = i32::try_from(w.count).map_err(|_| {
            IoError::new(
                w.out.target(),
                format!("{} streamlines do not fit n_count (int32)", w.count),
            )
        })?;
        w.out
            .seek(SeekFrom::Start(off::N_COUNT as u64))
            .and_then(|_| w.out.write_all(&i32_bytes(n, w.endian)))
            .map_err(|err| w.out.err(err))?;
        w.out.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("test.trk")
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn voxel_order_codes() {
        assert_eq!(
            order_orientation("RAS"),
            Some([(0, 1.0), (1, 1.0), (2, 1.0)])
        );
        assert_eq!(
            order_orientation("lps"),
            Some([(0, -1.0), (1, -1.0), (2, 1.0)])
        );
        assert_eq!(
            order_orientation("ASL"),
            Some([(1, 1.0), (2, 1.0), (0, -1.0)])
        );
        for bad in ["RRS", "RA", "RASL", "XYZ", ""] {
            assert_eq!(order_orientation(bad), None, "{bad}");
        }
        let o = order_orientation("PIR").unwrap();
        assert_eq!(orientation_code(&o), "PIR");
    }

    #[test]
    fn affine_axes_as_nibabel_finds_them() {
        let code = |m: DMat4| affine_orientation(&m).map(|o| orientation_code(&o));
        assert_eq!(code(DMat4::IDENTITY).as_deref(), Some("RAS"));
        assert_eq!(
            code(DMat4::from_scale(DVec3::new(-2.0, 1.0, 3.0))).as_deref(),
            Some("LAS")
        );
        // Voxel x runs along world −y, voxel y along world x.
        let swap = DMat4::from_cols_array_2d(&[
            [0.0, -1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [5.0, 6.0, 7.0, 1.0],
        ]);
        assert_eq!(code(swap).as_deref(), Some("PRS"));
        // An oblique scan 30° about z is still closest to RAS.
        assert_eq!(code(DMat4::from_rotation_z(0.5)).as_deref(), Some("RAS"));
        assert_eq!(code(DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0))), None);
    }

    #[test]
    fn lps_voxel_order_flips_about_the_image_centre() {
        let ras = order_orientation("RAS").unwrap();
        let lps = order_orientation("LPS").unwrap();
        let m = reorientation(&lps, &ras, [4, 5, 7]);
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(3.0, 4.0, 0.0));
        assert_eq!(
            m.transform_point3(DVec3::new(3.0, 4.0, 6.0)),
            DVec3::new(0.0, 0.0, 6.0)
        );
        assert_eq!(reorientation(&ras, &ras, [4, 5, 7]), DMat4::IDENTITY);
    }

    #[test]
    fn names_decode_nibabel_counts_and_unnamed_rest() {
        let mut raw = [0u8; HEADER_SIZE];
        put(&mut raw, off::SCALAR_NAME, b"colors\x003");
        put(&mut raw, off::SCALAR_NAME + 20, b"fa");
        let got = decode_names(
            &raw,
            off::SCALAR_NAME,
            6,
            "scalars",
            "scalar_name",
            "n_scalars",
            p(),
        )
        .unwrap();
        assert_eq!(
            got,
            names(&[
                "colors[0]",
                "colors[1]",
                "colors[2]",
                "fa",
                "scalars[0]",
                "scalars[1]"
            ])
        );
        let got = decode_names(
            &raw,
            off::SCALAR_NAME,
            5,
            "scalars",
            "scalar_name",
            "n_scalars",
            p(),
        )
        .unwrap();
        assert_eq!(got.last().map(String::as_str), Some("scalars"));
        let e = decode_names(
            &raw,
            off::SCALAR_NAME,
            3,
            "scalars",
            "scalar_name",
            "n_scalars",
            p(),
        )
        .unwrap_err();
        assert!(e.reason.contains("more than the 3 values"), "{e}");
        assert!(decode_names(&raw, off::SCALAR_NAME, 0, "s", "f", "n", p())
            .unwrap()
            .is_empty());
        put(&mut raw, off::SCALAR_NAME + 40, b"x\x00y\x00z");
        let e = decode_names(&raw, off::SCALAR_NAME, 9, "s", "scalar_name", "n", p()).unwrap_err();
        assert!(e.reason.contains("stray bytes"), "{e}");
    }

    #[test]
    fn names_encode_and_decode_back() {
        let cases = [
            names(&["fa"]),
            names(&["colors[0]", "colors[1]", "colors[2]", "fa", "md"]),
            names(&["x[0]", "y[0]", "y[1]"]),
            names(&["a", "a", "twenty_bytes_exactly"]),
            (0..10).map(|i| format!("s{i}")).collect(),
            (0..25).map(|i| format!("many[{i}]")).collect(),
        ];
        for want in cases {
            let enc = encode_names(&want, "per-point", p()).unwrap();
            let mut raw = [0u8; HEADER_SIZE];
            put(&mut raw, off::SCALAR_NAME, &enc);
            let got = decode_names(
                &raw,
                off::SCALAR_NAME,
                want.len(),
                "scalars",
                "scalar_name",
                "n",
                p(),
            )
            .unwrap();
            assert_eq!(got, want);
        }
        assert!(encode_names(&names(&[""]), "per-point", p()).is_err());
        assert!(encode_names(&names(&["a\0b"]), "per-point", p()).is_err());
        assert!(encode_names(&names(&["ω"]), "per-point", p()).is_err());
        assert!(encode_names(&names(&["twenty_one_bytes_long"]), "per-point", p()).is_err());
        let eleven: Vec<String> = (0..11).map(|i| format!("s{i}")).collect();
        assert!(encode_names(&eleven, "per-point", p()).is_err());
    }

    #[test]
    fn hex_round_trips() {
        let b: Vec<u8> = (0..=255).collect();
        assert_eq!(from_hex(&to_hex(&b)).unwrap(), b);
        assert!(from_hex("abc").is_none());
        assert!(from_hex("zz").is_none());
    }

    #[test]
    fn header_byte_order_and_affine_fallbacks() {
        let le = default_header();
        let h = Header::parse(&le, p()).unwrap();
        assert_eq!(h.endian, Endian::Little);
        assert_eq!(h.voxmm_to_ras, DMat4::from_translation(DVec3::splat(-0.5)));
        // The same header with every numeric field byte-swapped.
        let mut be = le;
        for (at, len) in [
            (6, 2),
            (8, 2),
            (10, 2),
            (12, 4),
            (16, 4),
            (20, 4),
            (992, 4),
            (996, 4),
        ] {
            be[at..at + len].reverse();
        }
        for k in 0..16 {
            be[440 + 4 * k..444 + 4 * k].reverse();
        }
        let h = Header::parse(&be, p()).unwrap();
        assert_eq!(h.endian, Endian::Big);
        assert_eq!(h.vox_to_ras, DMat4::IDENTITY);
        assert_eq!(h.dims, [1, 1, 1]);
        // vox_to_ras not recorded ([3][3] = 0): identity, as nibabel.
        let mut zero = le;
        put(&mut zero, off::VOX_TO_RAS, &[0u8; 64]);
        put(&mut zero, off::VOXEL_SIZE, &f32_bytes(2.0, Endian::Little));
        let h = Header::parse(&zero, p()).unwrap();
        assert_eq!(h.vox_to_ras, DMat4::IDENTITY);
        assert_eq!(
            h.voxmm_to_ras.transform_point3(DVec3::new(3.0, 0.5, 0.5)),
            DVec3::new(1.0, 0.0, 0.0)
        );
        // Version 1 has no matrix: whatever lies there is ignored.
        let mut v1 = le;
        put(&mut v1, off::VERSION, &i32_bytes(1, Endian::Little));
        put(&mut v1, off::VOX_TO_RAS, &f32_bytes(7.0, Endian::Little));
        assert_eq!(Header::parse(&v1, p()).unwrap().vox_to_ras, DMat4::IDENTITY);
        // An empty voxel_order means LPS: with a RAS affine, x and y flip.
        let mut blank = le;
        put(&mut blank, off::VOXEL_ORDER, &[0; 4]);
        let h = Header::parse(&blank, p()).unwrap();
        assert_eq!(
            h.voxmm_to_ras.transform_point3(DVec3::splat(0.5)),
            DVec3::new(0.0, 0.0, 0.0)
        );
        put(&mut blank, off::DIM, &i16_bytes(10, Endian::Little));
        let h = Header::parse(&blank, p()).unwrap();
        assert_eq!(
            h.voxmm_to_ras.transform_point3(DVec3::splat(0.5)),
            DVec3::new(9.0, 0.0, 0.0)
        );
    }
}
