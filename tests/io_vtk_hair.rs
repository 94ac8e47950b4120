//! VTK legacy POLYDATA and `.hair` readers and writers: hand-made fixtures
//! (always: committed ASCII files, and binary files assembled byte by byte
//! here, independently of the writers), the shared field lines and hair
//! (when `../shared/data` or `STRANDFIT_SHARED_DATA` has them), round
//! trips, truncated / corrupted / hostile files.

mod common;

use std::io::{Seek, SeekFrom, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::io::{self, Curve, Format, IoError, Metadata};

// ---------------------------------------------------------------------------
// Where the data is

fn shared(rel: &str) -> Option<PathBuf> {
    common::shared_data(rel)
}

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

fn read(path: &Path) -> (Metadata, Vec<Curve>) {
    io::read_all(path, None).unwrap_or_else(|e| panic!("{e}"))
}

fn read_err(path: &Path) -> IoError {
    match io::read_all(path, None) {
        Ok((_, c)) => panic!(
            "{}: read {} curves, expected an error",
            path.display(),
            c.len()
        ),
        Err(e) => e,
    }
}

fn write(path: &Path, meta: &Metadata, curves: &[Curve]) {
    let mut w = io::create_writer(path, None, meta).unwrap_or_else(|e| panic!("{e}"));
    for c in curves {
        w.write_curve(c).unwrap_or_else(|e| panic!("{e}"));
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
}

/// Curves equal bit for bit (points as f64 bits, data as f32 bits).
fn assert_same(a: &[Curve], b: &[Curve], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: curve count");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let bits = |c: &Curve| {
            (
                c.points
                    .iter()
                    .flat_map(|p| p.to_array().map(f64::to_bits))
                    .collect::<Vec<_>>(),
                c.point_data.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                c.curve_data.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            )
        };
        assert!(
            bits(x) == bits(y),
            "{what}: curve {i} differs:\n{x:?}\n{y:?}"
        );
    }
}

fn arc_length(c: &Curve) -> f64 {
    c.points.windows(2).map(|w| (w[1] - w[0]).length()).sum()
}

// ---------------------------------------------------------------------------
// The fixture geometry (tests/data/vtk/*.vtk and the binary files below):
// 8 points, one vertex (point 7), three lines, one polygon; cells are
// numbered vertex, lines, polygon, so line i is cell 1 + i.

const P: [[f64; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.5],
    [2.0, 2.0, 2.0],
    [2.5, 2.0, 2.0],
    [3.0, 2.25, 2.0],
    [-1.0, -1.0, -1.0],
];
const LINES: [&[usize]; 3] = [&[0, 1, 2, 3], &[4, 5, 6], &[6, 2]];
const CELL_ID: [i32; 5] = [100, 0, 1, 2, 200];

fn temp(j: usize) -> f32 {
    j as f32 + 0.5
}

fn expected(
    point_data: impl Fn(usize) -> Vec<f32>,
    curve_data: impl Fn(usize) -> Vec<f32>,
) -> Vec<Curve> {
    LINES
        .iter()
        .enumerate()
        .map(|(i, l)| Curve {
            id: None,
            points: l.iter().map(|&j| DVec3::from_array(P[j])).collect(),
            point_data: l.iter().flat_map(|&j| point_data(j)).collect(),
            curve_data: curve_data(i),
        })
        .collect()
}

#[derive(Clone, Copy, Debug)]
enum Layout {
    Classic,
    V51 { int64: bool },
}

/// A BINARY file of the fixture geometry, assembled by hand: CELL_DATA
/// `SCALARS id int`, POINT_DATA `FIELD` with `temp` (float) and `vel`
/// (3 doubles: j, -j, 2j).
fn vtk_binary(layout: Layout, double: bool) -> Vec<u8> {
    let mut b = Vec::new();
    let version = if matches!(layout, Layout::Classic) {
        "3.0"
    } else {
        "5.1"
    };
    b.extend(
        format!("# vtk DataFile Version {version}\nbinary fixture\nBINARY\nDATASET POLYDATA\n")
            .bytes(),
    );
    b.extend(format!("POINTS 8 {}\n", if double { "double" } else { "float" }).bytes());
    for p in P.iter().flatten() {
        if double {
            b.extend(p.to_be_bytes());
        } else {
            b.extend((*p as f32).to_be_bytes());
        }
    }
    b.push(b'\n');
    let cells: [(&str, Vec<&[usize]>); 3] = [
        ("VERTICES", vec![&[7]]),
        ("LINES", LINES.to_vec()),
        ("POLYGONS", vec![&[0, 1, 2]]),
    ];
    for (kw, cs) in cells {
        let conn: usize = cs.iter().map(|c| c.len()).sum();
        match layout {
            Layout::Classic => {
                b.extend(format!("{kw} {} {}\n", cs.len(), conn + cs.len()).bytes());
                for c in &cs {
                    b.extend((c.len() as i32).to_be_bytes());
                    for &j in c.iter() {
                        b.extend((j as i32).to_be_bytes());
                    }
                }
            }
            Layout::V51 { int64 } => {
                let t = if int64 {
                    "vtktypeint64"
                } else {
                    "vtktypeint32"
                };
                let put = |b: &mut Vec<u8>, v: usize| {
                    if int64 {
                        b.extend((v as i64).to_be_bytes())
                    } else {
                        b.extend((v as i32).to_be_bytes())
                    }
                };
                b.extend(format!("{kw} {} {conn}\nOFFSETS {t}\n", cs.len() + 1).bytes());
                let mut o = 0;
                put(&mut b, 0);
                for c in &cs {
                    o += c.len();
                    put(&mut b, o);
                }
                b.extend(format!("\nCONNECTIVITY {t}\n").bytes());
                for c in &cs {
                    for &j in c.iter() {
                        put(&mut b, j);
                    }
                }
            }
        }
        b.push(b'\n');
    }
    b.extend(b"CELL_DATA 5\nSCALARS id int 1\nLOOKUP_TABLE default\n");
    for v in CELL_ID {
        b.extend(v.to_be_bytes());
    }
    b.extend(b"\nPOINT_DATA 8\nFIELD FieldData 2\ntemp 1 8 float\n");
    for j in 0..8 {
        b.extend(temp(j).to_be_bytes());
    }
    b.extend(b"\nvel 3 8 double\n");
    for j in 0..8 {
        for v in [j as f64, -(j as f64), 2.0 * j as f64] {
            b.extend(v.to_be_bytes());
        }
    }
    b.push(b'\n');
    b
}

