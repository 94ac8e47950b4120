#!/usr/bin/env python3
"""A large synthetic tractogram: jittered replicas of the fornix.

Each replica is a random streamline of fibres/dipy_fornix_tracks300.tck moved
rigidly (a rotation of up to 3 degrees about a random axis through the
bundle's centroid, then a translation of up to +-5 mm on each axis) plus
independent Gaussian jitter (sigma 0.05 mm) on every point. Deterministic for
a given --seed. The MRtrix .tck is written directly, chunk by chunk, so
memory stays bounded whatever --count is: a text header, then float32
triplets, each streamline followed by a NaN triplet, the file ended by an
Inf triplet.

Usage: python benches/make_replicas.py --count 1000000 -o /tmp/replicas.tck
       [--source ../shared/data/fibres/dipy_fornix_tracks300.tck] [--seed 0]
       [--check]   (read the result back with nibabel and compare)
Needs numpy and nibabel.
"""
import argparse
import os

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.environ.get("STRANDFIT_DATA", os.path.join(HERE, "..", "..", "shared", "data"))
CHUNK = 20000  # replicas per write


def rotations(rng, n, max_deg):
    """n rotation matrices about uniformly random axes, angles in [0, max_deg]."""
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ang = np.radians(rng.uniform(0.0, max_deg, n))
    k = np.zeros((n, 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k -= k.transpose(0, 2, 1)
    s, c = np.sin(ang)[:, None, None], (1 - np.cos(ang))[:, None, None]
    return np.eye(3) + s * k + c * (k @ k)  # Rodrigues


def header(count):
    """The .tck header; `file: . OFFSET` points just past it."""
    body = "mrtrix tracks\ndatatype: Float32LE\nfile: . {}\ncount: {}\nEND\n"
    offset = len(body.format(0, count))
    while len(body.format(offset, count)) != offset:
        offset = len(body.format(offset, count))
    return body.format(offset, count).encode()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--count", type=int, default=1_000_000)
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--source", default=os.path.join(DATA, "fibres", "dipy_fornix_tracks300.tck"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shift", type=float, default=5.0, help="max translation per axis (mm)")
    ap.add_argument("--degrees", type=float, default=3.0, help="max rotation angle")
    ap.add_argument("--sigma", type=float, default=0.05, help="per-point jitter (mm)")
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()

    src = [np.asarray(s, np.float64) for s in nib.streamlines.load(args.source).streamlines]
    lens = np.array([len(s) for s in src])
    flat = np.concatenate(src)
    starts = np.concatenate([[0], np.cumsum(lens)[:-1]])
    centroid = flat.mean(axis=0)
    rng = np.random.default_rng(args.seed)
    sep = np.full((1, 3), np.nan, np.float32)
    points = 0
    with open(args.output + ".part", "wb") as f:
        f.write(header(args.count))
        for first in range(0, args.count, CHUNK):
            n = min(CHUNK, args.count - first)
            pick = rng.integers(0, len(src), n)
            rot = rotations(rng, n, args.degrees)
            shift = rng.uniform(-args.shift, args.shift, (n, 3))
            # per-point index into `flat` and owning replica
            counts = lens[pick]
            owner = np.repeat(np.arange(n), counts)
            within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
            p = flat[starts[pick][owner] + within] - centroid
            p = np.einsum("nij,nj->ni", rot[owner], p) + centroid + shift[owner]
            p += rng.normal(0.0, args.sigma, p.shape)
            # interleave each streamline with its NaN terminator
            out = np.empty((len(p) + n, 3), np.float32)
            ends = np.cumsum(counts + 1) - 1
            mask = np.ones(len(out), bool)
            mask[ends] = False
            out[mask] = p
            out[ends] = sep
            f.write(out.astype("<f4").tobytes())
            points += len(p)
        f.write(np.full(3, np.inf, "<f4").tobytes())
    os.replace(args.output + ".part", args.output)
    print(f"{args.output}: {args.count} streamlines, {points} points "
          f"({os.path.getsize(args.output)} bytes)")
    if args.check:
        back = nib.streamlines.load(args.output).streamlines
        assert len(back) == args.count, (len(back), args.count)
        assert sum(len(s) for s in back) == points
        print("read back with nibabel:", len(back), "streamlines, first",
              np.asarray(back[0][:2]).tolist())


if __name__ == "__main__":
    main()
