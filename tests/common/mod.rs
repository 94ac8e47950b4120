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

/// The GPU if it runs f64 shaders (`SHADER_F64`), or `None` with a printed
/// reason. A missing adapter in CI still fails (see [`gpu_or_skip`]); an
/// adapter without f64 is a fact about the device, not a failure.
pub fn gpu_f64_or_skip(test: &str) -> Option<GpuContext> {
    let ctx = gpu_or_skip(test)?;
    if !ctx.supports_f64() {
        eprintln!("{test}: adapter has no SHADER_F64; f64 parity not applicable");
        return None;
    }
    Some(ctx)
}

/// Unit rounding of the two precisions, as f64.
pub const E32: f64 = f32::EPSILON as f64;
pub const E64: f64 = f64::EPSILON;

/// A uniformly distributed random unit vector (rejection from the ball,
/// away from the origin so that normalising is well conditioned).
pub fn unit_vector(rng: &mut rand_chacha::ChaCha8Rng) -> glam::DVec3 {
    use rand::Rng;
    loop {
        let v = glam::DVec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if v.length() > 0.2 && v.length() < 1.0 {
            return v.normalize();
        }
    }
}
