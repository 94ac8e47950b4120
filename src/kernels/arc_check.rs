//! `shaders/arc_check.wgsl` (twin: [`crate::twin::arc_check`]): the codec's
//! acceptance test for many candidate arcs at once.
//!
//! A block's input points are uploaded once ([`ArcChecker::open`], a
//! resident buffer); each round of the block's search then uploads only its
//! candidates (16 reals and 8 indices each) and reads back one verdict per
//! candidate. The band around the tolerance is computed here, on the host,
//! in `f64` ([`crate::twin::arc_check::band`]) for the kernel's precision,
//! so that `f32` kernels give sure verdicts as often as their precision
//! allows and never a wrong one.
//!
//! Buffers: `rec_in`, per candidate `start.xyz, tangent.xyz, normal.xyz,
//! end.xyz, κ, step, tol²_lo, tol²_hi`; `idx_in`, per candidate `pieces,
//! cover_first, cover_last, window_first, window_last` and 3 unused;
//! `points` (resident), `xyz` per input point relative to its curve's
//! origin; `verdicts`, one `u32` per candidate.

use std::borrow::Cow;
use std::marker::PhantomData;

use glam::DVec3;

use super::{
    binding, Access, Batch, Binding, Data, Elem, Exec, GpuError, Kernel, Precision, Rng, Timings,
    Twin,
};
use crate::codec::{ArcCandidate, ArcCheckBlock, ArcChecker, Verdict};
use crate::twin::arc_check::{self as twin, IDX_STRIDE, IN_STRIDE};
use crate::twin::Real;

/// The kernel.
pub struct ArcCheck;

impl Kernel for ArcCheck {
    const NAME: &'static str = "arc_check";
    const WGSL: &'static str = include_str!("../../shaders/arc_check.wgsl");
    const PARAMS: &'static [(&'static str, super::Field)] = crate::map_params!("unused");
    const BINDINGS: &'static [Binding] = &[
        binding("rec_in", Elem::Real, Access::Input),
        binding("idx_in", Elem::U32, Access::Input),
        binding("points", Elem::Real, Access::Resident),
        binding("verdicts", Elem::U32, Access::Output),
    ];
    const PARITY_EPS: f64 = 0.0;
    type Config = ();

    fn configs() -> Vec<()> {
        vec![()]
    }
    fn twin<R: Real>(_: (), batch: &Batch<'_, R>, resident: &[&Data<'_, R>]) -> Data<'static, R> {
        let (rec, idx, points) = (
            batch.inputs[0].reals(),
            batch.inputs[1].u32s(),
            resident[0].reals(),
        );
        let verdicts = rec
            .chunks(IN_STRIDE)
            .zip(idx.chunks(IDX_STRIDE))
            .map(|(r, i)| twin::arc_check(r, i, points))
            .collect();
        Data::U32(Cow::Owned(verdicts))
    }
    fn parity_batch<R: Real>(_: (), rng: &mut Rng) -> (Batch<'static, R>, Vec<Data<'static, R>>) {
        // Points on a circle of radius 1/κ; candidates along it, off it
        // by a random amount, with tolerances at random scales — verdicts
        // of every kind, far enough from the band's edges.
        let kappa = 0.3;
        let step = 0.25;
        let points: Vec<DVec3> = (0..400)
            .map(|k| {
                let a = kappa * step * k as f64;
                DVec3::new(
                    a.sin() / kappa,
                    (1.0 - a.cos()) / kappa,
                    0.01 * (k % 3) as f64,
                )
            })
            .collect();
        let mut candidates = Vec::new();
        for _ in 0..300 {
            let first = (rng.range(0.0, 350.0)) as u32;
            let last = first + 2 + (rng.range(0.0, 40.0) as u32).min(398 - first);
            let a = kappa * step * first as f64;
            let start = points[first as usize] + 0.01 * rng.unit_vector();
            let length = step * (last - first) as f64 * rng.range(0.97, 1.03);
            let tangent = DVec3::new(a.cos(), a.sin(), 0.0);
            let normal = DVec3::new(-a.sin(), a.cos(), 0.0);
            let k = kappa * rng.range(0.9, 1.1);
            let b = k * length;
            let end = start + (b.sin() * tangent + (1.0 - b.cos()) * normal) / k;
            let pieces = 1 + (rng.range(0.0, 16.0) as u32);
            let tol = [0.005, 0.05, 0.2][candidates.len() % 3];
            candidates.push(ArcCandidate {
                start,
                tangent,
                normal,
                end,
                curvature: k,
                step: length / pieces as f64,
                length,
                pieces,
                cover: (first + 1, last - 1),
                window: (first, last),
                tol2: tol * tol,
                radius: 40.0,
                origin_scale: 0.0,
            });
        }
        let (batch, _) = batch::<R>(&candidates);
        (batch, vec![Data::Real(Cow::Owned(flat(&points)))])
    }
}

