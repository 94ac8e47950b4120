#!/usr/bin/env python3
"""strandfit against simple lossy codecs for polylines, at the same tolerance.

For each curve file and tolerance T, one table row per method:
  strandfit    `strandfit compress FILE --tolerance T -o X.sfh` on the original
               file; bytes = size of X.sfh; decoded with `strandfit decompress
               X.sfh -o Y.tck` (defaults: as many points per curve as the input).
  dipy         dipy's compress_streamlines(float32 curves, tol_error=T) (default
               max_segment_length 10, in the file's unit); bytes = 12 per kept
               point + 4 per curve (float32 polylines with a count).
  q+zstd d1/d2 every point snapped to a grid of step 2T/sqrt(3) (round(x/s), so
               the error is <= T); per curve the first point absolute, then
               first-order deltas (d1) or second-order prediction residuals
               x_i - (2x_{i-1} - x_{i-2}) (d2); zigzag, little-endian int32
               split into 4 byte planes (the (points, 3) array row-major), then
               the curves' point counts as uint32 byte planes; all of it zstd
               level 19; bytes = the compressed size.
  dipy-lin+q   compress_streamlines at a*T, the kept points quantised as above
               (best of d1/d2) with step 2(1-a)T/sqrt(3); the smallest result
               over a in {0.25, 0.4, 0.5, 0.6, 0.75} that is within T everywhere.
Columns: bytes; ratio = input float32 bytes (12 per point + 4 per curve) /
bytes; worst two-sided error; curves within T (error <= T(1+1e-9)); compress
and decompress points/s from the whole process's wall time (strandfit; dipy:
a python process that loads the .tck, compresses and writes a .tck);
strandfit's decompress is the median of three runs, each to a new file.
Error = two-sided Hausdorff per curve, vertices to polyline both ways (every
input vertex to the output polyline, point to segment, and every output vertex
to the input polyline). Every file is read by converting it with `strandfit
convert FILE -o tmp.tck` (float32, lossless for float32 inputs) and loading
that with nibabel. Each (file, T) block ends with the best baseline (the
smallest baseline within T on every curve) and strandfit / best baseline.

--replicas N: the same table (strandfit, dipy, q+zstd; T = 0.5 unless
--tolerances) on N jittered fornix replicas from benches/make_replicas.py
(--replicas-sigma: their per-point jitter, 0.05 mm by default; at 0.1 mm
that noise sends every curve to points, 0.01 mm leaves them smooth arcs),
errors on a fixed random subset of 10,000 curves, plus the peak RSS of the
strandfit compress process.

Usage: python benches/codec_compare.py [--strandfit target/release/strandfit]
       [--data ../shared/data] [--quick] [--files F ...] [--tolerances T ...]
       [--replicas N [--replicas-path /tmp/replicas.tck] [--replicas-sigma MM]]
       [--json OUT.json]
Needs numpy, nibabel, dipy and zstandard.
"""
import argparse
import json
import os
import re
import resource
import shlex
import subprocess
import sys
import tempfile
import time

import nibabel as nib
import numpy as np
import zstandard
from dipy.tracking.streamlinespeed import compress_streamlines

HERE = os.path.dirname(os.path.abspath(__file__))
TRACT_T, FIELD_T = (0.1, 0.5), (1e-3, 1e-2)
DEFAULT_FILES = [
    "fibres/dipy_fornix_tracks300.tck", "fibres/dipy_EuDX_small_25.tck",
    "fibres/dipy_minimal_bundles/sub_1/AF_L.tck", "fibres/dipy_minimal_bundles/sub_1/CST_R.tck",
    "fibres/dipy_minimal_bundles/sub_1/CC_ForcepsMajor.tck", "hair/synthetic_hair.hair",
    "fieldlines/pfss_fieldlines.vtk"]
QUICK_FILES = DEFAULT_FILES[0:1] + DEFAULT_FILES[2:3]
LIN_A = (0.25, 0.4, 0.5, 0.6, 0.75)
SUBSET = 10_000
BLOCK = 1 << 18  # point-segment pairs per distance block (~6 MB per array)
DIPY_PROC = """import sys, numpy as np, nibabel as nib
from dipy.tracking.streamlinespeed import compress_streamlines
c = compress_streamlines(nib.streamlines.load(sys.argv[1]).streamlines,
                         tol_error=float(sys.argv[3]))
nib.streamlines.save(nib.streamlines.Tractogram(c, affine_to_rasmm=np.eye(4)), sys.argv[2])"""


