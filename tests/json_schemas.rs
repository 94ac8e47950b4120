//! The JSON outputs against their schemas (`docs/schemas/<command>.schema.json`,
//! `docs/json.md`): every command writes JSON and has a schema, every
//! output of the commands validates against it (failures and optional
//! parts included), the schemas are valid JSON Schema (draft 2020-12), and
//! a key names one kind of value in every schema.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::Value;

/// Commands whose output (standard output or `-o`) is JSON without a
/// `--json` flag; those with `--json` are found from the command line's
/// definition.
const JSON_OUTPUT: [&str; 8] = [
    "helix",
    "fit",
    "sample",
    "evaluate",
    "integrate",
    "complete",
    "motion",
    "sketch",
];
/// Commands that write no JSON.
const NO_JSON: [&str; 0] = [];

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn schema_path(command: &str) -> PathBuf {
    root().join(format!("docs/schemas/{command}.schema.json"))
}

fn schema(command: &str) -> Value {
    let p = schema_path(command);
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Run the binary in the package root; returns (exit code, stdout).
fn run(args: &[&str], stdin: &str) -> (Option<i32>, Vec<u8>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .current_dir(root())
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run strandfit");
    let _ = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    let out = child.wait_with_output().unwrap();
    (out.status.code(), out.stdout)
}

fn run_ok(args: &[&str], stdin: &str) -> Vec<u8> {
    let (code, out) = run(args, stdin);
    assert_eq!(code, Some(0), "{args:?}");
    out
}

/// The documents of an output: one, or one per line (JSON Lines).
fn documents(out: &[u8], lines: bool) -> Vec<Value> {
    let text = std::str::from_utf8(out).unwrap();
    if lines {
        text.lines()
            .map(|l| serde_json::from_str(l).expect("a JSON line"))
            .collect()
    } else {
        vec![serde_json::from_str(text).expect("a JSON document")]
    }
}

/// Validate `docs` against `command`'s schema; also their `version`.
fn check(command: &str, docs: &[Value]) {
    let s = schema(command);
    let v = jsonschema::validator_for(&s).unwrap_or_else(|e| panic!("{command}: {e}"));
    assert!(!docs.is_empty(), "{command}: no output");
    for d in docs {
        let errors: Vec<String> = v
            .iter_errors(d)
            .map(|e| format!("{} at {}", e, e.instance_path()))
            .collect();
        let mut shown = d.to_string();
        shown.truncate(2000);
        assert!(errors.is_empty(), "{command}: {errors:#?}\n{shown}");
        assert_eq!(
            d["version"].as_u64(),
            Some(strandfit::cli::JSON_VERSION as u64),
            "{command}"
        );
    }
}

#[test]
fn every_command_that_writes_json_has_a_schema_and_no_other_does() {
    let cli = strandfit::cli::command();
    let mut want = BTreeSet::new();
    for c in cli.get_subcommands() {
        let name = c.get_name();
        let has_json_flag = c.get_arguments().any(|a| a.get_long() == Some("json"));
        if has_json_flag || JSON_OUTPUT.contains(&name) {
            assert!(!NO_JSON.contains(&name), "{name}: writes JSON");
            want.insert(name.to_string());
            assert!(
                schema_path(name).exists(),
                "{name} writes JSON: docs/schemas/{name}.schema.json is missing"
            );
        } else {
            assert!(
                NO_JSON.contains(&name),
                "a new command, {name}: does it write JSON? (tests/json_schemas.rs)"
            );
        }
    }
    let have: BTreeSet<String> = std::fs::read_dir(root().join("docs/schemas"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .map(|n| {
            n.strip_suffix(".schema.json")
                .unwrap_or_else(|| panic!("docs/schemas/{n}: not <command>.schema.json"))
                .to_string()
        })
        .collect();
    assert_eq!(
        have, want,
        "schemas without a command, or commands without one"
    );
    for name in &want {
        let s = schema(name);
        if let Err(e) = jsonschema::meta::validate(&s) {
            panic!("{name}.schema.json is not a valid JSON Schema: {e}");
        }
        assert_eq!(
            s["$schema"], "https://json-schema.org/draft/2020-12/schema",
            "{name}"
        );
    }
}

#[test]
fn every_json_output_matches_its_schema() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let fornix = "tests/data/fibres/dipy_fornix_tracks300.tck";

    // helix and integrate: JSON Lines, a bad line among them.
    let pairs = std::fs::read_to_string(root().join("examples/pairs.jsonl")).unwrap();
    let out = run_ok(
        &["helix", "--backend", "cpu"],
        &format!("{pairs}not json\n"),
    );
    let docs = documents(&out, true);
    assert!(docs.iter().any(|d| d["failure"].is_string()));
    check("helix", &docs);
    let spirals = std::fs::read_to_string(root().join("examples/spirals.jsonl")).unwrap();
    for extra in [&[][..], &["-m", "5"]] {
        let mut args = vec!["integrate", "--backend", "cpu"];
        args.extend_from_slice(extra);
        let out = run_ok(&args, &format!("{spirals}\n{{}}\n"));
        let docs = documents(&out, true);
        assert!(docs.iter().any(|d| d["failure"].is_string()));
        check("integrate", &docs);
    }

    // fit, then evaluate its output; sample.
    let fitted = tmp("fit.json");
    run_ok(
        &[
            "fit",
            "--backend",
            "cpu",
            "-n",
            "4",
            "examples/curls.json",
            "-o",
            &fitted,
        ],
        "",
    );
    check("fit", &documents(&std::fs::read(&fitted).unwrap(), false));
    for extra in [&[][..], &["--tangents"]] {
        let mut args = vec!["evaluate", "--backend", "cpu", "-m", "9", &fitted];
        args.extend_from_slice(extra);
        check("evaluate", &documents(&run_ok(&args, ""), false));
    }
    let out = run_ok(
        &[
            "sample",
            "--backend",
            "cpu",
            "--intervals",
            "5",
            "examples/curls.json",
        ],
        "",
    );
    check("sample", &documents(&out, false));

    // complete: both methods, with and without points; the examples hold
    // pairs that fail.
    for method in ["euler", "atph"] {
        for extra in [&[][..], &["-m", "5"]] {
            let mut args = vec!["complete", "--backend", "cpu", "--method", method];
            args.extend_from_slice(extra);
            args.push("examples/gaps.json");
            let docs = documents(&run_ok(&args, ""), false);
            let pairs = docs[0]["pairs"].as_array().unwrap();
            assert!(pairs.iter().any(|p| p["failure"].is_string()), "{method}");
            assert!(pairs.iter().any(|p| p["residual"].is_number()), "{method}");
            check("complete", &docs);
        }
    }

    // motion: one document, and JSON Lines with a bad line.
    let out = run_ok(&["motion", "-m", "5", "examples/motion.json"], "");
    check("motion", &documents(&out, false));
    let streams = std::fs::read_to_string(root().join("examples/motions.jsonl")).unwrap();
    let out = run_ok(
        &["motion", "--lines"],
        &format!("{streams}{{\"points\":[]}}\n"),
    );
    let docs = documents(&out, true);
    assert!(docs.iter().any(|d| d["failure"].is_string()));
    check("motion", &docs);

    // sketch, with and without the G1 re-fit.
    for extra in [&[][..], &["--g1"]] {
        let mut args = vec!["sketch", "examples/spring.svg"];
        args.extend_from_slice(extra);
        check("sketch", &documents(&run_ok(&args, ""), false));
    }

    // compress: version 3 and version 1.
    let sfh = tmp("f.sfh");
    let out = run_ok(
        &[
            "compress",
            fornix,
            "--tolerance",
            "0.5",
            "-o",
            &sfh,
            "--json",
        ],
        "",
    );
    check("compress", &documents(&out, false));
    let out = run_ok(
        &[
            "compress",
            fornix,
            "--distance",
            "ordered",
            "--tolerance",
            "0.5",
            "-o",
            &tmp("v1.sfh"),
            "--json",
        ],
        "",
    );
    check("compress", &documents(&out, false));

    // inspect: a curve file, both container versions, and a truncated
    // file (its report has a failure, and the command exits 1).
    for file in [fornix, &sfh, "tests/data/sfh/fornix_v1_ordered_0.5.sfh"] {
        check(
            "inspect",
            &documents(&run_ok(&["inspect", file, "--json"], ""), false),
        );
    }
    let bytes = std::fs::read(root().join(fornix)).unwrap();
    let cut = tmp("cut.tck");
    std::fs::write(&cut, &bytes[..bytes.len() - 1000]).unwrap();
    let (code, out) = run(&["inspect", &cut, "--json"], "");
    assert_eq!(code, Some(1));
    let docs = documents(&out, false);
    assert!(docs[0]["failure"].is_string(), "{}", docs[0]);
    check("inspect", &docs);

    // split and merge.
    let shards = tmp("shards");
    let out = run_ok(
        &[
            "split",
            &sfh,
            "--curves-per-shard",
            "4096",
            "-o",
            &shards,
            "--json",
        ],
        "",
    );
    let docs = documents(&out, false);
    check("split", &docs);
    let parts: Vec<String> = docs[0]["shards"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["path"].as_str().unwrap().to_string())
        .collect();
    let merged = tmp("merged.sfh");
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(String::as_str));
    args.extend(["-o", &merged, "--json"]);
    check("merge", &documents(&run_ok(&args, ""), false));

    // decompress: version 3 at its points (the guarantee holds), resampled
    // (it does not), a range of curves, and version 1; a container cut
    // short fails (exit 1) with a report that says why.
    let back = tmp("back.tck");
    for extra in [
        &[][..],
        &["-m", "20"],
        &["--step", "2"],
        &["--curves", "10:20"],
    ] {
        let mut args = vec!["decompress", &sfh, "-o", &back, "--json"];
        args.extend_from_slice(extra);
        let docs = documents(&run_ok(&args, ""), false);
        let resampled = matches!(extra.first(), Some(&"-m" | &"--step"));
        assert_eq!(docs[0]["guaranteed"], !resampled, "{extra:?}");
        assert!(docs[0]["output_point_count"].as_u64() > Some(0));
        check("decompress", &docs);
    }
    let v1 = "tests/data/sfh/fornix_v1_ordered_0.5.sfh";
    let docs = documents(
        &run_ok(&["decompress", v1, "-o", &tmp("v1.json"), "--json"], ""),
        false,
    );
    assert_eq!(docs[0]["container_version"], 1);
    check("decompress", &docs);
    let bytes = std::fs::read(&sfh).unwrap();
    let short = tmp("short.sfh");
    std::fs::write(&short, &bytes[..bytes.len() / 2]).unwrap();
    let never = tmp("never.tck");
    let (code, out) = run(&["decompress", &short, "-o", &never, "--json"], "");
    assert_eq!(code, Some(1));
    let docs = documents(&out, false);
    assert!(docs[0]["failure"].is_string(), "{}", docs[0]);
    check("decompress", &docs);

    // convert: per-point and per-curve data carried and dropped, curves
    // left out by --skip-bad; a file cut short fails (exit 1) with a
    // report.
    let complex = "tests/data/fibres/nibabel_fixtures/complex.trk";
    let bad = tmp("bad.csv");
    std::fs::write(
        &bad,
        "curve,x,y,z\na,0,0,0\na,1,0,0\nb,0,0,0\nb,1,NaN,0\nc,0,0,1\nc,1,0,1\n",
    )
    .unwrap();
    for (input, output, extra) in [
        (fornix, tmp("f.json"), &[][..]),
        (complex, tmp("c.csv"), &[][..]),
        (complex, tmp("c.tck"), &[][..]),
        (&bad, tmp("b.json"), &["--skip-bad"][..]),
    ] {
        let mut args = vec!["convert", input, "-o", &output, "--json"];
        args.extend_from_slice(extra);
        let docs = documents(&run_ok(&args, ""), false);
        check("convert", &docs);
    }
    let (code, out) = run(&["convert", &cut, "-o", &never, "--json"], "");
    assert_eq!(code, Some(1));
    let docs = documents(&out, false);
    assert!(docs[0]["failure"].is_string(), "{}", docs[0]);
    check("convert", &docs);

    // bench, small: every stage once, on the CPU, and on a GPU where there
    // is one (lavapipe will do: its rows have the GPU split), else a
    // failure; with a GPU adapter that does not exist it fails (exit 1)
    // with a report.
    let bench = |backend| {
        let args = [
            "bench",
            "--backend",
            backend,
            "--splines",
            "40",
            "-n",
            "4",
            "--segments",
            "2",
            "--repeat",
            "1",
            "--json",
        ];
        run(&args, "")
    };
    let (code, out) = bench("cpu");
    assert_eq!(code, Some(0));
    let docs = documents(&out, false);
    assert_eq!(docs[0]["stages"].as_array().map(Vec::len), Some(12));
    check("bench", &docs);
    let (code, out) = bench("gpu");
    let docs = documents(&out, false);
    match code {
        Some(0) => assert!(docs[0]["stages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["gpu_split"].is_object())),
        _ => assert!(docs[0]["failure"].is_string(), "{}", docs[0]),
    }
    check("bench", &docs);
    let out = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .current_dir(root())
        .args(["bench", "--backend", "gpu", "--repeat", "1", "--json"])
        .env("STRANDFIT_ADAPTER", "no such adapter, json_schemas.rs")
        .stderr(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let docs = documents(&out.stdout, false);
    assert!(docs[0]["failure"].is_string(), "{}", docs[0]);
    check("bench", &docs);
}

/// The checks can fail: outputs with a renamed, missing, mistyped or extra
/// key do not validate.
#[test]
fn the_schemas_refuse_what_the_commands_do_not_write() {
    let out = run_ok(&["complete", "--backend", "cpu", "examples/gaps.json"], "");
    let good = documents(&out, false).remove(0);
    let s = schema("complete");
    let v = jsonschema::validator_for(&s).unwrap();
    assert!(v.is_valid(&good));
    let mut bad = Vec::new();
    // The old name of the residual.
    let mut d = good.clone();
    let p = &mut d["pairs"][0];
    p["error"] = p["residual"].take();
    p.as_object_mut().unwrap().remove("residual");
    bad.push(d);
    // A failure that is not a string.
    let mut d = good.clone();
    let i = good["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .position(|p| p["failure"].is_string())
        .unwrap();
    d["pairs"][i]["failure"] = 1.into();
    bad.push(d);
    // No version, or another one.
    let mut d = good.clone();
    d.as_object_mut().unwrap().remove("version");
    bad.push(d);
    let mut d = good.clone();
    d["version"] = 2.into();
    bad.push(d);
    // A key the schema does not know.
    let mut d = good.clone();
    d["pairs"][0]["colour"] = "red".into();
    bad.push(d);
    for d in &bad {
        assert!(!v.is_valid(d), "{d}");
    }
}

/// The types a schema gives each property name, through `$ref`s, `oneOf`s
/// and `items`.
fn key_types(
    node: &Value,
    root: &Value,
    out: &mut BTreeMap<String, BTreeSet<String>>,
    depth: usize,
) {
    if depth > 32 {
        return;
    }
    match node {
        Value::Object(m) => {
            if let Some(Value::String(r)) = m.get("$ref") {
                let target = root
                    .pointer(r.trim_start_matches('#'))
                    .unwrap_or_else(|| panic!("dangling $ref {r}"));
                key_types(target, root, out, depth + 1);
            }
            if let Some(Value::Object(props)) = m.get("properties") {
                for (k, p) in props {
                    let mut p = p;
                    while let Some(Value::String(r)) = p.get("$ref") {
                        p = root.pointer(r.trim_start_matches('#')).unwrap();
                    }
                    let types: Vec<String> = match (p.get("type"), p.get("const"), p.get("enum")) {
                        (Some(Value::String(t)), _, _) => vec![t.clone()],
                        (Some(Value::Array(ts)), _, _) => {
                            ts.iter().map(|t| t.as_str().unwrap().to_string()).collect()
                        }
                        (None, Some(c), _) => vec![json_type(c)],
                        (None, None, Some(Value::Array(e))) => e.iter().map(json_type).collect(),
                        _ => vec![],
                    };
                    for t in types.into_iter().filter(|t| t != "null") {
                        out.entry(k.clone()).or_default().insert(t);
                    }
                }
            }
            for (k, v) in m {
                if k != "$ref" {
                    key_types(v, root, out, depth + 1);
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|v| key_types(v, root, out, depth + 1)),
        _ => {}
    }
}

fn json_type(v: &Value) -> String {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "boolean",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
    .to_string()
}

/// A key holds one kind of value in every command: `curves` is never a
/// count in one and a list in another, `error` never a number here and a
/// string there; counts are `*_count`, residuals `residual`, failures
/// `failure`, times `*seconds` and rates `*_per_second` numbers, paths and
/// formats strings.
#[test]
fn a_key_means_one_thing_in_every_schema() {
    let mut all: BTreeMap<String, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for e in std::fs::read_dir(root().join("docs/schemas")).unwrap() {
        let path = e.unwrap().path();
        let s: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let mut types = BTreeMap::new();
        key_types(&s, &s, &mut types, 0);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        for (k, ts) in types {
            for t in ts {
                all.entry(k.clone())
                    .or_default()
                    .entry(t)
                    .or_default()
                    .insert(name.clone());
            }
        }
    }
    let clashes: Vec<String> = all
        .iter()
        .filter(|(_, by_type)| by_type.len() > 1)
        .map(|(k, by_type)| format!("{k}: {by_type:?}"))
        .collect();
    assert!(
        clashes.is_empty(),
        "keys with more than one type: {clashes:#?}"
    );
    for k in ["error", "errors", "curves_count", "n_curves"] {
        assert!(!all.contains_key(k), "{k}: see docs/json.md for the names");
    }
    for (k, by_type) in &all {
        if k.ends_with("_count") {
            assert!(by_type.keys().eq(["integer"]), "{k}: a count is an integer");
        }
        if k.ends_with("seconds") || k.ends_with("_per_second") {
            assert!(
                by_type.keys().eq(["number"]),
                "{k}: a time or a rate is a number"
            );
        }
    }
    for k in [
        "input",
        "output",
        "input_format",
        "output_format",
        "backend",
    ] {
        assert!(all[k].keys().eq(["string"]), "{k}");
    }
    assert!(all["residual"].keys().eq(["number"]));
    assert!(all["failure"].keys().eq(["string"]));
    assert!(all["version"].keys().eq(["number"]));
}
