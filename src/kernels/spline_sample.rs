//! `shaders/spline_sample.wgsl` (twin: [`crate::twin::spline_sample`]):
//! equal-arc-length sampling of many [`BezierSpline`]s, with the contract of
//! [`BezierSpline::sample_equal_arclen`] — `N + 1` points with unit tangents
//! at `s_j = j·L/N`, the first and last point exactly the end control points.
//!
//! The GPU does the arc-length work from the control points (three passes,
//! see the twin's docs). The host, in `f64`, hands each segment over
//! relative to its start point and divided by a per-spline power of two,
//! fills chunks (bounded in samples and segments) with splines in order —
//! a spline whose samples overflow the chunk is split into pieces at the
//! boundary, each piece carrying all of the spline's segments, so results
//! do not depend on the chunking — keeps two chunks in flight (on the GPU), and turns
//! records back into points
//! (`P₀ + S·offset`). Splines the kernel cannot take at working precision
//! are sampled by the `f64` reference instead, flagged in
//! [`SplineSamples::fallback`]:
//! * flagged by the kernel: a segment whose fixed panel table misses the
//!   quadrature tolerance (a cusp or near-cusp, where `|B'|` has a kink), or
//!   a non-finite result;
//! * refused by the host: `N ≥ 2²⁴` (sample indices must be exact in `f32`),
//!   more segments than a chunk holds, or a non-point segment so small next
//!   to the spline's largest that its squares would underflow (legs below
//!   `ε²` of the largest in the kernel's precision).
//!
//! Buffers (see the twin's docs): `pieces`, per piece `seg_first,
//! seg_count, out_first, out_count, n, j_first`; `segs`, per segment `P1 −
//! P0, P2 − P0, P3 − P0` (scaled); `table` (scratch), per segment the FINE
//! cumulative panel lengths, flag, cumulative end; `spl` (scratch), per
//! piece length and flag; `rec_out`, per sample `flag, seg, t, point.xyz,
//! tangent.xyz`.
//!
//! [`Timings`]: `prepare` is the per-spline scaling and the packing of
//! records, `upload` the writes, encoding and submission of the three
//! dispatches, `wait` the blocking on a chunk, `readback` the copy out of
//! the mapped buffer, the unpacking, and the reference's sampling of the
//! splines that fell back.

use std::borrow::Cow;
use std::cell::Cell;
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use super::{
    binding, by_precision, Access, Batch, Binding, Data, Elem, Exec, Field, GpuError, Kernel,
    Limits, Rng, Timings, Twin,
};
use crate::spline::{BezierSpline, CubicBez};
use crate::twin::spline_sample::{
    self as twin, OUT_FLAG, OUT_POINT, OUT_STRIDE, OUT_TANGENT, PIECE_STRIDE, P_J_FIRST, P_N,
    P_OUT_COUNT, P_OUT_FIRST, P_SEG_COUNT, P_SEG_FIRST, SEG_STRIDE, SPL_STRIDE, TABLE_STRIDE,
};
use crate::twin::Real;

/// Default output records (samples) per chunk; binding limits may lower it.
pub const CHUNK_SAMPLES: usize = 1 << 18;
/// Default segments per chunk; binding limits may lower it. A spline with
/// more segments is sampled by the reference.
pub const CHUNK_SEGMENTS: usize = 1 << 16;
/// Largest `N` the kernel takes (`j ≤ N` exact in `f32`).
pub const MAX_ELEMENTS: usize = (1 << 24) - 1;

/// Points and unit tangents of one sampled spline.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplineSamples {
    pub points: Vec<DVec3>,
    pub tangents: Vec<DVec3>,
    /// `true` when this spline was sampled by the `f64` reference (see the
    /// module docs for when).
    pub fallback: bool,
}

/// The kernel: three passes over one chunk.
pub struct SplineSample;