/// The kernel's records of one candidate in precision `R`.
pub fn pack<R: Real>(c: &ArcCandidate) -> ([R; IN_STRIDE], [u32; IDX_STRIDE]) {
    let tol = c.tol2.sqrt();
    let eta = twin::band::<R>(tol, c.radius, c.length, c.pieces as usize)
        + 64.0 * f64::EPSILON * c.origin_scale * (tol + c.origin_scale * f64::EPSILON);
    let v = |x: DVec3| [x.x, x.y, x.z];
    let mut rec = [R::zero(); IN_STRIDE];
    let reals = [
        v(c.start),
        v(c.tangent),
        v(c.normal),
        v(c.end),
        [c.curvature, c.step, c.tol2 - eta],
    ];
    for (o, x) in rec.iter_mut().zip(reals.iter().flatten()) {
        *o = R::from_f64(*x);
    }
    // Rounding `tol² ± η` into R must not narrow the band.
    rec[twin::IN_TOL_LO] = R::from_f64((c.tol2 - eta) * (1.0 - 2.0 * R::EPSILON.to_f64()));
    rec[twin::IN_TOL_HI] = R::from_f64((c.tol2 + eta) * (1.0 + 2.0 * R::EPSILON.to_f64()));
    let mut idx = [0u32; IDX_STRIDE];
    idx[twin::IDX_PIECES] = c.pieces;
    idx[twin::IDX_COVER_FIRST] = c.cover.0;
    idx[twin::IDX_COVER_LAST] = c.cover.1;
    idx[twin::IDX_WINDOW_FIRST] = c.window.0;
    idx[twin::IDX_WINDOW_LAST] = c.window.1;
    (rec, idx)
}

/// Whether a candidate can be checked in `R` (others are answered
/// unsure): its records finite after the conversion; no squared length the
/// kernel forms (at most `(2(radius + length))²`) overflowing; `tol²`
/// comfortably in `R`'s normal range, so that no squared distance near it
/// is flushed to zero.
fn fits<R: Real>(rec: &[R], c: &ArcCandidate) -> bool {
    let max = R::from_f64(f64::MAX).to_f64();
    let min_normal = if std::mem::size_of::<R>() == 4 {
        f32::MIN_POSITIVE as f64
    } else {
        f64::MIN_POSITIVE
    };
    let span = c.radius + c.length;
    rec.iter().all(|x| x.is_finite()) && 16.0 * span * span < max && c.tol2 > 1e6 * min_normal
}

fn verdict(v: u32) -> Verdict {
    match v {
        twin::PASS => Verdict::Pass,
        twin::FAIL => Verdict::Fail,
        _ => Verdict::Unsure,
    }
}

/// Points in the kernel's precision, `xyz` flat.
fn flat<R: Real>(points: &[DVec3]) -> Vec<R> {
    points
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .map(R::from_f64)
        .collect()
}