/// A `.hair` file assembled by hand: strands of 2, 4 and 3 points (or,
/// without the segments array, 3 strands of the default 2 segments), with
/// the optional arrays of `bits`. Point k is (k, k/10, -k), thickness
/// k/100, transparency k/200, colour (k/10, k/20, k/30).
fn hair_bytes(bits: u32) -> (Vec<u8>, Vec<usize>) {
    let lens: Vec<usize> = if bits & 1 != 0 {
        vec![2, 4, 3]
    } else {
        vec![3, 3, 3]
    };
    let n: usize = lens.iter().sum();
    let mut b = b"HAIR".to_vec();
    for v in [lens.len() as u32, n as u32, bits, 2] {
        b.extend(v.to_le_bytes());
    }
    for v in [0.07f32, 0.0, 0.3, 0.2, 0.12] {
        b.extend(v.to_le_bytes());
    }
    let mut info = [0u8; 88];
    info[..12].copy_from_slice(b"hand-made ok");
    b.extend(info);
    if bits & 1 != 0 {
        for l in &lens {
            b.extend((*l as u16 - 1).to_le_bytes());
        }
    }
    for k in 0..n {
        for v in [k as f32, k as f32 / 10.0, -(k as f32)] {
            b.extend(v.to_le_bytes());
        }
    }
    if bits & 4 != 0 {
        (0..n).for_each(|k| b.extend((k as f32 / 100.0).to_le_bytes()));
    }
    if bits & 8 != 0 {
        (0..n).for_each(|k| b.extend((k as f32 / 200.0).to_le_bytes()));
    }
    if bits & 16 != 0 {
        for k in 0..n {
            for d in [10.0f32, 20.0, 30.0] {
                b.extend((k as f32 / d).to_le_bytes());
            }
        }
    }
    (b, lens)
}

