//! `shaders/frenet_integrate.wgsl` (twin: [`crate::twin::frenet_integrate`],
//! reference: [`crate::euler::FrenetProblem`]): 3D Euler spirals, one problem per
//! invocation.
//!
//! The host validates each problem ([`FrenetProblem::validate`]; an invalid
//! one gets its [`FrenetError`] and is not integrated), computes the scaled
//! rates `κ₀L, γL², τ₀L, δL²` in `f64`, and packs them with the start frame.
//! The kernel returns the offset `(x(L) − x₀)/L` and the end frame; the
//! host forms `x₀ + L·offset` in `f64`. Problems the kernel cannot take — a
//! step angle beyond [`STEP_ANGLE_MAX`], more than [`MAX_STEPS`] steps, or a
//! kernel status other than [`STATUS_OK`] — are integrated by the `f64`
//! reference with the same step count instead, so every answer is the
//! reference's up to the kernel's rounding.
//!
//! Two modes, one kernel: the configuration is the number of samples per
//! problem, prepended as `const SAMPLES` with `const OUT_STRIDE` — 0 is the
//! end mode ([`integrate`]), `m ≥ 1` the sampled mode ([`sample`], `m`
//! samples with their tangents); the GPU compiles each configuration on
//! first use and keeps it.
//!
//! Buffers: `rec_in`, per problem `k0, g, t0, d` (scaled rates), `T0.xyz,
//! N0.xyz, B0.xyz`; `rec_out`, end mode `status, offset.xyz / L, T.xyz,
//! N.xyz, B.xyz`, sampled mode `status`, then `SAMPLES ×` (`offset.xyz / L,
//! tangent.xyz`). `params.steps`: end mode the steps `N`, sampled mode the
//! steps per sample interval (an integer, exact in `f32` up to `2²⁴`).

use glam::DVec3;
use rayon::prelude::*;

use super::{
    by_precision, map, map_batch, map_bindings, map_twin, Batch, Binding, Data, Exec, GpuError,
    Kernel, MapKernel, Rng, Timings, Twin,
};
use crate::euler::{FrenetEnd, FrenetError, FrenetProblem};
use crate::twin::frenet_integrate::{
    self as twin, sampled_out_stride, IN_B0, IN_N0, IN_RATES, IN_STRIDE, IN_T0, MAX_STEPS,
    OUT_STRIDE, STATUS_OK, STEP_ANGLE_MAX,
};
use crate::twin::Real;

/// The kernel; its configuration is the number of samples (0: end mode).
pub struct FrenetIntegrate;

impl Kernel for FrenetIntegrate {
    const NAME: &'static str = "frenet_integrate";
    const WGSL: &'static str = include_str!("../../shaders/frenet_integrate.wgsl");
    const PARAMS: &'static [(&'static str, super::Field)] = crate::map_params!("steps");
    const BINDINGS: &'static [Binding] = &map_bindings("rec_in", "rec_out");
    const PARITY_EPS: f64 = 256.0;
    type Config = usize;

    fn constants<R: Real>(samples: usize) -> String {
        format!(
            "const SAMPLES: u32 = {samples}u;\nconst OUT_STRIDE: u32 = {}u;\n",
            Self::out_stride(samples)
        )
    }
    fn configs() -> Vec<usize> {
        vec![0, 4]
    }
    fn twin<R: Real>(cfg: usize, batch: &Batch<'_, R>, _: &[&Data<'_, R>]) -> Data<'static, R> {
        map_twin::<Self, R>(cfg, batch)
    }
    fn parity_batch<R: Real>(
        cfg: usize,
        rng: &mut Rng,
    ) -> (Batch<'static, R>, Vec<Data<'static, R>>) {
        let (steps, records) = Self::parity_records(cfg, rng);
        map_batch::<Self, R>(cfg, steps, &records)
    }
}

impl MapKernel for FrenetIntegrate {
    const IN_STRIDE: usize = IN_STRIDE;
    fn out_stride(samples: usize) -> usize {
        if samples == 0 {
            OUT_STRIDE
        } else {
            sampled_out_stride(samples)
        }
    }
    fn twin_record<R: Real>(samples: usize, steps: f32, rec: &[R], out: &mut [R]) {
        if samples == 0 {
            out.copy_from_slice(&twin::frenet_integrate(rec, steps as u32));
        } else {
            twin::frenet_sample(rec, samples, steps as u32, out);
        }
    }
    fn parity_records(_: usize, rng: &mut Rng) -> (f32, Vec<f64>) {
        let mut records = Vec::new();
        for _ in 0..300 {
            let t = rng.unit_vector();
            let n = t.any_orthonormal_vector();
            let p = FrenetProblem {
                start: DVec3::ZERO,
                frame: [t, n, t.cross(n)],
                length: rng.range(0.5, 3.0),
                kappa0: rng.range(-1.0, 1.0),
                gamma: rng.range(-1.0, 1.0),
                tau0: rng.range(-1.0, 1.0),
                delta: rng.range(-1.0, 1.0),
            };
            records.extend_from_slice(&record(&p));
        }
        (16.0, records)
    }
}

