#!/usr/bin/env python3
"""Make the TRX fixtures under tests/data/trx/ with trx-python (the reference
implementation of the TRX format), from tractograms already in tests/data.

    python tests/scripts/make_trx_fixtures.py [OUTDIR]   # default tests/data/trx

Written (trx-python 0.6, nibabel 5.4):
- fornix_f32_deflated.trx  dipy_fornix_tracks300.tck, float32 positions, uint32
                           offsets, zip with every entry deflated
- fornix_f16_stored.trx    the same, float16 positions, zip stored (uncompressed)
- fornix_f16_dir/          the same, float16 positions, uint64 offsets, as a folder
- complex.trx              nibabel's complex.trk (3 streamlines of 1/2/5 points),
                           float32 positions, dpv colors (3 × uint8) and fa
                           (float16), dps mean_colors (3 × float32), mean_curvature
                           (float64), mean_torsion (float32), one group `odd`
                           (streamlines 0 and 2) with a dpg value; zip stored
- complex_dir/             the same as a folder

The reference points of the fornix files are the .tck's (RAS+ mm); the header
(VOXEL_TO_RASMM, DIMENSIONS) comes from the matching .trk.
"""

import os
import shutil
import sys
import zipfile

import nibabel as nib
import numpy as np
from trx import trx_file_memmap as tmm

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "data")
FIB = os.path.join(DATA, "fibres")


def dtypes(positions, offsets, dpv=None, dps=None):
    return {"positions": positions, "offsets": offsets, "dpv": dpv or {}, "dps": dps or {}}


def write(trx, path, compression=zipfile.ZIP_STORED):
    if os.path.isdir(path):
        shutil.rmtree(path)
    elif os.path.exists(path):
        os.remove(path)
    tmm.save(trx, path, compression_standard=compression)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(DATA, "trx")
    os.makedirs(out, exist_ok=True)

    fornix = nib.streamlines.load(os.path.join(FIB, "dipy_fornix_tracks300.tck")).tractogram
    ref = os.path.join(FIB, "dipy_fornix_tracks300.trk")
    for name, pos, off, comp in [
        ("fornix_f32_deflated.trx", np.float32, np.uint32, zipfile.ZIP_DEFLATED),
        ("fornix_f16_stored.trx", np.float16, np.uint32, zipfile.ZIP_STORED),
        ("fornix_f16_dir", np.float16, np.uint64, None),
    ]:
        trx = tmm.TrxFile.from_tractogram(fornix, ref, dtype_dict=dtypes(pos, off))
        write(trx, os.path.join(out, name), comp or zipfile.ZIP_STORED)
        trx.close()

    cpath = os.path.join(FIB, "nibabel_fixtures", "complex.trk")
    complex_ = nib.streamlines.load(cpath).tractogram
    dt = dtypes(
        np.float32,
        np.uint32,
        dpv={"colors": np.uint8, "fa": np.float16},
        dps={"mean_colors": np.float32, "mean_curvature": np.float64, "mean_torsion": np.float32},
    )
    trx = tmm.TrxFile.from_tractogram(complex_, cpath, dtype_dict=dt)
    trx.groups["odd"] = np.array([0, 2], dtype=np.uint32)
    trx.data_per_group["odd"] = {"weight": np.array([[0.5]], dtype=np.float32)}
    write(trx, os.path.join(out, "complex.trx"))
    write(trx, os.path.join(out, "complex_dir"))
    trx.close()

    for name in sorted(os.listdir(out)):
        p = os.path.join(out, name)
        if os.path.isdir(p):
            size = sum(os.path.getsize(os.path.join(r, f)) for r, _, fs in os.walk(p) for f in fs)
        else:
            size = os.path.getsize(p)
        print(f"{name}\t{size}")


if __name__ == "__main__":
    main()
