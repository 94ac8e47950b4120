//! The programs in `examples/` run as tests (so `cargo test --all-targets`
//! in CI runs them): each is included as a module and its `run` called
//! with no arguments (its defaults: bundled data, small sizes).
//! The examples' own `main`s (the command-line argument parsing) are not
//! called here.

#[allow(dead_code)]
#[path = "../examples/compress_tractogram.rs"]
mod compress_tractogram;
#[allow(dead_code)]
#[path = "../examples/euler_gaps.rs"]
mod euler_gaps;
#[allow(dead_code)]
#[path = "../examples/gpu_splines.rs"]
mod gpu_splines;

#[test]
fn compress_tractogram_example() {
    compress_tractogram::run(Vec::new()).unwrap();
}

#[test]
fn euler_gaps_example() {
    euler_gaps::run(Vec::new()).unwrap();
}

/// On the GPU when there is one (lavapipe in CI), else on the CPU.
#[test]
fn gpu_splines_example() {
    gpu_splines::run(Vec::new()).unwrap();
}
