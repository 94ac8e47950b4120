//! Driver of `shaders/spline_sample.wgsl` (twin:
//! [`crate::twin::spline_sample`]): equal-arc-length sampling of many
//! [`BezierSpline`]s on the GPU, with the contract of
//! [`BezierSpline::sample_equal_arclen`] — `N + 1` points with unit tangents
//! at `s_j = j·L/N`, the first and last point exactly the end control points.
//!
//! The GPU does the arc-length work from the control points (three passes,
//! see the twin's docs). The host, in `f64`, hands each segment over
//! relative to its start point and divided by a per-spline power of two,
//! fills chunks (bounded in samples and segments) with splines in order —
//! a spline whose samples overflow the chunk is split into pieces at the
//! boundary, each piece carrying all of the spline's segments, so results
//! do not depend on the chunking — keeps two chunks in flight, and turns
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
//! [`Timings`]: `prepare` is the per-spline scaling and the packing of
//! records, `upload` the writes, encoding and submission of the three
//! dispatches, `wait` the blocking on a chunk, `readback` the copy out of
//! the mapped buffer, the unpacking, and the reference's sampling of the
//! splines that fell back.

use std::sync::mpsc;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use rayon::prelude::*;

use super::dispatch::{grid, Timings};
use super::{shader_source, GpuContext, GpuError, Precision};
use crate::spline::{BezierSpline, CubicBez};
use crate::twin::spline_sample::{
    self as twin, OUT_FLAG, OUT_POINT, OUT_STRIDE, OUT_TANGENT, PIECE_STRIDE, P_J_FIRST, P_N,
    P_OUT_COUNT, P_OUT_FIRST, P_SEG_COUNT, P_SEG_FIRST, SEG_STRIDE, SPL_STRIDE, TABLE_STRIDE,
};
use crate::twin::Real;

/// `shaders/spline_sample.wgsl`.
pub const SPLINE_SAMPLE_WGSL: &str = include_str!("../../shaders/spline_sample.wgsl");

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

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    n_segs: u32,
    n_pieces: u32,
    n_samples: u32,
    row_seg: u32,
    row_piece: u32,
    row_sample: u32,
    _pad: [u32; 2],
}

/// The compiled kernel (three entry points) in one precision.
pub struct SplineSampleGpu {
    seg_table: wgpu::ComputePipeline,
    prefix: wgpu::ComputePipeline,
    sample: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    precision: Precision,
    chunk_samples: usize,
    chunk_segments: usize,
}

/// The kernel's source in precision `R`: prelude, math, `REAL_MAX`, body.
pub fn source<R: Real>() -> String {
    let max = real_max::<R>();
    shader_source::<R>(&format!(
        "const REAL_MAX: real = {max:e};\n{SPLINE_SAMPLE_WGSL}"
    ))
}

/// The largest finite value of `R`.
fn real_max<R: Real>() -> f64 {
    if std::mem::size_of::<R>() == 4 {
        f32::MAX as f64
    } else {
        f64::MAX
    }
}

