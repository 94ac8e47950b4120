//! Sketch to 3D (paper 003): a drawing lifted to a piecewise helix, per
//! sketch (the paper: about a minute for 500 vertices in Matlab).
//!
//! `cargo bench --bench sketch`.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use strandfit::sketch::{lift_sketch, SketchOptions};
use strandfit::synthetic::{synthetic_sketch, synthetic_sketch_curls};

fn sketch(c: &mut Criterion) {
    let mut g = c.benchmark_group("sketch");
    for n in [100, 500, 2000] {
        let drawing = synthetic_sketch(n);
        g.bench_with_input(BenchmarkId::new("lift", n), &drawing, |b, d| {
            b.iter(|| lift_sketch(black_box(d), &SketchOptions::default()).expect("lift"))
        });
    }
    let drawing = synthetic_sketch_curls(500, 4);
    g.bench_with_input(BenchmarkId::new("lift_4_curls", 500), &drawing, |b, d| {
        b.iter(|| lift_sketch(black_box(d), &SketchOptions::default()).expect("lift"))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = sketch
}
criterion_main!(benches);
