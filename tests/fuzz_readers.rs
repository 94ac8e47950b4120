//! Fuzzing that stays (issue 18, part 7): every reader and the `.sfh`
//! container decoder, run on the committed seed corpus `tests/fuzz/corpus/`
//! and on a bounded, deterministic set of mutations of each seed.
//!
//! For every input the oracle (`tests/fuzz/oracle.rs`, shared with the
//! cargo-fuzz targets in `fuzz/`) asserts: no panic; an error names the
//! file; a curve read has only finite points within float32's range, and
//! per-point/per-curve values that match the metadata; a container chain
//! samples to finite points. This file adds: no read hangs (a watchdog), no
//! read takes absurd memory (a counting allocator: no single allocation over
//! [`HARD_ALLOC`], no read peaking over [`PEAK_LIMIT`]), and the `huge_*`
//! seeds, whose headers announce 2^32 curves or points, are errors.
//!
//! Mutations: truncations, bit flips, bytes and 2/4/8-byte words set to
//! interesting values (0, 0xFF, 0x7F, 0x80, f16/f32/f64 NaN/±Inf/huge,
//! u32::MAX, i32::MIN, …) in either byte order, chunks duplicated, deleted
//! or inserted; in text (the `.tck` header, VTK, JSON, CSV, TRX's
//! `header.json`, the container's header) numbers replaced by `nan`, `inf`,
//! `1e300`, `-0`, huge integers, syntax characters deleted or inserted,
//! keywords swapped, lines duplicated or dropped. Containers and TRX zips
//! are also mutated inside: the container's inflated blocks and header with
//! fresh CRCs (else nearly every mutation stops at a checksum), the TRX
//! entries (values, sizes, names, dtypes) re-zipped.
//!
//! Every case is reproducible on its own: its mutations come from a ChaCha8
//! generator seeded by the seed file's name and the case number, and a
//! finding names the reader, the seed file, the case and the mutations.
//!
//! Environment:
//! - `STRANDFIT_FUZZ_ITERS=N`: mutated cases per seed (default
//!   [`DEFAULT_ITERS`], ~9 s unoptimised on 2 cores; the budget is 20 s).
//! - `STRANDFIT_FUZZ_ONLY=tck/simple.tck` or `tck/simple.tck#37`: one seed,
//!   or one case of it.
//! - `STRANDFIT_FUZZ_SAVE=DIR`: write every input with a finding to DIR.
//! - `STRANDFIT_FUZZ_VERBOSE=1`: print every case and its outcome.
//! - `STRANDFIT_FUZZ_RAW=1` (diagnostic): read with each format's own
//!   `open` instead of `io::read_all`, i.e. without the point check that
//!   `io::open_reader` adds for every reader, to see what a reader would
//!   hand out on its own. Findings there are expected where a reader leaves
//!   the check to `open_reader`.

#[path = "fuzz/oracle.rs"]
mod oracle;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::{Cell, RefCell};
use std::io::{Cursor, Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use oracle::{Bug, Outcome, Target};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::io::{Curve, Format, IoError, Metadata};

/// Mutated cases per seed file by default. About 140 seeds: ~27,000 reads
/// in all, ~9 s on 2 cores unoptimised (see `tests/fuzz/README.md`).
const DEFAULT_ITERS: u64 = 192;
/// No read of these small inputs needs more than this at its peak.
const PEAK_LIMIT: usize = 64 << 20;
/// A single allocation above this is refused (the test then aborts, after
/// printing the case): a header count sized it.
const HARD_ALLOC: usize = 1 << 30;
/// A read taking longer than this is a hang.
const WATCHDOG: Duration = Duration::from_secs(30);
/// Largest mutated input (mutations that grow a file stop here).
const MAX_INPUT: usize = 64 << 10;

// ---------------------------------------------------------------------------
// Memory: a counting allocator, per thread

struct Counting;

thread_local! {
    /// Bytes allocated minus bytes freed on this thread, and the peak of it
    /// since the last reset.
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
    /// The case this thread is reading, for the abort message.
    static CASE: Cell<[u8; 160]> = const { Cell::new([0; 160]) };
}

fn count(delta: isize) {
    let _ = LIVE.try_with(|l| {
        let v = l.get().wrapping_add(delta);
        l.set(v);
        let _ = PEAK.try_with(|p| {
            if v > p.get() {
                p.set(v)
            }
        });
    });
}

fn refuse(size: usize) {
    // No allocation here: a fixed buffer and a raw write to stderr.
    let case = CASE.try_with(|c| c.get()).unwrap_or([0; 160]);
    let end = case.iter().position(|&b| b == 0).unwrap_or(case.len());
    let mut msg = [0u8; 400];
    let mut n = 0;
    for part in [
        &b"\nfuzz_readers: ABSURD ALLOCATION of "[..],
        format_usize(size).as_slice(),
        b" bytes refused while reading ",
        &case[..end],
        b" (a header count sized an allocation)\n",
    ] {
        let part = &part[..part.len().min(msg.len() - n)];
        msg[n..n + part.len()].copy_from_slice(part);
        n += part.len();
    }
    let _ = std::io::stderr().write_all(&msg[..n]);
}

fn format_usize(mut v: usize) -> Vec<u8> {
    // Only called on the refusal path, where one small allocation is fine.
    let mut d = Vec::with_capacity(24);
    loop {
        d.push(b'0' + (v % 10) as u8);
        v /= 10;
        if v == 0 {
            break;
        }
    }
    d.reverse();
    d
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_ALLOC {
            refuse(layout.size());
            return std::ptr::null_mut();
        }
        let p = System.alloc(layout);
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_ALLOC {
            refuse(layout.size());
            return std::ptr::null_mut();
        }
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        count(-(layout.size() as isize));
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > HARD_ALLOC {
            refuse(new_size);
            return std::ptr::null_mut();
        }
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

// ---------------------------------------------------------------------------
// Panics: where, for the report

thread_local! {
    static IN_ORACLE: Cell<bool> = const { Cell::new(false) };
    static LAST_PANIC: RefCell<String> = const { RefCell::new(String::new()) };
}

/// Panics inside the oracle are recorded (with their location) instead of
/// printed; all others go to the default hook.
fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_ORACLE.with(Cell::get) {
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                LAST_PANIC.with(|p| *p.borrow_mut() = at);
            } else {
                default(info)
            }
        }));
    });
}

