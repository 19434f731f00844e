"""`sail-ros report`: figures and CSV from deploy logs, cut logs and live-style logs."""

import csv

import numpy as np
import pytest
from harness import SMALL, SMALL_SET, assert_figure, assert_png
from rcl_interfaces.msg import ParameterEvent
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message

from sail_ros import status as key
from sail_ros import topics
from sail_ros.analysis.log_series import read_log
from sail_ros.analysis.parameter_history import parameter_changes
from sail_ros.bag import BagWriter
from sail_ros.bag.recording import ParameterChange, changes_record_of
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import state as state_msg
from sail_ros.model import SailModel, SailParameters
from sail_ros.tools import deploy, report

pytestmark = pytest.mark.model

FIGURES = ("tip_deflections", "root_moments", "boom_lengths", "modal_energies")


@pytest.fixture(scope="module")
def deploy_log(tmp_path_factory):
    """The reference deployment's first 4 s at 25 Hz, shapes at 5 Hz."""
    folder = tmp_path_factory.mktemp("deploy")
    path = folder / "run.mcap"
    assert deploy.main([*SMALL_SET, "--t-end", "4", "--rate", "25", "--mcap", str(path)]) == 0
    return path


def _rows(path):
    return list(csv.DictReader(path.open()))


def test_report_of_a_deploy_log(deploy_log, tmp_path, capsys, figure_checks):
    out = tmp_path / "report"
    assert report.main([str(deploy_log), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "sail parameters recorded in the log" in text
    assert "real-time factor not available" in text
    checks = {name: assert_figure(out / f"{name}.png", figure_checks) for name in FIGURES}
    assert not (out / "real_time_factor.png").exists()
    # boom a bent: b and d move alike (one line), c apart
    for name in ("tip_deflections", "root_moments"):
        (panel,) = checks[name].panels.values()
        assert panel.lines == ("boom a", "booms b, d", "boom c")
    booms, quadrants, total = checks["modal_energies"].panels.values()
    assert booms.lines == ("boom a", "booms b, d", "boom c")
    assert quadrants.lines == ("membranes ab, da", "membranes bc, cd")

    states = _rows(out / "states.csv")
    assert len(states) == 101 and float(states[-1]["t_s"]) == pytest.approx(4.0)
    assert float(states[0]["a_tip_deflection_m"]) == pytest.approx(0.1)
    energies = _rows(out / "energies.csv")
    first = energies[0]
    # boom a bent in its first mode at rest: all energy is boom a's strain energy
    model = SailModel(SMALL)
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


def _live_style_log(path, params, count=30, reset_at=None, time_scale=None, history=None,
                    tip_force_at=None):  # fmt: skip
    """What the recorder writes from a live simulator: stamps from a wall-clock
    epoch, /diagnostics with the integrator status, no parameters record.

    With `history`, the sail's mode counts and a time scale of 1.0 recorded as the
    simulator's parameters, and a change of the time scale to 2.0 received 50 ms after
    sample 12: as the recorder stores it ("record"), or as logs written before it did,
    on /parameter_events only ("events", next to an event of another node).

    With `reset_at` (a sample index) boom c's deflection grows by 2 % a sample and a
    reset at that sample sets it back: a fresh sample with the stamp of the one
    before, as a live simulator publishes it. With `time_scale`, /diagnostics says so
    every 5 samples, with the measurement window (0 before the first measurement). With
    `tip_force_at` (a sample index) the simulator's answer to a tip force of 0.05 N on
    boom b, applied at that sample."""
    model = SailModel(params)
    epoch = 1_700_000_000_000_000_000
    q0 = model.mode_state("c", 0.02)
    samples = [(i, i) for i in range(count)]  # (stamp index, samples since start or reset)
    if reset_at is not None:
        samples = [(i, i) for i in range(reset_at + 1)]
        samples += [(i, i - reset_at) for i in range(reset_at, count)]
    every = 10 if time_scale is None else 5
    with BagWriter(path) as bag:
        for topic, kind in (
            (topics.absolute(topics.BOOM_STATE), "sensor_msgs/msg/JointState"),
            (topics.absolute(topics.MODAL_STATE), "sensor_msgs/msg/JointState"),
            (topics.absolute(topics.TIP_DEFLECTION), "sensor_msgs/msg/JointState"),
            (topics.DIAGNOSTICS, "diagnostic_msgs/msg/DiagnosticArray"),
            (topics.absolute(topics.COMMAND_STATUS), "diagnostic_msgs/msg/DiagnosticArray"),
        ):
            bag.add_topic(topic, kind)
        if history is not None:
            _parameter_history(bag, history, params, change_ns=topics.stamp_ns(epoch, 1.25))
        for n, (i, age) in enumerate(samples):
            stamp = topics.stamp_ns(epoch, 0.1 * i)
            q = q0 * (1.0 + 0.02 * age) if reset_at is not None else q0
            lengths, rates = np.full(4, 20.0), np.zeros(4)
            messages = [
                (topics.BOOM_STATE, state_msg.boom_state(stamp, lengths, rates)),
                (
                    topics.MODAL_STATE,
                    state_msg.modal_state(stamp, model.coordinate_names, q, 0 * q),
                ),
                (
                    topics.TIP_DEFLECTION,
                    state_msg.tip_deflection(stamp, model.tip_deflections(q), np.zeros(4)),
                ),
            ]
            if n % every == 0:
                values = {
                    key.REAL_TIME_FACTOR: 0.98 + 0.01 * i / 10,
                    "step_time_ms": 0.4,
                    key.SIM_TIME: 0.1 * i,
                }
                if time_scale is not None:
                    values[key.TIME_SCALE] = time_scale
                    values[key.REAL_TIME_FACTOR_WINDOW] = 1.0 if n else 0.0
                    values[key.REAL_TIME_FACTOR] = time_scale * (0.997 + 0.001 * (n // every % 3))
                    if n == 0:
                        values[key.REAL_TIME_FACTOR] = 0.0  # not measured yet
                message = diagnostics_msg.diagnostics(stamp, "OK", "running", values)
                messages.append((topics.DIAGNOSTICS, message))
            if n == tip_force_at:
                answer = commands_msg.CommandAnswer(
                    topics.absolute(topics.TIP_FORCE_CMD), commands_msg.ACCEPTED, "held", 0, 1,
                    {"t_start_s": str(0.1 * i), commands_msg.LOADS_HELD: "[0.0, 0.05, 0.0, 0.0]"},
                )  # fmt: skip
                messages.append(
                    (topics.COMMAND_STATUS, commands_msg.command_status(stamp, [answer]))
                )
            for topic, message in messages:
                bag.write(topics.absolute(topic), serialize_message(message), log_time_ns=stamp)


def _parameter_history(bag, kind, params, change_ns):
    start = {
        "sail.n_boom_modes": str(params.n_boom_modes),
        "sail.n_membrane_modes": str(params.n_membrane_modes),
        "time_scale": "1.0",
    }
    bag.add_metadata(topics.PARAMETERS_METADATA, start)
    if kind == "record":
        change = ParameterChange("time_scale", "1.0", "2.0")
        record = changes_record_of("/sail_sim", change_ns - 1000, change_ns, [change])
        bag.add_metadata(topics.PARAMETER_CHANGES_METADATA, record)
        return
    bag.add_topic(topics.PARAMETER_EVENTS, "rcl_interfaces/msg/ParameterEvent")
    for node, value in (("/other", 7.0), ("/sail_sim", 2.0)):
        event = ParameterEvent(node=node)
        event.stamp.sec, event.stamp.nanosec = divmod(change_ns - 1000, 1_000_000_000)
        changed = Parameter("time_scale", value=value).to_parameter_msg()
        event.changed_parameters = [changed]
        bag.write(topics.PARAMETER_EVENTS, serialize_message(event), log_time_ns=change_ns)


def test_report_lists_the_parameter_changes_at_their_simulation_time(tmp_path, capsys):
    params = SailParameters(n_boom_modes=2, n_membrane_modes=3)
    log = tmp_path / "live.mcap"
    _live_style_log(log, params, history="record")
    out = tmp_path / "report"
    assert report.main([str(log), "--out", str(out)]) == 0  # the recorded mode counts
    text = capsys.readouterr().out
    assert (
        "parameter changes (1, from sail_sim_parameter_changes; t: simulation time t [s]):\n"
        "    t = 1.250 s  time_scale: 1.0 -> 2.0\n" in text
    )
    (row,) = _rows(out / "parameter_changes.csv")
    assert float(row.pop("t_s")) == pytest.approx(1.25)  # 50 ms after sample 12 (1.2 s)
    change_ns = topics.stamp_ns(1_700_000_000_000_000_000, 1.25)
    assert row == {
        "log_time_ns": str(change_ns),
        "time_ns": str(change_ns - 1000),
        "name": "time_scale",
        "old": "1.0",
        "new": "2.0",
    }


def test_parameter_changes_of_a_log_written_before_the_records_come_from_its_events(tmp_path):
    """A log with the changes only on /parameter_events still opens, and lists them."""
    log = tmp_path / "older.mcap"
    _live_style_log(log, SailParameters(n_boom_modes=2, n_membrane_modes=3), history="events")
    changes, source = parameter_changes(read_log(log))
    assert source == topics.PARAMETER_EVENTS
    (change,) = changes
    assert (change.name, change.old, change.new) == ("time_scale", "1.0", "2.0")
    assert change.t_s == pytest.approx(1.25)


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
    assert "parameter changes: none recorded" in text
    assert _rows(out / "parameter_changes.csv") == []
    assert_png(out / "real_time_factor.png", min_height=200)
    rtf = _rows(out / "real_time_factor.csv")
    assert [float(r[key.REAL_TIME_FACTOR]) for r in rtf] == pytest.approx([0.98, 0.99, 1.0])
    assert [float(r["t_s"]) for r in rtf] == pytest.approx([0.0, 1.0, 2.0])
    energies = _rows(out / "energies.csv")
    total = SailModel(params).energy(SailModel(params).mode_state("c", 0.02), np.zeros(20), 20.0)
    assert float(energies[5]["boom_c_J"]) == pytest.approx(total, rel=1e-9)


def test_report_of_a_live_log_with_a_reset_and_a_time_scale(tmp_path, capsys, figure_checks):
    """Every time history breaks at the reset instead of drawing a vertical stroke; the
    real-time factor is drawn against the time scale asked for (2), measured values
    only, on a y-range that shows their 0.2 % variation."""
    params = SailParameters(n_boom_modes=2, n_membrane_modes=3)
    log = tmp_path / "live.mcap"
    _live_style_log(log, params, reset_at=15, time_scale=2.0, tip_force_at=5)
    out = tmp_path / "report"
    argv = [str(log), "--out", str(out), "--set", "n_boom_modes=2", "--set", "n_membrane_modes=3"]
    assert report.main(argv) == 0
    # 7 statuses, the first before any measurement (its 0 is no factor)
    assert "min 1.99, max 2 over 6 diagnostics messages" in capsys.readouterr().out

    tips = assert_figure(out / "tip_deflections.png", figure_checks)
    ((title, panel),) = tips.panels.items()
    assert panel.lines[:2] == ("booms a, b, d", "boom c") and panel.segments[:2] == (2, 2)
    # a live run by its log's name; the tip force from 0.5 s, until the reset zeroes it
    assert title == "Boom-tip deflections live run, live.mcap"
    assert panel.marks == ("F_b 0.05 N", "F_b off")
    energies = assert_figure(out / "modal_energies.png", figure_checks)
    for panel in energies.panels.values():
        drawn = [k for k, label in enumerate(panel.lines) if label]  # not the load marks
        assert {panel.segments[k] for k in drawn} == {2}, panel
    # zeros cannot be drawn on the log axis: the legend says so
    booms = next(iter(energies.panels.values()))
    assert booms.lines[:2] == ("booms a, b, d (0 J throughout)", "boom c")
    assert_figure(out / "boom_lengths.png", figure_checks)

    rtf = assert_figure(out / "real_time_factor.png", figure_checks, min_height=200)
    (panel,) = rtf.panels.values()
    assert panel.lines == ("achieved", "time scale asked for (2)")
    low, high = panel.ylim
    measured = [float(r[key.REAL_TIME_FACTOR]) for r in _rows(out / "real_time_factor.csv")][1:]
    assert low < min(measured) and max(max(measured), 2.0) < high
    assert high - low < 0.1  # the variation (0.004) fills a visible part of the axis


def _two_runs(path, change: str) -> None:
    """A log of a simulator run then another, 10 samples each, as a recorder that kept
    running while the simulator was restarted writes it: the second with another sail
    ("sail", its parameters stored again; the same state size and epoch), other mode
    counts ("size", no parameters stored; the same epoch), or the same sail started
    again ("epoch", a new epoch)."""
    epoch = 1_700_000_000_000_000_000
    first = SailParameters(n_boom_modes=2, n_membrane_modes=2)
    second = {
        "sail": first.replace(boom_bending_stiffness=2 * first.boom_bending_stiffness),
        "size": first.replace(n_boom_modes=3),
        "epoch": first,
    }[change]
    state = topics.absolute(topics.MODAL_STATE)
    with BagWriter(path) as bag:
        bag.add_topic(state, "sensor_msgs/msg/JointState")
        bag.add_topic(topics.DIAGNOSTICS, "diagnostic_msgs/msg/DiagnosticArray")
        for run, params in enumerate((first, second)):
            if change == "sail":
                record = {f"sail.{k}": str(v) for k, v in params.to_dict().items()}
                bag.add_metadata(topics.PARAMETERS_METADATA, record)
            model = SailModel(params)
            start = epoch + run * (1_000_000_000 if change != "epoch" else 3_000_000_000)
            for i in range(10):
                t = 0.1 * i + (run if change != "epoch" else 0.0)  # sim time, the run's
                stamp = topics.stamp_ns(epoch if change != "epoch" else start, t)
                q = model.mode_state("a", 0.01)
                messages = [(state, state_msg.modal_state(stamp, model.coordinate_names, q, q))]
                if i % 5 == 0:
                    status = {key.SIM_TIME: t, key.REAL_TIME_FACTOR: 1.0}
                    messages.append(
                        (topics.DIAGNOSTICS, diagnostics_msg.diagnostics(stamp, "OK", "", status))
                    )
                for topic, message in messages:
                    bag.write(topic, serialize_message(message), log_time_ns=stamp)


@pytest.mark.parametrize(
    ("change", "what"),
    [
        ("sail", "the sail parameters change (sail.boom_bending_stiffness 6000.0 -> 12000.0)"),
        ("size", "/sail/modal_state changes from 16 to 20 joints 1.000 s after its first message"),
        ("epoch", "its /diagnostics tell another start 3.000 s after the first (epoch "),
    ],
)
def test_a_log_of_a_simulator_restarted_under_the_recorder_is_refused(
    tmp_path, capsys, change, what
):
    """A recorder that ran on while the simulator was restarted holds two runs: the report
    refuses the log in one line saying what changed, rather than read it as one run
    (the old mode counts for the new state, energies that stop at the restart)."""
    log = tmp_path / "two_runs.mcap"
    _two_runs(log, change)
    argv = [str(log), "--out", str(tmp_path / "report"), "--set", "n_boom_modes=2"]
    assert report.main([*argv, "--set", "n_membrane_modes=2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: '{log}' holds more than one run of the simulator: {what}")
    assert err.endswith("a report covers one run: record each run on its own\n")
    assert err.count("\n") == 1
    assert not (tmp_path / "report").exists()


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
    # the accuracy asked of tips: 0.2 % of their peak, the largest boom's
    largest = max(float(rows["rerun"][f"peak_tip_{boom}_m"]) for boom in "abcd")
    for boom in "abcd":
        sampled = max(abs(float(row[f"{boom}_tip_deflection_m"])) for row in states)
        logged = float(rows["log"][f"peak_tip_{boom}_m"])
        rerun = float(rows["rerun"][f"peak_tip_{boom}_m"])
        assert sampled <= logged * (1 + 1e-12)
        assert logged == pytest.approx(rerun, abs=2e-3 * largest)
    assert report.main([str(deploy_log), "--out", str(out), "--no-convergence"]) == 0
    assert {row["source"] for row in _rows(out / "peaks.csv")} == {"log", "rerun"}


def test_report_of_a_free_hub_log_gives_its_peaks_figure_and_states(
    tmp_path, capsys, figure_checks
):
    """config/scenario_free_hub.yaml logged at 10 Hz: states.csv carries the hub's six
    values under the states table's names (`record.column_names`), as logged; peaks.csv
    its peaks interpolated between the samples (at least the largest sample, within
    1e-4 of the rerun's true peaks) and the rerun's; hub_attitude.png draws the tilt,
    heave and the holds of the recorded scenario."""
    from harness import CONFIG

    from sail_ros.model.record import column_names

    log_path = tmp_path / "hub.mcap"
    scenario = CONFIG / "scenario_free_hub.yaml"
    argv = [*SMALL_SET, "--scenario", str(scenario), "--rate", "10", "--mcap", str(log_path)]
    assert deploy.main(argv) == 0
    out = tmp_path / "report"
    assert report.main([str(log_path), "--out", str(out), "--no-convergence"]) == 0
    text = capsys.readouterr().out
    assert "free hub: |z_h| up to" in text and "free hub (true peaks of the rerun):" in text

    log = read_log(log_path)
    stamps, hub = log.hub
    hub_columns = column_names(True)[len(column_names(False)) :]
    assert hub_columns[0] == "hub_z_h_m" and len(hub_columns) == 6
    with (out / "states.csv").open() as stream:
        header = next(csv.reader(stream))
    assert header[-6:] == hub_columns
    states = _rows(out / "states.csv")
    assert [int(row["stamp_ns"]) for row in states] == stamps.tolist()
    table = np.array([[float(row[name]) for name in hub_columns] for row in states])
    np.testing.assert_array_equal(table, hub)

    rows = {row["source"]: row for row in _rows(out / "peaks.csv")}
    names = ("heave_m", "tilt_x_rad", "tilt_y_rad", "tilt_rad")
    logged = np.array([float(rows["log"][f"peak_hub_{name}"]) for name in names])
    rerun = np.array([float(rows["rerun"][f"peak_hub_{name}"]) for name in names])
    sampled = np.abs(hub[:, :3]).max(axis=0).tolist() + [np.hypot(hub[:, 1], hub[:, 2]).max()]
    assert np.all(logged >= np.array(sampled) * (1 - 1e-12))
    np.testing.assert_allclose(logged, rerun, rtol=1e-4)
    assert rerun[1] > 0.08  # boom d jams: the pressure tilts the hub about x

    check = assert_figure(out / "hub_attitude.png", figure_checks)
    assert len(check.panels) >= 3  # tilt, heave, holds
