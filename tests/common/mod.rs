//! Shared by the GPU parity tests.
#![allow(dead_code)]

use strandfit::gpu::GpuContext;

use std::path::{Path, PathBuf};

/// Whether this is a CI run (`CI=true`), where a skip is a failure.
pub fn in_ci() -> bool {
    std::env::var("CI").map(|v| v == "true").unwrap_or(false)
}

/// Records that GPU test `test` ran (`outcome` = "ran") or skipped, one
/// file per test under `target/tmp/gpu-tests/`, so that `.ci/run` can say
/// how many GPU tests ran and how many skipped: `cargo test` hides the
/// stderr of passing tests, so a printed skip alone is seen by nobody.
fn ledger(test: &str, outcome: &str, detail: &str) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gpu-tests");
    let _ = std::fs::create_dir_all(&dir);
    let _ = std::fs::write(dir.join(test), format!("{outcome}\t{detail}\n"));
}

/// The GPU, or `None` with a printed reason. In CI (`CI=true`) a missing
/// adapter is a failure, not a skip: the parity tests are the point there.
pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(ctx) => {
            eprintln!("{test}: GPU {}", ctx.describe());
            ledger(test, "ran", &ctx.describe());
            Some(ctx)
        }
        Err(e) => {
            if in_ci() {
                ledger(test, "failed", &format!("no GPU: {e}"));
                panic!("{test}: CI=true but no GPU: {e}");
            }
            eprintln!("{test}: SKIPPED, no GPU: {e}");
            ledger(test, "skipped", &format!("no GPU: {e}"));
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
        ledger(test, "skipped", "adapter has no SHADER_F64");
        return None;
    }
    Some(ctx)
}

/// A file of the shared data folder (`../shared/data`, or
/// `STRANDFIT_SHARED_DATA`). Missing, it is a skip with a printed reason on
/// a developer's machine and a failure naming the file under `CI=true`, so
/// that a test cannot pass in CI by checking nothing.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let base = std::env::var_os("STRANDFIT_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let p = base.join(rel);
    if p.is_file() {
        return Some(p);
    }
    let why = format!(
        "shared data file {} not found (set STRANDFIT_SHARED_DATA to the shared data folder)",
        p.display()
    );
    if in_ci() {
        panic!("CI=true: {why}");
    }
    eprintln!("SKIPPED: {why}");
    None
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
