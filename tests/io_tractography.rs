//! `.tck` and `.trk` readers and writers against the bundled tractograms
//! (tests/data/fibres, written by dipy and nibabel), round trips, and
//! truncated, corrupted and hand-made hostile files.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::io::{self, Curve, Format, IoError, Metadata};
use strandfit::DVec3;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fibres")
        .join(name)
}

/// Every bundled `.tck` and `.trk`.
const BUNDLED: [&str; 16] = [
    "dipy_fornix_tracks300.trk",
    "dipy_fornix_tracks300.tck",
    "dipy_EuDX_small_25.trk",
    "dipy_EuDX_small_25.tck",
    "dipy_minimal_bundles/AF_L.trk",
    "dipy_minimal_bundles/AF_L.tck",
    "nibabel_fixtures/complex.trk",
    "nibabel_fixtures/complex_big_endian.trk",
    "nibabel_fixtures/empty.tck",
    "nibabel_fixtures/empty.trk",
    "nibabel_fixtures/simple.tck",
    "nibabel_fixtures/simple.trk",
    "nibabel_fixtures/simple_big_endian.tck",
    "nibabel_fixtures/standard.LPS.trk",
    "nibabel_fixtures/standard.tck",
    "nibabel_fixtures/standard.trk",
];

fn read(path: &Path) -> (Metadata, Vec<Curve>) {
    io::read_all(path, None).unwrap_or_else(|e| panic!("{e}"))
}

