//! Every WGSL kernel, in both precisions, parsed and validated by naga (the
//! compiler wgpu uses) on any machine, GPU or not: a broken shader fails
//! here before it reaches a device. And every file of `shaders/` is a
//! kernel of that list (but `math.wgsl`, which each kernel includes), so a
//! new kernel cannot be left out.

use std::collections::BTreeSet;

use strandfit::kernels::kernel_sources;
use strandfit::twin::Real;
use wgpu::naga;

fn validate<R: Real>() -> BTreeSet<&'static str> {
    let mut names = BTreeSet::new();
    for (name, source) in kernel_sources::<R>() {
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{name} ({}): {}", R::WGSL, e.emit_to_string(&source)));
        let caps = naga::valid::Capabilities::FLOAT64;
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name} ({}): {}", R::WGSL, e.emit_to_string(&source)));
        assert!(
            !module.entry_points.is_empty()
                && module
                    .entry_points
                    .iter()
                    .all(|e| e.stage == naga::ShaderStage::Compute),
            "{name}: not a compute kernel"
        );
        names.insert(name);
    }
    names
}

#[test]
fn every_kernel_parses_and_validates_in_both_precisions() {
    let f32_names = validate::<f32>();
    let f64_names = validate::<f64>();
    assert_eq!(f32_names, f64_names);
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
    let files: BTreeSet<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .filter(|s| s != "math")
        .collect();
    let listed: BTreeSet<String> = f32_names.iter().map(|s| s.to_string()).collect();
    assert_eq!(files, listed, "shaders/ and kernels::kernel_sources differ");
    assert_eq!(files.len(), 6);
}

#[test]
fn a_broken_kernel_is_refused() {
    // The check itself can fail: a type error in an otherwise valid kernel.
    let (_, source) = kernel_sources::<f64>().remove(0);
    let broken = source.replacen(
        "let s: real = arc.step * real(k);",
        "let s: real = arc.step * k;",
        1,
    );
    assert_ne!(broken, source, "the line to break is in arc_check.wgsl");
    let parsed = naga::front::wgsl::parse_str(&broken);
    let refused = match parsed {
        Err(_) => true,
        Ok(m) => naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::FLOAT64,
        )
        .validate(&m)
        .is_err(),
    };
    assert!(refused);
}
