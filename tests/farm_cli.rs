//! What a preprocessing farm relies on (issue 18), through the binary:
//! nothing written that cannot be read back, bad curves named or skipped,
//! nothing left behind when the scheduler kills a run, nothing dropped
//! without a word, and messages that name the input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use proptest::prelude::*;
use strandfit::io::read_all;

fn strandfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(args)
        .output()
        .expect("run strandfit")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(args: &[&str]) -> Output {
    let o = strandfit(args);
    assert!(o.status.success(), "strandfit {args:?}: {}", stderr(&o));
    o
}

fn fails(args: &[&str]) -> String {
    let o = strandfit(args);
    assert_eq!(
        o.status.code(),
        Some(1),
        "strandfit {args:?}: {}",
        stderr(&o)
    );
    stderr(&o)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    v.sort();
    v
}

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

/// A TRX folder (the format's uncompressed form) holding `curves`, written
/// byte by byte here so that it can hold what no writer of ours writes.
fn trx_folder(dir: &Path, curves: &[Vec<[f32; 3]>]) -> PathBuf {
    let root = dir.join("t.trx");
    std::fs::create_dir(&root).unwrap();
    let nv: usize = curves.iter().map(Vec::len).sum();
    std::fs::write(
        root.join("header.json"),
        format!(
            "{{\"VOXEL_TO_RASMM\":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],\
             \"DIMENSIONS\":[10,10,10],\"NB_VERTICES\":{nv},\"NB_STREAMLINES\":{}}}",
            curves.len()
        ),
    )
    .unwrap();
    let mut pos = Vec::new();
    let mut off = Vec::new();
    let mut at = 0u32;
    for c in curves {
        off.extend_from_slice(&at.to_le_bytes());
        at += c.len() as u32;
        for p in c {
            for x in p {
                pos.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    off.extend_from_slice(&at.to_le_bytes());
    std::fs::write(root.join("positions.3.float32"), pos).unwrap();
    std::fs::write(root.join("offsets.uint32"), off).unwrap();
    root
}

fn line(n: usize, z: f32) -> Vec<[f32; 3]> {
    (0..n)
        .map(|k| {
            let t = k as f32 * 0.7;
            [t, t.sin() * 2.0, z]
        })
        .collect()
}

// ------------------------------------------------------------- part 1

#[test]
fn a_nan_curve_is_an_error_naming_file_curve_and_point_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let mut curves: Vec<_> = (0..4).map(|k| line(12, k as f32)).collect();
    curves[2][5][1] = f32::NAN;
    let trx = trx_folder(dir.path(), &curves);
    let out = dir.path().join("x.sfh");
    let e = fails(&["compress", s(&trx), "--tolerance", "0.5", "-o", s(&out)]);
    assert!(
        e.contains("t.trx, curve 2: point 5: coordinate y is NaN"),
        "{e}"
    );
    assert_eq!(listing(dir.path()), ["t.trx"], "no output, no temporary");
    // The same for convert, and for a coordinate beyond float32 in CSV and
    // JSON (which hold f64).
    let e = fails(&["convert", s(&trx), "-o", s(&dir.path().join("x.tck"))]);
    assert!(e.contains("curve 2: point 5"), "{e}");
    let csv = dir.path().join("big.csv");
    std::fs::write(
        &csv,
        "curve,x,y,z\na,0,0,0\na,1,0,0\nb,0,0,0\nb,1,1e300,0\n",
    )
    .unwrap();
    let e = fails(&["compress", s(&csv), "--tolerance", "0.5", "-o", s(&out)]);
    assert!(
        e.contains("big.csv, curve 1: point 1: coordinate y = 1e300"),
        "{e}"
    );
    let json = dir.path().join("big.json");
    std::fs::write(&json, r#"{"curves":[{"points":[[0,0,0],[4e38,0,0]]}]}"#).unwrap();
    let e = fails(&["compress", s(&json), "--tolerance", "0.5", "-o", s(&out)]);
    assert!(
        e.contains("big.json, curve 0: point 1: coordinate x = 4e38"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn skip_bad_leaves_out_the_bad_curves_and_gives_every_other_back() {
    let dir = tempfile::tempdir().unwrap();
    let mut curves: Vec<_> = (0..6).map(|k| line(15, k as f32)).collect();
    curves[1][0][0] = f32::INFINITY;
    curves[4][14][2] = f32::NAN;
    let trx = trx_folder(dir.path(), &curves);
    let sfh = dir.path().join("x.sfh");
    let o = ok(&[
        "compress",
        s(&trx),
        "--tolerance",
        "0.1",
        "--skip-bad",
        "-o",
        s(&sfh),
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["skipped"], serde_json::json!([1, 4]));
    assert_eq!(report["curve_count"], 4);
    let e = stderr(&o);
    assert!(
        e.contains("left out 2 curve(s)") && e.contains("curve 4: point 14"),
        "{e}"
    );
    let back = dir.path().join("back.json");
    ok(&["decompress", s(&sfh), "-o", s(&back)]);
    let (_, got) = read_all(&back, None).unwrap();
    assert_eq!(got.len(), 4);
    for (g, k) in got.iter().zip([0usize, 2, 3, 5]) {
        // Each kept curve comes back in order: its z identifies it.
        assert!(
            g.points.iter().all(|p| (p.z - k as f64).abs() < 0.1),
            "curve {k}"
        );
    }
}

/// Whatever `compress` accepts, `decompress` reads back: curve count and
/// order intact (ids carry the order). Coordinates span the whole float32
/// range and the awkward cases: empty, one-point and repeated points,
/// non-finite and out-of-range values (which `compress` must refuse, or
/// leave out under `--skip-bad`).
#[test]
fn whatever_compress_accepts_decompress_reads_back() {
    let special = prop_oneof![
        Just(0.0f64),
        Just(-0.0),
        Just(1e-300),
        Just(3.0e38),
        Just(-3.4028234e38),
        Just(4e38),
        Just(1e300),
        Just(f64::NAN),
        Just(f64::INFINITY),
        -1e6..1e6f64,
        -1.0..1.0f64,
    ];
    let point = prop_oneof![
        4 => prop::array::uniform3(-100.0..100.0f64),
        1 => prop::array::uniform3(special),
    ];
    let curve = prop::collection::vec(point, 0..12);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 24,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let dir = tempfile::tempdir().unwrap();
    runner
        .run(
            &(prop::collection::vec(curve, 1..8), any::<bool>(), 0usize..4),
            |(curves, skip, storage)| {
                let csv = dir.path().join("in.csv");
                let mut text = String::from("curve,x,y,z\n");
                for (i, c) in curves.iter().enumerate() {
                    if c.is_empty() {
                        text.push_str(&format!("c{i},,,\n"));
                    }
                    for p in c {
                        text.push_str(&format!("c{i},{:e},{:e},{:e}\n", p[0], p[1], p[2]));
                    }
                }
                std::fs::write(&csv, text).unwrap();
                let sfh = dir.path().join("x.sfh");
                let _ = std::fs::remove_file(&sfh);
                // 0: the default (version 2, the arc codec); 1-3: the
                // version-1 helix container in each storage.
                let mut args = vec![
                    "compress",
                    s(&csv),
                    "--tolerance",
                    "0.5",
                    "-o",
                    s(&sfh),
                    "--json",
                ];
                if storage > 0 {
                    args.extend(["--distance", "ordered", "--storage"]);
                    args.push(["compact", "f32", "f64"][storage - 1]);
                }
                if skip {
                    args.push("--skip-bad");
                }
                let o = strandfit(&args);
                let bad: Vec<usize> = curves
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| {
                        c.iter()
                            .flatten()
                            .any(|x| !x.is_finite() || x.abs() > f32::MAX as f64)
                    })
                    .map(|(i, _)| i)
                    .collect();
                if !o.status.success() {
                    prop_assert!(!skip && !bad.is_empty(), "refused: {}", stderr(&o));
                    prop_assert!(!sfh.exists());
                    return Ok(());
                }
                prop_assert!(skip || bad.is_empty(), "accepted a bad curve");
                let back = dir.path().join("back.json");
                let d = strandfit(&["decompress", s(&sfh), "-o", s(&back)]);
                prop_assert!(d.status.success(), "{}", stderr(&d));
                let (_, got) = read_all(&back, None).unwrap();
                let want: Vec<String> = (0..curves.len())
                    .filter(|i| !bad.contains(i))
                    .map(|i| format!("c{i}"))
                    .collect();
                let ids: Vec<String> = got.iter().map(|c| c.id.clone().unwrap()).collect();
                prop_assert_eq!(ids, want);
                if storage == 0 {
                    // Version 2: every curve within the tolerance, two-sided.
                    let kept = (0..curves.len()).filter(|i| !bad.contains(i));
                    for (i, g) in kept.zip(&got) {
                        let want: Vec<strandfit::DVec3> = curves[i]
                            .iter()
                            .map(|p| strandfit::DVec3::from_array(*p))
                            .collect();
                        if want.is_empty() {
                            prop_assert!(g.points.is_empty());
                        } else {
                            let h = strandfit::metrics::hausdorff(&want, &g.points).unwrap();
                            prop_assert!(h <= 0.5, "curve {i}: {h}");
                        }
                    }
                }
                Ok(())
            },
        )
        .unwrap();
}

// ------------------------------------------------------------- part 2

#[cfg(unix)]
#[test]
fn sigterm_and_sigint_leave_the_output_folder_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    // Enough wavy curves that compress runs for a while.
    let curves: Vec<_> = (0..3000)
        .map(|k| {
            (0..200)
                .map(|j| {
                    let t = j as f32 * 0.3 + k as f32;
                    [t, (t * 0.9).sin() * 3.0, (t * 0.4).cos() * 2.0 + k as f32]
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let trx = trx_folder(&input, &curves);
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("keep.sfh"), "an earlier result").unwrap();
    for (sig, code) in [(libc::SIGTERM, 143), (libc::SIGINT, 130)] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_strandfit"))
            .args(["compress", s(&trx), "--tolerance", "0.01"])
            .args(["-o", s(&out.join("keep.sfh"))])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Wait for the temporary to appear: the run is under way.
        let started = std::time::Instant::now();
        while !listing(&out).iter().any(|n| n.ends_with(".tmp")) {
            assert!(started.elapsed().as_secs() < 60, "no temporary after 60 s");
            if let Some(st) = child.try_wait().unwrap() {
                panic!("compress ended ({st}) before it could be interrupted");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        // SAFETY: sending a signal to our own child process.
        assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(code), "signal {sig}");
        assert_eq!(listing(&out), ["keep.sfh"], "signal {sig}");
        assert_eq!(
            std::fs::read_to_string(out.join("keep.sfh")).unwrap(),
            "an earlier result"
        );
    }
}

#[cfg(unix)]
#[test]
fn outputs_through_links_to_devices_and_with_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let tck = fixture("fibres/dipy_fornix_tracks300.tck");
    let e = fails(&["convert", s(&tck), "-o", "/dev/full", "--to", "tck"]);
    assert!(
        e.contains("/dev/full") && e.contains("not a regular file"),
        "{e}"
    );
    assert!(!std::fs::metadata("/dev/full").unwrap().is_file());
    let real = dir.path().join("real.tck");
    let link = dir.path().join("link.tck");
    std::os::unix::fs::symlink("real.tck", &link).unwrap();
    ok(&["convert", s(&tck), "-o", s(&link)]);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let (_, a) = read_all(&tck, None).unwrap();
    let (_, b) = read_all(&real, None).unwrap();
    assert_eq!(a.len(), b.len());
    // The test process's umask is this process's; a file std makes shows it.
    let probe = dir.path().join("probe");
    std::fs::write(&probe, "").unwrap();
    let want = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
    let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, want, "{mode:o}");
}

// ------------------------------------------------------------- part 3

#[test]
fn dropped_data_are_named_and_strict_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let trk = fixture("fibres/nibabel_fixtures/complex.trk");
    let tck = dir.path().join("x.tck");
    let o = ok(&["convert", s(&trk), "-o", s(&tck)]);
    let e = stderr(&o);
    assert!(
        e.contains("warning") && e.contains("per-point data `colors[0]`") && e.contains("`fa`"),
        "{e}"
    );
    assert!(e.contains("per-curve data `mean_colors[0]`"), "{e}");
    std::fs::remove_file(&tck).unwrap();
    let e = fails(&["convert", s(&trk), "-o", s(&tck), "--strict"]);
    assert!(e.contains("--strict") && e.contains("`fa`"), "{e}");
    assert!(!tck.exists());
    // The default container keeps both; a version-1 container keeps
    // per-curve data, not per-point data.
    let sfh = dir.path().join("x.sfh");
    let compress = |extra: &[&'static str]| {
        let mut args = vec!["compress", s(&trk), "--tolerance", "0.5", "-o", s(&sfh)];
        args.extend_from_slice(extra);
        args
    };
    let e = stderr(&ok(&compress(&["--strict"])));
    assert!(!e.contains("warning"), "{e}");
    let v1 = ["--distance", "ordered"];
    let e = stderr(&ok(&compress(&v1)));
    assert!(
        e.contains("per-point data") && !e.contains("per-curve data"),
        "{e}"
    );
    let e = fails(&compress(&["--strict", v1[0], v1[1]]));
    assert!(e.contains("`fa`"), "{e}");
    // And decompressing to a format without per-curve data says so.
    let sfh2 = dir.path().join("y.sfh");
    ok(&["compress", s(&trk), "--tolerance", "0.5", "-o", s(&sfh2)]);
    let e = stderr(&ok(&["decompress", s(&sfh2), "-o", s(&tck)]));
    assert!(e.contains("per-curve data `mean_colors[0]`"), "{e}");
    assert!(e.contains("per-point data `colors[0]`"), "{e}");
    // trk -> trk keeps everything: no warning.
    let e = stderr(&ok(&[
        "convert",
        s(&trk),
        "-o",
        s(&dir.path().join("y.trk")),
    ]));
    assert!(!e.contains("warning"), "{e}");
}

#[test]
fn trx_groups_and_data_per_group_are_kept_or_named() {
    let dir = tempfile::tempdir().unwrap();
    let curves: Vec<_> = (0..4).map(|k| line(5, k as f32)).collect();
    let trx = trx_folder(dir.path(), &curves);
    std::fs::create_dir_all(trx.join("groups")).unwrap();
    std::fs::create_dir_all(trx.join("dpg/left")).unwrap();
    let members: Vec<u8> = [3u32, 1].iter().flat_map(|i| i.to_le_bytes()).collect();
    std::fs::write(trx.join("groups/left.uint32"), members).unwrap();
    std::fs::write(trx.join("dpg/left/colour.3.uint8"), [255u8, 0, 0]).unwrap();
    std::fs::write(trx.join("notes.txt"), "not part of the layout").unwrap();
    // TRX -> TRX keeps the group and its data; the stray entry is named.
    let out = dir.path().join("out.trx");
    let e = stderr(&ok(&["convert", s(&trx), "-o", s(&out)]));
    assert!(e.contains("notes.txt") && !e.contains("group"), "{e}");
    let (meta, got) = read_all(&out, None).unwrap();
    assert_eq!(meta.curve_data_names, ["group:left"]);
    let member: Vec<f32> = got.iter().map(|c| c.curve_data[0]).collect();
    assert_eq!(member, [0.0, 1.0, 0.0, 1.0]);
    assert_eq!(
        meta.extra("trx.entry.dpg/left/colour.3.uint8"),
        Some("ff0000")
    );
    // Through the container and back to TRX, too.
    let sfh = dir.path().join("x.sfh");
    ok(&["compress", s(&trx), "--tolerance", "0.1", "-o", s(&sfh)]);
    let back = dir.path().join("back.trx");
    ok(&["decompress", s(&sfh), "-o", s(&back)]);
    let (meta, got) = read_all(&back, None).unwrap();
    assert_eq!(meta.curve_data_names, ["group:left"]);
    assert_eq!(
        got.iter().map(|c| c.curve_data[0]).collect::<Vec<_>>(),
        member
    );
    assert!(meta.extra("trx.entry.dpg/left/colour.3.uint8").is_some());
    // A .tck has no place for them: named, and an error under --strict.
    let e = stderr(&ok(&[
        "convert",
        s(&trx),
        "-o",
        s(&dir.path().join("x.tck")),
    ]));
    assert!(e.contains("`group:left`"), "{e}");
    let e = fails(&[
        "convert",
        s(&trx),
        "-o",
        s(&dir.path().join("y.tck")),
        "--strict",
    ]);
    assert!(e.contains("`group:left`") && e.contains("notes.txt"), "{e}");
}

#[test]
fn an_empty_curve_survives_csv() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("e.json");
    std::fs::write(
        &json,
        r#"{"curves":[{"id":"a","points":[[0,0,0],[1,0,0]]},{"id":"e","points":[]},{"id":"b","points":[[0,0,1]]}]}"#,
    )
    .unwrap();
    let csv = dir.path().join("e.csv");
    ok(&["convert", s(&json), "-o", s(&csv)]);
    let (_, c) = read_all(&csv, None).unwrap();
    let ids: Vec<_> = c.iter().map(|c| c.id.clone().unwrap()).collect();
    assert_eq!(ids, ["a", "e", "b"]);
    assert!(c[1].points.is_empty());
}

// ------------------------------------------------------------- part 4

#[test]
fn a_missing_input_is_named_once_with_the_os_reason_once() {
    let e = fails(&["decompress", "no/such/file.sfh", "-o", "/tmp/never.tck"]);
    assert!(e.contains("no/such/file.sfh"), "{e}");
    assert_eq!(e.matches("No such file or directory").count(), 1, "{e}");
    let e = fails(&[
        "compress",
        "no/such/file.tck",
        "--tolerance",
        "1",
        "-o",
        "/tmp/never.sfh",
    ]);
    assert_eq!(e.matches("No such file or directory").count(), 1, "{e}");
}

#[test]
fn driver_chatter_is_hidden_unless_verbose() {
    // Whatever the machine has (lavapipe prints XDG_RUNTIME_DIR complaints
    // while adapters are listed), a default run shows only our own line.
    let out = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(["helix", "examples/pairs.jsonl"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let e = stderr(&out);
    let lines: Vec<&str> = e.lines().collect();
    assert!(
        lines.iter().all(|l| l.starts_with("strandfit:")),
        "stderr has lines that are not ours: {e}"
    );
}

#[test]
fn the_reported_worst_distance_never_exceeds_a_met_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let tck = fixture("fibres/dipy_fornix_tracks300.tck");
    for t in ["0.5", "0.1"] {
        let o = ok(&[
            "compress",
            s(&tck),
            "--tolerance",
            t,
            "-o",
            s(&dir.path().join("x.sfh")),
            "--json",
        ]);
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let tol: f64 = t.parse().unwrap();
        if r["over_tolerance_count"] == 0 {
            assert!(r["max_distance"].as_f64().unwrap() <= tol, "{r}");
        }
    }
}

#[test]
fn per_point_values_come_back_on_the_decoded_points() {
    // A .trk of helices whose scalar is the arc length at each point (and
    // a second, constant one): after compress and decompress every decoded
    // point carries the arc length of where it lies on the input, to
    // within the tolerance, and the constant stays what it was.
    use strandfit::io::{create_writer, Curve, Format, Metadata};
    use strandfit::DVec3;
    let dir = tempfile::tempdir().unwrap();
    let trk = dir.path().join("s.trk");
    let mut meta = Metadata::new(Format::Trk);
    meta.point_data_names = vec!["s".into(), "c".into()];
    let step = 0.25;
    let curves: Vec<Curve> = (0..30)
        .map(|k| {
            let r = 4.0 + k as f64 * 0.1;
            let pitch = 0.5;
            let ds = step / (r * r + pitch * pitch).sqrt();
            let points: Vec<DVec3> = (0..200)
                .map(|i| {
                    let a = i as f64 * ds;
                    DVec3::new(r * a.cos() + k as f64, r * a.sin(), pitch * a)
                })
                .collect();
            let point_data = (0..200)
                .flat_map(|i| [i as f32 * step as f32, 7.5])
                .collect();
            Curve {
                id: None,
                points,
                point_data,
                curve_data: vec![],
            }
        })
        .collect();
    let mut w = create_writer(&trk, Some(Format::Trk), &meta).unwrap();
    for c in &curves {
        w.write_curve(c).unwrap();
    }
    w.finish().unwrap();
    let tol = 0.1;
    let sfh = dir.path().join("s.sfh");
    let back = dir.path().join("back.trk");
    ok(&[
        "compress",
        s(&trk),
        "--tolerance",
        "0.1",
        "-o",
        s(&sfh),
        "--strict",
    ]);
    let e = stderr(&ok(&["decompress", s(&sfh), "-o", s(&back)]));
    assert!(!e.contains("warning"), "{e}");
    let (m, got) = read_all(&back, None).unwrap();
    assert_eq!(m.point_data_names, meta.point_data_names);
    assert_eq!(got.len(), curves.len());
    let mut fewer = 0;
    for (k, (a, b)) in curves.iter().zip(&got).enumerate() {
        assert_eq!(b.point_data.len(), 2 * b.points.len(), "curve {k}");
        fewer += (b.points.len() < a.points.len()) as usize;
        for (j, q) in b.points.iter().enumerate() {
            // Arc length of the input point nearest q (the input is dense).
            let i = (0..a.points.len())
                .min_by(|&x, &y| {
                    a.points[x]
                        .distance(*q)
                        .total_cmp(&a.points[y].distance(*q))
                })
                .unwrap();
            let s_near = i as f64 * step;
            let v = b.point_data[2 * j] as f64;
            assert!(
                (v - s_near).abs() <= step + tol,
                "curve {k} point {j}: {v} vs {s_near}"
            );
            assert_eq!(b.point_data[2 * j + 1], 7.5);
        }
    }
    // The helices are arcs, so the output is not the input's points.
    assert!(fewer > 20, "{fewer}");
}
