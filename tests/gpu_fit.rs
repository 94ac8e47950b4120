//! `strandfit fit --backend gpu` against `--backend cpu` on the bundled
//! example, in both kernel precisions, through the command line.

mod common;

use std::process::Command;

use serde_json::Value;

fn run_fit(backend: &str, precision: &str) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args([
            "--backend",
            backend,
            "--precision",
            precision,
            "fit",
            "-n",
            "20",
        ])
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/curls.json"))
        .env(
            "XDG_RUNTIME_DIR",
            std::env::var("XDG_RUNTIME_DIR").unwrap_or("/tmp".into()),
        )
        .output()
        .expect("run strandfit");
    assert!(
        out.status.success(),
        "strandfit --backend {backend} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
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
