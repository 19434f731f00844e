"""Studies on real Dask clusters: a local one (1 and 2 workers) and an external one
(`dask scheduler` and two `dask worker` processes on loopback), the same CSV byte
for byte from all three; a failing sample is a row; the worst samples rerun; the
stability sweep on the external cluster."""

import csv
import ipaddress
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest
import yaml
from harness import assert_figure
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from sail_ros import topics
from sail_ros.analysis.montecarlo import load_study, sample_inputs
from sail_ros.analysis.stability import CRITICAL, STABLE, UNSTABLE, stability_sweep
from sail_ros.bag import BagReader
from sail_ros.model import SailParameters
from sail_ros.tools import deploy, montecarlo, stability
from sail_ros.tools.cluster import dask_client

pytestmark = pytest.mark.multiprocess

# one single-threaded worker process per `dask worker`, no dashboard
WORKER_OPTIONS = ("--nthreads", "1", "--nworkers", "1", "--no-dashboard")
STABILITY_PARAMS = SailParameters()

STUDY = {
    "study": {
        "description": "short test study",
        "samples": 10,
        "seed": 11,
        "output_rate_hz": 10.0,
        "scenario": {
            "scenario": {
                # within the simulator's limits of rate and acceleration, also for the
                # faster rate.c draws
                "duration": 5.0,
                "profile": {"type": "cycloidal", "start": 10.0, "end": 11.0, "duration": 5.0},
                "initial": {"mode_state": {"a": 0.1}},
                "snapshots": [0.0, 5.0],
            },
            "sail": {"n_boom_modes": 2, "n_membrane_modes": 2},
        },
        "dispersions": {
            "boom_bending_stiffness": {"distribution": "normal", "mean": 6000.0, "std": 600.0},
            "initial_tip_deflection.b": {"distribution": "uniform", "low": -0.1, "high": 0.1},
            "rate.c": {"distribution": "lognormal", "median": 1.0, "sigma": 0.1},
            # below zero now and then: those samples fail, as rows
            "membrane_thickness": {"distribution": "normal", "mean": 2.5e-6, "std": 2.5e-6},
        },
        "jam": {
            "probability": 0.5,
            "fraction": {"distribution": "uniform", "low": 0.2, "high": 0.8},
        },
    }
}


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("study") / "study.yaml"
    path.write_text(yaml.safe_dump(STUDY))
    return path


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def external_cluster(ros_env):
    """`dask scheduler` and two `dask worker` processes on loopback; their address."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**ros_env, "OPENBLAS_NUM_THREADS": "1"}
    dask = [str(Path(sys.executable).parent / "dask")]  # the environment's dask command
    processes = [
        subprocess.Popen(
            [*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    for _ in range(2):
        processes.append(
            subprocess.Popen(
                [*dask, "worker", address, *WORKER_OPTIONS],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
    from dask.distributed import Client

    deadline = time.monotonic() + 60.0
    while True:
        try:
            with Client(address, timeout="2s") as client:
                if len(client.scheduler_info()["workers"]) == 2:
                    break
        except (OSError, TimeoutError):
            pass
        assert time.monotonic() < deadline, "the external cluster did not come up"
        time.sleep(0.5)
    yield address
    for process in processes:
        process.terminate()
    for process in processes:
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()


def test_the_same_study_gives_the_same_csv_on_any_cluster(
    study_file, tmp_path, external_cluster, capsys
):
    outputs = {}
    for name, options in (
        ("one", ["--workers", "1"]),
        ("two", ["--workers", "2"]),
        ("external", ["--scheduler", external_cluster]),
    ):
        out = tmp_path / name
        code = montecarlo.main([str(study_file), "--out", str(out), "--no-figures", *options])
        assert code == 0, capsys.readouterr().err
        outputs[name] = (out / "samples.csv").read_bytes()
    assert outputs["one"] == outputs["two"] == outputs["external"]

    rows = list(csv.DictReader((tmp_path / "one" / "samples.csv").open()))
    assert [int(r["sample"]) for r in rows] == list(range(10))
    failed = [r for r in rows if r["error"]]
    assert failed and all("membrane_thickness must be in [0, 0.01] m" in r["error"] for r in failed)
    study = load_study(study_file)
    for row in failed:  # the sample that failed did draw a negative thickness
        assert sample_inputs(study, int(row["sample"]))["membrane_thickness"] < 0
    ran = [r for r in rows if not r["error"]]
    assert len(ran) >= 3 and all(float(r["peak_tip_m"]) > 0 for r in ran)
    jammed = [r for r in ran if float(r["jam_boom"]) >= 0]
    assert jammed  # half the samples jam a boom
    assert (tmp_path / "one" / "samples.parquet").is_file()


def worker_settings(dask_worker):
    import os

    import dask

    profiler = dask.config.get("distributed.worker.profile.enabled")
    periods_ms = {  # the worker's own periodic callbacks, as it runs them
        name: dask_worker.periodic_callbacks[name].callback_time
        for name in ("tick", "monitor", "memory_monitor")
    }
    return os.environ.get("MALLOC_TRIM_THRESHOLD_"), profiler, periods_ms


def test_local_workers_keep_glibc_malloc_defaults_no_profiler_and_seldom_ticks(monkeypatch):
    """Dask's nanny would start them with MALLOC_TRIM_THRESHOLD_=65536, its profiler and
    event-loop callbacks every 20 ms (the tick), 500 ms (the system monitor) and 100 ms
    (the memory monitor), under which a sample costs more CPU (sail_ros.tools.cluster):
    the local cluster's workers get neither of the first two and the callbacks every 1,
    5 and 1 s, and this process keeps its environment."""
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with dask_client(workers=1) as client:
        ((trim, profiler, periods_ms),) = client.run(worker_settings).values()
    assert (trim, profiler) == (None, False)
    assert periods_ms == {"tick": 1000, "monitor": 5000, "memory_monitor": 1000}, periods_ms
    assert "MALLOC_TRIM_THRESHOLD_" not in os.environ


def _listening(process) -> set[tuple[int, str, int]]:
    """(pid, address, port) of every TCP socket listening in `process` and its children."""
    found = set()
    for each in [process, *process.children(recursive=True)]:
        try:
            sockets = each.net_connections(kind="tcp")
        except psutil.NoSuchProcess:
            continue
        found |= {(each.pid, s.laddr.ip, s.laddr.port) for s in sockets if s.status == "LISTEN"}
    return found


def test_a_local_cluster_listens_on_loopback_only():
    """Every port a local cluster opens (scheduler, workers, nannies, Dask's HTTP endpoints
    and dashboard) is on 127.0.0.1: Dask's default would serve the dashboard on every
    interface, to anyone who reaches the machine."""
    me = psutil.Process()
    before = _listening(me)
    with dask_client(workers=1):
        opened = _listening(me) - before
    assert len(opened) >= 4, opened  # the scheduler, its HTTP server, the worker, the nanny
    assert all(ipaddress.ip_address(ip).is_loopback for _, ip, _ in opened), opened


def test_worst_samples_rerun_to_the_same_numbers(study_file, tmp_path, capsys, external_cluster):
    out = tmp_path / "study"
    argv = [str(study_file), "--out", str(out), "--scheduler", external_cluster]
    assert montecarlo.main(argv) == 0
    printed = capsys.readouterr().out
    assert "inputs by |Spearman rank correlation| with peak_tip_m" in printed
    rows = {int(r["sample"]): r for r in csv.DictReader((out / "samples.csv").open())}
    worst = sorted((out / "worst").glob("worst_*.yaml"))
    assert 1 <= len(worst) <= 5
    for path in worst[:2]:
        index = int(path.stem.split("_")[-1])
        log = tmp_path / f"rerun_{index}.mcap"
        argv = ["--scenario", str(path), "--mcap", str(log), "--rate", "10", "--json"]
        assert deploy.main(argv) == 0
        rerun = json.loads(capsys.readouterr().out)
        tips = np.array(
            [
                deserialize_message(m.data, JointState).position
                for m in BagReader(log).messages([topics.absolute(topics.TIP_DEFLECTION)])
            ]
        )
        for k, boom in enumerate("abcd"):
            for name, key in (("tip", "peak_tip_deflection_m"),
                              ("root_moment", "peak_root_moment_Nm")):  # fmt: skip
                unit = "m" if name == "tip" else "N_m"
                assert rerun[key][boom] == pytest.approx(
                    float(rows[index][f"peak_{name}_{boom}_{unit}"]), rel=1e-9
                )
            # true peaks: never below the logged samples of the same run
            assert np.abs(tips[:, k]).max() <= rerun["peak_tip_deflection_m"][boom] * (1 + 1e-12)
    for name in ("envelopes", "peaks", "influence"):
        assert (out / f"{name}.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"dispersions": {"no_such_field": {"distribution": "normal", "mean": 1, "std": 1}}},
         "unknown key 'no_such_field'"),
        ({"dispersions": {"sail_side": {"distribution": "normal", "mean": 1, "std": -1}}},
         "study.dispersions.sail_side.std must be >= 0, got -1"),
        ({"dispersions": {"sail_side": {"distribution": "beta", "a": 1, "b": 1}}},
         "distribution: normal | uniform | lognormal"),
        ({"jam": {"probability": 1.5, "fraction": {"distribution": "uniform", "low": 0,
                                                    "high": 1}}}, "jam.probability must be in"),
        ({"samples": 0}, "study.samples must be an integer >= 1"),
        ({"extra": 1}, "study: unknown key(s) 'extra'"),
    ],
    ids=["key", "negative-std", "distribution", "probability", "samples", "study-key"],
)  # fmt: skip
def test_bad_studies_name_the_key(tmp_path, capsys, change, message):
    document = {"study": {**STUDY["study"], **change}}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(document))
    assert montecarlo.main([str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_stability_tool_finds_instability_in_retraction_and_none_at_rest(
    tmp_path, capsys, figure_checks, external_cluster
):
    """Two worker processes over a small grid; CSVs and figures hold what they claim."""
    critical, grid = tmp_path / "critical.csv", tmp_path / "grid.csv"
    assert (
        stability.main(
            [
                "--rates",
                "-0.1",
                "0",
                "0.1",
                "1",
                "--prestress",
                "1",
                "1e4",
                "--points",
                "9",
                "--scheduler",
                external_cluster,
                "--csv",
                str(critical),
                "--grid-csv",
                str(grid),
                "--figures",
                str(tmp_path),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "unstable at every prestress" in out and "stable at every prestress" in out

    rows = {float(r["rate_m_s"]): r for r in csv.DictReader(critical.open())}
    assert rows[-0.1]["status"] == UNSTABLE
    assert rows[0.0]["status"] == STABLE
    assert rows[0.1]["status"] == rows[1.0]["status"] == CRITICAL
    # the membrane's N term scales with rate^2, so does the critical prestress
    ratio = float(rows[1.0]["critical_prestress_pa"]) / float(rows[0.1]["critical_prestress_pa"])
    assert ratio == pytest.approx(100.0, rel=0.02)
    # at the sail's own 6890 Pa: retraction grows, deployment decays, rest is neutral
    assert float(rows[-0.1]["max_real_at_sail_prestress_1_s"]) > 1e-4
    assert float(rows[0.1]["max_real_at_sail_prestress_1_s"]) < -1e-4
    assert abs(float(rows[0.0]["max_real_at_sail_prestress_1_s"])) < 1e-12

    points = list(csv.DictReader(grid.open()))
    assert len(points) == 4 * 9
    at_rest = [p for p in points if float(p["rate_m_s"]) == 0.0]
    assert not any(p["unstable"] == "True" for p in at_rest)
    assert all(p["unstable"] == "True" for p in points if float(p["rate_m_s"]) < 0)
    # one length: the narrowest map, whose legend ran off its sides in one row
    for name in ("stability", "stability_map", "eigenvalue_loci"):
        assert_figure(tmp_path / f"{name}.png", figure_checks)


def test_serial_and_dask_stability_sweeps_agree(external_cluster):
    from dask.distributed import Client

    grid = np.logspace(0, 3, 4)
    serial = stability_sweep(
        STABILITY_PARAMS, [STABILITY_PARAMS.full_boom_length, 20.0], [-0.1, 0.1], grid
    )
    with Client(external_cluster) as client:
        parallel = stability_sweep(
            STABILITY_PARAMS,
            [STABILITY_PARAMS.full_boom_length, 20.0],
            [-0.1, 0.1],
            grid,
            client=client,
        )
    for a, b in zip(serial, parallel, strict=True):
        assert (a.length, a.rate, a.status) == (b.length, b.rate, b.status)
        np.testing.assert_array_equal(a.max_real, b.max_real)
