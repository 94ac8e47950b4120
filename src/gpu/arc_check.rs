//! Driver of `shaders/arc_check.wgsl` (twin: [`crate::twin::arc_check`]):
//! the codec's acceptance test for many candidate arcs at once.
//!
//! A block's input points are uploaded once ([`ArcCheckGpu::open`]); each
//! round of the block's search then uploads only its candidates (16 reals
//! and 8 indices each) and reads back one verdict per candidate. The band
//! around the tolerance is computed here, on the host, in `f64`
//! ([`crate::twin::arc_check::band`]) for the kernel's precision, so that
//! `f32` kernels give sure verdicts as often as their precision allows and
//! never a wrong one.

use std::marker::PhantomData;
use std::sync::mpsc;

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use super::dispatch::{compile, grid};
use super::{shader_source, GpuContext, GpuError, Precision};
use crate::codec::batch::{ArcCandidate, ArcCheckBlock, ArcChecker, Verdict};
use crate::twin::arc_check::{self as twin, IDX_STRIDE, IN_STRIDE};
use crate::twin::Real;

/// `shaders/arc_check.wgsl`.
pub const ARC_CHECK_WGSL: &str = include_str!("../../shaders/arc_check.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    count: u32,
    row: u32,
    unused: f32,
    _pad: u32,
}

/// The kernel's records of one candidate in precision `R`.
pub fn pack<R: Real>(c: &ArcCandidate) -> ([R; IN_STRIDE], [u32; IDX_STRIDE]) {
    let tol = c.tol2.sqrt();
    let eta = twin::band::<R>(tol, c.radius, c.length, c.pieces as usize)
        + 64.0 * f64::EPSILON * c.origin_scale * (tol + c.origin_scale * f64::EPSILON);
    let v = |x: DVec3| [x.x, x.y, x.z];
    let mut rec = [R::zero(); IN_STRIDE];
    let reals = [
        v(c.start),
        v(c.tangent),
        v(c.normal),
        v(c.end),
        [c.curvature, c.step, c.tol2 - eta],
    ];
    for (o, x) in rec.iter_mut().zip(reals.iter().flatten()) {
        *o = R::from_f64(*x);
    }
    // Rounding `tol² ± η` into R must not narrow the band.
    rec[twin::IN_TOL_LO] = R::from_f64((c.tol2 - eta) * (1.0 - 2.0 * R::EPSILON.to_f64()));
    rec[twin::IN_TOL_HI] = R::from_f64((c.tol2 + eta) * (1.0 + 2.0 * R::EPSILON.to_f64()));
    let mut idx = [0u32; IDX_STRIDE];
    idx[twin::IDX_PIECES] = c.pieces;
    idx[twin::IDX_COVER_FIRST] = c.cover.0;
    idx[twin::IDX_COVER_LAST] = c.cover.1;
    idx[twin::IDX_WINDOW_FIRST] = c.window.0;
    idx[twin::IDX_WINDOW_LAST] = c.window.1;
    (rec, idx)
}

/// Whether a candidate can be checked in `R` (others are answered
/// unsure): its records finite after the conversion; no squared length the
/// kernel forms (at most `(2(radius + length))²`) overflowing; `tol²`
/// comfortably in `R`'s normal range, so that no squared distance near it
/// is flushed to zero.
fn fits<R: Real>(rec: &[R], c: &ArcCandidate) -> bool {
    let max = R::from_f64(f64::MAX).to_f64();
    let min_normal = if std::mem::size_of::<R>() == 4 {
        f32::MIN_POSITIVE as f64
    } else {
        f64::MIN_POSITIVE
    };
    let span = c.radius + c.length;
    rec.iter().all(|x| x.is_finite()) && 16.0 * span * span < max && c.tol2 > 1e6 * min_normal
}

fn verdict(v: u32) -> Verdict {
    match v {
        twin::PASS => Verdict::Pass,
        twin::FAIL => Verdict::Fail,
        _ => Verdict::Unsure,
    }
}

/// Points in the kernel's precision, `xyz` flat.
fn flat<R: Real>(points: &[DVec3]) -> Vec<R> {
    points
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .map(R::from_f64)
        .collect()
}

