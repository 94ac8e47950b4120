"""strandfit: compress 3D curves within a two-sided tolerance, NumPy in and out.

Tractograms (brain and heart fibres), hair strands and stellar magnetic field
lines are sets of polylines. :func:`compress_arrays` turns them into a
strandfit container (``.sfh`` bytes) such that every curve that
:func:`decompress_arrays` gives back is within ``tolerance`` of its input in
the two-sided Hausdorff distance (every input point within ``tolerance`` of
the output polyline and every output point within ``tolerance`` of the input
polyline). The work runs in Rust with the GIL released.

Curves are passed as two arrays, as nibabel's ``ArraySequence`` and TRX hold
them: ``positions``, an ``(P, 3)`` float array of all points, and
``offsets``, an int64 array of ``C + 1`` non-decreasing indices, so that
curve ``i`` is ``positions[offsets[i]:offsets[i + 1]]``.

>>> import numpy as np, strandfit
>>> t = np.linspace(0, 20, 200)
>>> helix = np.stack([3 * np.cos(t), 3 * np.sin(t), 0.8 * t], axis=1)
>>> data = strandfit.compress_arrays(helix, [0, 200], tolerance=0.05)
>>> len(data) < helix.astype(np.float32).nbytes // 10
True
>>> positions, offsets = strandfit.decompress_arrays(data)
>>> offsets.tolist()[0], positions.dtype.name
(0, 'float32')
"""

from __future__ import annotations

import operator
import os
import warnings
from typing import Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _strandfit

__all__ = [
    "compress_arrays",
    "decompress_arrays",
    "compress_file",
    "decompress_file",
    "compress_streamlines",
    "decompress_streamlines",
    "open",
    "Container",
]
__version__ = _strandfit.__version__

PathLike = Union[str, "os.PathLike[str]"]


def _positions(positions) -> np.ndarray:
    p = np.asarray(positions)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"positions must have shape (P, 3), got {p.shape}")
    if p.dtype not in (np.float32, np.float64):
        raise ValueError(f"positions must be float32 or float64, got {p.dtype}")
    return np.ascontiguousarray(p, dtype=np.float64)


def _offsets(offsets) -> np.ndarray:
    o = np.asarray(offsets)
    if o.ndim != 1:
        raise ValueError(f"offsets must be one-dimensional, got shape {o.shape}")
    if o.size and not np.issubdtype(o.dtype, np.integer):
        raise ValueError(f"offsets must be integers, got {o.dtype}")
    return np.ascontiguousarray(o, dtype=np.int64)


def _tolerance(tolerance) -> float:
    t = float(tolerance)
    if not (t > 0 and np.isfinite(t)):
        raise ValueError(f"tolerance must be positive and finite, got {tolerance}")
    return t


def _effort(effort) -> str:
    if effort not in ("default", "best"):
        raise ValueError(f'effort must be "default" or "best", got {effort!r}')
    return effort


def compress_arrays(positions, offsets, tolerance: float = 0.5, effort: str = "default") -> bytes:
    """Compress curves given as ``positions`` and ``offsets`` into container bytes.

    Parameters
    ----------
    positions : array_like, shape (P, 3), float32 or float64
        All points, curve after curve.
    offsets : array_like of int, shape (C + 1,)
        ``0 = offsets[0] <= ... <= offsets[C] = P``; curve ``i`` is
        ``positions[offsets[i]:offsets[i + 1]]`` (empty curves are kept).
    tolerance : float
        The two-sided Hausdorff distance every decompressed curve keeps to
        its input, in the units of ``positions``.
    effort : {"default", "best"}
        ``"best"`` also chooses each arc looking one arc ahead and keeps
        each block's smaller coding (the command line's ``--effort best``):
        the same format and guarantee, never larger (field lines and the
        fornix 0.5-3 % smaller, points-coded bundles the same), about three
        times the time.

    Returns
    -------
    bytes
        A strandfit container (version 3), the same format ``strandfit
        compress`` writes; :func:`decompress_arrays` or ``strandfit
        decompress`` read it.

    Raises
    ------
    ValueError
        Wrong shape or dtype, offsets that do not run from 0 to ``P`` without
        decreasing, a point that is NaN, infinite or beyond float32, or a
        tolerance that is not positive; the message names the curve and point.
    """
    return _strandfit.compress_arrays(_positions(positions), _offsets(offsets), _tolerance(tolerance), _effort(effort))


