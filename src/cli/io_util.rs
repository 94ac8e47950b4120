//! Input from a file or standard input; output written atomically.

use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Read, Write};
use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::io::AtomicFile;
use rayon::prelude::*;
use serde::Serialize;

/// Display name of an input ("<stdin>" for standard input).
pub fn input_name(path: &Option<PathBuf>) -> String {
    match path {
        Some(p) if p.as_os_str() != "-" => p.display().to_string(),
        _ => "<stdin>".to_string(),
    }
}

/// Open an input for buffered reading.
pub fn open_input(path: &Option<PathBuf>) -> Result<Box<dyn BufRead>> {
    match path {
        Some(p) if p.as_os_str() != "-" => {
            let f = File::open(p).with_context(|| format!("cannot open {}", p.display()))?;
            Ok(Box::new(BufReader::new(f)))
        }
        _ => Ok(Box::new(BufReader::new(io::stdin()))),
    }
}

/// Read a whole input into a string.
pub fn read_input(path: &Option<PathBuf>) -> Result<String> {
    let mut s = String::new();
    open_input(path)?
        .read_to_string(&mut s)
        .with_context(|| format!("cannot read {}", input_name(path)))?;
    Ok(s)
}

/// An output sink: standard output, or an [`AtomicFile`] (a temporary file
/// next to the target, renamed over it only by [`Output::commit`]) — so a
/// failed run never leaves a partial or truncated output file behind.
pub enum Output {
    Stdout(BufWriter<io::Stdout>),
    File(AtomicFile),
}

impl Output {
    pub fn create(path: &Option<PathBuf>) -> Result<Output> {
        Ok(match path {
            Some(p) if p.as_os_str() != "-" => Output::File(AtomicFile::create(p)?),
            _ => Output::Stdout(BufWriter::new(io::stdout())),
        })
    }

    pub fn writer(&mut self) -> &mut dyn Write {
        match self {
            Output::Stdout(w) => w,
            Output::File(f) => f,
        }
    }

    /// Flush, and for a file sync and move it into place.
    pub fn commit(self) -> Result<()> {
        match self {
            Output::Stdout(mut w) => w.flush().context("cannot write output")?,
            Output::File(f) => f.commit()?,
        }
        Ok(())
    }
}

/// How an item of a JSON document is named in messages: `spline "a"
/// (splines[3])` by its id, or `splines[3]` when it has none (or its id is
/// its index, as absent ids become).
pub fn label(kind: &str, array: &str, index: usize, id: &serde_json::Value) -> String {
    match id {
        serde_json::Value::String(s) => format!("{kind} \"{s}\" ({array}[{index}])"),
        serde_json::Value::Null => format!("{array}[{index}]"),
        v if v.as_u64() == Some(index as u64) => format!("{array}[{index}]"),
        v => format!("{kind} {v} ({array}[{index}])"),
    }
}

/// Lines processed per parallel batch by [`map_json_lines`]: bounds memory
/// for any input size.
const JSONL_CHUNK: usize = 1 << 16;

#[derive(Serialize)]
struct Failure {
    failure: String,
}

