#!/usr/bin/env python3
"""Bundles resampled to a fixed number of points per streamline, as DIPY's
`set_number_of_points` leaves them (the shared AF_L, CST_R and CC have 20):
the codec's hardest tractography class at 0.1 mm, points curves at steps of
several millimetres.

Writes to OUTDIR streamlines of --points points (equal arc-length steps,
numpy.interp):
  fornix50.tck          50 fornix streamlines of ../shared/data (seed 5)
  bundle{0,1,2}.tck     50 consecutive streamlines of each of the first three
                        bundles of benches/make_unseen.py's bundles.tck
                        (a probabilistic tracker's: less alike than a real
                        bundle's after clustering)
  heart50.tck           the first 50 of make_unseen.py's heart.tck
  tracked.tck           all 3,000 of bundles.tck's streamlines (a file of
                        many blocks' curves, as a whole tractogram
                        resampled for clustering would be)

    python benches/make_unseen.py -o /tmp/unseen
    python benches/resample_bundles.py /tmp/unseen /tmp/r20
    python benches/codec_compare.py --data /tmp/r20 --files bundle0.tck --tolerances 0.1 0.5

numpy + nibabel only; deterministic.
"""
import argparse
import os

import nibabel as nib
import numpy as np


def set_number_of_points(s, n):
    s = np.asarray(s, float)
    arc = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(s, axis=0), axis=1))])
    t = np.linspace(0, arc[-1], n)
    return np.stack([np.interp(t, arc, s[:, a]) for a in range(3)], -1).astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("unseen", help="folder make_unseen.py wrote")
    ap.add_argument("outdir")
    ap.add_argument("--points", type=int, default=20)
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    args = ap.parse_args()
    os.makedirs(args.outdir, exist_ok=True)

    def save(name, curves):
        path = os.path.join(args.outdir, name)
        nib.streamlines.save(nib.streamlines.Tractogram(curves, affine_to_rasmm=np.eye(4)), path)
        print(f"{path}: {len(curves)} curves of {args.points} points")

    n = args.points
    fornix = nib.streamlines.load(os.path.join(args.data, "fibres", "dipy_fornix_tracks300.tck")).streamlines
    pick = np.random.default_rng(5).choice(len(fornix), 50, replace=False)
    save("fornix50.tck", [set_number_of_points(fornix[i], n) for i in pick])
    bundles = nib.streamlines.load(os.path.join(args.unseen, "bundles.tck")).streamlines
    for k in range(3):
        save(f"bundle{k}.tck", [set_number_of_points(bundles[k * 250 + i], n) for i in range(50)])
    heart = nib.streamlines.load(os.path.join(args.unseen, "heart.tck")).streamlines
    save("heart50.tck", [set_number_of_points(heart[i], n) for i in range(50)])
    save("tracked.tck", [set_number_of_points(s, n) for s in bundles])


if __name__ == "__main__":
    main()
