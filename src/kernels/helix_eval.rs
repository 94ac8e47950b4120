//! `shaders/helix_eval.wgsl` (twin: [`crate::twin::helix_eval`]):
//! decompression of piecewise helices into sampled points.
//!
//! A map kernel over *samples*: the host, in `f64`, places the `m` samples
//! of each chain exactly as [`PiecewiseHelix::sample_into`] does (same
//! cumulative lengths, same element choice, same local arc length `u`),
//! packs one record per sample with the element's parameters relative to
//! its start, and adds the start point `p₀` to the kernel's offset in `f64`.
//! Samples whose record does not fit the kernel (non-finite or out-of-range
//! values, `|φ| > PHI_MAX`) are evaluated by the `f64` reference instead.
//!
//! Buffers: `rec_in`, per sample `s, κ, τ, φ, t0.xyz, n0.xyz`; `rec_out`,
//! per sample `offset.xyz, tangent.xyz`.

use glam::DVec3;
use rayon::prelude::*;

use super::{by_precision, map, Exec, GpuError, MapKernel, Rng, Timings, Twin};
use crate::helix::{HelixElement, PiecewiseHelix};
use crate::twin::helix_eval::{self as twin, IN_STRIDE, OUT_STRIDE};
use crate::twin::Real;

/// Points and unit tangents of one sampled chain.
pub type ChainSamples = crate::sampled::SampledCurve;

crate::map_kernel! {
    /// The kernel.
    HelixEval {
        name: "helix_eval",
        scalar: "unused",
        buffers: ("rec_in", "rec_out"),
        parity_eps: 64.0,
    }
}

impl MapKernel for HelixEval {
    const IN_STRIDE: usize = IN_STRIDE;
    fn out_stride(_: ()) -> usize {
        OUT_STRIDE
    }
    fn twin_record<R: Real>(_: (), _: f32, rec: &[R], out: &mut [R]) {
        out.copy_from_slice(&twin::helix_eval(rec));
    }
    fn parity_records(_: (), rng: &mut Rng) -> (f32, Vec<f64>) {
        let mut records = Vec::new();
        for _ in 0..1000 {
            let t = rng.unit_vector();
            let n = t.any_orthonormal_vector();
            let e = HelixElement {
                start: DVec3::ZERO,
                tangent: t,
                normal: n,
                curvature: rng.range(0.0, 3.0),
                torsion: rng.range(-2.0, 2.0),
                length: rng.range(0.01, 4.0),
            };
            let pl = Place {
                element: &e,
                u: rng.range(0.0, e.length),
            };
            if let Some(rec) = record(&pl) {
                records.extend_from_slice(&rec);
            }
        }
        (0.0, records)
    }
}

/// For each chain the `m` points of [`PiecewiseHelix::sample`]`(m)`.
pub fn sample_chains<E: Exec>(
    exec: &E,
    chains: &[PiecewiseHelix],
    m: usize,
    timings: &mut Timings,
) -> Result<Vec<Vec<DVec3>>, GpuError> {
    let full = sample_chains_full(exec, chains, m, timings)?;
    Ok(full.into_iter().map(|c| c.points).collect())
}

/// [`sample_chains`] with the unit tangents.
pub fn sample_chains_full<E: Exec>(
    exec: &E,
    chains: &[PiecewiseHelix],
    m: usize,
    timings: &mut Timings,
) -> Result<Vec<ChainSamples>, GpuError> {
    by_precision!(exec, sample_in(exec, chains, m, timings))
}

fn sample_in<R: Real, E: Exec>(
    exec: &E,
    chains: &[PiecewiseHelix],
    m: usize,
    timings: &mut Timings,
) -> Result<Vec<ChainSamples>, GpuError> {
    let t = std::time::Instant::now();
    let places = place_all(chains, m);
    let mut input = vec![R::zero(); places.len() * IN_STRIDE];
    input
        .par_chunks_mut(IN_STRIDE)
        .zip(places.par_iter())
        .for_each(|(rec, pl)| pack(pl, rec));
    let mut out = vec![R::zero(); places.len() * OUT_STRIDE];
    timings.prepare += t.elapsed();
    map::<HelixEval, R, E>(exec, (), 0.0, &input, &mut out, timings)?;
    let t = std::time::Instant::now();
    let samples: Vec<(DVec3, DVec3)> = out
        .par_chunks(OUT_STRIDE)
        .zip(places.par_iter())
        .map(|(rec, pl)| unpack(rec, pl))
        .collect();
    let result = regroup(chains, m, samples);
    timings.readback += t.elapsed();
    Ok(result)
}

