//! TRX reader and writer against fixtures written by trx-python
//! (tests/data/trx, made by tests/scripts/make_trx_fixtures.py from the
//! bundled .tck/.trk), round trips, and truncated, corrupted and hand-made
//! hostile archives.

use std::io::Write;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::io::{self, create_trx, open_trx, Curve, Format, IoError, Metadata};
use strandfit::DVec3;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn read_trx(path: &Path) -> Result<(Metadata, Vec<Curve>), IoError> {
    let r = open_trx(path)?;
    let meta = r.metadata().clone();
    Ok((meta, r.collect::<Result<Vec<_>, _>>()?))
}

fn read(path: &Path) -> (Metadata, Vec<Curve>) {
    read_trx(path).unwrap_or_else(|e| panic!("{e}"))
}

fn write(path: &Path, format: Format, meta: &Metadata, curves: &[Curve]) {
    let mut w = io::create_writer(path, Some(format), meta).unwrap_or_else(|e| panic!("{e}"));
    for c in curves {
        w.write_curve(c).unwrap_or_else(|e| panic!("{e}"));
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
}

const FORNIX: [(&str, f64); 3] = [
    // (fixture, relative rounding of its positions dtype)
    ("trx/fornix_f32_deflated.trx", f32::EPSILON as f64 / 2.0),
    ("trx/fornix_f16_stored.trx", 1.0 / 2048.0),
    ("trx/fornix_f16_dir", 1.0 / 2048.0),
];

/// Largest |a - b| / |b| over all coordinates (|b| ≥ 1e-3; absolute below).
fn max_rel_diff(a: &[Curve], b: &[Curve]) -> f64 {
    assert_eq!(a.len(), b.len(), "curve counts differ");
    let mut d = 0.0f64;
    for (i, (ca, cb)) in a.iter().zip(b).enumerate() {
        assert_eq!(ca.points.len(), cb.points.len(), "curve {i}: point counts");
        for (p, q) in ca.points.iter().zip(&cb.points) {
            for k in 0..3 {
                d = d.max((p[k] - q[k]).abs() / q[k].abs().max(1e-3));
            }
        }
    }
    d
}

#[test]
fn fornix_fixtures_equal_the_tck_within_their_dtype_rounding() {
    let (_, tck) = io::read_all(&data("fibres/dipy_fornix_tracks300.tck"), None).unwrap();
    for (name, rel) in FORNIX {
        let (meta, curves) = read(&data(name));
        assert_eq!(curves.len(), 300, "{name}");
        assert_eq!(meta.count, Some(300));
        assert_eq!(meta.format, Format::Trx);
        assert_eq!(meta.units.as_deref(), Some("mm"));
        assert_eq!(meta.dimensions, Some([50, 50, 50]), "{name}");
        assert_eq!(meta.vox_to_world, glam::DMat4::IDENTITY);
        let lens: Vec<usize> = curves.iter().map(|c| c.points.len()).collect();
        let (lo, hi) = (lens.iter().min().unwrap(), lens.iter().max().unwrap());
        let mean = lens.iter().sum::<usize>() as f64 / 300.0;
        assert_eq!((*lo, mean.round() as usize, *hi), (30, 49, 91), "{name}");
        let d = max_rel_diff(&curves, &tck);
        println!("{name}: max relative deviation from the .tck {d:.3e} (bound {rel:.3e})");
        assert!(d <= rel, "{name}: {d} > {rel}");
        if rel > 1e-6 {
            // float16 really is coarser: the bound is not vacuous.
            assert!(d > rel / 8.0, "{name}: {d} suspiciously small for float16");
            assert_eq!(meta.extra("trx.positions_dtype"), Some("float16"));
        } else {
            assert_eq!(d, 0.0, "{name}: float32 holds the .tck's float32 exactly");
            assert_eq!(meta.extra("trx.positions_dtype"), Some("float32"));
        }
    }
    let (m, _) = read(&data("trx/fornix_f16_dir"));
    assert_eq!(m.extra("trx.offsets_dtype"), Some("uint64"));
    let (m, _) = read(&data("trx/fornix_f16_stored.trx"));
    assert_eq!(m.extra("trx.offsets_dtype"), Some("uint32"));
}

#[test]
fn complex_fixture_carries_per_vertex_and_per_streamline_data() {
    let (_, trk) = io::read_all(&data("fibres/nibabel_fixtures/complex.trk"), None).unwrap();
    for name in ["trx/complex.trx", "trx/complex_dir"] {
        let (meta, curves) = read(&data(name));
        assert_eq!(
            curves.iter().map(|c| c.points.len()).collect::<Vec<_>>(),
            [1, 2, 5]
        );
        assert_eq!(max_rel_diff(&curves, &trk), 0.0);
        // dpv in name order: colors (3 × uint8), fa (float16).
        assert_eq!(
            meta.point_data_names,
            ["colors_0", "colors_1", "colors_2", "fa"]
        );
        assert_eq!(
            meta.curve_data_names,
            [
                "mean_colors_0",
                "mean_colors_1",
                "mean_colors_2",
                "mean_curvature",
                "mean_torsion",
                "group:odd"
            ]
        );
        // The group `odd` (streamlines 0 and 2, as trx-python wrote it) as
        // a membership column; its data per group carried verbatim.
        let odd: Vec<f32> = curves.iter().map(|c| c.curve_data[5]).collect();
        assert_eq!(odd, [1.0, 0.0, 1.0]);
        assert!(meta.extra("trx.entry.dpg/odd/weight.float32").is_some());
        assert_eq!(meta.extra("trx.dropped"), None);
        assert_eq!(meta.extra("trx.dpv.colors"), Some("3.uint8"));
        assert_eq!(meta.extra("trx.dpv.fa"), Some("float16"));
        assert_eq!(meta.extra("trx.dps.mean_curvature"), Some("float64"));
        // The .trk's values: colors [1,0,0 | 0,1,0 0,1,0 | 0,0,1 ×5], fa 0.2…0.8.
        let tc = &curves;
        let fa: Vec<f32> = tc
            .iter()
            .flat_map(|c| c.point_data.chunks(4).map(|r| r[3]).collect::<Vec<_>>())
            .collect();
        let want = [0.2f32, 0.3, 0.4, 0.5, 0.6, 0.6, 0.7, 0.8];
        for (a, b) in fa.iter().zip(want) {
            assert!((a - b).abs() <= b / 2048.0, "fa {a} vs {b} (float16)");
        }
        assert_eq!(&tc[0].point_data[..3], &[1.0, 0.0, 0.0]);
        assert_eq!(&tc[1].point_data[4..7], &[0.0, 1.0, 0.0]);
        assert_eq!(&tc[2].point_data[16..19], &[0.0, 0.0, 1.0]);
        // Per streamline, compared with the .trk's properties by name.
        let (tmeta, tcurves) =
            io::read_all(&data("fibres/nibabel_fixtures/complex.trk"), None).unwrap();
        // The .trk reader names components `x[0]`, TRX (like VTK) `x_0`.
        for (j, n) in meta.curve_data_names.iter().enumerate() {
            if n.starts_with("group:") {
                continue; // no .trk counterpart
            }
            let k = tmeta
                .curve_data_names
                .iter()
                .position(|m| m.replace('[', "_").replace(']', "") == *n)
                .unwrap_or_else(|| panic!("{n} not in {:?}", tmeta.curve_data_names));
            for (c, t) in curves.iter().zip(&tcurves) {
                assert_eq!(c.curve_data[j], t.curve_data[k], "{n}");
            }
        }
    }
}

#[test]
fn trx_round_trips_are_bitwise_and_keep_dtypes() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "trx/fornix_f32_deflated.trx",
        "trx/fornix_f16_stored.trx",
        "trx/fornix_f16_dir",
        "trx/complex.trx",
    ] {
        let (meta, curves) = read(&data(name));
        let out = dir.path().join("rt.trx");
        write(&out, Format::Trx, &meta, &curves);
        let (m2, c2) = read(&out);
        assert_eq!(c2, curves, "{name}: curves differ after a round trip");
        assert_eq!(m2.point_data_names, meta.point_data_names);
        assert_eq!(m2.curve_data_names, meta.curve_data_names);
        assert_eq!(m2.vox_to_world, meta.vox_to_world);
        assert_eq!(m2.dimensions, meta.dimensions);
        for key in [
            "trx.positions_dtype",
            "trx.offsets_dtype",
            "trx.dpv.colors",
            "trx.dpv.fa",
            "trx.dps.mean_colors",
            "trx.dps.mean_curvature",
        ] {
            assert_eq!(m2.extra(key), meta.extra(key), "{name}: {key}");
        }
        // Bitwise: the positions bytes equal the source's (stored entries).
        if name.ends_with(".trx") && !name.contains("deflated") {
            let a = std::fs::read(data(name)).unwrap();
            let b = std::fs::read(&out).unwrap();
            let pos = |z: &[u8]| -> Vec<u8> {
                let mut ar = zip::ZipArchive::new(std::io::Cursor::new(z.to_vec())).unwrap();
                let n = ar
                    .file_names()
                    .find(|n| n.starts_with("positions"))
                    .unwrap()
                    .to_string();
                let mut v = Vec::new();
                std::io::Read::read_to_end(&mut ar.by_name(&n).unwrap(), &mut v).unwrap();
                v
            };
            assert!(pos(&a) == pos(&b), "{name}: positions bytes differ");
        }
    }
}

