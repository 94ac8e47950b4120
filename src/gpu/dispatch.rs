//! The one dispatcher: compiles a [`Kernel`] from its description (cached
//! per context, configuration and precision) and runs it over a sequence of
//! [`Batch`]es with two batches in flight — the upload and readback of one
//! overlap the dispatch of the other.
//!
//! Binding 0 is the parameter block, filled from the description
//! ([`Field`]: counts and 2D-dispatch rows of each pass, the batch's
//! scalars); bindings 1… are the description's buffers: inputs uploaded per
//! batch, resident buffers uploaded once ([`Gpu::resident`]), scratch
//! buffers, and the output, copied to a staging buffer and mapped.
//! Workgroups are [`WORKGROUP`] wide; past 65535 groups a dispatch is 2D and
//! the kernel's index is `gid.x + gid.y * row`.

use std::sync::{mpsc, Arc};
use std::time::Instant;

use super::{Gpu, GpuContext, GpuError};
use crate::kernels::{
    source, Access, Batch, Data, Elem, Exec, Field, Kernel, Limits, Precision, Timings, WORKGROUP,
};
use crate::twin::Real;

/// A compiled kernel: one pipeline per entry point, one bind group layout.
pub(crate) struct Compiled {
    name: &'static str,
    pipelines: Vec<wgpu::ComputePipeline>,
    layout: wgpu::BindGroupLayout,
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

/// Compile `K` in configuration `cfg` and precision `R`, turning
/// validation errors into [`GpuError::Shader`].
pub(crate) fn compile<K: Kernel, R: Real>(
    ctx: &GpuContext,
    cfg: K::Config,
) -> Result<Compiled, GpuError> {
    let d = &ctx.device;
    let mut entries = vec![layout_entry(0, wgpu::BufferBindingType::Uniform)];
    for (k, b) in K::BINDINGS.iter().enumerate() {
        let read_only = matches!(b.access, Access::Input | Access::Resident);
        entries.push(layout_entry(
            k as u32 + 1,
            wgpu::BufferBindingType::Storage { read_only },
        ));
    }
    let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(K::NAME),
        entries: &entries,
    });
    let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(K::NAME),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(K::NAME),
        source: wgpu::ShaderSource::Wgsl(source::<K, R>(cfg).into()),
    });
    let pipelines = K::ENTRIES
        .iter()
        .map(|entry| {
            d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        })
        .collect();
    if let Some(err) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Shader {
            name: K::NAME.to_string(),
            reason: err.to_string(),
        });
    }
    Ok(Compiled {
        name: K::NAME,
        pipelines,
        layout,
    })
}

/// `(x, y, row)` for `n` invocations of [`WORKGROUP`] width.
fn grid(ctx: &GpuContext, n: usize) -> (u32, u32, u32) {
    let groups = n.div_ceil(WORKGROUP as usize).max(1);
    let x = groups.min(ctx.max_groups_per_dim() as usize);
    let y = groups.div_ceil(x);
    (x as u32, y as u32, x as u32 * WORKGROUP)
}

/// The parameter block of `K` for passes of `counts` invocations.
fn params<K: Kernel>(grids: &[(u32, u32, u32)], counts: &[usize], scalars: &[f32]) -> Vec<u32> {
    let mut scalars = scalars.iter();
    K::PARAMS
        .iter()
        .map(|(_, f)| match *f {
            Field::Count(p) => counts[p] as u32,
            Field::Row(p) => grids[p].2,
            Field::Scalar => scalars.next().copied().unwrap_or(0.0).to_bits(),
            Field::Pad => 0,
        })
        .collect()
}

struct Pending {
    index: wgpu::SubmissionIndex,
    batch: usize,
    bytes: u64,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// The buffers of one batch in flight, grown to the largest batch seen.
struct Slot {
    uniform: wgpu::Buffer,
    /// One per non-resident binding (resident ones: `None`).
    buffers: Vec<Option<wgpu::Buffer>>,
    sizes: Vec<u64>,
    staging: Option<wgpu::Buffer>,
    bind: Option<wgpu::BindGroup>,
    pending: Option<Pending>,
}

fn buffer(ctx: &GpuContext, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage,
        mapped_at_creation: false,
    })
}

impl Slot {
    fn new<K: Kernel>(ctx: &GpuContext) -> Slot {
        let bytes = (K::PARAMS.len() * 4) as u64;
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        Slot {
            uniform: buffer(ctx, K::NAME, bytes, usage),
            buffers: K::BINDINGS.iter().map(|_| None).collect(),
            sizes: vec![0; K::BINDINGS.len()],
            staging: None,
            bind: None,
            pending: None,
        }
    }