fn write(path: &Path, meta: &Metadata, curves: &[Curve]) {
    let mut w = io::create_writer(path, None, meta).unwrap_or_else(|e| panic!("{e}"));
    for c in curves {
        w.write_curve(c).unwrap_or_else(|e| panic!("{e}"));
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
}

/// Largest coordinate difference between two curve sets of the same shape.
fn max_diff(a: &[Curve], b: &[Curve]) -> f64 {
    assert_eq!(a.len(), b.len(), "curve counts differ");
    let mut d = 0.0f64;
    for (i, (ca, cb)) in a.iter().zip(b).enumerate() {
        assert_eq!(
            ca.points.len(),
            cb.points.len(),
            "curve {i}: point counts differ"
        );
        for (p, q) in ca.points.iter().zip(&cb.points) {
            d = d.max((*p - *q).abs().max_element());
        }
    }
    d
}

fn point_counts(curves: &[Curve]) -> (usize, usize, usize) {
    let mut n: Vec<usize> = curves.iter().map(|c| c.points.len()).collect();
    n.sort_unstable();
    (n[0], n[n.len() / 2], n[n.len() - 1])
}

#[test]
fn bundled_files_read_with_their_known_shapes() {
    for name in BUNDLED {
        let (meta, curves) = read(&data(name));
        let want = if name.ends_with("trk") {
            Format::Trk
        } else {
            Format::Tck
        };
        assert_eq!(meta.format, want, "{name}");
        assert_eq!(meta.units.as_deref(), Some("mm"), "{name}");
        if let Some(n) = meta.count {
            assert_eq!(n, curves.len() as u64, "{name}");
        }
        for c in &curves {
            assert!(c.points.iter().all(|p| p.is_finite()), "{name}");
        }
    }
    for ext in ["trk", "tck"] {
        let (_, fornix) = read(&data(&format!("dipy_fornix_tracks300.{ext}")));
        assert_eq!(fornix.len(), 300);
        assert_eq!(point_counts(&fornix), (30, 46, 91), "fornix .{ext}");
        let (_, eudx) = read(&data(&format!("dipy_EuDX_small_25.{ext}")));
        assert_eq!(eudx.len(), 60);
        assert_eq!(point_counts(&eudx), (2, 4, 8), "EuDX .{ext}");
        let (_, af) = read(&data(&format!("dipy_minimal_bundles/AF_L.{ext}")));
        assert_eq!(af.len(), 50);
        assert!(af.iter().all(|c| c.points.len() == 20));
    }
    // A point as nibabel gives it (RAS+ mm, half voxel applied).
    let (_, fornix) = read(&data("dipy_fornix_tracks300.trk"));
    let p = fornix[7].points[0];
    assert!(
        (p - DVec3::new(91.35964965820312, 113.82960510253906, 66.02192687988281))
            .abs()
            .max_element()
            < 1e-5
    );
}

#[test]
fn trk_metadata_comes_from_the_header() {
    let (m, _) = read(&data("dipy_fornix_tracks300.trk"));
    assert_eq!(m.count, Some(300));
    assert_eq!(m.dimensions, Some([50, 50, 50]));
    assert_eq!(m.voxel_size, Some([1.0; 3]));
    assert!(m.extra(io::TRK_HEADER_KEY).is_some_and(|h| h.len() == 2000));
    let (m, _) = read(&data("nibabel_fixtures/standard.trk"));
    assert_eq!(m.dimensions, Some([4, 5, 7]));
    assert_eq!(m.voxel_size, Some([1.0, 3.0, 2.0]));
    assert_eq!(m.vox_to_world.x_axis.x, 1.0);
    assert_eq!(m.vox_to_world.y_axis.y, 3.0);
    assert_eq!(m.vox_to_world.z_axis.z, 2.0);
    let (m, _) = read(&data("nibabel_fixtures/empty.trk"));
    assert_eq!(m.count, None, "n_count 0 means unknown");
}

/// The README's relation: each `.tck` is its `.trk` in RAS+ mm.
#[test]
fn each_tck_equals_its_trk() {
    let pairs = [
        ("dipy_fornix_tracks300.tck", "dipy_fornix_tracks300.trk"),
        ("dipy_EuDX_small_25.tck", "dipy_EuDX_small_25.trk"),
        (
            "dipy_minimal_bundles/AF_L.tck",
            "dipy_minimal_bundles/AF_L.trk",
        ),
        (
            "nibabel_fixtures/standard.tck",
            "nibabel_fixtures/standard.trk",
        ),
        (
            "nibabel_fixtures/standard.tck",
            "nibabel_fixtures/standard.LPS.trk",
        ),
        ("nibabel_fixtures/simple.tck", "nibabel_fixtures/simple.trk"),
        ("nibabel_fixtures/empty.tck", "nibabel_fixtures/empty.trk"),
    ];
    for (tck, trk) in pairs {
        let (_, a) = read(&data(tck));
        let (_, b) = read(&data(trk));
        let d = max_diff(&a, &b);
        eprintln!("{tck} vs {trk}: {} curves, max |Δ| = {d:.3e} mm", a.len());
        assert!(d <= 1e-4, "{tck} vs {trk}: {d}");
    }
    // The LPS file's voxel order flips x and y about the image centre: a
    // reader ignoring voxel_order is 3 mm off on this point.
    let (_, lps) = read(&data("nibabel_fixtures/standard.LPS.trk"));
    let want = [
        DVec3::new(-0.5, 4.5, -1.0),
        DVec3::new(0.0, 3.0, 0.0),
        DVec3::new(0.5, 1.5, 1.0),
    ];
    assert_eq!(lps[5].points, want);
}

#[test]
fn big_endian_files_equal_their_little_endian_twins() {
    let (_, le) = read(&data("nibabel_fixtures/simple.tck"));
    let (_, be) = read(&data("nibabel_fixtures/simple_big_endian.tck"));
    assert_eq!(le.len(), 3);
    assert_eq!(le, be);

    let (mle, le) = read(&data("nibabel_fixtures/complex.trk"));
    let (mbe, be) = read(&data("nibabel_fixtures/complex_big_endian.trk"));
    assert_eq!(le, be);
    assert_eq!(
        mle.point_data_names,
        ["colors[0]", "colors[1]", "colors[2]", "fa"]
    );
    assert_eq!(mbe.point_data_names, mle.point_data_names);
    assert_eq!(
        mle.curve_data_names,
        [
            "mean_colors[0]",
            "mean_colors[1]",
            "mean_colors[2]",
            "mean_curvature",
            "mean_torsion"
        ]
    );
    assert_eq!(mbe.curve_data_names, mle.curve_data_names);
    // Values as nibabel reads them.
    assert_eq!(
        le.iter().map(|c| c.points.len()).collect::<Vec<_>>(),
        [1, 2, 5]
    );
    assert_eq!(
        le[1].points,
        [DVec3::new(0.0, 1.0, 2.0), DVec3::new(3.0, 4.0, 5.0)]
    );
    assert_eq!(le[1].point_data, [0.0, 1.0, 0.0, 0.3, 0.0, 1.0, 0.0, 0.4]);
    assert_eq!(le[2].curve_data, [0.0, 0.0, 1.0, 3.11, 3.22]);
    assert_eq!(le[0].point_data, [1.0, 0.0, 0.0, 0.2]);
}

#[test]
fn empty_files_hold_no_curves() {
    for name in ["nibabel_fixtures/empty.tck", "nibabel_fixtures/empty.trk"] {
        assert!(read(&data(name)).1.is_empty(), "{name}");
    }
}

/// read → write (same format) → read: identical points, data and metadata;
/// `.trk` files come back byte for byte.
#[test]
fn same_format_round_trips_are_exact() {
    let dir = tempfile::tempdir().unwrap();
    for name in BUNDLED {
        let src = data(name);
        let (meta, curves) = read(&src);
        let out = dir.path().join(format!("out.{}", meta.format));
        write(&out, &meta, &curves);
        let (meta2, curves2) = read(&out);
        assert_eq!(
            curves2, curves,
            "{name}: curves differ after the round trip"
        );
        let mut want = meta.clone();
        if want.count.is_none() && !curves.is_empty() {
            want.count = Some(curves.len() as u64);
        }
        if meta.format == Format::Trk {
            // n_count is the one header field the writer may change.
            let (a, b) = (std::fs::read(&src).unwrap(), std::fs::read(&out).unwrap());
            assert_eq!(a.len(), b.len(), "{name}");
            assert_eq!(a[..988], b[..988], "{name}: header differs");
            assert_eq!(a[992..], b[992..], "{name}: header end or data differ");
            assert_eq!(meta2.extra, meta.extra, "{name}");
        } else {
            // The data bytes are the source's (Float32 written back exactly).
            let (a, b) = (std::fs::read(&src).unwrap(), std::fs::read(&out).unwrap());
            let data_of = |bytes: &[u8]| {
                let text = String::from_utf8_lossy(&bytes[..bytes.len().min(200)]).to_string();
                let at = text
                    .split("file: . ")
                    .nth(1)
                    .unwrap()
                    .split('\n')
                    .next()
                    .unwrap();
                bytes[at.trim().parse::<usize>().unwrap()..].to_vec()
            };
            assert_eq!(data_of(&a), data_of(&b), "{name}: data bytes differ");
        }
        assert_eq!(meta2, want, "{name}: metadata differ");
    }
}

/// `.tck` → `.trk` → `.tck` stays within float32 rounding, and the `.trk`
/// in the middle reads as the same RAS+ points.
#[test]
fn tck_to_trk_to_tck_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    for name in BUNDLED.iter().filter(|n| n.ends_with(".tck")) {
        let (meta, curves) = read(&data(name));
        let trk = dir.path().join("mid.trk");
        write(&trk, &meta, &curves);
        let (tmeta, tcurves) = read(&trk);
        assert_eq!(tmeta.voxel_size, Some([1.0; 3]));
        assert_eq!(tmeta.dimensions, Some([1; 3]));
        assert_eq!(tmeta.vox_to_world, glam::DMat4::IDENTITY);
        let tck = dir.path().join("back.tck");
        write(&tck, &tmeta, &tcurves);
        let (_, back) = read(&tck);
        let scale = curves
            .iter()
            .flat_map(|c| c.points.iter())
            .fold(1.0f64, |m, p| m.max(p.abs().max_element()));
        let (d1, d2) = (max_diff(&curves, &tcurves), max_diff(&curves, &back));
        eprintln!("{name}: tck→trk max |Δ| = {d1:.3e}, tck→trk→tck {d2:.3e} (|x| ≤ {scale:.1})");
        // One float32 rounding of voxmm = x + 0.5, relative to the largest |x|.
        let tol = 2.0 * f64::from(f32::EPSILON) * (scale + 1.0);
        assert!(d1 <= tol && d2 <= tol, "{name}: {d1} {d2} > {tol}");
    }
}

