"""The Python package against the command line and against an independent
two-sided distance: round trips within the tolerance, the CLI's bytes, lazy
slicing equal to the full decode, bad input as ValueError/OSError naming the
curve, and no memory growth over repeated calls."""

import os
import resource
import subprocess
from pathlib import Path

import numpy as np
import pytest

import strandfit

ROOT = Path(__file__).resolve().parents[2]
FORNIX = ROOT / "tests" / "data" / "fibres" / "dipy_fornix_tracks300.tck"
BIN = os.environ.get("STRANDFIT_BIN", str(ROOT / "target" / "debug" / "strandfit"))


def seg_dist(p, a, b):
    """Distances from points p (n, 3) to every segment a[j]-b[j] (m, 3): (n, m)."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    w = p[:, None, :] - a[None, :, :]
    t = np.where(dd > 0, np.einsum("nmj,mj->nm", w, d) / np.where(dd > 0, dd, 1), 0)
    t = np.clip(t, 0, 1)
    x = w - t[:, :, None] * d[None, :, :]
    return np.sqrt(np.einsum("nmj,nmj->nm", x, x))


def two_sided(u, v):
    """Vertex-to-segment Hausdorff distance of two polylines (numpy, brute force)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)

    def one(p, q):
        if len(q) == 1:
            return np.linalg.norm(p - q[0], axis=1).max()
        return seg_dist(p, q[:-1], q[1:]).min(axis=1).max()

    return max(one(u, v), one(v, u))


def random_curves(rng, n):
    curves = []
    for k in range(n):
        m = int(rng.integers(2, 60))
        s = np.linspace(0, rng.uniform(5, 40), m)
        c = np.stack(
            [s, 2 * np.sin(0.3 * s + k), np.cos(0.2 * s)], axis=1
        ) + rng.normal(0, 0.02, (m, 3)) + rng.uniform(-50, 50, 3)
        curves.append(c)
    return curves


def pack(curves):
    offsets = np.concatenate([[0], np.cumsum([len(c) for c in curves])]).astype(np.int64)
    return np.concatenate(curves), offsets


@pytest.mark.parametrize("tolerance", [0.05, 0.5])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_round_trip_is_within_the_tolerance_both_ways(tolerance, dtype):
    rng = np.random.default_rng(3)
    curves = random_curves(rng, 40) + [np.zeros((0, 3)), np.ones((1, 3))]
    positions, offsets = pack(curves)
    data = strandfit.compress_arrays(positions.astype(dtype), offsets, tolerance=tolerance)
    assert isinstance(data, bytes) and data[:4] == b"\x89SFH"
    back, back_offsets = strandfit.decompress_arrays(data)
    assert back.dtype == np.float32 and back.shape[1] == 3
    assert back_offsets.dtype == np.int64 and len(back_offsets) == len(offsets)
    for i, c in enumerate(curves):
        out = back[back_offsets[i] : back_offsets[i + 1]]
        if len(c) == 0:
            assert len(out) == 0
            continue
        inp = c.astype(dtype).astype(np.float64)
        assert two_sided(inp, out) <= tolerance, i
    # Smaller than the float32 points.
    assert len(data) < positions.astype(np.float32).nbytes / 4


def test_streamline_lists_and_array_sequences():
    rng = np.random.default_rng(5)
    curves = random_curves(rng, 12)
    data = strandfit.compress_streamlines(curves, tolerance=0.2)
    back = strandfit.decompress_streamlines(data)
    assert len(back) == 12
    assert all(two_sided(c, b) <= 0.2 for c, b in zip(curves, back))
    nib = pytest.importorskip("nibabel")
    seq = nib.streamlines.ArraySequence(curves)
    assert strandfit.compress_streamlines(seq, tolerance=0.2) == data


def test_compress_file_writes_the_bytes_of_the_command_line(tmp_path):
    report = strandfit.compress_file(FORNIX, tmp_path / "py.sfh", tolerance=0.5)
    subprocess.run(
        [BIN, "compress", str(FORNIX), "--tolerance", "0.5", "-o", str(tmp_path / "cli.sfh")],
        check=True,
        capture_output=True,
    )
    py = (tmp_path / "py.sfh").read_bytes()
    assert py == (tmp_path / "cli.sfh").read_bytes()
    assert report["curve_count"] == 300 and report["point_count"] == 14576
    assert report["bytes_out"] == len(py) and report["ratio"] > 20
    out = strandfit.decompress_file(tmp_path / "py.sfh", tmp_path / "back.tck")
    assert out["curve_count"] == 300
    subprocess.run(
        [BIN, "decompress", str(tmp_path / "cli.sfh"), "-o", str(tmp_path / "cli.tck")],
        check=True,
        capture_output=True,
    )
    assert (tmp_path / "back.tck").read_bytes() == (tmp_path / "cli.tck").read_bytes()
    # The file's curves, through the arrays, are the decompressed file's.
    positions, offsets = strandfit.decompress_arrays(py)
    assert len(offsets) == 301 and offsets[-1] == report["output_point_count"]


