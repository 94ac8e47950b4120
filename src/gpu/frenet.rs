//! Driver of `shaders/frenet_integrate.wgsl` (twin:
//! [`crate::twin::frenet_integrate`], reference: [`crate::euler::frenet`]):
//! 3D Euler spirals integrated on the GPU, one problem per invocation.
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
//! Two modes, two pipelines from the same shader: the end mode
//! ([`FrenetGpu::integrate`], `SAMPLES = 0`) and the sampled mode
//! ([`FrenetGpu::sample`], `m` samples per problem with their tangents,
//! compiled on first use for each `m` and kept).

use std::sync::{Arc, Mutex};

use glam::DVec3;

use super::dispatch::{MapKernel, Timings};
use super::{GpuContext, GpuError, Precision};
use crate::euler::{FrenetEnd, FrenetError, FrenetProblem};
use crate::twin::frenet_integrate::{
    self as twin, sampled_out_stride, IN_B0, IN_N0, IN_RATES, IN_STRIDE, IN_T0, MAX_STEPS,
    OUT_STRIDE, STATUS_OK, STEP_ANGLE_MAX,
};
use crate::twin::Real;

/// `shaders/frenet_integrate.wgsl` (without the `SAMPLES`/`OUT_STRIDE`
/// constants the driver prepends).
pub const FRENET_INTEGRATE_WGSL: &str = include_str!("../../shaders/frenet_integrate.wgsl");

/// The kernel body for `samples` samples per problem (0: end mode).
pub fn kernel_body(samples: usize) -> String {
    let stride = if samples == 0 {
        OUT_STRIDE
    } else {
        sampled_out_stride(samples)
    };
    format!(
        "const SAMPLES: u32 = {samples}u;\nconst OUT_STRIDE: u32 = {stride}u;\n{FRENET_INTEGRATE_WGSL}"
    )
}

/// Points and unit tangents at `m` equally spaced arc lengths of one spiral.
pub type SpiralSamples = crate::sampled::SampledCurve;

fn from_reference(s: &[FrenetEnd]) -> SpiralSamples {
    SpiralSamples {
        points: s.iter().map(|e| e.point).collect(),
        tangents: s.iter().map(|e| e.frame[0]).collect(),
    }
}

/// The compiled kernel in one precision.
pub struct FrenetGpu {
    end: MapKernel,
    sampled: Mutex<Vec<(usize, Arc<MapKernel>)>>,
    precision: Precision,
}