#[test]
fn trk_carries_per_point_and_per_curve_values_from_other_sources() {
    let dir = tempfile::tempdir().unwrap();
    let mut meta = Metadata::new(Format::Vtk);
    meta.point_data_names = vec![
        "fa".into(),
        "rgb[0]".into(),
        "rgb[1]".into(),
        "rgb[2]".into(),
    ];
    meta.curve_data_names = vec!["length".into()];
    meta.voxel_size = Some([2.0, 2.0, 2.5]);
    meta.dimensions = Some([40, 50, 60]);
    meta.vox_to_world = glam::DMat4::from_cols_array_2d(&[
        [-2.0, 0.0, 0.0, 0.0],
        [0.0, 2.0, 0.0, 0.0],
        [0.0, 0.0, 2.5, 0.0],
        [80.0, -100.0, -70.0, 1.0],
    ]);
    let curves = vec![
        Curve {
            id: None,
            points: vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-10.25, 7.5, 0.125)],
            point_data: vec![0.5, 1.0, 0.0, 0.0, 0.25, 0.0, 1.0, 0.0],
            curve_data: vec![11.0],
        },
        Curve {
            id: None,
            points: vec![DVec3::new(3.0, -2.0, 1.0)],
            point_data: vec![0.75, 0.0, 0.0, 1.0],
            curve_data: vec![0.0],
        },
    ];
    let p = dir.path().join("values.trk");
    write(&p, &meta, &curves);
    let (m, back) = read(&p);
    assert_eq!(m.point_data_names, meta.point_data_names);
    assert_eq!(m.curve_data_names, meta.curve_data_names);
    assert_eq!(m.voxel_size, meta.voxel_size);
    assert_eq!(m.dimensions, meta.dimensions);
    assert_eq!(m.vox_to_world, meta.vox_to_world);
    let raw = std::fs::read(&p).unwrap();
    assert_eq!(&raw[948..951], b"LAS", "voxel_order follows the affine");
    assert!(max_diff(&back, &curves) < 1e-4);
    for (a, b) in back.iter().zip(&curves) {
        assert_eq!(a.point_data, b.point_data);
        assert_eq!(a.curve_data, b.curve_data);
    }
}