#[test]
fn tck_to_trx_to_tck_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let (tmeta, tck) = io::read_all(&data("fibres/dipy_fornix_tracks300.tck"), None).unwrap();
    let t = dir.path().join("f.trx");
    write(&t, Format::Trx, &tmeta, &tck);
    let (m, c) = read(&t);
    assert_eq!(m.extra("trx.positions_dtype"), Some("float32"));
    assert_eq!(m.extra("trx.offsets_dtype"), Some("uint32"));
    assert_eq!(c, tck, "float32 .tck → float32 TRX is exact");
    let back = dir.path().join("f.tck");
    write(&back, Format::Tck, &m, &c);
    let (_, c2) = io::read_all(&back, None).unwrap();
    assert_eq!(c2, tck);
    // The same, with .trk per-point and per-curve values and its affine.
    let (kmeta, trk) = io::read_all(&data("fibres/nibabel_fixtures/complex.trk"), None).unwrap();
    write(&t, Format::Trx, &kmeta, &trk);
    let (m, c) = read(&t);
    assert_eq!(c, trk);
    // The .trk's `colors[0..3]` components become one `colors.3.float32`.
    let renamed = |v: &[String]| -> Vec<String> {
        v.iter()
            .map(|n| n.replace('[', "_").replace(']', ""))
            .collect()
    };
    assert_eq!(m.point_data_names, renamed(&kmeta.point_data_names));
    assert_eq!(m.curve_data_names, renamed(&kmeta.curve_data_names));
    assert_eq!(m.extra("trx.dpv.colors"), Some("3.float32"));
    assert_eq!(m.vox_to_world, kmeta.vox_to_world);
    assert_eq!(m.dimensions, kmeta.dimensions);
}