def test_best_effort_is_the_command_lines_and_keeps_the_guarantee(tmp_path):
    # effort="best" is `--effort best`: the same bytes as the command line,
    # smaller than the default on the fornix at 0.5 mm, and every curve
    # within the tolerance both ways; an unknown effort is a ValueError.
    report = strandfit.compress_file(FORNIX, tmp_path / "best.sfh", tolerance=0.5, effort="best")
    default = strandfit.compress_file(FORNIX, tmp_path / "default.sfh", tolerance=0.5)
    subprocess.run(
        [BIN, "compress", str(FORNIX), "--tolerance", "0.5", "--effort", "best", "-o", str(tmp_path / "cli.sfh")],
        check=True,
        capture_output=True,
    )
    best = (tmp_path / "best.sfh").read_bytes()
    assert best == (tmp_path / "cli.sfh").read_bytes()
    assert report["bytes_out"] < 0.99 * default["bytes_out"]
    assert (report["effort"], default["effort"]) == ("best", "default")
    rng = np.random.default_rng(8)
    curves = random_curves(rng, 30)
    positions, offsets = pack(curves)
    data = strandfit.compress_arrays(positions, offsets, tolerance=0.1, effort="best")
    back, back_offsets = strandfit.decompress_arrays(data)
    for i, c in enumerate(curves):
        assert two_sided(c, back[back_offsets[i] : back_offsets[i + 1]]) <= 0.1, i
    assert strandfit.compress_streamlines(curves, tolerance=0.1, effort="best") == data
    with pytest.raises(ValueError, match="effort"):
        strandfit.compress_arrays(positions, offsets, tolerance=0.1, effort="fast")


def test_lazy_slices_equal_the_full_decode(tmp_path):
    rng = np.random.default_rng(9)
    curves = random_curves(rng, 9000)  # three blocks of up to 4,096 curves
    positions, offsets = pack(curves)
    path = tmp_path / "many.sfh"
    path.write_bytes(strandfit.compress_arrays(positions, offsets, tolerance=0.3))
    full = strandfit.decompress_streamlines(path.read_bytes())
    c = strandfit.open(path)
    assert len(c) == 9000 and c.tolerance == 0.3
    assert [n for _, n in c.blocks] == [4096, 4096, 808]
    for key in [slice(0, 10), slice(4090, 4100), slice(8990, None), slice(-5, None), slice(100, 50)]:
        got = c[key]
        want = full[key]
        assert len(got) == len(want)
        assert all(np.array_equal(g, w) for g, w in zip(got, want))
    assert np.array_equal(c[4096], full[4096]) and np.array_equal(c[-1], full[-1])
    assert len(c[0:30:7]) == 5
    with pytest.raises(IndexError):
        c[9000]
    assert sum(1 for _ in c) == 9000
    assert sum(len(o) - 1 for _, o in c.chunks()) == 9000


def test_bad_input_is_a_value_error_naming_the_curve():
    good = np.zeros((4, 3))
    bad = good.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"curve 1: point 0"):
        strandfit.compress_arrays(np.concatenate([good[:2], bad[2:]]), [0, 2, 4])
    with pytest.raises(ValueError, match="shape"):
        strandfit.compress_arrays(np.zeros((4, 2)), [0, 4])
    with pytest.raises(ValueError, match="float32 or float64"):
        strandfit.compress_arrays(np.zeros((4, 3), dtype=np.int32), [0, 4])
    with pytest.raises(ValueError, match="not decrease"):
        strandfit.compress_arrays(good, [0, 3, 2, 4])
    with pytest.raises(ValueError, match="from 0"):
        strandfit.compress_arrays(good, [0, 3])
    with pytest.raises(ValueError, match="tolerance"):
        strandfit.compress_arrays(good, [0, 4], tolerance=-1)
    with pytest.raises(ValueError, match="beyond|float32|finite"):
        strandfit.compress_arrays(np.full((2, 3), 1e300), [0, 2])


