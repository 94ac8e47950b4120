//! The codec's encoding and decoding throughput, in input points per
//! second, and its linearity in curve length: the same 1,000,000 points as
//! one curve and as 1,000 curves of 1,000 (a quadratic search would make
//! the first hundreds of times slower; the bound is 3×).
//!
//! `throughput` encodes and decodes 4,096 curves of 50 points at 0.1 and
//! 0.5 mm, jittered (at 0.1 mm they go as points) and smooth (as arcs).
//!
//! `cargo bench --bench codec` (add `-- linear` or `-- throughput`).

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::codec::{decode_block, encode_block, CodecParams};

/// A smooth wandering curve: 0.5 mm steps, the direction turning by a
/// random walk, plus 0.05 mm jitter (tractography-like).
fn wandering(n: usize, seed: u64) -> Vec<DVec3> {
    wandering_with(n, seed, 0.05)
}

/// [`wandering`] with `jitter` (mm, each axis uniform in ±`jitter`).
fn wandering_with(n: usize, seed: u64, jitter: f64) -> Vec<DVec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p = DVec3::ZERO;
    let mut d = DVec3::X;
    let mut turn = DVec3::ZERO;
    (0..n)
        .map(|_| {
            turn = (turn * 0.9
                + DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                ) * 0.02)
                .clamp_length_max(0.1);
            d = (d + turn).normalize();
            p += d * 0.5;
            p + DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            ) * jitter
        })
        .collect()
}

fn linear(c: &mut Criterion) {
    let params = CodecParams::new(0.5);
    let long = wandering(1_000_000, 1);
    let cut: Vec<Vec<DVec3>> = long.chunks(1000).map(|c| c.to_vec()).collect();
    let mut g = c.benchmark_group("linear");
    g.sample_size(10);
    g.throughput(Throughput::Elements(long.len() as u64));
    g.bench_function("one_curve_of_1M_points", |b| {
        b.iter(|| encode_block(black_box(&[&long[..]]), &params).unwrap())
    });
    g.bench_function("1000_curves_of_1000_points", |b| {
        b.iter(|| encode_block(black_box(&cut), &params).unwrap())
    });
    g.finish();
}

fn throughput(c: &mut Criterion) {
    let mut g = c.benchmark_group("throughput");
    g.sample_size(10);
    for (kind, jitter) in [("", 0.05), ("_smooth", 0.0)] {
        for tol in [0.1, 0.5] {
            let params = CodecParams::new(tol);
            let curves: Vec<Vec<DVec3>> =
                (0..4096).map(|k| wandering_with(50, k, jitter)).collect();
            let points: usize = curves.iter().map(Vec::len).sum();
            g.throughput(Throughput::Elements(points as u64));
            g.bench_with_input(
                BenchmarkId::new(format!("encode{kind}"), tol),
                &tol,
                |b, _| b.iter(|| encode_block(black_box(&curves), &params).unwrap()),
            );
            let block = encode_block(&curves, &params).unwrap();
            g.bench_with_input(
                BenchmarkId::new(format!("decode{kind}"), tol),
                &tol,
                |b, _| {
                    b.iter(|| decode_block(black_box(&block.bytes), curves.len(), &params).unwrap())
                },
            );
        }
    }
    g.finish();
}

criterion_group!(benches, linear, throughput);
criterion_main!(benches);
