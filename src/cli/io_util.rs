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
    error: String,
}

/// One answer per input line, in order, for a JSON Lines input: each batch
/// of lines is parsed in parallel, the records that parsed go to `solve`
/// together (which returns one result per record, in order), and every
/// line gets its answer or an `{"error":"line K: …"}` object. A bad line
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
        Ok(a) => serde_json::to_string(&a),
        Err(reason) => serde_json::to_string(&Failure {
            error: format!("line {line_no}: {reason}"),
        }),
    };
    json.unwrap_or_else(|e| format!("{{\"error\":\"line {line_no}: cannot serialise: {e}\"}}"))
}
