//! Throughput of each stage of the floating tangents fit, in helix elements
//! per second: sampling, relaxation (dense LU vs tridiagonal), interpolation,
//! and the whole fit (single-threaded per curve and rayon over curves); the
//! backends; Frenet–Serret integration and spline sampling; and Euler-spiral
//! completion (completions per second).
//!
//! `cargo bench --bench fit` (add `-- <filter>` to pick a group).

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use strandfit::helix::{interpolate, relax_dense, relax_tridiagonal, RelaxScratch};
use strandfit::synthetic::synthetic_splines;
use strandfit::{fit_spline_with, fit_splines, FitOptions, FitScratch};

/// Points and tangents of a synthetic spline at `n` elements.
fn samples(n: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let spline = &synthetic_splines(1, (n / 2).max(4))[0];
    let (mut p, mut t) = (Vec::new(), Vec::new());
    spline
        .sample_equal_arclen_into(n, &mut p, &mut t)
        .expect("sampling");
    (p, t)
}

fn sampling(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampling");
    let spline = &synthetic_splines(1, 8)[0];
    for n in [10usize, 20, 100, 1000] {
        g.throughput(Throughput::Elements(n as u64));
        let (mut p, mut t) = (Vec::new(), Vec::new());
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| {
                spline
                    .sample_equal_arclen_into(black_box(n), &mut p, &mut t)
                    .expect("sampling")
            })
        });
    }
    g.finish();
}

fn relaxation(c: &mut Criterion) {
    let mut g = c.benchmark_group("relaxation");
    for n in [10usize, 100, 1000] {
        let (p, t) = samples(n);
        g.throughput(Throughput::Elements(n as u64));
        let mut out = Vec::new();
        let mut scratch = RelaxScratch::default();
        g.bench_with_input(BenchmarkId::new("tridiagonal", n), &n, |b, _| {
            b.iter(|| relax_tridiagonal(black_box(&p), &t, &mut out, &mut scratch))
        });
        if n == 1000 {
            g.sample_size(10);
        }
        g.bench_with_input(BenchmarkId::new("dense_lu", n), &n, |b, _| {
            b.iter(|| relax_dense(black_box(&p), &t))
        });
    }
    g.finish();
}

fn interpolation(c: &mut Criterion) {
    let mut g = c.benchmark_group("interpolation");
    let n = 1000;
    let (p, t) = samples(n);
    let mut relaxed = Vec::new();
    relax_tridiagonal(&p, &t, &mut relaxed, &mut RelaxScratch::default());
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("ghosh", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for i in 0..n {
                let h = interpolate(relaxed[i], t[i], relaxed[i + 1], t[i + 1], 1e-6)
                    .expect("co-helical");
                acc += h.phi;
            }
            black_box(acc)
        })
    });
    g.finish();
}

fn whole_fit(c: &mut Criterion) {
    let mut g = c.benchmark_group("whole_fit");
    let splines = synthetic_splines(2000, 8);
    {
        let n = 20usize;
        let opts = FitOptions::new(n);
        g.throughput(Throughput::Elements((n * splines.len()) as u64));
        g.bench_with_input(BenchmarkId::new("rayon", n), &n, |b, _| {
            b.iter(|| fit_splines(black_box(&splines), &opts))
        });
        let mut scratch = FitScratch::default();
        g.bench_with_input(BenchmarkId::new("one_thread", n), &n, |b, _| {
            b.iter(|| {
                for s in &splines {
                    black_box(fit_spline_with(s, &opts, &mut scratch).expect("fit"));
                }
            })
        });
    }
    g.finish();
}

/// The same batch of relaxed pairs through each backend: CPU reference
/// (rayon), GPU f64 and f32 (including host packing, transfers, readback).
/// Skipped, with a note, when no GPU adapter exists.
fn backends(c: &mut Criterion) {
    use strandfit::relaxed_pairs;
    use strandfit::{Backend, BackendChoice, PrecisionChoice};
    let splines = synthetic_splines(5000, 8);
    let opts = FitOptions::new(20);
    let mut pairs = Vec::new();
    let mut scratch = FitScratch::default();
    for s in &splines {
        relaxed_pairs(s, &opts, &mut scratch, &mut pairs).expect("synthetic splines fit");
    }
    let mut g = c.benchmark_group("backend");
    g.sample_size(10);
    let mut engines = vec![("cpu", Backend::Cpu)];
    for (name, p) in [
        ("gpu_f64", PrecisionChoice::F64),
        ("gpu_f32", PrecisionChoice::F32),
    ] {
        match Backend::open(BackendChoice::Gpu, p) {
            Ok(b) => engines.push((name, b)),
            Err(e) => eprintln!("backend bench: {name} skipped: {e}"),
        }
    }
    for (name, backend) in &engines {
        g.throughput(Throughput::Elements(pairs.len() as u64));
        g.bench_function(BenchmarkId::new("interpolate", name), |b| {
            b.iter(|| black_box(backend.interpolate(&pairs, 1e-6).expect("backend")))
        });
        g.throughput(Throughput::Elements((splines.len() * opts.elements) as u64));
        g.bench_function(BenchmarkId::new("whole_fit_20", name), |b| {
            b.iter(|| black_box(backend.fit(&splines, &opts).expect("backend")))
        });
    }
    g.finish();
}