fn put(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

// ---------------------------------------------------------------------------
// Fixtures

#[test]
fn classic_ascii_fixture_carries_skips_and_drops() {
    let (meta, curves) = read(&fixture("vtk/classic_ascii.vtk"));
    assert_eq!(meta.format, Format::Vtk);
    assert_eq!(meta.count, Some(3));
    assert_eq!(meta.units, None);
    assert_eq!(
        meta.point_data_names,
        ["temp", "vel_0", "vel_1", "vel_2", "mass"]
    );
    assert_eq!(meta.curve_data_names, ["id", "weight kg"]);
    let weight = [9.0, 0.5, 1.5, 2.5, 9.0];
    let want = expected(
        |j| {
            vec![
                temp(j),
                j as f32,
                0.0 - j as f32,
                2.0 * j as f32,
                j as f32 + 10.0,
            ]
        },
        |i| vec![CELL_ID[1 + i] as f32, weight[1 + i]],
    );
    assert_same(&curves, &want, "classic ASCII fixture");
    assert_eq!(meta.extra("vtk.encoding"), Some("ASCII"));
    assert_eq!(meta.extra("vtk.dtype.id"), Some("int"));
    assert_eq!(meta.extra("vtk.dtype.mass"), Some("double"));
    assert!(meta
        .extra("vtk.title")
        .unwrap()
        .starts_with("hand-made fixture: 3 lines"));
    let dropped = meta.extra("vtk.dropped").unwrap();
    for d in [
        "`TIME`",
        "COLOR_SCALARS `rgb`",
        "LOOKUP_TABLE `my_table`",
        "`tags` (3 tuples, not 8)",
        "`names` (string",
    ] {
        assert!(dropped.contains(d), "{d} not in {dropped}");
    }
}

#[test]
fn v51_ascii_fixture_matches_the_geometry() {
    let (meta, curves) = read(&fixture("vtk/v51_ascii.vtk"));
    assert_eq!(meta.extra("vtk.layout"), Some("5.1"));
    assert_eq!(meta.point_data_names, ["temp"]);
    assert_eq!(meta.curve_data_names, ["id"]);
    let want = expected(|j| vec![temp(j)], |i| vec![CELL_ID[1 + i] as f32]);
    assert_same(&curves, &want, "5.1 ASCII fixture");
}

#[test]
fn binary_layouts_read_the_same() {
    let dir = tempfile::tempdir().unwrap();
    for layout in [
        Layout::Classic,
        Layout::V51 { int64: true },
        Layout::V51 { int64: false },
    ] {
        for double in [false, true] {
            let p = put(dir.path(), "b.vtk", &vtk_binary(layout, double));
            let (meta, curves) = read(&p);
            let what = format!("{layout:?} double={double}");
            assert_eq!(meta.extra("vtk.encoding"), Some("BINARY"), "{what}");
            assert_eq!(
                meta.extra("vtk.points_type"),
                Some(if double { "double" } else { "float" })
            );
            assert_eq!(
                meta.point_data_names,
                ["temp", "vel_0", "vel_1", "vel_2"],
                "{what}"
            );
            assert_eq!(meta.curve_data_names, ["id"], "{what}");
            let want = expected(
                |j| vec![temp(j), j as f32, -(j as f32), 2.0 * j as f32],
                |i| vec![CELL_ID[1 + i] as f32],
            );
            assert_same(&curves, &want, &what);
        }
    }
}

#[test]
fn hair_fixtures_with_and_without_optional_arrays() {
    let dir = tempfile::tempdir().unwrap();
    for bits in [2, 3, 3 | 4, 3 | 8, 3 | 16, 3 | 4 | 8 | 16, 2 | 4 | 16] {
        let (bytes, lens) = hair_bytes(bits);
        let p = put(dir.path(), "h.hair", &bytes);
        let (meta, curves) = read(&p);
        assert_eq!(meta.format, Format::Hair);
        assert_eq!(meta.count, Some(3));
        assert_eq!(meta.extra("hair.info"), Some("hand-made ok"));
        assert_eq!(meta.extra("hair.default_thickness"), Some("0.07"));
        assert_eq!(meta.extra("hair.default_color"), Some("0.3 0.2 0.12"));
        let mut names = Vec::new();
        if bits & 4 != 0 {
            names.push("thickness");
        }
        if bits & 8 != 0 {
            names.push("transparency");
        }
        if bits & 16 != 0 {
            names.extend(["color_r", "color_g", "color_b"]);
        }
        assert_eq!(meta.point_data_names, names, "bits {bits}");
        assert_eq!(
            curves.iter().map(|c| c.points.len()).collect::<Vec<_>>(),
            lens
        );
        let mut k = 0;
        for c in &curves {
            let mut want = Vec::new();
            for p in &c.points {
                let kf = k as f32;
                assert_eq!(*p, DVec3::new(kf as f64, (kf / 10.0) as f64, -kf as f64));
                if bits & 4 != 0 {
                    want.push(kf / 100.0);
                }
                if bits & 8 != 0 {
                    want.push(kf / 200.0);
                }
                if bits & 16 != 0 {
                    want.extend([kf / 10.0, kf / 20.0, kf / 30.0]);
                }
                k += 1;
            }
            assert_eq!(c.point_data, want, "bits {bits}");
            assert!(c.curve_data.is_empty());
        }
    }
}

// ---------------------------------------------------------------------------
// The shared data

fn median(v: &mut [usize]) -> usize {
    v.sort_unstable();
    v[v.len() / 2]
}

#[test]
fn shared_fieldlines_binary() {
    let Some(p) = shared("fieldlines/pfss_fieldlines.vtk") else {
        return;
    };
    let (meta, curves) = read(&p);
    assert_eq!(meta.count, Some(5800));
    assert_eq!(curves.len(), 5800);
    let mut lens: Vec<usize> = curves.iter().map(|c| c.points.len()).collect();
    assert_eq!(lens.iter().sum::<usize>(), 326_860);
    assert_eq!(*lens.iter().min().unwrap(), 8);
    assert_eq!(*lens.iter().max().unwrap(), 149);
    assert_eq!(median(&mut lens), 60);
    assert_eq!(meta.units, None, "the file does not say its unit");
    assert_eq!(meta.curve_data_names, ["polarity"]);
    assert!(meta.point_data_names.is_empty());
    assert_eq!(meta.extra("vtk.dtype.polarity"), Some("int"));
    assert!(meta
        .extra("vtk.title")
        .unwrap()
        .starts_with("PFSS field lines"));
    let mut hist = [0usize; 3];
    for c in &curves {
        let v = c.curve_data[0];
        assert!(v == -1.0 || v == 0.0 || v == 1.0, "polarity {v}");
        hist[(v + 1.0) as usize] += 1;
        // Heliocentric, in solar radii: between the surface and the source
        // surface at 2.5.
        for q in &c.points {
            assert!((0.99..2.51).contains(&q.length()), "{q}");
        }
    }
    assert!(hist.iter().all(|&n| n > 100), "polarity histogram {hist:?}");
    eprintln!("polarity -1/0/+1: {hist:?}");
}

#[test]
fn shared_ascii_subset_is_every_tenth_line_bitwise() {
    let (Some(b), Some(a)) = (
        shared("fieldlines/pfss_fieldlines.vtk"),
        shared("fieldlines/pfss_fieldlines_every10th_ascii.vtk"),
    ) else {
        return;
    };
    let (_, all) = read(&b);
    let (meta, sub) = read(&a);
    assert_eq!(sub.len(), 580);
    assert_eq!(sub.iter().map(|c| c.points.len()).sum::<usize>(), 32_279);
    assert_eq!(meta.curve_data_names, ["polarity"]);
    let tenth: Vec<Curve> = all.into_iter().step_by(10).collect();
    // %.9g round-trips float32, so the ASCII values are the same bits.
    assert_same(&sub, &tenth, "every 10th line");
}

#[test]
fn shared_hair() {
    let Some(p) = shared("hair/synthetic_hair.hair") else {
        return;
    };
    let (meta, curves) = read(&p);
    assert_eq!(meta.count, Some(2000));
    assert_eq!(curves.len(), 2000);
    assert!(curves.iter().all(|c| c.points.len() == 100));
    assert!(meta.point_data_names.is_empty());
    assert!(meta
        .extra("hair.info")
        .unwrap()
        .starts_with("synthetic hair"));
    let lens: Vec<f64> = curves.iter().map(arc_length).collect();
    let (lo, hi) = lens
        .iter()
        .fold((f64::MAX, 0f64), |(a, b), &l| (a.min(l), b.max(l)));
    eprintln!("hair arc lengths {lo:.1}..{hi:.1} mm");
    assert!(
        lo >= 152.0 && hi <= 667.0 && lo < 153.0 && hi > 665.0,
        "{lo} {hi}"
    );
}

// ---------------------------------------------------------------------------
// Round trips

fn with_extra(meta: &Metadata, key: &str, value: &str) -> Metadata {
    let mut m = meta.clone();
    m.extra.retain(|(k, _)| k != key);
    m.extra.push((key.into(), value.into()));
    m
}

/// read → write (each encoding) → read: the same curves and names.
fn vtk_round_trip(src: &Path, dir: &Path) -> (Metadata, Vec<Curve>) {
    let (meta, curves) = read(src);
    for enc in ["BINARY", "ASCII"] {
        let out = dir.join(format!("rt_{enc}.vtk"));
        write(&out, &with_extra(&meta, "vtk.encoding", enc), &curves);
        let (m2, c2) = read(&out);
        let what = format!("{} via {enc}", src.display());
        assert_same(&c2, &curves, &what);
        assert_eq!(m2.point_data_names, meta.point_data_names, "{what}");
        assert_eq!(m2.curve_data_names, meta.curve_data_names, "{what}");
        assert_eq!(m2.extra("vtk.encoding"), Some(enc));
        assert_eq!(m2.extra("vtk.layout"), Some("classic"));
        assert_eq!(m2.extra("vtk.title"), meta.extra("vtk.title"));
        assert_eq!(m2.extra("vtk.points_type"), meta.extra("vtk.points_type"));
        for n in meta.point_data_names.iter().chain(&meta.curve_data_names) {
            let k = format!("vtk.dtype.{n}");
            assert_eq!(m2.extra(&k), meta.extra(&k), "{what}: type of {n}");
        }
        assert_eq!(m2.extra("vtk.dropped"), None, "{what}");
    }
    (meta, curves)
}

#[test]
fn vtk_round_trips_fixtures() {
    let dir = tempfile::tempdir().unwrap();
    vtk_round_trip(&fixture("vtk/classic_ascii.vtk"), dir.path());
    vtk_round_trip(&fixture("vtk/v51_ascii.vtk"), dir.path());
    for layout in [Layout::Classic, Layout::V51 { int64: true }] {
        for double in [false, true] {
            let p = put(dir.path(), "b.vtk", &vtk_binary(layout, double));
            vtk_round_trip(&p, dir.path());
        }
    }
}

#[test]
fn vtk_round_trip_shared_is_byte_identical() {
    let Some(p) = shared("fieldlines/pfss_fieldlines.vtk") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (meta, curves) = vtk_round_trip(&p, dir.path());
    // The writer lays BINARY files out as the source's writer did.
    let out = dir.path().join("same.vtk");
    write(&out, &meta, &curves);
    assert!(
        std::fs::read(&out).unwrap() == std::fs::read(&p).unwrap(),
        "bytes differ"
    );
    if let Some(a) = shared("fieldlines/pfss_fieldlines_every10th_ascii.vtk") {
        vtk_round_trip(&a, dir.path());
    }
}

#[test]
fn hair_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    for bits in [2, 3, 3 | 4 | 8 | 16, 2 | 16] {
        let (bytes, _) = hair_bytes(bits);
        let p = put(dir.path(), "h.hair", &bytes);
        let (meta, curves) = read(&p);
        let out = dir.path().join("rt.hair");
        write(&out, &meta, &curves);
        let (m2, c2) = read(&out);
        assert_same(&c2, &curves, &format!("hair bits {bits}"));
        assert_eq!(m2.point_data_names, meta.point_data_names);
        // Defaults and info are kept; the segments array is always written.
        assert_eq!(m2.extra, meta.extra);
        if bits & 1 != 0 {
            assert!(
                std::fs::read(&out).unwrap() == bytes,
                "bits {bits}: bytes differ"
            );
        }
    }
    if let Some(p) = shared("hair/synthetic_hair.hair") {
        let (meta, curves) = read(&p);
        let out = dir.path().join("shared.hair");
        write(&out, &meta, &curves);
        assert!(
            std::fs::read(&out).unwrap() == std::fs::read(&p).unwrap(),
            "bytes differ"
        );
    }
}