/// Points and unit tangents at `m` equally spaced arc lengths of one spiral.
pub type SpiralSamples = crate::sampled::SampledCurve;

fn from_reference(s: &[FrenetEnd]) -> SpiralSamples {
    SpiralSamples {
        points: s.iter().map(|e| e.point).collect(),
        tangents: s.iter().map(|e| e.frame[0]).collect(),
    }
}

/// Each problem's end point and frame after `steps` steps: what
/// [`FrenetProblem::integrate`]`(steps)` returns, up to the kernel's
/// rounding (the tolerance table of docs/reference.md).
pub fn integrate<E: Exec>(
    exec: &E,
    problems: &[FrenetProblem],
    steps: usize,
    timings: &mut Timings,
) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
    by_precision!(exec, integrate_in(exec, problems, steps, timings))
}

/// Each problem's `m` samples with `steps_per_interval` steps between
/// consecutive ones: the points and tangents of
/// [`FrenetProblem::sample`]`(m, steps_per_interval)`.
pub fn sample<E: Exec>(
    exec: &E,
    problems: &[FrenetProblem],
    m: usize,
    steps_per_interval: usize,
    timings: &mut Timings,
) -> Result<Vec<Result<SpiralSamples, FrenetError>>, GpuError> {
    by_precision!(
        exec,
        sample_in(exec, problems, m, steps_per_interval, timings)
    )
}

fn integrate_in<R: Real, E: Exec>(
    exec: &E,
    problems: &[FrenetProblem],
    steps: usize,
    timings: &mut Timings,
) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
    if steps == 0 {
        return Ok(vec![Err(FrenetError::ZeroSteps); problems.len()]);
    }
    let t = std::time::Instant::now();
    let plan = plan(problems, steps, steps);
    let mut out = vec![R::zero(); problems.len() * OUT_STRIDE];
    let input = pack_all::<R>(problems, &plan);
    timings.prepare += t.elapsed();
    if plan.contains(&Plan::Kernel) {
        map::<FrenetIntegrate, R, E>(exec, 0, steps as f32, &input, &mut out, timings)?;
    }
    let t = std::time::Instant::now();
    let result = problems
        .par_iter()
        .zip(plan.par_iter())
        .zip(out.par_chunks(OUT_STRIDE))
        .map(|((p, pl), o)| unpack_end(p, *pl, o, steps))
        .collect();
    timings.readback += t.elapsed();
    Ok(result)
}

fn sample_in<R: Real, E: Exec>(
    exec: &E,
    problems: &[FrenetProblem],
    m: usize,
    steps_per_interval: usize,
    timings: &mut Timings,
) -> Result<Vec<Result<SpiralSamples, FrenetError>>, GpuError> {
    if steps_per_interval == 0 {
        return Ok(vec![Err(FrenetError::ZeroSteps); problems.len()]);
    }
    if m == 0 {
        return Ok(problems
            .iter()
            .map(|p| p.validate().map(|()| SpiralSamples::default()))
            .collect());
    }
    let t = std::time::Instant::now();
    let total = (m - 1).saturating_mul(steps_per_interval);
    let plan = plan(problems, total, steps_per_interval);
    let stride = sampled_out_stride(m);
    let mut out = vec![R::zero(); problems.len() * stride];
    let input = pack_all::<R>(problems, &plan);
    timings.prepare += t.elapsed();
    if plan.contains(&Plan::Kernel) {
        let spi = steps_per_interval as f32;
        map::<FrenetIntegrate, R, E>(exec, m, spi, &input, &mut out, timings)?;
    }
    let t = std::time::Instant::now();
    let result = problems
        .par_iter()
        .zip(plan.par_iter())
        .zip(out.par_chunks(stride))
        .map(|((p, pl), o)| unpack_sampled(p, *pl, o, m, steps_per_interval))
        .collect();
    timings.readback += t.elapsed();
    Ok(result)
}

/// What becomes of one problem.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    Kernel,
    Reference,
    Invalid(FrenetError),
}