// ---------------------------------------------------------------------------
// One read, on a worker thread with a watchdog

struct Done {
    result: Result<Outcome, Bug>,
    peak: usize,
}

struct Worker {
    jobs: mpsc::Sender<(PathBuf, Target, String)>,
    done: mpsc::Receiver<Done>,
}

impl Worker {
    fn new() -> Self {
        install_panic_hook();
        let (jobs, job_rx) = mpsc::channel::<(PathBuf, Target, String)>();
        let (done_tx, done) = mpsc::channel();
        std::thread::spawn(move || {
            for (path, target, label) in job_rx {
                let mut case = [0u8; 160];
                let n = label.len().min(159);
                case[..n].copy_from_slice(&label.as_bytes()[..n]);
                CASE.with(|c| c.set(case));
                IN_ORACLE.with(|f| f.set(true));
                let base = LIVE.with(Cell::get);
                PEAK.with(|p| p.set(base));
                let mut result = match (target, raw()) {
                    (Target::Reader(f), true) => {
                        oracle::guarded(|| oracle::judge_read(&path, raw_read(&path, f)))
                    }
                    _ => oracle::check(&path, target),
                };
                let peak = (PEAK.with(Cell::get) - base).max(0) as usize;
                IN_ORACLE.with(|f| f.set(false));
                if let Err(Bug::Panic(m)) = &mut result {
                    m.push_str(&LAST_PANIC.with(|p| p.take()));
                }
                if done_tx.send(Done { result, peak }).is_err() {
                    break;
                }
            }
        });
        Worker { jobs, done }
    }

    /// Read `path`; `None` when it did not finish within [`WATCHDOG`].
    fn read(&self, path: &Path, target: Target, label: &str) -> Option<Done> {
        self.jobs
            .send((path.to_path_buf(), target, label.to_string()))
            .unwrap();
        self.done.recv_timeout(WATCHDOG).ok()
    }
}

/// `STRANDFIT_FUZZ_RAW`: read without `io::open_reader`'s point check.
fn raw() -> bool {
    std::env::var_os("STRANDFIT_FUZZ_RAW").is_some()
}

/// A whole-file read with the format's own reader alone.
fn raw_read(path: &Path, f: Format) -> Result<(Metadata, Vec<Curve>), IoError> {
    use strandfit::io::{open_csv, open_hair, open_json, open_tck, open_trk, open_trx, open_vtk};
    let reader = match f {
        Format::Tck => open_tck(path),
        Format::Trk => open_trk(path),
        Format::Trx => open_trx(path),
        Format::Vtk => open_vtk(path),
        Format::Hair => open_hair(path),
        Format::Json => open_json(path),
        Format::Csv => open_csv(path),
    }?;
    let meta = reader.metadata().clone();
    let curves = reader.collect::<Result<Vec<_>, _>>()?;
    Ok((meta, curves))
}

// ---------------------------------------------------------------------------
// The corpus

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz/corpus")
}

/// The seeds of `target`: (`format/name`, bytes), sorted by name.
fn seeds(target: Target) -> Vec<(String, Vec<u8>)> {
    let dir = corpus_dir().join(target.name());
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = format!(
                "{}/{}",
                target.name(),
                p.file_name().unwrap().to_string_lossy()
            );
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    v.sort();
    v
}

/// `STRANDFIT_FUZZ_ONLY`: a seed name and maybe a case.
fn only() -> Option<(String, Option<u64>)> {
    let s = std::env::var("STRANDFIT_FUZZ_ONLY").ok()?;
    Some(match s.split_once('#') {
        Some((name, case)) => (name.to_string(), Some(case.parse().expect("case number"))),
        None => (s, None),
    })
}

fn iters() -> u64 {
    std::env::var("STRANDFIT_FUZZ_ITERS")
        .ok()
        .map(|s| {
            s.parse()
                .expect("STRANDFIT_FUZZ_ITERS: a number of cases per seed")
        })
        .unwrap_or(DEFAULT_ITERS)
}

/// FNV-1a: a stable seed from the seed file's name.
fn name_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

// ---------------------------------------------------------------------------
// Byte-level mutations

const BYTES: [u8; 8] = [0x00, 0xFF, 0x7F, 0x80, 0x01, 0xFE, b'\n', b' '];

