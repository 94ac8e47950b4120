//! `strandfit fit --backend gpu` against `--backend cpu` on the bundled
//! example, in both kernel precisions, through the command line.

mod common;

use std::process::Command;

use serde_json::Value;

/// Run strandfit with `args` and parse its JSON output.
fn strandfit_json(args: &[&str], file: &std::path::Path) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(args)
        .arg(file)
        .env(
            "XDG_RUNTIME_DIR",
            std::env::var("XDG_RUNTIME_DIR").unwrap_or("/tmp".into()),
        )
        .output()
        .expect("run strandfit");
    assert!(
        out.status.success(),
        "strandfit {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

fn run_fit(backend: &str, precision: &str) -> Value {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/curls.json");
    strandfit_json(
        &[
            "fit",
            "--backend",
            backend,
            "--precision",
            precision,
            "-n",
            "20",
        ],
        example.as_ref(),
    )
}

/// Largest differences between two fit outputs: element parameters relative
/// to the element's ω (κ, τ) or length (L, start point), unit vectors
/// absolute, the Fréchet distance relative to the curve's length.
fn max_diff(a: &Value, b: &Value) -> f64 {
    let (ca, cb) = (
        a["curves"].as_array().unwrap(),
        b["curves"].as_array().unwrap(),
    );
    assert_eq!(ca.len(), cb.len());
    let mut worst = 0.0f64;
    for (x, y) in ca.iter().zip(cb) {
        assert_eq!(x["id"], y["id"]);
        let (ex, ey) = (
            x["elements"].as_array().unwrap(),
            y["elements"].as_array().unwrap(),
        );
        assert_eq!(ex.len(), ey.len());
        for (p, q) in ex.iter().zip(ey) {
            let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
            let omega = f(q, "curvature").hypot(f(q, "torsion"));
            let len = f(q, "length");
            worst = worst
                .max((f(p, "curvature") - f(q, "curvature")).abs() / omega)
                .max((f(p, "torsion") - f(q, "torsion")).abs() / omega)
                .max((f(p, "length") - len).abs() / len);
            for k in ["start", "tangent", "axis"] {
                let scale = if k == "start" { len } else { 1.0 };
                for i in 0..3 {
                    let d = (p[k][i].as_f64().unwrap() - q[k][i].as_f64().unwrap()).abs();
                    worst = worst.max(d / scale);
                }
            }
        }
        // Fréchet distance: a difference of sampled positions, so relative
        // to the curve's length (not to the distance itself, which is
        // ~1e-13 for the straight example).
        let total: f64 = ey.iter().map(|e| e["length"].as_f64().unwrap()).sum();
        let fr = y["frechet"].as_f64().unwrap();
        worst = worst.max((x["frechet"].as_f64().unwrap() - fr).abs() / total);
    }
    worst
}

/// Tolerances: the GPU path differs from the CPU one only in Ghosh's root
/// (bisection with polynomial sin/cos instead of Brent with libm), measured
/// in `tests/gpu_ghosh.rs` at ≤ 100 ε of the kernel's precision relative to
/// ω and L on all well-conditioned data; the example's elements have
/// θ ≥ 0.05, so 1e3 ε covers the 1/θ conditioning with margin.
#[test]
fn fit_gpu_matches_cpu_on_the_bundled_example() {
    let Some(ctx) = common::gpu_or_skip("fit_gpu_matches_cpu_on_the_bundled_example") else {
        return;
    };
    let cpu = run_fit("cpu", "auto");
    if ctx.supports_f64() {
        let d = max_diff(&run_fit("gpu", "f64"), &cpu);
        eprintln!("f64 kernel vs cpu: {d:e}");
        assert!(d <= 1e3 * f64::EPSILON, "f64: {d:e}");
    }
    let d = max_diff(&run_fit("gpu", "f32"), &cpu);
    eprintln!("f32 kernel vs cpu: {d:e}");
    assert!(d <= 1e3 * f32::EPSILON as f64, "f32: {d:e}");
}

fn run_evaluate(fitted: &std::path::Path, backend: &str, precision: &str) -> Value {
    let args = [
        "evaluate",
        "--backend",
        backend,
        "--precision",
        precision,
        "-m",
        "1001",
        "--tangents",
    ];
    strandfit_json(&args, fitted)
}

/// Largest point difference relative to the curve's length, and largest
/// tangent difference, between two `evaluate` outputs.
fn max_sample_diff(a: &Value, b: &Value, lengths: &[f64]) -> (f64, f64) {
    let (mut p, mut t) = (0.0f64, 0.0f64);
    for ((x, y), len) in a["curves"]
        .as_array()
        .unwrap()
        .iter()
        .zip(b["curves"].as_array().unwrap())
        .zip(lengths)
    {
        assert_eq!(x["id"], y["id"]);
        for (key, worst, scale) in [("points", &mut p, *len), ("tangents", &mut t, 1.0)] {
            let (u, v) = (x[key].as_array().unwrap(), y[key].as_array().unwrap());
            assert_eq!(u.len(), v.len());
            for (q, r) in u.iter().zip(v) {
                for i in 0..3 {
                    let d = (q[i].as_f64().unwrap() - r[i].as_f64().unwrap()).abs();
                    *worst = worst.max(d / scale);
                }
            }
        }
    }
    (p, t)
}

/// `evaluate --backend gpu` (helix_eval.wgsl) against `--backend cpu` on the
/// bundled example's fitted chains. Tolerances from `tests/gpu_helix_eval.rs`
/// (≤ 40 ε·L for points, ≤ 80 ε for tangents against the reference), plus the
/// `f64` rounding of `p₀ + offset` (≤ 4 ε₆₄ (|p₀| + L), which relative to
/// the whole curve's length is below 40 ε₆₄ for this example).
#[test]
fn evaluate_gpu_matches_cpu_on_the_bundled_example() {
    let Some(ctx) = common::gpu_or_skip("evaluate_gpu_matches_cpu_on_the_bundled_example") else {
        return;
    };
    let fitted = run_fit("cpu", "auto");
    let lengths: Vec<f64> = fitted["curves"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            c["elements"]
                .as_array()
                .unwrap()
                .iter()
                .map(|e| e["length"].as_f64().unwrap())
                .sum()
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fit.json");
    std::fs::write(&path, serde_json::to_vec(&fitted).unwrap()).unwrap();
    let cpu = run_evaluate(&path, "cpu", "auto");
    let mut runs = vec![("f32", f32::EPSILON as f64)];
    if ctx.supports_f64() {
        runs.push(("f64", f64::EPSILON));
    }
    for (precision, eps) in runs {
        let (p, t) = max_sample_diff(&run_evaluate(&path, "gpu", precision), &cpu, &lengths);
        eprintln!(
            "evaluate {precision} kernel vs cpu: points {:.2} ε·L, tangents {:.2} ε",
            p / eps,
            t / eps
        );
        assert!(p <= 80.0 * eps, "{precision}: points {p:e}");
        assert!(t <= 80.0 * eps, "{precision}: tangents {t:e}");
    }
}

/// `integrate --backend gpu` (frenet_integrate.wgsl) against `--backend cpu`
/// on a family of Euler spirals through the command line. The kernel and
/// the reference run the same scheme at the same step count, so only
/// rounding differs: `tests/gpu_frenet.rs` bounds it by 2(√N + Θ)ε on the
/// frame and on the offset relative to L (N steps, Θ total turning), plus
/// 4ε₆₄(|x₀| + L) for the host's f64 addition. Here N = 256 and Θ ≤ 12.
#[test]
fn integrate_gpu_matches_cpu() {
    let Some(ctx) = common::gpu_or_skip("integrate_gpu_matches_cpu") else {
        return;
    };
    let mut lines = String::new();
    for i in 0..200 {
        let x = i as f64 / 200.0;
        lines.push_str(&format!(
            "{{\"start\":[{},{},0.5],\"tangent\":[0,0,1],\"normal\":[0,1,0],\"kappa0\":{},\"gamma\":{},\"tau0\":{},\"delta\":{},\"length\":{}}}\n",
            10.0 * x,
            -3.0 * x,
            2.0 * x - 0.5,
            0.3 - x,
            1.5 * (x - 0.5),
            0.1 * x,
            1.0 + 3.0 * x
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("spirals.jsonl");
    std::fs::write(&path, &lines).unwrap();
    let run = |backend: &str, precision: &str| -> Vec<Value> {
        let args = [
            "integrate",
            "--backend",
            backend,
            "--precision",
            precision,
            "--steps",
            "256",
            "-m",
            "9",
        ];
        let out = Command::new(env!("CARGO_BIN_EXE_strandfit"))
            .args(args)
            .arg(&path)
            .env(
                "XDG_RUNTIME_DIR",
                std::env::var("XDG_RUNTIME_DIR").unwrap_or("/tmp".into()),
            )
            .output()
            .expect("run strandfit");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out.stdout
            .split(|&b| b == b'\n')
            .filter(|l| !l.is_empty())
            .map(|l| serde_json::from_slice(l).unwrap())
            .collect()
    };
    let cpu = run("cpu", "auto");
    let mut runs = vec![("f32", f32::EPSILON as f64)];
    if ctx.supports_f64() {
        runs.push(("f64", f64::EPSILON));
    }
    for (precision, eps) in runs {
        let gpu = run("gpu", precision);
        assert_eq!(gpu.len(), cpu.len());
        let mut worst = 0.0f64;
        for (g, c) in gpu.iter().zip(&cpu) {
            assert!(c["failure"].is_null() && g["failure"].is_null());
            // Absolute, in units of ε: 2(√256 + 12)·L ≤ 224 (L ≤ 4) for the
            // scheme's rounding plus 4(|x₀| + L) ≤ 60 for the host's f64
            // addition (f64 only; f32 has no such term but a larger ε): 300.
            for key in ["end", "tangent", "normal", "binormal"] {
                for i in 0..3 {
                    let d = (g[key][i].as_f64().unwrap() - c[key][i].as_f64().unwrap()).abs();
                    worst = worst.max(d / eps);
                }
            }
        }
        eprintln!("integrate {precision} kernel vs cpu: worst {worst:.2} ε");
        assert!(worst <= 300.0, "{precision}: {worst} ε");
    }
}