class Curves:
    """Polylines as one (points, 3) float64 array and per-curve lengths."""

    def __init__(self, data, lens):
        self.data = np.asarray(data, np.float64).reshape(-1, 3)
        self.lens = np.asarray(lens, np.int64)
        self.starts = np.cumsum(self.lens) - self.lens

    @classmethod
    def from_list(cls, curves):
        lens = [len(c) for c in curves]
        return cls(np.concatenate(curves) if curves else np.zeros((0, 3)), lens)

    def __len__(self):
        return len(self.lens)

    def __getitem__(self, i):
        return self.data[self.starts[i]:self.starts[i] + self.lens[i]]

    def f32_list(self):
        return np.split(self.data.astype(np.float32), self.starts[1:])

    def index_in_curve(self):
        return np.arange(len(self.data)) - np.repeat(self.starts, self.lens)


def load_tck(path):
    sl = nib.streamlines.load(path).streamlines
    return Curves(sl.get_data(), sl._lengths)


# ---------------------------------------------------------------- distances
def directed(p, q):
    """Largest distance from the points p (n, 3) to the polyline q (m, 3)."""
    if len(q) == 1:
        return float(np.sqrt(((p - q[0]) ** 2).sum(1).max()))
    a, d = q[:-1], q[1:] - q[:-1]
    dd = np.maximum((d * d).sum(1), 1e-300)
    worst, rows = 0.0, max(1, BLOCK // len(a))
    for i in range(0, len(p), rows):
        x = p[i:i + rows, None, :] - a  # (rows, m-1, 3)
        t = np.clip((x * d).sum(-1) / dd, 0.0, 1.0)
        r = x - t[..., None] * d
        worst = max(worst, float((r * r).sum(-1).min(1).max()))
    return float(np.sqrt(worst))


def two_sided(a, b):
    """(input vertices -> output polyline, output vertices -> input polyline)."""
    if len(a) == 0 or len(b) == 0:
        return (0.0, 0.0) if len(a) == len(b) else (float("inf"), float("inf"))
    return directed(a, b), directed(b, a)


def errors(inp, out, subset):
    """Per-curve Hausdorff distance; the one-sided worsts as attributes."""
    d = np.array([two_sided(inp[i], out[i]) for i in subset]).reshape(-1, 2)
    err = d.max(1)
    return err, (float(d[:, 0].max(initial=0)), float(d[:, 1].max(initial=0)))


# ---------------------------------------------------------------- baselines
def quantise(curves, step):
    return np.round(curves.data / step).astype(np.int64)


def byte_planes(v):
    return np.ascontiguousarray(v.astype("<u4").view(np.uint8).reshape(-1, 4).T).tobytes()


def qzstd_bytes(k, curves, order):
    """Size of the delta (order 1) or second-order (order 2) zstd stream."""
    j = curves.index_in_curve()
    r = k.copy()
    r[1:] -= k[:-1]
    r[j == 0] = k[j == 0]
    if order == 2:
        r2 = r.copy()
        r2[1:] -= r[:-1]
        r2[j <= 1] = r[j <= 1]
        r = r2
    z = (r << 1) ^ (r >> 63)  # zigzag
    if len(z) and z.max() >= 1 << 32:
        raise ValueError("grid index too large for int32")
    raw = byte_planes(z.reshape(-1)) + byte_planes(curves.lens)
    return len(zstandard.ZstdCompressor(level=19).compress(raw))


def dipy_compress(curves, tol):
    return Curves.from_list([np.asarray(c, np.float64)
                             for c in compress_streamlines(curves.f32_list(), tol_error=tol)])


# ---------------------------------------------------------------- processes
def timed(cmd, rss=False):
    """Run cmd; (wall seconds, peak RSS in KiB or None, stderr)."""
    tv = os.path.exists("/usr/bin/time") and rss
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        full = ["/usr/bin/time", "-v", "-o", tf.name] + cmd if tv else cmd
        t0 = time.perf_counter()
        p = subprocess.run(full, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise RuntimeError(f"{shlex.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
        peak = None
        if tv:
            m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", tf.read())
            peak = int(m.group(1)) if m else None
        elif rss:  # largest of all children so far: an upper bound
            peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return wall, peak, p.stderr.strip()


def pps(n, sec):
    return f"{n / sec:.3g}" if sec else "-"


# ---------------------------------------------------------------- the table
def run_block(args, path, inp, tol, methods, subset, tmp):
    """All methods on one (file, T); returns the rows."""
    npts, ncur = len(inp.data), len(inp)
    raw = 12 * npts + 4 * ncur
    rows = []

    def row(method, nbytes, errs, comp_s=None, decomp_s=None, note=""):
        err, (in_out, out_in) = errs
        within = int((err <= tol * (1 + 1e-9)).sum())
        r = dict(file=os.path.basename(path), path=path, tolerance=tol, method=method,
                 bytes=nbytes, ratio=raw / nbytes, worst=float(err.max(initial=0)),
                 in_to_out=in_out, out_to_in=out_in, within=within, checked=len(subset),
                 curves=ncur, points=npts, compress_pps=npts / comp_s if comp_s else None,
                 decompress_pps=npts / decomp_s if decomp_s else None, note=note)
        rows.append(r)
        print(f"| {method:12} | {nbytes:>10} | {r['ratio']:8.2f} | {r['worst']:10.4g} | "
              f"{within:>6}/{len(subset):<6} | {pps(npts, comp_s):>9} | "
              f"{pps(npts, decomp_s):>9} | {note}", flush=True)
        return r

    what = "all" if len(subset) == ncur else f"a fixed random subset of {len(subset)}"
    print(f"\n### {os.path.basename(path)}  T = {tol:g}  ({ncur} curves, {npts} points, "
          f"{raw} input float32 bytes; errors on {what} curves)")
    print("| method       |      bytes |    ratio |  worst err | within T      "
          "| comp pt/s | dec pt/s  | note")
    print("|---|---:|---:|---:|---|---:|---:|---|")
    if "strandfit" in methods:
        sfh, out = os.path.join(tmp, "x.sfh"), os.path.join(tmp, "y.tck")
        try:
            cs, peak, log = timed([args.strandfit, "compress", path, "--tolerance", repr(tol),
                                   "-o", sfh] + shlex.split(args.compress_args), rss=True)
            # Decompress takes a quarter of a second on 100,000 replicas, where
            # one timing is noisy: the median of three, each to a new file.
            times = []
            for _ in range(3):
                if os.path.exists(out):
                    os.remove(out)
                times.append(timed([args.strandfit, "decompress", sfh, "-o", out])[0])
            ds = sorted(times)[1]
            dec = load_tck(out)
            if len(dec) != ncur:
                raise RuntimeError(f"decompress gave {len(dec)} curves, the input has {ncur}")
            errs = errors(inp, dec, subset)
            note = f"in->out {errs[1][0]:.4g}, out->in {errs[1][1]:.4g}"
            note += f"; peak RSS {peak / 1024:.0f} MiB" if peak else ""
            r = row("strandfit", os.path.getsize(sfh), errs, cs, ds, note)
            r["peak_rss_kib"], r["log"] = peak, log.splitlines()[-1] if log else ""
        except RuntimeError as e:
            print(f"!!! STRANDFIT FAILURE on {path} at T={tol:g}: {e}", flush=True)
            rows.append(dict(file=os.path.basename(path), path=path, tolerance=tol,
                             method="strandfit", failure=str(e)))
    if "dipy" in methods:
        comp = dipy_compress(inp, tol)
        cs, _, _ = timed([sys.executable, "-c", DIPY_PROC, os.path.join(tmp, "in.tck"),
                          os.path.join(tmp, "dipy.tck"), repr(tol)])
        row("dipy", 12 * len(comp.data) + 4 * len(comp), errors(inp, comp, subset), cs)
    if "q" in methods:
        step = 2 * tol / np.sqrt(3)
        k = quantise(inp, step)
        err = errors(inp, Curves(k * step, inp.lens), subset)  # d1 and d2 decode alike
        for order in (1, 2):
            row(f"q+zstd d{order}", qzstd_bytes(k, inp, order), err)
    if "lin" in methods:
        cands = []
        for a in LIN_A:
            comp = dipy_compress(inp, a * tol)
            step = 2 * (1 - a) * tol / np.sqrt(3)
            k = quantise(comp, step)
            b1, b2 = qzstd_bytes(k, comp, 1), qzstd_bytes(k, comp, 2)
            cands.append((min(b1, b2), a, 1 if b1 <= b2 else 2, Curves(k * step, comp.lens)))
        for nbytes, a, order, dec in sorted(cands, key=lambda c: c[0]):
            err = errors(inp, dec, subset)
            if (err[0] <= tol * (1 + 1e-9)).all():
                row("dipy-lin+q", nbytes, err, note=f"a={a} d{order}; "
                    + " ".join(f"{c[1]}:{c[0]}" for c in cands))
                break
        else:
            print("| dipy-lin+q   | no a within T on every curve")
    ok = [r for r in rows if r["method"] != "strandfit" and r.get("bytes")
          and r["within"] == r["checked"]]
    sf = [r for r in rows if r["method"] == "strandfit" and r.get("bytes")]
    if ok:
        best = min(ok, key=lambda r: r["bytes"])
        line = f"best baseline: {best['method']} {best['bytes']} B"
        if sf:
            line += (f"; strandfit {sf[0]['bytes']} B = {sf[0]['bytes'] / best['bytes']:.3f} x best"
                     f"; strandfit within T on every curve: "
                     f"{'yes' if sf[0]['within'] == sf[0]['checked'] else 'NO'}"
                     f" ({sf[0]['within']}/{sf[0]['checked']})")
        elif "strandfit" in methods:
            line += "; strandfit FAILED"
        print(line, flush=True)
        rows.append(dict(file=os.path.basename(path), path=path, tolerance=tol, method="summary",
                         best_baseline=best["method"], best_bytes=best["bytes"],
                         strandfit_over_best=sf[0]["bytes"] / best["bytes"] if sf else None,
                         strandfit_all_within=bool(sf) and sf[0]["within"] == sf[0]["checked"]))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--strandfit",
                    default=os.path.join(HERE, "..", "target", "release", "strandfit"))
    ap.add_argument("--data", default=os.environ.get(
        "STRANDFIT_DATA", os.path.join(HERE, "..", "..", "shared", "data")))
    ap.add_argument("--files", nargs="+", help="curve files (relative to --data or absolute)")
    ap.add_argument("--tolerances", nargs="+", type=float,
                    help=f"default {TRACT_T}, {FIELD_T} for .vtk field lines")
    ap.add_argument("--quick", action="store_true", help="fornix and AF_L only")
    ap.add_argument("--replicas", type=int, metavar="N", help="N jittered fornix replicas")
    ap.add_argument("--replicas-path", help="where to keep them (reused if it exists)")
    ap.add_argument("--replicas-sigma", type=float, default=0.05,
                    help="their per-point Gaussian jitter (mm; make_replicas.py --sigma)")
    ap.add_argument("--compress-args", default="", help="extra `strandfit compress` options")
    ap.add_argument("--json", help="write all rows here")
    args = ap.parse_args()
    sys.stdout.reconfigure(line_buffering=True)
    args.strandfit = os.path.abspath(args.strandfit)
    if not os.path.exists(args.strandfit):
        sys.exit(f"{args.strandfit} missing: cargo build --release")

    t_start, rows = time.perf_counter(), []
    with tempfile.TemporaryDirectory(prefix="codec_compare.") as tmp:
        if args.replicas:
            path = args.replicas_path or os.path.join(
                tmp, f"replicas_{args.replicas}_{args.replicas_sigma}.tck")
            if not os.path.exists(path):
                t0 = time.perf_counter()
                subprocess.run([sys.executable, os.path.join(HERE, "make_replicas.py"),
                                "--count", str(args.replicas), "--sigma", str(args.replicas_sigma),
                                "-o", path], check=True)
                print(f"generated in {time.perf_counter() - t0:.1f} s")
            jobs = [(path, args.tolerances or [0.5], ("strandfit", "dipy", "q"))]
        else:
            files = args.files or (QUICK_FILES if args.quick else DEFAULT_FILES)
            jobs = []
            for f in files:
                path = f if os.path.isabs(f) or os.path.exists(f) else os.path.join(args.data, f)
                path = os.path.normpath(path)  # the container records the source path
                tols = args.tolerances or (FIELD_T if path.endswith(".vtk") else TRACT_T)
                jobs.append((path, tols, ("strandfit", "dipy", "q", "lin")))
        for path, tols, methods in jobs:
            t0 = time.perf_counter()
            conv = os.path.join(tmp, "in.tck")
            subprocess.run([args.strandfit, "convert", path, "-o", conv], check=True,
                           capture_output=True)
            inp = load_tck(conv)
            subset = np.arange(len(inp))
            if len(inp) > SUBSET and args.replicas:
                subset = np.sort(np.random.default_rng(0).choice(len(inp), SUBSET, replace=False))
            for tol in tols:
                rows += run_block(args, path, inp, tol, methods, subset, tmp)
            print(f"({os.path.basename(path)}: {time.perf_counter() - t0:.1f} s)", flush=True)
    print(f"\ntotal {time.perf_counter() - t_start:.1f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    failures = [r for r in rows if "failure" in r]
    if failures:
        print(f"!!! {len(failures)} strandfit failure(s)")
        sys.exit(1)


if __name__ == "__main__":
    main()
