//! The `Backend` seam; what runs where is described on `Backend`.

use rayon::prelude::*;

use crate::euler::{FrenetEnd, FrenetError, FrenetProblem};
use crate::fit::{fit_splines, relaxed_pairs, FitError, FitOptions, FitScratch};
use crate::gpu::{Gpu, GpuContext, Precision};
use crate::helix::{HelixError, HermitePair, PiecewiseHelix, ShortHelix};
use crate::kernels::arc_check::ArcCheckOn;
use crate::kernels::frenet_integrate::SpiralSamples;
use crate::kernels::{
    atph_hermite, frenet_integrate, ghosh_bisect, helix_eval, spline_sample, Timings,
};
use crate::spline::BezierSpline;

/// Why the GPU backend is unavailable or failed.
pub use crate::kernels::GpuError;

/// Points with their unit tangents along one curve (what `sample` and
/// `evaluate` return per curve).
pub type Samples = crate::sampled::SampledCurve;

/// What the user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// The `f64` reference on all cores.
    Cpu,
    /// The GPU; an error if none can be opened.
    Gpu,
    /// The GPU if an adapter exists, else the CPU (reported on stderr).
    #[default]
    Auto,
}

/// Kernel precision on the GPU backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PrecisionChoice {
    /// `f64` where the adapter offers `SHADER_F64`, else `f32`.
    #[default]
    Auto,
    /// `f32` kernels.
    F32,
    /// `f64` kernels (needs `SHADER_F64`).
    F64,
}

/// An opened GPU and the precision its kernels run in (each kernel is
/// compiled on first use and kept by the context).
pub struct GpuEngine {
    /// The GPU context (device, queue, pipeline cache).
    pub ctx: GpuContext,
    /// The precision the kernels run in.
    pub precision: Precision,
}

impl GpuEngine {
    /// Open the engine on `ctx` with the chosen precision (an error if `F64` is asked for and the adapter lacks it).
    ///
    /// Plumbing, not part of the public API: `ctx` is a type of the hidden
    /// `gpu` module. A program opens the GPU with [`Backend::open`].
    #[doc(hidden)]
    pub fn new(ctx: GpuContext, precision: PrecisionChoice) -> Result<Self, GpuError> {
        let precision = match precision {
            PrecisionChoice::Auto => ctx.best_precision(),
            PrecisionChoice::F32 => Precision::F32,
            PrecisionChoice::F64 => Precision::F64,
        };
        ctx.exec(precision)?;
        Ok(GpuEngine { ctx, precision })
    }

    /// The executor the kernels run on.
    ///
    /// Plumbing for the GPU kernels (a type of the hidden `gpu` module), not
    /// part of the public API.
    #[doc(hidden)]
    pub fn exec(&self) -> Gpu<'_> {
        self.ctx.exec(self.precision).expect("checked when opened")
    }
}

/// A resolved backend.
///
/// Every batch operation goes through one choice of engine — the `f64` CPU
/// reference (rayon) or the GPU (wgpu kernels, each checked against a CPU
/// twin).
///
/// [`BackendChoice::Auto`] opens the GPU when an adapter exists and falls back
/// to the CPU otherwise ([`Backend::open_explained`] says which). What runs
/// where on the GPU backend:
///
/// | operation     | GPU backend                                   |
/// |---------------|-----------------------------------------------|
/// | `interpolate` | `ghosh_bisect.wgsl`                            |
/// | `fit`         | sampling and relaxation on the CPU (rayon; the dense 2N+3 LU stays there by design), all Ghosh interpolations of a batch of curves in one `ghosh_bisect` run |
/// | `evaluate`    | `helix_eval.wgsl` (piecewise helices → points and tangents) |
/// | `sample`      | `spline_sample.wgsl` (arc-length tables and inversion on the GPU; splines with cusps fall back to the `f64` reference) |
/// | `integrate`   | `frenet_integrate.wgsl` (Euler spirals: end point and frame, or samples) |
/// | `compress`    | `arc_check.wgsl`: the codec's candidate elements of all curves of a block checked together, a batch per round of the search; unsure verdicts (within rounding of the tolerance) and the entropy coding stay on the CPU, so the container is the same bytes |
pub enum Backend {
    /// The `f64` CPU reference, on all cores (rayon).
    Cpu,
    /// The GPU.
    Gpu(Box<GpuEngine>),
}

/// Curves per GPU batch in [`Backend::fit`]: bounds host memory (pairs and
/// results of one batch) for any number of curves.
const FIT_BATCH_CURVES: usize = 1 << 15;

