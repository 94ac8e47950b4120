//! `shaders/atph_hermite.wgsl` (twin: [`crate::twin::atph_hermite`]):
//! ATPH G1 Hermite interpolation for a batch of pairs.
//!
//! The host builds each pair's tangent field in `f64` with the reference's
//! code ([`crate::atph::tangent_field`]: branch rules, poles, equal
//! tangents) and checks the ends and length ([`crate::atph::check_ends`]).
//! Spatial fields go to the kernel as the unit problem; planar and constant
//! fields (a 2×2 or 1×1 system in the plane or along the line) are solved
//! by the `f64` reference on the host. The kernel's `ρ` is scaled back by
//! `|P₂ − P₁|`.
//!
//! **Trust.** The solve's error is about `ε Σ|ρ| / rel_det` (`rel_det`:
//! `|det|` over the product of the column norms; the system's condition).
//! A kernel answer is kept only where `rel_det ≥` [`trust_threshold`]
//! `= max(4·SINGULAR_TOL, 64ε)`: the relative error of `ρ` then stays below
//! 1/64 even in `f32`, and the kernel's `rel_det` is accurate enough that
//! it cannot be on the wrong side of the reference's singularity test.
//! Below it the pair is solved by the `f64` reference on the host, which
//! decides (singular, or the reference answer). So the GPU backend reports
//! exactly the reference's successes and errors; the parity tests check
//! that, and bound `ρ`'s differences by the conditioning.
//!
//! Buffers: `rec_in`, per pair `a0, a1, b0, b1, chord.xyz / |chord|,
//! L / |chord|` (0: none); `rec_out`, `ρ0..ρ3` (unit problem; `ρ3 = 0` for
//! the quadratic), `|det| / Π|col|`.

use glam::DVec3;
use rayon::prelude::*;

use super::{by_precision, map, Exec, GpuError, MapKernel, Rng, Timings, Twin};
use crate::atph::{
    check_ends, interpolate_field, tangent_field, AtphCurve, AtphError, Bernstein, FieldKind,
    HermitePair, SphericalTangent, SINGULAR_TOL,
};
use crate::twin::atph_hermite::{self as twin, IN_STRIDE, OUT_REL_DET, OUT_STRIDE};
use crate::twin::Real;

crate::map_kernel! {
    /// The kernel.
    AtphHermite {
        name: "atph_hermite",
        scalar: "unused",
        buffers: ("rec_in", "rec_out"),
        parity_eps: 4096.0,
    }
}

impl MapKernel for AtphHermite {
    const IN_STRIDE: usize = IN_STRIDE;
    fn out_stride(_: ()) -> usize {
        OUT_STRIDE
    }
    fn twin_record<R: Real>(_: (), _: f32, rec: &[R], out: &mut [R]) {
        out.copy_from_slice(&twin::atph_hermite(rec));
    }
    fn parity_records(_: (), rng: &mut Rng) -> (f32, Vec<f64>) {
        let mut records = Vec::new();
        for k in 0..500 {
            let p1 = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let p2 = p1 + rng.range(0.5, 2.0) * rng.unit_vector();
            let length = (k % 2 == 1).then(|| (p2 - p1).length() * rng.range(1.1, 1.6));
            if let Prepared::Kernel { record, .. } = prepare(
                &HermitePair::new(p1, rng.unit_vector(), p2, rng.unit_vector()),
                length,
            ) {
                // Well-conditioned systems only: the twin's and the GPU's
                // rounding are amplified by 1/rel_det.
                if twin::atph_hermite(&record)[OUT_REL_DET] > 0.05 {
                    records.extend_from_slice(&record);
                }
            }
        }
        (0.0, records)
    }
}

/// One pair after the host's part: the kernel's record, or a finished
/// answer (reference or error).
enum Prepared {
    Kernel {
        p1: DVec3,
        p2: DVec3,
        field: SphericalTangent,
        chord: f64,
        length: Option<f64>,
        record: [f64; IN_STRIDE],
    },
    Done(Result<AtphCurve, AtphError>),
}

fn prepare(pair: &HermitePair, length: Option<f64>) -> Prepared {
    let (p1, t1, p2, t2) = (*pair).into();
    let field = match tangent_field(p1, t1, p2, t2) {
        Ok(f) => f,
        Err(e) => return Prepared::Done(Err(e)),
    };
    let chord = match check_ends(p1, p2, length) {
        Ok(c) => c,
        Err(e) => return Prepared::Done(Err(e)),
    };
    if field.kind() != FieldKind::Spatial {
        return Prepared::Done(interpolate_field(p1, p2, field, length));
    }
    let u = (p2 - p1) / chord;
    let record = [
        field.a0,
        field.a1,
        field.b0,
        field.b1,
        u.x,
        u.y,
        u.z,
        length.map_or(0.0, |l| l / chord),
    ];
    Prepared::Kernel {
        p1,
        p2,
        field,
        chord,
        length,
        record,
    }
}