impl Kernel for SplineSample {
    const NAME: &'static str = "spline_sample";
    const WGSL: &'static str = include_str!("../../shaders/spline_sample.wgsl");
    const PARAMS: &'static [(&'static str, Field)] = &[
        ("n_segs", Field::Count(0)),
        ("n_pieces", Field::Count(1)),
        ("n_samples", Field::Count(2)),
        ("row_seg", Field::Row(0)),
        ("row_piece", Field::Row(1)),
        ("row_sample", Field::Row(2)),
        ("_pad0", Field::Pad),
        ("_pad1", Field::Pad),
    ];
    const BINDINGS: &'static [Binding] = &[
        binding("pieces", Elem::U32, Access::Input),
        binding("segs", Elem::Real, Access::Input),
        binding("table", Elem::Real, Access::Scratch),
        binding("spl", Elem::Real, Access::Scratch),
        binding("rec_out", Elem::Real, Access::Output),
    ];
    const ENTRIES: &'static [&'static str] = &["seg_table_main", "prefix_main", "sample_main"];
    const PARITY_EPS: f64 = 1024.0;
    type Config = ();

    fn constants<R: Real>(_: ()) -> String {
        format!("const REAL_MAX: real = {:e};\n", real_max::<R>())
    }
    fn configs() -> Vec<()> {
        vec![()]
    }
    fn twin<R: Real>(_: (), batch: &Batch<'_, R>, _: &[&Data<'_, R>]) -> Data<'static, R> {
        let out = run_twin_chunk(
            batch.inputs[0].u32s(),
            batch.inputs[1].reals(),
            batch.counts[2],
        );
        Data::Real(Cow::Owned(out))
    }
    fn parity_batch<R: Real>(_: (), rng: &mut Rng) -> (Batch<'static, R>, Vec<Data<'static, R>>) {
        let mut splines = Vec::new();
        let mut counts = Vec::new();
        for k in 0..40 {
            let mut cps = vec![DVec3::ZERO];
            for _ in 0..3 * (1 + k % 4) {
                let last = *cps.last().expect("one");
                cps.push(last + rng.range(0.2, 1.0) * rng.unit_vector() + DVec3::X);
            }
            if let Ok(s) = BezierSpline::from_control_points(&cps) {
                splines.push(s);
                counts.push(1 + k % 17);
            }
        }
        let prep = Prep::<R>::new(&splines, &counts, CHUNK_SEGMENTS);
        let caps = ChunkLimits::default().caps::<R>(Limits::NONE);
        let chunks = plan_chunks(&splines, &counts, &prep.ok, caps);
        (prep.batch(&chunks[0]), Vec::new())
    }
}

/// The kernel's largest finite value, `REAL_MAX`.
fn real_max<R: Real>() -> f64 {
    if std::mem::size_of::<R>() == 4 {
        f32::MAX as f64
    } else {
        f64::MAX
    }
}

/// Per-chunk limits (samples, segments), lowered further to fit the
/// executor's limits. Splines with more segments than a chunk holds go to
/// the reference. Lower them to exercise chunking and splitting in tests,
/// or to bound memory further.
#[derive(Clone, Copy, Debug)]
pub struct ChunkLimits {
    pub samples: usize,
    pub segments: usize,
}

impl Default for ChunkLimits {
    fn default() -> Self {
        ChunkLimits {
            samples: CHUNK_SAMPLES,
            segments: CHUNK_SEGMENTS,
        }
    }
}

impl ChunkLimits {
    fn caps<R: Real>(self, limits: Limits) -> Caps {
        let rs = std::mem::size_of::<R>() as u64;
        let bind = limits.max_binding_bytes;
        let by_groups = limits.max_invocations();
        let fit = |want: usize, stride: usize| {
            want.max(1)
                .min((bind / (stride as u64 * rs)).min(usize::MAX as u64) as usize)
                .min(by_groups)
                .max(1)
        };
        let (samples, segments) = (
            fit(self.samples, OUT_STRIDE),
            fit(self.segments, TABLE_STRIDE),
        );
        Caps {
            samples,
            segments,
            // A piece has at least one sample and one segment.
            pieces: samples.min(segments),
        }
    }
}

/// For each spline the `N + 1 = n_elements + 1` samples of
/// [`BezierSpline::sample_equal_arclen`]`(n_elements)`.
/// `n_elements = 0` is [`GpuError::InvalidInput`].
pub fn sample<E: Exec>(
    exec: &E,
    splines: &[BezierSpline],
    n_elements: usize,
    timings: &mut Timings,
) -> Result<Vec<SplineSamples>, GpuError> {
    let counts = vec![n_elements; splines.len()];
    sample_counts(exec, splines, &counts, ChunkLimits::default(), timings)
}

