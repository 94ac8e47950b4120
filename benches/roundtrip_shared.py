#!/usr/bin/env python3
"""Round trips on the shared data set, checked with other tools.

For every curve file in the shared data folder (default ../shared/data) and
each tolerance: strandfit compress → decompress (to the same format) → read
the result back with another tool — nibabel for .tck/.trk, meshio for .vtk,
a numpy parser written here from the format description for .hair — and
measure the largest distance from an input point to the decompressed
polyline (input read by the same other tool). Prints a markdown table with
the compression ratio (input bytes / container bytes).

Usage: python benches/roundtrip_shared.py [--data ../shared/data]
       [--strandfit target/release/strandfit] [--tolerances 0.1 0.5]
Needs numpy, nibabel, meshio.
"""
import argparse
import glob
import os
import subprocess
import sys
import tempfile

import numpy as np


def read_tract(path):
    import nibabel as nib
    return [np.asarray(s, dtype=np.float64) for s in nib.streamlines.load(path).streamlines]


def read_vtk(path):
    """VTK legacy POLYDATA with classic `LINES n size`, ASCII or BINARY
    (big endian), written here from the file-format description (meshio does
    not read POLYDATA)."""
    b = open(path, "rb").read()
    lines = b.split(b"\n", 3)
    binary = lines[2].strip().upper() == b"BINARY"
    pos = len(lines[0]) + len(lines[1]) + len(lines[2]) + 3

    def next_line():
        nonlocal pos
        while True:
            e = b.index(b"\n", pos)
            line = b[pos:e].strip()
            pos = e + 1
            if line:
                return line.decode()

    def ascii_numbers(n, dtype):
        nonlocal pos
        out = []
        while len(out) < n:
            out.extend(next_line().split())
        return np.array(out[:n], dtype=dtype)

    points = conn = None
    while conn is None:
        words = next_line().split()
        if words[0] == "POINTS":
            n, t = int(words[1]), words[2]
            if binary:
                dt = ">f4" if t == "float" else ">f8"
                size = np.dtype(dt).itemsize * 3 * n
                points = np.frombuffer(b[pos:pos + size], dtype=dt).reshape(-1, 3).astype(np.float64)
                pos += size
            else:
                points = ascii_numbers(3 * n, np.float64).reshape(-1, 3)
        elif words[0] == "LINES":
            size = int(words[2])
            if binary:
                conn = np.frombuffer(b[pos:pos + 4 * size], dtype=">i4").astype(np.int64)
                pos += 4 * size
            else:
                conn = ascii_numbers(size, np.int64)
    out, k = [], 0
    while k < len(conn):
        c = conn[k]
        out.append(points[conn[k + 1:k + 1 + c]])
        k += c + 1
    return out


def read_hair(path):
    b = open(path, "rb").read()
    assert b[:4] == b"HAIR"
    n_hair, n_pts, bits, dseg = np.frombuffer(b[4:20], dtype="<u4")
    off = 128
    if bits & 1:
        segs = np.frombuffer(b[off:off + 2 * n_hair], dtype="<u2").astype(int)
        off += 2 * n_hair
    else:
        segs = np.full(n_hair, dseg, dtype=int)
    pts = np.frombuffer(b[off:off + 12 * n_pts], dtype="<f4").reshape(-1, 3).astype(np.float64)
    out, k = [], 0
    for s in segs:
        out.append(pts[k:k + s + 1])
        k += s + 1
    return out


READ = {".tck": read_tract, ".trk": read_tract, ".vtk": read_vtk, ".hair": read_hair}


def seg_dist(points, poly):
    if len(poly) == 1:
        return np.linalg.norm(points - poly[0], axis=1)
    best = np.full(len(points), np.inf)
    # chunk over segments to bound memory
    for i in range(0, len(poly) - 1, 4096):
        a = poly[i:i + 4097][:-1][None]
        d = (poly[i + 1:i + 4097] - poly[i:i + 4097][:-1])[None]
        p = points[:, None, :]
        dd = np.maximum((d * d).sum(-1), 1e-300)
        t = np.clip(((p - a) * d).sum(-1) / dd, 0.0, 1.0)
        q = a + t[..., None] * d
        best = np.minimum(best, np.sqrt(((p - q) ** 2).sum(-1)).min(axis=1))
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    ap.add_argument("--strandfit", default="target/release/strandfit")
    ap.add_argument("--tolerances", nargs="+", type=float, default=[0.1, 0.5])
    args = ap.parse_args()
    files = sorted(f for ext in READ for f in glob.glob(os.path.join(args.data, "**", "*" + ext), recursive=True))
    print("| file | T | curves | points | input bytes | .sfh bytes | ratio | elements | max dev (other tool) | ok |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    bad = 0
    for f in files:
        ext = os.path.splitext(f)[1]
        try:
            src = READ[ext](f)
        except Exception as e:  # noqa: BLE001 - report and go on
            print(f"| {os.path.relpath(f, args.data)} | — | other tool cannot read it: {e} |")
            continue
        for tol in args.tolerances:
            with tempfile.TemporaryDirectory() as d:
                sfh = os.path.join(d, "x.sfh")
                back = os.path.join(d, "back" + ext)
                r = subprocess.run([args.strandfit, "compress", f, "--tolerance", str(tol), "-o", sfh, "--json"],
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    print(f"| {os.path.relpath(f, args.data)} | {tol} | compress failed: {r.stderr.strip()[:200]} |")
                    bad = 1
                    continue
                import json
                rep = json.loads(r.stdout)
                # .hair holds at most 65,536 points a strand (uint16
                # segments): sample it by count instead of by step.
                dense = ["--points", "30000"] if ext == ".hair" else ["--step", str(tol / 50)]
                subprocess.run([args.strandfit, "decompress", sfh, *dense, "-o", back],
                               check=True, capture_output=True)
                out = READ[ext](back)
                if len(out) != len(src):
                    print(f"| {os.path.relpath(f, args.data)} | {tol} | {len(out)} curves back for {len(src)} |")
                    bad = 1
                    continue
                dev = 0.0
                for s, c in zip(src, out):
                    if len(s) == 0:
                        continue
                    dev = max(dev, float(seg_dist(s, c).max()))
                ok = dev <= tol * (1 + 1e-5) + 1e-6
                bad |= not ok
                print(f"| {os.path.relpath(f, args.data)} | {tol} | {len(src)} | {sum(len(s) for s in src)} | "
                      f"{os.path.getsize(f)} | {rep['bytes_out']} | {rep['ratio']:.2f} | {rep['elements']} | {dev:.4f} | {'yes' if ok else 'NO'} |")
    return bad


if __name__ == "__main__":
    sys.exit(main())
