//! The GPU engine: one cached device context ([`GpuContext`]) and one
//! generic dispatcher that runs any kernel of [`crate::kernels`] from its
//! description. [`Gpu`] — a context in one precision — is the GPU
//! [`Exec`]utor the kernels' host code runs on; the CPU twin is
//! [`crate::kernels::Twin`].
//!
//! Precision: every kernel is written once over a scalar alias `real` and
//! compiled in `f64` where the adapter offers `SHADER_F64` (lavapipe and
//! NVIDIA do) or `f32` (everywhere). WGSL's transcendental built-ins are
//! never used on `real` (see [`crate::twin::math`]).

mod context;
mod dispatch;

pub use crate::kernels::{kernel_sources, prelude, GpuError, Precision, Timings, MATH_WGSL};
pub use context::{list_adapters, GpuContext, ADAPTER_ENV};

use crate::kernels::{Batch, Data, Exec, Kernel, Limits};
use crate::twin::Real;

impl Precision {
    /// `f64` where the adapter has it, else `f32`.
    pub fn best(ctx: &GpuContext) -> Precision {
        ctx.best_precision()
    }
}

/// An opened GPU in one precision: the GPU [`Exec`]utor.
#[derive(Clone, Copy, Debug)]
pub struct Gpu<'a> {
    pub ctx: &'a GpuContext,
    precision: Precision,
}

impl GpuContext {
    /// This GPU running kernels in `precision`; `f64` only on adapters with
    /// `SHADER_F64`.
    pub fn exec(&self, precision: Precision) -> Result<Gpu<'_>, GpuError> {
        if precision == Precision::F64 && !self.supports_f64() {
            return Err(GpuError::NoF64 {
                adapter: self.adapter_info().name.clone(),
            });
        }
        Ok(Gpu {
            ctx: self,
            precision,
        })
    }
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
        let buffer = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("resident"),
            size: (bytes.len() as u64).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if !bytes.is_empty() {
            self.ctx.queue.write_buffer(&buffer, 0, bytes);
        }
        Ok(buffer)
    }

    fn run<'a, K: Kernel, R: Real>(
        &self,
        cfg: K::Config,
        resident: &[&wgpu::Buffer],
        batches: &mut dyn Iterator<Item = Batch<'a, R>>,
        done: &mut dyn FnMut(usize, &Data<'_, R>),
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        self.stream::<K, R>(cfg, resident, batches, done, timings)
    }
}
