"""strandfit.dask on a LocalCluster of two worker processes: the outputs are
byte for byte the command line's (compress per file; compress then split for
shards), and merge joins the shards into the whole file's container."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import strandfit
import strandfit.dask

distributed = pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[2]
FIBRES = ROOT / "tests" / "data" / "fibres"
BIN = os.environ.get("STRANDFIT_BIN", str(ROOT / "target" / "debug" / "strandfit"))


def cli(*args):
    subprocess.run([BIN, *map(str, args)], check=True, capture_output=True)


def write_tck(path, curves):
    """An MRtrix .tck (float32 LE, NaN between curves, Inf at the end)."""
    head = "mrtrix tracks\ndatatype: Float32LE\ncount: {:010d}\nfile: . {:d}\nEND\n"
    offset = len(head.format(0, 0)) + 3
    text = head.format(len(curves), offset).encode()
    text += b"\0" * (offset - len(text))
    sep = np.full((1, 3), np.nan, dtype="<f4")
    body = [np.concatenate([c.astype("<f4"), sep]) for c in curves]
    data = np.concatenate(body + [np.full((1, 3), np.inf, dtype="<f4")])
    Path(path).write_bytes(text + data.tobytes())


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as c:
        yield c


def test_compress_files_on_two_workers_writes_the_cli_bytes(tmp_path, client):
    srcs = [FIBRES / "dipy_fornix_tracks300.tck", FIBRES / "dipy_EuDX_small_25.trk"]
    srcs += sorted((FIBRES / "dipy_minimal_bundles" / "sub_1").glob("*.tck"))
    reports = strandfit.dask.compress_files(srcs, tmp_path / "dask", 0.3, client=client)
    assert [r["input"] for r in reports] == [str(s) for s in srcs]
    workers = client.run(os.getpid)
    assert len(set(workers.values())) == 2
    for src, r in zip(srcs, reports):
        out = tmp_path / "cli" / (src.stem + ".sfh")
        out.parent.mkdir(exist_ok=True)
        cli("compress", src, "--tolerance", "0.3", "-o", out)
        assert Path(r["output"]).read_bytes() == out.read_bytes(), src.name
        assert r["bytes_out"] == out.stat().st_size


def test_compress_sharded_writes_the_shards_of_compress_then_split(tmp_path, client):
    rng = np.random.default_rng(4)
    curves = []
    for k in range(9000):
        m = int(rng.integers(2, 14))
        t = np.arange(m, dtype=np.float64)
        o = rng.uniform(-60, 60, 3)
        curves.append(o + np.stack([t, np.sin(0.4 * t + k), 0.05 * t * t], axis=1))
    src = tmp_path / "big.tck"
    write_tck(src, curves)
    reports = strandfit.dask.compress_sharded(src, tmp_path / "dask", 5000, tolerance=0.25, client=client)
    # Rounded down to whole blocks: 4096, 4096, 808.
    assert [(r["first"], r["curve_count"]) for r in reports] == [(0, 4096), (4096, 4096), (8192, 808)]
    whole = tmp_path / "whole.sfh"
    cli("compress", src, "--tolerance", "0.25", "-o", whole)
    cli("split", whole, "--curves-per-shard", "4096", "-o", tmp_path / "split")
    mine = sorted((tmp_path / "dask").glob("*.sfh"))
    theirs = sorted((tmp_path / "split").glob("*.sfh"))
    assert len(mine) == len(theirs) == 3
    for a, b in zip(mine, theirs):
        assert a.read_bytes() == b.read_bytes(), a.name
    merged = tmp_path / "merged.sfh"
    cli("merge", *mine, "-o", merged)
    assert merged.read_bytes() == whole.read_bytes()


def test_sharding_rounds_to_whole_blocks_like_split_and_clears_old_shards(tmp_path):
    rng = np.random.default_rng(8)
    curves = [o + np.cumsum(rng.normal(0, 1, (int(rng.integers(2, 9)), 3)), axis=0) for o in rng.uniform(-9, 9, (5000, 3))]
    src = tmp_path / "five.tck"
    write_tck(src, curves)
    out = tmp_path / "dask"
    strandfit.dask.compress_sharded(src, out, 9000, tolerance=0.3)  # one shard
    reports = strandfit.dask.compress_sharded(src, out, 5000, tolerance=0.3)
    assert [r["curve_count"] for r in reports] == [4096, 904]
    whole = tmp_path / "whole.sfh"
    cli("compress", src, "--tolerance", "0.3", "-o", whole)
    cli("split", whole, "--curves-per-shard", "5000", "-o", tmp_path / "split")
    mine = sorted(out.glob("*.sfh"))
    theirs = sorted((tmp_path / "split").glob("*.sfh"))
    assert [p.read_bytes() for p in mine] == [p.read_bytes() for p in theirs]