#[test]
fn empty_and_odd_curves_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("e.trx");
    let mut meta = Metadata::new(Format::Json);
    write(&p, Format::Trx, &meta, &[]);
    let (m, c) = read(&p);
    assert!(c.is_empty());
    assert_eq!(m.count, Some(0));
    // Zero-point curves between others; f64 positions when asked.
    meta.format = Format::Trx;
    meta.extra
        .push(("trx.positions_dtype".into(), "float64".into()));
    meta.point_data_names = vec!["w".into()];
    meta.curve_data_names = vec!["id".into()];
    let curves = vec![
        Curve {
            points: vec![DVec3::new(0.1, 0.2, 0.3), DVec3::new(1e10, -2.5, 3.0)],
            point_data: vec![1.5, -2.0],
            curve_data: vec![7.0],
            ..Default::default()
        },
        Curve {
            curve_data: vec![8.0],
            ..Default::default()
        },
        Curve {
            points: vec![DVec3::new(std::f64::consts::PI, 0.0, -0.0)],
            point_data: vec![3.25],
            curve_data: vec![9.0],
            ..Default::default()
        },
    ];
    write(&p, Format::Trx, &meta, &curves);
    let (m, c) = read(&p);
    assert_eq!(c, curves, "float64 is exact, empty curves survive");
    assert_eq!(m.extra("trx.positions_dtype"), Some("float64"));
}

