"""`sail-ros report`: figures and CSV from deploy logs, cut logs and live-style logs."""

import csv

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from test_tool_figures import assert_png

from sail_ros import topics
from sail_ros.bag import BagWriter
from sail_ros.model import SailModel, SailParameters
from sail_ros.tools import deploy, report

pytestmark = pytest.mark.model

FIGURES = ("tip_deflections", "boom_lengths", "modal_energies")


@pytest.fixture(scope="module")
def deploy_log(tmp_path_factory):
    """The reference deployment's first 4 s at 25 Hz, shapes at 5 Hz."""
    folder = tmp_path_factory.mktemp("deploy")
    path = folder / "run.mcap"
    assert deploy.main(["--t-end", "4", "--rate", "25", "--mcap", str(path)]) == 0
    return path


def _rows(path):
    return list(csv.DictReader(path.open()))


def test_report_of_a_deploy_log(deploy_log, tmp_path, capsys):
    out = tmp_path / "report"
    assert report.main([str(deploy_log), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "sail parameters recorded in the log" in text
    assert "real-time factor not available" in text
    for name in FIGURES:
        assert_png(out / f"{name}.png")
    assert not (out / "real_time_factor.png").exists()

    states = _rows(out / "states.csv")
    assert len(states) == 101 and float(states[-1]["t_s"]) == pytest.approx(4.0)
    assert float(states[0]["a_tip_m"]) == pytest.approx(0.1)
    energies = _rows(out / "energies.csv")
    first = energies[0]
    # boom a bent in its first mode at rest: all energy is boom a's strain energy
    model = SailModel()
    q0 = model.mode_state("a", 0.1)
    assert float(first["total_J"]) == pytest.approx(model.energy(q0, 0 * q0, 10.0), rel=1e-9)
    assert float(first["boom_a_J"]) == pytest.approx(float(first["total_J"]), rel=1e-9)
    for row in energies:
        parts = sum(float(v) for k, v in row.items() if k.startswith(("boom_", "membrane_")))
        assert parts + float(row["coupling_J"]) == pytest.approx(float(row["total_J"]))


def test_report_of_a_log_cut_at_60_percent(deploy_log, tmp_path, capsys):
    cut = tmp_path / "cut.mcap"
    data = deploy_log.read_bytes()
    cut.write_bytes(data[: int(0.6 * len(data))])
    out = tmp_path / "report"
    assert report.main([str(cut), "--out", str(out)]) == 0
    assert "incomplete (cut short)" in capsys.readouterr().out
    for name in FIGURES:
        assert_png(out / f"{name}.png")
    states = _rows(out / "states.csv")
    times = [float(row["t_s"]) for row in states]
    # the part before the cut, from the start, in order, on the 25 Hz grid
    assert times[0] == 0.0 and 1.0 < times[-1] < 4.0
    np.testing.assert_allclose(np.diff(times), 0.04, atol=1e-9)
    assert len(_rows(out / "energies.csv")) == len(states)


def _live_style_log(path, params, count=30):
    """What the recorder writes from a live simulator: stamps from a wall-clock
    epoch, /diagnostics with the integrator status, no parameters record."""
    model = SailModel(params)
    epoch = 1_700_000_000_000_000_000
    q = model.mode_state("c", 0.02)
    with BagWriter(path) as bag:
        for topic, kind in (
            (topics.absolute(topics.BOOM_STATE), "sensor_msgs/msg/JointState"),
            (topics.absolute(topics.MODAL_STATE), "sensor_msgs/msg/JointState"),
            (topics.absolute(topics.TIP_DEFLECTION), "sensor_msgs/msg/JointState"),
            (topics.DIAGNOSTICS, "diagnostic_msgs/msg/DiagnosticArray"),
        ):
            bag.add_topic(topic, kind)
        for i in range(count):
            stamp = topics.stamp_ns(epoch, 0.1 * i)
            lengths, rates = np.full(4, 20.0), np.zeros(4)
            messages = [
                (topics.BOOM_STATE, topics.boom_state(stamp, lengths, rates)),
                (topics.MODAL_STATE, topics.modal_state(stamp, model.coordinate_names, q, 0 * q)),
                (
                    topics.TIP_DEFLECTION,
                    topics.tip_deflection(stamp, model.tip_deflections(q), np.zeros(4)),
                ),
            ]
            if i % 10 == 0:
                messages.append(
                    (
                        topics.DIAGNOSTICS,
                        topics.diagnostics(
                            stamp,
                            "OK",
                            "running",
                            {
                                "real_time_factor": 0.98 + 0.01 * i / 10,
                                "step_time_ms": 0.4,
                                "sim_time_s": 0.1 * i,
                            },
                        ),
                    )
                )
            for topic, message in messages:
                bag.write(topics.absolute(topic), serialize_message(message), log_time_ns=stamp)


def test_report_of_a_live_style_log_with_diagnostics(tmp_path, capsys):
    params = SailParameters(n_boom_modes=2, n_membrane_modes=3)
    log = tmp_path / "live.mcap"
    _live_style_log(log, params)
    out = tmp_path / "report"
    argv = [str(log), "--out", str(out)]
    assert report.main(argv) == 2  # default mode counts do not match the recorded coordinates
    assert "give the recorded mode counts with --set" in capsys.readouterr().err

    assert report.main([*argv, "--set", "n_boom_modes=2", "--set", "n_membrane_modes=3"]) == 0
    text = capsys.readouterr().out
    assert "no recorded sail parameters" in text and "real-time factor: mean" in text
    assert_png(out / "real_time_factor.png", min_height=200)
    rtf = _rows(out / "real_time_factor.csv")
    assert [float(r["real_time_factor"]) for r in rtf] == pytest.approx([0.98, 0.99, 1.0])
    assert [float(r["t_s"]) for r in rtf] == pytest.approx([0.0, 1.0, 2.0])
    energies = _rows(out / "energies.csv")
    total = SailModel(params).energy(SailModel(params).mode_state("c", 0.02), np.zeros(20), 20.0)
    assert float(energies[5]["boom_c_J"]) == pytest.approx(total, rel=1e-9)


def test_report_rejects_what_is_not_a_log(tmp_path, capsys):
    path = tmp_path / "notes.mcap"
    path.write_text("not an mcap file")
    assert report.main([str(path)]) == 2
    assert "is not an MCAP file" in capsys.readouterr().err
    assert report.main([str(tmp_path / "absent.mcap")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_report_peaks_interpolate_the_log_and_rerun_its_scenario(deploy_log, tmp_path, capsys):
    """peaks.csv: the peaks interpolated between the logged samples with the logged
    rates, those of a rerun of the recorded scenario (which reproduces the log), and of a
    rerun with twice the modes; the interpolated peaks lie between the largest logged
    sample and the rerun's true peak, and the report says what the sampling misses."""
    out = tmp_path / "report"
    assert report.main([str(deploy_log), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "interpolated with the logged rates (cubic Hermite)" in text
    assert "reproduces the logged tips to 0 of their peak" in text
    assert "sampled too coarsely to follow" in text
    rows = {row["source"]: row for row in _rows(out / "peaks.csv")}
    assert set(rows) == {"log", "rerun", "rerun, more modes"}
    assert rows["rerun, more modes"]["n_boom_modes"] == "8"
    states = _rows(out / "states.csv")
    for boom in "abcd":
        sampled = max(abs(float(row[f"{boom}_tip_m"])) for row in states)
        logged = float(rows["log"][f"peak_tip_{boom}_m"])
        rerun = float(rows["rerun"][f"peak_tip_{boom}_m"])
        assert sampled <= logged * (1 + 1e-12)
        assert logged == pytest.approx(rerun, rel=2e-3)
    assert report.main([str(deploy_log), "--out", str(out), "--no-convergence"]) == 0
    assert {row["source"] for row in _rows(out / "peaks.csv")} == {"log", "rerun"}