/// One answer per input line, in order, for a JSON Lines input: each batch
/// of lines is parsed in parallel, the records that parsed go to `solve`
/// together (which returns one result per record, in order), and every
/// line gets its answer or a `{"version":1,"failure":"line K: …"}` object. A bad line
/// never stops the others; the output is committed only at the end.
pub fn map_json_lines<P, A>(
    input: &Option<PathBuf>,
    output: &Option<PathBuf>,
    parse: impl Fn(&str) -> Result<P, String> + Sync,
    mut solve: impl FnMut(&[P]) -> Result<Vec<Result<A, String>>>,
) -> Result<()>
where
    P: Clone + Send,
    A: Serialize + Send,
{
    let name = input_name(input);
    let mut reader = open_input(input)?;
    let mut out = Output::create(output)?;
    let mut lines: Vec<String> = Vec::with_capacity(JSONL_CHUNK);
    let mut line_no = 0usize;
    loop {
        lines.clear();
        for _ in 0..JSONL_CHUNK {
            let mut s = String::new();
            let n = reader.read_line(&mut s).with_context(|| {
                format!("{name}: cannot read line {}", line_no + lines.len() + 1)
            })?;
            if n == 0 {
                break;
            }
            lines.push(s);
        }
        if lines.is_empty() {
            break;
        }
        let first = line_no + 1;
        let parsed: Vec<Result<P, String>> = lines
            .par_iter()
            .map(|line| {
                let line = line.trim_end_matches(['\n', '\r']);
                if line.trim().is_empty() {
                    Err("empty line".into())
                } else {
                    parse(line)
                }
            })
            .collect();
        let records: Vec<P> = parsed
            .iter()
            .filter_map(|p| p.as_ref().ok())
            .cloned()
            .collect();
        let mut answers = solve(&records)?.into_iter();
        let solved: Vec<Result<A, String>> = parsed
            .into_iter()
            .map(|p| {
                p.and_then(|_| {
                    answers
                        .next()
                        .unwrap_or_else(|| Err("internal error: missing result".into()))
                })
            })
            .collect();
        let json: Vec<String> = solved
            .into_par_iter()
            .enumerate()
            .map(|(k, r)| to_json(r, first + k))
            .collect();
        let w = out.writer();
        for a in &json {
            w.write_all(a.as_bytes())?;
            w.write_all(b"\n")?;
        }
        line_no += lines.len();
    }
    out.commit()
}

fn to_json<A: Serialize>(result: Result<A, String>, line_no: usize) -> String {
    let json = match result {
        Ok(a) => serde_json::to_string(&super::versioned(&a)),
        Err(reason) => serde_json::to_string(&super::versioned(&Failure {
            failure: format!("line {line_no}: {reason}"),
        })),
    };
    json.unwrap_or_else(|e| {
        format!(
            "{{\"version\":{},\"failure\":\"line {line_no}: cannot serialise: {e}\"}}",
            super::JSON_VERSION
        )
    })
}

/// Report what a run drops (see `io::Format::losses`, `io::source_losses`)
/// before anything is written: with `strict` an error, else one warning a
/// line on stderr.
pub fn check_losses(
    input: &std::path::Path,
    output: &std::path::Path,
    losses: &[String],
    strict: bool,
) -> Result<()> {
    if losses.is_empty() {
        return Ok(());
    }
    if strict {
        anyhow::bail!(
            "{}: writing {} would drop {} (--strict)",
            input.display(),
            output.display(),
            losses.join("; ")
        );
    }
    for l in losses {
        eprintln!(
            "warning: {}: dropped {l}; --strict makes this an error",
            input.display()
        );
    }
    Ok(())
}

/// Report the curves `--skip-bad` left out: how many, and the first few
/// with their reasons (all indices go to the JSON reports).
pub fn report_skipped(input: &std::path::Path, skipped: &[crate::io::SkippedCurve]) {
    if skipped.is_empty() {
        return;
    }
    eprintln!(
        "warning: {}: left out {} curve(s) with unusable points (--skip-bad):",
        input.display(),
        skipped.len()
    );
    for s in skipped.iter().take(10) {
        eprintln!("  curve {}: {}", s.index, s.reason);
    }
    if skipped.len() > 10 {
        eprintln!("  … and {} more", skipped.len() - 10);
    }
}

/// Run `f` with the process's standard error (file descriptor 2) sent to
/// /dev/null, for chatter from C libraries (the Vulkan loader) that Rust
/// cannot catch; restored afterwards. Elsewhere than Unix, just `f()`.
pub fn with_stderr_hidden<T>(f: impl FnOnce() -> T) -> T {
    #[cfg(unix)]
    {
        // SAFETY: plain descriptor calls on fd 2 and on descriptors this
        // function opens and closes itself; on any failure nothing is
        // redirected and `f` runs as it is.
        unsafe {
            let saved = libc::dup(2);
            let null = libc::open(c"/dev/null".as_ptr(), libc::O_WRONLY);
            if saved >= 0 && null >= 0 && libc::dup2(null, 2) >= 0 {
                libc::close(null);
                let out = f();
                libc::dup2(saved, 2);
                libc::close(saved);
                return out;
            }
            if null >= 0 {
                libc::close(null);
            }
            if saved >= 0 {
                libc::close(saved);
            }
        }
    }
    f()
}

