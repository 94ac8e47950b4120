//! Compile a kernel and run it over a flat batch of fixed-size records, in
//! chunks, with two chunks in flight (upload and readback of one overlap the
//! dispatch of the other).
//!
//! Every "map" kernel has the same bindings: 0 a uniform `Params { count,
//! row, param: f32, _pad }`, 1 the input records (`array<real>`, read), 2 the
//! output records (`array<real>`, read-write). Workgroups are 64 wide; past
//! 65535 groups the dispatch is 2D and the kernel's index is
//! `gid.x + gid.y * row`.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};

use super::{shader_source, GpuContext, GpuError};
use crate::twin::Real;

pub(crate) const WORKGROUP: u32 = 64;
/// Default records per chunk; the binding limits may lower it.
pub(crate) const CHUNK_RECORDS: usize = 1 << 18;

/// Where the time of a GPU batch went (summed over chunks). With two chunks
/// in flight, `wait` is the part of the device's work the host could not
/// hide behind upload and readback.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// Packing records into the kernel's precision.
    pub prepare: Duration,
    /// `write_buffer` + encode + submit.
    pub upload: Duration,
    /// Blocking until a chunk's results are mapped.
    pub wait: Duration,
    /// Copying mapped results out (and unpacking).
    pub readback: Duration,
    /// Number of chunks.
    pub chunks: usize,
}

impl Timings {
    pub fn total(&self) -> Duration {
        self.prepare + self.upload + self.wait + self.readback
    }
    pub fn add(&mut self, o: &Timings) {
        self.prepare += o.prepare;
        self.upload += o.upload;
        self.wait += o.wait;
        self.readback += o.readback;
        self.chunks += o.chunks;
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    count: u32,
    row: u32,
    param: f32,
    _pad: u32,
}

/// A compiled map kernel.
pub(crate) struct MapKernel {
    name: &'static str,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    in_stride: usize,
    out_stride: usize,
    real_size: usize,
}

/// Compile WGSL, turning validation errors into [`GpuError::Shader`].
pub(crate) fn compile(
    ctx: &GpuContext,
    name: &str,
    source: &str,
) -> Result<wgpu::ComputePipeline, GpuError> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    let pipeline = ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
    if let Some(err) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Shader {
            name: name.to_string(),
            reason: err.to_string(),
        });
    }
    Ok(pipeline)
}

/// `(x, y, row)` for `n` invocations of [`WORKGROUP`] width.
pub(crate) fn grid(ctx: &GpuContext, n: usize) -> (u32, u32, u32) {
    let groups = n.div_ceil(WORKGROUP as usize).max(1);
    let x = groups.min(ctx.max_groups_per_dim() as usize);
    let y = groups.div_ceil(x);
    (x as u32, y as u32, x as u32 * WORKGROUP)
}

struct Pending {
    index: wgpu::SubmissionIndex,
    first: usize,
    count: usize,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

struct Slot {
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    staging: wgpu::Buffer,
    uniform: wgpu::Buffer,
    bind: wgpu::BindGroup,
    pending: Option<Pending>,
}

impl MapKernel {
    pub(crate) fn new<R: Real>(
        ctx: &GpuContext,
        name: &'static str,
        body: &str,
        in_stride: usize,
        out_stride: usize,
    ) -> Result<Self, GpuError> {
        let pipeline = compile(ctx, name, &shader_source::<R>(body))?;
        let layout = pipeline.get_bind_group_layout(0);
        Ok(MapKernel {
            name,
            pipeline,
            layout,
            in_stride,
            out_stride,
            real_size: std::mem::size_of::<R>(),
        })
    }

    /// Compile in `precision`, refusing `f64` on adapters without
    /// `SHADER_F64`.
    pub(crate) fn for_precision(
        ctx: &GpuContext,
        precision: super::Precision,
        name: &'static str,
        body: &str,
        in_stride: usize,
        out_stride: usize,
    ) -> Result<Self, GpuError> {
        match precision {
            super::Precision::F32 => Self::new::<f32>(ctx, name, body, in_stride, out_stride),
            super::Precision::F64 if ctx.supports_f64() => {
                Self::new::<f64>(ctx, name, body, in_stride, out_stride)
            }
            super::Precision::F64 => Err(GpuError::NoF64 {
                adapter: ctx.adapter_info().name.clone(),
            }),
        }
    }

