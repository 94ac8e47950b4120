//! `atph_hermite.wgsl` on the GPU against its CPU twin and the `f64`
//! reference (`atph::interpolate`, `atph::interpolate_with_length`), over
//! 100,000 pairs: arcs of smooth curves, random data (mostly
//! ill-conditioned, ERRATA 002.4), tangents at and near the poles, equal
//! tangents (latitude loops), half turns, far from the origin, tiny and huge
//! scales; half of them with a prescribed length (system 4.1).
//!
//! Tolerances. The solve's error is `ε Σ|ρ| / rel_det` (the system's
//! condition times rounding), with `rel_det` from [`condition`]:
//! * GPU vs twin: the same operations in the same order, so `8 ε_R` of that
//!   (measured: 0, bit-identical on lavapipe; other drivers fuse a·b+c and
//!   round `f32` division, `sqrt`, `sin` and `cos` their own way, within
//!   WGSL's accuracy: NVIDIA H200, driver 580, `f32` 4.4, `f64` 2.6, so the
//!   same bound as against the reference);
//! * GPU vs reference: the same results and the same errors for every pair
//!   (the host re-solves untrusted pairs, see `kernels::atph_hermite`), and `ρ` within
//!   `8 ε_R Σ|ρ| / rel_det` (`f64`: different `sin`/`cos`, series lengths and
//!   pivot tie-breaks; `f32`: the record's rounding to `f32` perturbs the
//!   system by `ε₃₂`).

mod common;
use common::{unit_vector, E32, E64};

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::atph::{interpolate, interpolate_with_length, AtphCurve, AtphError, HermitePair};
use strandfit::gpu::{GpuContext, Precision, Timings};
use strandfit::kernels::atph_hermite::{
    condition, interpolate as interpolate_on, interpolate_twin, trust_threshold,
};
use strandfit::twin::Real;

fn pairs() -> (Vec<HermitePair>, Vec<Option<f64>>) {
    let mut rng = ChaCha8Rng::seed_from_u64(2002);
    let mut pairs = strandfit::synthetic::synthetic_hermite_pairs(40_000);
    for _ in 0..40_000 {
        let mut p = || {
            DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
        };
        let (a, b) = (p(), p());
        pairs.push(HermitePair::new(
            a,
            unit_vector(&mut rng),
            b,
            unit_vector(&mut rng),
        ));
    }
    for i in 0..20_000 {
        let t = unit_vector(&mut rng);
        let q = DVec3::new(
            rng.gen_range(-2.0..2.0),
            rng.gen_range(-2.0..2.0),
            rng.gen_range(-2.0..2.0),
        );
        let pair = match i % 6 {
            // At and near a pole.
            0 => (DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0), q, t),
            1 => (DVec3::ZERO, DVec3::new(1e-9, -2e-9, -1.0), q, t),
            // Equal tangents, not along the chord: the latitude loop.
            2 => (DVec3::ZERO, t, q, t),
            // A half turn in azimuth.
            3 => (DVec3::ZERO, t, q, DVec3::new(-t.x, -t.y, t.z)),
            // Far from the origin, and tiny and huge scales.
            4 => {
                let o = DVec3::splat(1e5);
                (o, t, o + q, unit_vector(&mut rng))
            }
            _ => {
                let s = if rng.gen_bool(0.5) { 1e-6 } else { 1e6 };
                (DVec3::ZERO, t, s * q, unit_vector(&mut rng))
            }
        };
        pairs.push(pair.into());
    }
    let lengths = pairs
        .iter()
        .enumerate()
        .map(|(i, p)| (i % 2 == 1).then(|| (1.05 + 0.1 * (i % 7) as f64) * (p.p1 - p.p0).length()))
        .collect();
    (pairs, lengths)
}

fn reference(pairs: &[HermitePair], lengths: &[Option<f64>]) -> Vec<Result<AtphCurve, AtphError>> {
    pairs
        .iter()
        .zip(lengths)
        .map(|(p, l)| match l {
            Some(l) => interpolate_with_length(p.p0, p.t0, p.p1, p.t1, *l),
            None => interpolate(p.p0, p.t0, p.p1, p.t1),
        })
        .collect()
}

/// Worst `|Δρ_j| / (ε Σ|ρ| / rel_det)` over pairs solved by both; panics
/// if the two disagree on success or on the error.
fn compare(
    label: &str,
    a: &[Result<AtphCurve, AtphError>],
    b: &[Result<AtphCurve, AtphError>],
    pairs: &[HermitePair],
    lengths: &[Option<f64>],
    eps: f64,
) -> f64 {
    let mut worst = 0.0f64;
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        match (x, y) {
            (Ok(x), Ok(y)) => {
                let (rx, ry) = (x.rho.coefficients(), y.rho.coefficients());
                assert_eq!(rx.len(), ry.len(), "{label}: pair {i} degree");
                assert_eq!(x.tangent, y.tangent, "{label}: pair {i} field");
                let size: f64 = ry.iter().map(|v| v.abs()).sum();
                let rel = condition(&pairs[i], lengths[i]).unwrap_or(1.0);
                for (u, v) in rx.iter().zip(ry) {
                    worst = worst.max((u - v).abs() / (eps * size / rel));
                }
            }
            (Err(e), Err(f)) => assert_eq!(
                std::mem::discriminant(e),
                std::mem::discriminant(f),
                "{label}: pair {i}: {e} vs {f}"
            ),
            _ => panic!("{label}: pair {i}: {x:?} vs {y:?}"),
        }
    }
    worst
}

fn check<R: Real>(ctx: &GpuContext, precision: Precision, eps: f64) {
    let (pairs, lengths) = pairs();
    let gpu = ctx.exec(precision).unwrap();
    let mut timings = Timings::default();
    let got = interpolate_on(&gpu, &pairs, Some(&lengths), &mut timings).unwrap();
    let twin = interpolate_twin::<R>(&pairs, Some(&lengths));
    let refs = reference(&pairs, &lengths);
    let ok = refs.iter().filter(|r| r.is_ok()).count();
    let kernel = pairs
        .iter()
        .zip(&lengths)
        .filter(|(p, l)| condition(p, **l).is_some_and(|c| c >= trust_threshold::<R>()))
        .count();
    let vs_twin = compare("gpu vs twin", &got, &twin, &pairs, &lengths, eps);
    let vs_ref = compare("gpu vs reference", &got, &refs, &pairs, &lengths, eps);
    eprintln!(
        "{}: {} pairs, {ok} solved, {kernel} by the kernel; gpu vs twin {vs_twin:.3}, \
         gpu vs reference {vs_ref:.3} (units of ε Σ|ρ|/rel_det); {:?}",
        precision.name(),
        pairs.len(),
        timings
    );
    assert!(kernel > 50_000, "{kernel}");
    assert!(vs_twin <= 8.0, "{vs_twin}");
    assert!(vs_ref <= 8.0, "{vs_ref}");
}

#[test]
fn atph_hermite_f64_matches_twin_and_reference() {
    let Some(ctx) = common::gpu_f64_or_skip("atph_hermite_f64") else {
        return;
    };
    check::<f64>(&ctx, Precision::F64, E64);
}

#[test]
fn atph_hermite_f32_matches_twin_and_reference() {
    let Some(ctx) = common::gpu_or_skip("atph_hermite_f32") else {
        return;
    };
    check::<f32>(&ctx, Precision::F32, E32);
}
