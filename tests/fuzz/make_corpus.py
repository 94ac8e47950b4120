#!/usr/bin/env python3
"""Write the fuzz seed corpus tests/fuzz/corpus/<format>/ (standard library only).

Run from the repository root:

    cargo build --release
    python3 tests/fuzz/make_corpus.py [path/to/strandfit]

Copies small real files from tests/data/, writes hand-made edge cases (empty
file, header only, one point, zero-length curves, big endian, NaN/Inf and
out-of-float32-range values, headers announcing 2^32 curves or points), and
makes .sfh seeds with `strandfit compress`. Seeds named `huge_*` announce
absurd counts: every reader must refuse them with an error (the test
`tests/fuzz_readers.rs` asserts it). The output is deterministic, so running
the script again reproduces the committed files (the .sfh seeds as long as
the compressor does not change).
"""

import json
import os
import shutil
import struct
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "tests", "fuzz", "corpus")
DATA = os.path.join(ROOT, "tests", "data")
NAN = float("nan")
INF = float("inf")


def put(fmt, name, data):
    d = os.path.join(OUT, fmt)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def copy(fmt, rel, name=None):
    src = os.path.join(DATA, rel)
    os.makedirs(os.path.join(OUT, fmt), exist_ok=True)
    shutil.copyfile(src, os.path.join(OUT, fmt, name or os.path.basename(rel)))


# ---------------------------------------------------------------- tck


def tck(curves, dtype="Float32LE", count="auto", terminate=True, extra=""):
    """A .tck file; `curves` are lists of (x, y, z); count=None leaves it out."""
    wide = dtype.startswith("Float64")
    end = ">" if dtype.endswith("BE") else "<"
    fmt = end + ("ddd" if wide else "fff")
    body = b""
    for c in curves:
        for p in c:
            body += struct.pack(fmt, *p)
        body += struct.pack(fmt, NAN, NAN, NAN)
    if terminate:
        body += struct.pack(fmt, INF, INF, INF)
    lines = ["mrtrix tracks"]
    if count == "auto":
        lines.append("count: %010d" % len(curves))
    elif count is not None:
        lines.append("count: %s" % count)
    lines.append("datatype: " + dtype)
    if extra:
        lines.append(extra)
    # The offset is the header length, which depends on its own digits.
    for digits in range(2, 8):
        head = "\n".join(lines + ["file: . %0*d" % (digits, 0), "END", ""])
        off = len(head)
        if len(str(off)) <= digits:
            head = "\n".join(lines + ["file: . %d" % off, "END", ""])
            head += " " * (off - len(head))
            return head.encode() + body
    raise ValueError


CURVES = [
    [(0.0, 0.0, 0.0), (1.0, 0.5, 0.25), (2.0, 1.5, 0.5), (3.0, 3.0, 1.0)],
    [(-1.0, 2.0, 3.0), (-1.5, 2.5, 3.5)],
    [(10.0, -10.0, 5.0)],
]