/// Interesting values of 2, 4 and 8 bytes (little endian; written in either
/// byte order).
fn words() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("f16 NaN", 0x7E00u16.to_le_bytes().to_vec()),
        ("f16 +Inf", 0x7C00u16.to_le_bytes().to_vec()),
        ("f16 -Inf", 0xFC00u16.to_le_bytes().to_vec()),
        ("f16 max", 0x7BFFu16.to_le_bytes().to_vec()),
        ("u16::MAX", u16::MAX.to_le_bytes().to_vec()),
        ("f32 NaN", f32::NAN.to_le_bytes().to_vec()),
        ("f32 +Inf", f32::INFINITY.to_le_bytes().to_vec()),
        ("f32 -Inf", f32::NEG_INFINITY.to_le_bytes().to_vec()),
        ("f32 1e38", 1e38f32.to_le_bytes().to_vec()),
        ("f32 -3.4e38", (-3.4e38f32).to_le_bytes().to_vec()),
        ("f32 1e-45", 1e-45f32.to_le_bytes().to_vec()),
        ("u32::MAX", u32::MAX.to_le_bytes().to_vec()),
        ("i32::MIN", i32::MIN.to_le_bytes().to_vec()),
        ("i32::MAX", i32::MAX.to_le_bytes().to_vec()),
        ("u32 0", 0u32.to_le_bytes().to_vec()),
        ("u32 1", 1u32.to_le_bytes().to_vec()),
        ("u32 0x10000", 0x10000u32.to_le_bytes().to_vec()),
        ("f64 NaN", f64::NAN.to_le_bytes().to_vec()),
        ("f64 +Inf", f64::INFINITY.to_le_bytes().to_vec()),
        ("f64 -Inf", f64::NEG_INFINITY.to_le_bytes().to_vec()),
        ("f64 1e300", 1e300f64.to_le_bytes().to_vec()),
        ("f64 1e39", 1e39f64.to_le_bytes().to_vec()),
        ("u64::MAX", u64::MAX.to_le_bytes().to_vec()),
        ("u64 2^32", (1u64 << 32).to_le_bytes().to_vec()),
        ("i64::MIN", i64::MIN.to_le_bytes().to_vec()),
    ]
}

/// A position in `0..n`: half the time in a hot range, half the time
/// aligned to `align`.
fn pick(rng: &mut ChaCha8Rng, n: usize, hot: &[Range<usize>], align: usize) -> usize {
    if n == 0 {
        return 0;
    }
    let mut at = if !hot.is_empty() && rng.gen_bool(0.5) {
        let r = &hot[rng.gen_range(0..hot.len())];
        rng.gen_range(r.start..r.end.max(r.start + 1))
    } else {
        rng.gen_range(0..n)
    };
    if align > 1 && rng.gen_bool(0.5) {
        at -= at % align;
    }
    at.min(n - 1)
}

/// One byte-level mutation of `b`; returns what it did.
fn byte_mutation(
    rng: &mut ChaCha8Rng,
    b: &mut Vec<u8>,
    hot: &[Range<usize>],
    align: usize,
) -> String {
    let n = b.len();
    if n == 0 {
        let k = rng.gen_range(1..=16);
        let fill: Vec<u8> = (0..k).map(|_| rng.gen()).collect();
        b.extend_from_slice(&fill);
        return format!("insert {k} random bytes into the empty file");
    }
    match rng.gen_range(0..8) {
        0 => {
            let at = if rng.gen_bool(0.3) {
                rng.gen_range(0..n)
            } else {
                pick(rng, n, hot, 1)
            };
            b.truncate(at);
            format!("truncate to {at} bytes")
        }
        1 => {
            let at = pick(rng, n, hot, 1);
            let bit = rng.gen_range(0..8);
            b[at] ^= 1 << bit;
            format!("flip bit {bit} of byte {at}")
        }
        2 => {
            let at = pick(rng, n, hot, 1);
            let v = BYTES[rng.gen_range(0..BYTES.len())];
            b[at] = v;
            format!("byte {at} = {v:#04x}")
        }
        3 | 4 => {
            let ws = words();
            let (name, w) = &ws[rng.gen_range(0..ws.len())];
            let big = rng.gen_bool(0.5);
            let mut w = w.clone();
            if big {
                w.reverse();
            }
            let at = pick(rng, n, hot, align.max(w.len().min(4))).min(n.saturating_sub(w.len()));
            let end = (at + w.len()).min(n);
            b[at..end].copy_from_slice(&w[..end - at]);
            format!(
                "bytes {at}..{end} = {name} ({})",
                if big { "BE" } else { "LE" }
            )
        }
        5 => {
            let len = rng.gen_range(1..=n.min(64));
            let from = rng.gen_range(0..=n - len);
            let to = pick(rng, n, hot, 1);
            let chunk = b[from..from + len].to_vec();
            b.splice(to..to, chunk);
            format!("duplicate bytes {from}..{} at {to}", from + len)
        }
        6 => {
            let at = pick(rng, n, hot, 1);
            let len = rng.gen_range(1..=(n - at).min(64));
            b.drain(at..at + len);
            format!("delete bytes {at}..{}", at + len)
        }
        _ => {
            let at = pick(rng, n, hot, 1);
            let k = rng.gen_range(1..=8);
            let fill: Vec<u8> = (0..k)
                .map(|_| BYTES[rng.gen_range(0..BYTES.len())])
                .collect();
            b.splice(at..at, fill.iter().copied());
            format!("insert {fill:02x?} at {at}")
        }
    }
}

// ---------------------------------------------------------------------------
// Text mutations

const NUMBERS: [&str; 22] = [
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "1e300",
    "-1e300",
    "1e39",
    "3.5e38",
    "1e999",
    "1e-400",
    "-0",
    "0",
    "-1",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999999999",
    "0x10",
];

const SYNTAX: &[u8] = b",[]{}:\"\n -.";

