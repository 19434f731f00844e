"""The offline tools keep the simulator's policy: what it refuses they refuse, in its
words (exit 2, one line, nothing written); a run that leaves the linear range stops
with its alarm and keeps what it computed (exit 1); outputs are sized before anything
is allocated."""

import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from harness import ROOT, SMALL, SMALL_SET, run_tool
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from sail_ros import topics
from sail_ros.analysis.montecarlo import run_sample, study_from_dict
from sail_ros.analysis.scenario import REFERENCE
from sail_ros.bag import BagReader
from sail_ros.model import SailParameters
from sail_ros.policy import Policy

pytestmark = pytest.mark.model

SAIL = SailParameters()
DEFAULTS_NOTE = "; the simulator's limits (defaults; --set NAME=VALUE changes them)"


def simulator_words(value: float) -> str:
    """How the simulator's policy says a length is outside (the same check it runs on a
    deploy command)."""
    with pytest.raises(ValueError, match="is outside") as refused:
        Policy().check_length(value, "target", SAIL)
    return str(refused.value).split(" is ", 1)[1]


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize(
    ("tool", "argv", "message"),
    [
        ("deploy", ["--to", "500"],
         "--from/--to/--duration: boom_a would pass through 500 m on the way, "
         "outside [min_length, max_length] = [5, 70.7107] m" + DEFAULTS_NOTE),
        ("deploy", ["--tip", "1e6"],
         "--boom/--tip: tip deflection of boom a = 1e+06 m is outside +-tip_error_fraction x "
         "length = +-3 m (boom length 10 m)" + DEFAULTS_NOTE),
        ("deploy", ["--duration", "2"],
         "--from/--to/--duration: boom_a would move at 5 m/s, above max_rate 1 m/s"),
        ("deploy", ["--to", "80", "--duration", "150", "--set", "max_length=75"],
         "outside [min_length, max_length] = [5, 75] m; the simulator's limits "
         "(--set max_length=75; --set NAME=VALUE changes them)"),
        ("deploy", ["--set", "min_length=0.01"],
         "min_length = 0.01 m would need 4.306e+06 sub-steps per second of simulation, more "
         "than max_substep_rate = 3200: the shortest affordable min_length here is 0.367 m"),
        ("modes", ["--lengths", "1000"],
         "--lengths of boom a = 1000 m is " + simulator_words(1000) + DEFAULTS_NOTE),
        ("modes", ["--lengths", "10", "10", "0.5", "10"],
         "--lengths of boom c = 0.5 m is " + simulator_words(0.5)),
        ("plant", ["--lengths", "30", "--rates", "0", "2", "0", "0"],
         "--rates of boom b = 2 m/s is outside [-max_rate, max_rate] = [-1, 1] m/s"),
        ("stability", ["--rates", "0.1", "-3"],
         "--rates = -3 m/s is outside [-max_rate, max_rate] = [-1, 1] m/s"),
        ("stability", ["--lengths", "100", "--rates", "0.1"], "--lengths = 100 m is outside"),
    ],
    ids=["to", "tip", "rate", "set-limit", "min-length", "modes", "modes-short", "plant",
         "stability-rate", "stability-length"],
)  # fmt: skip
def test_what_the_simulator_refuses_is_refused_in_its_words(tmp_path, tool, argv, message):
    output = {"deploy": ["--mcap", str(tmp_path / "run.mcap"), "--figures", str(tmp_path)],
              "modes": ["--csv", str(tmp_path / "f.csv")],
              "plant": ["--npz", str(tmp_path / "p.npz")],
              "stability": ["--csv", str(tmp_path / "c.csv")]}[tool]  # fmt: skip
    code, out, err = run_tool(tool, [*argv, *output])
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert message in err, err
    assert leftovers(tmp_path) == []  # nothing written


def waypoint_scenario(path: Path, points: int) -> Path:
    """A scenario whose booms stand at 10 m through `points` waypoints 1 ms apart."""
    times = [1e-3 * i for i in range(points)]
    document = {"scenario": {"duration": times[-1], "profile": {
        "type": "waypoints", "times": times, "lengths": [10.0] * points}}}  # fmt: skip
    path.write_text(yaml.safe_dump(document))
    return path


