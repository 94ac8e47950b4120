//! Shared by the cargo-fuzz targets in `fuzz_targets/`: write libFuzzer's
//! input to a file with the format's extension, read it, and panic (which
//! libFuzzer records as a crash) on anything the oracle calls a bug. The
//! oracle is the one the CI test `tests/fuzz_readers.rs` uses.

use std::path::PathBuf;
use std::sync::OnceLock;

#[path = "../../tests/fuzz/oracle.rs"]
mod oracle;

pub use oracle::{check, Bug, Outcome, Target};
pub use strandfit::io::Format;

/// One scratch folder per fuzzing process, removed when it exits normally.
fn scratch() -> &'static tempfile::TempDir {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().expect("a scratch folder for fuzz inputs"))
}

/// Read `data` as `target`; panic on a bug.
pub fn fuzz(target: Target, data: &[u8]) {
    let path: PathBuf = scratch().path().join(format!("input.{}", target.name()));
    std::fs::write(&path, data).expect("writing the fuzz input");
    if let Err(bug) = check(&path, target) {
        panic!("{} reader: {bug}", target.name());
    }
}