fn dictionary(target: Target) -> &'static [&'static str] {
    match target {
        Target::Reader(Format::Tck) => &[
            "Float32LE",
            "Float32BE",
            "Float64LE",
            "Float64BE",
            "count",
            "datatype",
            "file",
            "END",
            "mrtrix tracks",
        ],
        Target::Reader(Format::Vtk) => &[
            "ASCII",
            "BINARY",
            "float",
            "double",
            "int",
            "unsigned_char",
            "vtktypeint64",
            "vtktypeint32",
            "POINTS",
            "LINES",
            "OFFSETS",
            "CONNECTIVITY",
            "VERTICES",
            "POLYGONS",
            "POINT_DATA",
            "CELL_DATA",
            "FIELD",
            "SCALARS",
            "VECTORS",
            "LOOKUP_TABLE",
            "METADATA",
            "string",
            "bit",
            "POLYDATA",
        ],
        Target::Reader(Format::Json) => &[
            "\"curves\"",
            "\"points\"",
            "\"id\"",
            "\"point_data\"",
            "\"curve_data\"",
            "\"units\"",
            "null",
            "true",
            "[]",
            "{}",
            "[[0,0,0]]",
        ],
        Target::Reader(Format::Csv) => &["curve", "x", "y", "z", "fa", ",", "\n"],
        Target::Reader(Format::Trx) => &[
            "NB_VERTICES",
            "NB_STREAMLINES",
            "VOXEL_TO_RASMM",
            "DIMENSIONS",
            "null",
            "[]",
        ],
        Target::Container => &[
            "compact",
            "f32",
            "f64",
            "storage",
            "curve_data_names",
            "vox_to_world",
            "null",
            "[]",
            "\"x\"",
        ],
        _ => &[],
    }
}

/// Spans of number-like tokens within `r`.
fn numbers(b: &[u8], r: Range<usize>) -> Vec<Range<usize>> {
    let is_tok = |c: u8| c.is_ascii_digit() || b"+-.eE".contains(&c);
    let mut out = Vec::new();
    let mut i = r.start;
    while i < r.end {
        if is_tok(b[i]) {
            let s = i;
            while i < r.end && is_tok(b[i]) {
                i += 1;
            }
            if b[s..i].iter().any(u8::is_ascii_digit) {
                out.push(s..i);
            }
        } else {
            i += 1;
        }
    }
    out
}

fn find_all(hay: &[u8], needle: &[u8]) -> Vec<usize> {
    if needle.is_empty() || hay.len() < needle.len() {
        return Vec::new();
    }
    hay.windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i)
        .collect()
}

