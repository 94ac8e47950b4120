//! The `strandfit` command line: `helix`, `fit`, `sample`, `evaluate`,
//! `integrate`, `complete`, `motion`, `compress`, `decompress`, `inspect`,
//! `convert`, `bench`.

mod bench_cmd;
mod complete_cmd;
mod compress_cmd;
mod convert_cmd;
mod decompress_cmd;
mod evaluate_cmd;
mod fit_cmd;
mod helix_cmd;
mod inspect_cmd;
mod integrate_cmd;
mod io_util;
mod motion_cmd;
mod sample_cmd;
mod shards_cmd;
mod sketch_cmd;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

use crate::backend::{Backend, BackendChoice, PrecisionChoice};
use crate::helix::Relaxation;

/// What the exit status means, for every command (also in --help).
pub const EXIT_CODES: &str = "Exit status: 0 done; 1 the input or the run failed (an \
unreadable or bad file, a curve that cannot be fitted, a write that failed); 2 usage (an \
unknown or malformed option, a value out of range, options that do not go together).";

/// The version of every JSON document the commands write (the `"version"`
/// key; `docs/json.md`): raised when a key is renamed, removed or changes
/// its meaning.
pub const JSON_VERSION: u32 = 1;

#[derive(Parser, Debug)]
#[command(
    name = "strandfit",
    version,
    about = "Fit 3D curves with G1 piecewise helices (floating tangents)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Worker threads (default: all cores).
    #[arg(long, global = true, value_parser = clap::value_parser!(u64).range(1..))]
    pub threads: Option<u64>,
}

/// The engine options, offered by the commands that run on one.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct BackendArgs {
    /// Engine for batch work: the f64 CPU reference, the GPU (wgpu/Vulkan),
    /// or auto (a hardware GPU if one exists, else the CPU; software
    /// adapters such as lavapipe only when asked for with --backend gpu or
    /// STRANDFIT_ADAPTER). The choice is reported on stderr.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// GPU kernel precision (auto: f64 where the adapter has SHADER_F64).
    #[arg(long, value_enum, default_value_t = PrecisionArg::Auto)]
    pub precision: PrecisionArg,
    /// Also show what the GPU driver stack prints while the backend is
    /// chosen (Vulkan loader and driver messages; hidden otherwise).
    #[arg(long, short = 'v')]
    pub verbose: bool,
}

/// A command line that asks for something impossible: a value out of
/// range, options that do not go together. Exits with status 2, as clap's
/// own usage errors do.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// `return Err(UsageError(format!(…)))`: a usage error (exit status 2).
macro_rules! usage {
    ($($t:tt)*) => {
        return Err(anyhow::Error::new($crate::cli::UsageError(format!($($t)*))))
    };
}
pub(crate) use usage;

/// Wrap a JSON answer with the schema version: `{"version":1, …}`.
#[derive(serde::Serialize)]
pub(crate) struct Versioned<'a, A: serde::Serialize> {
    version: u32,
    #[serde(flatten)]
    body: &'a A,
}

pub(crate) fn versioned<A: serde::Serialize>(body: &A) -> Versioned<'_, A> {
    Versioned {
        version: JSON_VERSION,
        body,
    }
}