#[test]
fn writers_refuse_what_the_format_cannot_hold_and_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.trk");
    std::fs::write(&p, b"keep me").unwrap();

    let mut meta = Metadata::new(Format::Tck);
    meta.point_data_names = (0..11).map(|i| format!("s{i}")).collect();
    let e = io::create_writer(&p, None, &meta).err().unwrap();
    assert!(e.reason.contains("at most 10"), "{e}");
    meta.point_data_names = vec!["a name longer than twenty bytes".into()];
    let e = io::create_writer(&p, None, &meta).err().unwrap();
    assert!(e.reason.contains("20 bytes"), "{e}");

    meta.point_data_names = vec!["fa".into()];
    let mut w = io::create_writer(&p, None, &meta).unwrap();
    w.write_curve(&Curve {
        id: None,
        points: vec![DVec3::ZERO],
        point_data: vec![1.0],
        curve_data: vec![],
    })
    .unwrap();
    let e = w
        .write_curve(&Curve::from_points(vec![DVec3::ZERO]))
        .unwrap_err();
    assert_eq!(e.curve, Some(1));
    assert!(e.reason.contains("per-point values"), "{e}");
    let e = w
        .write_curve(&Curve {
            id: None,
            points: vec![DVec3::new(0.0, f64::INFINITY, 0.0)],
            point_data: vec![1.0],
            curve_data: vec![],
        })
        .unwrap_err();
    assert!(e.reason.contains("not finite"), "{e}");
    drop(w);
    assert_eq!(
        std::fs::read(&p).unwrap(),
        b"keep me",
        "a failed write clobbered the target"
    );
    let leftovers = std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(leftovers, 1, "temporary files left behind");
}

// ---- hostile input -------------------------------------------------------

/// Read `bytes` as `name`'s format from a file in `dir`: must not panic.
fn read_bytes(dir: &Path, name: &str, bytes: &[u8]) -> Result<Vec<Curve>, IoError> {
    let ext = Path::new(name).extension().unwrap().to_str().unwrap();
    let p = dir.join(format!("fuzz.{ext}"));
    std::fs::write(&p, bytes).unwrap();
    let r = io::read_all(&p, None).map(|(_, c)| c);
    if let Err(e) = &r {
        assert_eq!(e.path, p, "the error names the file");
        assert!(e.to_string().contains(&p.display().to_string()));
    }
    r
}