impl FrenetGpu {
    pub fn new(ctx: &GpuContext, precision: Precision) -> Result<Self, GpuError> {
        let end = MapKernel::for_precision(
            ctx,
            precision,
            "frenet_integrate",
            &kernel_body(0),
            IN_STRIDE,
            OUT_STRIDE,
        )?;
        Ok(FrenetGpu {
            end,
            sampled: Mutex::new(Vec::new()),
            precision,
        })
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The sampled-mode pipeline for `m ≥ 1` samples (compiled once).
    fn sampled_kernel(&self, ctx: &GpuContext, m: usize) -> Result<Arc<MapKernel>, GpuError> {
        let mut cache = self.sampled.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, k)) = cache.iter().find(|(n, _)| *n == m) {
            return Ok(k.clone());
        }
        let k = Arc::new(MapKernel::for_precision(
            ctx,
            self.precision,
            "frenet_sample",
            &kernel_body(m),
            IN_STRIDE,
            sampled_out_stride(m),
        )?);
        cache.push((m, k.clone()));
        Ok(k)
    }

    /// End mode on raw records (layout of [`crate::twin::frenet_integrate`]),
    /// `1 ≤ steps ≤ MAX_STEPS`. `R` must match the kernel's precision.
    pub fn run_raw<R: Real>(
        &self,
        ctx: &GpuContext,
        input: &[R],
        steps: usize,
        out: &mut [R],
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        assert_eq!(R::WGSL, self.precision.name(), "record precision");
        assert!((1..=MAX_STEPS).contains(&steps), "steps {steps}");
        self.end.run(ctx, input, steps as f32, out, timings)
    }

    /// Sampled mode on raw records: `out` holds
    /// [`sampled_out_stride`]`(m)` reals per record, `m ≥ 1`,
    /// `1 ≤ steps_per_interval`, `(m − 1)·steps_per_interval ≤ MAX_STEPS`.
    pub fn run_raw_sampled<R: Real>(
        &self,
        ctx: &GpuContext,
        input: &[R],
        m: usize,
        steps_per_interval: usize,
        out: &mut [R],
        timings: &mut Timings,
    ) -> Result<(), GpuError> {
        assert_eq!(R::WGSL, self.precision.name(), "record precision");
        assert!(m >= 1 && (1..=MAX_STEPS).contains(&steps_per_interval));
        assert!((m - 1) * steps_per_interval <= MAX_STEPS);
        let k = self.sampled_kernel(ctx, m)?;
        k.run(ctx, input, steps_per_interval as f32, out, timings)
    }

    /// Each problem's end point and frame after `steps` steps: what
    /// [`FrenetProblem::integrate`]`(steps)` returns, up to the kernel's
    /// rounding (the tolerance table of docs/reference.md).
    pub fn integrate(
        &self,
        ctx: &GpuContext,
        problems: &[FrenetProblem],
        steps: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
        match self.precision {
            Precision::F32 => self.integrate_in::<f32>(ctx, problems, steps, timings),
            Precision::F64 => self.integrate_in::<f64>(ctx, problems, steps, timings),
        }
    }

    /// Each problem's `m` samples with `steps_per_interval` steps between
    /// consecutive ones: the points and tangents of
    /// [`FrenetProblem::sample`]`(m, steps_per_interval)`.
    pub fn sample(
        &self,
        ctx: &GpuContext,
        problems: &[FrenetProblem],
        m: usize,
        steps_per_interval: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Result<SpiralSamples, FrenetError>>, GpuError> {
        match self.precision {
            Precision::F32 => self.sample_in::<f32>(ctx, problems, m, steps_per_interval, timings),
            Precision::F64 => self.sample_in::<f64>(ctx, problems, m, steps_per_interval, timings),
        }
    }

    fn integrate_in<R: Real>(
        &self,
        ctx: &GpuContext,
        problems: &[FrenetProblem],
        steps: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
        use rayon::prelude::*;
        if steps == 0 {
            return Ok(vec![Err(FrenetError::ZeroSteps); problems.len()]);
        }
        let t = std::time::Instant::now();
        let plan = plan(problems, steps, steps);
        let mut out = vec![R::zero(); problems.len() * OUT_STRIDE];
        let input = pack_all::<R>(problems, &plan);
        timings.prepare += t.elapsed();
        if plan.contains(&Plan::Kernel) {
            self.end.run(ctx, &input, steps as f32, &mut out, timings)?;
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

    fn sample_in<R: Real>(
        &self,
        ctx: &GpuContext,
        problems: &[FrenetProblem],
        m: usize,
        steps_per_interval: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Result<SpiralSamples, FrenetError>>, GpuError> {
        use rayon::prelude::*;
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
            let k = self.sampled_kernel(ctx, m)?;
            k.run(ctx, &input, steps_per_interval as f32, &mut out, timings)?;
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
    use rayon::prelude::*;
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
    use rayon::prelude::*;
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

/// The same computation as [`FrenetGpu::integrate`] with the kernel replaced
/// by its CPU twin in precision `R`: what the GPU path should return, for
/// parity tests, and an emulation of it without a GPU.
pub fn integrate_twin<R: Real>(
    problems: &[FrenetProblem],
    steps: usize,
) -> Vec<Result<FrenetEnd, FrenetError>> {
    use rayon::prelude::*;
    if steps == 0 {
        return vec![Err(FrenetError::ZeroSteps); problems.len()];
    }
    let plan = plan(problems, steps, steps);
    problems
        .par_iter()
        .zip(plan.par_iter())
        .map(|(p, pl)| {
            let mut rec = [R::zero(); IN_STRIDE];
            if *pl == Plan::Kernel {
                for (o, x) in rec.iter_mut().zip(record(p)) {
                    *o = R::from_f64(x);
                }
            }
            let o = twin::frenet_integrate(&rec, steps as u32);
            unpack_end(p, *pl, &o, steps)
        })
        .collect()
}

/// [`FrenetGpu::sample`] with the kernel replaced by its twin in `R`.
pub fn sample_twin<R: Real>(
    problems: &[FrenetProblem],
    m: usize,
    steps_per_interval: usize,
) -> Vec<Result<SpiralSamples, FrenetError>> {
    use rayon::prelude::*;
    if steps_per_interval == 0 {
        return vec![Err(FrenetError::ZeroSteps); problems.len()];
    }
    if m == 0 {
        return problems
            .iter()
            .map(|p| p.validate().map(|()| SpiralSamples::default()))
            .collect();
    }
    let total = (m - 1).saturating_mul(steps_per_interval);
    let plan = plan(problems, total, steps_per_interval);
    problems
        .par_iter()
        .zip(plan.par_iter())
        .map(|(p, pl)| {
            let mut rec = [R::zero(); IN_STRIDE];
            let mut o = vec![R::zero(); sampled_out_stride(m)];
            if *pl == Plan::Kernel {
                for (o, x) in rec.iter_mut().zip(record(p)) {
                    *o = R::from_f64(x);
                }
                twin::frenet_sample(&rec, m, steps_per_interval as u32, &mut o);
            }
            unpack_sampled(p, *pl, &o, m, steps_per_interval)
        })
        .collect()
}