#[test]
fn writer_refuses_what_its_dtypes_cannot_hold_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.trx");
    let mut meta = Metadata::new(Format::Trx);
    meta.extra
        .push(("trx.positions_dtype".into(), "float16".into()));
    meta.point_data_names = vec!["c".into()];
    meta.extra.push(("trx.dpv.c".into(), "uint8".into()));
    let mut w = create_trx(&p, &meta).unwrap();
    let ok = Curve {
        points: vec![DVec3::ONE],
        point_data: vec![3.0],
        ..Default::default()
    };
    w.write_curve(&ok).unwrap();
    let e = w
        .write_curve(&Curve {
            points: vec![DVec3::new(1e6, 0.0, 0.0)],
            point_data: vec![3.0],
            ..Default::default()
        })
        .unwrap_err();
    assert_eq!(e.curve, Some(1));
    assert!(e.reason.contains("float16"), "{e}");
    let e = w
        .write_curve(&Curve {
            points: vec![DVec3::ONE],
            point_data: vec![300.0],
            ..Default::default()
        })
        .unwrap_err();
    assert!(e.reason.contains("dpv/c.uint8"), "{e}");
    let e = w
        .write_curve(&Curve::from_points(vec![DVec3::new(f64::NAN, 0.0, 0.0)]))
        .unwrap_err();
    assert!(e.reason.contains("per-point values"), "{e}");
    drop(w);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

// ------------------------------------------------------------ hostile input

fn files_of(path: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    if path.is_dir() {
        let mut stack = vec![(path.to_path_buf(), String::new())];
        while let Some((d, pre)) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let e = e.unwrap();
                let n = format!("{pre}{}", e.file_name().to_string_lossy());
                if e.path().is_dir() {
                    stack.push((e.path(), format!("{n}/")));
                } else {
                    out.push((n, std::fs::read(e.path()).unwrap()));
                }
            }
        }
    } else {
        let mut ar = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
        for i in 0..ar.len() {
            let mut f = ar.by_index(i).unwrap();
            let mut v = Vec::new();
            std::io::Read::read_to_end(&mut f, &mut v).unwrap();
            out.push((f.name().to_string(), v));
        }
    }
    out.sort();
    out
}

/// Write `entries` as a zip (`deflate`d or stored) or, with `zip: false`, a
/// folder; return its path.
fn make(
    dir: &Path,
    name: &str,
    entries: &[(String, Vec<u8>)],
    zipped: bool,
    deflate: bool,
) -> PathBuf {
    let p = dir.join(name);
    if p.is_dir() {
        std::fs::remove_dir_all(&p).unwrap();
    } else if p.exists() {
        std::fs::remove_file(&p).unwrap();
    }
    if zipped {
        let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
        let o = zip::write::SimpleFileOptions::default().compression_method(if deflate {
            zip::CompressionMethod::Deflated
        } else {
            zip::CompressionMethod::Stored
        });
        for (n, b) in entries {
            z.start_file(n.as_str(), o).unwrap();
            z.write_all(b).unwrap();
        }
        z.finish().unwrap();
    } else {
        for (n, b) in entries {
            let f = p.join(n);
            std::fs::create_dir_all(f.parent().unwrap()).unwrap();
            std::fs::write(f, b).unwrap();
        }
    }
    p
}

fn with(
    entries: &[(String, Vec<u8>)],
    name: &str,
    bytes: Option<Vec<u8>>,
) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = entries.iter().filter(|(n, _)| n != name).cloned().collect();
    if let Some(b) = bytes {
        v.push((name.to_string(), b));
    }
    v
}

fn header(nv: u64, ns: u64) -> Vec<u8> {
    format!(
        r#"{{"DIMENSIONS":[1,1,1],"VOXEL_TO_RASMM":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"NB_VERTICES":{nv},"NB_STREAMLINES":{ns}}}"#
    )
    .into_bytes()
}