/// The compiled kernel in one precision.
pub struct ArcCheckGpu {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    precision: Precision,
}

impl ArcCheckGpu {
    pub fn new(ctx: &GpuContext, precision: Precision) -> Result<Self, GpuError> {
        let source = match precision {
            Precision::F32 => shader_source::<f32>(ARC_CHECK_WGSL),
            Precision::F64 if ctx.supports_f64() => shader_source::<f64>(ARC_CHECK_WGSL),
            Precision::F64 => {
                return Err(GpuError::NoF64 {
                    adapter: ctx.adapter_info().name.clone(),
                })
            }
        };
        let pipeline = compile(ctx, "arc_check", &source)?;
        let layout = pipeline.get_bind_group_layout(0);
        Ok(ArcCheckGpu {
            pipeline,
            layout,
            precision,
        })
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// Uploads a block's points (relative to their curves' origins) for
    /// the rounds of checks that follow.
    pub fn open<'a>(
        &'a self,
        ctx: &'a GpuContext,
        points: &[DVec3],
    ) -> Result<ArcCheckSession<'a>, GpuError> {
        let real = match self.precision {
            Precision::F32 => 4,
            Precision::F64 => 8,
        };
        let bytes = (points.len() * 3 * real).max(16) as u64;
        if bytes > ctx.max_binding_bytes() || points.len() >= u32::MAX as usize {
            return Err(GpuError::Execution(format!(
                "arc_check: {} points do not fit one binding",
                points.len()
            )));
        }
        let data: Vec<u8> = match self.precision {
            Precision::F32 => bytemuck::cast_slice(&flat::<f32>(points)).to_vec(),
            Precision::F64 => bytemuck::cast_slice(&flat::<f64>(points)).to_vec(),
        };
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("arc_check points"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if !data.is_empty() {
            ctx.queue.write_buffer(&buffer, 0, &data);
        }
        Ok(ArcCheckSession {
            kernel: self,
            ctx,
            points: buffer,
        })
    }
}

/// One block's points on the device.
pub struct ArcCheckSession<'a> {
    kernel: &'a ArcCheckGpu,
    ctx: &'a GpuContext,
    points: wgpu::Buffer,
}

