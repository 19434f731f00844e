"""The hub's controller live, CI-sized: `sail-ros sim`, `sail-ros control` and `sail-ros
recorder` as processes over DDS, the reference closed-loop scenario driven with `sail-ros
send` (pause, reset, deploy, boom d's waypoints, resume), at time scales 1 and 4 (the
full 20 s at both: benchmarks/control_loop.py, and the `slow` trial here). The recorded
tilt follows the offline closed loop within 5 % of its peak; the controller refuses a
clamped simulator with one line and exit 2."""

import signal

import numpy as np
import pytest
from harness import CONFIG, run_tool

from sail_ros import status as key
from sail_ros.analysis.closed_loop import last_run, run_closed_loop, tilt_agreement
from sail_ros.analysis.log_series import read_log
from sail_ros.analysis.scenario import load_scenario
from sail_ros.model import SailModel, SailParameters

pytestmark = pytest.mark.multiprocess

COUNTS = {"sail.n_boom_modes": 4, "sail.n_membrane_modes": 6}
SCENARIO = CONFIG / "scenario_free_hub_control.yaml"


def send(*args):
    code, out, err = run_tool("send", list(args))
    assert code == 0, f"sail-ros send {' '.join(args)}: {out}{err}"


def d_points(scenario, spacing=0.25):
    """`--point T L` of boom d's cycloid, every `spacing` [s] to its end at 6 s."""
    points = []
    for k in range(1, round(6.0 / spacing) + 1):
        points += ["--point", f"{k * spacing:g}", f"{scenario.profile(k * spacing)[0][3]:.9f}"]
    return points


def closed_loop_live(processes, operator, tmp_path, config, scale, duration):
    """The scenario's first `duration` [s] live with the params file `config`; the
    largest tilt difference from the offline loop over its peak, and the log."""
    params = ["--ros-args", "--params-file", str(CONFIG / config)]
    params += [item for name, value in COUNTS.items() for item in ("-p", f"{name}:={value}")]
    sim = processes("sim", *params)
    control = processes("control", *params)
    bag = tmp_path / f"scale_{scale}"
    recorder = processes("recorder", "-o", str(bag))
    control.wait_for_lines(["runs the plant of this design"], timeout=60.0)
    recorder.wait_for_lines(["recording /sail/hub_wrench_cmd "], timeout=60.0)
    scenario = load_scenario(SCENARIO)
    send("pause")
    # the run is timed by the simulator's clock, not the wall's (a loaded machine may run
    # it slower than asked): statuses come in order, and those after the first paused
    # one that say running are the new run's (the simulator's statuses alone tell the
    # simulation time)
    operator.wait_for_status(
        lambda status: key.SIM_TIME in status and status[key.STATE] == "paused",
        30.0,
        "the pause",
    )
    send("reset")
    send("deploy", "16")
    send("move", "--booms", "d", *d_points(scenario))
    send("resume")
    operator.wait_for_status(
        lambda status: (
            key.SIM_TIME in status
            and status[key.STATE] == "running"
            and float(status[key.SIM_TIME]) > duration + 0.25
        ),
        10.0 + 4.0 * duration / scale,
        f"{duration} s of the run",
    )
    assert recorder.stop(signal.SIGINT) == 0
    assert control.stop(signal.SIGINT) == 0, control.log()
    assert "stopped: a zero wrench commanded" in control.log()
    assert sim.stop(signal.SIGINT) == 0
    log = read_log(bag)
    rate, delay = (100.0, 0.0) if scale == 1 else (50.0, 0.0)  # as the params files say
    design = scenario.controller.replace(state_rate_hz=rate, loop_delay_s=delay)
    model = SailModel(SailParameters(**scenario.sail, n_boom_modes=4, n_membrane_modes=6))
    short = scenario.__class__(**{**scenario.__dict__, "duration": duration})
    closed = run_closed_loop(model, short, design)
    t, hub = last_run(log)
    keep = t <= duration + 1e-9
    difference, peak, compared = tilt_agreement(t[keep], hub[keep], closed)
    assert compared >= round(0.9 * duration * rate), compared
    return difference / peak, log


@pytest.mark.parametrize(
    ("config", "scale", "duration"),
    [("closed_loop.yaml", 1, 3.0), ("closed_loop_scale4.yaml", 4, 6.0)],
    ids=["scale-1", "scale-4"],
)
def test_the_live_loop_reproduces_the_offline_loop(
    processes, operator, tmp_path, config, scale, duration
):
    fraction, log = closed_loop_live(processes, operator, tmp_path, config, scale, duration)
    assert fraction < 0.05, f"{100 * fraction:.3g} % of the peak tilt"
    statuses = log.controller[1]
    assert statuses["state"][-1] in ("running", "stale")  # stale: the simulator stopped last
    delays = [float(v) for v in statuses["applied_delay_median_s"] if float(v) >= 0]
    assert delays and np.median(delays) == 0.0  # commands act from their sample's time
    assert log.hub_commands is not None and len(log.hub_commands[2]) > duration * 40


@pytest.mark.slow
@pytest.mark.parametrize(
    ("config", "scale"),
    [("closed_loop.yaml", 1), ("closed_loop_scale4.yaml", 4)],
    ids=["scale-1", "scale-4"],
)
def test_the_whole_live_run_reproduces_the_offline_loop(
    processes, operator, tmp_path, config, scale
):
    fraction, _ = closed_loop_live(processes, operator, tmp_path, config, scale, 20.0)
    assert fraction < 0.05, f"{100 * fraction:.3g} % of the peak tilt"


def test_a_clamped_simulator_is_refused_with_one_line(processes):
    sim = processes("sim", parameters=COUNTS)
    control = processes("control", parameters={**COUNTS, "sail.free_hub": True})
    code = control.process.wait(60.0)
    sim.stop(signal.SIGINT)
    lines = [line for line in control.log().splitlines() if "ERROR" in line]
    assert code == 2, control.log()
    assert len(lines) == 1 and "the simulator /sail_sim has a clamped hub" in lines[0]