/// The batch of one round: candidates the kernel cannot take get a
/// harmless record (no covered vertex, a one-point window) and `false`.
fn batch<R: Real>(candidates: &[ArcCandidate]) -> (Batch<'static, R>, Vec<bool>) {
    let n = candidates.len();
    let mut rec = vec![R::zero(); n * IN_STRIDE];
    let mut idx = vec![0u32; n * IDX_STRIDE];
    let mut usable = vec![true; n];
    for (k, c) in candidates.iter().enumerate() {
        let (r, i) = pack::<R>(c);
        usable[k] = fits(&r, c);
        if usable[k] {
            rec[k * IN_STRIDE..(k + 1) * IN_STRIDE].copy_from_slice(&r);
            idx[k * IDX_STRIDE..(k + 1) * IDX_STRIDE].copy_from_slice(&i);
        } else {
            idx[k * IDX_STRIDE + twin::IDX_COVER_FIRST] = 1;
        }
    }
    let batch = Batch {
        counts: vec![n],
        scalars: vec![0.0],
        inputs: vec![Data::Real(Cow::Owned(rec)), Data::U32(Cow::Owned(idx))],
        scratch: Vec::new(),
        out_len: n,
    };
    (batch, usable)
}

/// The kernel on an executor as the codec's [`ArcChecker`]: what the GPU
/// backend hands the codec ([`crate::gpu::Gpu`]), or its twin
/// ([`TwinArcChecker`]).
pub struct ArcCheckOn<E>(pub E);

/// The kernel's CPU twin in precision `R` as an [`ArcChecker`]: what the
/// GPU backend should do, without a GPU (tests, emulation).
pub type TwinArcChecker<R> = ArcCheckOn<Twin<R>>;

impl<R: Real> Default for ArcCheckOn<Twin<R>> {
    fn default() -> Self {
        ArcCheckOn(Twin::new())
    }
}

/// One block's points on the executor.
struct Block<'e, E: Exec, R: Real> {
    exec: &'e E,
    points: E::Resident<R>,
    _r: PhantomData<R>,
}

impl<E: Exec> ArcCheckOn<E> {
    fn open_in<R: Real>(&self, points: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, GpuError> {
        if points.len() >= u32::MAX as usize {
            return Err(GpuError::Execution(format!(
                "arc_check: {} points do not fit one binding",
                points.len()
            )));
        }
        let points = self.0.resident(Data::Real(Cow::Owned(flat::<R>(points))))?;
        Ok(Box::new(Block::<E, R> {
            exec: &self.0,
            points,
            _r: PhantomData,
        }))
    }
}

impl<E: Exec> ArcChecker for ArcCheckOn<E> {
    fn open(&self, points: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String> {
        match self.0.precision() {
            Precision::F32 => self.open_in::<f32>(points),
            Precision::F64 => self.open_in::<f64>(points),
        }
        .map_err(|e| e.to_string())
    }
}

impl<E: Exec, R: Real> ArcCheckBlock for Block<'_, E, R> {
    fn verdicts(&mut self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, String> {
        if candidates.is_empty() {
            return Ok(Vec::new());
        }
        let (batch, usable) = batch::<R>(candidates);
        let mut verdicts = Vec::new();
        self.exec
            .run::<ArcCheck, R>(
                (),
                &[&self.points],
                &mut std::iter::once(batch),
                &mut |_, out| {
                    verdicts = out
                        .u32s()
                        .iter()
                        .zip(&usable)
                        .map(|(&v, &ok)| if ok { verdict(v) } else { Verdict::Unsure })
                        .collect();
                },
                &mut Timings::default(),
            )
            .map_err(|e| e.to_string())?;
        Ok(verdicts)
    }
}

/// The verdicts of the twin on `candidates` over flat `points` (in `R`).
pub fn verdicts_twin<R: Real>(points: &[R], candidates: &[ArcCandidate]) -> Vec<Verdict> {
    candidates
        .iter()
        .map(|c| {
            let (rec, idx) = pack::<R>(c);
            if fits(&rec, c) {
                verdict(twin::arc_check(&rec, &idx, points))
            } else {
                Verdict::Unsure
            }
        })
        .collect()
}
