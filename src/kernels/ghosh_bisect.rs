//! `shaders/ghosh_bisect.wgsl` (twin: [`crate::twin::ghosh_bisect`]):
//! Ghosh short helices for a batch of Hermite pairs.
//!
//! The host does in `f64` what is cheap and precision-critical (see the
//! twin's docs): it reduces each pair to six scalars, and turns the kernel's
//! answer back into an element with start point, tangent, axis and normal
//! in `f64` and κ, τ, L, φ* from the kernel. Records the kernel rejects are re-run
//! through the `f64` reference [`crate::helix::interpolate`], which
//! decides borderline cases (a co-helicity residual at the tolerance, say)
//! and words the error.
//!
//! Buffers: `seg_in`, per segment `|d|, |t1 − t0|, |t1 + t0|, d·e1, d·e2,
//! d·e3`; `seg_out`, per segment `status, φ, ω, τ̄, κ, τ, length, a1, a2, χ,
//! residual, steps`; `params.tol` the relative co-helicity tolerance.

use glam::DVec3;
use rayon::prelude::*;

use super::{by_precision, map, Exec, GpuError, MapKernel, Rng, Timings, Twin};
use crate::helix::ghosh_basis;
use crate::helix::{HelixElement, HelixError, HermitePair, ShortHelix};
use crate::twin::ghosh_bisect::{self as twin, status, IN_STRIDE, OUT_STEPS, OUT_STRIDE};
use crate::twin::Real;

crate::map_kernel! {
    /// The kernel.
    GhoshBisect {
        name: "ghosh_bisect",
        scalar: "tol",
        buffers: ("seg_in", "seg_out"),
        parity_eps: 64.0,
    }
}

impl MapKernel for GhoshBisect {
    const IN_STRIDE: usize = IN_STRIDE;
    fn out_stride(_: ()) -> usize {
        OUT_STRIDE
    }
    fn twin_record<R: Real>(_: (), tol: f32, rec: &[R], out: &mut [R]) {
        let rec: &[R; IN_STRIDE] = rec.try_into().expect("stride");
        out.copy_from_slice(&twin::ghosh_bisect(rec, R::from_f64(tol as f64)));
    }
    /// The bisection's step count (a diagnostic) may differ by a step or
    /// two where the stopping test `hi − lo > 2ε·hi` rounds the other way.
    fn parity_count_slack(index: usize) -> Option<f64> {
        (index % OUT_STRIDE == OUT_STEPS).then_some(2.0)
    }
    fn parity_records(_: (), rng: &mut Rng) -> (f32, Vec<f64>) {
        let mut records = Vec::new();
        for _ in 0..500 {
            let e = HelixElement {
                start: DVec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), 0.0),
                tangent: DVec3::X,
                normal: DVec3::Y,
                curvature: rng.range(0.05, 2.0),
                torsion: rng.range(-1.0, 1.0),
                length: rng.range(0.05, 2.0),
            };
            let pr = HermitePair {
                p0: e.start,
                t0: e.tangent,
                p1: e.end_point(),
                t1: e.end_frame().tangent,
            };
            if let Some((_, rec)) = host_side(&pr) {
                records.extend_from_slice(&rec);
            }
        }
        (1e-6, records)
    }
}

/// Short helices for `pairs`, with the reference's semantics (errors and
/// all). `tol` is the relative co-helicity tolerance.
pub fn interpolate<E: Exec>(
    exec: &E,
    pairs: &[HermitePair],
    tol: f64,
    timings: &mut Timings,
) -> Result<Vec<Result<ShortHelix, HelixError>>, GpuError> {
    by_precision!(exec, interpolate_in(exec, pairs, tol, timings))
}

fn interpolate_in<R: Real, E: Exec>(
    exec: &E,
    pairs: &[HermitePair],
    tol: f64,
    timings: &mut Timings,
) -> Result<Vec<Result<ShortHelix, HelixError>>, GpuError> {
    let t = std::time::Instant::now();
    let mut input = vec![R::zero(); pairs.len() * IN_STRIDE];
    input
        .par_chunks_mut(IN_STRIDE)
        .zip(pairs.par_iter())
        .for_each(|(rec, pr)| pack(pr, rec));
    let mut out = vec![R::zero(); pairs.len() * OUT_STRIDE];
    timings.prepare += t.elapsed();
    map::<GhoshBisect, R, E>(exec, (), tol as f32, &input, &mut out, timings)?;
    let t = std::time::Instant::now();
    let result = out
        .par_chunks(OUT_STRIDE)
        .zip(pairs.par_iter())
        .map(|(rec, pr)| unpack(rec, pr, tol))
        .collect();
    timings.readback += t.elapsed();
    Ok(result)
}