/// Ragged variant: spline `i` gets `n_elements[i] + 1` samples; chunks of
/// at most `limits`.
pub fn sample_counts<E: Exec>(
    exec: &E,
    splines: &[BezierSpline],
    n_elements: &[usize],
    limits: ChunkLimits,
    timings: &mut Timings,
) -> Result<Vec<SplineSamples>, GpuError> {
    check_counts(splines, n_elements)?;
    by_precision!(exec, sample_in(exec, splines, n_elements, limits, timings))
}

fn sample_in<R: Real, E: Exec>(
    exec: &E,
    splines: &[BezierSpline],
    n_elements: &[usize],
    limits: ChunkLimits,
    timings: &mut Timings,
) -> Result<Vec<SplineSamples>, GpuError> {
    let t = Instant::now();
    let caps = limits.caps::<R>(exec.limits());
    let prep = Prep::<R>::new(splines, n_elements, caps.segments);
    let chunks = plan_chunks(splines, n_elements, &prep.ok, caps);
    let mut result = prep.empty_result();
    timings.prepare += t.elapsed();
    let packing = Cell::new(Duration::ZERO);
    let mut batches = chunks.iter().map(|c| {
        let t = Instant::now();
        let b = prep.batch(c);
        packing.set(packing.get() + t.elapsed());
        b
    });
    exec.run::<SplineSample, R>(
        (),
        &[],
        &mut batches,
        // Timed as readback by the executor.
        &mut |i, out| prep.unpack(&chunks[i], out.reals(), &mut result),
        timings,
    )?;
    timings.prepare += packing.get();
    let t = Instant::now();
    finish_result(splines, n_elements, &mut result);
    timings.readback += t.elapsed();
    Ok(result)
}

/// Per-chunk capacities.
#[derive(Clone, Copy, Debug)]
struct Caps {
    samples: usize,
    segments: usize,
    pieces: usize,
}

/// A run of consecutive samples `j_first..j_first + count` of one spline.
#[derive(Clone, Copy, Debug)]
struct Piece {
    spline: usize,
    j_first: usize,
    count: usize,
}

/// Whole splines (or pieces of one) that go to the GPU together.
#[derive(Clone, Debug, Default)]
struct Chunk {
    pieces: Vec<Piece>,
    segments: usize,
    samples: usize,
}

/// Same contract as [`BezierSpline::sample_equal_arclen`]: at least one
/// element per spline, one count per spline.
fn check_counts(splines: &[BezierSpline], n_elements: &[usize]) -> Result<(), GpuError> {
    if n_elements.len() != splines.len() {
        return Err(GpuError::InvalidInput(format!(
            "spline_sample: {} element counts for {} splines",
            n_elements.len(),
            splines.len()
        )));
    }
    if let Some(i) = n_elements.iter().position(|&n| n == 0) {
        return Err(GpuError::InvalidInput(format!(
            "spline_sample: spline {i}: need at least 1 element, got 0"
        )));
    }
    Ok(())
}

/// Fills chunks with the splines the kernel takes, in order; a spline whose
/// samples overflow a chunk continues as a new piece in the next one (its
/// segments are packed again there; a spline never overflows the segment
/// limit, the host refuses those).
fn plan_chunks(
    splines: &[BezierSpline],
    n_elements: &[usize],
    ok: &[bool],
    caps: Caps,
) -> Vec<Chunk> {
    let mut chunks = Vec::new();
    let mut cur = Chunk::default();
    for (i, s) in splines.iter().enumerate() {
        if !ok[i] {
            continue;
        }
        let k = s.num_segments();
        let total = n_elements[i] + 1;
        let mut j = 0;
        while j < total {
            if cur.segments + k > caps.segments
                || cur.samples == caps.samples
                || cur.pieces.len() == caps.pieces
            {
                chunks.push(std::mem::take(&mut cur));
            }
            let count = (total - j).min(caps.samples - cur.samples);
            cur.pieces.push(Piece {
                spline: i,
                j_first: j,
                count,
            });
            cur.segments += k;
            cur.samples += count;
            j += count;
        }
    }
    if !cur.pieces.is_empty() {
        chunks.push(cur);
    }
    chunks
}

/// Per-spline scale and acceptance, and the packing of segment records.
struct Prep<'a, R: Real> {
    splines: &'a [BezierSpline],
    n_elements: &'a [usize],
    /// Power of two the spline's segments are divided by.
    scale: Vec<f64>,
    /// Whether the kernel takes the spline.
    ok: Vec<bool>,
    _r: std::marker::PhantomData<R>,
}