/// The kernel takes `p` at `steps` total steps, `per` per dispatch unit.
fn plan_one(p: &FrenetProblem, steps: usize, per: usize) -> Plan {
    match p.validate() {
        Err(e) => Plan::Invalid(e),
        Ok(()) if steps == 0 => Plan::Kernel, // m = 1: the start only
        Ok(()) if steps > MAX_STEPS || per > MAX_STEPS => Plan::Reference,
        Ok(()) if p.max_step_angle(steps) <= STEP_ANGLE_MAX => Plan::Kernel,
        Ok(()) => Plan::Reference,
    }
}

/// [`plan_one`] for every problem.
fn plan(problems: &[FrenetProblem], total: usize, per: usize) -> Vec<Plan> {
    problems
        .par_iter()
        .map(|p| plan_one(p, total, per))
        .collect()
}

/// The `f64` record of a problem.
pub fn record(p: &FrenetProblem) -> [f64; IN_STRIDE] {
    let mut rec = [0.0; IN_STRIDE];
    rec[IN_RATES..IN_RATES + 4].copy_from_slice(&p.rates());
    for (at, v) in [(IN_T0, 0), (IN_N0, 1), (IN_B0, 2)] {
        rec[at..at + 3].copy_from_slice(&p.frame[v].to_array());
    }
    rec
}

/// All records in `R`; zeros for problems the kernel does not take (it
/// integrates them harmlessly, the result is ignored).
fn pack_all<R: Real>(problems: &[FrenetProblem], plan: &[Plan]) -> Vec<R> {
    let mut input = vec![R::zero(); problems.len() * IN_STRIDE];
    input
        .par_chunks_mut(IN_STRIDE)
        .zip(problems.par_iter().zip(plan.par_iter()))
        .for_each(|(rec, (p, pl))| {
            if *pl == Plan::Kernel {
                for (o, x) in rec.iter_mut().zip(record(p)) {
                    *o = R::from_f64(x);
                }
            }
        });
    input
}

fn get<R: Real>(o: &[R], at: usize) -> DVec3 {
    DVec3::new(o[at].to_f64(), o[at + 1].to_f64(), o[at + 2].to_f64())
}

fn unpack_end<R: Real>(
    p: &FrenetProblem,
    plan: Plan,
    o: &[R],
    steps: usize,
) -> Result<FrenetEnd, FrenetError> {
    match plan {
        Plan::Invalid(e) => Err(e),
        Plan::Kernel if o[twin::OUT_STATUS].to_f64() == STATUS_OK => Ok(FrenetEnd {
            point: p.start + p.length * get(o, twin::OUT_OFFSET),
            frame: [
                get(o, twin::OUT_T),
                get(o, twin::OUT_N),
                get(o, twin::OUT_B),
            ],
        }),
        _ => Ok(p.integrate_unchecked(steps)),
    }
}

fn unpack_sampled<R: Real>(
    p: &FrenetProblem,
    plan: Plan,
    o: &[R],
    m: usize,
    steps_per_interval: usize,
) -> Result<SpiralSamples, FrenetError> {
    match plan {
        Plan::Invalid(e) => Err(e),
        Plan::Kernel if o[twin::OUT_STATUS].to_f64() == STATUS_OK => {
            let (points, tangents) = (0..m)
                .map(|j| {
                    let at = twin::OUT_SAMPLES + twin::SAMPLE_STRIDE * j;
                    (
                        p.start + p.length * get(o, at + twin::SAMPLE_OFFSET),
                        get(o, at + twin::SAMPLE_TANGENT),
                    )
                })
                .unzip();
            Ok(SpiralSamples { points, tangents })
        }
        _ => Ok(from_reference(&p.sample_unchecked(m, steps_per_interval))),
    }
}

/// [`integrate`] with the kernel replaced by its CPU twin in precision
/// `R`: what the GPU path should return, for parity tests, and an emulation
/// of it without a GPU.
pub fn integrate_twin<R: Real>(
    problems: &[FrenetProblem],
    steps: usize,
) -> Vec<Result<FrenetEnd, FrenetError>> {
    integrate(&Twin::<R>::new(), problems, steps, &mut Timings::default())
        .expect("the twin cannot fail")
}

/// [`sample`] with the kernel replaced by its twin in `R`.
pub fn sample_twin<R: Real>(
    problems: &[FrenetProblem],
    m: usize,
    steps_per_interval: usize,
) -> Vec<Result<SpiralSamples, FrenetError>> {
    sample(
        &Twin::<R>::new(),
        problems,
        m,
        steps_per_interval,
        &mut Timings::default(),
    )
    .expect("the twin cannot fail")
}