/// [`interpolate`] with the kernel replaced by its CPU twin in precision
/// `R` — what the GPU path should return, for parity tests, and an `f32`
/// emulation of it on machines without a GPU.
pub fn interpolate_twin<R: Real>(
    pairs: &[HermitePair],
    tol: f64,
) -> Vec<Result<ShortHelix, HelixError>> {
    interpolate(&Twin::<R>::new(), pairs, tol, &mut Timings::default())
        .expect("the twin cannot fail")
}

/// What the host keeps of a pair between pack and unpack: unit tangents and
/// Ghosh's basis, in `f64`.
struct HostSide {
    t0: DVec3,
    e1: DVec3,
    e2: DVec3,
}

/// The host's `f64` part: unit tangents, Ghosh's basis (zero where
/// undefined), and the kernel's record. `None` when the data is not usable
/// (non-finite, zero tangent), so that the reference produces the error.
fn host_side(pr: &HermitePair) -> Option<(HostSide, [f64; IN_STRIDE])> {
    let d = pr.p1 - pr.p0;
    let (l0, l1) = (pr.t0.length(), pr.t1.length());
    let ok =
        pr.p0.is_finite() && pr.p1.is_finite() && d.is_finite() && l0.is_normal() && l1.is_normal();
    if !ok {
        return None;
    }
    let (t0, t1) = (pr.t0 / l0, pr.t1 / l1);
    let (diff, sum) = (t1 - t0, t1 + t0);
    let (nd, ns) = (diff.length(), sum.length());
    let (mut e1, mut e2, mut de3) = (DVec3::ZERO, DVec3::ZERO, 0.0);
    if nd > twin::PARALLEL_EPS {
        de3 = d.dot(diff / nd);
        if ns > twin::PARALLEL_EPS {
            (e1, e2) = ghosh_basis(t0, t1, diff, sum, nd, ns);
        }
    }
    let rec = [d.length(), nd, ns, d.dot(e1), d.dot(e2), de3];
    Some((HostSide { t0, e1, e2 }, rec))
}

/// Pack one record in the kernel's precision (all zeros, which the kernel
/// reports as coincident points, when the host rejected the data).
fn pack<R: Real>(pr: &HermitePair, rec: &mut [R]) {
    match host_side(pr) {
        Some((_, r64)) if r64.iter().all(|x| R::from_f64(*x).is_finite()) => {
            for (o, x) in rec.iter_mut().zip(r64) {
                *o = R::from_f64(x);
            }
        }
        _ => rec.iter_mut().for_each(|x| *x = R::zero()),
    }
}

/// A kernel record back to the reference's types.
fn unpack<R: Real>(rec: &[R], pr: &HermitePair, tol: f64) -> Result<ShortHelix, HelixError> {
    let code = rec[twin::OUT_STATUS].to_f64() as u32;
    if code != status::OK {
        // Degenerate branches (straight, half circle) and rejections: the
        // reference takes them in O(1), decides borderline cases and words
        // the error.
        return pr.interpolate(tol);
    }
    let Some((host, _)) = host_side(pr) else {
        return pr.interpolate(tol);
    };
    let get = |i: usize| rec[i].to_f64();
    let axis = (get(twin::OUT_AXIS_E1) * host.e1 + get(twin::OUT_AXIS_E2) * host.e2).normalize();
    // κ̄ n₀ = Ω̄ × t₀ (paper, proof of (A.9)).
    let n = axis.cross(host.t0);
    let normal = (n - n.dot(host.t0) * host.t0).normalize();
    Ok(ShortHelix {
        element: HelixElement {
            start: pr.p0,
            tangent: host.t0,
            normal,
            curvature: get(twin::OUT_CURVATURE),
            torsion: get(twin::OUT_TORSION),
            length: get(twin::OUT_LENGTH),
        },
        phi: get(twin::OUT_PHI),
        axis,
        omega: get(twin::OUT_OMEGA),
        tau_bar: get(twin::OUT_TAU_BAR),
        chi: get(twin::OUT_CHI),
    })
}