/// The smallest power of two `≥ x` (for `x > 0` finite), capped at `2¹⁰²³`.
fn pow2_at_least(x: f64) -> f64 {
    let e = x.log2().ceil().clamp(-1022.0, 1023.0) as i32;
    let mut s = 2f64.powi(e);
    // log2 may round; make sure s ≥ x (or the cap).
    while s < x && e < 1023 {
        s *= 2.0;
    }
    s
}

/// The segment record in `f64`: `P₁ − P₀, P₂ − P₀, P₃ − P₀`, over `scale`.
fn seg_record(c: &CubicBez, scale: f64) -> [f64; SEG_STRIDE] {
    let a = (c.p1 - c.p0) / scale;
    let b = (c.p2 - c.p0) / scale;
    let d = (c.p3 - c.p0) / scale;
    [a.x, a.y, a.z, b.x, b.y, b.z, d.x, d.y, d.z]
}

impl<'a, R: Real> Prep<'a, R> {
    fn new(splines: &'a [BezierSpline], n_elements: &'a [usize], max_segments: usize) -> Self {
        let (scale, ok) = splines
            .par_iter()
            .zip(n_elements.par_iter())
            .map(|(s, &n)| {
                let segs = s.segments();
                let big = segs.iter().map(|c| c.leg_scale()).fold(0.0, f64::max);
                let scale = pow2_at_least(big);
                // Legs below ε² of the largest: squares would underflow in
                // f32 (relative 1e-28 of normal scale) — reference instead.
                let eps = R::EPSILON.to_f64();
                let tiny = eps * eps;
                let max = real_max::<R>();
                let fits = segs.iter().all(|c| {
                    c.is_point()
                        || (c.leg_scale() / scale >= tiny
                            && seg_record(c, scale).iter().all(|x| x.abs() <= max))
                });
                let ok = fits
                    && n <= MAX_ELEMENTS
                    && segs.len() <= max_segments
                    && scale.is_finite()
                    && scale > 0.0;
                (scale, ok)
            })
            .unzip();
        Prep {
            splines,
            n_elements,
            scale,
            ok,
            _r: std::marker::PhantomData,
        }
    }

    fn empty_result(&self) -> Vec<SplineSamples> {
        self.n_elements
            .iter()
            .zip(&self.ok)
            .map(|(&n, &ok)| {
                if ok {
                    SplineSamples {
                        points: vec![DVec3::ZERO; n + 1],
                        tangents: vec![DVec3::ZERO; n + 1],
                        fallback: false,
                    }
                } else {
                    SplineSamples {
                        fallback: true,
                        ..Default::default()
                    }
                }
            })
            .collect()
    }

    /// The chunk's piece and segment records.
    fn pack(&self, chunk: &Chunk) -> (Vec<u32>, Vec<R>) {
        let (splines, n_elements) = (self.splines, self.n_elements);
        let mut pieces = Vec::with_capacity(chunk.pieces.len() * PIECE_STRIDE);
        let mut segs = Vec::with_capacity(chunk.segments * SEG_STRIDE);
        let (mut seg_first, mut out_first) = (0usize, 0usize);
        for p in &chunk.pieces {
            let s = &splines[p.spline];
            let k = s.num_segments();
            let mut rec = [0u32; PIECE_STRIDE];
            rec[P_SEG_FIRST] = seg_first as u32;
            rec[P_SEG_COUNT] = k as u32;
            rec[P_OUT_FIRST] = out_first as u32;
            rec[P_OUT_COUNT] = p.count as u32;
            rec[P_N] = n_elements[p.spline] as u32;
            rec[P_J_FIRST] = p.j_first as u32;
            pieces.extend_from_slice(&rec);
            for c in s.segments() {
                segs.extend(
                    seg_record(c, self.scale[p.spline])
                        .iter()
                        .map(|&x| R::from_f64(x)),
                );
            }
            seg_first += k;
            out_first += p.count;
        }
        (pieces, segs)
    }