/// [`sample_chains`] with the kernel replaced by its CPU twin in precision
/// `R` — what the GPU path should return, for parity tests, and an
/// emulation of it without a GPU.
pub fn sample_chains_twin<R: Real>(chains: &[PiecewiseHelix], m: usize) -> Vec<Vec<DVec3>> {
    sample_chains(&Twin::<R>::new(), chains, m, &mut Timings::default())
        .expect("the twin cannot fail")
}

/// [`sample_chains_twin`] with the unit tangents.
pub fn sample_chains_twin_full<R: Real>(chains: &[PiecewiseHelix], m: usize) -> Vec<ChainSamples> {
    sample_chains_full(&Twin::<R>::new(), chains, m, &mut Timings::default())
        .expect("the twin cannot fail")
}

/// One sample: its element and the local arc length in it.
struct Place<'a> {
    element: &'a HelixElement,
    u: f64,
}

/// Samples per chain: what [`PiecewiseHelix::sample_into`] returns
/// (nothing for an empty chain or `m = 0`).
fn count(chain: &PiecewiseHelix, m: usize) -> usize {
    if chain.is_empty() {
        0
    } else {
        m
    }
}

/// Every chain's samples, chain after chain, placed as
/// [`PiecewiseHelix::sample_into`] places them: the same cumulative sums,
/// `s = total·k/(m − 1)`, the last element with `cum ≤ s`. `m = 1` is the
/// start point (`u = 0` in the first element).
fn place_all(chains: &[PiecewiseHelix], m: usize) -> Vec<Place<'_>> {
    let mut places = Vec::with_capacity(chains.iter().map(|c| count(c, m)).sum());
    let mut cum = Vec::new();
    for chain in chains {
        let elements = chain.elements();
        if count(chain, m) == 0 {
            continue;
        }
        if m == 1 {
            places.push(Place {
                element: &elements[0],
                u: 0.0,
            });
            continue;
        }
        cum.clear();
        let mut acc = 0.0;
        cum.push(acc);
        for e in elements {
            acc += e.length;
            cum.push(acc);
        }
        let total = chain.length();
        let mut i = 0;
        for k in 0..m {
            let s = total * k as f64 / (m - 1) as f64;
            while i + 1 < elements.len() && cum[i + 1] <= s {
                i += 1;
            }
            places.push(Place {
                element: &elements[i],
                u: s - cum[i],
            });
        }
    }
    places
}

/// The `f64` record of a sample, or `None` when the kernel cannot take it
/// (then [`unpack`] evaluates the reference).
fn record(pl: &Place) -> Option<[f64; IN_STRIDE]> {
    let e = pl.element;
    let phi = e.omega() * pl.u;
    let (t, n) = (e.tangent, e.normal);
    let rec = [
        pl.u,
        e.curvature,
        e.torsion,
        phi,
        t.x,
        t.y,
        t.z,
        n.x,
        n.y,
        n.z,
    ];
    (phi.abs() <= twin::PHI_MAX).then_some(rec)
}

/// Whether `rec` survives the conversion to `R` (finite, and the products
/// the kernel forms, up to `κ s³`, stay finite: |values| ≤ ⁴√max).
fn fits<R: Real>(rec: &[f64; IN_STRIDE]) -> bool {
    let limit = R::from_f64(f64::MAX).to_f64().sqrt().sqrt();
    rec.iter().all(|x| x.abs() <= limit)
}

/// Pack one record in the kernel's precision (zeros when it does not fit:
/// the kernel evaluates them harmlessly and [`unpack`] ignores the result).
fn pack<R: Real>(pl: &Place, rec: &mut [R]) {
    match record(pl) {
        Some(r64) if fits::<R>(&r64) => {
            for (o, x) in rec.iter_mut().zip(r64) {
                *o = R::from_f64(x);
            }
        }
        _ => rec.iter_mut().for_each(|x| *x = R::zero()),
    }
}

/// A kernel record back to `(point, tangent)`: `p₀ + offset` in `f64`.
fn unpack<R: Real>(rec: &[R], pl: &Place) -> (DVec3, DVec3) {
    let e = pl.element;
    match record(pl) {
        Some(r64) if fits::<R>(&r64) => {
            let get =
                |j: usize| DVec3::new(rec[j].to_f64(), rec[j + 1].to_f64(), rec[j + 2].to_f64());
            (e.start + get(twin::OUT_OFFSET), get(twin::OUT_TANGENT))
        }
        _ => (e.point(pl.u), e.tangent_at(pl.u)),
    }
}

/// Flat samples back into chains.
fn regroup(chains: &[PiecewiseHelix], m: usize, samples: Vec<(DVec3, DVec3)>) -> Vec<ChainSamples> {
    let mut it = samples.into_iter();
    chains
        .iter()
        .map(|c| {
            let (points, tangents) = it.by_ref().take(count(c, m)).unzip();
            ChainSamples { points, tangents }
        })
        .collect()
}