fn layout_entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl SplineSampleGpu {
    pub fn new(ctx: &GpuContext, precision: Precision) -> Result<Self, GpuError> {
        let src = match precision {
            Precision::F32 => source::<f32>(),
            Precision::F64 if ctx.supports_f64() => source::<f64>(),
            Precision::F64 => {
                return Err(GpuError::NoF64 {
                    adapter: ctx.adapter_info().name.clone(),
                })
            }
        };
        let d = &ctx.device;
        let storage = |read_only| wgpu::BufferBindingType::Storage { read_only };
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("spline_sample"),
            entries: &[
                layout_entry(0, wgpu::BufferBindingType::Uniform),
                layout_entry(1, storage(true)),
                layout_entry(2, storage(true)),
                layout_entry(3, storage(false)),
                layout_entry(4, storage(false)),
                layout_entry(5, storage(false)),
            ],
        });
        let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("spline_sample"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("spline_sample"),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        let pipeline = |entry: &str| {
            d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let seg_table = pipeline("seg_table_main");
        let prefix = pipeline("prefix_main");
        let sample = pipeline("sample_main");
        if let Some(err) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader {
                name: "spline_sample".to_string(),
                reason: err.to_string(),
            });
        }
        Ok(SplineSampleGpu {
            seg_table,
            prefix,
            sample,
            layout,
            precision,
            chunk_samples: CHUNK_SAMPLES,
            chunk_segments: CHUNK_SEGMENTS,
        })
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// Lower the per-chunk limits (samples, segments; at least 1 each) from
    /// [`CHUNK_SAMPLES`], [`CHUNK_SEGMENTS`] — to exercise chunking and
    /// splitting in tests, or to bound memory further. Splines with more
    /// segments than a chunk holds go to the reference.
    pub fn with_chunk_limits(mut self, samples: usize, segments: usize) -> Self {
        self.chunk_samples = samples.max(1);
        self.chunk_segments = segments.max(1);
        self
    }

    /// For each spline the `N + 1 = n_elements + 1` samples of
    /// [`BezierSpline::sample_equal_arclen`]`(n_elements)`.
    /// `n_elements = 0` is [`GpuError::InvalidInput`].
    pub fn sample(
        &self,
        ctx: &GpuContext,
        splines: &[BezierSpline],
        n_elements: usize,
        timings: &mut Timings,
    ) -> Result<Vec<SplineSamples>, GpuError> {
        let counts = vec![n_elements; splines.len()];
        self.sample_counts(ctx, splines, &counts, timings)
    }

    /// Ragged variant: spline `i` gets `n_elements[i] + 1` samples.
    pub fn sample_counts(
        &self,
        ctx: &GpuContext,
        splines: &[BezierSpline],
        n_elements: &[usize],
        timings: &mut Timings,
    ) -> Result<Vec<SplineSamples>, GpuError> {
        check_counts(splines, n_elements)?;
        match self.precision {
            Precision::F32 => self.sample_in::<f32>(ctx, splines, n_elements, timings),
            Precision::F64 => self.sample_in::<f64>(ctx, splines, n_elements, timings),
        }
    }

    fn caps<R: Real>(&self, ctx: &GpuContext) -> Caps {
        let rs = std::mem::size_of::<R>() as u64;
        let bind = ctx.max_binding_bytes();
        let by_groups = ctx.max_groups_per_dim() as usize * ctx.max_groups_per_dim() as usize * 64;
        let samples = self
            .chunk_samples
            .min((bind / (OUT_STRIDE as u64 * rs)) as usize)
            .min(by_groups)
            .max(1);
        let segments = self
            .chunk_segments
            .min((bind / (TABLE_STRIDE as u64 * rs)) as usize)
            .min(by_groups)
            .max(1);
        Caps {
            samples,
            segments,
            // A piece has at least one sample and one segment.
            pieces: samples.min(segments),
        }
    }

    fn sample_in<R: Real>(
        &self,
        ctx: &GpuContext,
        splines: &[BezierSpline],
        n_elements: &[usize],
        timings: &mut Timings,
    ) -> Result<Vec<SplineSamples>, GpuError> {
        let t = Instant::now();
        let caps = self.caps::<R>(ctx);
        let prep = Prep::<R>::new(splines, n_elements, caps.segments);
        let chunks = plan_chunks(splines, n_elements, &prep.ok, caps);
        let mut result = prep.empty_result();
        timings.prepare += t.elapsed();
        if !chunks.is_empty() {
            let slot_caps = Caps {
                samples: chunks.iter().map(|c| c.samples).max().unwrap_or(1),
                segments: chunks.iter().map(|c| c.segments).max().unwrap_or(1),
                pieces: chunks.iter().map(|c| c.pieces.len()).max().unwrap_or(1),
            };
            let mut slots = [
                self.slot::<R>(ctx, slot_caps),
                self.slot::<R>(ctx, slot_caps),
            ];
            let mut k = 0;
            for chunk in &chunks {
                let slot = &mut slots[k % 2];
                if let Some(p) = slot.pending.take() {
                    let (c, out) = self.finish::<R>(ctx, slot, p, timings)?;
                    let t = Instant::now();
                    prep.unpack(&chunks[c], &out, &mut result);
                    timings.readback += t.elapsed();
                }
                let t = Instant::now();
                let (pieces, segs) = prep.pack(chunk);
                timings.prepare += t.elapsed();
                let t = Instant::now();
                self.submit::<R>(ctx, slot, chunk, k, &pieces, &segs);
                timings.upload += t.elapsed();
                timings.chunks += 1;
                k += 1;
            }
            for j in 0..2 {
                let slot = &mut slots[(k + j) % 2];
                if let Some(p) = slot.pending.take() {
                    let (c, out) = self.finish::<R>(ctx, slot, p, timings)?;
                    let t = Instant::now();
                    prep.unpack(&chunks[c], &out, &mut result);
                    timings.readback += t.elapsed();
                }
            }
        }
        let t = Instant::now();
        finish_result(splines, n_elements, &mut result);
        timings.readback += t.elapsed();
        Ok(result)
    }

    fn slot<R: Real>(&self, ctx: &GpuContext, caps: Caps) -> Slot {
        let d = &ctx.device;
        let rs = std::mem::size_of::<R>();
        let buf = |bytes: usize, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("spline_sample"),
                size: bytes.max(16) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let uniform = buf(std::mem::size_of::<Params>(), U::UNIFORM | U::COPY_DST);
        let pieces = buf(caps.pieces * PIECE_STRIDE * 4, U::STORAGE | U::COPY_DST);
        let segs = buf(caps.segments * SEG_STRIDE * rs, U::STORAGE | U::COPY_DST);
        let table = buf(caps.segments * TABLE_STRIDE * rs, U::STORAGE);
        let spl = buf(caps.pieces * SPL_STRIDE * rs, U::STORAGE);
        let out_bytes = caps.samples * OUT_STRIDE * rs;
        let output = buf(out_bytes, U::STORAGE | U::COPY_SRC);
        let staging = buf(out_bytes, U::MAP_READ | U::COPY_DST);
        let entries: Vec<wgpu::BindGroupEntry> = [&uniform, &pieces, &segs, &table, &spl, &output]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("spline_sample"),
            layout: &self.layout,
            entries: &entries,
        });
        Slot {
            uniform,
            pieces,
            segs,
            output,
            staging,
            bind,
            pending: None,
            _keep: [table, spl],
        }
    }

    fn submit<R: Real>(
        &self,
        ctx: &GpuContext,
        slot: &mut Slot,
        chunk: &Chunk,
        index: usize,
        pieces: &[u32],
        segs: &[R],
    ) {
        let (gs, gp, gx) = (
            grid(ctx, chunk.segments),
            grid(ctx, chunk.pieces.len()),
            grid(ctx, chunk.samples),
        );
        let params = Params {
            n_segs: chunk.segments as u32,
            n_pieces: chunk.pieces.len() as u32,
            n_samples: chunk.samples as u32,
            row_seg: gs.2,
            row_piece: gp.2,
            row_sample: gx.2,
            _pad: [0; 2],
        };
        let q = &ctx.queue;
        q.write_buffer(&slot.uniform, 0, bytemuck::bytes_of(&params));
        q.write_buffer(&slot.pieces, 0, bytemuck::cast_slice(pieces));
        q.write_buffer(&slot.segs, 0, bytemuck::cast_slice(segs));
        let out_bytes = (chunk.samples * OUT_STRIDE * std::mem::size_of::<R>()) as u64;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("spline_sample"),
            });
        {
            // One pass: wgpu orders the dispatches' storage accesses.
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("spline_sample"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &slot.bind, &[]);
            pass.set_pipeline(&self.seg_table);
            pass.dispatch_workgroups(gs.0, gs.1, 1);
            pass.set_pipeline(&self.prefix);
            pass.dispatch_workgroups(gp.0, gp.1, 1);
            pass.set_pipeline(&self.sample);
            pass.dispatch_workgroups(gx.0, gx.1, 1);
        }
        enc.copy_buffer_to_buffer(&slot.output, 0, &slot.staging, 0, out_bytes);
        let submission = q.submit([enc.finish()]);
        let (tx, rx) = mpsc::channel();
        slot.staging
            .slice(..out_bytes)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        slot.pending = Some(Pending {
            submission,
            chunk: index,
            bytes: out_bytes,
            mapped: rx,
        });
    }

    fn finish<R: Real>(
        &self,
        ctx: &GpuContext,
        slot: &mut Slot,
        p: Pending,
        timings: &mut Timings,
    ) -> Result<(usize, Vec<R>), GpuError> {
        let t = Instant::now();
        ctx.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(p.submission),
                timeout: None,
            })
            .map_err(|e| GpuError::Execution(format!("spline_sample: {e}")))?;
        match p.mapped.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Execution(format!("spline_sample: map: {e}"))),
            Err(_) => {
                return Err(GpuError::Execution(
                    "spline_sample: map callback lost".to_string(),
                ))
            }
        }
        timings.wait += t.elapsed();
        let t = Instant::now();
        let out = {
            let view = slot
                .staging
                .slice(..p.bytes)
                .get_mapped_range()
                .map_err(|e| GpuError::Execution(format!("spline_sample: {e}")))?;
            bytemuck::cast_slice::<u8, R>(&view).to_vec()
        };
        slot.staging.unmap();
        timings.readback += t.elapsed();
        Ok((p.chunk, out))
    }
}

