//! The fuzz oracle, shared by `tests/fuzz_readers.rs` (bounded run in CI)
//! and the cargo-fuzz targets in `fuzz/` (open-ended runs on nightly), which
//! both include this file with `#[path]`.
//!
//! [`check`] reads one file with one reader and says what a reader must
//! never do with any input: panic, return an error that does not name the
//! file, or hand out a curve a writer could not store (a point that is NaN,
//! infinite or beyond float32's range, or per-point/per-curve values that do
//! not match the names in the metadata). For the `.sfh` container a decoded
//! record must also be usable: verbatim points as above, chain parameters
//! finite, and the chain's samples finite.

#![allow(dead_code)]

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use strandfit::codec::{container_version, CodecReader};
use strandfit::helix::PiecewiseHelix;
use strandfit::io::{self, ContainerReader, Curve, Format, IoError, Metadata, Shape};
use strandfit::DVec3;

/// What is read: a curve format through `io::read_all`, or the container.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    Reader(Format),
    Container,
}

impl Target {
    pub const ALL: [Target; 8] = [
        Target::Reader(Format::Tck),
        Target::Reader(Format::Trk),
        Target::Reader(Format::Trx),
        Target::Reader(Format::Vtk),
        Target::Reader(Format::Hair),
        Target::Reader(Format::Json),
        Target::Reader(Format::Csv),
        Target::Container,
    ];

    /// The corpus folder name, which is also the file extension.
    pub fn name(self) -> &'static str {
        match self {
            Target::Reader(f) => f.extension(),
            Target::Container => "sfh",
        }
    }

    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }
}

/// What a reader did with an input, when it did nothing wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Read to the end: curves and points in all.
    Read { curves: usize, points: usize },
    /// Refused, with this message (which names the file).
    Refused(String),
}

/// What a reader did wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum Bug {
    /// The reader panicked (the payload's message).
    Panic(String),
    /// An error whose message does not name the file.
    UnnamedError(String),
    /// A curve with a point that is NaN or infinite.
    NonFinite {
        curve: usize,
        point: usize,
        xyz: [f64; 3],
    },
    /// A curve with a point beyond float32's range (which the readers refuse:
    /// the output formats and the container store float32).
    BeyondF32 {
        curve: usize,
        point: usize,
        xyz: [f64; 3],
    },
    /// Per-point or per-curve values that do not match the metadata's names.
    Inconsistent { curve: usize, what: String },
    /// A container chain with non-finite parameters or samples.
    BadChain { curve: usize, what: String },
}

impl Bug {
    /// Short class name, for tallies.
    pub fn class(&self) -> &'static str {
        match self {
            Bug::Panic(_) => "panic",
            Bug::UnnamedError(_) => "unnamed error",
            Bug::NonFinite { .. } => "non-finite point",
            Bug::BeyondF32 { .. } => "point beyond f32",
            Bug::Inconsistent { .. } => "inconsistent data",
            Bug::BadChain { .. } => "bad chain",
        }
    }
}

impl std::fmt::Display for Bug {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Bug::Panic(m) => write!(f, "PANIC: {m}"),
            Bug::UnnamedError(m) => write!(f, "ERROR WITHOUT THE FILE NAME: {m}"),
            Bug::NonFinite { curve, point, xyz } => {
                write!(
                    f,
                    "NON-FINITE POINT handed out: curve {curve}, point {point} = {xyz:?}"
                )
            }
            Bug::BeyondF32 { curve, point, xyz } => write!(
                f,
                "POINT BEYOND FLOAT32 handed out: curve {curve}, point {point} = {xyz:?}"
            ),
            Bug::Inconsistent { curve, what } => write!(f, "INCONSISTENT curve {curve}: {what}"),
            Bug::BadChain { curve, what } => write!(f, "BAD CHAIN curve {curve}: {what}"),
        }
    }
}

/// The message of a panic payload.
pub fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}

fn check_points(curve: usize, points: &[DVec3]) -> Result<(), Bug> {
    for (k, p) in points.iter().enumerate() {
        let xyz = p.to_array();
        if xyz.iter().any(|x| !x.is_finite()) {
            return Err(Bug::NonFinite {
                curve,
                point: k,
                xyz,
            });
        }
        if xyz.iter().any(|x| x.abs() > f32::MAX as f64) {
            return Err(Bug::BeyondF32 {
                curve,
                point: k,
                xyz,
            });
        }
    }
    Ok(())
}

fn named(path: &Path, e: &dyn std::fmt::Display) -> Result<Outcome, Bug> {
    let msg = e.to_string();
    if msg.contains(&path.display().to_string()) {
        Ok(Outcome::Refused(msg))
    } else {
        Err(Bug::UnnamedError(msg))
    }
}