    /// The chunk's batch: records, scratch sizes and passes.
    fn batch(&self, chunk: &Chunk) -> Batch<'static, R> {
        let (pieces, segs) = self.pack(chunk);
        Batch {
            counts: vec![chunk.segments, chunk.pieces.len(), chunk.samples],
            scalars: Vec::new(),
            inputs: vec![Data::U32(Cow::Owned(pieces)), Data::Real(Cow::Owned(segs))],
            scratch: vec![
                chunk.segments * TABLE_STRIDE,
                chunk.pieces.len() * SPL_STRIDE,
            ],
            out_len: chunk.samples * OUT_STRIDE,
        }
    }

    /// Output records of a chunk into the result; a flagged record marks
    /// its spline for the reference.
    fn unpack(&self, chunk: &Chunk, out: &[R], result: &mut [SplineSamples]) {
        let splines = self.splines;
        let mut rec = 0usize;
        for p in &chunk.pieces {
            let s = &splines[p.spline];
            let scale = self.scale[p.spline];
            let res = &mut result[p.spline];
            for j in p.j_first..p.j_first + p.count {
                let o = &out[rec * OUT_STRIDE..(rec + 1) * OUT_STRIDE];
                rec += 1;
                if o[OUT_FLAG] != R::zero() {
                    res.fallback = true;
                    continue;
                }
                let seg = o[twin::OUT_SEG].to_f64() as usize;
                let get =
                    |i: usize| DVec3::new(o[i].to_f64(), o[i + 1].to_f64(), o[i + 2].to_f64());
                let p0 = s.segments()[seg.min(s.num_segments() - 1)].p0;
                res.points[j] = p0 + scale * get(OUT_POINT);
                res.tangents[j] = get(OUT_TANGENT);
            }
        }
    }
}

/// Ends exact, fallback splines by the reference.
fn finish_result(splines: &[BezierSpline], n_elements: &[usize], result: &mut [SplineSamples]) {
    result
        .par_iter_mut()
        .zip(splines.par_iter().zip(n_elements.par_iter()))
        .for_each(|(res, (s, &n))| {
            if res.fallback {
                // n ≥ 1 was checked, so the reference cannot fail.
                let (points, tangents) = s
                    .sample_equal_arclen(n)
                    .map(|v| v.into_iter().unzip())
                    .unwrap_or_default();
                *res = SplineSamples {
                    points,
                    tangents,
                    fallback: true,
                };
            } else {
                let cps = s.control_points();
                res.points[0] = cps[0];
                res.points[n] = cps[cps.len() - 1];
            }
        });
}

/// [`sample`] with the kernel replaced by its CPU twin in precision `R` —
/// what the GPU path should return, for parity tests, and an emulation of
/// it without a GPU.
pub fn sample_twin<R: Real>(
    splines: &[BezierSpline],
    n_elements: usize,
) -> Result<Vec<SplineSamples>, GpuError> {
    sample(
        &Twin::<R>::new(),
        splines,
        n_elements,
        &mut Timings::default(),
    )
}

/// [`sample_twin`] with one element count per spline.
pub fn sample_counts_twin<R: Real>(
    splines: &[BezierSpline],
    n_elements: &[usize],
) -> Result<Vec<SplineSamples>, GpuError> {
    let limits = ChunkLimits::default();
    sample_counts(
        &Twin::<R>::new(),
        splines,
        n_elements,
        limits,
        &mut Timings::default(),
    )
}

/// The three passes of the kernel on one chunk's records, by the twin.
pub fn run_twin_chunk<R: Real>(pieces: &[u32], segs: &[R], n_samples: usize) -> Vec<R> {
    let n_segs = segs.len() / SEG_STRIDE;
    let mut table = vec![R::zero(); n_segs * TABLE_STRIDE];
    table
        .par_chunks_mut(TABLE_STRIDE)
        .zip(segs.par_chunks(SEG_STRIDE))
        .for_each(|(row, rec)| {
            let t = twin::seg_table(rec);
            row[..t.len()].copy_from_slice(&t);
        });
    let spl: Vec<R> = pieces
        .chunks(PIECE_STRIDE)
        .flat_map(|p| twin::prefix(p, &mut table))
        .collect();
    let mut out = vec![R::zero(); n_samples * OUT_STRIDE];
    out.par_chunks_mut(OUT_STRIDE)
        .enumerate()
        .for_each(|(i, o)| o.copy_from_slice(&twin::sample(i as u32, pieces, segs, &table, &spl)));
    out
}