#[test]
fn cross_format_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    // vtk → hair → vtk: points survive bit for bit (float32 both ways); the
    // per-line polarity has no place in .hair and is dropped.
    let src = shared("fieldlines/pfss_fieldlines_every10th_ascii.vtk")
        .unwrap_or_else(|| fixture("vtk/v51_ascii.vtk"));
    let (meta, curves) = read(&src);
    let h = dir.path().join("lines.hair");
    write(&h, &meta, &curves);
    let (hm, hc) = read(&h);
    assert!(hm.point_data_names.is_empty() && hm.curve_data_names.is_empty());
    assert_eq!(
        hm.extra("hair.info"),
        meta.extra("vtk.title").map(|t| &t[..t.len().min(87)])
    );
    let v = dir.path().join("back.vtk");
    write(&v, &hm, &hc);
    let (_, vc) = read(&v);
    let bare: Vec<Curve> = curves
        .iter()
        .map(|c| Curve::from_points(c.points.clone()))
        .collect();
    assert_same(&vc, &bare, "vtk → hair → vtk");

    // hair → vtk → hair: thickness, transparency and colour ride along as
    // POINT_DATA and come back under the same names.
    let (bytes, _) = hair_bytes(3 | 4 | 8 | 16);
    let p = put(dir.path(), "h.hair", &bytes);
    let (meta, curves) = read(&p);
    let v = dir.path().join("h.vtk");
    write(&v, &meta, &curves);
    let (vm, vc) = read(&v);
    assert_eq!(vm.point_data_names, meta.point_data_names);
    assert_eq!(vm.extra("vtk.title"), Some("hand-made ok"));
    let h2 = dir.path().join("h2.hair");
    write(&h2, &vm, &vc);
    let (m2, c2) = read(&h2);
    assert_same(&c2, &curves, "hair → vtk → hair");
    assert_eq!(m2.point_data_names, meta.point_data_names);
}