    /// Makes room for `sizes` bytes per binding (re-creating the bind group
    /// when a buffer grew).
    fn fit<K: Kernel>(
        &mut self,
        ctx: &GpuContext,
        k: &Compiled,
        sizes: &[u64],
        resident: &[&wgpu::Buffer],
    ) {
        use wgpu::BufferUsages as U;
        let mut grew = self.bind.is_none();
        for (j, b) in K::BINDINGS.iter().enumerate() {
            if b.access == Access::Resident || sizes[j] <= self.sizes[j] {
                continue;
            }
            let usage = match b.access {
                Access::Input => U::STORAGE | U::COPY_DST,
                Access::Scratch => U::STORAGE,
                _ => U::STORAGE | U::COPY_SRC,
            };
            self.buffers[j] = Some(buffer(ctx, k.name, sizes[j], usage));
            if b.access == Access::Output {
                self.staging = Some(buffer(ctx, k.name, sizes[j], U::MAP_READ | U::COPY_DST));
            }
            self.sizes[j] = sizes[j];
            grew = true;
        }
        if !grew {
            return;
        }
        let mut resident = resident.iter();
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: self.uniform.as_entire_binding(),
        }];
        for (j, b) in self.buffers.iter().enumerate() {
            let buf = match b {
                Some(b) => b,
                None => resident
                    .next()
                    .expect("a resident buffer per resident binding"),
            };
            entries.push(wgpu::BindGroupEntry {
                binding: j as u32 + 1,
                resource: buf.as_entire_binding(),
            });
        }
        self.bind = Some(ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(k.name),
            layout: &k.layout,
            entries: &entries,
        }));
    }
}

fn bytes_of<R: Real>(elem: Elem, n: usize) -> u64 {
    (n * match elem {
        Elem::Real => std::mem::size_of::<R>(),
        Elem::U32 => 4,
    }) as u64
}

impl Exec for Gpu<'_> {
    type Resident<R: Real> = wgpu::Buffer;

    fn precision(&self) -> Precision {
        self.precision
    }

    fn limits(&self) -> Limits {
        Limits {
            max_binding_bytes: self.ctx.max_binding_bytes(),
            max_groups_per_dim: self.ctx.max_groups_per_dim(),
        }
    }

    fn resident<R: Real>(&self, data: Data<'_, R>) -> Result<wgpu::Buffer, GpuError> {
        let bytes = data.bytes();
        if bytes.len() as u64 > self.ctx.max_binding_bytes() {
            return Err(GpuError::Execution(format!(
                "{} bytes do not fit one binding",
                bytes.len()
            )));
        }
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let buffer = buffer(self.ctx, "resident", bytes.len() as u64, usage);
        if !bytes.is_empty() {
            self.ctx.queue.write_buffer(&buffer, 0, bytes);
        }
        Ok(buffer)
    }

    /// The compiled kernel (from the context's cache), two slots of
    /// buffers, each batch uploaded, dispatched pass after pass in one
    /// compute pass, read back in order.
    fn run<'a, K: Kernel, R: Real>(
        &self,
        cfg: K::Config,
        resident: &[&wgpu::Buffer],
        batches: &mut dyn Iterator<Item = Batch<'a, R>>,
        done: &mut dyn FnMut(usize, &Data<'_, R>),
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        assert_eq!(R::WGSL, self.precision.name(), "record precision");
        let ctx = self.ctx;
        let k: Arc<Compiled> = ctx.compiled::<K, R>(cfg)?;
        let out_elem = K::BINDINGS.last().expect("an output").elem;
        let mut slots = [Slot::new::<K>(ctx), Slot::new::<K>(ctx)];
        let mut n = 0;
        for batch in batches {
            let slot = &mut slots[n % 2];
            if let Some(p) = slot.pending.take() {
                finish::<R>(ctx, &k, slot, p, out_elem, done, timings)?;
            }
            let t = Instant::now();
            let sizes = self.sizes::<K, R>(&batch)?;
            slot.fit::<K>(ctx, &k, &sizes, resident);
            let grids: Vec<_> = batch.counts.iter().map(|&c| grid(ctx, c)).collect();
            let params = params::<K>(&grids, &batch.counts, &batch.scalars);
            ctx.queue
                .write_buffer(&slot.uniform, 0, bytemuck::cast_slice(&params));
            let inputs = K::BINDINGS
                .iter()
                .enumerate()
                .filter(|(_, b)| b.access == Access::Input);
            for ((j, _), data) in inputs.zip(&batch.inputs) {
                if !data.is_empty() {
                    let buf = slot.buffers[j].as_ref().expect("sized");
                    ctx.queue.write_buffer(buf, 0, data.bytes());
                }
            }
            let out_bytes = bytes_of::<R>(out_elem, batch.out_len);
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some(k.name),
                });
            {
                // One pass: wgpu orders the dispatches' storage accesses.
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(k.name),
                    timestamp_writes: None,
                });
                pass.set_bind_group(0, slot.bind.as_ref(), &[]);
                for (pipeline, g) in k.pipelines.iter().zip(&grids) {
                    pass.set_pipeline(pipeline);
                    pass.dispatch_workgroups(g.0, g.1, 1);
                }
            }
            let output = slot.buffers.last().and_then(|b| b.as_ref()).expect("sized");
            let staging = slot.staging.as_ref().expect("sized");
            if out_bytes > 0 {
                enc.copy_buffer_to_buffer(output, 0, staging, 0, out_bytes);
            }
            let index = ctx.queue.submit([enc.finish()]);
            let (tx, rx) = mpsc::channel();
            if out_bytes > 0 {
                staging
                    .slice(..out_bytes)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        let _ = tx.send(r);
                    });
            } else {
                let _ = tx.send(Ok(()));
            }
            slot.pending = Some(Pending {
                index,
                batch: n,
                bytes: out_bytes,
                mapped: rx,
            });
            timings.upload += t.elapsed();
            timings.chunks += 1;
            n += 1;
        }
        // Drain in submission order.
        for j in 0..2 {
            let slot = &mut slots[(n + j) % 2];
            if let Some(p) = slot.pending.take() {
                finish::<R>(ctx, &k, slot, p, out_elem, done, timings)?;
            }
        }
        Ok(())
    }
}

