//! `inspect CONTAINER --preview OUT.svg --source INPUT`: the picture of a
//! compression (its drawing is tested in `metrics::preview`).

use std::process::Command;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strandfit"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn a_preview_of_the_fornix_draws_every_curve_in_three_views() {
    let dir = tempfile::tempdir().unwrap();
    let input = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/fibres/dipy_fornix_tracks300.tck"
    );
    let sfh = dir.path().join("f.sfh");
    let svg = dir.path().join("f.svg");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    assert!(
        run(&["compress", input, "--tolerance", "0.5", "-o", &s(&sfh)])
            .status
            .success()
    );
    let o = run(&[
        "inspect",
        &s(&sfh),
        "--preview",
        &s(&svg),
        "--source",
        input,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    assert_eq!(text.matches("class=\"input\"").count(), 3);
    assert!(text.contains("300 curves"));
    // Every decoded point within the tolerance: nothing past the top bin.
    let err = String::from_utf8_lossy(&o.stderr);
    let worst: f64 = err
        .split("input ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(worst <= 0.5, "{err}");
    // --preview needs --source, and a source that is not the input is named.
    assert!(!run(&["inspect", &s(&sfh), "--preview", &s(&svg)])
        .status
        .success());
    let other = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/fibres/dipy_EuDX_small_25.tck"
    );
    let o = run(&[
        "inspect",
        &s(&sfh),
        "--preview",
        &s(&dir.path().join("x.svg")),
        "--source",
        other,
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("dipy_EuDX_small_25.tck"));
    assert!(!dir.path().join("x.svg").exists());
}