/// Smallest kernel `rel_det` whose answer is kept (see the module docs).
pub fn trust_threshold<R: Real>() -> f64 {
    (4.0 * SINGULAR_TOL).max(64.0 * R::EPSILON.to_f64())
}

/// The kernel's output for one pair back to a curve (or the reference's
/// error), in `f64`.
fn finish<R: Real>(prep: Prepared, out: &[R]) -> Result<AtphCurve, AtphError> {
    match prep {
        Prepared::Done(r) => r,
        Prepared::Kernel {
            p1,
            p2,
            field,
            chord,
            length,
            ..
        } => {
            let rel = out[OUT_REL_DET].to_f64();
            let n = if length.is_some() { 4 } else { 3 };
            let rho: Vec<f64> = out[..n].iter().map(|v| v.to_f64() * chord).collect();
            if !(rel >= trust_threshold::<R>()) || !rho.iter().all(|v| v.is_finite()) {
                return interpolate_field(p1, p2, field, length);
            }
            Ok(AtphCurve {
                start: p1,
                tangent: field,
                rho: Bernstein::new(&rho),
            })
        }
    }
}

/// [`crate::atph::interpolate_pairs`] with the spatial solves on `exec`.
pub fn interpolate<E: Exec>(
    exec: &E,
    pairs: &[HermitePair],
    lengths: Option<&[Option<f64>]>,
    timings: &mut Timings,
) -> Result<Vec<Result<AtphCurve, AtphError>>, GpuError> {
    by_precision!(exec, interpolate_in(exec, pairs, lengths, timings))
}

fn interpolate_in<R: Real, E: Exec>(
    exec: &E,
    pairs: &[HermitePair],
    lengths: Option<&[Option<f64>]>,
    timings: &mut Timings,
) -> Result<Vec<Result<AtphCurve, AtphError>>, GpuError> {
    let t = std::time::Instant::now();
    let prepared: Vec<Prepared> = pairs
        .par_iter()
        .enumerate()
        .map(|(i, p)| prepare(p, lengths.and_then(|l| l.get(i).copied().flatten())))
        .collect();
    let slots: Vec<usize> = prepared
        .iter()
        .enumerate()
        .filter(|(_, p)| matches!(p, Prepared::Kernel { .. }))
        .map(|(i, _)| i)
        .collect();
    let mut input = vec![R::zero(); slots.len() * IN_STRIDE];
    input
        .par_chunks_mut(IN_STRIDE)
        .zip(slots.par_iter())
        .for_each(|(rec, &i)| {
            if let Prepared::Kernel { record, .. } = &prepared[i] {
                for (o, x) in rec.iter_mut().zip(record) {
                    *o = R::from_f64(*x);
                }
            }
        });
    let mut out = vec![R::zero(); slots.len() * OUT_STRIDE];
    timings.prepare += t.elapsed();
    map::<AtphHermite, R, E>(exec, (), 0.0, &input, &mut out, timings)?;
    let t = std::time::Instant::now();
    let mut next = 0usize;
    let outputs: Vec<&[R]> = prepared
        .iter()
        .map(|p| match p {
            Prepared::Kernel { .. } => {
                next += 1;
                &out[(next - 1) * OUT_STRIDE..next * OUT_STRIDE]
            }
            Prepared::Done(_) => &out[..0],
        })
        .collect();
    let result = prepared
        .into_par_iter()
        .zip(outputs)
        .map(|(p, o)| finish(p, o))
        .collect();
    timings.readback += t.elapsed();
    Ok(result)
}

/// [`interpolate`] with the kernel replaced by its CPU twin in precision
/// `R` (parity tests; an emulation without a GPU).
pub fn interpolate_twin<R: Real>(
    pairs: &[HermitePair],
    lengths: Option<&[Option<f64>]>,
) -> Vec<Result<AtphCurve, AtphError>> {
    interpolate(&Twin::<R>::new(), pairs, lengths, &mut Timings::default())
        .expect("the twin cannot fail")
}

/// `rel_det` of a pair's spatial system (3.1)/(4.1) in `f64` (the twin), the
/// conditioning that bounds every backend's error in `ρ`; `None` for pairs
/// that are not solved by the kernel (errors, planar or constant fields).
pub fn condition(pair: &HermitePair, length: Option<f64>) -> Option<f64> {
    match prepare(pair, length) {
        Prepared::Kernel { record, .. } => Some(twin::atph_hermite(&record)[OUT_REL_DET]),
        Prepared::Done(_) => None,
    }
}