/// The command line's definition, with the exit codes after every
/// command's help.
pub fn command() -> clap::Command {
    use clap::CommandFactory;
    Cli::command()
        .after_help(EXIT_CODES)
        .mut_subcommands(|c| c.after_help(EXIT_CODES))
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum BackendArg {
    Cpu,
    Gpu,
    Auto,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum PrecisionArg {
    Auto,
    F32,
    F64,
}

impl BackendArgs {
    /// Open the chosen backend.
    pub fn open(&self) -> anyhow::Result<Backend> {
        let choice = match self.backend {
            BackendArg::Cpu => BackendChoice::Cpu,
            BackendArg::Gpu => BackendChoice::Gpu,
            BackendArg::Auto => BackendChoice::Auto,
        };
        let precision = match self.precision {
            PrecisionArg::Auto => PrecisionChoice::Auto,
            PrecisionArg::F32 => PrecisionChoice::F32,
            PrecisionArg::F64 => PrecisionChoice::F64,
        };
        // Vulkan loaders and drivers write to the process's stderr while
        // adapters are enumerated (lavapipe: XDG_RUNTIME_DIR complaints),
        // even when the run then uses the CPU: hidden unless --verbose.
        let opened = if self.verbose {
            Backend::open_explained(choice, precision)
        } else {
            io_util::with_stderr_hidden(|| Backend::open_explained(choice, precision))
        };
        let (backend, why) = opened?;
        eprintln!("strandfit: {why}");
        Ok(backend)
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Ghosh's short helix for each JSON Lines record {"p0","t0","p1","t1"}.
    Helix(HelixArgs),
    /// Fit Bézier splines ({"splines":[{"id","control_points"}]}) with N helices each.
    Fit(FitArgs),
    /// N + 1 points with unit tangents equally spaced in arc length on each
    /// Bézier spline (the fit's first step).
    Sample(SampleArgs),
    /// Sample fitted piecewise helices (the output of `fit`) back to
    /// polylines: M points per curve equally spaced in arc length.
    Evaluate(EvaluateArgs),
    /// Integrate 3D Euler spirals (curvature and torsion linear in arc
    /// length) from JSON Lines records {"start","tangent","normal","kappa0",
    /// "gamma","tau0","delta","length"}: end point and frame, optionally samples.
    Integrate(IntegrateArgs),
    /// Compress curves (.tck, .trk, .trx, .vtk, .hair, .json, .csv) into a .sfh
    /// container of piecewise helices: the fewest elements per curve within
    /// --tolerance, or --elements N, or --element-length S.
    Compress(CompressArgs),
    /// Decompress a .sfh container back to polylines (.tck, .trk, .trx, .vtk,
    /// .hair, .json, .csv), in the source's coordinate convention.
    Decompress(DecompressArgs),
    /// Summarise a curve file (.tck, .trk, .trx, .vtk, .hair, .json, .csv): header,
    /// counts, lengths, sizes and problems (empty or one-point curves,
    /// repeated points); stops at the first unreadable curve, naming it.
    Inspect(InspectArgs),
    /// Convert curves between file formats (streamed, in world coordinates).
    Convert(ConvertArgs),
    /// Cut a .sfh container (version 3) into shards of whole blocks, copied
    /// as they are (no decoding): DIR/STEM-00000.sfh, STEM-00001.sfh, …
    Split(SplitArgs),
    /// Join .sfh containers with the same header into one, block by block,
    /// curves in order (no decoding): undoes `split`, byte for byte.
    Merge(MergeArgs),
    /// Fill the gap between point–tangent pairs ({"pairs":[{"id","p0","t0",
    /// "p1","t1"}]}) with 3D Euler spirals (batched on the chosen backend) or
    /// ATPH curves (closed form, optionally of a prescribed arc length).
    Complete(CompleteArgs),
    /// Rigid-body motion through a point stream ({"points":[[x,y,z],…],
    /// "frame":[u,v,w],"c":0.125}): a G1 spline of RRMF quintics with a
    /// rational rotation-minimising frame; JSON Lines for many streams.
    Motion(MotionArgs),
    /// Lift a 2D drawing (JSON, CSV or SVG polyline) to a 3D piecewise
    /// helix whose projection matches it (paper 003).
    Sketch(SketchArgs),
    /// Measure whole-fit throughput on synthetic splines (elements per second).
    Bench(BenchArgs),
}

#[derive(clap::Args, Debug)]
pub struct HelixArgs {
    /// Input JSON Lines file ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Output file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Relative co-helicity tolerance |<p1-p0, t1-t0>|/(|p1-p0||t1-t0|)
    /// (dimensionless; --tolerance elsewhere is a distance).
    #[arg(long, default_value_t = crate::helix::DEFAULT_COHELICAL_TOL)]
    pub cohelical_tolerance: f64,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum RelaxationArg {
    /// O(N) tridiagonal solve in the Lagrange multipliers (default).
    Tridiagonal,
    /// The paper's 2N+3 normal equations by dense LU (reference, O(N^3)).
    Dense,
}

impl From<RelaxationArg> for Relaxation {
    fn from(r: RelaxationArg) -> Self {
        match r {
            RelaxationArg::Tridiagonal => Relaxation::Tridiagonal,
            RelaxationArg::Dense => Relaxation::DenseLu,
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// Input JSON file ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Number of helix elements per curve.
    #[arg(short = 'n', long)]
    pub elements: usize,
    /// Output JSON file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Relaxation solver.
    #[arg(long, value_enum, default_value_t = RelaxationArg::Tridiagonal)]
    pub relaxation: RelaxationArg,
    /// Points per element used to sample both curves for the Fréchet and
    /// Hausdorff distances (each curve gets K·N + 1 points equally spaced in
    /// its own arc length).
    #[arg(long, default_value_t = 32)]
    pub samples_per_element: usize,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(clap::Args, Debug)]
pub struct SampleArgs {
    /// Input JSON file, as for `fit` ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Number of equal arc-length intervals N (N + 1 points per spline).
    #[arg(long)]
    pub intervals: usize,
    /// Output JSON file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(clap::Args, Debug)]
pub struct EvaluateArgs {
    /// Input JSON file, as written by `fit` ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Points per curve, both ends included.
    #[arg(short = 'm', long, default_value_t = 100)]
    pub points: usize,
    /// Also write the unit tangent at every point.
    #[arg(long)]
    pub tangents: bool,
    /// Output JSON file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(clap::Args, Debug)]
pub struct IntegrateArgs {
    /// Input JSON Lines file ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Integration steps over the whole length (fourth-order Magnus +
    /// Simpson; error ≈ C (Θ/steps)⁴, Θ the total turning).
    #[arg(long, default_value_t = 64)]
    pub steps: usize,
    /// Also write M points and unit tangents per curve, equally spaced in
    /// arc length, ends included (0: none). Steps per interval are
    /// ⌈steps/(M − 1)⌉.
    #[arg(short = 'm', long, default_value_t = 0)]
    pub points: usize,
    /// Output file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum StorageArg {
    /// Quantised to the coarsest grids that keep each decoded curve within
    /// the tolerance, delta- and entropy-coded.
    Compact,
    F32,
    F64,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum EffortArg {
    /// Each arc reaches as far as it can.
    Default,
    /// Each arc also chosen one arc ahead, the smaller coding of each block
    /// kept: never larger, about 3x the time.
    Best,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum DistanceArg {
    /// Two-sided: every input point within the tolerance of the output
    /// polyline and every output point within it of the input polyline
    /// (container version 3, the arc codec; guaranteed at default
    /// decompression).
    Hausdorff,
    /// Version-1 helix container: the input's points lie within the
    /// tolerance of the chain, in order
    /// (Fréchet distance with the input taken as its samples).
    Ordered,
    /// Version-1 helix container: continuous Fréchet distance to the input polyline (also charges the
    /// input's chords: h²/8R on a bend of radius R sampled every h).
    Frechet,
}

#[derive(clap::Args, Debug)]
pub struct CompressArgs {
    /// Input curve file.
    pub input: std::path::PathBuf,
    /// Output container (.sfh). Written atomically.
    #[arg(short, long)]
    pub output: std::path::PathBuf,
    /// Fewest elements per curve within this distance (input units).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Exactly N elements per curve.
    #[arg(short = 'n', long)]
    pub elements: Option<usize>,
    /// About one element per this arc length.
    #[arg(long)]
    pub element_length: Option<f64>,
    /// How parameters are stored.
    #[arg(long, value_enum, default_value_t = StorageArg::Compact)]
    pub storage: StorageArg,
    /// The distance --tolerance is measured in. `hausdorff` writes a
    /// version-3 container (the arc codec); `ordered` and `frechet`, and
    /// --elements, --element-length and --storage f32|f64, write version 1
    /// (helix chains).
    #[arg(long, value_enum, default_value_t = DistanceArg::Hausdorff)]
    pub distance: DistanceArg,
    /// How hard the arc codec searches for a smaller file (same format and
    /// guarantee): `best` also chooses each arc looking one arc ahead and
    /// keeps each block's smaller coding, about 3x the time (field lines and
    /// the fornix 0.5-3 % smaller, points-coded bundles the same; never
    /// larger).
    #[arg(long, value_enum, default_value_t = EffortArg::Default)]
    pub effort: EffortArg,
    /// Cap on elements per curve.
    #[arg(long, default_value_t = 4096)]
    pub max_elements: usize,
    /// Share of the tolerance the helix fit may use; the rest is left to
    /// quantisation (compact storage).
    #[arg(long, default_value_t = 0.95)]
    pub fit_share: f64,
    /// Share of the fit's tolerance the smoothing spline may use.
    #[arg(long, default_value_t = 0.5)]
    pub smoothing_share: f64,
    /// Input format (default: from the extension).
    #[arg(long)]
    pub from: Option<String>,
    /// Print a machine-readable report (ratio, distances, curves/s) on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub care: CareArgs,
    /// The codec's candidate checks run on the GPU only with --backend gpu
    /// (auto keeps compress on the CPU: docs/reference.md, "Backends").
    #[command(flatten)]
    pub engine: BackendArgs,
}

/// What to do with bad curves and with data the output cannot hold.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct CareArgs {
    /// Leave out curves holding a point that is not finite or beyond the
    /// float32 range, and report their indices (default: such a curve is an
    /// error naming the file, the curve and the point).
    #[arg(long)]
    pub skip_bad: bool,
    /// Treat data that would be dropped (per-point or per-curve values the
    /// output cannot hold, source content the reader does not carry) as an
    /// error instead of a warning.
    #[arg(long)]
    pub strict: bool,
}

#[derive(clap::Args, Debug)]
pub struct DecompressArgs {
    /// Input container (.sfh).
    pub input: std::path::PathBuf,
    /// Output curve file. Written atomically.
    #[arg(short, long)]
    pub output: std::path::PathBuf,
    /// Sample each curve every S (input units) along its arc length. For a
    /// version-3 container this gives up the tolerance guarantee (which is
    /// about the default points), and says so.
    #[arg(long, conflicts_with = "points")]
    pub step: Option<f64>,
    /// Sample each curve at M points equally spaced in arc length (default:
    /// version 3, the points the tolerance is guaranteed for; version 1, as
    /// many as the input had). Gives up a version-2 guarantee, and says so.
    #[arg(short = 'm', long)]
    pub points: Option<usize>,
    /// Output format (default: from the extension).
    #[arg(long)]
    pub to: Option<String>,
    /// Only curves A to B (0-based, B excluded; `A:` to the end, `:B` from
    /// the start): only the blocks that hold them are read (version 3).
    #[arg(long, value_parser = parse_range)]
    pub curves: Option<(Option<u64>, Option<u64>)>,
    /// Treat per-curve data the output format cannot hold as an error
    /// instead of a warning.
    #[arg(long)]
    pub strict: bool,
    /// Machine-readable report on standard output (curves, points, bytes,
    /// whether the tolerance guarantee holds, points/s).
    #[arg(long)]
    pub json: bool,
}

/// `A:B`, `A:` or `:B` (curve indices).
fn parse_range(s: &str) -> Result<(Option<u64>, Option<u64>), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("{s:?}: expected A:B (curve indices, B excluded)"))?;
    let num = |t: &str| -> Result<Option<u64>, String> {
        if t.is_empty() {
            Ok(None)
        } else {
            t.trim()
                .parse()
                .map(Some)
                .map_err(|_| format!("{t:?} is not a curve index"))
        }
    };
    let (a, b) = (num(a)?, num(b)?);
    if let (Some(a), Some(b)) = (a, b) {
        if b < a {
            return Err(format!("{s:?}: the range ends before it starts"));
        }
    }
    Ok((a, b))
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum CompleteMethod {
    /// 3D Euler spirals (curvature and torsion linear in arc length).
    Euler,
    /// Algebraic–trigonometric PH curves (polynomial speed; closed form; an
    /// arc length can be prescribed).
    Atph,
}

#[derive(clap::Args, Debug)]
pub struct CompleteArgs {
    /// Input JSON file ("-" or absent: standard input).
    pub input: Option<std::path::PathBuf>,
    /// Output JSON file (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<std::path::PathBuf>,
    /// Construction.
    #[arg(long, value_enum, default_value_t = CompleteMethod::Euler)]
    pub method: CompleteMethod,
    /// ATPH only: prescribe this arc length for every pair (a pair's own
    /// "length" in the input takes precedence).
    #[arg(long)]
    pub length: Option<f64>,
    /// Also write M points per curve, ends included (0: none).
    #[arg(short = 'm', long, default_value_t = 0)]
    pub points: usize,
    #[command(flatten)]
    pub engine: BackendArgs,
}

#[derive(clap::Args, Debug)]
pub struct MotionArgs {
    /// Input: one JSON stream, or JSON Lines (one stream per line) with
    /// --lines or a .jsonl/.ndjson name ("-" or absent: standard input).
    pub input: Option<PathBuf>,
    /// Output JSON (JSON Lines for JSON Lines input; absent: standard
    /// output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write M samples (position, f1, f2, f3) per stream, equally
    /// spaced in the chord-length parameter, ends included (0: none).
    #[arg(short = 'm', long, default_value_t = 0)]
    pub points: usize,
    /// Read and write JSON Lines, one stream per line.
    #[arg(long)]
    pub lines: bool,
    /// Also write the paths with their frames as a legacy VTK POLYDATA file
    /// (for ParaView): --points points per stream, or 20 per segment.
    #[arg(long)]
    pub vtk: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct SketchArgs {
    /// The drawing: .json ([[x,y],...] or {"points":[...]}), .csv/.txt
    /// (x,y per line) or .svg (first path, polyline or polygon).
    pub input: PathBuf,
    /// Output JSON (absent: standard output). Written atomically.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// E_max, the coverage threshold, as a fraction of the drawing's length
    /// [default: 0.1 %, or 5 times the noise the drawing shows if larger].
    #[arg(long)]
    pub emax: Option<f64>,
    /// Weight of tangent continuity in the fine fitting, in [0, 1).
    #[arg(long = "alpha-t", default_value_t = 0.5)]
    pub alpha_t: f64,
    /// Also write an SVG of the drawing with the projected fit over it.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Also re-fit the lifted curve exactly G1 with the floating-tangents
    /// fitter (the paper's result has gaps at its junctions), reporting how
    /// far its projection moves from the drawing.
    #[arg(long)]
    pub g1: bool,
    /// Tolerance of the G1 re-fit, in the drawing's units (default: E_max
    /// times the drawing's length).
    #[arg(long = "g1-tolerance", requires = "g1")]
    pub g1_tolerance: Option<f64>,
    /// How an unevenly sampled drawing (edges more than 3x apart) is evened
    /// out: split its long edges along a spline, keeping every drawn vertex,
    /// or the paper's uniform resampling (corners between samples are cut).
    #[arg(long, value_enum, default_value_t = ResampleArg::Densify)]
    pub resample: ResampleArg,
    /// Fit the drawn vertices as they are, even where the drawing is
    /// noisy (by default a drawing whose noise is over 3e-6 of its length
    /// is denoised first, keeping its corners).
    #[arg(long = "no-denoise")]
    pub no_denoise: bool,
}

/// See [`crate::sketch::Resampling`].
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum ResampleArg {
    Densify,
    Uniform,
}

#[derive(clap::Args, Debug)]
pub struct SplitArgs {
    /// The container to split.
    pub input: PathBuf,
    /// Curves per shard at most, rounded down to whole blocks (4,096 curves
    /// each); every shard holds at least one block.
    #[arg(long)]
    pub curves_per_shard: u64,
    /// Folder for the shards (made if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Machine-readable report on standard output.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The containers to join, in order.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The joined container. Written atomically.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Machine-readable report on standard output.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// The file to inspect.
    pub input: PathBuf,
    /// With a .sfh container (version 3): draw its decoded curves over
    /// those of --source in three orthographic views, coloured by the
    /// local error, as an SVG picture.
    #[arg(long, requires = "source")]
    pub preview: Option<PathBuf>,
    /// The file the container was compressed from (for --preview).
    #[arg(long, requires = "preview")]
    pub source: Option<PathBuf>,
    /// Curves drawn by --preview at most (the first ones).
    #[arg(long, default_value_t = 2000)]
    pub preview_curves: u64,
    /// Input format (default: from the extension): tck, trk, trx, vtk, hair, json, csv.
    #[arg(long)]
    pub from: Option<String>,
    /// Machine-readable report on standard output.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// Input file.
    pub input: PathBuf,
    /// Output file. Written atomically.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Input format (default: from the extension).
    #[arg(long)]
    pub from: Option<String>,
    /// Output format (default: from the extension).
    #[arg(long)]
    pub to: Option<String>,
    /// Machine-readable report on standard output (curves, points, data
    /// carried and dropped).
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub care: CareArgs,
}

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Number of synthetic splines.
    #[arg(long, default_value_t = 20_000)]
    pub splines: usize,
    /// Helix elements per curve.
    #[arg(short = 'n', long, default_value_t = 20)]
    pub elements: usize,
    /// Cubic segments per synthetic spline.
    #[arg(long, default_value_t = 8)]
    pub segments: usize,
    /// Timed repetitions (the best is reported with the median).
    #[arg(long, default_value_t = 5)]
    pub repeat: usize,
    /// Machine-readable report on standard output (one row per stage)
    /// instead of the table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub engine: BackendArgs,
}

/// Run the command line; returns the process exit code.
/// A process ended by a signal runs no destructors, so the temporaries of
/// unfinished outputs (`.strandfit-*.tmp` next to each output) are deleted
/// here before it exits with the shell's 128 + signal code; a panic deletes
/// them too (unwinding would, but a panic in a thread may not reach it).
fn clean_up_on_signals_and_panics() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
            Ok(mut signals) => {
                std::thread::spawn(move || {
                    if let Some(sig) = signals.forever().next() {
                        crate::io::remove_unfinished_outputs();
                        std::process::exit(128 + sig);
                    }
                });
            }
            Err(e) => eprintln!("warning: cannot handle signals ({e}): an interrupted run may leave .strandfit-*.tmp files"),
        }
    }
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        crate::io::remove_unfinished_outputs();
        default_hook(info);
    }));
}

pub fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so writing to a closed pipe (`| head`) is an
    // error that println! turns into a panic. Restore the Unix default: the
    // process ends silently, as `cat` would.
    #[cfg(unix)]
    // SAFETY: setting a signal disposition to SIG_DFL at start-up, before
    // any thread exists, has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    clean_up_on_signals_and_panics();
    let cli = {
        use clap::FromArgMatches;
        let matches = command().get_matches();
        Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
    };
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build_global()
        {
            eprintln!("error: cannot start {n} threads: {e}");
            return ExitCode::FAILURE;
        }
    }
    let result = match &cli.command {
        Command::Helix(a) => a.engine.open().and_then(|b| helix_cmd::run(a, &b)),
        Command::Fit(a) => a.engine.open().and_then(|b| fit_cmd::run(a, &b)),
        Command::Sample(a) => a.engine.open().and_then(|b| sample_cmd::run(a, &b)),
        Command::Evaluate(a) => a.engine.open().and_then(|b| evaluate_cmd::run(a, &b)),
        Command::Integrate(a) => a.engine.open().and_then(|b| integrate_cmd::run(a, &b)),
        Command::Complete(a) => a.engine.open().and_then(|b| complete_cmd::run(a, &b)),
        Command::Motion(a) => motion_cmd::run(a),
        Command::Sketch(a) => sketch_cmd::run(a),
        // The codec's checks run on the GPU only when asked for: its GPU
        // path gives the same bytes but is not yet measured faster than the
        // CPU's (docs/reference.md, "Backends"), so auto keeps compress on the CPU.
        Command::Compress(a) if a.engine.backend == BackendArg::Gpu => {
            a.engine.open().and_then(|b| compress_cmd::run(a, &b))
        }
        Command::Compress(a) => compress_cmd::run(a, &Backend::Cpu),
        Command::Decompress(a) => decompress_cmd::run(a),
        Command::Inspect(a) => inspect_cmd::run(a),
        Command::Convert(a) => convert_cmd::run(a),
        Command::Split(a) => shards_cmd::split(a),
        Command::Merge(a) => shards_cmd::merge(a),
        Command::Bench(a) => bench_cmd::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<UsageError>().is_some() => {
            eprintln!("error: {e:#}\n\nFor more information, try '--help'.");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