// ---------------------------------------------------------------------------
// Truncations and corruptions: reading never panics

/// Offsets just after each occurrence of `needle`.
fn find_all(hay: &[u8], needle: &[u8]) -> Vec<usize> {
    hay.windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i)
        .collect()
}

/// The byte ranges that hold structure rather than bulk values: the header
/// and the text around each keyword (`before`/`after` bytes; VTK), the
/// header and the start of the segments (hair).
fn hot_ranges(
    bytes: &[u8],
    ext: &str,
    (before, after): (usize, usize),
) -> Vec<std::ops::Range<usize>> {
    let n = bytes.len();
    if ext == "hair" {
        return std::iter::once(0..n.min(200)).collect();
    }
    let mut r: Vec<_> = std::iter::once(0..n.min(160)).collect();
    for kw in [
        &b"POINTS"[..],
        b"VERTICES",
        b"LINES",
        b"POLYGONS",
        b"OFFSETS",
        b"CONNECTIVITY",
        b"CELL_DATA",
        b"POINT_DATA",
        b"SCALARS",
        b"LOOKUP_TABLE",
        b"FIELD",
        b"METADATA",
    ] {
        for at in find_all(bytes, kw) {
            r.push(at.saturating_sub(before)..(at + after).min(n));
        }
    }
    r
}

struct Fuzz {
    cases: usize,
    errors: usize,
    panics: Vec<String>,
}

fn try_read(path: &Path, fmt: Format, label: String, f: &mut Fuzz) {
    f.cases += 1;
    match catch_unwind(AssertUnwindSafe(|| io::read_all(path, Some(fmt)))) {
        Ok(Ok(_)) => {}
        Ok(Err(e)) => {
            f.errors += 1;
            assert_eq!(e.path, path, "{label}: error names another file: {e}");
        }
        Err(_) => f.panics.push(label),
    }
}

/// How hard to shake a file.
struct Plan {
    /// Bytes before and after each keyword to cut at (VTK).
    window: (usize, usize),
    /// Evenly spaced cuts over the whole file.
    dense: usize,
    corruptions: usize,
    seed: u64,
}

/// Truncate `bytes` at every byte of its hot ranges and at evenly spaced
/// cuts, then corrupt it (1–4 bytes, half of them in the hot ranges); read
/// each in full. Returns the number of truncations read as errors, and of
/// truncations tried.
fn fuzz_file(label: &str, bytes: &[u8], fmt: Format, plan: Plan) -> (usize, usize) {
    let Plan {
        window,
        dense,
        corruptions,
        seed,
    } = plan;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("fuzz.{}", fmt.extension()));
    let hot = hot_ranges(bytes, fmt.extension(), window);
    let mut cuts: Vec<usize> = hot.iter().flat_map(|r| r.clone()).collect();
    cuts.extend((0..dense).map(|k| k * bytes.len() / dense.max(1)));
    cuts.sort_unstable();
    cuts.dedup();
    cuts.retain(|&c| c < bytes.len());

    let mut f = Fuzz {
        cases: 0,
        errors: 0,
        panics: Vec::new(),
    };
    // One copy of the file, cut shorter and shorter in place.
    std::fs::write(&path, bytes).unwrap();
    for &c in cuts.iter().rev() {
        std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .unwrap()
            .set_len(c as u64)
            .unwrap();
        try_read(&path, fmt, format!("{label} cut at {c}"), &mut f);
    }
    let truncation_errors = f.errors;

    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let specials = [0u8, 0xff, b'\n', b' ', b'-', b'9', b'.', b'e', 0x7f, 0x80];
    // The whole file again, patched in place and restored after each read.
    std::fs::write(&path, bytes).unwrap();
    let poke = |at: usize, v: u8| {
        let mut file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        file.seek(SeekFrom::Start(at as u64)).unwrap();
        file.write_all(&[v]).unwrap();
    };
    for k in 0..corruptions {
        let mut what = Vec::new();
        let mut touched = Vec::new();
        for _ in 0..rng.gen_range(1..=4) {
            let at = if rng.gen_bool(0.5) {
                let r = &hot[rng.gen_range(0..hot.len())];
                rng.gen_range(r.start..r.end.max(r.start + 1))
                    .min(bytes.len() - 1)
            } else {
                rng.gen_range(0..bytes.len())
            };
            let v = if rng.gen_bool(0.5) {
                specials[rng.gen_range(0..specials.len())]
            } else {
                rng.gen()
            };
            poke(at, v);
            touched.push(at);
            what.push(format!("{at}={v:#04x}"));
        }
        try_read(
            &path,
            fmt,
            format!("{label} corruption {k}: {}", what.join(",")),
            &mut f,
        );
        for at in touched {
            poke(at, bytes[at]);
        }
    }
    eprintln!(
        "{label}: {} cases ({} truncations, {truncation_errors} of them errors; {} errors in all)",
        f.cases,
        cuts.len(),
        f.errors
    );
    assert!(f.panics.is_empty(), "{label}: panics in {:#?}", f.panics);
    (truncation_errors, cuts.len())
}

/// Small files: cut at every byte, 400 corruptions.
fn every_byte(bytes: &[u8], seed: u64) -> Plan {
    Plan {
        window: (8, 48),
        dense: bytes.len(),
        corruptions: 400,
        seed,
    }
}