def make_tck():
    f = "tck"
    for rel in [
        "fibres/nibabel_fixtures/simple.tck",
        "fibres/nibabel_fixtures/simple_big_endian.tck",
        "fibres/nibabel_fixtures/empty.tck",
        "fibres/nibabel_fixtures/standard.tck",
        "fibres/dipy_EuDX_small_25.tck",
        "fibres/dipy_minimal_bundles/AF_L.tck",
    ]:
        copy(f, rel)
    put(f, "zero_bytes.tck", b"")
    put(f, "magic_only.tck", "mrtrix tracks\n")
    put(f, "header_only.tck", tck([], terminate=False))
    put(f, "one_point.tck", tck([[(1.0, 2.0, 3.0)]]))
    put(f, "zero_length_curves.tck", tck([[], [(1.0, 2.0, 3.0)], []]))
    put(f, "float32be.tck", tck(CURVES, "Float32BE"))
    put(f, "float64le.tck", tck(CURVES, "Float64LE"))
    put(f, "float64be.tck", tck(CURVES, "Float64BE"))
    put(f, "no_count.tck", tck(CURVES, count=None))
    put(f, "no_terminator.tck", tck(CURVES, terminate=False))
    put(f, "extra_fields.tck", tck(CURVES, extra="step_size: 0.5\ncommand_history: tckgen a b c"))
    put(f, "nan_in_triplet.tck", tck([[(1.0, NAN, 2.0), (3.0, 4.0, 5.0)]]))
    put(f, "inf_in_triplet.tck", tck([[(1.0, 2.0, 3.0), (INF, 4.0, 5.0)]]))
    put(f, "f32_max.tck", tck([[(3.4e38, -3.4e38, 1e38), (0.0, 0.0, 0.0)]]))
    put(f, "beyond_f32.tck", tck([[(1e300, 0.0, 0.0), (0.0, 0.0, 0.0)]], "Float64LE"))
    put(f, "huge_count.tck", tck(CURVES, count="4294967296"))
    put(f, "huge_count_u64.tck", tck(CURVES, count="18446744073709551615"))
    put(f, "huge_offset.tck", b"mrtrix tracks\ncount: 1\ndatatype: Float32LE\nfile: . 4294967296\nEND\n")


# ---------------------------------------------------------------- trk


def patched(src, *edits):
    b = bytearray(src)
    for at, data in edits:
        b[at : at + len(data)] = data
    return bytes(b)


def i32(v):
    return struct.pack("<i", v)


def u32(v):
    return struct.pack("<I", v)


def f32s(*v):
    return struct.pack("<%df" % len(v), *v)


def make_trk():
    f = "trk"
    for rel in [
        "fibres/nibabel_fixtures/simple.trk",
        "fibres/nibabel_fixtures/empty.trk",
        "fibres/nibabel_fixtures/complex.trk",
        "fibres/nibabel_fixtures/complex_big_endian.trk",
        "fibres/nibabel_fixtures/standard.trk",
        "fibres/nibabel_fixtures/standard.LPS.trk",
        "fibres/dipy_EuDX_small_25.trk",
        "fibres/dipy_minimal_bundles/AF_L.trk",
    ]:
        copy(f, rel)
    simple = open(os.path.join(DATA, "fibres/nibabel_fixtures/simple.trk"), "rb").read()
    header = bytearray(simple[:1000])
    put(f, "zero_bytes.trk", b"")
    put(f, "header_truncated.trk", simple[:500])
    put(f, "header_only.trk", patched(header, (988, i32(0))))
    # n_count 2: a streamline of no points, then one of one point.
    body = i32(0) + i32(1) + f32s(1.5, 2.5, 3.5)
    put(f, "zero_length_and_one_point.trk", patched(header, (988, i32(2))) + body)
    one = i32(2) + f32s(1.5, 2.5, 3.5, NAN, 1.0, 1.0)
    put(f, "nan_point.trk", patched(header, (988, i32(1))) + one)
    one = i32(2) + f32s(1.5, 2.5, 3.5, 1.0, INF, 1.0)
    put(f, "inf_point.trk", patched(header, (988, i32(1))) + one)
    # Finite voxmm, but divided by a tiny voxel size it leaves float32's range.
    tiny = patched(header, (12, f32s(1e-38, 1.0, 1.0)), (988, i32(1)))
    put(f, "tiny_voxel_size.trk", tiny + i32(2) + f32s(1e3, 1.0, 1.0, 2e3, 1.0, 1.0))
    put(f, "huge_n_count.trk", patched(simple, (988, i32(0x7FFFFFFF))))
    put(f, "huge_n_count_negative.trk", patched(simple, (988, u32(0xFFFFFFFF))))
    put(f, "huge_points.trk", patched(simple, (1000, i32(0x7FFFFFFF))))
    put(f, "huge_points_negative.trk", patched(simple, (1000, u32(0xFFFFFFFF))))
    put(f, "huge_n_scalars.trk", patched(simple, (36, struct.pack("<h", 0x7FFF))))
    put(f, "bad_hdr_size.trk", patched(simple, (996, i32(999))))


# ---------------------------------------------------------------- trx


