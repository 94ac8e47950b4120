//! One description per WGSL kernel, and the host side of each kernel written
//! once over an executor: the GPU ([`crate::gpu::Gpu`]) or the CPU twin
//! ([`Twin`]).
//!
//! A kernel is a [`Kernel`]: the file it is in (`shaders/<NAME>.wgsl`), its
//! parameter block ([`Kernel::PARAMS`]), its buffers ([`Kernel::BINDINGS`]),
//! its entry points, the constants a configuration prepends, and its CPU
//! twin ([`Kernel::twin`], built on [`crate::twin`]). Everything the WGSL
//! files used to repeat — the precision prelude, `math.wgsl`, the `Params`
//! struct and the `@group(0) @binding(k)` declarations — is generated here
//! from the description ([`source`]), so shader and driver cannot disagree
//! on a layout.
//!
//! An [`Exec`] runs a kernel over a sequence of [`Batch`]es. The GPU
//! executor compiles each kernel once per context (its pipeline cache),
//! binds, uploads and reads back with one generic dispatcher; [`Twin`] runs
//! the twin. Each kernel's host code (packing records in `f64`, unpacking,
//! falling back to the `f64` reference) is generic over the executor, so
//! "what the GPU path returns" and "the same with the kernel replaced by its
//! twin" are one function.
//!
//! | shader                          | declaration and host side |
//! |---------------------------------|---------------------------|
//! | `shaders/arc_check.wgsl`        | [`arc_check`]             |
//! | `shaders/atph_hermite.wgsl`     | [`atph_hermite`]          |
//! | `shaders/frenet_integrate.wgsl` | [`frenet_integrate`]      |
//! | `shaders/ghosh_bisect.wgsl`     | [`ghosh_bisect`]          |
//! | `shaders/helix_eval.wgsl`       | [`helix_eval`]            |
//! | `shaders/spline_sample.wgsl`    | [`spline_sample`]         |

pub mod arc_check;
pub mod atph_hermite;
pub mod frenet_integrate;
pub mod ghosh_bisect;
pub mod helix_eval;
pub mod spline_sample;

use std::borrow::Cow;
use std::fmt::Debug;
use std::marker::PhantomData;
use std::time::Duration;

use thiserror::Error;

use crate::twin::Real;

/// Environment variable that picks the GPU adapter.
pub const ADAPTER_ENV: &str = "STRANDFIT_ADAPTER";