#[test]
fn fuzz_fixtures_never_panic() {
    for name in ["vtk/classic_ascii.vtk", "vtk/v51_ascii.vtk"] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        fuzz_file(name, &bytes, Format::Vtk, every_byte(&bytes, 1));
    }
    for (i, layout) in [
        Layout::Classic,
        Layout::V51 { int64: true },
        Layout::V51 { int64: false },
    ]
    .into_iter()
    .enumerate()
    {
        let bytes = vtk_binary(layout, i == 1);
        let label = format!("binary {layout:?}");
        let (errs, cuts) = fuzz_file(
            &label,
            &bytes,
            Format::Vtk,
            every_byte(&bytes, 2 + i as u64),
        );
        // A BINARY file cut short is an error, except where the cut falls
        // between whole sections (or drops only the final newline).
        assert!(
            errs * 10 >= cuts * 9,
            "{label}: only {errs} of {cuts} truncations were errors"
        );
    }
    for bits in [2, 3, 3 | 4 | 8 | 16] {
        let (bytes, _) = hair_bytes(bits);
        let label = format!("hair bits {bits}");
        let (errs, cuts) = fuzz_file(
            &label,
            &bytes,
            Format::Hair,
            every_byte(&bytes, 10 + bits as u64),
        );
        assert_eq!(
            errs, cuts,
            "{label}: every truncated .hair file is an error"
        );
    }
}

