"""`sail-ros deploy`: the summary table, scenarios, the MCAP log and the figures."""

import json
import re

import numpy as np
import pytest
import yaml
from harness import CONFIG, SMALL, SMALL_SET, assert_figure
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from sail_ros import topics
from sail_ros.analysis.scenario import REFERENCE, load_scenario, scenario_from_dict
from sail_ros.bag import BagReader
from sail_ros.integrate.control import DEFAULT_ATOL
from sail_ros.integrate.peaks import MAX_SPACING_S, PEAK_ERROR
from sail_ros.messages import hub as hub_msg
from sail_ros.model import SailModel, SailParameters
from sail_ros.nodes.recorder import PARAMETERS_METADATA
from sail_ros.policy import Policy
from sail_ros.runtime.config import PARAMETERS, config_from_values
from sail_ros.tools import deploy

pytestmark = pytest.mark.model


SHORT = """
scenario:
  description: short staggered test
  duration: 2.0
  profile:
    a: {type: cycloidal, start: 10.0, end: 11.0, duration: 2.0}
    b: {type: waypoints, times: [0.0, 1.0, 2.0], lengths: [10.0, 10.4, 11.0]}
    c: {type: static, lengths: 10.0}
    d: {type: cycloidal, start: 10.0, end: 11.0, duration: 1.0, t0: 1.0}
  initial:
    mode_state: {b: 0.05}
    q0: {membrane_ab_mode_2_1: 0.01}
  snapshots: [0.0, 1.0, 2.0]
sail:
  n_boom_modes: 3
  n_membrane_modes: 3
"""


def test_summary_prints_the_reference_table(capsys):
    assert deploy.main(["--summary"]) == 0
    out = capsys.readouterr().out
    assert "booms 10 m -> 15 m in 15 s (cycloidal), boom a tip 0.1 m at t = 0" in out
    rows = [
        line.split() for line in out.splitlines() if line[:9].strip().replace(".", "").isdigit()
    ]
    assert [float(r[0]) for r in rows] == list(np.arange(16.0))
    assert rows[0][1:] == ["10.000", "100.000", "0.000", "0.000", "0.000"]
    assert rows[-1][1] == "15.000"
    assert "x real time)" in out
    # the tolerance and the achieved estimate, within twice the run's tolerance (no warning)
    found = re.search(
        r"(\d+) steps \((\d+) refused\) at rtol 0\.001; error estimate: tips ([0-9.]+) %, "
        r"root moments ([0-9.]+) % of peak",
        out,
    )
    assert found and int(found[1]) > 10 and 0.0 < float(found[3]) < 0.4, out
    assert 0.0 < float(found[4]) < 0.4
    assert deploy.main(["--summary", "--rtol", "0"]) == 0
    assert "steps (0 refused) of fixed length: no error estimate" in capsys.readouterr().out


def test_atol_floors_reach_the_run_its_summary_and_its_json(capsys):
    """Below rtol x peak the default floors set the steps (the reference deployment's
    tips peak near 0.1 m: at rtol 1e-6 the tips' 1e-6 m floor binds); smaller ones asked
    with --atol take more steps to a smaller estimate, and both outputs say which."""
    base = ["--json", *SMALL_SET, "--rtol", "1e-6"]
    assert deploy.main(base) == 0
    default = json.loads(capsys.readouterr().out)
    assert deploy.main([*base, "--atol", "tips=1e-8", "root_moments=1e-6"]) == 0
    floored = json.loads(capsys.readouterr().out)
    assert default["atol"] == DEFAULT_ATOL
    assert floored["atol"] == {**DEFAULT_ATOL, "tips": 1e-8, "root_moments": 1e-6}
    assert floored["steps"] > default["steps"]
    for kind in ("tips", "root_moments"):
        estimate = floored["relative_error_estimate"][kind]
        assert estimate < 0.8 * default["relative_error_estimate"][kind], (kind, estimate)
    assert deploy.main([*SMALL_SET, "--rtol", "1e-6", "--atol", "tips=1e-8", "--every", "5"]) == 0
    assert "at rtol 1e-06 (atol tips 1e-08 m); error estimate" in capsys.readouterr().out
    assert deploy.main(["--json", *SMALL_SET, "--rtol", "0"]) == 0
    assert json.loads(capsys.readouterr().out)["atol"] is None  # fixed steps: no tolerance


