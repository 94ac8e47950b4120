#!/usr/bin/env python3
"""One long curve and the same points as many curves: for checking that
`strandfit compress` takes time linear in curve length.

The curves of the input (say, `benches/make_replicas.py`'s jittered fornix
replicas) are joined end to end until there are --points points, every
other one reversed and each moved so that it starts where the one before
ended: the joined curve turns back and forth, so its coordinates stay within
a few metres of the first point (joined without the reversals, 1,000 replicas
drift hundreds of metres away, where `f32` output eats into the tolerance).
The result is written twice: as one curve (`OUT/long1.tck`) and cut into
--pieces curves of equal length (`OUT/longN.tck`, N = --pieces), the same
points in the same order.

Usage: python benches/make_long_curve.py --input /tmp/r100k.tck -o /tmp/long
       [--points 1000000] [--pieces 1000]
then, for each tolerance, time `strandfit compress OUT/long1.tck -o a.sfh
--tolerance T` against the same for `OUT/long1000.tck` (whole process).
Needs numpy and nibabel.
"""
import argparse
import os

import nibabel as nib
import numpy as np


def joined(streamlines, points):
    """The curves joined end to end (every other one reversed), cut at `points`."""
    parts, end, n = [], None, 0
    for i, c in enumerate(streamlines):
        c = np.asarray(c, np.float64)
        if len(c) < 2:
            continue
        if i % 2:
            c = c[::-1]
        if end is None:
            end = c[0]
        c = c - c[0] + end
        part = c if not parts else c[1:]
        parts.append(part)
        end = c[-1]
        n += len(part)
        if n >= points:
            break
    if n < points:
        raise SystemExit(f"the input has only {n} points to join, fewer than --points {points}")
    return np.concatenate(parts)[:points]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--input", required=True, help="a curve file nibabel reads (.tck, .trk)")
    ap.add_argument("-o", "--output", required=True, help="folder to write into")
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--pieces", type=int, default=1000)
    a = ap.parse_args()
    if a.points < 2 or a.pieces < 1 or a.points % a.pieces:
        raise SystemExit("--points must be at least 2 and a multiple of --pieces")
    p = joined(nib.streamlines.load(a.input).streamlines, a.points).astype(np.float32)
    os.makedirs(a.output, exist_ok=True)
    eye = np.eye(4)
    one = os.path.join(a.output, "long1.tck")
    many = os.path.join(a.output, f"long{a.pieces}.tck")
    nib.streamlines.save(nib.streamlines.Tractogram([p], affine_to_rasmm=eye), one)
    nib.streamlines.save(nib.streamlines.Tractogram(np.split(p, a.pieces), affine_to_rasmm=eye), many)
    print(f"{one}: 1 curve, {len(p)} points; {many}: {a.pieces} curves; "
          f"largest |coordinate| {np.abs(p).max():.1f}")


if __name__ == "__main__":
    main()
