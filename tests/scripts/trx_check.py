#!/usr/bin/env python3
"""Check .trx files written by strandfit with trx-python (the reference
implementation).

Each WRITTEN .trx is loaded with trx-python and compared with its REFERENCE
(the file it was converted from: .tck/.trk loaded with nibabel, .trx with
trx-python): number of streamlines and points, header (VOXEL_TO_RASMM,
DIMENSIONS), maximum coordinate deviation in RAS+ mm, and per-vertex and
per-streamline values matched by name (a multi-component array `x` against
the reference's `x`). Prints one line per pair; exits 1 if a count differs or
a deviation exceeds --tol.

    python trx_check.py WRITTEN REFERENCE [WRITTEN REFERENCE ...]
    python trx_check.py --manifest manifest.txt   # "written<TAB>reference" lines

The manifest comes from
    STRANDFIT_TRX_OUT=/tmp/trx cargo test --test io_trx conversions_for_an_external_check
Not part of `cargo test`: it needs python with trx-python and nibabel.
"""

import argparse
import sys
import warnings

import numpy as np
import nibabel as nib
from trx import trx_file_memmap as tmm


def load_ref(path):
    """(streamlines list, dpv dict name->(N,k), dps dict name->(S,k), affine, dims)"""
    if path.rstrip("/").endswith(".trx") or not path.endswith((".tck", ".trk")):
        t = tmm.load(path)
        sl = [np.asarray(s, dtype=np.float64) for s in t.streamlines]
        dpv = {k: np.asarray(v._data, dtype=np.float64).reshape(len(v._data), -1)
               for k, v in t.data_per_vertex.items()}
        dps = {k: np.asarray(v, dtype=np.float64).reshape(len(v), -1)
               for k, v in t.data_per_streamline.items()}
        return sl, dpv, dps, np.asarray(t.header["VOXEL_TO_RASMM"]), list(t.header["DIMENSIONS"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = nib.streamlines.load(path)
    tg = f.tractogram
    sl = [np.asarray(s, dtype=np.float64) for s in tg.streamlines]
    dpv = {k: np.asarray(v._data, dtype=np.float64).reshape(len(v._data), -1)
           for k, v in tg.data_per_point.items()}
    dps = {k: np.asarray(v, dtype=np.float64).reshape(len(v), -1)
           for k, v in tg.data_per_streamline.items()}
    dims = list(f.header.get("dimensions", [])) if hasattr(f.header, "get") else []
    return sl, dpv, dps, np.asarray(f.affine), [int(d) for d in dims]


def check(written, reference, tol):
    t = tmm.load(written)
    sl = [np.asarray(s, dtype=np.float64) for s in t.streamlines]
    rsl, rdpv, rdps, raff, rdims = load_ref(reference)
    ok = True
    msgs = []
    if len(sl) != len(rsl) or any(len(a) != len(b) for a, b in zip(sl, rsl)):
        return False, f"FAIL {written}: {len(sl)} streamlines vs {len(rsl)} (or point counts differ)"
    dev = max((np.abs(a - b).max() for a, b in zip(sl, rsl) if len(a)), default=0.0)
    ok &= dev <= tol
    aff = np.asarray(t.header["VOXEL_TO_RASMM"])
    if reference.endswith(".tck"):
        pass  # a .tck has no affine: the writer uses identity
    elif not np.allclose(aff, raff):
        ok = False
        msgs.append("affine differs")
    if rdims and list(t.header["DIMENSIONS"]) != rdims:
        ok = False
        msgs.append(f"DIMENSIONS {t.header['DIMENSIONS']} vs {rdims}")
    vdev = 0.0
    names = []
    for kind, mine, ref in [
        ("dpv", {k: np.asarray(v._data, dtype=np.float64).reshape(len(v._data), -1)
                 for k, v in t.data_per_vertex.items()}, rdpv),
        ("dps", {k: np.asarray(v, dtype=np.float64).reshape(len(v), -1)
                 for k, v in t.data_per_streamline.items()}, rdps),
    ]:
        # Our writer splits a k-component array of a non-TRX source into x_0..x_k-1.
        for k, r in ref.items():
            if k in mine:
                m = mine[k]
            elif all(f"{k}_{c}" in mine for c in range(r.shape[1])):
                m = np.hstack([mine[f"{k}_{c}"] for c in range(r.shape[1])])
            else:
                ok = False
                msgs.append(f"{kind} {k} missing")
                continue
            if m.shape != r.shape:
                ok = False
                msgs.append(f"{kind} {k} shape {m.shape} vs {r.shape}")
                continue
            vdev = max(vdev, float(np.abs(m - r).max()) if m.size else 0.0)
            names.append(f"{kind}/{k}")
    ok &= vdev <= tol
    dt = {"positions": str(t.streamlines._data.dtype), "offsets": str(t.streamlines._offsets.dtype)}
    line = (f"{'ok' if ok else 'FAIL'} {written}: {len(sl)} streamlines, "
            f"{sum(len(s) for s in sl)} points, max |Δ| {dev:.3g} mm, data {names} max |Δ| {vdev:.3g}, "
            f"dtypes {dt} {' '.join(msgs)}")
    t.close()
    return ok, line


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("pairs", nargs="*")
    ap.add_argument("--manifest")
    ap.add_argument("--tol", type=float, default=1e-6)
    a = ap.parse_args()
    pairs = list(zip(a.pairs[::2], a.pairs[1::2]))
    if a.manifest:
        for line in open(a.manifest):
            if line.strip():
                w, r = line.rstrip("\n").split("\t")
                pairs.append((w, r))
    bad = 0
    for w, r in pairs:
        ok, line = check(w, r, a.tol)
        print(line)
        bad += not ok
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
