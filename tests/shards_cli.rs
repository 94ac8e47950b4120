//! `split`, `merge` and `decompress --curves` (issue 21, part 3): shards of
//! whole blocks copied as they are, joined back byte for byte; ranges that
//! read only their blocks; refusals that name the file and the reason and
//! leave nothing behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::io::{create_writer, read_all, Curve, Format, Metadata};

fn strandfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = strandfit(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The files of `dir`, sorted by name.
fn sorted_files(dir: &Path) -> Vec<PathBuf> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    names
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `n` short wiggly curves as a .tck, compressed at `tol` (more than two
/// blocks of 4,096 curves for n = 9,000).
fn container(dir: &Path, n: usize, tol: &str) -> PathBuf {
    let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
    let tck = dir.join(format!("in{n}.tck"));
    let mut w = create_writer(&tck, None, &Metadata::new(Format::Tck)).unwrap();
    for k in 0..n {
        let o = DVec3::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0), 0.0);
        let m = rng.gen_range(2..12);
        let pts = (0..m)
            .map(|i| {
                let t = i as f64;
                o + DVec3::new(t, (0.5 * t + k as f64).sin(), 0.1 * t * t)
            })
            .collect();
        w.write_curve(&Curve::from_points(pts)).unwrap();
    }
    w.finish().unwrap();
    let sfh = dir.join(format!("c{n}_{tol}.sfh"));
    ok(&["compress", s(&tck), "--tolerance", tol, "-o", s(&sfh)]);
    sfh
}

#[test]
fn split_then_merge_gives_back_the_container_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let c = container(dir.path(), 9000, "0.2");
    let shards = dir.path().join("shards");
    let report = ok(&[
        "split",
        s(&c),
        "--curves-per-shard",
        "5000",
        "-o",
        s(&shards),
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    // At most 5,000 a shard, rounded down to whole blocks of 4,096: the
    // shards of `strandfit.dask.compress_sharded` with the same N.
    let counts: Vec<u64> = report["shards"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["curve_count"].as_u64().unwrap())
        .collect();
    assert_eq!(counts, [4096, 4096, 808]);
    let names = sorted_files(&shards);
    assert_eq!(names.len(), 3);
    assert!(names[0].ends_with("c9000_0.2-00000.sfh"), "{names:?}");
    // Each shard decodes to its curves of the whole.
    let full_tck = dir.path().join("full.tck");
    ok(&["decompress", s(&c), "-o", s(&full_tck)]);
    let (_, full) = read_all(&full_tck, None).unwrap();
    let mut at = 0;
    for (k, name) in names.iter().enumerate() {
        let out = dir.path().join(format!("shard{k}.tck"));
        ok(&["decompress", s(name), "-o", s(&out)]);
        let (_, part) = read_all(&out, None).unwrap();
        assert_eq!(part, full[at..at + part.len()], "shard {k}");
        at += part.len();
    }
    assert_eq!(at, 9000);
    // Merged back: the input's bytes.
    let merged = dir.path().join("merged.sfh");
    let mut args = vec!["merge"];
    args.extend(names.iter().map(|p| s(p)));
    args.extend(["-o", s(&merged)]);
    ok(&args);
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&c).unwrap());
    // Shards of one block each (fewer curves asked than a block holds)
    // merge the same way; a split into bigger shards in the same folder
    // leaves none of the earlier ones behind.
    let small = dir.path().join("small");
    ok(&[
        "split",
        s(&c),
        "--curves-per-shard",
        "9000",
        "-o",
        s(&small),
    ]);
    ok(&["split", s(&c), "--curves-per-shard", "1", "-o", s(&small)]);
    assert_eq!(sorted_files(&small).len(), 3);
    ok(&[
        "split",
        s(&c),
        "--curves-per-shard",
        "8192",
        "-o",
        s(&small),
    ]);
    assert_eq!(sorted_files(&small).len(), 2);
    ok(&["split", s(&c), "--curves-per-shard", "1", "-o", s(&small)]);
    let names = sorted_files(&small);
    assert_eq!(names.len(), 3);
    let mut args = vec!["merge"];
    args.extend(names.iter().map(|p| s(p)));
    args.extend(["-o", s(&merged)]);
    ok(&args);
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&c).unwrap());
}

#[test]
fn a_range_decodes_the_curves_of_the_whole_and_reads_only_their_blocks() {
    let dir = tempfile::tempdir().unwrap();
    let c = container(dir.path(), 9000, "0.3");
    let full_tck = dir.path().join("full.tck");
    ok(&["decompress", s(&c), "-o", s(&full_tck)]);
    let (_, full) = read_all(&full_tck, None).unwrap();
    let size = std::fs::metadata(&c).unwrap().len();
    for (range, a, b) in [
        ("4090:4100", 4090, 4100),
        ("8990:", 8990, 9000),
        (":5", 0, 5),
        ("100:100", 100, 100),
        ("8999:20000", 8999, 9000),
    ] {
        let out = dir.path().join("part.tck");
        let o = strandfit(&["decompress", s(&c), "--curves", range, "-o", s(&out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, part) = read_all(&out, None).unwrap();
        assert_eq!(part, full[a..b], "{range}");
        let err = String::from_utf8_lossy(&o.stderr);
        let read: u64 = err
            .split("read ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("no bytes read in {err:?}"));
        // One block of three at most, or two where the range straddles.
        let blocks = if range == "4090:4100" { 2 } else { 1 };
        assert!(
            read < size * (blocks + 1) / 3 + 200,
            "{range}: read {read} of {size}"
        );
    }
    let o = strandfit(&["decompress", s(&c), "--curves", "7:3", "-o", s(&full_tck)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("ends before it starts"));
}

#[test]
fn refusals_name_the_file_and_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let a = container(dir.path(), 50, "0.2");
    let b = container(dir.path(), 60, "0.5");
    let out = dir.path().join("m.sfh");
    let o = strandfit(&["merge", s(&a), s(&b), "-o", s(&out)]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(s(&b)) && err.contains("tolerance differs"),
        "{err}"
    );
    assert!(!out.exists());
    // Containers of the same settings and source kind merge, in order.
    let a2 = container(dir.path(), 70, "0.2");
    ok(&["merge", s(&a), s(&a2), "-o", s(&out)]);
    let back = dir.path().join("back.tck");
    ok(&["decompress", s(&out), "-o", s(&back)]);
    assert_eq!(read_all(&back, None).unwrap().1.len(), 120);
    // A missing input: named, and no folder made.
    let shards = dir.path().join("never");
    let o = strandfit(&[
        "split",
        s(&dir.path().join("nope.sfh")),
        "--curves-per-shard",
        "10",
        "-o",
        s(&shards),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.sfh"));
    assert!(!shards.exists());
    let o = strandfit(&["split", s(&a), "--curves-per-shard", "0", "-o", s(&shards)]);
    assert!(!o.status.success());
    assert!(!shards.exists());
    // A version-1 container has no blocks to range over.
    let v1 = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/sfh/fornix_v1_ordered_0.5.sfh"
    );
    let o = strandfit(&["decompress", v1, "--curves", "1:3", "-o", s(&back)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("version-1"));
}