def test_corrupt_and_missing_containers(tmp_path):
    data = strandfit.compress_arrays(np.random.default_rng(1).normal(size=(50, 3)).cumsum(0), [0, 50])
    for broken in [data[:-3], data[:20], b"not a container at all" * 3, data[:40] + bytes([data[40] ^ 0xFF]) + data[41:]]:
        with pytest.raises(ValueError):
            strandfit.decompress_arrays(broken)
    with pytest.raises(OSError):
        strandfit.open(tmp_path / "nowhere.sfh")
    with pytest.raises(OSError):
        strandfit.compress_file(tmp_path / "nowhere.tck", tmp_path / "x.sfh")
    assert not (tmp_path / "x.sfh").exists()
    assert list(tmp_path.iterdir()) == []


def test_no_memory_growth_over_repeated_calls():
    rng = np.random.default_rng(2)
    positions, offsets = pack(random_curves(rng, 300))

    def rss_kib():
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss

    for _ in range(20):
        strandfit.decompress_arrays(strandfit.compress_arrays(positions, offsets, 0.2))
    before = rss_kib()
    for _ in range(200):
        strandfit.decompress_arrays(strandfit.compress_arrays(positions, offsets, 0.2))
    # Peak resident memory may not grow by more than a few MiB over 200
    # round trips of ~0.3 MB of points each (60 MB in all).
    assert rss_kib() - before < 8 * 1024


def test_the_report_is_the_command_lines_json(tmp_path):
    import json

    report = strandfit.compress_file(FORNIX, tmp_path / "py.sfh", tolerance=0.3)
    out = subprocess.run(
        [BIN, "compress", str(FORNIX), "--tolerance", "0.3", "--json", "-o", str(tmp_path / "cli.sfh")],
        check=True,
        capture_output=True,
    )
    cli = json.loads(out.stdout)
    assert list(report) == list(cli)
    for k in cli:
        if k not in ("output", "seconds", "curves_per_second"):
            assert report[k] == cli[k], k


def test_resampling_warns_and_matches_the_command_line(tmp_path):
    rng = np.random.default_rng(6)
    positions, offsets = pack(random_curves(rng, 20))
    data = strandfit.compress_arrays(positions, offsets, 0.2)
    with pytest.warns(UserWarning, match="gives up the guarantee"):
        p, o = strandfit.decompress_arrays(data, points=7)
    assert np.all(np.diff(o) == 7) and len(o) == 21
    with pytest.warns(UserWarning):
        p, o = strandfit.decompress_arrays(data, step=0.5)
    lengths = np.diff(o)
    assert np.all(lengths >= 2)
    for bad in [dict(points=1), dict(step=-1.0), dict(points=3, step=1.0)]:
        with pytest.raises(ValueError):
            strandfit.decompress_arrays(data, **bad)
    sfh = tmp_path / "f.sfh"
    strandfit.compress_file(FORNIX, sfh, 0.5)
    with pytest.warns(UserWarning):
        r = strandfit.decompress_file(sfh, tmp_path / "py.tck", points=12)
    assert r["curve_count"] == 300 and r["guaranteed"] is False
    subprocess.run(
        [BIN, "decompress", str(sfh), "--points", "12", "-o", str(tmp_path / "cli.tck")],
        check=True,
        capture_output=True,
    )
    assert (tmp_path / "py.tck").read_bytes() == (tmp_path / "cli.tck").read_bytes()


def test_container_slices_with_steps_read_each_block_once(tmp_path):
    rng = np.random.default_rng(12)
    positions, offsets = pack(random_curves(rng, 5000))
    path = tmp_path / "s.sfh"
    path.write_bytes(strandfit.compress_arrays(positions, offsets, tolerance=0.3))
    full = strandfit.decompress_streamlines(path.read_bytes())
    c = strandfit.open(path)
    for key in [slice(None, None, -1), slice(10, 4200, 97), slice(4999, 0, -250), slice(3, 3)]:
        got, want = c[key], full[key]
        assert len(got) == len(want) and all(np.array_equal(g, w) for g, w in zip(got, want))
    with pytest.raises(TypeError):
        c[1.7]
    for bad in [dict(points=-3), dict(points=1), dict(step=0.0)]:
        with pytest.raises(ValueError):
            strandfit.decompress_arrays(path.read_bytes(), **bad)
    with pytest.raises(ValueError, match="float32 or float64"):
        strandfit.compress_streamlines([np.zeros((3, 3), dtype=np.int64)])
