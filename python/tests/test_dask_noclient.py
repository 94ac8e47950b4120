"""strandfit.dask without a cluster: the tasks run one after the other in
this process (no default client here: the cluster tests are in another
module, whose client is closed by now)."""

from pathlib import Path

import pytest

import strandfit.dask

distributed = pytest.importorskip("distributed")

FIBRES = Path(__file__).resolve().parents[2] / "tests" / "data" / "fibres"


def test_without_a_client_the_tasks_run_here(tmp_path):
    with pytest.raises(ValueError):
        distributed.get_client()
    src = FIBRES / "dipy_fornix_tracks300.tck"
    (r,) = strandfit.dask.compress_files([src], tmp_path, 0.5)
    assert r["curve_count"] == 300 and Path(r["output"]).exists()
    with pytest.raises(ValueError, match="collide"):
        strandfit.dask.compress_files([src, src], tmp_path, 0.5)
    with pytest.raises(OSError):
        strandfit.dask.compress_files([tmp_path / "missing.tck"], tmp_path / "o", 0.5)
