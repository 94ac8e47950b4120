//! `compress --backend gpu` against the CPU path: the candidate elements of
//! a block checked by `arc_check.wgsl` (in f64 and f32) give containers
//! byte-identical to the CPU's, on real tractography, hair and field lines
//! at both tolerances (and with the look-ahead, `Effort::Best`); the GPU
//! decides nearly all checks in f64; and the
//! command line writes the same file with either backend.

mod common;

use std::path::Path;
use std::process::Command;

use glam::DVec3;
use strandfit::codec::ArcChecker;
use strandfit::codec::{encode_block, encode_block_on, CodecParams, Effort};
use strandfit::gpu::GpuContext;
use strandfit::{Backend, GpuEngine, PrecisionChoice};

/// The first `n` curves of a file.
fn curves(path: &Path, n: usize) -> Vec<Vec<DVec3>> {
    let (_, cs) = strandfit::io::read_all(path, None).unwrap();
    cs.into_iter().take(n).map(|c| c.points).collect()
}

/// `n` bending fibres of 40 points jittered by Gaussian noise of 0.05 on
/// each axis: at 0.1 points win, so after the block's first chunk only a
/// sample of the arcs searches runs (the GPU path must skip the same ones).
fn jittered_fibres(n: usize) -> Vec<Vec<DVec3>> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut gauss = move || {
        let (u, v): (f64, f64) = (rng.gen_range(1e-12..1.0), rng.gen_range(0.0..1.0));
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos() * 0.05
    };
    (0..n)
        .map(|c| {
            (0..40)
                .map(|k| {
                    let s = 1.5 * k as f64;
                    DVec3::new(
                        s,
                        20.0 * (s / 25.0 + 0.01 * c as f64).sin(),
                        10.0 * (s / 15.0).cos(),
                    ) + DVec3::new(gauss(), gauss(), gauss())
                })
                .collect()
        })
        .collect()
}

/// A data set: name, curves, the two tolerances.
type DataSet = (&'static str, Vec<Vec<DVec3>>, [f64; 2]);

/// The data sets.
fn data() -> Vec<DataSet> {
    let mut sets = vec![(
        "fornix",
        curves(
            Path::new(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/data/fibres/dipy_fornix_tracks300.tck"
            )),
            300,
        ),
        [0.1, 0.5],
    )];
    sets.push(("jittered fibres", jittered_fibres(600), [0.1, 0.5]));
    if let Some(p) = common::shared_data("hair/synthetic_hair.hair") {
        sets.push(("hair", curves(&p, 300), [0.1, 0.5]));
    }
    if let Some(p) = common::shared_data("fieldlines/pfss_fieldlines_every10th_ascii.vtk") {
        sets.push(("field lines", curves(&p, 580), [0.001, 0.01]));
    }
    sets
}

fn parity(ctx: GpuContext, precision: PrecisionChoice, max_unsure: f64) {
    let backend = Backend::Gpu(Box::new(GpuEngine::new(ctx, precision).unwrap()));
    let checker = backend.arc_checker().unwrap().unwrap();
    for (name, cs, tolerances) in data() {
        // Every set at both tolerances, and at the looser also with the
        // look-ahead (`Effort::Best`, whose extra checks go through the
        // same mailboxes).
        let runs = tolerances
            .iter()
            .map(|&t| (t, Effort::Default))
            .chain([(tolerances[1], Effort::Best)]);
        for (tol, effort) in runs {
            let params = CodecParams {
                effort,
                ..CodecParams::new(tol)
            };
            let cpu = encode_block(&cs, &params).unwrap();
            let gpu =
                encode_block_on(&cs, &params, false, Some(&checker as &dyn ArcChecker)).unwrap();
            let c = gpu.checks;
            assert!(
                !c.fell_back,
                "{name} at {tol}: the GPU did not take the block"
            );
            assert!(c.checked > 1000, "{name} at {tol}: {c:?}");
            let unsure = c.unsure as f64 / c.checked as f64;
            assert!(
                unsure <= max_unsure,
                "{name} at {tol}: {:.3} % of the checks left to the CPU",
                100.0 * unsure
            );
            assert_eq!(
                gpu.bytes, cpu.bytes,
                "{name} at {tol} ({precision:?}, {effort:?})"
            );
            assert_eq!(gpu.output_points, cpu.output_points);
        }
    }
}

#[test]
fn gpu_f64_checks_write_the_cpu_bytes() {
    let Some(ctx) = common::gpu_f64_or_skip("gpu_f64_checks_write_the_cpu_bytes") else {
        return;
    };
    // In f64 the band is ~1e-12 of the tolerance: the CPU decides almost
    // nothing.
    parity(ctx, PrecisionChoice::F64, 1e-3);
}

#[test]
fn gpu_f32_checks_write_the_cpu_bytes() {
    let Some(ctx) = common::gpu_or_skip("gpu_f32_checks_write_the_cpu_bytes") else {
        return;
    };
    // In f32 the band is ~1e-4..1e-3 of the tolerance: more is left to the
    // CPU, and the bytes are still the CPU's.
    parity(ctx, PrecisionChoice::F32, 0.25);
}

#[test]
fn compress_backend_gpu_writes_the_file_the_cpu_writes() {
    if common::gpu_or_skip("compress_backend_gpu_writes_the_file_the_cpu_writes").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/fibres/dipy_fornix_tracks300.tck"
    );
    let run = |backend: &str, out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_strandfit"))
            .args([
                "compress",
                "--backend",
                backend,
                input,
                "--tolerance",
                "0.3",
            ])
            .args(["--json", "-o"])
            .arg(dir.path().join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (std::fs::read(dir.path().join(out)).unwrap(), report)
    };
    let (cpu, cpu_report) = run("cpu", "cpu.sfh");
    let (gpu, gpu_report) = run("gpu", "gpu.sfh");
    assert_eq!(cpu, gpu);
    assert!(cpu_report.get("gpu_checks").is_none());
    let checks = &gpu_report["gpu_checks"];
    assert!(
        checks["candidate_count"].as_u64().unwrap() > 1000,
        "{checks}"
    );
    assert_eq!(checks["cpu_block_count"].as_u64(), Some(0), "{checks}");
}
