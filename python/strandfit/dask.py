"""Compress many files, or one large file in shards, on a Dask cluster.

One task per file (:func:`compress_files`) or per shard
(:func:`compress_sharded`); each task runs strandfit's Rust code with the
GIL released, so a worker with several threads compresses several at once.
The outputs are the same bytes as the command line's: a file's container is
``strandfit compress``'s, and the shards of :func:`compress_sharded` are
what ``strandfit compress`` then ``strandfit split`` write.

Needs ``dask.distributed`` (``pip install "dask[distributed]"``). With
``client=None`` the tasks go to the current default client
(``distributed.get_client()``), or, where there is none, run one after the
other in this process.

On a Slurm or Kubernetes cluster the same call runs on many machines::

    from dask_jobqueue import SLURMCluster          # or dask_kubernetes.KubeCluster
    from distributed import Client
    import strandfit.dask

    cluster = SLURMCluster(cores=8, memory="16GB", walltime="02:00:00")
    cluster.scale(jobs=20)
    reports = strandfit.dask.compress_files(paths, "/scratch/sfh", 0.5, client=Client(cluster))
"""

from __future__ import annotations

import os
from typing import List, Optional, Sequence

from . import _strandfit

__all__ = ["compress_files", "compress_sharded", "BLOCK_CURVES"]

#: Curves per block of a container: shards hold whole blocks.
BLOCK_CURVES = 4096


def _client(client):
    if client is not None:
        return client
    try:
        from distributed import get_client

        return get_client()
    except (ImportError, ValueError):
        return None


def _run(client, fn, args_list) -> List[dict]:
    if client is None:
        return [fn(*a) for a in args_list]
    futures = [client.submit(fn, *a, pure=False) for a in args_list]
    return client.gather(futures)


def _compress_one(src: str, dst: str, tolerance: float) -> dict:
    from . import compress_file

    return compress_file(src, dst, tolerance)


def _compress_range(src: str, dst: str, tolerance: float, first: int, count: int) -> dict:
    return _strandfit.compress_file_range(src, dst, float(tolerance), int(first), int(count))


def _stem(path: str) -> str:
    return os.path.splitext(os.path.basename(path))[0]


def compress_files(srcs: Sequence[os.PathLike], out_dir: os.PathLike, tolerance: float = 0.5, client=None) -> List[dict]:
    """Compress each file of ``srcs`` to ``out_dir/STEM.sfh``, one task per file.

    Returns the reports (as :func:`strandfit.compress_file`'s), in the order
    of ``srcs``. Two inputs with the same stem are refused (their outputs
    would collide). A failing file raises its error (``OSError`` or
    ``ValueError`` naming the file and curve); outputs are written
    atomically, so no half-written container is left.
    """
    out_dir = os.fspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    srcs = [os.fspath(s) for s in srcs]
    dsts = [os.path.join(out_dir, _stem(s) + ".sfh") for s in srcs]
    if len(set(dsts)) != len(dsts):
        raise ValueError("two inputs have the same name stem; their outputs would collide")
    return _run(_client(client), _compress_one, [(s, d, float(tolerance)) for s, d in zip(srcs, dsts)])


def compress_sharded(
    src: os.PathLike,
    out_dir: os.PathLike,
    curves_per_shard: int = 100 * BLOCK_CURVES,
    tolerance: float = 0.5,
    client=None,
) -> List[dict]:
    """Compress one large curve file as shards ``out_dir/STEM-00000.sfh``, ... in parallel.

    Each shard holds ``curves_per_shard`` curves, rounded down to whole
    blocks (at least one block, 4,096 curves), and is one task: it reads
    the file up to its last curve and compresses its own. The shards are
    byte for byte those of ``strandfit compress SRC`` then ``strandfit split
    --curves-per-shard N``, and ``strandfit merge`` joins them into that
    container. Returns one report per shard (``first``, ``curve_count``,
    ``bytes_out``, ...), in order.
    """
    src = os.fspath(src)
    out_dir = os.fspath(out_dir)
    per = max(BLOCK_CURVES, (int(curves_per_shard) // BLOCK_CURVES) * BLOCK_CURVES)
    n = _strandfit.count_curves(src)
    os.makedirs(out_dir, exist_ok=True)
    firsts = list(range(0, n, per)) or [0]
    tasks = [
        (src, os.path.join(out_dir, f"{_stem(src)}-{k:05d}.sfh"), float(tolerance), a, min(per, n - a))
        for k, a in enumerate(firsts)
    ]
    reports = _run(_client(client), _compress_range, tasks)
    # Shards of an earlier, longer run would be taken for this one's.
    k = len(tasks)
    while os.path.isfile(os.path.join(out_dir, f"{_stem(src)}-{k:05d}.sfh")):
        os.remove(os.path.join(out_dir, f"{_stem(src)}-{k:05d}.sfh"))
        k += 1
    return reports
