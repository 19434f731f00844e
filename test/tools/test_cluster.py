"""The local Dask cluster of `stability` and `montecarlo` is sized within the machine:
at most a worker per core, as many as the available memory holds; anything more is
refused in one line before a study starts (a cluster's own ports:
test/system/test_studies_dask.py)."""

import pytest
from harness import ROOT, run_tool

from sail_ros.tools import cluster
from sail_ros.tools.cluster import WORKER_BYTES, local_workers

pytestmark = pytest.mark.model


@pytest.fixture
def machine(monkeypatch):
    """A machine of 8 cores with `set(bytes)` of memory available (default plenty)."""
    memory = {"bytes": 1 << 40}
    monkeypatch.setattr(cluster, "usable_cores", lambda: 8)
    monkeypatch.setattr(cluster, "available_memory_bytes", lambda: memory["bytes"])
    return memory


def test_workers_are_bounded_by_the_cores_and_the_memory(machine):
    assert local_workers(None) == 8 and local_workers(3) == 3
    with pytest.raises(ValueError, match=r"^--workers 9: more than the 8 core\(s\) this proc"):
        local_workers(9)
    machine["bytes"] = 5 * WORKER_BYTES  # 80 % of it holds 4 workers
    assert local_workers(None) == 4 and local_workers(4) == 4
    refusal = (
        r"^--workers 5: would need about 1.25 GiB \(256 MiB a worker\), more than 80 % of "
        r"the 1.25 GiB available: at most 4$"
    )
    with pytest.raises(ValueError, match=refusal):
        local_workers(5)
    machine["bytes"] = WORKER_BYTES // 2
    assert local_workers(None) == 1  # one all the same: a study needs a worker
    with pytest.raises(ValueError, match="^--workers must be >= 1, got 0$"):
        local_workers(0)


@pytest.mark.parametrize(
    "argv",
    [
        ["stability", "--workers", "10000", "--rates", "0.1"],
        ["montecarlo", str(ROOT / "config" / "study_reference.yaml"), "--workers", "10000"],
    ],
    ids=["stability", "montecarlo"],
)
def test_ten_thousand_workers_are_refused_in_one_line_before_the_study(argv, tmp_path):
    tool, *args = argv
    code, out, err = run_tool(
        tool, [*args, *(["--out", str(tmp_path / "r")] * (tool != "stability"))]
    )
    assert code == 2 and out == "", out
    assert err.startswith("error: --workers 10000: more than the ") and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []
