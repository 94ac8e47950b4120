//! RRMF motions (paper 001): local G1 Hermite interpolations with a
//! one-sided frame per second (the rational RMF included), and whole
//! splines through point streams, in points per second.
//!
//! `cargo bench --bench motion`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use rayon::prelude::*;
use strandfit::rrmf::{default_frame, interpolate_local, minaj2_references, RrmfSpline};
use strandfit::synthetic::{synthetic_local_motions, synthetic_streams};

fn motion(c: &mut Criterion) {
    let problems = synthetic_local_motions(2000);
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
    let s = synthetic_streams(200, 30);
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