/// Per-chunk capacities.
#[derive(Clone, Copy, Debug)]
struct Caps {
    samples: usize,
    segments: usize,
    pieces: usize,
}

struct Pending {
    submission: wgpu::SubmissionIndex,
    chunk: usize,
    bytes: u64,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

struct Slot {
    uniform: wgpu::Buffer,
    pieces: wgpu::Buffer,
    segs: wgpu::Buffer,
    output: wgpu::Buffer,
    staging: wgpu::Buffer,
    bind: wgpu::BindGroup,
    pending: Option<Pending>,
    /// Scratch buffers only the kernel touches (table, spline sums).
    _keep: [wgpu::Buffer; 2],
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

/// The same computation as [`SplineSampleGpu::sample`] with the kernel
/// replaced by its CPU twin in precision `R` — what the GPU path should
/// return, for parity tests, and an emulation of it without a GPU.
pub fn sample_twin<R: Real>(
    splines: &[BezierSpline],
    n_elements: usize,
) -> Result<Vec<SplineSamples>, GpuError> {
    sample_counts_twin::<R>(splines, &vec![n_elements; splines.len()])
}

/// [`sample_twin`] with one element count per spline.
pub fn sample_counts_twin<R: Real>(
    splines: &[BezierSpline],
    n_elements: &[usize],
) -> Result<Vec<SplineSamples>, GpuError> {
    check_counts(splines, n_elements)?;
    let caps = Caps {
        samples: CHUNK_SAMPLES,
        segments: CHUNK_SEGMENTS,
        pieces: CHUNK_SEGMENTS,
    };
    let prep = Prep::<R>::new(splines, n_elements, caps.segments);
    let chunks = plan_chunks(splines, n_elements, &prep.ok, caps);
    let mut result = prep.empty_result();
    for chunk in &chunks {
        let (pieces, segs) = prep.pack(chunk);
        let out = run_twin_chunk(&pieces, &segs, chunk.samples);
        prep.unpack(chunk, &out, &mut result);
    }
    finish_result(splines, n_elements, &mut result);
    Ok(result)
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