/// Judge what a whole-file read of `path` gave: an error must name the
/// file; curves must be usable (see the module docs).
pub fn judge_read(
    path: &Path,
    read: Result<(Metadata, Vec<Curve>), IoError>,
) -> Result<Outcome, Bug> {
    let (meta, curves) = match read {
        Ok(r) => r,
        Err(e) => return named(path, &e),
    };
    let (np, nc) = (meta.point_data_names.len(), meta.curve_data_names.len());
    let mut points = 0;
    for (i, c) in curves.iter().enumerate() {
        check_points(i, &c.points)?;
        if c.point_data.len() != c.points.len() * np {
            return Err(Bug::Inconsistent {
                curve: i,
                what: format!(
                    "{} per-point values for {} points × {np} names",
                    c.point_data.len(),
                    c.points.len()
                ),
            });
        }
        if c.curve_data.len() != nc {
            return Err(Bug::Inconsistent {
                curve: i,
                what: format!("{} per-curve values for {nc} names", c.curve_data.len()),
            });
        }
        points += c.points.len();
    }
    Ok(Outcome::Read {
        curves: curves.len(),
        points,
    })
}

/// A version-3 container (or a refused version 2): every block read and
/// decoded, as `decompress` does; the points it hands out must be usable.
fn check_codec_container(path: &Path) -> Result<Outcome, Bug> {
    let mut reader = match CodecReader::open(path) {
        Ok(r) => r,
        Err(e) => return named(path, &e),
    };
    let header = reader.header().clone();
    let nc = header.source.curve_data_names.len();
    let (mut curves, mut points) = (0, 0);
    for b in 0..reader.block_count() {
        let block = match reader
            .read_block_bytes(b)
            .and_then(|raw| raw.decode(path, &header))
        {
            Ok(cs) => cs,
            Err(e) => return named(path, &e),
        };
        for c in block {
            if c.curve_data.len() != nc {
                return Err(Bug::Inconsistent {
                    curve: curves,
                    what: format!("{} per-curve values for {nc} names", c.curve_data.len()),
                });
            }
            check_points(curves, &c.points)?;
            points += c.points.len();
            curves += 1;
        }
    }
    Ok(Outcome::Read { curves, points })
}

fn check_container(path: &Path) -> Result<Outcome, Bug> {
    if container_version(path).is_some_and(|v| v >= 2) {
        return check_codec_container(path);
    }
    let reader = match ContainerReader::open(path) {
        Ok(r) => r,
        Err(e) => return named(path, &e),
    };
    let nc = reader.header().source.curve_data_names.len();
    let (mut curves, mut points) = (0, 0);
    for (i, c) in reader.enumerate() {
        let c = match c {
            Ok(c) => c,
            Err(e) => return named(path, &e),
        };
        if c.curve_data.len() != nc {
            return Err(Bug::Inconsistent {
                curve: i,
                what: format!("{} per-curve values for {nc} names", c.curve_data.len()),
            });
        }
        let chain = match &c.shape {
            Shape::Empty => None,
            Shape::Points(p) => {
                check_points(i, p)?;
                points += p.len();
                None
            }
            Shape::Chain(ch) => Some(ch.clone()),
            Shape::Quantized(q) => Some(q.dequantize()),
        };
        if let Some(ch) = chain {
            let params = [ch.start, ch.tangent, ch.normal]
                .iter()
                .flat_map(|v| v.to_array())
                .chain(
                    ch.elements
                        .iter()
                        .flat_map(|e| [e.length, e.curvature, e.torsion, e.twist]),
                )
                .collect::<Vec<f64>>();
            if let Some(x) = params.iter().find(|x| !x.is_finite()) {
                return Err(Bug::BadChain {
                    curve: i,
                    what: format!("a chain parameter is {x}"),
                });
            }
            // What `strandfit decompress` does with it: samples along the
            // chain (as many as the source had, here at most 64).
            let m = (c.source_points as usize).clamp(2, 64);
            let samples = PiecewiseHelix::from_params(&ch).sample(m);
            if let Some((k, p)) = samples.iter().enumerate().find(|(_, p)| !p.is_finite()) {
                return Err(Bug::BadChain {
                    curve: i,
                    what: format!("sample {k} of {m} is {p:?}"),
                });
            }
            points += samples.len();
        }
        curves += 1;
    }
    Ok(Outcome::Read { curves, points })
}

/// Read `path` as `target` and judge what the reader did (see the module
/// docs). A panic is caught and returned as [`Bug::Panic`].
pub fn check(path: &Path, target: Target) -> Result<Outcome, Bug> {
    guarded(|| match target {
        Target::Reader(f) => judge_read(path, io::read_all(path, Some(f))),
        Target::Container => check_container(path),
    })
}

/// `f`, with a panic caught and returned as [`Bug::Panic`].
pub fn guarded(f: impl FnOnce() -> Result<Outcome, Bug>) -> Result<Outcome, Bug> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => Err(Bug::Panic(panic_message(&*p))),
    }
}