/// One text mutation of `b` within `r`; `None` when it found nothing to do.
fn text_mutation(
    rng: &mut ChaCha8Rng,
    b: &mut Vec<u8>,
    r: Range<usize>,
    dict: &[&str],
) -> Option<String> {
    let r = r.start.min(b.len())..r.end.min(b.len());
    if r.is_empty() {
        return None;
    }
    match rng.gen_range(0..6) {
        0 | 1 => {
            let toks = numbers(b, r);
            if toks.is_empty() {
                return None;
            }
            let t = toks[rng.gen_range(0..toks.len())].clone();
            let new = NUMBERS[rng.gen_range(0..NUMBERS.len())];
            let old = String::from_utf8_lossy(&b[t.clone()]).into_owned();
            b.splice(t.clone(), new.bytes());
            Some(format!("number `{old}` at byte {} -> `{new}`", t.start))
        }
        2 => {
            let at: Vec<usize> = (r.clone()).filter(|&i| SYNTAX.contains(&b[i])).collect();
            if at.is_empty() {
                return None;
            }
            let i = at[rng.gen_range(0..at.len())];
            let c = b.remove(i);
            Some(format!("delete {:?} at byte {i}", c as char))
        }
        3 => {
            let i = rng.gen_range(r.clone());
            let c = SYNTAX[rng.gen_range(0..SYNTAX.len())];
            b.insert(i, c);
            Some(format!("insert {:?} at byte {i}", c as char))
        }
        4 => {
            if dict.is_empty() {
                return None;
            }
            let from = dict[rng.gen_range(0..dict.len())];
            let hits: Vec<usize> = find_all(&b[r.clone()], from.as_bytes())
                .into_iter()
                .map(|i| i + r.start)
                .collect();
            if hits.is_empty() {
                return None;
            }
            let at = hits[rng.gen_range(0..hits.len())];
            let to = dict[rng.gen_range(0..dict.len())];
            b.splice(at..at + from.len(), to.bytes());
            Some(format!("keyword `{from}` at byte {at} -> `{to}`"))
        }
        _ => {
            // Lines within r: duplicate or drop one.
            let mut starts = vec![r.start];
            starts.extend((r.clone()).filter(|&i| b[i] == b'\n').map(|i| i + 1));
            starts.retain(|&s| s < r.end);
            let s = starts[rng.gen_range(0..starts.len())];
            let e = b[s..r.end]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(r.end, |k| s + k + 1);
            if rng.gen_bool(0.5) {
                let line = b[s..e].to_vec();
                b.splice(e..e, line);
                Some(format!("duplicate the line at bytes {s}..{e}"))
            } else {
                b.drain(s..e);
                Some(format!("drop the line at bytes {s}..{e}"))
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Where each format keeps its structure

/// The byte ranges holding structure rather than bulk values.
fn hot(target: Target, b: &[u8]) -> Vec<Range<usize>> {
    let n = b.len();
    let cap = |r: Range<usize>| r.start.min(n)..r.end.min(n);
    let mut v = Vec::new();
    match target {
        Target::Reader(Format::Tck) => {
            let end = find_all(b, b"END\n").first().map_or(n.min(200), |&e| e + 4);
            v.push(cap(0..end));
            v.push(cap(end..end + 48));
            v.push(cap(n.saturating_sub(24)..n));
        }
        Target::Reader(Format::Trk) => {
            v.push(cap(0..1000));
            v.push(cap(980..1100));
            v.push(cap(n.saturating_sub(32)..n));
        }
        Target::Reader(Format::Hair) => v.push(cap(0..200)),
        Target::Reader(Format::Vtk) => {
            v.push(cap(0..160));
            for kw in dictionary(target) {
                for at in find_all(b, kw.as_bytes()) {
                    v.push(cap(at.saturating_sub(8)..at + 48));
                }
            }
        }
        Target::Reader(Format::Trx) => {
            for sig in [&b"PK\x03\x04"[..], b"PK\x01\x02", b"PK\x05\x06"] {
                for at in find_all(b, sig) {
                    v.push(cap(at..at + 46));
                }
            }
        }
        Target::Container => {
            v.push(cap(0..28));
            for sig in [&b"SFHB"[..], b"SFHE"] {
                for at in find_all(b, sig) {
                    v.push(cap(at..at + 24));
                }
            }
        }
        _ => {}
    }
    v.retain(|r| !r.is_empty());
    v
}

/// Where text mutations apply.
fn text_part(target: Target, b: &[u8]) -> Option<Range<usize>> {
    match target {
        Target::Reader(Format::Tck) => Some(
            0..find_all(b, b"END\n")
                .first()
                .map_or(b.len().min(256), |&e| e + 4),
        ),
        Target::Reader(Format::Vtk)
        | Target::Reader(Format::Json)
        | Target::Reader(Format::Csv) => Some(0..b.len()),
        _ => None,
    }
}

// ---------------------------------------------------------------------------
// The container, mutated inside with fresh checksums

struct Sfh {
    lead: Vec<u8>,
    json: Vec<u8>,
    blocks: Vec<(u32, Vec<u8>)>,
    end_delta: i64,
    deflate: bool,
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn inflate(b: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    flate2::read::DeflateDecoder::new(b)
        .take(4 << 20)
        .read_to_end(&mut out)
        .ok()?;
    Some(out)
}

fn deflate(b: &[u8]) -> Vec<u8> {
    let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(b).unwrap();
    z.finish().unwrap()
}

fn parse_sfh(b: &[u8]) -> Option<Sfh> {
    if b.get(..8)? != strandfit::io::CONTAINER_MAGIC {
        return None;
    }
    let len = u32_at(b, 16)? as usize;
    let json = inflate(b.get(24..24 + len)?)?;
    let mut at = 24 + len;
    let mut blocks = Vec::new();
    loop {
        match b.get(at..at + 4)? {
            b"SFHE" => break,
            b"SFHB" => {
                let curves = u32_at(b, at + 4)?;
                let stored_len = u32_at(b, at + 12)? as usize;
                let enc = *b.get(at + 16)?;
                let stored = b.get(at + 24..at + 24 + stored_len)?;
                let raw = if enc == 1 {
                    inflate(stored)?
                } else {
                    stored.to_vec()
                };
                blocks.push((curves, raw));
                at += 24 + stored_len;
            }
            _ => return None,
        }
    }
    Some(Sfh {
        lead: b[..12].to_vec(),
        json,
        blocks,
        end_delta: 0,
        deflate: true,
    })
}

fn write_sfh(s: &Sfh) -> Vec<u8> {
    let mut out = s.lead.clone();
    let stored = deflate(&s.json);
    out.extend((s.json.len() as u32).to_le_bytes());
    out.extend((stored.len() as u32).to_le_bytes());
    out.extend(crc32fast::hash(&stored).to_le_bytes());
    out.extend(&stored);
    let mut crcs = crc32fast::Hasher::new();
    let mut curves = 0u64;
    for (n, raw) in &s.blocks {
        let stored = if s.deflate { deflate(raw) } else { raw.clone() };
        let crc = crc32fast::hash(&stored);
        crcs.update(&crc.to_le_bytes());
        out.extend(b"SFHB");
        out.extend(n.to_le_bytes());
        out.extend((raw.len() as u32).to_le_bytes());
        out.extend((stored.len() as u32).to_le_bytes());
        out.extend([s.deflate as u8, 0, 0, 0]);
        out.extend(crc.to_le_bytes());
        out.extend(&stored);
        curves += *n as u64;
    }
    out.extend(b"SFHE");
    out.extend(curves.wrapping_add(s.end_delta as u64).to_le_bytes());
    out.extend(crcs.finalize().to_le_bytes());
    out
}

fn sfh_mutation(rng: &mut ChaCha8Rng, b: &[u8]) -> Option<(Vec<u8>, String)> {
    let mut s = parse_sfh(b)?;
    let mut what = Vec::new();
    s.deflate = rng.gen_bool(0.7);
    for _ in 0..rng.gen_range(1..=2) {
        let k = rng.gen_range(0..10);
        if k < 3 || s.blocks.is_empty() {
            let r = 0..s.json.len();
            if let Some(w) = text_mutation(rng, &mut s.json, r, dictionary(Target::Container)) {
                what.push(format!("header JSON: {w}"));
            }
            continue;
        }
        let i = rng.gen_range(0..s.blocks.len());
        match k {
            3..=6 => {
                // The raw block: a 24-byte stream table, then the streams.
                let raw = &mut s.blocks[i].1;
                let hot = vec![0..24.min(raw.len()), 24.min(raw.len())..64.min(raw.len())];
                let w = byte_mutation(rng, raw, &hot, 1);
                what.push(format!("block {i} inflated: {w}"));
            }
            7 => {
                let raw = &mut s.blocks[i].1;
                if raw.len() >= 24 {
                    let t = rng.gen_range(0..6);
                    let old = u32_at(raw, 4 * t).unwrap();
                    let new = [
                        old.wrapping_add(1),
                        old.wrapping_sub(1),
                        0,
                        u32::MAX,
                        raw.len() as u32,
                    ][rng.gen_range(0..5)];
                    raw[4 * t..4 * t + 4].copy_from_slice(&new.to_le_bytes());
                    what.push(format!("block {i} stream {t} length {old} -> {new}"));
                }
            }
            8 => {
                let old = s.blocks[i].0;
                let new = [
                    old.wrapping_add(1),
                    old.wrapping_sub(1),
                    0,
                    u32::MAX,
                    4097,
                    1 << 20,
                ][rng.gen_range(0..6)];
                s.blocks[i].0 = new;
                what.push(format!("block {i} curve count {old} -> {new}"));
            }
            _ => {
                if rng.gen_bool(0.5) {
                    let blk = s.blocks[i].clone();
                    s.blocks.insert(i, blk);
                    what.push(format!("duplicate block {i}"));
                } else {
                    s.end_delta = [1, -1][rng.gen_range(0..2)];
                    what.push(format!("end record count off by {}", s.end_delta));
                }
            }
        }
    }
    let out = write_sfh(&s);
    what.push(format!(
        "re-stored {} with fresh CRCs",
        if s.deflate { "deflated" } else { "raw" }
    ));
    Some((out, what.join("; ")))
}

// ---------------------------------------------------------------------------
// TRX, mutated inside its zip

fn parse_trx(b: &[u8]) -> Option<Vec<(String, Vec<u8>)>> {
    let mut z = zip::ZipArchive::new(Cursor::new(b)).ok()?;
    let mut out = Vec::new();
    for i in 0..z.len() {
        let mut f = z.by_index(i).ok()?;
        let mut data = Vec::new();
        f.read_to_end(&mut data).ok()?;
        out.push((f.name().to_string(), data));
    }
    Some(out)
}

fn write_trx(entries: &[(String, Vec<u8>)], deflated: bool) -> Option<Vec<u8>> {
    let mut z = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let method = if deflated {
        zip::CompressionMethod::Deflated
    } else {
        zip::CompressionMethod::Stored
    };
    let opts = zip::write::SimpleFileOptions::default().compression_method(method);
    for (name, data) in entries {
        z.start_file(name.as_str(), opts).ok()?;
        z.write_all(data).ok()?;
    }
    Some(z.finish().ok()?.into_inner())
}

/// Bytes per value of an entry, from its dtype suffix.
fn dtype_width(name: &str) -> usize {
    let t = name.rsplit('.').next().unwrap_or("");
    match t {
        "float16" | "uint16" | "int16" => 2,
        "float32" | "uint32" | "int32" => 4,
        "float64" | "uint64" | "int64" => 8,
        _ => 1,
    }
}

const DTYPES: [&str; 10] = [
    "float16", "float32", "float64", "uint8", "uint16", "uint32", "uint64", "int8", "int32", "bool",
];

fn trx_mutation(rng: &mut ChaCha8Rng, b: &[u8]) -> Option<(Vec<u8>, String)> {
    let mut entries = parse_trx(b)?;
    let mut what = Vec::new();
    for _ in 0..rng.gen_range(1..=2) {
        if entries.is_empty() {
            break;
        }
        let i = rng.gen_range(0..entries.len());
        let name = entries[i].0.clone();
        let k = rng.gen_range(0..10);
        if name == "header.json" && k < 6 {
            let r = 0..entries[i].1.len();
            if let Some(w) = text_mutation(
                rng,
                &mut entries[i].1,
                r,
                dictionary(Target::Reader(Format::Trx)),
            ) {
                what.push(format!("`{name}`: {w}"));
            }
            continue;
        }
        match k {
            0..=4 => {
                let width = dtype_width(&name);
                let data = &mut entries[i].1;
                if data.is_empty() {
                    continue;
                }
                let w = if rng.gen_bool(0.6) {
                    // A value of the entry's own width: NaN/Inf/huge/max.
                    let ws: Vec<_> = words()
                        .into_iter()
                        .filter(|(_, w)| w.len() == width)
                        .collect();
                    if ws.is_empty() || data.len() < width {
                        byte_mutation(rng, data, &[], width)
                    } else {
                        let (vn, v) = &ws[rng.gen_range(0..ws.len())];
                        let at = rng.gen_range(0..data.len() / width) * width;
                        data[at..at + width].copy_from_slice(v);
                        format!("value at byte {at} = {vn}")
                    }
                } else {
                    byte_mutation(rng, data, &[], width)
                };
                what.push(format!("`{name}`: {w}"));
            }
            5 => {
                let data = &mut entries[i].1;
                let len = data.len();
                let new = [0, len / 2, len.saturating_sub(1), len + dtype_width(&name)]
                    [rng.gen_range(0..4)];
                data.resize(new, 0x41);
                what.push(format!("`{name}`: {len} -> {new} bytes"));
            }
            6 => {
                entries.remove(i);
                what.push(format!("remove `{name}`"));
            }
            7 | 8 => {
                let mut parts: Vec<String> = name.split('.').map(String::from).collect();
                let new = if parts.len() >= 2 && rng.gen_bool(0.7) {
                    let last = parts.len() - 1;
                    parts[last] = DTYPES[rng.gen_range(0..DTYPES.len())].to_string();
                    parts.join(".")
                } else if parts.len() >= 3 {
                    parts[1] = ["1", "2", "4", "0", "4294967296"][rng.gen_range(0..5)].to_string();
                    parts.join(".")
                } else if let Some(rest) = name.strip_prefix("dpv/") {
                    format!("dps/{rest}")
                } else if let Some(rest) = name.strip_prefix("dps/") {
                    format!("dpv/{rest}")
                } else {
                    format!("dpv/{name}")
                };
                if entries.iter().any(|(n, _)| *n == new) {
                    continue;
                }
                entries[i].0 = new.clone();
                what.push(format!("rename `{name}` -> `{new}`"));
            }
            _ => {
                let dir = ["dpv", "dps"][rng.gen_range(0..2)];
                let dt = DTYPES[rng.gen_range(0..DTYPES.len())];
                let new = format!("{dir}/fuzz.{}{dt}", ["", "3.", "2."][rng.gen_range(0..3)]);
                if entries.iter().any(|(n, _)| *n == new) {
                    continue;
                }
                let len = rng.gen_range(0..64);
                let data: Vec<u8> = (0..len).map(|_| rng.gen()).collect();
                entries.push((new.clone(), data));
                what.push(format!("add `{new}` of {len} random bytes"));
            }
        }
    }
    let deflated = rng.gen_bool(0.4);
    let out = write_trx(&entries, deflated)?;
    what.push(format!(
        "re-zipped {}",
        if deflated { "deflated" } else { "stored" }
    ));
    Some((out, what.join("; ")))
}

// ---------------------------------------------------------------------------
// One case

/// The mutated input of case `case` of a seed, and what was done to it.
fn mutate(target: Target, seed_name: &str, seed: &[u8], case: u64) -> (Vec<u8>, String) {
    let mut rng =
        ChaCha8Rng::seed_from_u64(name_hash(seed_name) ^ case.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    // Containers and TRX: half the cases inside the structure.
    if rng.gen_bool(0.5) {
        let inner = match target {
            Target::Container => sfh_mutation(&mut rng, seed),
            Target::Reader(Format::Trx) => trx_mutation(&mut rng, seed),
            _ => None,
        };
        if let Some(r) = inner {
            return r;
        }
    }
    let mut b = seed.to_vec();
    let align = match target {
        Target::Reader(Format::Tck)
        | Target::Reader(Format::Trk)
        | Target::Reader(Format::Hair)
        | Target::Reader(Format::Vtk) => 4,
        _ => 1,
    };
    let text_share = match target {
        Target::Reader(Format::Json) | Target::Reader(Format::Csv) => 0.7,
        Target::Reader(Format::Tck) | Target::Reader(Format::Vtk) => 0.35,
        _ => 0.0,
    };
    let mut what = Vec::new();
    let stack = [1, 1, 1, 2, 2, 3][rng.gen_range(0..6)];
    for _ in 0..stack {
        let mut done = None;
        if rng.gen_bool(text_share) {
            if let Some(r) = text_part(target, &b) {
                done = text_mutation(&mut rng, &mut b, r, dictionary(target));
            }
        }
        let w = match done {
            Some(w) => w,
            None => {
                let h = hot(target, &b);
                byte_mutation(&mut rng, &mut b, &h, align)
            }
        };
        what.push(w);
        b.truncate(MAX_INPUT);
    }
    (b, what.join("; "))
}

struct Finding {
    seed: String,
    case: Option<u64>,
    mutation: String,
    /// The kind of bug, for grouping (a panic's kind includes where).
    kind: String,
    what: String,
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.case {
            None => write!(f, "seed {} (unmutated): {}", self.seed, self.what),
            Some(c) => write!(
                f,
                "seed {} case #{c} [{}]: {}",
                self.seed, self.mutation, self.what
            ),
        }
    }
}

#[derive(Default)]
struct Tally {
    reads: usize,
    read_ok: usize,
    refused: usize,
    peak: usize,
    findings: Vec<Finding>,
}

/// Read one input and record what went wrong. `false` when the read hung
/// (the worker is then stuck and the run must stop).
#[allow(clippy::too_many_arguments)]
fn run_case(
    worker: &Worker,
    target: Target,
    path: &Path,
    seed: &str,
    case: Option<u64>,
    mutation: &str,
    bytes: &[u8],
    t: &mut Tally,
) -> bool {
    let label = match case {
        Some(c) => format!("{seed} case #{c}"),
        None => seed.to_string(),
    };
    std::fs::write(path, bytes).unwrap();
    let found = |kind: String, what: String, t: &mut Tally| {
        if let Ok(dir) = std::env::var("STRANDFIT_FUZZ_SAVE") {
            let name = label.replace(['/', '#', ' '], "_");
            let _ = std::fs::create_dir_all(&dir);
            let _ = std::fs::write(
                Path::new(&dir).join(format!("{name}.{}", target.name())),
                bytes,
            );
        }
        t.findings.push(Finding {
            seed: seed.to_string(),
            case,
            mutation: mutation.to_string(),
            kind,
            what,
        });
    };
    t.reads += 1;
    let Some(r) = worker.read(path, target, &label) else {
        found(
            "HANG".into(),
            format!(
                "HANG: the {} reader did not finish in {WATCHDOG:?}",
                target.name()
            ),
            t,
        );
        return false;
    };
    t.peak = t.peak.max(r.peak);
    if std::env::var_os("STRANDFIT_FUZZ_VERBOSE").is_some() {
        eprintln!("{label} [{mutation}]: {:?}", r.result);
    }
    if r.peak > PEAK_LIMIT {
        found(
            "ABSURD MEMORY".into(),
            format!(
                "ABSURD MEMORY: the {} reader peaked at {} MiB on a {}-byte input",
                target.name(),
                r.peak >> 20,
                bytes.len()
            ),
            t,
        );
    }
    match r.result {
        Ok(Outcome::Read { .. }) => {
            t.read_ok += 1;
            if seed.rsplit('/').next().unwrap().starts_with("huge_") && case.is_none() {
                found(
                    "HUGE COUNTS ACCEPTED".into(),
                    "HUGE COUNTS ACCEPTED: a header announcing 2^32 curves or points read as a valid file"
                        .into(),
                    t,
                );
            }
        }
        Ok(Outcome::Refused(_)) => t.refused += 1,
        Err(bug) => {
            let kind = match &bug {
                // Where it panicked (the hook appends " at FILE:LINE").
                Bug::Panic(m) => format!("panic{}", m.rfind(" at ").map_or("", |k| &m[k..])),
                b => b.class().to_string(),
            };
            found(kind, format!("{} reader: {bug}", target.name()), t)
        }
    }
    true
}

fn fuzz(target: Target) {
    let started = Instant::now();
    let only = only();
    let n_iters = iters();
    let worker = Worker::new();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("fuzz.{}", target.name()));
    let mut t = Tally::default();
    let all = seeds(target);
    assert!(!all.is_empty(), "no seeds for {}", target.name());
    'seeds: for (name, bytes) in &all {
        let cases: Vec<u64> = match &only {
            Some((o, _)) if o != name => continue,
            Some((_, Some(c))) => vec![*c],
            _ => (0..n_iters).collect(),
        };
        if !run_case(&worker, target, &path, name, None, "", bytes, &mut t) {
            break;
        }
        for case in cases {
            let (m, what) = mutate(target, name, bytes, case);
            if !run_case(&worker, target, &path, name, Some(case), &what, &m, &mut t) {
                break 'seeds;
            }
        }
    }
    eprintln!(
        "fuzz {}: {} seeds, {} reads ({} read, {} refused) in {:.1} s; peak {} KiB; {} findings",
        target.name(),
        all.len(),
        t.reads,
        t.read_ok,
        t.refused,
        started.elapsed().as_secs_f64(),
        t.peak >> 10,
        t.findings.len()
    );
    if !t.findings.is_empty() {
        // One line per seed and kind of bug (its first case, and how many).
        let mut groups: Vec<((&str, &str), &Finding, usize)> = Vec::new();
        let mut kinds = std::collections::BTreeMap::new();
        for f in &t.findings {
            *kinds.entry(f.kind.as_str()).or_insert(0) += 1;
            let key = (f.seed.as_str(), f.kind.as_str());
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.2 += 1,
                None => groups.push((key, f, 1)),
            }
        }
        let list: Vec<String> = groups
            .iter()
            .map(|(_, f, n)| match n {
                1 => format!("  {f}"),
                n => format!("  {f}\n      (and {} more cases of this seed)", n - 1),
            })
            .collect();
        panic!(
            "FUZZ FINDINGS for the {} reader: {} of {} reads ({kinds:?}); the first case of \
             each seed and kind (reproduce with STRANDFIT_FUZZ_ONLY='<seed>#<case>', keep \
             the inputs with STRANDFIT_FUZZ_SAVE=DIR):\n{}",
            target.name(),
            t.findings.len(),
            t.reads,
            list.join("\n"),
        );
    }
}

// ---------------------------------------------------------------------------
// Tests

#[test]
fn corpus_is_small_and_covers_every_reader() {
    let mut total = 0;
    for target in Target::ALL {
        let s = seeds(target);
        assert!(s.len() >= 8, "{}: only {} seeds", target.name(), s.len());
        for (name, bytes) in &s {
            assert!(bytes.len() <= 20 << 10, "{name}: {} bytes", bytes.len());
            total += bytes.len();
        }
        if !matches!(target, Target::Reader(Format::Json | Format::Csv)) {
            assert!(
                s.iter().any(|(n, _)| n.contains("/huge_")),
                "{}: no seed announcing huge counts",
                target.name()
            );
        }
        assert!(
            s.iter().any(|(_, b)| b.is_empty()),
            "{}: no empty-file seed",
            target.name()
        );
    }
    assert!(total <= 300 << 10, "corpus of {total} bytes");
    let vtk = seeds(Target::Reader(Format::Vtk));
    for enc in [&b"\nASCII\n"[..], b"\nBINARY\n"] {
        assert!(vtk.iter().any(|(_, b)| !find_all(b, enc).is_empty()));
    }
}

/// Headers announcing 2^32 (or 2^63) curves or points: an error naming the
/// file, and no allocation sized by the count.
#[test]
fn huge_counts_are_errors_not_allocations() {
    let worker = Worker::new();
    let dir = tempfile::tempdir().unwrap();
    let mut bad = Vec::new();
    let mut n = 0;
    for target in Target::ALL {
        let path = dir.path().join(format!("huge.{}", target.name()));
        for (name, bytes) in seeds(target) {
            if !name.contains("/huge_") {
                continue;
            }
            n += 1;
            std::fs::write(&path, &bytes).unwrap();
            let r = worker.read(&path, target, &name).expect("hang");
            match &r.result {
                Ok(Outcome::Refused(_)) if r.peak <= 16 << 20 => {}
                Ok(Outcome::Refused(_)) => bad.push(format!(
                    "{name}: refused, but after allocating {} MiB",
                    r.peak >> 20
                )),
                Ok(o) => bad.push(format!("{name}: accepted ({o:?})")),
                Err(b) => bad.push(format!("{name}: {b}")),
            }
        }
    }
    assert!(n >= 20, "only {n} huge-count seeds");
    assert!(bad.is_empty(), "huge-count seeds:\n{}", bad.join("\n"));
}

#[test]
fn fuzz_tck() {
    fuzz(Target::Reader(Format::Tck));
}

#[test]
fn fuzz_trk() {
    fuzz(Target::Reader(Format::Trk));
}

#[test]
fn fuzz_trx() {
    fuzz(Target::Reader(Format::Trx));
}

#[test]
fn fuzz_vtk() {
    fuzz(Target::Reader(Format::Vtk));
}

#[test]
fn fuzz_hair() {
    fuzz(Target::Reader(Format::Hair));
}

#[test]
fn fuzz_json() {
    fuzz(Target::Reader(Format::Json));
}

#[test]
fn fuzz_csv() {
    fuzz(Target::Reader(Format::Csv));
}

#[test]
fn fuzz_sfh() {
    fuzz(Target::Container);
}

/// The mutations are a function of the seed file (name and bytes) and the
/// case number alone, so a finding reproduces from what it names.
#[test]
fn mutations_are_deterministic() {
    for target in Target::ALL {
        let s = seeds(target);
        let (name, bytes) = &s[s.len() / 2];
        for case in [0, 7, 1000] {
            assert_eq!(
                mutate(target, name, bytes, case),
                mutate(target, name, bytes, case)
            );
        }
    }
}