/// A curve of `input` that the output's writer refused: named by its index
/// in the input (the `kept`-th curve read, counting past the curves
/// `--skip-bad` left out), since the input is what a user can go and fix.
pub fn write_failed(
    input: &std::path::Path,
    kept: u64,
    skipped: &[crate::io::SkippedCurve],
    e: crate::io::IoError,
) -> anyhow::Error {
    let mut index = kept;
    for s in skipped {
        if s.index <= index {
            index += 1;
        } else {
            break;
        }
    }
    anyhow::anyhow!("{}, curve {index}: cannot be written: {e}", input.display())
}

/// A progress bar on stderr that appears only once a job has run for a
/// second, and only when stderr is a terminal (indicatif's stderr target
/// draws nothing otherwise): short runs and logs stay clean.
pub struct DelayedBar {
    bar: indicatif::ProgressBar,
    started: std::time::Instant,
    shown: bool,
}

impl DelayedBar {
    /// A bar over `count` curves (a spinner when the count is unknown).
    pub fn new(count: Option<u64>) -> Self {
        let bar = match count {
            Some(n) => indicatif::ProgressBar::with_draw_target(
                Some(n),
                indicatif::ProgressDrawTarget::hidden(),
            ),
            None => indicatif::ProgressBar::hidden(),
        };
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {pos}/{len} curves {per_sec} eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        DelayedBar {
            bar,
            started: std::time::Instant::now(),
            shown: false,
        }
    }

    /// `n` curves done.
    pub fn set(&mut self, n: u64) {
        if !self.shown && self.started.elapsed() >= std::time::Duration::from_secs(1) {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar.set_position(n);
    }

    pub fn finish(self) {
        self.bar.finish_and_clear();
    }
}

/// The names of `meta`'s per-point and per-curve values that a writer of
/// `target` keeps (the others are in [`crate::io::Format::losses`]).
pub fn carried_data(
    meta: &crate::io::Metadata,
    target: crate::io::Format,
) -> (Vec<String>, Vec<String>) {
    let point = meta
        .point_data_names
        .iter()
        .filter(|n| target.keeps_point_data(n))
        .cloned()
        .collect();
    let curve = if target.keeps_curve_data() {
        meta.curve_data_names.clone()
    } else {
        Vec::new()
    };
    (point, curve)
}

#[derive(Serialize)]
struct RunFailure {
    version: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    input: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    output: Option<String>,
    failure: String,
}

/// `--json` for a run that failed (exit status 1): `{"version", "input",
/// "output", "failure"}` on standard output (`input` and `output` when the
/// command has them), the failure as it is also written on stderr; then
/// the error itself. A usage error (exit status 2) writes nothing, as
/// without `--json`.
pub fn failure_report(
    result: Result<()>,
    json: bool,
    input: Option<&std::path::Path>,
    output: Option<&std::path::Path>,
) -> Result<()> {
    if let Err(e) = &result {
        if json && e.downcast_ref::<super::UsageError>().is_none() {
            let doc = RunFailure {
                version: super::JSON_VERSION,
                input: input.map(|p| p.display().to_string()),
                output: output.map(|p| p.display().to_string()),
                failure: format!("{e:#}"),
            };
            println!("{}", serde_json::to_string_pretty(&doc)?);
        }
    }
    result
}

/// The bytes of a file, or of the files in a folder (a TRX folder), at
/// any depth; 0 when it cannot be read.
pub fn size_on_disk(path: &std::path::Path) -> u64 {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => std::fs::read_dir(path)
            .map(|entries| {
                entries
                    .filter_map(|e| e.ok())
                    .map(|e| size_on_disk(&e.path()))
                    .sum()
            })
            .unwrap_or(0),
        Ok(m) => m.len(),
        Err(_) => 0,
    }
}
