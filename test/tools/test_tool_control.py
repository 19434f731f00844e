"""The hub's controller offline: `sail-ros deploy` with a controller section (its
evidence on the reference free-hub scenario), `sail-ros plant --controller`, the
closed loop's log and report, and the bad inputs."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from harness import CONFIG, assert_figure, run_tool
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader

from sail_ros import topics
from sail_ros.bag import BagReader
from sail_ros.control.schedule import GainSchedule
from sail_ros.tools import deploy

pytestmark = pytest.mark.model

COUNTS = ["--set", "n_boom_modes=4", "--set", "n_membrane_modes=6"]  # today's defaults
SCENARIO = CONFIG / "scenario_free_hub_control.yaml"


def short_scenario(tmp_path, duration=3.0, **controller) -> str:
    """The closed-loop scenario cut to `duration` [s], its controller changed."""
    document = yaml.safe_load(SCENARIO.read_text())
    document["scenario"]["duration"] = duration
    document["scenario"]["snapshots"] = [0.0, duration]
    document["controller"] = controller
    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump(document))
    return str(path)


def test_the_closed_loop_holds_the_free_hub_of_the_reference_scenario(capsys):
    """Offline: config/scenario_free_hub_control.yaml at (n_B, n_M) = (4,
    6), whose open loop tilts the hub 85.4 mrad: closed, the peak tilt is under a
    twentieth of that, tilt and heave settle (over the run's last tenth within half their
    peaks, and far below the open loop's there), no boom tip bends more than in open
    loop, and the commands keep their limits."""
    assert deploy.main(["--scenario", str(SCENARIO), "--json", *COUNTS]) == 0
    report = json.loads(capsys.readouterr().out)
    control = report["controller"]
    assert control["open_loop_peak_tilt_rad"] == pytest.approx(85.4e-3, abs=0.05e-3)
    assert control["peak_tilt_rad"] <= control["open_loop_peak_tilt_rad"] / 20
    assert control["final_tilt_rad"] < 0.5 * control["peak_tilt_rad"]
    assert control["final_heave_m"] < 0.5 * control["peak_heave_m"]
    assert control["final_tilt_rad"] < 0.01 * control["open_loop_peak_tilt_rad"]
    assert control["peak_heave_m"] < 0.02 * control["open_loop_peak_heave_m"]
    closed, opened = control["peak_tip_deflection_m"], control["open_loop_peak_tip_deflection_m"]
    assert all(c <= o for c, o in zip(closed, opened, strict=True)), (closed, opened)
    assert all(p <= limit for p, limit in zip(control["peak_command"], control["limits"],
                                               strict=True))  # fmt: skip
    assert control["saturated_samples"] > 0  # the start saturates: boom a's 5 cm bend
    assert control["design_model"] == "rigid body" and control["state_rate_hz"] == 100.0
    assert report["hub"]["peak_tilt_rad"] == control["peak_tilt_rad"]


def test_a_closed_loop_run_draws_both_loops_and_logs_its_commands(tmp_path, capsys, figure_checks):
    scenario = short_scenario(tmp_path)
    log = tmp_path / "closed.mcap"
    code = deploy.main(["--scenario", scenario, "--figures", str(tmp_path / "fig"), "--mcap",
                        str(log), "--summary", "--set", "n_boom_modes=2", "--set",
                        "n_membrane_modes=2"])  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    assert "closed loop (docs/control.md): design model rigid body, 100 Hz" in out
    assert "samples saturated" in out and "open loop" in out
    check = assert_figure(tmp_path / "fig" / deploy.CLOSED_LOOP_FIGURE, figure_checks)
    labels = [panel.lines for panel in check.panels.values()]
    assert labels[0] == ("open loop", "closed loop") == labels[1]
    # the commands, as the recorder logs sail_control's, read by an independent reader
    commands = [m for m in BagReader(log).messages([topics.absolute(topics.HUB_WRENCH_CMD)])]
    assert len(commands) == 301  # every command, one a sample at 100 Hz (states at --rate)
    with AnyReader([log]) as reader:
        connections = [c for c in reader.connections if c.topic == "/sail/hub_wrench_cmd"]
        decoded = [reader.deserialize(raw, c.msgtype) for c, _, raw in
                   reader.messages(connections=connections)]  # fmt: skip
    first = deserialize_message(commands[5].data, topics.TOPICS[topics.HUB_WRENCH_CMD].message_type)
    assert decoded[5].wrench.torque.y == first.wrench.torque.y
    assert topics.stamp_ns_of(first.header.stamp) == round(5 / 100 * 1e9)
    code, out, err = run_tool("report", [str(log), "--out", str(tmp_path / "report"),
                                         "--no-convergence"])  # fmt: skip
    assert code == 0, err
    assert "hub wrench commands: 301" in out
    assert "reproduces the logged tips to 0 of their peak" in out  # the loop closed again
    assert_figure(tmp_path / "report" / "hub_commands.png", figure_checks)


def test_the_plant_tool_checks_the_loop_along_a_deployment_and_writes_its_gains(tmp_path):
    gains = tmp_path / "gains.npz"
    code, out, err = run_tool(
        "plant", ["--controller", "--scenario", str(SCENARIO), "--every", "5", *COUNTS,
                  "--gains", str(gains)],
    )  # fmt: skip
    assert code == 0, err
    assert "stable: no closed-loop pole with Re s > 1e-09 1/s at any of the 5 times" in out
    rows = [line.split() for line in out.splitlines()
            if re.fullmatch(r"\d+\.\d\d", (line.split() or [""])[0])]  # fmt: skip
    assert [float(row[0]) for row in rows] == [0.0, 5.0, 10.0, 15.0, 20.0]
    assert len(rows) == 5 and all(float(row[5]) <= 1e-9 for row in rows)
    schedule = GainSchedule.load(gains)
    assert schedule.period == 0.01 and schedule.inputs[0] == "hub_force_z"
    code, out, _ = run_tool(
        "plant", ["--controller", "--lengths", "16", "16", "16", "12", "--set", "free_hub=true",
                  "--set", "state_rate_hz=50", *COUNTS],
    )  # fmt: skip
    assert code == 1
    assert "unstable: a closed-loop pole with Re s = +" in out
    assert "above the Nyquist frequency 157.1 rad/s" in out


@pytest.mark.parametrize(
    ("tool", "args", "message"),
    [
        ("deploy", {"weight_tilt": float("nan")}, "controller.weight_tilt must be finite, got nan"),
        ("deploy", {"wieght_tilt": 1.0}, "controller: unknown key 'wieght_tilt' (did you mean"),
        ("deploy", {"free_hub": False}, "sail.free_hub is false: the controller holds a free"),
        ("plant", ["--set", "weight_torque=-1"], "controller: weight_torque must be in"),
        ("plant", ["--set", "design_boom_modes=2"], "both 0 (the rigid-body design model)"),
        ("plant", ["--gains", "x.npz"], "--scenario and --gains go with --controller"),
    ],
    ids=["nan-weight", "misspelt", "clamped", "negative-weight", "modes", "no-controller"],
)
def test_bad_controller_input_is_one_line_and_exit_2(tmp_path, tool, args, message):
    if tool == "deploy":
        if "free_hub" in args:
            scenario = short_scenario(tmp_path)
            document = yaml.safe_load(Path(scenario).read_text())
            document["sail"]["free_hub"] = False
            Path(scenario).write_text(yaml.safe_dump(document))
        else:
            scenario = short_scenario(tmp_path, **args)
        argv = ["--scenario", scenario]
    elif "--gains" in args:
        argv = args
    else:
        argv = ["--controller", "--set", "free_hub=true", *args]
    code, out, err = run_tool(tool, argv)
    assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not list(tmp_path.glob("*.npz"))


def test_every_command_of_the_closed_loop_is_within_its_limit_when_they_are_tight(tmp_path, capsys):
    """Limits of 0.2 N and 0.2 N m (--set): the commands saturate much more and never
    pass them; the loop still holds the hub far better than open loop."""
    scenario = short_scenario(tmp_path, duration=4.0)
    tight = ["--set", "max_hub_force=0.2", "--set", "max_hub_torque=0.2"]
    assert deploy.main(["--scenario", scenario, "--json", "--set", "n_boom_modes=2", "--set",
                        "n_membrane_modes=2", *tight]) == 0  # fmt: skip
    control = json.loads(capsys.readouterr().out)["controller"]
    assert control["limits"] == [0.2, 0.2, 0.2]
    assert np.all(np.array(control["peak_command"]) <= 0.2)
    assert control["saturated_samples"] > 100
    assert control["peak_heave_m"] < control["open_loop_peak_heave_m"]