impl ArcCheckSession<'_> {
    /// The verdicts on `candidates` (indices into this session's points).
    pub fn verdicts(&self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, GpuError> {
        match self.kernel.precision {
            Precision::F32 => self.run::<f32>(candidates),
            Precision::F64 => self.run::<f64>(candidates),
        }
    }

    fn run<R: Real>(&self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, GpuError> {
        let n = candidates.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let (ctx, d) = (self.ctx, &self.ctx.device);
        let mut rec = vec![R::zero(); n * IN_STRIDE];
        let mut idx = vec![0u32; n * IDX_STRIDE];
        let mut usable = vec![true; n];
        for (k, c) in candidates.iter().enumerate() {
            let (r, i) = pack::<R>(c);
            usable[k] = fits(&r, c);
            rec[k * IN_STRIDE..(k + 1) * IN_STRIDE].copy_from_slice(&r);
            idx[k * IDX_STRIDE..(k + 1) * IDX_STRIDE].copy_from_slice(&i);
            if !usable[k] {
                // A harmless record: no covered vertex, a one-point window.
                rec[k * IN_STRIDE..(k + 1) * IN_STRIDE].fill(R::zero());
                idx[k * IDX_STRIDE..(k + 1) * IDX_STRIDE].fill(0);
                idx[k * IDX_STRIDE + twin::IDX_COVER_FIRST] = 1;
            }
        }
        let rec_bytes: &[u8] = bytemuck::cast_slice(&rec);
        let idx_bytes: &[u8] = bytemuck::cast_slice(&idx);
        if rec_bytes.len() as u64 > ctx.max_binding_bytes() {
            return Err(GpuError::Execution(format!(
                "arc_check: {n} candidates do not fit one binding"
            )));
        }
        let storage = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let copy_dst = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let rec_buf = storage("arc_check records", rec_bytes.len() as u64, copy_dst);
        let idx_buf = storage("arc_check indices", idx_bytes.len() as u64, copy_dst);
        let out_bytes = (n * 4) as u64;
        let out_buf = storage(
            "arc_check verdicts",
            out_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let staging = storage(
            "arc_check staging",
            out_bytes,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let uniform = storage(
            "arc_check params",
            std::mem::size_of::<Params>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let (x, y, row) = grid(ctx, n);
        let params = Params {
            count: n as u32,
            row,
            unused: 0.0,
            _pad: 0,
        };
        ctx.queue
            .write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
        ctx.queue.write_buffer(&rec_buf, 0, rec_bytes);
        ctx.queue.write_buffer(&idx_buf, 0, idx_bytes);
        let entries = [&uniform, &rec_buf, &idx_buf, &self.points, &out_buf];
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("arc_check"),
            layout: &self.kernel.layout,
            entries: &entries
                .iter()
                .enumerate()
                .map(|(k, b)| wgpu::BindGroupEntry {
                    binding: k as u32,
                    resource: b.as_entire_binding(),
                })
                .collect::<Vec<_>>(),
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("arc_check"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("arc_check"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.kernel.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        enc.copy_buffer_to_buffer(&out_buf, 0, &staging, 0, out_bytes);
        let index = ctx.queue.submit([enc.finish()]);
        let (tx, rx) = mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        d.poll(wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: None,
        })
        .map_err(|e| GpuError::Execution(format!("arc_check: {e}")))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Execution(format!("arc_check: map: {e}"))),
            Err(_) => return Err(GpuError::Execution("arc_check: map callback lost".into())),
        }
        let verdicts = {
            let view = staging
                .slice(..)
                .get_mapped_range()
                .map_err(|e| GpuError::Execution(format!("arc_check: {e}")))?;
            let raw: &[u32] = bytemuck::cast_slice(&view);
            raw.iter()
                .zip(&usable)
                .map(|(&v, &ok)| if ok { verdict(v) } else { Verdict::Unsure })
                .collect()
        };
        staging.unmap();
        Ok(verdicts)
    }
}

/// The kernel as a [`ArcChecker`]: what the GPU backend hands the codec.
pub struct GpuArcChecker<'a> {
    pub kernel: &'a ArcCheckGpu,
    pub ctx: &'a GpuContext,
}

impl ArcChecker for GpuArcChecker<'_> {
    fn open(&self, points: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String> {
        let s = self
            .kernel
            .open(self.ctx, points)
            .map_err(|e| e.to_string())?;
        Ok(Box::new(s))
    }
}

impl ArcCheckBlock for ArcCheckSession<'_> {
    fn verdicts(&mut self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, String> {
        ArcCheckSession::verdicts(self, candidates).map_err(|e| e.to_string())
    }
}

/// The kernel's CPU twin in precision `R` as an [`ArcChecker`]: what the
/// GPU backend should do, without a GPU (tests, emulation).
pub struct TwinArcChecker<R>(PhantomData<R>);

impl<R: Real> Default for TwinArcChecker<R> {
    fn default() -> Self {
        TwinArcChecker(PhantomData)
    }
}

struct TwinBlock<R> {
    points: Vec<R>,
}

impl<R: Real> ArcChecker for TwinArcChecker<R> {
    fn open(&self, points: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String> {
        Ok(Box::new(TwinBlock::<R> {
            points: flat(points),
        }))
    }
}

impl<R: Real> ArcCheckBlock for TwinBlock<R> {
    fn verdicts(&mut self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, String> {
        Ok(verdicts_twin(&self.points, candidates))
    }
}

/// The verdicts of the twin on `candidates` over flat `points` (in `R`).
pub fn verdicts_twin<R: Real>(points: &[R], candidates: &[ArcCandidate]) -> Vec<Verdict> {
    candidates
        .iter()
        .map(|c| {
            let (rec, idx) = pack::<R>(c);
            if fits(&rec, c) {
                verdict(twin::arc_check(&rec, &idx, points))
            } else {
                Verdict::Unsure
            }
        })
        .collect()
}