/// The data offset of a `.tck` file's bytes.
fn tck_data_offset(bytes: &[u8]) -> usize {
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]).to_string();
    text.split("file: . ")
        .nth(1)
        .unwrap()
        .split('\n')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn every_truncation_is_an_error_or_a_documented_acceptance() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for name in BUNDLED {
        let bytes = std::fs::read(data(name)).unwrap();
        let header = if name.ends_with(".trk") {
            1000
        } else {
            tck_data_offset(&bytes)
        };
        let cuts: Vec<usize> = if bytes.len() <= 6_000 {
            (0..bytes.len()).collect()
        } else {
            let mut c: Vec<usize> = (0..=header + 64).collect();
            c.extend((0..400).map(|k| header + k * (bytes.len() - header) / 400));
            c.extend((0..100).map(|_| rng.gen_range(header..bytes.len())));
            c.extend(bytes.len() - 30..bytes.len());
            c
        };
        for cut in cuts {
            let r = read_bytes(dir.path(), name, &bytes[..cut]);
            // Only a .tck missing nothing but its Inf terminator reads.
            let tb = 12;
            let ok_expected = name.ends_with(".tck") && cut == bytes.len() - tb;
            match r {
                Ok(c) => assert!(
                    ok_expected,
                    "{name} cut at {cut} of {} read as {} curves",
                    bytes.len(),
                    c.len()
                ),
                Err(e) => assert!(!ok_expected, "{name} cut at {cut}: {e}"),
            }
        }
    }
}

#[test]
fn random_corruptions_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let (mut ok, mut err) = (0, 0);
    for name in BUNDLED {
        let bytes = std::fs::read(data(name)).unwrap();
        let header = if name.ends_with(".trk") {
            1000
        } else {
            tck_data_offset(&bytes)
        };
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..rng.gen_range(1..=4) {
                // Half the hits in the header, where the counts live.
                let at = if rng.gen_bool(0.5) {
                    rng.gen_range(0..header.min(b.len()))
                } else {
                    rng.gen_range(0..b.len())
                };
                b[at] = match rng.gen_range(0..4) {
                    0 => rng.gen(),
                    1 => b[at] ^ (1 << rng.gen_range(0..8)),
                    2 => 0xff,
                    _ => 0x7f,
                };
            }
            match read_bytes(dir.path(), name, &b) {
                Ok(_) => ok += 1,
                Err(_) => err += 1,
            }
        }
    }
    eprintln!("corruptions: {ok} read, {err} rejected");
    assert!(err > 0 && ok > 0);
}

fn trk_header_for_test() -> Vec<u8> {
    std::fs::read(data("nibabel_fixtures/simple.trk")).unwrap()
}

fn expect_err(dir: &Path, name: &str, bytes: &[u8], words: &[&str]) -> IoError {
    let e = read_bytes(dir, name, bytes).expect_err(name);
    let msg = e.to_string();
    for w in words {
        assert!(msg.contains(w), "{name}: {msg:?} lacks {w:?}");
    }
    e
}

