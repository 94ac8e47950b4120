//! Shared by the GPU parity tests.
#![allow(dead_code)]

use strandfit::gpu::GpuContext;

/// The GPU, or `None` with a printed reason. In CI (`CI=true`) a missing
/// adapter is a failure, not a skip: the parity tests are the point there.
pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(ctx) => {
            eprintln!("{test}: GPU {}", ctx.describe());
            Some(ctx)
        }
        Err(e) => {
            if std::env::var("CI").map(|v| v == "true").unwrap_or(false) {
                panic!("{test}: CI=true but no GPU: {e}");
            }
            eprintln!("{test}: SKIPPED, no GPU: {e}");
            None
        }
    }
}