#[test]
fn fuzz_shared_files_never_panic() {
    // Every header byte and each keyword with its counts, 120 cuts
    // elsewhere, 80 corruptions: a whole read of these files takes a while
    // unoptimised (the fixtures above get every byte and 400).
    for (rel, fmt, seed) in [
        ("fieldlines/pfss_fieldlines.vtk", Format::Vtk, 20),
        (
            "fieldlines/pfss_fieldlines_every10th_ascii.vtk",
            Format::Vtk,
            21,
        ),
        ("hair/synthetic_hair.hair", Format::Hair, 22),
    ] {
        let Some(p) = shared(rel) else { continue };
        let bytes = std::fs::read(&p).unwrap();
        let plan = Plan {
            window: (4, 24),
            dense: 120,
            corruptions: 80,
            seed,
        };
        let (errs, cuts) = fuzz_file(rel, &bytes, fmt, plan);
        if rel.ends_with("pfss_fieldlines.vtk") || fmt == Format::Hair {
            assert!(
                errs * 10 >= cuts * 9,
                "{rel}: only {errs} of {cuts} truncations were errors"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// Hostile and broken files: errors that say what, where and which file

/// A hostile file: name, bytes, what the message must say, which curve.
type Case = (&'static str, Vec<u8>, Vec<&'static str>, Option<u64>);

fn assert_error(e: &IoError, path: &Path, needles: &[&str]) {
    let msg = e.to_string();
    assert_eq!(e.path, path, "{msg}");
    assert!(
        msg.contains(&path.display().to_string()),
        "no path in: {msg}"
    );
    for n in needles {
        assert!(msg.contains(n), "`{n}` not in: {msg}");
    }
}

const HEAD: &str = "# vtk DataFile Version 3.0\nbad\n";

/// A BINARY file of 3 points up to `LINES n size\n` (117 bytes for one-digit counts).
fn bin_lines(n: u32, size: u32) -> Vec<u8> {
    let mut b = format!("{HEAD}BINARY\nDATASET POLYDATA\nPOINTS 3 float\n").into_bytes();
    b.extend(be_i32s(&[0; 9]));
    b.extend(format!("\nLINES {n} {size}\n").bytes());
    b
}

fn be_i32s(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_be_bytes()).collect()
}

#[test]
fn hostile_vtk_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<Case> = vec![
        ("magic", b"# vtk DataFile Versoin 3.0\nx\nASCII\nDATASET POLYDATA\n".to_vec(), vec!["not a VTK legacy file", "line 1"], None),
        ("empty", Vec::new(), vec!["not a VTK legacy file"], None),
        (
            "huge_points_binary",
            [format!("{HEAD}BINARY\nDATASET POLYDATA\nPOINTS 4000000000 float\n").as_bytes(), &[0u8; 24][..]].concat(),
            vec!["POINTS 4000000000 float", "do not fit", "byte "],
            None,
        ),
        (
            "huge_points_ascii",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 4000000000 float\n0 0 0 1 1 1\n").into_bytes(),
            vec!["POINTS 4000000000 float", "cannot fit", "line 5"],
            None,
        ),
        (
            "overflowing_points",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 18446744073709551615 float\n").into_bytes(),
            vec!["too many"],
            None,
        ),
        (
            "huge_lines_binary",
            [format!("{HEAD}BINARY\nDATASET POLYDATA\nPOINTS 1 float\n").as_bytes(), &[0u8; 12], b"\nLINES 4000000000 4000000001\n", &[0u8; 8]].concat(),
            vec!["LINES", "do not fit"],
            None,
        ),
        (
            "index_out_of_range",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 2 7\n3 0 1 2\n2 1 9\n").into_bytes(),
            vec!["index 9, out of range", "3 points", "curve 1", "line 9"],
            Some(1),
        ),
        (
            "negative_index",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 1 3\n2 0 -1\n").into_bytes(),
            vec!["index -1, out of range", "curve 0"],
            Some(0),
        ),
        (
            "unknown_points_type",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 quaternion\n").into_bytes(),
            vec!["data type `quaternion`", "line 5"],
            None,
        ),
        (
            "unknown_scalars_type",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\nPOINT_DATA 1\nSCALARS s complex\nLOOKUP_TABLE default\n1\n").into_bytes(),
            vec!["unknown data type `complex` for `s`"],
            None,
        ),
        (
            "nan_point",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 nan 0 0 2 0 0\nLINES 2 6\n2 0 2\n2 1 2\n").into_bytes(),
            vec!["not finite", "curve 1", "point 0"],
            Some(1),
        ),
        (
            "line_overruns_size",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 1 3\n3 0 1 2\n").into_bytes(),
            vec!["a cell of 3 points does not fit in the 2 values left of 3", "curve 0", "line 8"],
            Some(0),
        ),
        (
            "lines_size_short",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 1 10\n3 0 1 2\n").into_bytes(),
            vec!["LINES 1 10: the 1 cells hold 4 values, not 10"],
            None,
        ),
        (
            "binary_line_overruns_size",
            [bin_lines(1, 4).as_slice(), &be_i32s(&[5, 0, 1, 2])].concat(),
            vec!["a cell of 5 points does not fit in the 3 values left of 4", "curve 0", "byte 117"],
            Some(0),
        ),
        (
            "binary_lines_used_up",
            [bin_lines(2, 4).as_slice(), &be_i32s(&[3, 0, 1, 2])].concat(),
            vec!["the lines before this one used them all", "curve 1", "byte 133"],
            Some(1),
        ),
        (
            "binary_lines_size_too_big",
            [bin_lines(1, 5).as_slice(), &be_i32s(&[3, 0, 1, 2, 0])].concat(),
            vec!["LINES announces 5 values, but its 1 lines hold 4"],
            None,
        ),
        (
            "binary_index_out_of_range",
            [bin_lines(1, 3).as_slice(), &be_i32s(&[2, 0, 3])].concat(),
            vec!["index 3, out of range", "curve 0", "byte 117"],
            Some(0),
        ),
        (
            "offsets_decrease",
            "# vtk DataFile Version 5.1\nbad\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 3 3\nOFFSETS vtktypeint64\n0 2 1\nCONNECTIVITY vtktypeint64\n0 1 2\n".as_bytes().to_vec(),
            vec!["OFFSETS[2] = 1", "must not decrease", "curve 1"],
            Some(1),
        ),
        (
            "float_offsets",
            "# vtk DataFile Version 5.1\nbad\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 2 3\nOFFSETS float\n0 3\nCONNECTIVITY vtktypeint64\n0 1 2\n".as_bytes().to_vec(),
            vec!["OFFSETS has type `float`, not an integer type"],
            None,
        ),
        (
            "cell_data_count",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 2 0 0\nLINES 1 4\n3 0 1 2\nCELL_DATA 2\nSCALARS p int\nLOOKUP_TABLE default\n1 2\n").into_bytes(),
            vec!["CELL_DATA 2 does not match the 1 cells"],
            None,
        ),
        (
            "point_data_count",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\nPOINT_DATA 2\nSCALARS t float\nLOOKUP_TABLE default\n1 2\n").into_bytes(),
            vec!["POINT_DATA 2 does not match the 1 points", "line 7"],
            None,
        ),
        (
            "not_polydata",
            format!("{HEAD}ASCII\nDATASET UNSTRUCTURED_GRID\n").into_bytes(),
            vec!["UNSTRUCTURED_GRID, not POLYDATA"],
            None,
        ),
        (
            "unknown_keyword",
            format!("{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\nSPLINES 3\n").into_bytes(),
            vec!["unknown keyword `SPLINES`", "line 7"],
            None,
        ),
        (
            "binary_garbage_for_text",
            [format!("{HEAD}BINARY\nDATASET POLYDATA\n").as_bytes(), &[0x41u8; 4000]].concat(),
            vec!["longer than 1024 bytes"],
            None,
        ),
        (
            "hair_as_vtk",
            hair_bytes(3).0,
            vec!["not a VTK legacy file"],
            None,
        ),
    ];
    for (name, bytes, needles, curve) in cases {
        let p = put(d, &format!("{name}.vtk"), &bytes);
        let e = read_err(&p);
        eprintln!("{name}: {e}");
        assert_error(&e, &p, &needles);
        assert_eq!(e.curve, curve, "{name}: {e}");
    }
}

#[test]
fn unreadable_trailing_arrays_are_dropped_not_fatal() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{HEAD}ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 0 0\nLINES 1 3\n2 0 1\n\
         CELL_DATA 1\nFIELD f 2\nkeep 1 1 float\n7\nlabel 1 1 string\nhello\n\
         POINT_DATA 2\nSCALARS never_read float\nLOOKUP_TABLE default\n1 2\n"
    );
    let p = put(dir.path(), "s.vtk", text.as_bytes());
    let (meta, curves) = read(&p);
    assert_eq!(meta.curve_data_names, ["keep"]);
    assert!(meta.point_data_names.is_empty());
    assert_eq!(curves[0].curve_data, [7.0]);
    assert!(meta
        .extra("vtk.dropped")
        .unwrap()
        .contains("`label` (string arrays are not read) and everything after it"));
}

fn hair_header(n_strands: u32, n_points: u32, bits: u32, default_segments: u32) -> Vec<u8> {
    let mut b = b"HAIR".to_vec();
    for v in [n_strands, n_points, bits, default_segments] {
        b.extend(v.to_le_bytes());
    }
    b.extend([0u8; 108]);
    b
}

