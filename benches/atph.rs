//! ATPH Hermite interpolation (paper 002) throughput: one pair at a time
//! (3×3 system; 4×4 with a prescribed length), the rayon batch, and
//! evaluation of the closed form.
//!
//! `cargo bench --bench atph`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use strandfit::atph::{interpolate, interpolate_pairs, interpolate_with_length};
use strandfit::synthetic::synthetic_hermite_pairs;

fn atph(c: &mut Criterion) {
    let pairs = synthetic_hermite_pairs(100_000);
    let lengths: Vec<Option<f64>> = pairs
        .iter()
        .map(|p| Some(1.2 * (p.p1 - p.p0).length()))
        .collect();
    let mut g = c.benchmark_group("atph");
    g.throughput(Throughput::Elements(pairs.len() as u64));
    g.bench_function("interpolate_1thread", |b| {
        b.iter(|| {
            pairs
                .iter()
                .filter(|p| interpolate(p.p0, p.t0, p.p1, p.t1).is_ok())
                .count()
        })
    });
    g.bench_function("with_length_1thread", |b| {
        b.iter(|| {
            pairs
                .iter()
                .zip(&lengths)
                .filter(|(p, l)| {
                    interpolate_with_length(p.p0, p.t0, p.p1, p.t1, l.unwrap()).is_ok()
                })
                .count()
        })
    });
    g.bench_function("interpolate_batch", |b| {
        b.iter(|| interpolate_pairs(black_box(&pairs), None))
    });
    g.bench_function("with_length_batch", |b| {
        b.iter(|| interpolate_pairs(black_box(&pairs), Some(&lengths)))
    });
    let curves: Vec<_> = interpolate_pairs(&pairs[..10_000], None)
        .into_iter()
        .flatten()
        .collect();
    g.throughput(Throughput::Elements(curves.len() as u64 * 16));
    g.bench_function("evaluate_16_per_curve", |b| {
        b.iter(|| {
            let mut s = glam::DVec3::ZERO;
            for c in &curves {
                for k in 0..16 {
                    s += c.position(k as f64 / 15.0);
                }
            }
            s
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = atph
}
criterion_main!(benches);