#[test]
fn hand_made_bad_trk_files_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = trk_header_for_test();
    let set = |at: usize, v: &[u8]| {
        let mut b = good.clone();
        b[at..at + v.len()].copy_from_slice(v);
        b
    };
    expect_err(
        d,
        "a.trk",
        &set(0, b"TRICK"),
        &["not a TrackVis .trk file", "TRACK"],
    );
    expect_err(d, "a.trk", b"hello", &["not a TrackVis .trk file"]);
    expect_err(d, "a.trk", &good[..500], &["truncated"]);
    expect_err(
        d,
        "a.trk",
        &set(996, &999i32.to_le_bytes()),
        &["hdr_size", "999"],
    );
    expect_err(d, "a.trk", &set(992, &7i32.to_le_bytes()), &["version 7"]);
    expect_err(
        d,
        "a.trk",
        &set(988, &i32::MAX.to_le_bytes()),
        &["absurd n_count 2147483647", "n_count"],
    );
    expect_err(
        d,
        "a.trk",
        &set(988, &(1u32 << 31).to_le_bytes()),
        &["absurd n_count -2147483648", "negative"],
    );
    expect_err(
        d,
        "a.trk",
        &set(12, &0f32.to_le_bytes()),
        &["voxel_size", "non-zero"],
    );
    expect_err(d, "a.trk", &set(948, b"RRS\0"), &["voxel_order", "RRS"]);
    expect_err(
        d,
        "a.trk",
        &set(36, &(-1i16).to_le_bytes()),
        &["n_scalars is negative"],
    );
    let e = expect_err(
        d,
        "a.trk",
        &set(1000, &i32::MAX.to_le_bytes()),
        &["absurd point count 2147483647", "curve 0", "byte 1000"],
    );
    assert_eq!(e.curve, Some(0));
    let e = expect_err(
        d,
        "a.trk",
        &set(1016, &(-3i32).to_le_bytes()),
        &["negative point count -3", "curve 1"],
    );
    assert_eq!(e.curve, Some(1));
    // simple.trk: curve 1 starts at 1016 with 2 points; its second x at 1032.
    // Every reader's points go through one check (io::point_problem) that
    // names the file, the curve and the point.
    let e = expect_err(
        d,
        "a.trk",
        &set(1032, &f32::NAN.to_le_bytes()),
        &["coordinate x is NaN", "curve 1", "point 1"],
    );
    assert_eq!(e.curve, Some(1));
    // n_count says 3: a fourth streamline is an error, and so is a missing third.
    let mut extra = good.clone();
    extra.extend_from_slice(&0i32.to_le_bytes());
    expect_err(
        d,
        "a.trk",
        &extra,
        &["n_count says 3 streamlines", "4 more bytes"],
    );
    expect_err(d, "a.trk", &good[..1060], &["curve 2", "truncated"]);
    // With n_count 0 (unknown) the same trailing streamline reads.
    let mut open_ended = extra.clone();
    open_ended[988..992].copy_from_slice(&0i32.to_le_bytes());
    assert_eq!(read_bytes(d, "a.trk", &open_ended).unwrap().len(), 4);
    // A big-endian hdr_size marks a big-endian file: the rest must follow.
    let mut be = good.clone();
    be[996..1000].copy_from_slice(&1000i32.to_be_bytes());
    expect_err(d, "a.trk", &be, &["version"]);
}