def _resampling(points, step):
    if points is not None and step is not None:
        raise ValueError("give points or step, not both")
    if points is not None and int(points) < 2:
        raise ValueError(f"points must be at least 2, got {points}")
    if step is not None and not (float(step) > 0 and np.isfinite(float(step))):
        raise ValueError(f"step must be positive, got {step}")
    if points is not None or step is not None:
        warnings.warn(
            "resampling (points or step) gives up the guarantee that every curve is within "
            "the container's tolerance of its input; it holds for the default points",
            stacklevel=3,
        )
    return (None if points is None else int(points), None if step is None else float(step))


def decompress_arrays(data: bytes, points: Optional[int] = None, step: Optional[float] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Decode container bytes into ``(positions, offsets)``.

    ``positions`` is float32 of shape ``(P, 3)``, ``offsets`` int64 of shape
    ``(C + 1,)``: by default the points ``strandfit decompress`` writes, each
    curve within the container's tolerance of its input. ``points=N`` gives
    every curve N points equally spaced in arc length, ``step=S`` points S
    apart (both ends kept): a ``UserWarning`` says that this gives up the
    guarantee. A corrupt or truncated container raises ``ValueError`` saying
    where.

    >>> import numpy as np, strandfit
    >>> line = np.array([[0.0, 0, 0], [10, 0, 0]])
    >>> p, o = strandfit.decompress_arrays(strandfit.compress_arrays(line, [0, 2], 0.1))
    >>> import warnings; warnings.simplefilter("ignore")
    >>> p, o = strandfit.decompress_arrays(strandfit.compress_arrays(line, [0, 2], 0.1), points=5)
    >>> o.tolist(), bool(abs(p[-1, 0] - 10) <= 0.1), bool(np.ptp(np.diff(p[:, 0])) < 1e-4)
    ([0, 5], True, True)
    """
    points, step = _resampling(points, step)
    return _strandfit.decompress_arrays(bytes(data), points, step)


def _warn_dropped(report: dict) -> dict:
    for d in report.get("dropped", []):
        warnings.warn(f"{report['input']}: dropped {d}; strict=True makes this an error", stacklevel=3)
    return report


def compress_file(
    src: PathLike, dst: PathLike, tolerance: float = 0.5, strict: bool = False, skip_bad: bool = False, effort: str = "default"
) -> dict:
    """Compress a curve file (.tck .trk .trx .vtk .hair .json .csv) to a container.

    The same as ``strandfit compress SRC --tolerance T -o DST --json``: the
    same bytes, written atomically, and the same report, keys as in
    ``docs/schemas/compress.schema.json`` (``version``, ``curve_count``,
    ``point_count``, ``bytes_in``, ``bytes_out``, ``ratio``,
    ``output_point_count``, ``arc_count``, ``points_cheaper_count``,
    ``verbatim_count``, ``skipped``, ``dropped``, ``seconds``, ...). What the container cannot hold is listed in
    ``dropped`` and warned about (``strict=True``: an error); ``skip_bad=True``
    leaves out curves with unusable points (listed in ``skipped``) instead of
    failing; ``effort="best"`` is ``--effort best``. ``OSError`` when a file
    cannot be read or written, ``ValueError`` for bad data, naming the file
    and curve.
    """
    report = _strandfit.compress_file(
        os.fspath(src), os.fspath(dst), _tolerance(tolerance), bool(strict), bool(skip_bad), _effort(effort)
    )
    return _warn_dropped(report)


def decompress_file(src: PathLike, dst: PathLike, points: Optional[int] = None, step: Optional[float] = None, strict: bool = False) -> dict:
    """Decompress a container to a curve file, its format from ``dst``'s extension.

    The same as ``strandfit decompress SRC -o DST`` (``--points``/``--step``
    with ``points``/``step``, ``--strict`` with ``strict``). Returns
    ``{"input", "output", "curve_count", "guaranteed", "dropped", "seconds"}``.
    """
    points, step = _resampling(points, step)
    report = _strandfit.decompress_file(os.fspath(src), os.fspath(dst), points, step, bool(strict))
    return _warn_dropped(report)


def _split(positions: np.ndarray, offsets: np.ndarray) -> List[np.ndarray]:
    return [positions[a:b] for a, b in zip(offsets[:-1], offsets[1:])]


def compress_streamlines(streamlines, tolerance: float = 0.5, effort: str = "default") -> bytes:
    """:func:`compress_arrays` for a sequence of ``(n_i, 3)`` arrays.

    Takes a list of arrays, a nibabel ``ArraySequence`` or a nibabel
    ``Tractogram`` (its ``streamlines``); nibabel itself is not needed.
    """
    streamlines = getattr(streamlines, "streamlines", streamlines)
    data = getattr(streamlines, "_data", None)
    offs = getattr(streamlines, "_offsets", None)
    lengths = getattr(streamlines, "_lengths", None)
    if data is not None and offs is not None and lengths is not None and len(offs) == len(lengths):
        # An ArraySequence: its buffer, in order, when its pieces are packed.
        offs = np.asarray(offs, dtype=np.int64)
        lengths = np.asarray(lengths, dtype=np.int64)
        if len(offs) == 0 or np.array_equal(offs, np.concatenate([[0], np.cumsum(lengths)[:-1]])):
            end = int(lengths.sum())
            return compress_arrays(np.asarray(data)[:end], np.concatenate([[0], np.cumsum(lengths)]), tolerance, effort)
    arrays = [np.asarray(s) for s in streamlines]
    for i, a in enumerate(arrays):
        if a.ndim != 2 or (a.size and a.shape[1] != 3):
            raise ValueError(f"streamline {i} has shape {a.shape}, expected (n, 3)")
        if a.dtype not in (np.float32, np.float64):
            raise ValueError(f"streamline {i} is {a.dtype}; positions must be float32 or float64")
    lengths = np.array([len(a) for a in arrays], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    positions = (
        np.concatenate([a.reshape(-1, 3) for a in arrays]).astype(np.float64, copy=False)
        if arrays
        else np.zeros((0, 3))
    )
    return compress_arrays(positions, offsets, tolerance, effort)


def decompress_streamlines(data: bytes) -> List[np.ndarray]:
    """:func:`decompress_arrays` as a list of ``(n_i, 3)`` float32 arrays (views)."""
    return _split(*decompress_arrays(data))


class Container:
    """A container opened for random access: ``len()``, indexing and slicing by curve.

    ``c[i]`` is curve ``i`` as an ``(n, 3)`` float32 array; ``c[a:b]`` a list
    of them; ``c.read(a, b)`` the arrays ``(positions, offsets)`` of curves
    ``a..b``. Only the blocks (4,096 curves each) that hold the asked curves
    are read and decoded, so a small range of a large file is cheap.
    :meth:`chunks` iterates over the whole file a block at a time.
    """

    def __init__(self, path: PathLike):
        self._c = _strandfit.Container(os.fspath(path))
        self.path = os.fspath(path)

    def __len__(self) -> int:
        return len(self._c)

    @property
    def tolerance(self) -> float:
        """The tolerance the container was written with."""
        return self._c.tolerance

    @property
    def blocks(self) -> List[Tuple[int, int]]:
        """``(first curve, curve count)`` of each block."""
        return list(self._c.blocks)

    def read(self, start: int, stop: int) -> Tuple[np.ndarray, np.ndarray]:
        """Curves ``start..stop`` as ``(positions, offsets)``."""
        return self._c.read(int(start), int(stop))

    def __getitem__(self, key):
        n = len(self)
        if isinstance(key, slice):
            indices = range(*key.indices(n))
            if len(indices) == 0:
                return []
            # One read of the span: each block is decoded once.
            lo, hi = min(indices), max(indices) + 1
            curves = _split(*self.read(lo, hi))
            return [curves[i - lo] for i in indices]
        i = operator.index(key)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"curve {key} of a container of {n}")
        positions, _ = self.read(i, i + 1)
        return positions

    def __iter__(self) -> Iterator[np.ndarray]:
        for positions, offsets in self.chunks():
            yield from _split(positions, offsets)

    def chunks(self) -> Iterator[Tuple[np.ndarray, np.ndarray]]:
        """``(positions, offsets)`` of each block in turn (memory: one block)."""
        for first, count in self.blocks:
            yield self.read(first, first + count)

    def __repr__(self) -> str:
        return f"strandfit.Container({self.path!r}: {len(self)} curves, tolerance {self.tolerance})"


def open(path: PathLike) -> Container:  # noqa: A001 (the module's verb, as in gzip.open)
    """Open a container for random access (see :class:`Container`)."""
    return Container(path)
