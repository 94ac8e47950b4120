#!/usr/bin/env python3
"""Check .tck/.trk files written by strandfit with nibabel.

Each WRITTEN file is loaded with nibabel and compared with its REFERENCE
(the file it was converted from, also loaded with nibabel): same number of
streamlines and points, maximum coordinate deviation in RAS+ mm, and, when
both carry them, per-point and per-streamline values. Prints one line per
pair; exits 1 if any deviation exceeds --tol.

    python nibabel_roundtrip.py WRITTEN REFERENCE [WRITTEN REFERENCE ...]
    python nibabel_roundtrip.py --manifest manifest.txt   # "written<TAB>reference" lines

The manifest comes from
    STRANDFIT_TRACT_OUT=/tmp/tract cargo test --test io_tractography conversions_for_an_external_check
Not part of `cargo test`: it needs python with nibabel.
"""

import argparse
import sys
import warnings

import numpy as np
import nibabel as nib


def load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return nib.streamlines.load(path).tractogram


def compare(written, reference):
    a, b = load(written), load(reference)
    if len(a.streamlines) != len(b.streamlines):
        return np.inf, f"{len(a.streamlines)} vs {len(b.streamlines)} streamlines"
    dev = 0.0
    for i, (p, q) in enumerate(zip(a.streamlines, b.streamlines)):
        if p.shape != q.shape:
            return np.inf, f"streamline {i}: {p.shape} vs {q.shape} points"
        if len(p):
            dev = max(dev, float(np.max(np.abs(p.astype(np.float64) - q))))
    note = f"{len(a.streamlines)} streamlines"
    data_dev = 0.0
    for kind in ("data_per_point", "data_per_streamline"):
        da, db = getattr(a, kind), getattr(b, kind)
        shared = sorted(set(da.keys()) & set(db.keys()))
        for k in shared:
            x = np.concatenate([np.asarray(v).ravel() for v in da[k]]) if len(da[k]) else np.zeros(0)
            y = np.concatenate([np.asarray(v).ravel() for v in db[k]]) if len(db[k]) else np.zeros(0)
            if x.shape != y.shape:
                return np.inf, f"{kind} {k}: shapes {x.shape} vs {y.shape}"
            if x.size:
                data_dev = max(data_dev, float(np.max(np.abs(x - y))))
        if shared:
            note += f", {kind} {','.join(shared)}"
    if data_dev:
        note += f" (max value deviation {data_dev:.3g})"
    return max(dev, data_dev), note


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*", help="WRITTEN REFERENCE pairs")
    ap.add_argument("--manifest", help="file of 'written<TAB>reference' lines")
    ap.add_argument("--tol", type=float, default=1e-4, help="largest accepted deviation (mm)")
    args = ap.parse_args()
    pairs = list(zip(args.files[::2], args.files[1::2]))
    if len(args.files) % 2:
        ap.error("files come in WRITTEN REFERENCE pairs")
    if args.manifest:
        with open(args.manifest) as f:
            pairs += [tuple(line.rstrip("\n").split("\t")) for line in f if line.strip()]
    worst = 0.0
    failed = False
    for written, reference in pairs:
        try:
            dev, note = compare(written, reference)
        except Exception as e:  # a file nibabel cannot read is a failure to report
            dev, note = np.inf, f"nibabel error: {e}"
        bad = not dev <= args.tol
        failed |= bad
        worst = max(worst, dev)
        print(f"{'FAIL' if bad else 'ok  '} max |dev| {dev:.3e} mm  {written}  <- {reference}  [{note}]")
    print(f"{len(pairs)} pairs, worst deviation {worst:.3e} mm, tolerance {args.tol:g}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