    /// Records per chunk: the default, lowered to fit the binding limits.
    pub(crate) fn chunk_records(&self, ctx: &GpuContext) -> usize {
        let per = (self.in_stride.max(self.out_stride) * self.real_size) as u64;
        let by_binding = (ctx.max_binding_bytes() / per) as usize;
        let by_groups = ctx.max_groups_per_dim() as usize
            * ctx.max_groups_per_dim() as usize
            * WORKGROUP as usize;
        CHUNK_RECORDS.min(by_binding).min(by_groups).max(1)
    }

    fn slot(&self, ctx: &GpuContext, records: usize) -> Slot {
        let d = &ctx.device;
        let in_bytes = (records * self.in_stride * self.real_size).max(4) as u64;
        let out_bytes = (records * self.out_stride * self.real_size).max(4) as u64;
        let input = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.name),
            size: in_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let output = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.name),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.name),
            size: out_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.name),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.name),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        Slot {
            input,
            output,
            staging,
            uniform,
            bind,
            pending: None,
        }
    }

    /// Run over `input` (`n·in_stride` reals) into `out` (`n·out_stride`).
    /// `param` is the kernel's scalar parameter (e.g. a tolerance).
    pub(crate) fn run<R: Real>(
        &self,
        ctx: &GpuContext,
        input: &[R],
        param: f32,
        out: &mut [R],
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        assert_eq!(std::mem::size_of::<R>(), self.real_size);
        let n = input.len() / self.in_stride;
        assert_eq!(input.len(), n * self.in_stride);
        assert_eq!(out.len(), n * self.out_stride);
        if n == 0 {
            return Ok(());
        }
        let chunk = self.chunk_records(ctx);
        let slot_records = chunk.min(n);
        let mut slots = [self.slot(ctx, slot_records), self.slot(ctx, slot_records)];
        let mut first = 0;
        let mut k = 0;
        while first < n {
            let count = chunk.min(n - first);
            let slot = &mut slots[k % 2];
            if let Some(p) = slot.pending.take() {
                self.finish(ctx, slot, p, out, timings)?;
            }
            let t = Instant::now();
            let (x, y, row) = grid(ctx, count);
            let params = Params {
                count: count as u32,
                row,
                param,
                _pad: 0,
            };
            ctx.queue
                .write_buffer(&slot.uniform, 0, bytemuck::bytes_of(&params));
            ctx.queue.write_buffer(
                &slot.input,
                0,
                bytemuck::cast_slice(
                    &input[first * self.in_stride..(first + count) * self.in_stride],
                ),
            );
            let out_bytes = (count * self.out_stride * self.real_size) as u64;
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some(self.name),
                });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(self.name),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &slot.bind, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            enc.copy_buffer_to_buffer(&slot.output, 0, &slot.staging, 0, out_bytes);
            let index = ctx.queue.submit([enc.finish()]);
            let (tx, rx) = mpsc::channel();
            slot.staging
                .slice(..out_bytes)
                .map_async(wgpu::MapMode::Read, move |r| {
                    let _ = tx.send(r);
                });
            slot.pending = Some(Pending {
                index,
                first,
                count,
                mapped: rx,
            });
            timings.upload += t.elapsed();
            timings.chunks += 1;
            first += count;
            k += 1;
        }
        // Drain in submission order.
        for j in 0..2 {
            let slot = &mut slots[(k + j) % 2];
            if let Some(p) = slot.pending.take() {
                self.finish(ctx, slot, p, out, timings)?;
            }
        }
        Ok(())
    }

    fn finish<R: Real>(
        &self,
        ctx: &GpuContext,
        slot: &mut Slot,
        p: Pending,
        out: &mut [R],
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        let t = Instant::now();
        ctx.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(p.index),
                timeout: None,
            })
            .map_err(|e| GpuError::Execution(format!("{}: {e}", self.name)))?;
        match p.mapped.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Execution(format!("{}: map: {e}", self.name))),
            Err(_) => {
                return Err(GpuError::Execution(format!(
                    "{}: map callback lost",
                    self.name
                )))
            }
        }
        timings.wait += t.elapsed();
        let t = Instant::now();
        let out_bytes = (p.count * self.out_stride * self.real_size) as u64;
        {
            let slice = slot.staging.slice(..out_bytes);
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Execution(format!("{}: {e}", self.name)))?;
            out[p.first * self.out_stride..(p.first + p.count) * self.out_stride]
                .copy_from_slice(bytemuck::cast_slice(&view));
        }
        slot.staging.unmap();
        timings.readback += t.elapsed();
        Ok(())
    }
}
