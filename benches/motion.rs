//! RRMF motions (paper 001): local G1 Hermite interpolations with a
//! one-sided frame per second (the rational RMF included), and whole
//! splines through point streams, in points per second.
//!
//! `cargo bench --bench motion`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::{DQuat, DVec3};
use rayon::prelude::*;
use strandfit::rrmf::{default_frame, interpolate_local, minaj2_references, RrmfSpline};

/// Deterministic local problems satisfying (4.1): u_f is u_i turned about
/// the chord by 0.3–2.8 rad.
fn local_problems(n: usize) -> Vec<(DVec3, [DVec3; 3], DVec3, DVec3)> {
    (0..n)
        .map(|k| {
            let a = k as f64 * 0.618_033_988_75;
            let u = DVec3::new(a.cos(), a.sin(), 0.3 * (2.0 * a).sin()).normalize();
            let frame = default_frame(u).unwrap();
            let dp = DVec3::new(
                1.0 + (1.7 * a).sin(),
                (1.3 * a).cos(),
                0.5 * (0.7 * a).sin(),
            );
            let turn = 0.3 + 2.5 * (a * 0.414).fract();
            let u_f = DQuat::from_axis_angle(dp.normalize(), turn) * u;
            (DVec3::ZERO, frame, dp, u_f)
        })
        .collect()
}

/// Streams of `len` points along wandering helices (hair-strand-like).
fn streams(count: usize, len: usize) -> Vec<Vec<DVec3>> {
    (0..count)
        .map(|c| {
            let ph = c as f64 * 0.618_033_988_75;
            (0..len)
                .map(|k| {
                    let u = k as f64 * 0.45;
                    let r = 1.0 + 0.3 * (0.7 * u + ph).sin();
                    DVec3::new(r * (2.0 * u + ph).cos(), r * (2.0 * u + ph).sin(), 0.8 * u)
                })
                .collect()
        })
        .collect()
}

fn motion(c: &mut Criterion) {
    let problems = local_problems(2000);
    let mut g = c.benchmark_group("motion");
    g.throughput(Throughput::Elements(problems.len() as u64));
    g.bench_function("local_1thread", |b| {
        b.iter(|| {
            problems
                .iter()
                .filter(|p| interpolate_local(p.0, p.1, p.2, p.3).is_ok())
                .count()
        })
    });
    g.bench_function("local_rayon", |b| {
        b.iter(|| {
            problems
                .par_iter()
                .filter(|p| interpolate_local(p.0, p.1, p.2, p.3).is_ok())
                .count()
        })
    });
    let curves: Vec<_> = problems
        .iter()
        .filter_map(|p| interpolate_local(p.0, p.1, p.2, p.3).ok())
        .map(|s| s.curve.curve)
        .collect();
    g.throughput(Throughput::Elements(curves.len() as u64));
    g.bench_function("rational_rmf_only", |b| {
        b.iter(|| {
            curves
                .iter()
                .filter(|c| strandfit::rrmf::RrmfQuintic::new(**c).is_ok())
                .count()
        })
    });
    let s = streams(200, 30);
    let samples = 200;
    g.throughput(Throughput::Elements((s.len() * samples) as u64));
    g.bench_function("spline_build_and_sample_200pts", |b| {
        b.iter(|| {
            s.par_iter()
                .map(|p| {
                    let r = minaj2_references(p);
                    let m = RrmfSpline::build(p, &r, default_frame(r[0]).unwrap(), 0.125).unwrap();
                    black_box(m.sample(samples)).len()
                })
                .sum::<usize>()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = motion
}
criterion_main!(benches);