def test_a_scenario_with_more_waypoints_than_the_simulator_takes_is_refused_first(
    tmp_path, monkeypatch
):
    """1001 waypoints, one more than max_trajectory_points: refused in the simulator's words
    (the count it refuses a trajectory command with) before a spline is made of them;
    --set max_trajectory_points=1001 admits them."""
    from std_msgs.msg import Header  # noqa: F401 (the message packages load first)
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from sail_ros.runtime.commands import BoomState, CommandError, Rules, plan_trajectory

    scenario = waypoint_scenario(tmp_path / "many.yaml", 1001)
    points = [JointTrajectoryPoint(positions=[10.0]) for _ in range(1001)]
    command = JointTrajectory(joint_names=["boom_a"], points=points)
    now = BoomState(0.0, np.full(4, 10.0), np.zeros(4), np.zeros(4))
    with pytest.raises(CommandError) as simulator:
        plan_trajectory(command, now, Rules(Policy(), SAIL))
    assert str(simulator.value) == "1001 points, more than max_trajectory_points = 1000"

    def never(*args, **kwargs):
        raise AssertionError("a spline was made of the refused waypoints")

    monkeypatch.setattr("sail_ros.analysis.scenario.WaypointProfile", never)
    code, _, err = run_tool("deploy", ["--scenario", str(scenario), "--mcap", str(tmp_path / "r")])
    assert code == 2
    assert err == (f"error: {scenario}: scenario.profile.times: {simulator.value}{DEFAULTS_NOTE}\n")
    assert leftovers(tmp_path) == ["many.yaml"]
    monkeypatch.undo()
    code, _, err = run_tool(
        "deploy", ["--scenario", str(scenario), "--set", "max_trajectory_points=1001",
                   "--json"],
    )  # fmt: skip
    assert code == 0, err


@pytest.mark.slow
def test_a_scenario_of_300000_waypoints_is_refused_before_any_work(tmp_path):
    """The full size of the test above, as a process: 300000 waypoints are refused with
    one line and exit 2; prints the wall time and the peak memory the refusal took."""
    scenario = waypoint_scenario(tmp_path / "huge.yaml", 300_000)
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "sail_ros.cli", "deploy", "--scenario", str(scenario)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    seconds = time.monotonic() - started
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # kB -> MiB
    print(f"\n300000 waypoints refused in {seconds:.1f} s, peak {peak:.0f} MiB (a process's)")
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1
    assert "300000 points, more than max_trajectory_points = 1000" in result.stderr


def test_limits_come_from_set_or_the_simulators_params_file(tmp_path):
    """--set max_length=100 admits a deployment to 80 m (refused by default); the
    simulator's own params file as --config brings its limits."""
    argv = ["--to", "80", "--duration", "150", "--t-end", "1", "--json"]
    assert run_tool("deploy", argv)[0] == 2
    code, out, err = run_tool("deploy", [*argv, "--set", "max_length=100"])
    assert code == 0, err
    assert json.loads(out)["limits"]["max_length"] == 100.0
    params = yaml.safe_load((ROOT / "config" / "sim.yaml").read_text())
    params["sail_sim"]["ros__parameters"]["max_rate"] = 0.5
    config = tmp_path / "sim.yaml"
    config.write_text(yaml.safe_dump(params))
    code, _, err = run_tool("deploy", ["--config", str(config)])
    assert code == 2
    assert (
        err == "error: --from/--to/--duration: boom_a would move at 0.6667 m/s, above max_rate "
        f"0.5 m/s; the simulator's limits ({config}; --set NAME=VALUE changes them)\n"
    )


def test_a_run_that_leaves_the_linear_range_stops_with_the_alarm_and_keeps_its_log(tmp_path):
    """Retracting from 15 m with a 4 m tip: the tip's share of the shrinking boom passes
    0.1 (a warning, as the simulator's diagnostics turn WARN) and then 0.3 of its
    length: the run stops there with the simulator's alarm, the log holds the run up to
    the sample before, and the exit code is 1."""
    log = tmp_path / "retract.mcap"
    argv = [
        *SMALL_SET,
        "--from",
        "15",
        "--to",
        "10",
        "--tip",
        "4",
        "--rate",
        "10",
        "--mcap",
        str(log),
    ]
    code, out, err = run_tool("deploy", argv)
    assert code == 1
    warning, alarm = err.strip().splitlines()
    assert warning.startswith("warning: at t = ") and "beyond tip_warn_fraction 0.1" in warning
    assert alarm.startswith("error: integration stopped at t = ")
    stopped = float(alarm.split("t = ")[1].split(" s")[0])
    assert ", beyond tip_error_fraction 0.3: out of the linear range; wrote the run up to t =" in (
        alarm
    )
    assert f"wrote {log}" in out
    samples = [
        deserialize_message(m.data, JointState)
        for m in BagReader(log).messages([topics.absolute(topics.TIP_DEFLECTION)])
    ]
    lengths = [
        deserialize_message(m.data, JointState)
        for m in BagReader(log).messages([topics.absolute(topics.BOOM_STATE)])
    ]
    last = samples[-1].header.stamp.sec + samples[-1].header.stamp.nanosec * 1e-9
    assert 5.0 < last < stopped <= last + 0.1 + 1e-9  # the 10 Hz samples before the alarm
    fractions = [abs(s.position[0]) / b.position[0] for s, b in zip(samples, lengths, strict=True)]
    assert max(fractions) <= 0.3 and fractions[-1] > 0.25  # all within; the last near it