#[test]
fn hand_made_bad_tck_files_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = std::fs::read(data("nibabel_fixtures/simple.tck")).unwrap();
    let text = |h: &str| {
        let mut b = h.as_bytes().to_vec();
        b.extend_from_slice(&good[67..]);
        b
    };
    expect_err(
        d,
        "a.tck",
        &text("mrtrix trucks\ncount: 3\ndatatype: Float32LE\nfile: . 67\nEND\n"),
        &["not an MRtrix .tck file"],
    );
    expect_err(d, "a.tck", &[0xff; 100], &["not an MRtrix .tck file"]);
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 0000000003\ndatatype: Int16LE\nfile: . 67\nEND\n"),
        &["unknown datatype \"Int16LE\"", "datatype"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 0000000003\ndatatype: Float32LE\nfile: . 999999\nEND\n"),
        &["999999", "beyond the end", "file"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 0000000003\ndatatype: Float32LE\nfile: . 12\nEND\n"),
        &["inside the header"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 0000000003\ndatatype: Float32LE\nfile: other.dat 67\nEND\n"),
        &["separate file"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 2147483648\ndatatype: Float32LE\nfile: . 67\nEND\n"),
        &["absurd count 2147483648", "count"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: three\ndatatype: Float32LE\nfile: . 67\nEND\n"),
        &["not a whole number"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\ncount: 0000000003\nfile: . 67\nEND\n"),
        &["no `datatype`"],
    );
    expect_err(
        d,
        "a.tck",
        b"mrtrix tracks\ncount: 3\ndatatype: Float32LE\n",
        &["without an `END`"],
    );
    expect_err(
        d,
        "a.tck",
        &text("mrtrix tracks\nno colon here\ndatatype: Float32LE\nfile: . 67\nEND\n"),
        &["not `key: value`"],
    );
    // A triplet cut in the middle names the curve and the byte.
    let e = expect_err(
        d,
        "a.tck",
        &good[..67 + 12 + 12 + 12 + 6],
        &["truncated", "curve 1", "byte 103"],
    );
    assert_eq!(e.curve, Some(1));
    // A NaN mixed with numbers is neither separator nor point.
    let mut mixed = good.clone();
    mixed[67..71].copy_from_slice(&f32::NAN.to_le_bytes());
    expect_err(d, "a.tck", &mixed, &["curve 0", "mixes NaN"]);
}

/// A large file streams: a million short streamlines, written and read one
/// at a time, never all in memory.
#[test]
fn a_million_streamlines_stream_through() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["tck", "trk"] {
        let p = dir.path().join(format!("big.{ext}"));
        let n = 1_000_000u64;
        let meta = Metadata::new(Format::Tck);
        let mut w = io::create_writer(&p, None, &meta).unwrap();
        for i in 0..n {
            let x = i as f64;
            w.write_curve(&Curve::from_points(vec![
                DVec3::new(x, 1.0, 2.0),
                DVec3::new(x, 2.0, 3.0),
            ]))
            .unwrap();
        }
        w.finish().unwrap();
        let r = io::open_reader(&p, None).unwrap();
        assert_eq!(r.metadata().count, Some(n));
        let mut k = 0u64;
        for c in r {
            let c = c.unwrap();
            assert_eq!(c.points[0].x, k as f64);
            k += 1;
        }
        assert_eq!(k, n, ".{ext}");
    }
}

/// With `STRANDFIT_TRACT_OUT=DIR`, write every bundled file converted to
/// both formats into DIR, with `manifest.txt` pairing each output with its
/// source, for `tests/scripts/nibabel_roundtrip.py --manifest DIR/manifest.txt`
/// to check in nibabel. Without it, nothing to do.
#[test]
fn conversions_for_an_external_check() {
    let Some(out) = std::env::var_os("STRANDFIT_TRACT_OUT") else {
        eprintln!("STRANDFIT_TRACT_OUT not set: no files written for the nibabel check");
        return;
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out).unwrap();
    let mut manifest = String::new();
    for name in BUNDLED {
        let (meta, curves) = read(&data(name));
        for ext in ["tck", "trk"] {
            let target = out.join(format!("{}.{ext}", name.replace('/', "__")));
            write(&target, &meta, &curves);
            manifest.push_str(&format!("{}\t{}\n", target.display(), data(name).display()));
        }
    }
    // The fornix under non-trivial reference images: voxmm must map back to
    // the same RAS+ points in nibabel too.
    let src = data("dipy_fornix_tracks300.tck");
    let (meta, curves) = read(&src);
    let affines = [
        (
            "las_2mm",
            glam::DMat4::from_cols_array_2d(&[
                [-2.0, 0.0, 0.0, 0.0],
                [0.0, 2.0, 0.0, 0.0],
                [0.0, 0.0, 2.5, 0.0],
                [180.0, -20.0, -30.0, 1.0],
            ]),
            [2.0, 2.0, 2.5],
        ),
        (
            "oblique",
            glam::DMat4::from_translation(DVec3::new(-90.0, -120.0, -60.0))
                * glam::DMat4::from_rotation_z(0.35)
                * glam::DMat4::from_rotation_x(-0.2)
                * glam::DMat4::from_scale(DVec3::new(1.25, 1.25, 1.5)),
            [1.25, 1.25, 1.5],
        ),
    ];
    for (tag, affine, vs) in affines {
        let mut m = meta.clone();
        m.vox_to_world = affine;
        m.voxel_size = Some(vs);
        m.dimensions = Some([96, 114, 96]);
        let target = out.join(format!("fornix_{tag}.trk"));
        write(&target, &m, &curves);
        let (_, back) = read(&target);
        assert!(max_diff(&back, &curves) < 1e-4, "{tag}");
        manifest.push_str(&format!("{}\t{}\n", target.display(), src.display()));
    }
    std::fs::write(out.join("manifest.txt"), manifest).unwrap();
}