def zinfo(name, deflate):
    zi = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
    zi.compress_type = zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED
    zi.external_attr = 0o644 << 16
    return zi


def trx(entries, deflate=False):
    import io

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in entries:
            if isinstance(data, str):
                data = data.encode()
            z.writestr(zinfo(name, deflate), data)
    return buf.getvalue()


def trx_header(nv, ns, v2r=None, dims=(1, 1, 1)):
    v2r = v2r or [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    return json.dumps(
        {"DIMENSIONS": list(dims), "VOXEL_TO_RASMM": v2r, "NB_VERTICES": nv, "NB_STREAMLINES": ns}
    )


def trx_small(pos="float32", offs="uint32", sentinel=True, points=None, curves=None, dpv=False, dps=False, nv=None, ns=None, deflate=False):
    curves = curves if curves is not None else CURVES
    pts = [p for c in curves for p in c] if points is None else points
    lens = [len(c) for c in curves]
    offsets, o = [], 0
    for n in lens:
        offsets.append(o)
        o += n
    if sentinel:
        offsets.append(o)
    code = {"float16": "e", "float32": "f", "float64": "d"}[pos]
    pos_b = b"".join(struct.pack("<3" + code, *p) for p in pts)
    off_b = b"".join(struct.pack("<I" if offs == "uint32" else "<Q", v) for v in offsets)
    entries = [
        ("header.json", trx_header(len(pts) if nv is None else nv, len(curves) if ns is None else ns)),
        ("positions.3." + pos, pos_b),
        ("offsets." + offs, off_b),
    ]
    if dpv:
        entries.append(("dpv/fa.float32", struct.pack("<%df" % len(pts), *[0.1 * k for k in range(len(pts))])))
        entries.append(("dpv/colors.3.uint8", bytes(range(3 * len(pts)))))
    if dps:
        entries.append(("dps/weight.float64", struct.pack("<%dd" % len(curves), *[1.5 * k for k in range(len(curves))])))
        entries.append(("dps/count.int16", struct.pack("<%dh" % len(curves), *range(len(curves)))))
    return trx(entries, deflate)


def make_trx():
    f = "trx"
    copy(f, "trx/complex.trx")
    put(f, "zero_bytes.trx", b"")
    put(f, "small_f32_stored.trx", trx_small())
    put(f, "small_f16_u64_deflated.trx", trx_small("float16", "uint64", sentinel=False, deflate=True))
    put(f, "small_f64_data.trx", trx_small("float64", dpv=True, dps=True))
    put(f, "small_data_deflated.trx", trx_small(dpv=True, dps=True, deflate=True))
    put(f, "empty_header_only.trx", trx([("header.json", trx_header(0, 0))]))
    put(f, "zero_length_curves.trx", trx_small(curves=[[], [(1.0, 2.0, 3.0)], []]))
    put(f, "one_point.trx", trx_small(curves=[[(1.0, 2.0, 3.0)]]))
    put(f, "nan_position.trx", trx_small(points=[(0.0, 0.0, 0.0), (NAN, 1.0, 1.0)] + [(1.0, 1.0, 1.0)] * 5))
    put(f, "inf_position_f16.trx", trx_small("float16", points=[(0.0, 0.0, 0.0), (INF, 1.0, 1.0)] + [(1.0, 1.0, 1.0)] * 5))
    put(f, "beyond_f32_f64.trx", trx_small("float64", points=[(1e300, 0.0, 0.0)] + [(1.0, 1.0, 1.0)] * 6))
    put(f, "huge_nb_vertices.trx", trx_small(nv=4294967296))
    put(f, "huge_nb_streamlines.trx", trx_small(ns=4294967296))
    put(f, "huge_nb_both.trx", trx_small(nv=2**63 - 1, ns=2**63 - 1))


# ---------------------------------------------------------------- vtk

P = [
    [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.5],
    [2.0, 2.0, 2.0], [2.5, 2.0, 2.0], [3.0, 2.25, 2.0], [-1.0, -1.0, -1.0],
]
LINES = [[0, 1, 2, 3], [4, 5, 6], [6, 2]]


def vtk_binary(layout, double, points=None):
    """As `vtk_binary` in tests/io_vtk_hair.rs: layout 'classic', 'v51_32', 'v51_64'."""
    points = points or P
    version = "3.0" if layout == "classic" else "5.1"
    b = ("# vtk DataFile Version %s\nbinary fixture\nBINARY\nDATASET POLYDATA\n" % version).encode()
    b += ("POINTS %d %s\n" % (len(points), "double" if double else "float")).encode()
    for p in points:
        b += struct.pack(">3d" if double else ">3f", *p)
    b += b"\n"
    cells = [("VERTICES", [[7]]), ("LINES", LINES), ("POLYGONS", [[0, 1, 2]])]
    for kw, cs in cells:
        conn = sum(len(c) for c in cs)
        if layout == "classic":
            b += ("%s %d %d\n" % (kw, len(cs), conn + len(cs))).encode()
            for c in cs:
                b += struct.pack(">%di" % (len(c) + 1), len(c), *c)
        else:
            w = layout == "v51_64"
            t = "vtktypeint64" if w else "vtktypeint32"
            code = ">q" if w else ">i"
            b += ("%s %d %d\nOFFSETS %s\n" % (kw, len(cs) + 1, conn, t)).encode()
            o = 0
            b += struct.pack(code, 0)
            for c in cs:
                o += len(c)
                b += struct.pack(code, o)
            b += ("\nCONNECTIVITY %s\n" % t).encode()
            for c in cs:
                for j in c:
                    b += struct.pack(code, j)
        b += b"\n"
    b += b"CELL_DATA 5\nSCALARS id int 1\nLOOKUP_TABLE default\n"
    b += struct.pack(">5i", 100, 0, 1, 2, 200)
    b += b"\nPOINT_DATA 8\nFIELD FieldData 2\ntemp 1 8 float\n"
    b += struct.pack(">8f", *[j + 0.5 for j in range(8)])
    b += b"\nvel 3 8 double\n"
    for j in range(8):
        b += struct.pack(">3d", j, -j, 2.0 * j)
    b += b"\n"
    return b


HEAD = "# vtk DataFile Version 3.0\nfuzz seed\n"


def make_vtk():
    f = "vtk"
    copy(f, "vtk/classic_ascii.vtk")
    copy(f, "vtk/v51_ascii.vtk")
    put(f, "binary_classic_float.vtk", vtk_binary("classic", False))
    put(f, "binary_v51_int64_double.vtk", vtk_binary("v51_64", True))
    put(f, "binary_v51_int32_float.vtk", vtk_binary("v51_32", False))
    pts = [list(p) for p in P]
    pts[5] = [NAN, 2.0, 2.0]
    put(f, "binary_nan_point.vtk", vtk_binary("classic", False, pts))
    pts[5] = [2.0, 1e300, 2.0]
    put(f, "binary_beyond_f32_double.vtk", vtk_binary("classic", True, pts))
    put(f, "zero_bytes.vtk", b"")
    put(f, "header_only.vtk", HEAD + "ASCII\nDATASET POLYDATA\n")
    put(f, "ascii_points_no_lines.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\n")
    put(f, "ascii_one_point_line.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 1 float\n1 2 3\nLINES 1 2\n1 0\n")
    put(f, "ascii_zero_length_line.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n1 2 3 4 5 6\nLINES 2 4\n0\n2 0 1\n")
    put(f, "ascii_nan_inf.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 nan 0 1 1 1 inf 2 2\nLINES 1 4\n3 0 1 2\n")
    put(f, "ascii_beyond_f32.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 double\n0 1e300 0 1 1 1\nLINES 1 3\n2 0 1\n")
    put(f, "ascii_v51_empty_lines.vtk", "# vtk DataFile Version 5.1\nfuzz seed\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\nLINES 1 0\nOFFSETS vtktypeint64\n0\nCONNECTIVITY vtktypeint64\n\n")
    put(f, "huge_points.vtk", (HEAD + "BINARY\nDATASET POLYDATA\nPOINTS 4000000000 float\n").encode() + bytes(24))
    put(f, "huge_points_ascii.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 4294967296 float\n0 0 0 1 1 1\nLINES 1 3\n2 0 1\n")
    put(
        f,
        "huge_lines.vtk",
        (HEAD + "BINARY\nDATASET POLYDATA\nPOINTS 1 float\n").encode() + bytes(12) + b"\nLINES 4000000000 4000000001\n" + bytes(8),
    )
    put(f, "huge_lines_ascii.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\nLINES 4294967296 3\n2 0 1\n")
    put(f, "huge_line_length_ascii.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\nLINES 1 4294967297\n4294967296 0 1\n")
    # Regressions: inputs the fuzz test found (tests/fuzz_readers.rs).
    # classic_ascii.vtk case #1924: `size - used - 1` underflows (a panic in
    # debug builds, a read past the LINES section in release ones).
    put(f, "regress_lines_size_underflow.vtk", HEAD.replace("fuzz seed", "regression: LINES size used up before the last cell") + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\nLINES 2 2\n1 0\n1 1\n")
    # v51_ascii.vtk case #920: a second POINT_DATA (CELL_DATA) section's
    # count is the one checked; the first one's arrays, of another tuple
    # count, are carried, and curves get the wrong number of values.
    put(f, "regress_point_data_count.vtk", HEAD.replace("fuzz seed", "regression: a second POINT_DATA section hides the first one's count") + "ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 1 1 2 2 2\nLINES 1 4\n3 0 1 2\nPOINT_DATA 2\nSCALARS a float 1\nLOOKUP_TABLE default\n0.5 1.5\nPOINT_DATA 3\nSCALARS b float 1\nLOOKUP_TABLE default\n1 2 3\n")
    put(f, "regress_cell_data_count.vtk", HEAD.replace("fuzz seed", "regression: a second CELL_DATA section hides the first one's count") + "ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 1 1 2 2 2\nLINES 2 5\n2 0 1\n1 2\nCELL_DATA 1\nSCALARS a float 1\nLOOKUP_TABLE default\n5\nCELL_DATA 2\nSCALARS b float 1\nLOOKUP_TABLE default\n1 2\n")
    put(f, "huge_cell_data_ascii.vtk", HEAD + "ASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\nLINES 1 3\n2 0 1\nCELL_DATA 4294967296\nSCALARS s float 1\nLOOKUP_TABLE default\n1\n")


# ---------------------------------------------------------------- hair


def hair_bytes(bits, lens=None, points=None, n_strands=None, n_points=None, default_segments=2):
    """As `hair_bytes` in tests/io_vtk_hair.rs."""
    if lens is None:
        lens = [2, 4, 3] if bits & 1 else [3, 3, 3]
    n = sum(lens)
    b = b"HAIR" + struct.pack(
        "<4I", len(lens) if n_strands is None else n_strands, n if n_points is None else n_points, bits, default_segments
    )
    b += struct.pack("<5f", 0.07, 0.0, 0.3, 0.2, 0.12)
    b += b"hand-made ok".ljust(88, b"\0")
    if bits & 1:
        b += b"".join(struct.pack("<H", l - 1) for l in lens)
    pts = points or [(k, k / 10.0, -k) for k in range(n)]
    for p in pts:
        b += struct.pack("<3f", *p)
    if bits & 4:
        b += b"".join(struct.pack("<f", k / 100.0) for k in range(n))
    if bits & 8:
        b += b"".join(struct.pack("<f", k / 200.0) for k in range(n))
    if bits & 16:
        b += b"".join(struct.pack("<3f", k / 10.0, k / 20.0, k / 30.0) for k in range(n))
    return b


def make_hair():
    f = "hair"
    put(f, "points_only.hair", hair_bytes(2))
    put(f, "segments.hair", hair_bytes(3))
    put(f, "all_arrays.hair", hair_bytes(31))
    put(f, "zero_bytes.hair", b"")
    put(f, "header_truncated.hair", hair_bytes(3)[:64])
    put(f, "header_only.hair", hair_bytes(2, lens=[]))
    put(f, "one_point_strands.hair", hair_bytes(3, lens=[1, 1, 2]))
    pts = [(k, k / 10.0, -k) for k in range(9)]
    pts[4] = (NAN, 0.0, 0.0)
    put(f, "nan_point.hair", hair_bytes(3, points=pts))
    pts[4] = (0.0, INF, 0.0)
    put(f, "inf_point.hair", hair_bytes(2, points=pts))
    put(f, "huge_strands.hair", hair_bytes(3, n_strands=0xFFFFFFFF))
    put(f, "huge_points.hair", hair_bytes(3, n_points=0xFFFFFFFF))
    put(f, "huge_default_segments.hair", hair_bytes(2, default_segments=0xFFFFFFFF))


# ---------------------------------------------------------------- json / csv


def make_json():
    f = "json"
    doc = {
        "units": "mm",
        "curves": [
            {"id": "a", "points": [[0, 0, 0], [1, 0.5, 0.25], [2, 1.5, 0.5], [3, 3, 1]]},
            {"id": 7, "points": [[-1, 2, 3], [-1.5, 2.5, 3.5]]},
            {"points": [[10, -10, 5]]},
        ],
    }
    put(f, "simple.json", json.dumps(doc))
    put(f, "pretty.json", json.dumps(doc, indent=2))
    data = {
        "curves": [
            {
                "id": "a",
                "points": [[0, 0, 0], [1, 1, 1], [2, 0, 1]],
                "point_data": {"fa": [0.1, 0.2, 0.3]},
                "curve_data": {"weight": 2.5},
                "tangents": [[1, 0, 0], [1, 0, 0], [1, 0, 0]],
            },
            {"id": "b", "points": [[5, 5, 5], [6, 6, 6]], "point_data": {"fa": [1, 2]}, "curve_data": {"weight": -1}},
        ]
    }
    put(f, "data.json", json.dumps(data))
    put(f, "zero_bytes.json", b"")
    put(f, "not_object.json", "[]")
    put(f, "no_curves.json", '{"curves": []}')
    put(f, "zero_length_curve.json", '{"curves": [{"id": "e", "points": []}, {"points": [[1, 2, 3]]}]}')
    put(f, "one_point.json", '{"curves": [{"points": [[1.5, -2.5, 3.25]]}]}')
    put(f, "beyond_f32.json", '{"curves": [{"points": [[1e300, 0, 0], [0, 0, 0]]}]}')
    put(f, "overflow_f64.json", '{"curves": [{"points": [[1e400, 0, 0], [0, 0, 0]]}]}')
    put(f, "f32_max.json", '{"curves": [{"points": [[3.4028234663852886e38, -3.4e38, 0], [0, 0, 0]]}]}')
    put(f, "mismatched_data.json", '{"curves": [{"points": [[0,0,0],[1,1,1]], "point_data": {"fa": [1]}}]}')
    put(f, "deep_nesting.json", '{"curves": [{"points": ' + "[" * 200 + "]" * 200 + "}]}")


def make_csv():
    f = "csv"
    rows = ["curve,x,y,z"]
    for i, c in enumerate(CURVES):
        rows += ["c%d,%r,%r,%r" % (i, *p) for p in c]
    put(f, "simple.csv", "\n".join(rows) + "\n")
    put(f, "crlf.csv", "\r\n".join(rows) + "\r\n")
    rows = ["curve, x, y, z, fa, speed"] + ["%d, %d, %g, %g, %g, %g" % (k // 3, k, k / 2, -k, k / 10, k * 1.5) for k in range(9)]
    put(f, "extra_columns.csv", "\n".join(rows) + "\n")
    put(f, "zero_bytes.csv", b"")
    put(f, "header_only.csv", "curve,x,y,z\n")
    put(f, "one_point.csv", "curve,x,y,z\na,1,2,3\n")
    put(f, "blank_lines.csv", "curve,x,y,z\n\na,1,2,3\n\n  \na,4,5,6\n")
    put(f, "nan_inf.csv", "curve,x,y,z\na,1,2,3\na,nan,2,3\nb,inf,-inf,0\n")
    put(f, "beyond_f32.csv", "curve,x,y,z\na,1e300,0,0\na,0,0,0\n")
    put(f, "overflow_f64.csv", "curve,x,y,z\na,1e999,0,0\n")
    put(f, "interleaved.csv", "curve,x,y,z\na,0,0,0\nb,1,1,1\na,2,2,2\n")
    put(f, "no_header.csv", "a,1,2,3\na,4,5,6\n")


# ---------------------------------------------------------------- sfh


def make_sfh(binary):
    f = "sfh"
    d = os.path.join(OUT, f)
    os.makedirs(d, exist_ok=True)
    # Version 1 (helix chains: --distance ordered), then version 3 (the
    # default arc codec; its blocks are mutated byte-wise, under CRCs).
    v1 = ["--distance", "ordered"]
    jobs = [
        ("tck/dipy_EuDX_small_25.tck", "eudx_compact.sfh", ["--tolerance", "0.5"] + v1),
        ("tck/dipy_EuDX_small_25.tck", "eudx_f32.sfh", ["--tolerance", "0.5", "--storage", "f32"] + v1),
        ("tck/dipy_EuDX_small_25.tck", "eudx_f64.sfh", ["--tolerance", "0.5", "--storage", "f64"] + v1),
        ("trk/complex.trk", "complex_trk_compact.sfh", ["--tolerance", "0.5"] + v1),
        ("trk/complex.trk", "complex_trk_f64.sfh", ["--tolerance", "0.5", "--storage", "f64"] + v1),
        ("json/simple.json", "ids_f32.sfh", ["--tolerance", "0.5", "--storage", "f32"] + v1),
        ("tck/standard.tck", "standard_compact.sfh", ["--tolerance", "0.1"] + v1),
        ("tck/empty.tck", "empty.sfh", ["--tolerance", "0.5"] + v1),
        ("tck/dipy_EuDX_small_25.tck", "eudx_v3.sfh", ["--tolerance", "0.5"]),
        ("tck/dipy_EuDX_small_25.tck", "eudx_v3_fine.sfh", ["--tolerance", "0.05"]),
        ("trk/complex.trk", "complex_trk_v3.sfh", ["--tolerance", "0.1"]),
        ("json/simple.json", "ids_refs_v3.sfh", ["--tolerance", "0.1"]),
        ("tck/empty.tck", "empty_v3.sfh", ["--tolerance", "0.1"]),
    ]
    for src, name, args in jobs:
        # Relative paths: the source file's name is stored in the header.
        subprocess.run(
            [binary, "compress", os.path.join("tests/fuzz/corpus", src), "-o", os.path.join("tests/fuzz/corpus/sfh", name)] + args,
            cwd=ROOT,
            check=True,
            stdout=subprocess.DEVNULL,
        )
    # Version 2, a development format that readers refuse by name.
    shutil.copy(os.path.join(ROOT, "tests/data/sfh/eudx_v2_dev.sfh"), os.path.join(d, "eudx_v2_dev.sfh"))
    base = open(os.path.join(d, "eudx_compact.sfh"), "rb").read()
    # Header: magic 8, version 2, flags 2, raw length 4, stored length 4, crc 4.
    put(f, "zero_bytes.sfh", b"")
    put(f, "magic_only.sfh", base[:8])
    put(f, "huge_header_length.sfh", patched(base, (16, u32(0xFFFFFFFF))))
    put(f, "huge_header_raw_length.sfh", patched(base, (12, u32(0xFFFFFFFF))))
    hlen = struct.unpack_from("<I", base, 16)[0]
    blk = 24 + hlen  # "SFHB", curves, raw length, stored length, encoding, crc
    assert base[blk : blk + 4] == b"SFHB", base[blk : blk + 4]
    put(f, "huge_block_curves.sfh", patched(base, (blk + 4, u32(0xFFFFFFFF))))
    put(f, "huge_block_raw_length.sfh", patched(base, (blk + 8, u32(0xFFFFFFFF))))
    put(f, "huge_block_stored_length.sfh", patched(base, (blk + 12, u32(0xFFFFFFFF))))
    put(f, "no_end_record.sfh", base[:-16])
    # Regression: complex_trk_f64.sfh case #1204, an f64 container whose
    # verbatim point lies beyond float32's range (which every curve reader
    # refuses) decodes as is.
    put(f, "regress_f64_point_beyond_f32.sfh", sfh_points("f64", [(0.0, 1.0, 2.0), (0.0, 1.0, -8.4e298)]))
    # Regression: eudx_f64.sfh case #2399, a chain element of curvature
    # 4.7e302 (finite, so accepted) whose samples are NaN.
    put(f, "regress_f64_chain_huge_curvature.sfh", sfh_chain("f64", [(1.0, 4.6757333089481524e302, 0.1, 0.0)]))


def sfh_points(storage, points):
    """A container (docs/container.md) of one curve stored verbatim."""
    code = "<3d" if storage == "f64" else "<3f"
    head = bytes([1]) + varint(0) + varint(len(points)) + varint(len(points))
    head += b"".join(struct.pack(code, *p) for p in points)
    return sfh_one(storage, [head, b"", b"", b"", b"", b""])


def sfh_chain(storage, elements, start=(0.0, 0.0, 0.0), tangent=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0)):
    """A container of one chain: elements are (length, curvature, torsion, twist)."""
    code = "<d" if storage == "f64" else "<f"
    head = bytes([2]) + varint(0) + varint(len(elements) + 1) + varint(len(elements))
    st = b"".join(struct.pack(code, x) for v in (start, tangent, normal) for x in v)
    el = [b"".join(struct.pack(code, e[k]) for e in elements) for k in range(4)]
    return sfh_one(storage, [head, st] + el)


def varint(v):
    out = b""
    while v >= 0x80:
        out += bytes([(v & 0x7F) | 0x80])
        v >>= 7
    return out + bytes([v])


def sfh_one(storage, streams):
    """A container of one block holding one curve record (its 6 streams)."""
    import zlib

    def deflate(b):
        z = zlib.compressobj(9, zlib.DEFLATED, -15)
        return z.compress(b) + z.flush()

    header = json.dumps(
        {
            "storage": storage,
            "tolerance": 0.5,
            "mode": "regression",
            "source": {
                "format": "json",
                "file": None,
                "vox_to_world": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
                "voxel_size": None,
                "dimensions": None,
                "units": None,
                "curve_data_names": [],
                "extra": [],
            },
            "dropped_point_data": [],
            "written_by": "tests/fuzz/make_corpus.py",
        },
        separators=(",", ":"),
    ).encode()
    raw = b"".join(struct.pack("<I", len(s)) for s in streams) + b"".join(streams)
    hz, bz = deflate(header), deflate(raw)
    out = b"\x89SFH\r\n\x1a\n" + struct.pack("<HH", 1, 0)
    out += struct.pack("<III", len(header), len(hz), zlib.crc32(hz)) + hz
    bcrc = zlib.crc32(bz)
    out += b"SFHB" + struct.pack("<III", 1, len(raw), len(bz)) + bytes([1, 0, 0, 0]) + struct.pack("<I", bcrc) + bz
    out += b"SFHE" + struct.pack("<Q", 1) + struct.pack("<I", zlib.crc32(struct.pack("<I", bcrc)))
    return out


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target", "release", "strandfit")
    if os.path.isdir(OUT):
        shutil.rmtree(OUT)
    make_tck()
    make_trk()
    make_trx()
    make_vtk()
    make_hair()
    make_json()
    make_csv()
    make_sfh(binary)
    total = 0
    for dirpath, _, files in sorted(os.walk(OUT)):
        for name in sorted(files):
            size = os.path.getsize(os.path.join(dirpath, name))
            assert size <= 20 * 1024, (name, size)
            total += size
    print("corpus: %d bytes" % total)


if __name__ == "__main__":
    main()