#[test]
fn hostile_hair_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (good, _) = hair_bytes(3);
    let mut nan = good.clone();
    // Strand 1 starts at point 2: header 128 + 3 segments × 2 + 2 × 12.
    nan[128 + 6 + 24..128 + 6 + 28].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut bad_sum = good.clone();
    bad_sum[128..130].copy_from_slice(&5u16.to_le_bytes());
    let cases: Vec<Case> = vec![
        (
            "magic",
            [b"HAIX", &good[4..]].concat(),
            vec!["not a .hair file", "byte 0"],
            None,
        ),
        (
            "short",
            good[..100].to_vec(),
            vec!["file truncated", "info string"],
            None,
        ),
        ("tiny", b"HA".to_vec(), vec!["file truncated"], None),
        (
            "huge_count",
            [hair_header(4_000_000_000, 9, 3, 0), vec![0u8; 64]].concat(),
            vec!["4000000000 strands", "file truncated", "has 192"],
            None,
        ),
        (
            "segments_sum",
            bad_sum,
            vec!["gives 13 points", "header says 9", "byte 128"],
            None,
        ),
        (
            "default_segments_sum",
            [hair_header(2, 5, 2, 1), vec![0u8; 60]].concat(),
            vec![
                "2 strands of 1 default segments have 4 points",
                "header says 5",
            ],
            None,
        ),
        (
            "no_points",
            hair_header(0, 0, 1, 0),
            vec!["no points array"],
            None,
        ),
        (
            "unknown_bits",
            hair_header(0, 0, 2 | 64, 0),
            vec!["bits above the five"],
            None,
        ),
        (
            "nan",
            nan,
            vec!["coordinate x is NaN", "curve 1", "point 0"],
            Some(1),
        ),
        (
            "vtk_as_hair",
            std::fs::read(fixture("vtk/v51_ascii.vtk")).unwrap(),
            vec!["not a .hair file"],
            None,
        ),
    ];
    for (name, bytes, needles, curve) in cases {
        let p = put(d, &format!("{name}.hair"), &bytes);
        let e = read_err(&p);
        eprintln!("{name}: {e}");
        assert_error(&e, &p, &needles);
        assert_eq!(e.curve, curve, "{name}: {e}");
    }
}

// ---------------------------------------------------------------------------
// Writers

#[test]
fn writers_reject_bad_curves_and_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let line =
        |pts: &[[f64; 3]]| Curve::from_points(pts.iter().map(|&p| DVec3::from_array(p)).collect());
    let ok = line(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    for fmt in [Format::Vtk, Format::Hair] {
        let sub = dir.path().join(fmt.extension());
        std::fs::create_dir(&sub).unwrap();
        let target = sub.join(format!("out.{}", fmt.extension()));
        std::fs::write(&target, b"precious").unwrap();
        let meta = Metadata::new(fmt);
        let cases: [(Curve, &str); 3] = [
            (line(&[[0.0, f64::NAN, 0.0]]), "not finite"),
            (line(&[[1e39, 0.0, 0.0]]), "does not fit in float32"),
            (
                Curve {
                    point_data: vec![1.0],
                    ..ok.clone()
                },
                "per-point values",
            ),
        ];
        for (bad, needle) in cases {
            let mut w = io::create_writer(&target, None, &meta).unwrap();
            w.write_curve(&ok).unwrap();
            let e = w.write_curve(&bad).err().unwrap();
            assert_error(&e, &target, &[needle, "curve 1"]);
            drop(w);
        }
        // Dropped unfinished: the old file stands, no temporary is left.
        assert_eq!(std::fs::read(&target).unwrap(), b"precious");
        let left: Vec<_> = std::fs::read_dir(&sub).unwrap().collect();
        assert_eq!(left.len(), 1, "{fmt}: leftovers {left:?}");
    }
    let hair = dir.path().join("x.hair");
    let mut w = io::create_writer(&hair, None, &Metadata::new(Format::Hair)).unwrap();
    assert!(w.write_curve(&line(&[])).is_err());
    let long = Curve::from_points(vec![DVec3::ZERO; 65_537]);
    assert_error(
        &w.write_curve(&long).err().unwrap(),
        &hair,
        &["65537 points", "1 to 65536"],
    );
}

#[test]
fn vtk_writer_double_points_and_ascii_output() {
    let dir = tempfile::tempdir().unwrap();
    // Doubles that float32 cannot hold exactly (1/3, 1e-300, 1e30 + 1/7)
    // but within its range: readers refuse values beyond it (below).
    let c = Curve::from_points(vec![
        DVec3::new(0.1, 1e-300, -3.0),
        DVec3::new(1.0 / 3.0, 2.0, 1e30 + 1.0 / 7.0),
    ]);
    for enc in ["BINARY", "ASCII"] {
        let meta = with_extra(
            &with_extra(&Metadata::new(Format::Vtk), "vtk.points_type", "double"),
            "vtk.encoding",
            enc,
        );
        let p = dir.path().join(format!("d_{enc}.vtk"));
        write(&p, &meta, std::slice::from_ref(&c));
        let (m, back) = read(&p);
        assert_eq!(m.extra("vtk.points_type"), Some("double"));
        assert_same(&back, std::slice::from_ref(&c), enc);
        let text = std::fs::read(&p).unwrap();
        assert!(text.starts_with(format!("# vtk DataFile Version 3.0\ncurves written by strandfit\n{enc}\nDATASET POLYDATA\nPOINTS 2 double\n").as_bytes()));
        // A double beyond float32's range is written, and refused on reading
        // with the curve and point named: no output format could hold it.
        let huge = Curve::from_points(vec![DVec3::ZERO, DVec3::new(0.0, 0.0, 1e300)]);
        let p = dir.path().join(format!("huge_{enc}.vtk"));
        write(&p, &meta, std::slice::from_ref(&huge));
        let e = read_err(&p);
        assert_error(&e, &p, &["curve 0", "point 1", "beyond the float32 range"]);
    }
}
