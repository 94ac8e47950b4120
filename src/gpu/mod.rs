//! The GPU engine: one cached device context ([`GpuContext`]) and one
//! generic dispatcher that runs any kernel of [`crate::kernels`] from its
//! description. [`Gpu`] — a context in one precision — is the GPU
//! executor ([`crate::kernels::Exec`]) the kernels' host code runs on; the CPU twin is
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

impl Precision {
    /// `f64` where the adapter has it, else `f32`.
    pub fn best(ctx: &GpuContext) -> Precision {
        ctx.best_precision()
    }
}

/// An opened GPU in one precision: the GPU executor ([`crate::kernels::Exec`]).
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
