#!/usr/bin/env python3
"""strandfit's container vs DIPY's compress_streamlines, side by side.

For each tractogram and tolerance T:
  * DIPY: dipy.tracking.streamlinespeed.compress_streamlines(s, tol_error=T)
    keeps a subset of each streamline's points; its size is what tractography
    users store, float32 polylines: 12 bytes per kept point plus a 4-byte
    point count per streamline.
  * strandfit: `strandfit compress IN --tolerance T -o X.sfh` (the default
    compact storage); its size is the .sfh file.

Both outputs are measured the same way: the largest distance from an input
point to the output curve (the output as a polyline; strandfit's helices are
decompressed at a 0.01 mm step, so its polyline is within ~1e-6 mm of the
helices). That is DIPY's own error measure. strandfit additionally promises
order (each input point is matched at or after the previous one); the
symmetric Hausdorff distance is printed too.

Usage: python benches/compare_dipy.py [--strandfit target/release/strandfit]
       [--tolerances 0.1 0.5] FILE.tck|FILE.trk ...
Needs numpy, nibabel and dipy (pip install dipy).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import nibabel as nib
import numpy as np
from dipy.tracking.streamlinespeed import compress_streamlines


def seg_dist(points, poly):
    """Distance from each of `points` (n,3) to the polyline `poly` (m,3)."""
    if len(poly) == 1:
        return np.linalg.norm(points - poly[0], axis=1)
    a = poly[:-1][None, :, :]
    d = (poly[1:] - poly[:-1])[None, :, :]
    p = points[:, None, :]
    dd = np.maximum((d * d).sum(-1), 1e-300)
    t = np.clip(((p - a) * d).sum(-1) / dd, 0.0, 1.0)
    q = a + t[..., None] * d
    return np.sqrt(((p - q) ** 2).sum(-1)).min(axis=1)


def max_dev(inputs, outputs):
    """Largest input-point-to-output distance, and the symmetric Hausdorff
    (vertex to polyline both ways)."""
    dev = 0.0
    haus = 0.0
    for s, c in zip(inputs, outputs):
        s = np.asarray(s, dtype=np.float64)
        c = np.asarray(c, dtype=np.float64)
        d1 = seg_dist(s, c).max()
        d2 = seg_dist(c, s).max()
        dev = max(dev, d1)
        haus = max(haus, d1, d2)
    return dev, haus


def load(path):
    return [np.asarray(s, dtype=np.float64) for s in nib.streamlines.load(path).streamlines]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+")
    ap.add_argument("--strandfit", default="target/release/strandfit")
    ap.add_argument("--tolerances", nargs="+", type=float, default=[0.1, 0.5])
    args = ap.parse_args()
    print("| file | T (mm) | points | DIPY bytes | DIPY max dev | strandfit bytes | strandfit max dev | strandfit Hausdorff | size ratio DIPY/strandfit |")
    print("|---|---|---|---|---|---|---|---|---|")
    worst = 0
    for f in args.files:
        streams = load(f)
        npts = sum(len(s) for s in streams)
        for tol in args.tolerances:
            comp = compress_streamlines([s.astype(np.float32) for s in streams], tol_error=tol)
            dipy_bytes = sum(12 * len(c) + 4 for c in comp)
            dipy_dev, _ = max_dev(streams, comp)
            with tempfile.TemporaryDirectory() as d:
                sfh = os.path.join(d, "x.sfh")
                back = os.path.join(d, "back.tck")
                subprocess.run([args.strandfit, "compress", f, "--tolerance", str(tol), "-o", sfh],
                               check=True, capture_output=True)
                subprocess.run([args.strandfit, "decompress", sfh, "--step", "0.01", "-o", back],
                               check=True, capture_output=True)
                ours_bytes = os.path.getsize(sfh)
                ours = load(back)
            if len(ours) != len(streams):
                print(f"{f}: {len(ours)} curves back, {len(streams)} in", file=sys.stderr)
                return 1
            ours_dev, ours_haus = max_dev(streams, ours)
            ratio = dipy_bytes / ours_bytes
            print(f"| {os.path.basename(f)} | {tol} | {npts} | {dipy_bytes} | {dipy_dev:.4f} | {ours_bytes} | {ours_dev:.4f} | {ours_haus:.4f} | {ratio:.2f} |")
            if ours_dev > tol * (1 + 1e-6):
                worst = 1
                print(f"  strandfit exceeds the tolerance on {f} at {tol}", file=sys.stderr)
    return worst


if __name__ == "__main__":
    sys.exit(main())