/// Why the GPU path is unavailable or failed.
#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (Vulkan backend). Install a Vulkan driver — for a \
         software one, `apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe) — \
         or use --backend cpu"
    )]
    NoAdapter,
    #[error("{ADAPTER_ENV}={wanted:?} matches no adapter; available: {available}")]
    AdapterNotFound { wanted: String, available: String },
    #[error("cannot open GPU device on {adapter}: {reason}")]
    Device { adapter: String, reason: String },
    #[error("the adapter {adapter} has no SHADER_F64; use --precision f32")]
    NoF64 { adapter: String },
    #[error("GPU shader {name} failed to compile: {reason}")]
    Shader { name: String, reason: String },
    #[error("GPU execution failed: {0}")]
    Execution(String),
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

/// Scalar type a kernel is compiled with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }

    /// The precision of `R`.
    pub fn of<R: Real>() -> Precision {
        if std::mem::size_of::<R>() == 4 {
            Precision::F32
        } else {
            Precision::F64
        }
    }
}

/// Where the time of a GPU batch went (summed over chunks). With two chunks
/// in flight, `wait` is the part of the device's work the host could not
/// hide behind upload and readback.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// Packing records into the kernel's precision.
    pub prepare: Duration,
    /// `write_buffer` + encode + submit.
    pub upload: Duration,
    /// Blocking until a chunk's results are mapped.
    pub wait: Duration,
    /// Copying mapped results out (and unpacking).
    pub readback: Duration,
    /// Number of chunks.
    pub chunks: usize,
}

impl Timings {
    pub fn total(&self) -> Duration {
        self.prepare + self.upload + self.wait + self.readback
    }
    pub fn add(&mut self, o: &Timings) {
        self.prepare += o.prepare;
        self.upload += o.upload;
        self.wait += o.wait;
        self.readback += o.readback;
        self.chunks += o.chunks;
    }
}

// ---------------------------------------------------------------------------
// The description.

/// A field of a kernel's uniform parameter block (16-byte multiples: pad
/// with [`Field::Pad`]). The dispatcher fills counts and rows from the
/// batch's passes; scalars come from [`Batch::scalars`] in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Invocations of pass `k` (`u32`).
    Count(usize),
    /// Invocations per row of pass `k`'s 2D dispatch (`u32`): the kernel's
    /// index is `gid.x + gid.y * row`.
    Row(usize),
    /// A host-supplied `f32`.
    Scalar,
    /// `u32` padding.
    Pad,
}

/// Element type of a storage buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Elem {
    /// The kernel's precision (`real`).
    Real,
    U32,
}

impl Elem {
    fn wgsl(self) -> &'static str {
        match self {
            Elem::Real => "real",
            Elem::U32 => "u32",
        }
    }
}

/// What a storage buffer is to the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Uploaded with each batch ([`Batch::inputs`], in order), read only.
    Input,
    /// Uploaded once for many batches ([`Exec::resident`]), read only.
    Resident,
    /// Kernel-private (read-write), [`Batch::scratch`] elements, never read back.
    Scratch,
    /// The output (read-write, read back); exactly one per kernel, last.
    Output,
}

/// A storage buffer: its WGSL name, element type, and role. Binding
/// `k + 1` (binding 0 is the parameter block `params`).
#[derive(Clone, Copy, Debug)]
pub struct Binding {
    pub name: &'static str,
    pub elem: Elem,
    pub access: Access,
}

/// Shorthand for a [`Binding`].
pub const fn binding(name: &'static str, elem: Elem, access: Access) -> Binding {
    Binding { name, elem, access }
}

/// One WGSL kernel, described once.
pub trait Kernel: 'static {
    /// The stem of its file in `shaders/`.
    const NAME: &'static str;
    /// The kernel body (`shaders/<NAME>.wgsl`).
    const WGSL: &'static str;
    /// The uniform parameter block at binding 0, `var<uniform> params`.
    const PARAMS: &'static [(&'static str, Field)];
    /// The storage buffers at bindings 1, 2, … (inputs first, output last).
    const BINDINGS: &'static [Binding];
    /// Entry points, one per pass, in dispatch order.
    const ENTRIES: &'static [&'static str] = &["main"];
    /// Largest `|GPU − twin|` the generated parity test accepts per output
    /// value, in units of the precision's `ε` times `max(1, |twin|)`
    /// (integer outputs: exact).
    const PARITY_EPS: f64;
    /// Output values that count something (a bisection's steps, say): a
    /// stopping test like `hi − lo > 2ε·hi` may pass one step sooner or
    /// later under another driver's roundings (FMA contraction; measured on
    /// an NVIDIA H200: 27 steps against the twin's 26), so the generated
    /// parity test accepts `|GPU − twin| ≤ slack` there. `None`: the rule
    /// of [`Kernel::PARITY_EPS`].
    fn parity_count_slack(_index: usize) -> Option<f64> {
        None
    }
    /// A compile-time variant of the kernel (`()` for most).
    type Config: Copy + Debug + PartialEq + Send + Sync + 'static;

    /// WGSL constants the configuration prepends to the body.
    fn constants<R: Real>(_cfg: Self::Config) -> String {
        String::new()
    }
    /// The configurations every kernel test validates and runs.
    fn configs() -> Vec<Self::Config>;
    /// The CPU twin: what the kernel computes for `batch`.
    fn twin<R: Real>(
        cfg: Self::Config,
        batch: &Batch<'_, R>,
        resident: &[&Data<'_, R>],
    ) -> Data<'static, R>;
    /// A random batch of records the host could hand the kernel (for the
    /// generated parity tests), and its resident buffers.
    fn parity_batch<R: Real>(
        cfg: Self::Config,
        rng: &mut Rng,
    ) -> (Batch<'static, R>, Vec<Data<'static, R>>);
}

/// A kernel over fixed-size records: one pass, one invocation per record,
/// `params = { count, row, <scalar>, _pad }`, one input and one output of
/// `real`s.
pub trait MapKernel: Kernel {
    /// Reals per input record.
    const IN_STRIDE: usize;
    /// Reals per output record.
    fn out_stride(cfg: Self::Config) -> usize;
    /// The twin on one record; `scalar` as the kernel sees it.
    fn twin_record<R: Real>(cfg: Self::Config, scalar: f32, rec: &[R], out: &mut [R]);
    /// Random `f64` records the host could hand the kernel, and the scalar
    /// (for [`Kernel::parity_batch`]).
    fn parity_records(cfg: Self::Config, rng: &mut Rng) -> (f32, Vec<f64>);
    /// [`Kernel::parity_count_slack`] for output value `index` of the
    /// whole batch (record `index / out_stride`).
    fn parity_count_slack(_index: usize) -> Option<f64> {
        None
    }
}

/// Declares a [`MapKernel`] without configurations: the struct and its
/// [`Kernel`] impl from the file name, the scalar's name, the buffers'
/// names and the parity tolerance (the [`MapKernel`] impl is written by
/// hand next to it).
#[macro_export]
#[doc(hidden)]
macro_rules! map_kernel {
    ($(#[$m:meta])* $k:ident {
        name: $name:literal,
        scalar: $scalar:literal,
        buffers: ($input:literal, $output:literal),
        parity_eps: $eps:expr $(,)?
    }) => {
        $(#[$m])*
        pub struct $k;

        impl $crate::kernels::Kernel for $k {
            const NAME: &'static str = $name;
            const WGSL: &'static str = include_str!(concat!("../../shaders/", $name, ".wgsl"));
            const PARAMS: &'static [(&'static str, $crate::kernels::Field)] =
                $crate::map_params!($scalar);
            const BINDINGS: &'static [$crate::kernels::Binding] =
                &$crate::kernels::map_bindings($input, $output);
            const PARITY_EPS: f64 = $eps;
            type Config = ();

            fn parity_count_slack(index: usize) -> Option<f64> {
                <Self as $crate::kernels::MapKernel>::parity_count_slack(index)
            }

            fn configs() -> Vec<()> {
                vec![()]
            }
            fn twin<R: $crate::twin::Real>(
                cfg: (),
                batch: &$crate::kernels::Batch<'_, R>,
                _: &[&$crate::kernels::Data<'_, R>],
            ) -> $crate::kernels::Data<'static, R> {
                $crate::kernels::map_twin::<Self, R>(cfg, batch)
            }
            fn parity_batch<R: $crate::twin::Real>(
                cfg: (),
                rng: &mut $crate::kernels::Rng,
            ) -> (
                $crate::kernels::Batch<'static, R>,
                Vec<$crate::kernels::Data<'static, R>>,
            ) {
                let (scalar, records) =
                    <Self as $crate::kernels::MapKernel>::parity_records(cfg, rng);
                $crate::kernels::map_batch::<Self, R>(cfg, scalar, &records)
            }
        }
    };
}

/// The parameter block of a [`MapKernel`] whose scalar is called `scalar`.
#[macro_export]
#[doc(hidden)]
macro_rules! map_params {
    ($scalar:literal) => {
        &[
            ("count", $crate::kernels::Field::Count(0)),
            ("row", $crate::kernels::Field::Row(0)),
            ($scalar, $crate::kernels::Field::Scalar),
            ("_pad", $crate::kernels::Field::Pad),
        ]
    };
}

/// The bindings of a [`MapKernel`]: input and output records.
pub const fn map_bindings(input: &'static str, output: &'static str) -> [Binding; 2] {
    [
        binding(input, Elem::Real, Access::Input),
        binding(output, Elem::Real, Access::Output),
    ]
}

/// [`Kernel::twin`] of a [`MapKernel`], record by record (in parallel).
pub fn map_twin<K: MapKernel, R: Real>(cfg: K::Config, batch: &Batch<'_, R>) -> Data<'static, R> {
    use rayon::prelude::*;
    let input = batch.inputs[0].reals();
    let os = K::out_stride(cfg);
    let scalar = batch.scalars.first().copied().unwrap_or(0.0);
    let mut out = vec![R::zero(); batch.out_len];
    out.par_chunks_mut(os)
        .zip(input.par_chunks(K::IN_STRIDE))
        .for_each(|(o, i)| K::twin_record(cfg, scalar, i, o));
    Data::Real(Cow::Owned(out))
}

/// [`Kernel::parity_batch`] of a [`MapKernel`] from records (`f64`).
pub fn map_batch<K: MapKernel, R: Real>(
    cfg: K::Config,
    scalar: f32,
    records: &[f64],
) -> (Batch<'static, R>, Vec<Data<'static, R>>) {
    let n = records.len() / K::IN_STRIDE;
    let input: Vec<R> = records.iter().map(|&x| R::from_f64(x)).collect();
    let batch = Batch {
        counts: vec![n],
        scalars: vec![scalar],
        inputs: vec![Data::Real(Cow::Owned(input))],
        scratch: Vec::new(),
        out_len: n * K::out_stride(cfg),
    };
    (batch, Vec::new())
}

// ---------------------------------------------------------------------------
// Sources.

/// The precision prelude of every kernel, generated from [`Real`]'s constants
/// so that shader and twin read them from one place.
pub fn prelude<R: Real>() -> String {
    format!(
        "// generated by strandfit::kernels::prelude::<{w}>()\n\
         alias real = {w};\n\
         const REAL_EPS: real = {eps:e};\n\
         const PIO2_A: real = {a:e};\n\
         const PIO2_B: real = {b:e};\n\
         const PIO2_C: real = {c:e};\n\
         const BISECT_MAX: u32 = {m}u;\n",
        w = R::WGSL,
        eps = R::EPSILON.to_f64(),
        a = R::PIO2_A,
        b = R::PIO2_B,
        c = R::PIO2_C,
        m = R::BISECT_MAX,
    )
}

/// `shaders/math.wgsl`.
pub const MATH_WGSL: &str = include_str!("../../shaders/math.wgsl");

/// The `Params` struct and the bindings of `K`, generated from its
/// description.
pub fn interface<K: Kernel>() -> String {
    let mut s = format!(
        "// generated from strandfit::kernels ({})\nstruct Params {{\n",
        K::NAME
    );
    for (name, f) in K::PARAMS {
        let ty = if *f == Field::Scalar { "f32" } else { "u32" };
        s += &format!("    {name}: {ty},\n");
    }
    s += "}\n\n@group(0) @binding(0) var<uniform> params: Params;\n";
    for (k, b) in K::BINDINGS.iter().enumerate() {
        let access = match b.access {
            Access::Input | Access::Resident => "read",
            Access::Scratch | Access::Output => "read_write",
        };
        s += &format!(
            "@group(0) @binding({}) var<storage, {access}> {}: array<{}>;\n",
            k + 1,
            b.name,
            b.elem.wgsl()
        );
    }
    s
}

/// Full source of `K` in precision `R`: prelude, `math.wgsl`, the
/// configuration's constants, the generated interface, the body.
pub fn source<K: Kernel, R: Real>(cfg: K::Config) -> String {
    format!(
        "{}\n{}\n{}{}\n{}",
        prelude::<R>(),
        MATH_WGSL,
        K::constants::<R>(cfg),
        interface::<K>(),
        K::WGSL
    )
}

/// Calls `$m!` with every declared kernel type, so that lists of kernels
/// (sources, parity tests) are written once.
#[macro_export]
#[doc(hidden)]
macro_rules! for_each_kernel {
    ($m:ident) => {
        $m!(
            $crate::kernels::arc_check::ArcCheck,
            $crate::kernels::atph_hermite::AtphHermite,
            $crate::kernels::frenet_integrate::FrenetIntegrate,
            $crate::kernels::ghosh_bisect::GhoshBisect,
            $crate::kernels::helix_eval::HelixEval,
            $crate::kernels::spline_sample::SplineSample
        )
    };
}

/// The names of all declared kernels.
pub fn names() -> Vec<&'static str> {
    macro_rules! names {
        ($($k:ty),*) => { vec![$(<$k as Kernel>::NAME),*] };
    }
    for_each_kernel!(names)
}

/// Every kernel's full source in precision `R` for each of its
/// [`Kernel::configs`], by name — exactly what the GPU compiles. For
/// validating every kernel with naga on any machine, GPU or not
/// (`tests/shaders_validate.rs`).
pub fn kernel_sources<R: Real>() -> Vec<(&'static str, String)> {
    fn of<K: Kernel, R: Real>(out: &mut Vec<(&'static str, String)>) {
        for cfg in K::configs() {
            out.push((K::NAME, source::<K, R>(cfg)));
        }
    }
    macro_rules! all {
        ($($k:ty),*) => {{ let mut v = Vec::new(); $(of::<$k, R>(&mut v);)* v }};
    }
    for_each_kernel!(all)
}

// ---------------------------------------------------------------------------
// Batches and executors.

/// A buffer's contents: `real`s or `u32`s, borrowed or owned.
#[derive(Clone, Debug)]
pub enum Data<'a, R: Real> {
    Real(Cow<'a, [R]>),
    U32(Cow<'a, [u32]>),
}

impl<R: Real> Data<'_, R> {
    /// The reals (panics on `u32`s: a layout bug).
    pub fn reals(&self) -> &[R] {
        match self {
            Data::Real(v) => v,
            Data::U32(_) => panic!("u32 buffer where reals were declared"),
        }
    }
    /// The `u32`s (panics on reals: a layout bug).
    pub fn u32s(&self) -> &[u32] {
        match self {
            Data::U32(v) => v,
            Data::Real(_) => panic!("real buffer where u32s were declared"),
        }
    }
    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        match self {
            Data::Real(v) => bytemuck::cast_slice(v),
            Data::U32(v) => bytemuck::cast_slice(v),
        }
    }
    /// Number of elements.
    pub fn len(&self) -> usize {
        match self {
            Data::Real(v) => v.len(),
            Data::U32(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One dispatch of a kernel (all its passes) over one chunk of work.
#[derive(Clone, Debug)]
pub struct Batch<'a, R: Real> {
    /// Invocations of each pass ([`Kernel::ENTRIES`]).
    pub counts: Vec<usize>,
    /// The [`Field::Scalar`]s of the parameter block, in order.
    pub scalars: Vec<f32>,
    /// The [`Access::Input`] buffers, in order.
    pub inputs: Vec<Data<'a, R>>,
    /// Elements of each [`Access::Scratch`] buffer, in order.
    pub scratch: Vec<usize>,
    /// Elements of the output.
    pub out_len: usize,
}

/// What an executor's storage bindings and grids may hold.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Largest storage buffer binding, bytes.
    pub max_binding_bytes: u64,
    /// Largest workgroup count per dispatch dimension.
    pub max_groups_per_dim: u32,
}

impl Limits {
    /// No limits (the twin).
    pub const NONE: Limits = Limits {
        max_binding_bytes: u64::MAX,
        max_groups_per_dim: u32::MAX,
    };

    /// Largest number of invocations of one dispatch.
    pub fn max_invocations(&self) -> usize {
        let g = self.max_groups_per_dim as usize;
        g.saturating_mul(g).saturating_mul(WORKGROUP as usize)
    }
}

/// Invocations per workgroup of every kernel.
pub const WORKGROUP: u32 = 64;
/// Default records per chunk of a [`MapKernel`]; the limits may lower it.
pub const CHUNK_RECORDS: usize = 1 << 18;

/// Runs kernels: the GPU ([`crate::gpu::Gpu`]) or the twin ([`Twin`]).
pub trait Exec: Sync {
    /// A buffer uploaded once and bound to [`Access::Resident`] bindings.
    type Resident<R: Real>: Send + Sync;

    /// The precision kernels run in; the host code packs records in it.
    fn precision(&self) -> Precision;
    /// What one binding and dispatch may hold.
    fn limits(&self) -> Limits;
    /// Uploads `data` for the batches that follow.
    fn resident<R: Real>(&self, data: Data<'_, R>) -> Result<Self::Resident<R>, GpuError>;
    /// Runs `K` over `batches` in order; `done(i, output)` receives batch
    /// `i`'s output (on the GPU two batches are in flight).
    fn run<'a, K: Kernel, R: Real>(
        &self,
        cfg: K::Config,
        resident: &[&Self::Resident<R>],
        batches: &mut dyn Iterator<Item = Batch<'a, R>>,
        done: &mut dyn FnMut(usize, &Data<'_, R>),
        timings: &mut Timings,
    ) -> Result<(), GpuError>;
}

/// The CPU twins as an executor, in precision `R`: what the GPU path
/// returns, without a GPU (parity tests, emulation).
#[derive(Clone, Copy, Debug, Default)]
pub struct Twin<R>(PhantomData<R>);

impl<R: Real> Twin<R> {
    pub fn new() -> Self {
        Twin(PhantomData)
    }
}

impl<T: Real> Exec for Twin<T> {
    type Resident<R: Real> = Data<'static, R>;

    fn precision(&self) -> Precision {
        Precision::of::<T>()
    }
    fn limits(&self) -> Limits {
        Limits::NONE
    }
    fn resident<R: Real>(&self, data: Data<'_, R>) -> Result<Data<'static, R>, GpuError> {
        Ok(match data {
            Data::Real(v) => Data::Real(Cow::Owned(v.into_owned())),
            Data::U32(v) => Data::U32(Cow::Owned(v.into_owned())),
        })
    }
    fn run<'a, K: Kernel, R: Real>(
        &self,
        cfg: K::Config,
        resident: &[&Data<'static, R>],
        batches: &mut dyn Iterator<Item = Batch<'a, R>>,
        done: &mut dyn FnMut(usize, &Data<'_, R>),
        _timings: &mut Timings,
    ) -> Result<(), GpuError> {
        assert_eq!(
            std::mem::size_of::<R>(),
            std::mem::size_of::<T>(),
            "precision"
        );
        for (i, b) in batches.enumerate() {
            done(i, &K::twin(cfg, &b, resident));
        }
        Ok(())
    }
}

/// Records per chunk of a map kernel: [`CHUNK_RECORDS`], lowered to fit
/// the limits.
pub fn chunk_records(
    limits: Limits,
    in_stride: usize,
    out_stride: usize,
    real_size: usize,
) -> usize {
    let per = (in_stride.max(out_stride) * real_size) as u64;
    let by_binding = (limits.max_binding_bytes / per).min(usize::MAX as u64) as usize;
    CHUNK_RECORDS
        .min(by_binding)
        .min(limits.max_invocations())
        .max(1)
}

/// Runs map kernel `K` over `input` (`n·IN_STRIDE` reals) into `out`
/// (`n·out_stride` reals), in chunks; `scalar` is the kernel's parameter.
pub fn map<K: MapKernel, R: Real, E: Exec>(
    exec: &E,
    cfg: K::Config,
    scalar: f32,
    input: &[R],
    out: &mut [R],
    timings: &mut Timings,
) -> Result<(), GpuError> {
    assert_eq!(R::WGSL, exec.precision().name(), "record precision");
    let (is, os) = (K::IN_STRIDE, K::out_stride(cfg));
    let n = input.len() / is;
    assert_eq!(input.len(), n * is);
    assert_eq!(out.len(), n * os);
    if n == 0 {
        return Ok(());
    }
    let chunk = chunk_records(exec.limits(), is, os, std::mem::size_of::<R>());
    let mut batches = (0..n).step_by(chunk).map(|first| {
        let count = chunk.min(n - first);
        Batch {
            counts: vec![count],
            scalars: vec![scalar],
            inputs: vec![Data::Real(Cow::Borrowed(
                &input[first * is..(first + count) * is],
            ))],
            scratch: Vec::new(),
            out_len: count * os,
        }
    });
    exec.run::<K, R>(
        cfg,
        &[],
        &mut batches,
        &mut |i, o| {
            let o = o.reals();
            let first = i * chunk * os;
            out[first..first + o.len()].copy_from_slice(o);
        },
        timings,
    )
}

/// Calls `$f::<f32>(…)` or `$f::<f64>(…)` by the executor's precision.
macro_rules! by_precision {
    ($exec:expr, $f:ident($($arg:expr),* $(,)?)) => {
        match $exec.precision() {
            $crate::kernels::Precision::F32 => $f::<f32, _>($($arg),*),
            $crate::kernels::Precision::F64 => $f::<f64, _>($($arg),*),
        }
    };
}
pub(crate) use by_precision;

/// The generator of the parity batches.
pub use crate::synthetic::SplitMix64 as Rng;

/// Compares a GPU output with the twin's under `K`'s stated tolerance;
/// `Err` names the first value out of it. (The generated parity tests.)
pub fn parity_check<K: Kernel, R: Real>(
    gpu: &Data<'_, R>,
    twin: &Data<'_, R>,
) -> Result<f64, String> {
    if gpu.len() != twin.len() {
        return Err(format!(
            "{}: {} outputs, twin {}",
            K::NAME,
            gpu.len(),
            twin.len()
        ));
    }
    // Integers exactly; counts within their slack; reals within PARITY_EPS ε
    // relative to max(1, |twin|).
    let (g, t, tol): (Vec<f64>, Vec<f64>, f64) = match (gpu, twin) {
        (Data::U32(g), Data::U32(t)) => {
            let f = |v: &[u32]| v.iter().map(|&x| x as f64).collect();
            (f(g), f(t), 0.0)
        }
        (Data::Real(g), Data::Real(t)) => {
            let f = |v: &[R]| v.iter().map(|x| x.to_f64()).collect();
            (f(g), f(t), K::PARITY_EPS)
        }
        _ => return Err(format!("{}: output types differ", K::NAME)),
    };
    let eps = R::EPSILON.to_f64();
    let mut worst = 0.0f64;
    for (i, (&a, &b)) in g.iter().zip(&t).enumerate() {
        if a == b || (a.is_nan() && b.is_nan()) {
            continue;
        }
        if let Some(slack) = K::parity_count_slack(i) {
            if (a - b).abs() <= slack {
                continue;
            }
            return Err(format!(
                "{} ({}): output {i} (a count): GPU {a} twin {b} (more than {slack} apart)",
                K::NAME,
                R::WGSL,
            ));
        }
        let e = (a - b).abs() / (eps * b.abs().max(1.0));
        if !(e <= tol) {
            return Err(format!(
                "{} ({}): output {i}: GPU {a:e} twin {b:e} ({e:.1} ε > {tol})",
                K::NAME,
                R::WGSL,
            ));
        }
        worst = worst.max(e);
    }
    Ok(worst)
}
