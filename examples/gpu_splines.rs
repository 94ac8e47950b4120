//! Fit Bézier splines with G1 piecewise helices on the GPU backend, and
//! compare with the `f64` CPU reference. Without a usable GPU adapter the
//! example says so and runs on the CPU.
//!
//! `cargo run --release --example gpu_splines [-- CURVES ELEMENTS]`
//!
//! (`STRANDFIT_ADAPTER` picks an adapter by name, e.g. `llvmpipe` for
//! Mesa's software Vulkan.)

use std::error::Error;

use strandfit::synthetic::synthetic_splines;
use strandfit::FitOptions;
use strandfit::{Backend, BackendChoice, ParamCurve3, PrecisionChoice};

fn main() -> Result<(), Box<dyn Error>> {
    run(std::env::args().skip(1).collect())
}

/// The example on `args` (none: 64 splines, 16 helices each).
pub fn run(args: Vec<String>) -> Result<(), Box<dyn Error>> {
    let mut args = args.into_iter();
    let curves: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(64);
    let elements: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(16);

    let backend = match Backend::open_explained(BackendChoice::Gpu, PrecisionChoice::Auto) {
        Ok((backend, why)) => {
            println!("{why}");
            backend
        }
        Err(e) => {
            println!("no usable GPU ({e}); fitting on the CPU instead");
            Backend::Cpu
        }
    };

    // Four-segment cubic splines, deterministic.
    let splines = synthetic_splines(curves, 4);
    let opts = FitOptions::new(elements);
    let fitted = backend.fit(&splines, &opts)?;
    let reference = Backend::Cpu.fit(&splines, &opts)?;

    let mut worst = 0.0f64;
    let mut failed = 0;
    for (got, want) in fitted.iter().zip(&reference) {
        match (got, want) {
            (Ok(g), Ok(w)) => {
                // The two chains sampled at the same arc-length fractions.
                let d = g
                    .sample(33)
                    .iter()
                    .zip(w.sample(33))
                    .map(|(a, b)| a.distance(b) / w.arc_length())
                    .fold(0.0, f64::max);
                worst = worst.max(d);
            }
            _ => failed += 1,
        }
    }
    println!(
        "{} splines, {elements} helices each, on {}: {failed} failed; \
         largest distance to the CPU fit {worst:.2e} of the curve's length",
        splines.len(),
        backend.describe()
    );
    // f32 kernels agree to about 1e-4 of the length; f64 ones to rounding.
    if failed > 0 || worst > 1e-3 {
        return Err("the backend's fits differ from the CPU reference".into());
    }
    Ok(())
}