fn u32s(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn hand_made_bad_archives_say_why() {
    let dir = tempfile::tempdir().unwrap();
    // A good one: 2 streamlines of 2 and 3 points.
    let pos: Vec<u8> = (0..15).flat_map(|i| (i as f32).to_le_bytes()).collect();
    let good = vec![
        ("header.json".to_string(), header(5, 2)),
        ("positions.3.float32".to_string(), pos.clone()),
        ("offsets.uint32".to_string(), u32s(&[0, 2, 5])),
        ("dpv/w.float32".to_string(), vec![0u8; 20]),
    ];
    // (what, entries, words the error must contain, the curve it names)
    type Case<'a> = (&'a str, Vec<(String, Vec<u8>)>, &'a [&'a str], Option<u64>);
    let cases: Vec<Case> = vec![
        (
            "missing header",
            with(&good, "header.json", None),
            &["no `header.json`"],
            None,
        ),
        (
            "NB_VERTICES vs positions",
            with(&good, "header.json", Some(header(6, 2))),
            &["positions.3.float32", "holds 60 bytes", "6 vertices"],
            None,
        ),
        (
            "offsets decrease",
            with(&good, "offsets.uint32", Some(u32s(&[0, 3, 2]))),
            &["offsets decrease", "2 after 3"],
            Some(1),
        ),
        (
            "offsets past the end",
            with(&good, "offsets.uint32", Some(u32s(&[0, 7, 5]))),
            &["offset 7 lies past the end of the 5 vertices"],
            Some(0),
        ),
        (
            "bad sentinel",
            with(&good, "offsets.uint32", Some(u32s(&[0, 2, 4]))),
            &["sentinel", "not NB_VERTICES = 5"],
            Some(1),
        ),
        (
            "first offset",
            with(&good, "offsets.uint32", Some(u32s(&[1, 2, 5]))),
            &["first offset is 1"],
            Some(0),
        ),
        (
            "absurd NB_STREAMLINES",
            with(&good, "header.json", Some(header(5, 1 << 40))),
            &["offsets.uint32", "1099511627776 streamlines"],
            None,
        ),
        (
            "absurd NB_VERTICES",
            with(&good, "header.json", Some(header(u64::MAX / 2, 2))),
            &["positions.3.float32", "more than 2^64"],
            None,
        ),
        (
            "unknown dtype",
            with(&good, "dpv/w.float32", None)
                .into_iter()
                .chain([("dpv/w.complex64".to_string(), vec![0u8; 40])])
                .collect(),
            &["unknown dtype `complex64`", "dpv/w.complex64"],
            None,
        ),
        (
            "dpv size",
            with(&good, "dpv/w.float32", Some(vec![0u8; 16])),
            &["dpv/w.float32", "holds 16 bytes"],
            None,
        ),
        (
            "positions not 3",
            with(&good, "positions.3.float32", None)
                .into_iter()
                .chain([("positions.2.float32".to_string(), pos[..40].to_vec())])
                .collect(),
            &["positions must be 3 floats"],
            None,
        ),
        (
            "no offsets",
            with(&good, "offsets.uint32", None),
            &["no `offsets` array"],
            None,
        ),
        (
            "header not json",
            with(&good, "header.json", Some(b"{\"NB_VERTICES\": 5,".to_vec())),
            &["header.json is not valid JSON"],
            None,
        ),
        (
            "header negative",
            with(
                &good,
                "header.json",
                Some(br#"{"NB_VERTICES": -5, "NB_STREAMLINES": 2}"#.to_vec()),
            ),
            &["`NB_VERTICES` is -5"],
            None,
        ),
    ];
    for (zipped, deflate) in [(true, false), (true, true), (false, false)] {
        let p = make(dir.path(), "good.trx", &good, zipped, deflate);
        let (_, c) = read(&p);
        assert_eq!(c.len(), 2);
        assert_eq!(c[1].points[2], DVec3::new(12.0, 13.0, 14.0));
        for (what, entries, words, curve) in &cases {
            let p = make(dir.path(), "bad.trx", entries, zipped, deflate);
            let e = match read_trx(&p) {
                Ok(_) => panic!("{what} (zip {zipped}): read fine"),
                Err(e) => e,
            };
            let msg = e.to_string();
            assert!(msg.starts_with(&p.display().to_string()), "{what}: {msg}");
            for w in *words {
                assert!(
                    msg.contains(w),
                    "{what} (zip {zipped}): {msg:?} lacks {w:?}"
                );
            }
            assert_eq!(e.curve, *curve, "{what}: {msg}");
            if !zipped {
                std::fs::remove_dir_all(&p).unwrap();
            }
        }
        if !zipped {
            std::fs::remove_dir_all(dir.path().join("good.trx")).unwrap();
        }
    }
    // Not a zip at all.
    let p = dir.path().join("text.trx");
    std::fs::write(&p, "hello").unwrap();
    let e = read_trx(&p).err().unwrap();
    assert!(e.reason.contains("not a TRX file"), "{e}");
}

/// Every error, whatever the damage: read all curves or fail, never panic.
fn survive(path: &Path) -> Result<usize, IoError> {
    let r = open_trx(path)?;
    let mut n = 0;
    for c in r {
        c?;
        n += 1;
    }
    Ok(n)
}

