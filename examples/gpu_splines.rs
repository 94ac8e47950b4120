//! Fit Bézier splines with G1 piecewise helices on the GPU backend, and
//! compare with the `f64` CPU reference. Without a usable GPU adapter the
//! example says so and runs on the CPU.
//!
//! `cargo run --release --example gpu_splines [-- CURVES ELEMENTS]`
//!
//! (`STRANDFIT_ADAPTER` picks an adapter by name, e.g. `llvmpipe` for
//! Mesa's software Vulkan.)

use std::error::Error;

use strandfit::{Backend, BackendChoice, BezierSpline, DVec3, FitOptions};
use strandfit::{ParamCurve3, PrecisionChoice};

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

    let splines = (0..curves).map(strand).collect::<Result<Vec<_>, _>>()?;
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

/// Strand `c`: a four-segment cubic spline through five points of a
/// wandering helix (its radius varying slowly), about the shape of a hair,
/// each segment the Hermite cubic of the helix's points and derivatives.
fn strand(c: usize) -> Result<BezierSpline, strandfit::spline::SplineError> {
    let phase = c as f64 * 0.618;
    let pos = |u: f64| {
        let r = 1.0 + 0.3 * (0.7 * u + phase).sin();
        let a = 2.0 * u + phase;
        DVec3::new(r * a.cos(), r * a.sin(), 0.8 * u + 0.2 * (1.3 * u).sin())
    };
    let vel = |u: f64| (pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6;
    let h = 1.5; // four segments of u ∈ [0, 6]
    let mut control = vec![pos(0.0)];
    for (a, b) in (0..4).map(|k| (k as f64 * h, (k + 1) as f64 * h)) {
        control.extend([pos(a) + vel(a) * h / 3.0, pos(b) - vel(b) * h / 3.0, pos(b)]);
    }
    BezierSpline::from_control_points(&control)
}