/// 3D Euler spirals integrated at 64 steps: the `f64` reference on all
/// cores (rayon) against the GPU kernel in `f64` and `f32` (including host
/// packing, transfers and readback), in problems per second. The GPU
/// variants are skipped, with a note, when no adapter exists.
fn frenet(c: &mut Criterion) {
    use rayon::prelude::*;
    use strandfit::euler::FrenetProblem;
    use strandfit::gpu::{GpuContext, Precision, Timings};
    use strandfit::kernels::frenet_integrate::integrate;
    let problems: Vec<FrenetProblem> = (0..20_000)
        .map(|i| {
            let x = i as f64 / 20_000.0;
            let t = DVec3::new(1.0, x, -0.5).normalize();
            FrenetProblem::new(
                DVec3::new(x, 2.0 * x, 10.0),
                t,
                t.any_orthonormal_vector(),
                1.0 + x,
                -2.0 * x,
                0.5 - x,
                x,
                2.0 + x,
            )
        })
        .collect();
    let steps = 64;
    let mut g = c.benchmark_group("frenet");
    g.sample_size(10);
    g.throughput(Throughput::Elements(problems.len() as u64));
    g.bench_function(BenchmarkId::new("integrate_64", "cpu"), |b| {
        b.iter(|| {
            black_box(
                problems
                    .par_iter()
                    .map(|p| p.integrate(steps))
                    .collect::<Vec<_>>(),
            )
        })
    });
    match GpuContext::new() {
        Ok(ctx) => {
            for (name, p) in [("gpu_f64", Precision::F64), ("gpu_f32", Precision::F32)] {
                match ctx.exec(p) {
                    Ok(k) => {
                        g.bench_function(BenchmarkId::new("integrate_64", name), |b| {
                            b.iter(|| {
                                let mut t = Timings::default();
                                black_box(integrate(&k, &problems, steps, &mut t).expect("gpu"))
                            })
                        });
                    }
                    Err(e) => eprintln!("frenet bench: {name} skipped: {e}"),
                }
            }
        }
        Err(e) => eprintln!("frenet bench: gpu skipped: {e}"),
    }
    g.finish();
}

/// Equal-arc-length sampling of a batch of splines (samples per second):
/// the `f64` reference on all cores vs the `spline_sample` kernel in `f64`
/// and `f32` (host packing, transfers, readback included). Skipped, with a
/// note, when no GPU adapter exists.
fn spline_sample(c: &mut Criterion) {
    use rayon::prelude::*;
    use strandfit::gpu::{GpuContext, Precision, Timings};
    use strandfit::kernels::spline_sample::sample;
    let splines = synthetic_splines(5000, 8);
    let mut g = c.benchmark_group("spline_sample");
    g.sample_size(10);
    let ctx = GpuContext::new()
        .map_err(|e| eprintln!("spline_sample bench: GPU skipped: {e}"))
        .ok();
    for n in [20usize, 200] {
        g.throughput(Throughput::Elements((splines.len() * (n + 1)) as u64));
        g.bench_function(BenchmarkId::new("cpu", n), |b| {
            b.iter(|| {
                let out: Vec<_> = splines
                    .par_iter()
                    .map(|s| s.sample_equal_arclen(n).expect("sampling"))
                    .collect();
                black_box(out)
            })
        });
        let Some(ctx) = &ctx else { continue };
        for (name, p) in [("gpu_f64", Precision::F64), ("gpu_f32", Precision::F32)] {
            let k = match ctx.exec(p) {
                Ok(k) => k,
                Err(e) => {
                    eprintln!("spline_sample bench: {name} skipped: {e}");
                    continue;
                }
            };
            g.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| {
                    let mut t = Timings::default();
                    black_box(sample(&k, &splines, n, &mut t).expect("gpu"))
                })
            });
        }
    }
    g.finish();
}

/// Euler-spiral completion, in completions (pairs) per second: the default
/// Levenberg–Marquardt solver through `solve_spirals` on the CPU backend
/// (per-pair solves on all cores) and on the GPU backend in `f64` (lockstep,
/// every candidate curve of a round in one dispatch per step count;
/// skipped, with a note, without an f64 adapter), on 1,000 random pairs
/// within one revolution; and the paper's Algorithm 1 (`paper_spiral`, its
/// defaults: explicit Euler at 100 samples) on the first 20 of them, on all
/// cores (rayon over pairs), for comparison.
fn completion(c: &mut Criterion) {
    use rayon::prelude::*;
    use strandfit::euler::{paper_spiral, solve_spirals, PaperOptions, SolveOptions};
    use strandfit::synthetic::{random_spirals, spiral_end_pairs};
    use strandfit::{Backend, BackendChoice, PrecisionChoice};
    let pairs = spiral_end_pairs(&random_spirals(1000, 1));
    let opts = SolveOptions::default();
    let mut g = c.benchmark_group("completion");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pairs.len() as u64));
    g.bench_function(BenchmarkId::new("euler_lm", "cpu"), |b| {
        b.iter(|| black_box(solve_spirals(&pairs, &opts, &Backend::Cpu).expect("cpu")))
    });
    match Backend::open(BackendChoice::Gpu, PrecisionChoice::F64) {
        Ok(gpu) => {
            g.bench_function(BenchmarkId::new("euler_lm", "gpu_f64"), |b| {
                b.iter(|| black_box(solve_spirals(&pairs, &opts, &gpu).expect("gpu")))
            });
        }
        Err(e) => eprintln!("completion bench: gpu_f64 skipped: {e}"),
    }
    let few = &pairs[..20];
    let paper = PaperOptions::default();
    g.throughput(Throughput::Elements(few.len() as u64));
    g.bench_function(BenchmarkId::new("paper_alg1", "cpu"), |b| {
        b.iter(|| {
            let out: Vec<_> = few
                .par_iter()
                .map(|p| paper_spiral(p.p0, p.t0, p.p1, p.t1, &paper))
                .collect();
            black_box(out)
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    sampling,
    relaxation,
    interpolation,
    whole_fit,
    backends,
    frenet,
    spline_sample,
    completion
);
criterion_main!(benches);