def test_output_sizes_are_refused_with_the_estimate(tmp_path):
    code, _, err = run_tool("deploy", [*SMALL_SET, "--duration", "1e7", "--to", "10"])
    assert code == 2
    assert err == (
        "error: the run over 1e+07 s (a table row every 1 s): 1e+07 samples would take 15.1 "
        "GiB, more than the 1 GiB an offline output may hold (fewer samples: a shorter "
        "duration, a longer --every, a lower --rate)\n"
    )
    scenario = tmp_path / "long.yaml"
    scenario.write_text("scenario: {duration: 1.0e9, profile: {type: static, lengths: 10.0}}\n")
    code, _, err = run_tool("deploy", [*SMALL_SET, "--scenario", str(scenario), "--every", "1e3"])
    assert code == 2 and "1e+06 samples would take 1.51 GiB" in err


def test_deploy_for_1e9_s_is_refused_within_4_gb_of_address_space():
    """Under RLIMIT_AS = 4 GB: refused before anything is allocated (the outputs of 1e9 s
    would take 23.8 GiB, and the process be killed asking for them)."""
    limit = 4 * 10**9

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    result = subprocess.run(
        [sys.executable, "-m", "sail_ros.cli", "deploy", "--duration", "1e9"],
        preexec_fn=limited,
        capture_output=True,
        text=True,
        timeout=120,
        env={**__import__("os").environ, "OPENBLAS_NUM_THREADS": "1"},
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith("error: the run over 1e+09 s") and "GiB" in result.stderr
    assert result.stderr.count("\n") == 1 and result.stdout == ""


def test_montecarlo_checks_the_base_scenario_and_each_draw(tmp_path):
    """A study whose base scenario the simulator would refuse stops before any sample
    (exit 2, nothing written); a draw that makes a boom too fast is a row with the
    policy's words."""
    fast = {"scenario": {**REFERENCE["scenario"], "profile": {"type": "cycloidal",
            "start": 10.0, "end": 15.0, "duration": 5.0}, "duration": 5.0,
            "snapshots": [0.0, 5.0]}}  # fmt: skip
    study = tmp_path / "fast.yaml"
    study.write_text(yaml.safe_dump({"study": {"samples": 2, "scenario": fast}}))
    out = tmp_path / "out"
    code, _, err = run_tool("montecarlo", [str(study), "--out", str(out)])
    assert code == 2 and not out.exists()
    assert err == (
        "error: study.scenario: scenario.profile: boom_a would move at 2 m/s, above max_rate "
        "1 m/s; the simulator's limits (defaults; --set NAME=VALUE changes them)\n"
    )
    quicker = study_from_dict(
        {
            "study": {
                "samples": 1,
                "scenario": REFERENCE,
                "dispersions": {"rate.c": {"distribution": "uniform", "low": 1.6, "high": 1.7}},
            }
        }  # fmt: skip
    )
    row = run_sample((quicker, 0, SMALL.to_dict(), Policy()))
    prefix, _, rest = row["error"].partition(" would move at ")
    assert prefix == "ValueError: scenario.profile: boom_c"
    speed, _, limit = rest.partition(" m/s, ")
    assert 2 * 5 / 15 * 1.6 <= float(speed) <= 2 * 5 / 15 * 1.7 and limit == "above max_rate 1 m/s"
    row = run_sample((quicker, 0, SMALL.to_dict(), Policy(max_rate=1.2)))
    assert row["error"] == "" and np.isfinite(row["peak_tip_m"])


def test_a_report_reruns_with_the_limits_the_log_recorded(tmp_path):
    """`deploy --mcap` records its limits with the simulator's other parameters; the
    report's rerun keeps them, and refuses (exit 2, nothing written) under stricter ones
    given with --set."""
    log = tmp_path / "fast.mcap"
    limits = ["--set", "max_rate=2", "--set", "max_acceleration=2"]
    argv = [*SMALL_SET, "--to", "14", "--duration", "5", "--t-end", "2", "--rate", "10",
            "--mcap", str(log)]  # fmt: skip
    assert run_tool("deploy", [*argv, *limits])[0] == 0
    assert dict(BagReader(log).metadata())[topics.PARAMETERS_METADATA]["max_rate"] == "2.0"
    out = tmp_path / "report"
    code, _, err = run_tool("report", [str(log), "--out", str(out), "--no-convergence"])
    assert code == 0, err
    assert (out / "peaks.csv").read_text().count("rerun") == 1
    strict = tmp_path / "strict"
    code, _, err = run_tool("report", [str(log), "--out", str(strict), "--set", "max_rate=1"])
    assert code == 2 and not strict.exists()
    assert err == (
        "error: the recorded scenario: scenario.profile: boom_a would move at 1.6 m/s, above "
        "max_rate 1 m/s\n"
    )
