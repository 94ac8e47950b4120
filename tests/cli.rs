//! The command line: JSON formats, errors that name the culprit, exit codes,
//! and no partial output files.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn strandfit(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run strandfit");
    // The program may exit before reading (usage errors): ignore a broken pipe.
    let _ = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    child.wait_with_output().unwrap()
}

/// [`strandfit`], which must succeed (its stderr shown if not).
fn strandfit_ok(args: &[&str], stdin: &str) -> Output {
    let out = strandfit(args, stdin);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn json(s: &[u8]) -> serde_json::Value {
    serde_json::from_slice(s).expect("valid JSON")
}

fn v3(v: &serde_json::Value) -> strandfit::DVec3 {
    strandfit::DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// A JSON array of `[x,y,z]`.
fn points(v: &serde_json::Value) -> Vec<strandfit::DVec3> {
    v.as_array().unwrap().iter().map(v3).collect()
}

#[test]
fn helix_answers_every_line_in_order() {
    let input = concat!(
        r#"{"p0":[1,0,0],"t0":[0,1,0],"p1":[0,1,0],"t1":[-1,0,0]}"#,
        "\n",
        "not json\n",
        r#"{"p0":[0,0,0],"t0":[1,0,0],"p1":[0,0,0],"t1":[0,1,0]}"#,
        "\n",
        r#"{"p0":[0,0,0],"t0":[0,2,0],"p1":[2,2,2],"t1":[3,0,0]}"#,
        "\n",
        r#"{"p0":[0,0,0],"t0":[1,0,0],"p1":[1,1,1],"t1":[1,1,0]}"#,
        "\n",
    );
    let out = strandfit(&["helix"], input);
    assert!(out.status.success());
    let lines: Vec<serde_json::Value> = out
        .stdout
        .split(|&b| b == b'\n')
        .filter(|l| !l.is_empty())
        .map(json)
        .collect();
    assert_eq!(lines.len(), 5);
    // Quarter circle of radius 1.
    assert!((lines[0]["length"].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((lines[0]["curvature"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert_eq!(lines[0]["torsion"].as_f64().unwrap(), 0.0);
    assert!(lines[1]["failure"].as_str().unwrap().contains("line 2"));
    assert!(lines[2]["failure"].as_str().unwrap().contains("coincide"));
    // Non-unit tangents are normalised; this one is right-handed.
    assert!(lines[3]["torsion"].as_f64().unwrap() > 0.0);
    assert_eq!(lines[3]["axis"].as_array().unwrap().len(), 3);
    assert!(lines[4]["failure"]
        .as_str()
        .unwrap()
        .contains("not co-helical"));
}

#[test]
fn helix_reads_a_file_and_writes_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let inp = dir.path().join("in.jsonl");
    let outp = dir.path().join("out.jsonl");
    std::fs::write(
        &inp,
        "{\"p0\":[0,0,0],\"t0\":[1,0,0],\"p1\":[3,0,0],\"t1\":[1,0,0]}\n",
    )
    .unwrap();
    strandfit_ok(
        &["helix", inp.to_str().unwrap(), "-o", outp.to_str().unwrap()],
        "",
    );
    let v = json(std::fs::read(&outp).unwrap().trim_ascii_end());
    assert_eq!(v["length"].as_f64().unwrap(), 3.0);
    assert_eq!(v["curvature"].as_f64().unwrap(), 0.0);
}

const TWO_SPLINES: &str = r#"{"splines":[
 {"id":"a","control_points":[[0,0,0],[1,0,0],[2,1,0],[2,2,1],[2,3,2],[1,4,2],[0,4,3]]},
 {"id":"b","control_points":[[0,0,0],[1,1,1],[2,2,2],[3,3,3]]}]}"#;

#[test]
fn fit_writes_the_documented_format() {
    let dir = tempfile::tempdir().unwrap();
    let outp = dir.path().join("out.json");
    strandfit_ok(
        &["fit", "--elements", "6", "-o", outp.to_str().unwrap()],
        TWO_SPLINES,
    );
    let v = json(&std::fs::read(&outp).unwrap());
    let curves = v["curves"].as_array().unwrap();
    assert_eq!(curves.len(), 2);
    assert_eq!(curves[0]["id"], "a");
    let els = curves[0]["elements"].as_array().unwrap();
    assert_eq!(els.len(), 6);
    for key in ["start", "tangent", "axis", "curvature", "torsion", "length"] {
        assert!(!els[0][key].is_null(), "missing {key}");
    }
    let f = curves[0]["frechet"].as_f64().unwrap();
    let h = curves[0]["hausdorff"].as_f64().unwrap();
    assert!(f >= h && f > 0.0 && f < 0.05, "frechet {f}, hausdorff {h}");
    assert!(curves[1]["frechet"].as_f64().unwrap() < 1e-12); // a straight line is fitted exactly
                                                             // Standard output when no -o is given.
    let out = strandfit(&["fit", "-n", "3", "-"], TWO_SPLINES);
    assert!(out.status.success());
    assert_eq!(json(&out.stdout)["curves"].as_array().unwrap().len(), 2);
}

fn assert_fails_without_output(input: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let outp = dir.path().join("out.json");
    let out = strandfit(
        &["fit", "--elements", "4", "-o", outp.to_str().unwrap()],
        input,
    );
    assert!(!out.status.success(), "should fail for {input}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(needle),
        "stderr {err:?} should mention {needle:?}"
    );
    assert!(!Path::new(&outp).exists(), "no output file on failure");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no temporary files left"
    );
}

#[test]
fn malformed_fit_input_names_the_spline_and_leaves_no_file() {
    assert_fails_without_output("{\"splines\":[", "expected");
    assert_fails_without_output("{\"curves\":[]}", "splines");
    assert_fails_without_output(
        r#"{"splines":[{"id":"ok","control_points":[[0,0,0],[1,0,0],[2,0,0],[3,1,0]]},{"id":"bad","control_points":[[0,0,0],[1,0,0]]}]}"#,
        "spline \"bad\"",
    );
    assert_fails_without_output(
        r#"{"splines":[{"id":"pt","control_points":[[1,1,1],[1,1,1],[1,1,1],[1,1,1]]}]}"#,
        "zero length",
    );
    assert_fails_without_output(
        r#"{"splines":[{"id":"big","control_points":[[0,0,0],[1e308,0,0],[-1e308,0,0],[1e308,1,0]]}]}"#,
        "big",
    );
    assert_fails_without_output(
        r#"{"splines":[{"id":"x","control_points":[[0,0],[1,0],[2,0],[3,0]]}]}"#,
        "expected",
    );
    // An existing output file is not touched by a failed run.
    let dir = tempfile::tempdir().unwrap();
    let outp = dir.path().join("keep.json");
    std::fs::write(&outp, "previous").unwrap();
    let out = strandfit(&["fit", "-n", "2", "-o", outp.to_str().unwrap()], "{}");
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read_to_string(&outp).unwrap(), "previous");
    // Usage errors.
    assert_eq!(
        strandfit(&["fit", "-n", "0"], TWO_SPLINES).status.code(),
        Some(2)
    );
    assert_eq!(strandfit(&["fit"], TWO_SPLINES).status.code(), Some(2));
    let missing = strandfit(&["fit", "-n", "2", "/nonexistent/in.json"], "");
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/in.json"));
}

/// Exit status 0 done, 1 a failure of the input or the run, 2 usage: clap's
/// own errors and the range and combination checks of the commands alike.
#[test]
fn exit_codes_are_0_done_1_failure_2_usage() {
    let code = |args: &[&str], stdin: &str| strandfit(args, stdin).status.code();
    let fornix = "tests/data/fibres/dipy_fornix_tracks300.tck";
    let dir = tempfile::tempdir().unwrap();
    let sfh = dir.path().join("f.sfh");
    let sfh = sfh.to_str().unwrap();
    // 2: the command line.
    for args in [
        &["nonsense"][..],
        &["fit", "--elements", "2", "--no-such-flag"],
        &["fit", "--elements", "two"],
        &["sample", "-n", "5"], // -n is "elements per curve"; sample takes --intervals
        &["sample", "--intervals", "0"],
        &["evaluate", "-m", "1"],
        &["integrate", "-m", "1"],
        &["integrate", "--steps", "0"],
        &["complete", "-m", "1", "examples/gaps.json"],
        &["complete", "--length", "2", "examples/gaps.json"], // --length is ATPH's
        &["motion", "-m", "1", "examples/motion.json"],
        &["helix", "--cohelical-tolerance=-1"],
        &["helix", "--tolerance", "0.1"], // renamed: --tolerance is a distance elsewhere
        &["compress", fornix, "-o", sfh], // no --tolerance
        &[
            "compress",
            fornix,
            "-o",
            sfh,
            "--tolerance",
            "0.5",
            "-n",
            "3",
        ],
        &["compress", fornix, "-o", sfh, "--tolerance=-1"],
        &[
            "compress",
            fornix,
            "-o",
            sfh,
            "--tolerance",
            "0.5",
            "--from",
            "xyz",
        ],
        &["inspect", fornix, "--from", "xyz"],
        &["inspect", fornix, "--format", "tck"], // renamed --from, as in compress and convert
        &["decompress", sfh, "-o", "x.tck", "-m", "1"],
        &["sketch", "examples/spring.svg", "--emax", "2"],
        &["bench", "--splines", "0"],
        &["fit", "--elements", "2", "--threads", "0"],
        // The engine options only where an engine runs.
        &["motion", "--backend", "cpu", "examples/motion.json"],
        &["sketch", "--precision", "f32", "examples/spring.svg"],
        &["decompress", sfh, "-o", "x.tck", "--backend", "cpu"],
        &["inspect", fornix, "-v"],
        &["--backend", "cpu", "fit", "--elements", "2"], // an option of the command, after it
    ] {
        assert_eq!(code(args, TWO_SPLINES), Some(2), "{args:?}");
    }
    assert!(!Path::new(sfh).exists(), "a usage error writes nothing");
    // 1: the input or the run.
    assert_eq!(code(&["fit", "--elements", "2"], "not json"), Some(1));
    assert_eq!(code(&["inspect", "/nonexistent.tck"], ""), Some(1));
    assert_eq!(
        code(
            &[
                "compress",
                "/nonexistent.tck",
                "--tolerance",
                "0.5",
                "-o",
                sfh
            ],
            ""
        ),
        Some(1)
    );
    // 0: done.
    assert_eq!(
        code(&["fit", "--elements", "2", "--backend", "cpu"], TWO_SPLINES),
        Some(0)
    );
    assert_eq!(
        code(&["compress", fornix, "--tolerance", "0.5", "-o", sfh], ""),
        Some(0)
    );
    // Documented in every command's help.
    for args in [
        &["--help"][..],
        &["fit", "--help"],
        &["merge", "--help"],
        &["bench", "-h"],
    ] {
        let out = strandfit_ok(args, "");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains("Exit status: 0 done; 1 ") && text.contains("2 usage"),
            "{args:?}: {text}"
        );
    }
}

#[test]
fn bundled_example_runs() {
    let ex = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/curls.json");
    let out = strandfit_ok(&["fit", "--elements", "20", ex], "");
    let v = json(&out.stdout);
    for c in v["curves"].as_array().unwrap() {
        assert!(c["frechet"].as_f64().unwrap() < 0.1, "{}", c["id"]);
    }
}

/// `evaluate` reads what `fit` writes and samples the chains exactly as `fit`
/// does for its Fréchet distance: the distance recomputed from `evaluate`'s
/// points equals the reported one.
#[test]
fn evaluate_decompresses_fit_output() {
    use strandfit::metrics::discrete_frechet;
    use strandfit::spline::BezierSpline;
    let dir = tempfile::tempdir().unwrap();
    let fitted = dir.path().join("fit.json");
    let polys = dir.path().join("polys.json");
    let n = 6;
    strandfit_ok(
        &[
            "fit",
            "--backend",
            "cpu",
            "-n",
            "6",
            "-o",
            fitted.to_str().unwrap(),
        ],
        TWO_SPLINES,
    );
    let m = 32 * n + 1; // fit's default --samples-per-element 32
    strandfit_ok(
        &[
            "evaluate",
            "--backend",
            "cpu",
            fitted.to_str().unwrap(),
            "-m",
            &m.to_string(),
            "--tangents",
            "-o",
            polys.to_str().unwrap(),
        ],
        "",
    );
    let fit = json(&std::fs::read(&fitted).unwrap());
    let ev = json(&std::fs::read(&polys).unwrap());
    let input = json(TWO_SPLINES.as_bytes());
    for (k, curve) in ev["curves"].as_array().unwrap().iter().enumerate() {
        assert_eq!(curve["id"], input["splines"][k]["id"]);
        let (pts, tans) = (points(&curve["points"]), points(&curve["tangents"]));
        assert_eq!((pts.len(), tans.len()), (m, m));
        let cps = points(&input["splines"][k]["control_points"]);
        let spline = BezierSpline::from_control_points(&cps).unwrap();
        let scale = spline.length();
        // Relaxation moves the end points too; the discrete Fréchet distance
        // bounds how far (it couples first with first, last with last).
        let want = fit["curves"][k]["frechet"].as_f64().unwrap();
        assert!((pts[0] - cps[0]).length() <= want + 1e-14 * scale);
        assert!((pts[m - 1] - *cps.last().unwrap()).length() <= want + 1e-14 * scale);
        for t in &tans {
            assert!((t.length() - 1.0).abs() < 1e-12);
        }
        let got = discrete_frechet(&spline.sample_points(m).unwrap(), &pts).unwrap();
        assert!((got - want).abs() <= 1e-14 * scale, "{got} vs {want}");
    }
}

#[test]
fn evaluate_rejects_bad_elements_by_name() {
    let el = |normal: &str, k: &str| {
        format!(
            r#"{{"start":[0,0,0],"tangent":[1,0,0],"normal":{normal},"curvature":{k},"torsion":0,"length":1}}"#
        )
    };
    let cases = [
        (el("[0,1,0]", "-1"), "negative curvature"),
        (el("[1,0,0]", "1"), "not orthogonal"),
        (el("[0,2,0]", "1"), "unit"),
        (el("[0,1,0]", "1e999"), "expected"),
    ];
    for (e, needle) in cases {
        let doc = format!(
            r#"{{"curves":[{{"id":"ok","elements":[{}]}},{{"id":"bad","elements":[{},{e}]}}]}}"#,
            el("[0,1,0]", "1"),
            el("[0,1,0]", "1")
        );
        let dir = tempfile::tempdir().unwrap();
        let outp = dir.path().join("out.json");
        let out = strandfit(
            &["evaluate", "--backend", "cpu", "-o", outp.to_str().unwrap()],
            &doc,
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert!(err.contains(needle), "{err}");
        if needle != "expected" {
            assert!(
                err.contains("curve \"bad\" (curves[1]): elements[1]"),
                "{err}"
            );
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
    let out = strandfit(&["evaluate", "-m", "1"], "{\"curves\":[]}");
    assert!(!out.status.success());
    let out = strandfit(
        &["evaluate", "--backend", "cpu"],
        r#"{"curves":[{"id":1,"elements":[]}]}"#,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("no elements"));
}

/// `sample` writes N + 1 points and unit tangents per spline, equally spaced
/// in arc length: on the CPU exactly the library's `sample_equal_arclen`.
#[test]
fn sample_writes_equal_arclength_points() {
    use strandfit::spline::BezierSpline;
    let out = strandfit_ok(
        &["sample", "--backend", "cpu", "--intervals", "5"],
        TWO_SPLINES,
    );
    let v = json(&out.stdout);
    let input = json(TWO_SPLINES.as_bytes());
    for (k, s) in v["splines"].as_array().unwrap().iter().enumerate() {
        assert_eq!(s["id"], input["splines"][k]["id"]);
        let cps = points(&input["splines"][k]["control_points"]);
        let want = BezierSpline::from_control_points(&cps)
            .unwrap()
            .sample_equal_arclen(5)
            .unwrap();
        let pts = s["points"].as_array().unwrap();
        let tans = s["tangents"].as_array().unwrap();
        assert_eq!((pts.len(), tans.len()), (6, 6));
        for (j, (p, t)) in want.iter().enumerate() {
            assert_eq!(v3(&pts[j]), *p);
            assert_eq!(v3(&tans[j]), *t);
        }
    }
    let bad = strandfit(&["sample", "--intervals", "0"], TWO_SPLINES);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--intervals"));
    let bad = strandfit(
        &["sample", "--backend", "cpu", "--intervals", "2"],
        r#"{"splines":[{"id":"nan","control_points":[[0,0,0],[1,0,0],[2,0,0],[3,0,null]]}]}"#,
    );
    assert!(!bad.status.success());
}

/// `integrate`: a circle (κ constant, τ = 0) of radius 1 over half a turn
/// ends at (0, 2, 0) facing back; samples include both ends; bad lines give
/// errors naming the line and never stop the others.
#[test]
fn integrate_answers_every_line() {
    let input = concat!(
        r#"{"start":[0,0,0],"tangent":[1,0,0],"normal":[0,1,0],"kappa0":1,"length":3.141592653589793}"#,
        "\n",
        "junk\n",
        r#"{"start":[0,0,0],"tangent":[1,0,0],"normal":[1,0,0],"kappa0":1,"length":1}"#,
        "\n",
        r#"{"start":[0,0,0],"tangent":[1,0,0],"normal":[0,1,0],"kappa0":1,"length":-1}"#,
        "\n",
        r#"{"start":[1,2,3],"tangent":[0,0,1],"normal":[1,0,0],"kappa0":0.5,"gamma":0.2,"tau0":0.3,"delta":-0.1,"length":5}"#,
        "\n",
    );
    let out = strandfit_ok(
        &["integrate", "--backend", "cpu", "--steps", "512", "-m", "5"],
        input,
    );
    let lines: Vec<serde_json::Value> = out
        .stdout
        .split(|&b| b == b'\n')
        .filter(|l| !l.is_empty())
        .map(json)
        .collect();
    assert_eq!(lines.len(), 5);
    // Fourth order: (π/512)⁴ ≈ 1.4e-9, times a small constant.
    let end = v3(&lines[0]["end"]);
    assert!(
        (end - strandfit::DVec3::new(0.0, 2.0, 0.0)).length() < 1e-9,
        "{end}"
    );
    assert!((v3(&lines[0]["tangent"]) + strandfit::DVec3::X).length() < 1e-12);
    let pts = points(&lines[0]["points"]);
    assert_eq!(pts.len(), 5);
    assert_eq!(pts[0], strandfit::DVec3::ZERO);
    assert_eq!(pts[4], end);
    assert!((pts[2] - strandfit::DVec3::new(1.0, 1.0, 0.0)).length() < 1e-9);
    assert!(lines[1]["failure"].as_str().unwrap().contains("line 2"));
    assert!(lines[2]["failure"]
        .as_str()
        .unwrap()
        .contains("orthonormal"));
    assert!(lines[3]["failure"].as_str().unwrap().contains("line 4"));
    assert_eq!(
        v3(&lines[4]["points"][0]),
        strandfit::DVec3::new(1.0, 2.0, 3.0)
    );
    assert!(!strandfit(&["integrate", "--steps", "0"], "")
        .status
        .success());
    assert!(!strandfit(&["integrate", "-m", "1"], "").status.success());
}

/// `strandfit … | head`: a closed pipe ends the program quietly (SIGPIPE),
/// not with a panic from println!.
#[cfg(unix)]
#[test]
fn closed_stdout_pipe_is_not_a_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(["inspect", "tests/data/fibres/dipy_fornix_tracks300.tck"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away at once
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn complete_fills_gaps_with_euler_spirals() {
    let out = strandfit_ok(&["complete", "--points", "9", "examples/gaps.json"], "");
    let doc = json(&out.stdout);
    let pairs = doc["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 4);
    // Roundness: a quarter of the unit circle. The solve stops at the step
    // count whose truncation error is below 1e-7 of |p1 − p0| (here the
    // first, 32); κ₀ and L absorb Simpson's position error there (2e-9).
    let q = &pairs[0];
    assert_eq!(q["id"], "quarter-circle");
    assert!((q["kappa0"].as_f64().unwrap() - 1.0).abs() < 1e-8, "{q}");
    assert!(q["gamma"].as_f64().unwrap().abs() < 1e-9);
    assert!((q["length"].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-8);
    assert_eq!(q["regular"], true);
    // Samples run from p0 to p1.
    let pts = points(&q["points"]);
    assert_eq!(pts.len(), 9);
    assert!(
        pts[8].distance(strandfit::DVec3::new(0.0, 1.0, 0.0)) < 1e-9,
        "{}",
        pts[8]
    );
    // A non-planar pair is met too.
    assert_eq!(pairs[2]["regular"], true, "{}", pairs[2]);
    // A bad pair gets its own error; the batch goes on.
    let e = pairs[3]["failure"].as_str().unwrap();
    assert!(e.contains("coincident") && e.contains("pairs[3]"), "{e}");
}

#[test]
fn complete_with_atph_curves() {
    let out = strandfit_ok(
        &[
            "complete",
            "--method",
            "atph",
            "--points",
            "9",
            "examples/gaps.json",
        ],
        "",
    );
    let doc = json(&out.stdout);
    let pairs = doc["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 4);
    // The quarter circle: a planar field (the equator), linear ρ = π/2,
    // every sample on the unit circle, from p0 to p1.
    let q = &pairs[0];
    assert_eq!(q["id"], "quarter-circle");
    for r in q["rho"].as_array().unwrap() {
        assert!(
            (r.as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-14,
            "{q}"
        );
    }
    assert_eq!(
        (q["regular"].clone(), q["forward"].clone()),
        (true.into(), true.into())
    );
    let pts = points(&q["points"]);
    assert_eq!(pts.len(), 9);
    assert!(pts.iter().all(|p| (p.length() - 1.0).abs() < 1e-14));
    assert!(pts[8].distance(strandfit::DVec3::Y) < 1e-15);
    // An S curve needs an inflection, which a linear azimuth cannot make in
    // the plane: its own error, naming the pair.
    let e = pairs[1]["failure"].as_str().unwrap();
    assert!(e.contains("\"s-curve\"") && e.contains("singular"), "{e}");
    // The twisted pair is met (error ~ 0) and its regularity reported.
    let t = &pairs[2];
    assert!(t["residual"].as_f64().unwrap() < 1e-24, "{t}");
    assert_eq!(t["rho"].as_array().unwrap().len(), 3);
    assert!(t["regular"].is_boolean());
    assert!(pairs[3]["failure"].as_str().unwrap().contains("coincide"));
}

#[test]
fn complete_atph_with_prescribed_lengths() {
    // Fig. 5 of paper 002 with L = 6 (regular), and a pair of its own
    // length overriding --length.
    let input = r#"{"pairs":[
        {"id":"fig5","p0":[0,0,0],"t0":[1,0,0],"p1":[1.5,4,2],"t1":[-3,2,3]},
        {"id":"own","p0":[0,0,0],"t0":[1,0,0],"p1":[1,0,1],"t1":[0,0,1],"length":1.7}]}"#;
    let out = strandfit_ok(&["complete", "--method", "atph", "--length", "6"], input);
    let doc = json(&out.stdout);
    let f = &doc["pairs"][0];
    assert_eq!(f["rho"].as_array().unwrap().len(), 4, "{f}");
    assert!((f["length"].as_f64().unwrap() - 6.0).abs() < 1e-12, "{f}");
    assert_eq!(f["forward"], true);
    let o = &doc["pairs"][1];
    assert!((o["length"].as_f64().unwrap() - 1.7).abs() < 1e-12, "{o}");
    // --length is for ATPH only, and must be a positive number.
    let out = strandfit(&["complete", "--length", "6"], input);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--method atph"));
    let out = strandfit(&["complete", "--method", "atph", "--length=-1"], input);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("positive"));
    // A per-pair length with the Euler method is that pair's error.
    let out = strandfit(&["complete"], input);
    let doc = json(&out.stdout);
    assert!(doc["pairs"][1]["failure"]
        .as_str()
        .unwrap()
        .contains("atph"));
}

#[test]
fn motion_through_a_point_stream() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("motion.vtk");
    let out = strandfit_ok(
        &[
            "motion",
            "--points",
            "9",
            "examples/motion.json",
            "--vtk",
            vtk.to_str().unwrap(),
        ],
        "",
    );
    let doc = json(&out.stdout);
    assert_eq!(doc["id"], "example-5.6");
    let segs = doc["segments"].as_array().unwrap();
    assert_eq!(segs.len(), 5);
    // Each quintic runs from its data point to the next (control points
    // r0 and r5), and consecutive ones join.
    let data = [
        [0.0, 0.0, 0.0],
        [-5.0, 5.0, 2.0],
        [0.0, 10.0, -2.0],
        [8.0, 12.0, 5.0],
        [15.0, 2.0, 3.0],
        [2.0, 0.0, 7.0],
    ];
    for (k, s) in segs.iter().enumerate() {
        let cp = points(&s["control_points"]);
        assert_eq!(cp.len(), 6);
        assert!(cp[0].distance(strandfit::DVec3::from(data[k])) < 1e-9);
        assert!(
            cp[5].distance(strandfit::DVec3::from(data[k + 1])) < 1e-9,
            "{}",
            cp[5]
        );
        assert_eq!(s["pre_image"].as_array().unwrap().len(), 3);
    }
    // Samples: orthonormal right-handed frames, f1 the path's direction.
    let samples = doc["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 9);
    for s in samples {
        let (f1, f2, f3) = (v3(&s["f1"]), v3(&s["f2"]), v3(&s["f3"]));
        assert!((f1.length() - 1.0).abs() < 1e-12 && f1.dot(f2).abs() < 1e-12);
        assert!((f1.cross(f2) - f3).length() < 1e-12);
    }
    // The VTK export reads back with the frame arrays as point data.
    let inspect = strandfit(&["inspect", "--json", vtk.to_str().unwrap()], "");
    assert!(
        inspect.status.success(),
        "{}",
        String::from_utf8_lossy(&inspect.stderr)
    );
    let report = String::from_utf8_lossy(&inspect.stdout);
    assert!(report.contains("f1") && report.contains("f3"), "{report}");
}

#[test]
fn motion_batches_json_lines_and_names_bad_streams() {
    let out = strandfit_ok(&["motion", "examples/motions.jsonl"], "");
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4);
    // Example 5.5 of the paper: Algorithm 1 inserts p_m (c = 1/8).
    let ins = &lines[0]["inserted"][0];
    assert_eq!(ins["after"], 1);
    let pm = v3(&ins["point"]);
    assert!(
        pm.distance(strandfit::DVec3::new(-2.29636, 8.60499, 2.18027)) < 2e-5,
        "{pm}"
    );
    // A given frame is kept: the first segment starts along its u.
    assert_eq!(lines[2]["id"], "example-5.7");
    let e = lines[3]["failure"].as_str().unwrap();
    assert!(
        e.contains("line 4") && e.contains("points 1 and 2 coincide"),
        "{e}"
    );
    // A frame that is not orthonormal, and a document that is not a stream.
    let bad = r#"{"points":[[0,0,0],[1,1,0],[2,0,1]],"frame":[[1,0,0],[1,1,0],[0,0,1]]}"#;
    let out = strandfit(&["motion"], bad);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("orthonormal"));
    let out = strandfit(&["motion"], "[1,2,3]");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("<stdin>"));
}

#[test]
fn sketch_lifts_the_bundled_spring_drawing() {
    // examples/spring.svg: the projection of a helix of radius 30, pitch
    // 9 per radian, axis tilted 60° out of the page (c = 30°), 2.5 turns.
    let dir = tempfile::tempdir().unwrap();
    let out_json = dir.path().join("spring.json");
    let preview = dir.path().join("preview.svg");
    strandfit_ok(
        &[
            "sketch",
            "examples/spring.svg",
            "-o",
            out_json.to_str().unwrap(),
            "--preview",
            preview.to_str().unwrap(),
        ],
        "",
    );
    let doc = json(&std::fs::read(&out_json).unwrap());
    let helices = doc["helices"].as_array().unwrap();
    assert_eq!(helices.len(), 1, "{doc}");
    let h = &helices[0];
    // The drawing is a polyline through the curve (its chords are within
    // 0.02 of it), so the parameters come back to about 1e-3.
    assert!((h["radius"].as_f64().unwrap() - 30.0).abs() < 0.05, "{h}");
    assert!(
        (h["pitch_per_turn"].as_f64().unwrap() - 18.0 * std::f64::consts::PI).abs() < 0.1,
        "{h}"
    );
    assert!(
        (h["c"].as_f64().unwrap().abs() - 30f64.to_radians()).abs() < 1e-3,
        "{h}"
    );
    assert!(doc["projection"]["max_relative_distance"].as_f64().unwrap() < 1e-4);
    let n = doc["points_3d"].as_array().unwrap().len();
    assert_eq!(h["last_vertex"].as_u64().unwrap() as usize, n - 1);
    let svg = std::fs::read_to_string(&preview).unwrap();
    assert_eq!(svg.matches("<polyline").count(), 2, "sketch + one helix");
}

/// The benchmark's two-helix drawing at 200 vertices, written to
/// `dir/two.json`; its path and points.
fn two_helix_drawing(dir: &std::path::Path) -> (std::path::PathBuf, Vec<[f64; 2]>) {
    let input = dir.join("two.json");
    let pts: Vec<[f64; 2]> = strandfit::synthetic::synthetic_sketch(200)
        .iter()
        .map(|p| p.to_array())
        .collect();
    std::fs::write(&input, serde_json::to_string(&pts).unwrap()).unwrap();
    (input, pts)
}

/// `strandfit sketch INPUT EXTRA… -o DIR/out.json`, which must succeed;
/// the JSON written.
fn sketch_json(dir: &Path, input: &Path, extra: &[&str]) -> serde_json::Value {
    let out_json = dir.join("out.json");
    let mut args = vec![
        "sketch",
        input.to_str().unwrap(),
        "-o",
        out_json.to_str().unwrap(),
    ];
    args.extend(extra);
    strandfit_ok(&args, "");
    json(&std::fs::read(&out_json).unwrap())
}

#[test]
fn sketch_reports_the_noise_of_a_noisy_drawing_and_its_emax() {
    // Issue 22: a drawing with Gaussian noise of 0.1 % of its length (half
    // a pixel on a 500-pixel stroke). The command reports the noise it
    // estimates and the E_max it chose above it (5 times the noise), and
    // lifts two helices; `--emax` overrides the choice.
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let d = strandfit::synthetic::synthetic_sketch(500);
    let length: f64 = d.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    let sigma = 1e-3 * length;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut gauss = move || {
        let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
        let v: f64 = rng.gen();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let pts: Vec<[f64; 2]> = d
        .iter()
        .map(|p| [p.x + sigma * gauss(), p.y + sigma * gauss()])
        .collect();
    let input = dir.path().join("noisy.json");
    std::fs::write(&input, serde_json::to_string(&pts).unwrap()).unwrap();
    let run = |extra: &[&str]| sketch_json(dir.path(), &input, extra);
    let doc = run(&[]);
    let noise = doc["noise_distance"].as_f64().unwrap();
    let emax = doc["emax_distance"].as_f64().unwrap();
    let l = doc["length"].as_f64().unwrap();
    assert!(
        (noise / sigma - 1.0).abs() < 0.15,
        "noise {noise} against {sigma}"
    );
    assert!((emax / (5.0 * noise) - 1.0).abs() < 1e-9, "{emax} {noise}");
    assert_eq!(doc["denoised"], true);
    assert_eq!(
        doc["helices"].as_array().unwrap().len(),
        2,
        "{}",
        doc["helices"]
    );
    // Every drawn vertex within a few times the noise of the lift.
    let drawn = doc["projection"]["drawn_max_distance"].as_f64().unwrap();
    assert!(drawn < 8.0 * sigma, "{drawn} against σ {sigma}");
    // Given, E_max is that fraction of the length; the noise is still told.
    let given = run(&["--emax", "0.02"]);
    let emax = given["emax_distance"].as_f64().unwrap();
    assert!((emax / (0.02 * l) - 1.0).abs() < 1e-9, "{emax} {l}");
    assert_eq!(given["noise_distance"].as_f64().unwrap(), noise);
}

#[test]
fn sketch_evens_out_an_uneven_drawing_keeping_its_vertices() {
    // The benchmark's two-helix drawing at 200 vertices, sampled evenly in
    // the helix parameter (edges up to ~5x apart). Densified (default):
    // every drawn vertex is kept, so the fit is exact and the junction is
    // a drawn vertex; uniform (the paper's): as many points as drawn.
    let dir = tempfile::tempdir().unwrap();
    let (input, pts) = two_helix_drawing(dir.path());
    let run = |extra: &[&str]| sketch_json(dir.path(), &input, extra);
    let dense = run(&[]);
    assert_eq!(dense["resampled"], true);
    assert_eq!(dense["resampling"], "densify");
    let lifted: Vec<[f64; 2]> = dense["points_3d"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
        .collect();
    assert!(
        lifted.len() > 200 && lifted.len() <= 400,
        "{}",
        lifted.len()
    );
    let mut it = lifted.iter();
    assert!(
        pts.iter().all(|p| it.any(|q| q == p)),
        "a drawn vertex was moved"
    );
    assert_eq!(dense["helices"].as_array().unwrap().len(), 2, "{dense}");
    assert!(
        dense["projection"]["max_relative_distance"]
            .as_f64()
            .unwrap()
            < 1e-5
    );
    let uniform = run(&["--resample", "uniform"]);
    assert_eq!(uniform["resampling"], "uniform");
    assert_eq!(uniform["points_3d"].as_array().unwrap().len(), 200);
    let bad = strandfit(
        &["sketch", input.to_str().unwrap(), "--resample", "cubic"],
        "",
    );
    assert!(!bad.status.success());
}

#[test]
fn sketch_g1_refits_a_two_helix_drawing() {
    // Two helices meeting with a tangent gap in the lift; --g1 adds the
    // floating-tangents re-fit: G1 to rounding, within its tolerance, its
    // projection within its 3D distance of the drawing.
    let dir = tempfile::tempdir().unwrap();
    let (input, _) = two_helix_drawing(dir.path());
    let out_json = dir.path().join("out.json");
    strandfit_ok(
        &[
            "sketch",
            input.to_str().unwrap(),
            "-o",
            out_json.to_str().unwrap(),
            "--g1",
        ],
        "",
    );
    let doc = json(&std::fs::read(&out_json).unwrap());
    assert!(doc["helices"].as_array().unwrap().len() >= 2, "{doc}");
    let g = &doc["g1"];
    let t = g["tolerance"].as_f64().unwrap();
    assert!(
        (t - doc["emax_distance"].as_f64().unwrap()).abs() <= 1e-12 * t,
        "{g}"
    );
    assert_eq!(g["within_tolerance"], true, "{g}");
    assert!(g["continuity_angle_deg"].as_f64().unwrap() < 1e-5, "{g}");
    let d3 = g["distance_3d"].as_f64().unwrap();
    let dp = g["projection_distance"].as_f64().unwrap();
    assert!(d3 <= t && dp <= d3 * (1.0 + 1e-6) + t / 64.0, "{g}");
    let n = g["element_count"].as_u64().unwrap() as usize;
    assert_eq!(g["chain"]["elements"].as_array().unwrap().len(), n);
    // Without --g1 there is no such section; the tolerance needs --g1.
    let out = strandfit(&["sketch", "examples/spring.svg"], "");
    assert!(out.status.success());
    assert!(json(&out.stdout).get("g1").is_none());
    let out = strandfit(
        &["sketch", "examples/spring.svg", "--g1-tolerance", "0.1"],
        "",
    );
    assert!(!out.status.success());
}

#[test]
fn sketch_refuses_bad_drawings_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let two = dir.path().join("two.json");
    std::fs::write(&two, "[[0,0],[1,1]]").unwrap();
    let target = dir.path().join("out.json");
    let out = strandfit(
        &[
            "sketch",
            two.to_str().unwrap(),
            "-o",
            target.to_str().unwrap(),
        ],
        "",
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("two.json") && err.contains("at least 3"),
        "{err}"
    );
    assert!(!target.exists());
    let bad = dir.path().join("draw.png");
    std::fs::write(&bad, "x").unwrap();
    let out = strandfit(&["sketch", bad.to_str().unwrap()], "");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("draw.png"));
    let out = strandfit(&["sketch", "examples/spring.svg", "--alpha-t", "1.5"], "");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--alpha-t"));
}
