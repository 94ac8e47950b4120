#!/usr/bin/env python3
"""Splits a curve file by how much its curves turn, to see where a codec's bytes go.

    python benches/split_by_turning.py IN.tck OUTDIR [--edges 3 12]

Each curve's mean turning angle per vertex (degrees, between consecutive
segments) puts it in one of the classes the edges make (default: under 3°,
3–12°, 12° and over: on the shared hair, nearly straight, wavy and curly
strands); each class is written to OUTDIR/turn_LO_HI.tck in the input's
order. Then, for example:

    python benches/codec_compare.py --data OUTDIR --files turn_0_3.tck --tolerances 0.5

Convert other formats first (`strandfit convert IN -o IN.tck`). Needs
numpy and nibabel.
"""
import argparse
import os

import nibabel as nib
import numpy as np


def mean_turn(s):
    d = np.diff(s, axis=0)
    length = np.linalg.norm(d, axis=1)
    d = d[length > 0] / length[length > 0, None]
    if len(d) < 2:
        return 0.0
    c = np.clip((d[1:] * d[:-1]).sum(1), -1.0, 1.0)
    return float(np.degrees(np.arccos(c)).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("outdir")
    ap.add_argument("--edges", nargs="+", type=float, default=[3.0, 12.0])
    args = ap.parse_args()
    curves = nib.streamlines.load(args.input).streamlines
    turn = np.array([mean_turn(np.asarray(s, dtype=np.float64)) for s in curves])
    edges = [0.0] + sorted(args.edges) + [np.inf]
    os.makedirs(args.outdir, exist_ok=True)
    for lo, hi in zip(edges[:-1], edges[1:]):
        keep = np.nonzero((turn >= lo) & (turn < hi))[0]
        name = f"turn_{lo:g}_{hi:g}.tck".replace("inf", "up")
        path = os.path.join(args.outdir, name)
        t = nib.streamlines.Tractogram([curves[i] for i in keep], affine_to_rasmm=np.eye(4))
        nib.streamlines.save(t, path)
        print(f"{path}: {len(keep)} curves, mean turn {lo:g}–{hi:g}°".replace("inf°", "…"))


if __name__ == "__main__":
    main()