impl Gpu<'_> {
    /// Bytes of each binding of `batch` (resident: 0), refusing buffers
    /// larger than one binding may be.
    fn sizes<K: Kernel, R: Real>(&self, batch: &Batch<'_, R>) -> Result<Vec<u64>, GpuError> {
        let (mut inputs, mut scratch) = (batch.inputs.iter(), batch.scratch.iter());
        let sizes: Vec<u64> = K::BINDINGS
            .iter()
            .map(|b| match b.access {
                Access::Input => inputs
                    .next()
                    .expect("an input per input binding")
                    .bytes()
                    .len() as u64,
                Access::Resident => 0,
                Access::Scratch => bytes_of::<R>(b.elem, *scratch.next().expect("a scratch size")),
                Access::Output => bytes_of::<R>(b.elem, batch.out_len),
            })
            .collect();
        if let Some(j) = (0..sizes.len()).find(|&j| sizes[j] > self.ctx.max_binding_bytes()) {
            return Err(GpuError::Execution(format!(
                "{}: {} ({} bytes) does not fit one binding",
                K::NAME,
                K::BINDINGS[j].name,
                sizes[j]
            )));
        }
        Ok(sizes)
    }
}

/// Waits for a batch, hands its mapped output to `done`, unmaps.
fn finish<R: Real>(
    ctx: &GpuContext,
    k: &Compiled,
    slot: &mut Slot,
    p: Pending,
    elem: Elem,
    done: &mut dyn FnMut(usize, &Data<'_, R>),
    timings: &mut Timings,
) -> Result<(), GpuError> {
    let name = k.name;
    let t = Instant::now();
    ctx.device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(p.index),
            timeout: None,
        })
        .map_err(|e| GpuError::Execution(format!("{name}: {e}")))?;
    match p.mapped.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(GpuError::Execution(format!("{name}: map: {e}"))),
        Err(_) => return Err(GpuError::Execution(format!("{name}: map callback lost"))),
    }
    timings.wait += t.elapsed();
    let t = Instant::now();
    if p.bytes == 0 {
        let empty = match elem {
            Elem::Real => Data::Real(Vec::new().into()),
            Elem::U32 => Data::U32(Vec::new().into()),
        };
        done(p.batch, &empty);
    } else {
        let staging = slot.staging.as_ref().expect("sized");
        {
            let view = staging
                .slice(..p.bytes)
                .get_mapped_range()
                .map_err(|e| GpuError::Execution(format!("{name}: {e}")))?;
            let data = match elem {
                Elem::Real => Data::Real(bytemuck::cast_slice::<u8, R>(&view).into()),
                Elem::U32 => Data::U32(bytemuck::cast_slice::<u8, u32>(&view).into()),
            };
            done(p.batch, &data);
        }
        staging.unmap();
    }
    timings.readback += t.elapsed();
    Ok(())
}