def test_reference_file_is_the_built_in_reference():
    assert (
        load_scenario(CONFIG / "scenario_reference.yaml").document
        == scenario_from_dict(REFERENCE).document
    )


def test_every_shipped_scenario_loads():
    for path in sorted(CONFIG.glob("scenario_*.yaml")):
        scenario = load_scenario(path)
        lengths, rates, _ = scenario.profile(0.5 * scenario.duration)
        assert np.all(lengths > 0) and np.all(np.isfinite(rates)), path


def test_scenario_run_writes_a_simulator_log_and_figures(tmp_path, capsys, figure_checks):
    scenario = tmp_path / "short.yaml"
    scenario.write_text(SHORT)
    log = tmp_path / "logs" / "short.mcap"
    assert (
        deploy.main(
            [
                "--scenario",
                str(scenario),
                "--rate",
                "10",
                "--shape-rate",
                "2",
                "--mcap",
                str(log),
                "--figures",
                str(tmp_path / "fig"),
                "--summary",
                # its quick moves are beyond the simulator's default limits
                "--set",
                "max_rate=2",
                "--set",
                "max_acceleration=7",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "short staggered test" in out and f"wrote {log}" in out

    bag = BagReader(log)
    counts = {name: info.message_count for name, info in bag.topics().items()}
    assert counts == {
        topics.CLOCK: 21,
        topics.absolute(topics.BOOM_STATE): 21,
        topics.absolute(topics.MODAL_STATE): 21,
        topics.absolute(topics.TIP_DEFLECTION): 21,
        topics.absolute(topics.ROOT_MOMENT): 21,
        topics.absolute(topics.SHAPE): 5,
    }
    metadata = dict(bag.metadata())
    parameters = metadata[PARAMETERS_METADATA]
    # the simulator's own names and value syntax: its validator accepts them
    assert set(parameters) <= set(PARAMETERS)
    config = config_from_values({name: yaml.safe_load(text) for name, text in parameters.items()})
    assert (config.integration_step, config.state_rate_hz, config.shape_rate_hz) == (0.1, 10, 2)
    assert (config.max_model_step, config.model_rtol) == (0.5, 1e-3)  # the run's accuracy
    assert (config.sail.n_boom_modes, config.sail.n_membrane_modes) == (3, 3)
    np.testing.assert_allclose(config.initial_lengths, [10.0] * 4)
    np.testing.assert_allclose(config.initial_tip_deflection, [0.0, 0.05, 0.0, 0.0], atol=1e-12)

    model = SailModel(config.sail)
    modal = [m for m in bag.messages([topics.absolute(topics.MODAL_STATE)])]
    # stamps, log times and publish times are simulation time since the Unix epoch
    assert [m.log_time_ns for m in modal] == [round(t * 1e8) for t in range(21)]
    last = deserialize_message(modal[-1].data, JointState)
    assert list(last.name) == model.coordinate_names
    assert last.header.stamp.sec == 2 and last.header.stamp.nanosec == 0
    boom = deserialize_message(
        next(bag.messages([topics.absolute(topics.BOOM_STATE)])).data, JointState
    )
    assert list(boom.name) == list(topics.BOOM_JOINTS)

    with AnyReader([log]) as reader:  # a strict third-party reader takes every message
        assert sum(1 for _ in reader.messages()) == sum(counts.values())  # 110

    for name in ("deployment_snapshots", "tip_deflections", "boom_lengths"):
        assert_figure(tmp_path / "fig" / f"{name}.png", figure_checks)


def test_figures_of_the_loaded_scenario_fit_its_description_and_show_every_boom(
    tmp_path, figure_checks
):
    """config/scenario_loaded.yaml (few modes): its long description wraps inside each
    figure; booms a and b deploy at one rate from different lengths, so the rate panel
    has one line for both and the length panel one for each."""
    figures = tmp_path / "fig"
    argv = ["--scenario", str(CONFIG / "scenario_loaded.yaml"), "--figures", str(figures),
            "--rate", "10", "--set", "n_boom_modes=2", "--set", "n_membrane_modes=3"]  # fmt: skip
    assert deploy.main(argv) == 0
    checks = {
        name: assert_figure(figures / f"{name}.png", figure_checks)
        for name in ("deployment_snapshots", "tip_deflections", "boom_lengths")
    }
    lengths, rates = checks["boom_lengths"].panels.values()
    assert lengths.lines == ("boom a", "boom b", "boom c", "boom d")
    assert rates.lines == ("booms a, b", "boom c", "boom d")
    (tips,) = checks["tip_deflections"].panels.values()
    assert tips.lines == ("boom a", "boom b", "boom c", "boom d", "", "")  # and 2 load changes
    assert tips.ylabel == "tip deflection [mm]" and rates.ylabel == "extension rate [m/s]"


@pytest.mark.parametrize(
    ("document", "message"),
    [
        (
            "scenario: {duration: 1.0, profile: {type: spiral}}",
            "scenario.profile.type must be one of cycloidal, waypoints, static, got 'spiral'",
        ),
        (
            "scenario: {duration: 1.0, profile: {type: cycloidal, start: 10, end: 11}}",
            "scenario.profile (cycloidal) needs duration",
        ),
        (
            "scenario: {duration: 1.0, profile: {a: {type: static, lengths: 1.0}}}",
            "one profile for each boom a, b, c, d",
        ),
        (
            "scenario: {duration: 1.0, profile: {type: static, lengths: 5.0}, "
            "initial: {q0: {boom_e_mode_1: 1.0}}}",
            "unknown coordinate 'boom_e_mode_1'",
        ),
        (
            "scenario: {duration: 1.0, profile: {type: static, lengths: 5.0}, snapshots: [2.0]}",
            "scenario.snapshots[0] = 2.0 s is outside [0, duration = 1 s]",
        ),
        (
            "scenario: {duration: -1.0, profile: {type: static, lengths: 5.0}}",
            "scenario.duration must be > 0 s, got -1.0",
        ),
        (
            "scenario: {duration: 5.0, profile: {type: static, lengths: 5.0}, "
            "loads: [{at: 1.0, force: 1.0}]}",
            "scenario.loads[0]: unknown key(s) 'force'",
        ),
        (
            "scenario: {duration: 5.0, profile: {type: static, lengths: 5.0}, "
            "loads: [{at: 2.0, tip_forces: 1.0}, {at: 1.0, tip_forces: 0.0}]}",
            "times must be finite and increasing, got 1.0",
        ),
        (
            "scenario: {duration: 5.0, profile: {type: static, lengths: 5.0}, "
            "loads: [{at: 9.0, pressures: 1.0e-3}]}",
            "scenario.loads[0].at = 9.0 s is outside [0, duration = 5 s]",
        ),
        (
            "scenario: {duration: 5.0, profile: {type: static, lengths: 5.0}, "
            "loads: [{at: 1.0, pressures: [1, 2]}]}",
            "pressures must be a scalar or 4 values",
        ),
    ],
    ids=[
        "type",
        "missing",
        "per-boom",
        "coordinate",
        "snapshot",
        "duration",
        "load-key",
        "load-order",
        "load-time",
        "load-shape",
    ],  # fmt: skip
)
def test_scenario_errors_name_the_entry(tmp_path, capsys, document, message):
    path = tmp_path / "bad.yaml"
    path.write_text(document)
    assert deploy.main(["--scenario", str(path)]) == 2
    assert message in capsys.readouterr().err


def test_a_loaded_damped_scenario_logs_root_moments_and_switches_on_step_boundaries(tmp_path):
    """config/scenario_loaded.yaml: the log holds the root moments at every state sample;
    the load switches join the output grid (steps land on them), and the loads change
    the root moments."""
    from sail_ros.analysis.deployment import run_deployment
    from sail_ros.analysis.scenario import scenario_from_dict

    log = tmp_path / "loaded.mcap"
    scenario_path = CONFIG / "scenario_loaded.yaml"
    assert deploy.main(["--scenario", str(scenario_path), "--mcap", str(log), "--rate", "10"]) == 0
    counts = {name: info.message_count for name, info in BagReader(log).topics().items()}
    assert counts[topics.absolute(topics.ROOT_MOMENT)] == counts[topics.absolute(topics.BOOM_STATE)]

    scenario = load_scenario(scenario_path)
    model = SailModel(SailParameters(**scenario.sail))
    loaded = run_deployment(model, scenario, [2.0, 5.0, 12.0])
    assert {3.0, 7.0} <= set(loaded.t.tolist())  # the switches joined the grid
    document = yaml.safe_load(scenario_path.read_text())
    del document["scenario"]["loads"]
    unloaded = run_deployment(model, scenario_from_dict(document), [2.0, 5.0, 12.0])
    common = np.isin(loaded.t, unloaded.t)
    assert np.abs(loaded.root_moments[common] - unloaded.root_moments).max() > 0.1  # N m
    assert loaded.root_moments.shape == (len(loaded.t), 4)


@pytest.mark.parametrize("case", ["loaded", "leaves the range"])
def test_a_run_without_states_has_the_same_tips_peaks_and_end(case):
    """`run_deployment(states=False)`, a Monte Carlo sample's run: the tips at every
    output time from the steps' curve, the sampled states' to round-off, the same steps,
    peaks and end, the rest of the state nan; a run that leaves the linear range keeps
    the same outputs before its alarm."""
    from sail_ros.analysis.deployment import run_deployment
    from sail_ros.analysis.scenario import scenario_from_dict

    if case == "loaded":
        scenario = load_scenario(CONFIG / "scenario_loaded.yaml")
        t_eval = np.arange(0.0, 12.05, 0.1)
    else:  # as test_tool_policy's retraction: a 4 m tip passes 0.3 of a shrinking boom
        profile = {"type": "cycloidal", "start": 15.0, "end": 10.0, "duration": 5.0}
        document = {"scenario": {"duration": 6.0, "profile": profile,
                                 "initial": {"mode_state": {"a": 4.0}}}}  # fmt: skip
        scenario = scenario_from_dict(document)
        t_eval = np.arange(0.0, 6.05, 0.1)
    model = SailModel(SMALL.replace(**scenario.sail))
    policy = Policy(max_rate=3.0, max_acceleration=2.0)
    full = run_deployment(model, scenario, t_eval, rates=None, policy=policy)
    lean = run_deployment(model, scenario, t_eval, states=False, policy=policy)
    assert np.array_equal(lean.t, full.t) and lean.alarm == full.alarm
    assert bool(lean.alarm) == (case == "leaves the range")
    assert lean.accuracy.steps == full.accuracy.steps
    np.testing.assert_allclose(lean.tips, full.tips, rtol=0, atol=1e-12 * np.abs(full.tips).max())
    for kind in ("tip_deflection", "root_moment"):
        for part in (0, 1):  # values, times
            assert np.array_equal(getattr(lean.peaks, kind)[part], getattr(full.peaks, kind)[part])
    # the state only where an output is a step's end (the start, the load switches, the
    # end, a few by chance): the same there
    ends = np.isfinite(lean.q).all(axis=1)
    assert ends[0] and ends.sum() < 0.1 * ends.size and np.isnan(lean.q[~ends]).all()
    np.testing.assert_array_equal(lean.q[ends], full.q[ends])
    if not lean.alarm:
        assert ends[-1] and np.array_equal(lean.qd[-1], full.qd[-1])


def test_a_run_stopped_by_its_alarm_has_no_peak_after_the_stop():
    """The alarm falls inside a step: the peaks are searched up to it, not over the rest
    of that step (boom a's root moment peaked 13 ms after the stop here)."""
    from sail_ros.analysis.deployment import run_deployment
    from sail_ros.analysis.scenario import scenario_from_dict

    profile = {"type": "cycloidal", "start": 15.0, "end": 10.0, "duration": 15.0}
    document = {"scenario": {"duration": 15.0, "profile": profile,
                             "initial": {"mode_state": {"a": 4.0}}}}  # fmt: skip
    scenario = scenario_from_dict(document)
    model = SailModel(SMALL)
    run = run_deployment(model, scenario, np.arange(0.0, 15.05, 0.1), states=False)
    stop = float(run.alarm.split("stopped at t = ")[1].split(" s")[0])
    assert 9.0 < stop < 9.3, run.alarm
    for peak in (run.peaks.tip_deflection, run.peaks.root_moment):  # (printed to 10 us)
        assert np.all(peak.time_s <= stop + 5e-6), (peak.time_s, stop)


def test_a_batched_range_check_stops_where_a_check_after_every_step_does(monkeypatch):
    """The peaks sample up to 16 steps at a time (`peaks.BATCH_STEPS`), so the range
    check comes up to 16 steps late: the run still stops at its first sample out of
    range, with the same alarm and outputs as a check after every step, the stepper
    further on. A batch spaces its samples by the largest values before it, so the
    samples, and the times of the warning and the stop, may differ by a sample spacing;
    the peaks by their error."""
    import sail_ros.integrate.peaks as peaks_module
    from sail_ros.analysis.deployment import run_deployment
    from sail_ros.analysis.scenario import scenario_from_dict

    profile = {"type": "cycloidal", "start": 15.0, "end": 10.0, "duration": 15.0}
    document = {"scenario": {"duration": 15.0, "profile": profile,
                             "initial": {"mode_state": {"a": 4.0}}}}  # fmt: skip
    scenario = scenario_from_dict(document)
    model = SailModel(SMALL)
    t_eval = np.arange(0.0, 15.05, 0.1)
    runs, batched_steps = {}, peaks_module.BATCH_STEPS
    for batch in (batched_steps, 1):
        monkeypatch.setattr(peaks_module, "BATCH_STEPS", batch)
        for states in (False, True):
            runs[batch, states] = run_deployment(model, scenario, t_eval, states=states)
    for states in (False, True):
        batched, single = runs[batched_steps, states], runs[1, states]
        times = {}
        for text in ("alarm", "warning"):
            found, expected = getattr(batched, text), getattr(single, text)
            time_s = [float(re.search(r"t = ([0-9.]+) s", m).group(1)) for m in (found, expected)]
            assert abs(time_s[0] - time_s[1]) <= MAX_SPACING_S, (found, expected)
            times[text] = min(time_s)
            subject = [re.search(r" s: (.+?) is ", m).group(1) for m in (found, expected)]
            assert subject[0] == subject[1]  # the output and boom
        assert "stopped at t = 9." in single.alarm and "tip deflection of boom a" in single.alarm
        assert batched.t.size == single.t.size and np.array_equal(batched.t, single.t)
        scale = np.abs(single.tips).max()
        np.testing.assert_allclose(batched.tips, single.tips, rtol=0, atol=1e-12 * scale)
        assert batched.accuracy.steps > single.accuracy.steps
        # a peak at the stop (the tip leaving the range) is where each run stopped
        stop = times["alarm"] - MAX_SPACING_S
        for kind in ("tip_deflection", "root_moment"):
            found, expected = getattr(batched.peaks, kind), getattr(single.peaks, kind)
            before = expected.time_s < stop
            assert before.sum() >= 3 and np.all(found.time_s[~before] >= stop)
            np.testing.assert_allclose(found.value[before], expected.value[before], rtol=PEAK_ERROR)


def test_reference_options_conflict_with_a_scenario(capsys):
    path = CONFIG / "scenario_reference.yaml"
    assert deploy.main(["--scenario", str(path), "--from", "5", "--tip", "0.2"]) == 2
    assert "--from, --tip describe the reference scenario" in capsys.readouterr().err


def test_json_gives_true_peaks_per_boom_and_their_convergence(capsys):
    """`--json`: one object with every boom's true peaks and times (those of the run's
    own steps, not of the printed 1 s table), the parameters, mode counts and wall time;
    `--convergence 4 10` reruns with more membrane modes, which moves the peaks by far
    more than 1 % of the largest: a warning says so."""
    import json

    from sail_ros.analysis.deployment import run_deployment

    argv = ["--t-end", "6", "--set", "n_boom_modes=4", "--set", "n_membrane_modes=3"]
    assert deploy.main([*argv, "--json", "--convergence", "4", "10"]) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out, parse_constant=strict_json)
    assert report["n_boom_modes"] == 4 and report["n_membrane_modes"] == 3
    # the limits in force: max_length 0 stands for the full boom length
    assert report["limits"]["max_length"] == pytest.approx(100.0 / np.sqrt(2.0))
    assert report["limits"]["min_length"] == 5.0
    assert report["parameters"]["n_membrane_modes"] == 3 and report["wall_time_s"] > 0
    scenario = deploy._scenario(deploy.build_parser().parse_args(argv))[0]
    model = SailModel(SailParameters(n_boom_modes=4, n_membrane_modes=3))
    peaks = run_deployment(model, scenario, np.arange(7.0)).peaks
    for key, peak in (("peak_tip_deflection", peaks.tip_deflection),
                      ("peak_root_moment", peaks.root_moment)):  # fmt: skip
        unit = "_m" if key.endswith("deflection") else "_Nm"
        assert list(report[key + unit]) == ["a", "b", "c", "d"]
        assert [report[key + unit][b] for b in "abcd"] == pytest.approx(peak.value, rel=1e-12)
        assert [report[key + "_time_s"][b] for b in "abcd"] == pytest.approx(peak.time_s)
    # the true peak of boom a's tip lies between the printed seconds
    table = deploy.main(argv) == 0 and capsys.readouterr().out
    printed = [float(line.split()[2]) for line in table.splitlines()
               if line[:9].strip().replace(".", "").isdigit()]  # fmt: skip
    assert 1e3 * peaks.tip_deflection.value[0] > max(abs(v) for v in printed)
    assert "peaks over the whole run, per boom" in table and "|root moment| [N m]" in table
    convergence = report["convergence"]
    (level,) = convergence["levels"]
    assert (level["n_boom_modes"], level["n_membrane_modes"]) == (4, 10)
    changes = [convergence["root_moment_change"][b] for b in "abcd"]
    assert max(map(abs, changes)) > 0.01 and convergence["converged"] is False
    assert "warning: peaks not converged" in captured.err and "moment b" in captured.err


def strict_json(constant: str):
    """A `json.loads` hook for NaN and Infinity, which JSON does not have."""
    raise AssertionError(f"{constant} in the JSON")


def test_the_convergence_table_gives_each_change_against_the_largest_and_its_own_peak(capsys):
    """Under each peak and its time, its change against the finest rerun: over the
    largest peak of its kind and over the boom's own, the numbers of --json."""
    import json

    argv = ["--t-end", "2", "--set", "n_boom_modes=2", "--set", "n_membrane_modes=2",
            "--convergence", "2", "4"]  # fmt: skip
    assert deploy.main([*argv, "--json"]) == 0
    convergence = json.loads(capsys.readouterr().out)["convergence"]
    assert deploy.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    start = lines.index(next(line for line in lines if line.startswith("  peaks over")))
    labels = [" ".join(line.split()[:-4]) for line in lines[start + 2 : start + 10]]
    assert labels == [
        "|tip deflection| [mm]", "at t [s]",
        "change against (2, 4) modes, % of the largest",
        "change against (2, 4) modes, % of its own peak",
        "|root moment| [N m]", "at t [s]",
        "change against (2, 4) modes, % of the largest",
        "change against (2, 4) modes, % of its own peak",
    ]  # fmt: skip
    for row, key in ((4, "tip_deflection_change"), (5, "tip_deflection_change_own"),
                     (8, "root_moment_change"), (9, "root_moment_change_own")):  # fmt: skip
        printed = [float(v) for v in lines[start + row].split()[-4:]]
        assert printed == pytest.approx([100 * convergence[key][b] for b in "abcd"], abs=6e-4)


def test_a_run_where_nothing_moves_has_peaks_of_zero_and_no_times(tmp_path, capsys):
    """A peak of 0 has no time: the table prints a dash for it, --json null (JSON has
    no NaN)."""
    import json

    path = tmp_path / "still.yaml"
    path.write_text("scenario: {duration: 1.0, profile: {type: static, lengths: 12.0}}\n")
    argv = [*SMALL_SET, "--scenario", str(path)]
    assert deploy.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    times = [line.split() for line in lines if line.strip().startswith("at t [s]")]
    assert times == [["at", "t", "[s]", "-", "-", "-", "-"]] * 2
    assert deploy.main([*argv, "--json"]) == 0
    report = json.loads(capsys.readouterr().out, parse_constant=strict_json)
    assert report["peak_tip_deflection_m"] == dict.fromkeys("abcd", 0.0)
    assert report["peak_tip_deflection_time_s"] == dict.fromkeys("abcd", None)


def test_unequal_booms_each_have_their_length_in_the_table(capsys):
    """config/scenario_loaded.yaml's booms start at 10, 11, 10 and 12 m: a column each."""
    argv = [*SMALL_SET, "--scenario", str(CONFIG / "scenario_loaded.yaml"), "--every", "6"]
    assert deploy.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.strip().startswith("t [s]"))
    assert header.split()[:10] == ["t", "[s]", "L_a", "[m]", "L_b", "[m]", "L_c", "[m]",
                                   "L_d", "[m]"]  # fmt: skip
    first = lines[lines.index(header) + 1].split()
    assert first[:5] == ["0.00", "10.000", "11.000", "10.000", "12.000"]


def test_a_study_file_given_as_a_scenario_is_named_in_one_short_line(capsys):
    assert deploy.main(["--scenario", str(CONFIG / "study_reference.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) < 200, err
    assert "got a mapping of 'study' (a study file: sail-ros montecarlo runs it)" in err


def test_the_default_convergence_reruns_finer_until_the_peaks_settle_or_says_they_did_not(
    capsys,
):
    """`--convergence` without counts (the guide's command, CI-sized): finer reruns one
    after another, each named with how far it moved the peaks before it; from (4, 6) they
    do not settle within the reruns allowed, which the warning says with the counts."""
    assert deploy.main([*SMALL_SET, "--convergence"]) == 0
    captured = capsys.readouterr()
    reruns = [line.split("=")[1].split(":")[0].strip() for line in captured.out.splitlines()
              if line.strip().startswith("rerun at (n_B, n_M)")]  # fmt: skip
    assert len(reruns) >= 2 and reruns[0] != "(4, 6)", reruns
    assert f"change against {reruns[-1]} modes, % of the largest" in captured.out
    assert "peaks not converged" in captured.err and reruns[-1] in captured.err


def test_convergence_needs_more_modes(capsys):
    assert deploy.main(["--convergence", "4", "6"]) == 2
    assert "must grow from the run's (n_B, n_M) = (8, 181)" in capsys.readouterr().err
    assert deploy.main(["--convergence", "8"]) == 2
    assert "--convergence takes no value or two (N_B N_M)" in capsys.readouterr().err


def test_a_free_hubs_log_gives_back_its_attitude(tmp_path):
    """`deploy --mcap` of config/scenario_free_hub.yaml: the log reader's hub series (from
    each /sail/hub_state's pose and twist, the tilts from the quaternion) is the run's
    hub state at every stamp to 1e-12, tilts of several degrees included."""
    from sail_ros.analysis.deployment import run_deployment
    from sail_ros.analysis.log_series import read_log

    path = tmp_path / "hub.mcap"
    scenario_file = CONFIG / "scenario_free_hub.yaml"
    argv = [*SMALL_SET, "--scenario", str(scenario_file), "--rate", "10", "--mcap", str(path)]
    assert deploy.main(argv) == 0
    log = read_log(path)
    scenario = load_scenario(scenario_file)
    model = SailModel(SMALL.replace(**scenario.sail))
    run = run_deployment(model, scenario, log.seconds(log.hub[0]))
    assert log.hub[1].shape == (201, 6) and np.degrees(np.abs(log.hub[1][:, 1]).max()) > 4.0
    np.testing.assert_allclose(log.hub[1], run.hub, rtol=0, atol=1e-12 * np.abs(run.hub).max())
    assert log.field("hub") is log.hub  # the record's fields through their messages
    stamps, tips = log.field("tips")
    assert stamps is log.tips.stamp_ns and tips is log.tips.position
    assert log.field("root_moments")[1] is log.moments.effort


@pytest.mark.parametrize("tilt", [(0.0, 0.0), (1e-9, -2e-9), (0.3, -0.4), (2.0, 1.0)])
def test_hub_state_messages_give_back_the_hubs_state(tilt):
    """`messages.hub.hub_from_odometry` inverts `messages.hub.hub_state`, from 1e-9 rad
    to 2.2 rad."""
    hub = np.array([0.25, *tilt, -0.01, 0.02, -0.03])
    message = hub_msg.hub_state(5, hub)
    np.testing.assert_allclose(hub_msg.hub_from_odometry(message), hub, rtol=1e-14, atol=1e-17)


def test_a_free_hub_deployment_prints_its_attitude_peaks_and_hold_reactions(
    tmp_path, capsys, figure_checks
):
    """config/scenario_free_hub.yaml: beside the boom tables a hub table (heave [mm], tilts
    and |theta| [mrad], their rates) at the run's states; the hub's true peaks; the holds'
    peak reactions, the in-plane force within 1e-4 of a five times finer sampling and no
    spin torque (booms a and c move alike); --json carries the same; --figures adds
    hub_attitude.png."""
    import json

    from sail_ros.analysis.deployment import hold_reactions, run_deployment

    scenario_file = CONFIG / "scenario_free_hub.yaml"
    argv = [*SMALL_SET, "--scenario", str(scenario_file), "--every", "5"]
    assert deploy.main([*argv, "--summary", "--rate", "10", "--figures", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    scenario = load_scenario(scenario_file)
    model = SailModel(SMALL.replace(**scenario.sail))
    run = run_deployment(model, scenario, [0.0, 5.0, 10.0, 15.0, 20.0])

    lines = out.splitlines()
    start = lines.index(next(line for line in lines if line.startswith("  free hub: heave")))
    assert lines[start + 1].split() == ["t", "[s]", "z_h", "[mm]", "theta_x", "[mrad]",
        "theta_y", "[mrad]", "|theta|", "[mrad]", "zd_h", "[mm/s]", "thd_x", "[mrad/s]",
        "thd_y", "[mrad/s]"]  # fmt: skip
    rows = np.array([[float(v) for v in line.split()] for line in lines[start + 2 : start + 7]])
    assert rows[:, 0].tolist() == [0.0, 5.0, 10.0, 15.0, 20.0]
    hub = 1e3 * run.hub
    expected = np.column_stack([hub[:, :3], np.hypot(hub[:, 1], hub[:, 2]), hub[:, 3:]])
    np.testing.assert_allclose(rows[:, 1:], expected, rtol=0, atol=5e-4)
    assert rows[-1, 2] > 80.0  # boom d jams: the pressure tilts the hub about x

    peak_line = next(line for line in lines[start:] if line.startswith("  peak "))
    printed = [float(v) for v in peak_line.split()[1:]]
    np.testing.assert_allclose(printed, 1e3 * run.peaks.hub.value, rtol=0, atol=5e-5)

    fine = np.linspace(0.0, 8.0, 4001)  # every 2 ms while boom d moves, and after
    holds = hold_reactions(model, scenario.profile, fine)
    force = np.hypot(holds[:, 0], holds[:, 1])
    assert np.all(holds[:, 2] == 0.0) and force.max() > 2 * force[-1]
    hold_line = next(line for line in lines if line.startswith("  hold reactions"))
    assert "spin |tau_z| 0 N m throughout" in hold_line  # no time for a torque of 0

    assert deploy.main([*argv, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["hub"]
    assert report["peak_hold_force_N"] == pytest.approx(force.max(), rel=1e-4)
    assert abs(report["peak_hold_force_time_s"] - fine[np.argmax(force)]) <= 0.01
    assert f"|F| {report['peak_hold_force_N']:.4g} N" in hold_line
    assert report["peak_hold_torque_N_m"] == 0.0
    assert [report[f"peak_{name}"] for name in ("heave_m", "tilt_x_rad", "tilt_y_rad",
            "tilt_rad")] == pytest.approx(run.peaks.hub.value, rel=1e-12)  # fmt: skip
    assert report["peak_tilt_time_s"] == pytest.approx(run.peaks.hub.time_s[3])
    assert_figure(tmp_path / deploy.HUB_FIGURE, figure_checks)


def test_a_clamped_sails_output_has_no_hub(tmp_path, capsys):
    import json

    assert deploy.main([*SMALL_SET, "--t-end", "2", "--summary", "--figures", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "hub" not in out and not (tmp_path / deploy.HUB_FIGURE).exists()
    assert deploy.main([*SMALL_SET, "--t-end", "2", "--json"]) == 0
    assert "hub" not in json.loads(capsys.readouterr().out)