/// Samples per GPU batch in [`Backend::evaluate`] (whole chains; a chain
/// with more samples than this is a batch of its own).
const EVAL_BATCH_SAMPLES: usize = 1 << 22;

impl Backend {
    /// Where the codec checks its candidate elements: `None` on the CPU
    /// (each curve's search checks its own, in parallel over curves), the
    /// `arc_check` kernel on the GPU (all curves of a block together, one
    /// batch per round; [`crate::codec::ArcChecker`]). Both give the same bytes.
    ///
    /// Plumbing for the command line's `compress` and
    /// [`crate::compress_polylines`] (the checker is a type of the hidden
    /// `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn arc_checker(&self) -> Result<Option<ArcCheckOn<Gpu<'_>>>, GpuError> {
        match self {
            Backend::Cpu => Ok(None),
            Backend::Gpu(e) => Ok(Some(ArcCheckOn(e.exec()))),
        }
    }

    /// Open the backend the user chose. `auto` never fails: without an
    /// adapter it uses the CPU ([`Backend::open_explained`] says why).
    ///
    /// ```
    /// use strandfit::{Backend, BackendChoice, PrecisionChoice};
    ///
    /// let backend = Backend::open(BackendChoice::Cpu, PrecisionChoice::Auto).unwrap();
    /// assert!(matches!(backend, Backend::Cpu));
    /// // `auto` never fails: the GPU where one opens, else the CPU.
    /// assert!(Backend::open(BackendChoice::Auto, PrecisionChoice::Auto).is_ok());
    /// ```
    pub fn open(choice: BackendChoice, precision: PrecisionChoice) -> Result<Backend, GpuError> {
        Backend::open_explained(choice, precision).map(|(b, _)| b)
    }

    /// [`Backend::open`], with a sentence saying which backend was chosen
    /// and, for `auto`, why (for a program to show its user; the library
    /// prints nothing).
    ///
    /// ```
    /// use strandfit::{Backend, BackendChoice, PrecisionChoice};
    ///
    /// let (_, why) = Backend::open_explained(BackendChoice::Cpu, PrecisionChoice::Auto).unwrap();
    /// assert_eq!(why, "backend cpu");
    /// ```
    pub fn open_explained(
        choice: BackendChoice,
        precision: PrecisionChoice,
    ) -> Result<(Backend, String), GpuError> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, "backend cpu".into())),
            BackendChoice::Gpu => {
                let engine = GpuEngine::new(GpuContext::new()?, precision)?;
                let why = format!(
                    "backend gpu: {} ({})",
                    engine.ctx.describe(),
                    engine.precision.name()
                );
                Ok((Backend::Gpu(Box::new(engine)), why))
            }
            BackendChoice::Auto => {
                match GpuContext::new().and_then(|ctx| GpuEngine::new(ctx, precision)) {
                    // A software rasteriser (lavapipe) runs on the same cores as
                    // the CPU path, and slower: auto takes it only when named.
                    Ok(engine)
                        if engine.ctx.adapter_info().device_type == wgpu::DeviceType::Cpu
                            && std::env::var_os(crate::gpu::ADAPTER_ENV).is_none() =>
                    {
                        let why = format!(
                            "backend cpu (the only GPU adapter, {}, is software; \
                             --backend gpu uses it)",
                            engine.ctx.adapter_info().name
                        );
                        Ok((Backend::Cpu, why))
                    }
                    Ok(engine) => {
                        let why = format!(
                            "backend gpu: {} ({})",
                            engine.ctx.describe(),
                            engine.precision.name()
                        );
                        Ok((Backend::Gpu(Box::new(engine)), why))
                    }
                    Err(e) => Ok((Backend::Cpu, format!("backend cpu (no usable GPU: {e})"))),
                }
            }
        }
    }

    /// `cpu`, or `gpu <adapter> (<precision>)`.
    ///
    /// ```
    /// use strandfit::Backend;
    ///
    /// assert!(Backend::Cpu.describe().starts_with("cpu (f64, "));
    /// ```
    pub fn describe(&self) -> String {
        match self {
            Backend::Cpu => format!("cpu (f64, {} threads)", rayon::current_num_threads()),
            Backend::Gpu(g) => format!("gpu {} ({})", g.ctx.describe(), g.precision.name()),
        }
    }

    /// Ghosh short helices for a batch of pairs (order kept; one bad pair
    /// never stops the others).
    ///
    /// A quarter circle of radius 1, and a pair with coincident ends:
    ///
    /// ```
    /// use strandfit::{Backend, DVec3, HermitePair, ParamCurve3};
    ///
    /// let arc = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
    /// let bad = HermitePair::new(DVec3::ONE, DVec3::X, DVec3::ONE, DVec3::Y);
    /// let out = Backend::Cpu.interpolate(&[arc, bad], 1e-9).unwrap();
    /// let helix = out[0].as_ref().unwrap();
    /// assert!((helix.element.arc_length() - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    /// assert!(out[1].is_err());
    /// ```
    pub fn interpolate(
        &self,
        pairs: &[HermitePair],
        tol: f64,
    ) -> Result<Vec<Result<ShortHelix, HelixError>>, GpuError> {
        self.interpolate_timed(pairs, tol, &mut Timings::default())
    }

    /// [`Backend::interpolate`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn interpolate_timed(
        &self,
        pairs: &[HermitePair],
        tol: f64,
        timings: &mut Timings,
    ) -> Result<Vec<Result<ShortHelix, HelixError>>, GpuError> {
        match self {
            Backend::Cpu => Ok(pairs.par_iter().map(|p| p.interpolate(tol)).collect()),
            Backend::Gpu(g) => ghosh_bisect::interpolate(&g.exec(), pairs, tol, timings),
        }
    }

    /// Fit every spline with `opts.elements` helices (order kept).
    ///
    /// ```
    /// use strandfit::{Backend, BezierSpline, DVec3, FitOptions};
    ///
    /// let splines: Vec<BezierSpline> = (1..=3)
    ///     .map(|k| {
    ///         let z = k as f64;
    ///         BezierSpline::from_control_points(&[
    ///             DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::new(2.0, -1.0, z), DVec3::new(3.0, 0.0, z),
    ///         ]).unwrap()
    ///     })
    ///     .collect();
    /// // `Backend::open(BackendChoice::Auto, …)` would take a GPU where there is one.
    /// let chains = Backend::Cpu.fit(&splines, &FitOptions::new(12)).unwrap();
    /// assert!(chains.iter().all(|c| c.as_ref().is_ok_and(|c| c.len() == 12)));
    /// ```
    pub fn fit(
        &self,
        splines: &[BezierSpline],
        opts: &FitOptions,
    ) -> Result<Vec<Result<PiecewiseHelix, FitError>>, GpuError> {
        self.fit_timed(splines, opts, &mut Timings::default())
    }

    /// [`Backend::fit`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn fit_timed(
        &self,
        splines: &[BezierSpline],
        opts: &FitOptions,
        timings: &mut Timings,
    ) -> Result<Vec<Result<PiecewiseHelix, FitError>>, GpuError> {
        let g = match self {
            Backend::Cpu => return Ok(fit_splines(splines, opts)),
            Backend::Gpu(g) => g,
        };
        let exec = g.exec();
        let mut results = Vec::with_capacity(splines.len());
        for batch in splines.chunks(FIT_BATCH_CURVES) {
            // Steps 1–2 on the CPU, per curve in parallel.
            let prepared: Vec<Result<Vec<HermitePair>, FitError>> = batch
                .par_iter()
                .map_init(FitScratch::default, |scratch, s| {
                    let mut pairs = Vec::with_capacity(opts.elements);
                    relaxed_pairs(s, opts, scratch, &mut pairs).map(|()| pairs)
                })
                .collect();
            // Step 3 for the whole batch in one kernel run.
            let flat: Vec<HermitePair> = prepared
                .iter()
                .filter_map(|r| r.as_ref().ok())
                .flatten()
                .copied()
                .collect();
            let helices = ghosh_bisect::interpolate(&exec, &flat, opts.cohelical_tol, timings)?;
            let mut next = 0;
            for r in prepared {
                results.push(r.and_then(|pairs| {
                    let these = &helices[next..next + pairs.len()];
                    next += pairs.len();
                    let elements = these
                        .iter()
                        .enumerate()
                        .map(|(index, h)| {
                            h.as_ref()
                                .map(|h| h.element)
                                .map_err(|e| FitError::Element { index, source: *e })
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    Ok(PiecewiseHelix::new(elements))
                }));
            }
        }
        Ok(results)
    }

    /// `n + 1` points with unit tangents equally spaced in arc length on
    /// every spline — [`BezierSpline::sample_equal_arclen`] — order kept.
    /// `n ≥ 1` (the CLI checks; `n = 0` gives the two ends).
    ///
    /// ```
    /// use strandfit::{Backend, BezierSpline, DVec3};
    ///
    /// // A straight segment of length 3, sampled at 4 points.
    /// let line = BezierSpline::from_control_points(&[DVec3::ZERO, DVec3::X, 2.0 * DVec3::X, 3.0 * DVec3::X]).unwrap();
    /// let samples = Backend::Cpu.sample(&[line], 3).unwrap();
    /// let xs: Vec<f64> = samples[0].points.iter().map(|p| p.x).collect();
    /// assert!(xs.iter().zip([0.0, 1.0, 2.0, 3.0]).all(|(x, e)| (x - e).abs() < 1e-6));
    /// assert!(samples[0].tangents.iter().all(|t| t.distance(DVec3::X) < 1e-9));
    /// ```
    pub fn sample(&self, splines: &[BezierSpline], n: usize) -> Result<Vec<Samples>, GpuError> {
        self.sample_timed(splines, n, &mut Timings::default())
    }

    /// [`Backend::sample`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn sample_timed(
        &self,
        splines: &[BezierSpline],
        n: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Samples>, GpuError> {
        let n = n.max(1);
        match self {
            Backend::Cpu => Ok(splines
                .par_iter()
                .map(|s| {
                    let mut out = Samples::default();
                    // Cannot fail for n ≥ 1.
                    let _ = s.sample_equal_arclen_into(n, &mut out.points, &mut out.tangents);
                    out
                })
                .collect()),
            Backend::Gpu(g) => Ok(spline_sample::sample(&g.exec(), splines, n, timings)?
                .into_iter()
                .map(|s| Samples {
                    points: s.points,
                    tangents: s.tangents,
                })
                .collect()),
        }
    }

    /// `m` points (and unit tangents) of every chain equally spaced in arc
    /// length, ends included — [`PiecewiseHelix::sample`] — order kept.
    /// Empty chains give no samples.
    ///
    /// ```
    /// use strandfit::{Backend, DVec3, HermitePair, PiecewiseHelix};
    ///
    /// // A half circle of radius 1 as two quarter-circle helices.
    /// let q1 = HermitePair::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y).interpolate(1e-9).unwrap();
    /// let q2 = HermitePair::new(DVec3::new(1.0, 1.0, 0.0), DVec3::Y, DVec3::new(0.0, 2.0, 0.0), -DVec3::X).interpolate(1e-9).unwrap();
    /// let chain = PiecewiseHelix::new(vec![q1.element, q2.element]);
    /// let out = Backend::Cpu.evaluate(&[chain, PiecewiseHelix::new(vec![])], 5).unwrap();
    /// assert_eq!(out[0].points.len(), 5);
    /// assert!(out[0].points.iter().all(|p| (p.distance(DVec3::Y) - 1.0).abs() < 1e-9));
    /// assert!(out[0].tangents[2].distance(DVec3::Y) < 1e-9); // the middle
    /// assert!(out[1].points.is_empty());
    /// ```
    pub fn evaluate(&self, chains: &[PiecewiseHelix], m: usize) -> Result<Vec<Samples>, GpuError> {
        self.evaluate_timed(chains, m, &mut Timings::default())
    }

    /// [`Backend::evaluate`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn evaluate_timed(
        &self,
        chains: &[PiecewiseHelix],
        m: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Samples>, GpuError> {
        let g = match self {
            Backend::Cpu => {
                return Ok(chains
                    .par_iter()
                    .map(|c| {
                        let (points, tangents) = c.sample_with_tangents(m);
                        Samples { points, tangents }
                    })
                    .collect())
            }
            Backend::Gpu(g) => g,
        };
        let exec = g.exec();
        let per_batch = (EVAL_BATCH_SAMPLES / m.max(1)).max(1);
        let mut out = Vec::with_capacity(chains.len());
        for batch in chains.chunks(per_batch) {
            out.extend(helix_eval::sample_chains_full(&exec, batch, m, timings)?);
        }
        Ok(out)
    }

    /// End point and frame of every Euler spiral after `steps` steps of the
    /// fourth-order scheme of [`crate::euler::FrenetProblem`] (order kept; a bad
    /// problem gets its own error).
    ///
    /// A circle of radius 1, half way round, and a problem with a NaN:
    ///
    /// ```
    /// use std::f64::consts::PI;
    /// use strandfit::{Backend, DVec3, FrenetProblem};
    ///
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, PI);
    /// let bad = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, f64::NAN, 0.0, 0.0, 0.0, PI);
    /// let out = Backend::Cpu.integrate(&[half, bad], 64).unwrap();
    /// let end = out[0].as_ref().unwrap();
    /// assert!(end.point.distance(DVec3::new(0.0, 2.0, 0.0)) < 1e-8); // fourth order
    /// assert!(end.frame[0].distance(-DVec3::X) < 1e-9);
    /// assert!(out[1].is_err());
    /// ```
    pub fn integrate(
        &self,
        problems: &[FrenetProblem],
        steps: usize,
    ) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
        self.integrate_timed(problems, steps, &mut Timings::default())
    }

    /// [`Backend::integrate`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn integrate_timed(
        &self,
        problems: &[FrenetProblem],
        steps: usize,
        timings: &mut Timings,
    ) -> Result<Vec<Result<FrenetEnd, FrenetError>>, GpuError> {
        match self {
            Backend::Cpu => Ok(problems.par_iter().map(|p| p.integrate(steps)).collect()),
            Backend::Gpu(g) => frenet_integrate::integrate(&g.exec(), problems, steps, timings),
        }
    }

    /// `m` points and unit tangents of every Euler spiral, equally spaced
    /// in arc length (ends included), `steps_per_interval` steps apart.
    ///
    /// ```
    /// use std::f64::consts::PI;
    /// use strandfit::{Backend, DVec3, FrenetProblem};
    ///
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, PI);
    /// let out = Backend::Cpu.integrate_samples(&[half], 3, 16).unwrap();
    /// let s = out[0].as_ref().unwrap();
    /// assert_eq!(s.points.len(), 3);
    /// assert!(s.points[1].distance(DVec3::new(1.0, 1.0, 0.0)) < 1e-7); // a quarter round
    /// assert!(s.tangents[1].distance(DVec3::Y) < 1e-9);
    /// ```
    pub fn integrate_samples(
        &self,
        problems: &[FrenetProblem],
        m: usize,
        steps_per_interval: usize,
    ) -> Result<Vec<Result<SpiralSamples, FrenetError>>, GpuError> {
        match self {
            Backend::Cpu => Ok(problems
                .par_iter()
                .map(|p| {
                    p.sample(m, steps_per_interval).map(|s| SpiralSamples {
                        points: s.iter().map(|e| e.point).collect(),
                        tangents: s.iter().map(|e| e.frame[0]).collect(),
                    })
                })
                .collect()),
            Backend::Gpu(g) => frenet_integrate::sample(
                &g.exec(),
                problems,
                m,
                steps_per_interval,
                &mut Timings::default(),
            ),
        }
    }

    /// ATPH G1 Hermite interpolation of every pair (paper 002), with the
    /// prescribed arc length where `lengths` gives one; a pair that cannot
    /// be solved gets its own error. GPU: spatial solves in one kernel run
    /// (planar and straight cases on the host, see [`crate::kernels::atph_hermite`]).
    ///
    /// With and without a prescribed length:
    ///
    /// ```
    /// use strandfit::atph::HermitePair;
    /// use strandfit::{Backend, DVec3};
    ///
    /// // Two points of the cylinder curve (4 cos t, 4 sin t, 0.2t²), t = 0 and 1.
    /// let (c1, t1) = (DVec3::new(4.0 * 1f64.cos(), 4.0 * 1f64.sin(), 0.2), DVec3::new(-4.0 * 1f64.sin(), 4.0 * 1f64.cos(), 0.4));
    /// let pair = HermitePair::new(DVec3::new(4.0, 0.0, 0.0), DVec3::Y, c1, t1);
    /// let l = 0.5 * 16.16f64.sqrt() + 20.0 * 0.1f64.asinh(); // its arc length on the cylinder
    /// let out = Backend::Cpu.interpolate_atph(&[pair, pair], Some(&[None, Some(l)])).unwrap();
    /// let (free, fixed) = (out[0].as_ref().unwrap(), out[1].as_ref().unwrap());
    /// assert!(free.position(1.0).distance(pair.p1) < 1e-12);
    /// assert!((fixed.length() - l).abs() < 1e-12);
    /// ```
    pub fn interpolate_atph(
        &self,
        pairs: &[crate::atph::HermitePair],
        lengths: Option<&[Option<f64>]>,
    ) -> Result<Vec<Result<crate::atph::AtphCurve, crate::atph::AtphError>>, GpuError> {
        self.interpolate_atph_timed(pairs, lengths, &mut Timings::default())
    }

    /// [`Backend::interpolate_atph`] reporting where the GPU time went.
    ///
    /// Plumbing for the command line's `bench` (`timings` is a type of the
    /// hidden `kernels` module), not part of the public API.
    #[doc(hidden)]
    pub fn interpolate_atph_timed(
        &self,
        pairs: &[crate::atph::HermitePair],
        lengths: Option<&[Option<f64>]>,
        timings: &mut Timings,
    ) -> Result<Vec<Result<crate::atph::AtphCurve, crate::atph::AtphError>>, GpuError> {
        match self {
            Backend::Cpu => Ok(crate::atph::interpolate_pairs(pairs, lengths)),
            Backend::Gpu(g) => atph_hermite::interpolate(&g.exec(), pairs, lengths, timings),
        }
    }
}