#[test]
fn truncations_and_corruptions_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7258);
    let mut errors = 0;
    let mut total = 0;
    for name in [
        "trx/complex.trx",
        "trx/fornix_f32_deflated.trx",
        "trx/fornix_f16_stored.trx",
    ] {
        let bytes = std::fs::read(data(name)).unwrap();
        let p = dir.path().join("t.trx");
        // Truncations: every length for the small one, 60 for the others.
        let cuts: Vec<usize> = if bytes.len() < 4096 {
            (0..bytes.len()).collect()
        } else {
            (0..60).map(|_| rng.gen_range(0..bytes.len())).collect()
        };
        for cut in cuts {
            std::fs::write(&p, &bytes[..cut]).unwrap();
            total += 1;
            // A zip's directory is at its end: every cut loses it.
            let e = survive(&p).expect_err("a truncated zip reads");
            assert!(e.path == p);
            errors += 1;
        }
        // Corruptions: 1–8 random bytes changed.
        for _ in 0..150 {
            let mut b = bytes.clone();
            for _ in 0..rng.gen_range(1..=8) {
                let i = rng.gen_range(0..b.len());
                b[i] = rng.gen();
            }
            std::fs::write(&p, &b).unwrap();
            total += 1;
            if survive(&p).is_err() {
                errors += 1;
            }
        }
    }
    // Folders: truncate and corrupt each file in turn.
    for name in ["trx/complex_dir", "trx/fornix_f16_dir"] {
        let entries = files_of(&data(name));
        for (i, (n, b)) in entries.iter().enumerate() {
            for _ in 0..10 {
                let mut v = entries.clone();
                let mut nb = b.clone();
                if rng.gen_bool(0.5) {
                    nb.truncate(rng.gen_range(0..=b.len()));
                } else if !nb.is_empty() {
                    let j = rng.gen_range(0..nb.len());
                    nb[j] = rng.gen();
                }
                v[i] = (n.clone(), nb);
                let p = make(dir.path(), "d", &v, false, false);
                total += 1;
                if survive(&p).is_err() {
                    errors += 1;
                }
                std::fs::remove_dir_all(&p).unwrap();
            }
        }
    }
    println!("{errors} of {total} damaged inputs were errors, the rest read");
    assert!(errors > total / 2);
}

#[test]
fn corrupted_stored_data_fails_its_crc_on_the_last_curve() {
    let dir = tempfile::tempdir().unwrap();
    let entries = files_of(&data("trx/fornix_f16_stored.trx"));
    let p = make(dir.path(), "c.trx", &entries, true, false);
    let mut b = std::fs::read(&p).unwrap();
    // A byte inside the positions entry (the largest one).
    let (at, _) = b
        .windows(19)
        .enumerate()
        .find(|(_, w)| w == b"positions.3.float16")
        .unwrap();
    b[at + 19 + 1000] ^= 0x40;
    std::fs::write(&p, &b).unwrap();
    let r = open_trx(&p).unwrap();
    let results: Vec<_> = r.collect();
    assert_eq!(results.len(), 300, "curves stream until the end");
    let e = results.last().unwrap().as_ref().unwrap_err();
    assert!(e.reason.contains("CRC-32"), "{e}");
    assert_eq!(e.curve, Some(299));
}

/// Writes `$STRANDFIT_TRX_OUT/ours_*.trx` for tests/scripts/trx_check.py.
#[test]
fn conversions_for_an_external_check() {
    let Some(out) = std::env::var_os("STRANDFIT_TRX_OUT") else {
        return;
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out).unwrap();
    let mut manifest = String::new();
    for (src, name) in [
        (
            "fibres/dipy_fornix_tracks300.tck",
            "ours_fornix_from_tck.trx",
        ),
        (
            "fibres/nibabel_fixtures/complex.trk",
            "ours_complex_from_trk.trx",
        ),
        ("trx/complex.trx", "ours_complex_from_trx.trx"),
        ("trx/fornix_f16_stored.trx", "ours_fornix_f16_from_trx.trx"),
    ] {
        let (meta, curves) = io::read_all(
            &data(src),
            if src.ends_with(".trx") {
                Some(Format::Trx)
            } else {
                None
            },
        )
        .unwrap();
        let p = out.join(name);
        write(&p, Format::Trx, &meta, &curves);
        manifest.push_str(&format!("{}\t{}\n", p.display(), data(src).display()));
    }
    std::fs::write(out.join("manifest.txt"), manifest).unwrap();
}
