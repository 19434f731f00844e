"""`sail_sim` (and `sail_recorder`) as separate processes over real DDS, loopback only.

This test process is the operator: it publishes the commands, calls the
services and listens to everything the simulator publishes, then checks it
against the model run offline for the same motion.
"""

import math
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from harness import ROOT, SMALL, SMALL_SIM, run_tool
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bag import BagReader
from sail_ros.integrate.control import DEFAULT_MAX_STEP
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.model import SailModel, SailParameters, StaticProfile
from sail_ros.model.profiles import BoomMotion, SwitchedProfile
from sail_ros.policy import Policy
from sail_ros.runtime.commands import BoomState, Rules, plan_deploy, plan_trajectory
from sail_ros.runtime.config import config_from_values
from sail_ros.runtime.realtime import COMMAND_LINES, RTF_MIN_WINDOW_S
from sail_ros.runtime.simulation import Simulation

pytestmark = pytest.mark.multiprocess

STEP = 0.01  # s, integration_step (default)
MODEL_STEP = DEFAULT_MAX_STEP  # s, max_model_step (default)
RULES = Rules(Policy(), SailParameters())  # the simulator's defaults
# The simulator and SailModel.simulate_on_grid integrate the same equations with the
# same steps and samples from the same state, so they differ by round-off in the step
# times only (~1e-9 m, ~1e-7 m/s); a command applied one step late moves the tips by
# ~3e-3 m.
TIP_TOLERANCE = 1e-6  # m; rates 1e-5 m/s


def trajectory(names, *points) -> JointTrajectory:
    """A JointTrajectory; each point is (positions [m], time_from_start [s])."""
    message = JointTrajectory(joint_names=list(names))
    for positions, seconds in points:
        sec = math.floor(seconds)
        message.points.append(
            JointTrajectoryPoint(
                positions=[float(p) for p in positions],
                time_from_start=Duration(sec=sec, nanosec=round((seconds - sec) * 1e9)),
            )
        )
    return message


def series(messages, epoch_ns):
    """(simulation times on the grid [s], positions, velocities) of JointStates."""
    t = np.array(
        [(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - epoch_ns) * 1e-9 for m in messages]
    )
    return (
        np.round(t / STEP) * STEP,
        np.array([m.position for m in messages]),
        np.array([m.velocity for m in messages]),
    )


def commanded_motion(t_deploy: float, t_command: float, command) -> SwitchedProfile:
    """At rest at 10 m, deployed to 12 m from `t_deploy` [s], and `command` (a
    trajectory) from `t_command` [s] on: the plans the simulator makes, rebuilt."""
    hold = BoomMotion([StaticProfile(10.0)] * 4)
    deploy = plan_deploy(12.0, BoomState(t_deploy, *hold(t_deploy)), RULES)
    deploying = hold.replaced(deploy.profile, deploy.booms)
    follow = plan_trajectory(command, BoomState(t_command, *deploying(t_command)), RULES)
    moving = deploying.replaced(follow.profile, follow.booms)
    return SwitchedProfile([0.0, t_deploy, t_command], [hold, deploying, moving])


# -- tests --------------------------------------------------------------------------------------


def test_deployment_follows_both_commands_and_is_recorded(processes, operator, tmp_path):
    """Deploy all booms 10 -> 12 m, and while they move send booms a and b elsewhere."""
    tip0 = [0.1, 0.0, 0.0, 0.0]
    sim = processes(
        "sim",
        parameters={
            **SMALL_SIM,
            "time_scale": 4.0,
            "initial_tip_deflection": tip0,
            "diagnostics_rate_hz": 10.0,
        },
    )
    bag = tmp_path / "bag"
    recorder = processes("recorder", "-o", str(bag))
    operator.wait_for_simulator(subscribers=2)  # the simulator and the recorder
    operator.spin_until(
        lambda: operator.count_subscribers(topics.BOOM_STATE) >= 2,
        10.0,
        "the recorder's subscription",
    )

    operator.deploy.publish(Float64(data=12.0))
    deployed = operator.wait_for_status(
        lambda s: s[key.ACCEPTED] == "1", 10.0, "the deployment to be accepted"
    )
    t_deploy = float(deployed[key.LAST_COMMAND_START])
    operator.spin_until(
        lambda: float(operator.status()[key.SIM_TIME]) > t_deploy + 2.0,
        10.0,
        "the booms to be half way",
    )
    command = trajectory(["boom_a", "boom_b"], ([12.5, 11.5], 8.0), ([13.0, 11.0], 14.0))
    operator.trajectory.publish(command)
    moved = operator.wait_for_status(
        lambda s: s[key.ACCEPTED] == "2", 10.0, "the trajectory to be accepted"
    )
    t_command = float(moved[key.LAST_COMMAND_START])
    t_end = float(moved[key.MOTION_END])
    assert t_end == pytest.approx(t_command + 14.0)
    operator.spin_until(
        lambda: float(operator.status()[key.SIM_TIME]) > t_end + 1.0, 30.0, "the motion to end"
    )
    assert sim.stop(signal.SIGTERM) == 0, sim.log()
    operator.spin_until_quiet()  # the last samples in flight
    assert recorder.stop(signal.SIGINT) == 0, recorder.log()
    assert operator.status()[key.REJECTED] == "0"
    log = sim.log()
    assert f"/sail/deploy_cmd accepted at t = {t_deploy:.6f} s: deploy to 12 m: cycloidal" in log
    assert "SIGTERM: stopping" in log

    # the motion the simulator should have followed, rebuilt from the same plans
    motion = commanded_motion(t_deploy, t_command, command)

    epoch = operator.epoch_ns()
    t, lengths, rates = series(operator.states[topics.BOOM_STATE], epoch)
    assert t[-1] > t_end
    expected = [motion(ti) for ti in t]
    assert lengths == pytest.approx(np.array([e[0] for e in expected]), abs=1e-7)
    assert rates == pytest.approx(np.array([e[1] for e in expected]), abs=1e-7)
    assert lengths[-1] == pytest.approx([13.0, 11.0, 12.0, 12.0])

    model = SailModel(SMALL)
    t_tip, tips, tip_rates = series(operator.states[topics.TIP_DEFLECTION], epoch)
    t_grid, q, qd = model.simulate_on_grid(
        motion, t_tip[-1] + 0.5 * STEP, STEP, model.initial_coordinates(tip0), max_step=MODEL_STEP
    )
    on_grid = np.rint(t_tip / STEP).astype(int)
    assert t_grid[on_grid] == pytest.approx(t_tip, abs=1e-9)
    q, qd = q[on_grid], qd[on_grid]
    assert np.abs(tips).max() > 0.05  # the boom still rings: a real comparison
    assert tips == pytest.approx(model.tip_deflections(q), abs=TIP_TOLERANCE)
    assert tip_rates == pytest.approx(model.tip_deflections(qd), abs=10 * TIP_TOLERANCE)

    # the bag: every topic, every sample (no gap in the 0.02 s grid), the parameters
    reader = BagReader(bag)
    counts = {name: info.message_count for name, info in reader.topics().items()}
    assert (
        counts[topics.absolute(topics.DEPLOY_CMD)] == 1
        and counts[topics.absolute(topics.BOOM_LENGTH_CMD)] == 1
    )
    assert (
        counts[topics.absolute(topics.SHAPE)] > 0
        and counts[topics.absolute(topics.DIAGNOSTICS)] > 0
    )
    entries = list(reader.messages([topics.absolute(topics.BOOM_STATE)]))
    recorded = [deserialize_message(m.data, JointState) for m in entries]
    t_bag, lengths_bag, _ = series(recorded, epoch)
    gaps = np.flatnonzero(np.abs(np.diff(t_bag) - 0.02) > 1e-9)
    assert not gaps.size, [  # where, and how long the recorder received nothing
        (t_bag[i], t_bag[i + 1], (entries[i + 1].log_time_ns - entries[i].log_time_ns) * 1e-6)
        for i in gaps
    ]
    assert t_bag[-1] == t[-1]  # the simulator's last sample made it into the bag
    parameters = dict(reader.metadata())["sail_sim_parameters"]
    assert yaml.safe_load(parameters["time_scale"]) == 4.0
    assert yaml.safe_load(parameters["initial_tip_deflection"]) == tip0
    assert yaml.safe_load(parameters["sail.n_boom_modes"]) == 4


BAD_COMMANDS = [
    (Float64(data=math.nan), "target is nan"),
    (Float64(data=math.inf), "target is inf"),
    (Float64(data=0.5), "target = 0.5 m is outside [min_length, max_length]"),
    (Float64(data=75.0), "target = 75 m is outside"),
    (trajectory(["boom_e"], ([11.0], 5.0)), "unknown joint name(s) 'boom_e'"),
    (trajectory(["boom_a", "boom_a"], ([11.0, 11.0], 5.0)), "'boom_a' given more than once"),
    (trajectory(["boom_a", "boom_b"], ([11.0], 5.0)), "point 0 has 1 positions for 2"),
    (
        trajectory(["boom_c"], ([11.0], 5.0), ([11.5], 4.0)),
        "point 1: time_from_start 4 s must be > that of point 0 (5 s)",
    ),
    (trajectory(["boom_c"], ([11.0], 0.0)), "time_from_start 0 s must be > 0"),
    (trajectory(["boom_d"], ([math.nan], 5.0)), "point 0: boom_d is nan"),
    (trajectory(["boom_d"], ([80.0], 500.0)), "boom_d = 80 m is outside"),
    (trajectory(["boom_b"], ([40.0], 10.0)), "above max_rate 1 m/s"),
    (trajectory(["boom_b"], ([10.5], 1.0)), "above max_acceleration 0.5 m/s^2"),
    (trajectory(["boom_a"]), "no points"),
]


def test_bad_commands_are_rejected_whole_and_change_nothing(processes, operator):
    """Real time; then pause, resume and reset through the services."""
    tip0 = [0.0, 0.02, 0.0, -0.01]
    sim = processes(
        "sim", parameters={**SMALL_SIM, "initial_tip_deflection": tip0, "diagnostics_rate_hz": 20.0}
    )
    operator.wait_for_simulator()
    for count, (command, reason) in enumerate(BAD_COMMANDS, start=1):
        publisher = operator.deploy if isinstance(command, Float64) else operator.trajectory
        publisher.publish(command)
        status = operator.wait_for_status(
            lambda s, c=count: s[key.REJECTED] == str(c),
            5.0,
            f"rejection {count} ({reason})",
        )
        assert reason in status[key.LAST_REJECTION]
        assert status["level"] == DiagnosticStatus.WARN
    operator.spin_for(1.0)
    assert operator.status()[key.ACCEPTED] == "0"

    # untouched: booms at rest at 10 m, and the vibration exactly as if alone
    epoch = operator.epoch_ns()
    _, lengths, rates = series(operator.states[topics.BOOM_STATE], epoch)
    assert np.all(lengths == 10.0) and np.all(rates == 0.0)
    t, q, _ = series(operator.states[topics.MODAL_STATE], epoch)
    model = SailModel(SMALL)
    _, q_alone, _ = model.simulate(
        StaticProfile(10.0), t[-1], model.initial_coordinates(tip0), t_eval=t, max_step=STEP
    )
    assert np.abs(q).max() > 0.005
    assert q == pytest.approx(q_alone, abs=1e-9)
    # real time: simulation time kept pace with the wall clock. A status is published
    # on its tick or late, never early, so the least lag of the wall clock behind
    # simulation time is the same in the run's last quarter as in its first
    sim_time = np.array(
        [float(operator.status(i)[key.SIM_TIME]) for i in range(2, len(operator.diagnostics))]
    )
    lag = np.array(operator.published_ns[2:]) * 1e-9 - sim_time
    quarter = len(lag) // 4
    span = sim_time[-quarter] - sim_time[quarter - 1]
    drift = (lag[-quarter:].min() - lag[:quarter].min()) / span
    assert span > 0.5 and abs(drift) < 0.02, (span, drift)

    answer = operator.call(operator.pause, SetBool.Request(data=True))
    assert answer.success
    paused = operator.wait_for_status(lambda s: s[key.STATE] == "paused", 5.0, "paused")
    operator.spin_for(0.5)
    assert operator.status()[key.SIM_TIME] == paused[key.SIM_TIME]
    count = len(operator.states[topics.MODAL_STATE])
    answer = operator.call(operator.reset, Trigger.Request())
    assert answer.success and answer.message.endswith("(paused)")
    operator.spin_until(
        lambda: len(operator.states[topics.MODAL_STATE]) > count, 5.0, "the state after the reset"
    )
    operator.spin_for(0.5)  # paused: no state follows the reset's own
    # the state the reset left first if a tick had stopped between two samples, then the
    # reset's with the same stamp
    sent = operator.states[topics.MODAL_STATE][count:]
    assert (
        len(sent) in (1, 2)
        and len({(m.header.stamp.sec, m.header.stamp.nanosec) for m in sent}) == 1
    )
    after = sent[-1]
    assert np.array(after.position) == pytest.approx(model.initial_coordinates(tip0), abs=1e-15)
    assert operator.call(operator.pause, SetBool.Request(data=False)).success
    running = operator.wait_for_status(
        lambda s: (
            s[key.STATE] == "running" and float(s[key.SIM_TIME]) > float(paused[key.SIM_TIME]) + 0.3
        ),
        5.0,
        "running again",
    )
    assert running["level"] != DiagnosticStatus.ERROR  # WARN would be an overrun: load
    assert sim.stop(signal.SIGINT) == 0
    # the log names the first few rejections, then counts the rest in one line (every
    # reason went out on sail/command_status and into /diagnostics, checked above)
    log = sim.log()
    for _, reason in BAD_COMMANDS[:COMMAND_LINES]:
        assert reason in log
    assert f"{len(BAD_COMMANDS) - COMMAND_LINES} rejected (last rejection: " in log


def test_divergence_is_an_error_before_anything_non_finite_until_reset(
    processes, operator, tmp_path
):
    """A boom axial load far beyond buckling: the booms diverge; the simulator stops them
    once a tip passes tip_error_fraction (0.3) of its boom, before any absurd value goes
    out; the node stays up."""
    params = tmp_path / "buckling.yaml"
    params.write_text(
        yaml.safe_dump(
            {
                "sail_sim": {
                    "ros__parameters": {
                        "sail": {
                            "boom_axial_load": 1e4
                        },  # N; the Euler load of a 10 m boom is 148 N
                        "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0],
                        "diagnostics_rate_hz": 20.0,
                    }
                }
            }
        )
    )
    sim = processes("sim", "--ros-args", "--params-file", str(params), parameters=SMALL_SIM)
    # diagnostics go on in the error state (the states stop), so this needs no head start
    error = operator.wait_for_status(
        lambda s: s["level"] == DiagnosticStatus.ERROR, 30.0, "the ERROR diagnostic"
    )
    assert error[key.STATE] == "error" and "out of the linear range" in error["message"]
    # the state is kept (transient local): it may arrive after the diagnostics
    operator.spin_until(lambda: operator.states[topics.TIP_DEFLECTION], 5.0, "the tips")
    tips = np.array([m.position for m in operator.states[topics.TIP_DEFLECTION]])
    assert np.all(np.isfinite(tips)) and np.abs(tips).max() <= 0.3 * 10.0
    operator.spin_for(0.3)
    assert operator.status()[key.SIM_TIME] == error[key.SIM_TIME]  # stopped
    assert sim.process.poll() is None  # but up

    request = SetParameters.Request(
        parameters=[
            Parameter("initial_tip_deflection", value=[0.0, 0.0, 0.0, 0.0]).to_parameter_msg()
        ]
    )
    assert operator.call(operator.set_parameters, request).results[0].successful
    assert operator.call(operator.reset, Trigger.Request()).success
    running = operator.wait_for_status(  # a flat sail stays flat, buckling or not
        lambda s: (
            s[key.STATE] == "running" and float(s[key.SIM_TIME]) > float(error[key.SIM_TIME]) + 0.3
        ),
        5.0,
        "0.3 s of running after the reset",
    )
    assert running["level"] != DiagnosticStatus.ERROR
    assert not np.any(operator.states[topics.MODAL_STATE][-1].position)
    assert sim.stop(signal.SIGTERM) == 0
    assert "beyond tip_error_fraction 0.3: out of the linear range" in sim.log()


@pytest.mark.timing
def test_demo_runs_the_reference_deployment(ros_env, tmp_path):
    """`sail-ros demo`: both processes, the deployment, a clean stop and the summary."""
    output = tmp_path / "demo"
    result = subprocess.run(
        [sys.executable, "-m", "sail_ros.cli", "demo", "-o", str(output), "--time-scale", "5.0"],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    assert "simulator and recorder stopped cleanly (exit code 0)" in lines
    assert f"MCAP log: {output}" in lines
    # the live tips at 5, 10 and 15 s equal the offline model's (same grid, same state)
    rows = [line for line in lines if line.lstrip().startswith("t = ")]
    assert [row.split()[2] for row in rows] == ["5.00", "10.00", "15.00"]
    assert all(float(row.rsplit("(", 1)[1].split()[0]) < 1e-9 for row in rows), rows
    assert BagReader(output).topics()[topics.absolute(topics.DEPLOY_CMD)].message_count == 1
    # measured over >= 0.5 s windows: near the time scale, never a short window's 10x+
    (factor,) = [line for line in lines if "real-time factor: max" in line]
    largest, median = (float(word.strip(",")) for word in factor.split()[3:6:2])
    assert 0.5 * 5.0 < median <= largest, factor
    (overruns,) = [line for line in lines if line.lstrip().startswith("overruns (")]
    if overruns.split("): ")[1].startswith("0;"):  # a late tick's catch-up would show
        assert largest < 1.2 * 5.0, factor
    statuses = [
        diagnostics_msg.diagnostic_values(deserialize_message(m.data, DiagnosticArray))
        for m in BagReader(output).messages([topics.DIAGNOSTICS])
    ]
    # every measurement over a window of at least the minimum (0.0: none yet). A status
    # repeats the last measurement: a new one is where the window changes (counted so,
    # not as distinct values: steady ticks give two measurements the same window). About
    # 3.3 s of running wall time: a window closes at the first 10 Hz status 0.5 s or more
    # after it opened, the last one stays open at the stop, and a late status lengthens
    # one: 4 or 5 measurements, 3 at the least
    windows = [float(status[key.REAL_TIME_FACTOR_WINDOW]) for status in statuses]
    measured = [b for a, b in zip([0.0, *windows], windows, strict=False) if b > 0.0 and b != a]
    assert len(measured) >= 3 and min(measured) >= RTF_MIN_WINDOW_S, windows
    # the count the README quotes of the main job (scripts/main.sh runs this demo)
    stored = re.search(r"simulator parameters stored: \d+ \(", result.stdout)
    assert stored and stored.group(0) in (ROOT / "README.md").read_text(), stored


def test_the_offline_replay_does_not_hang_on_the_logged_times_rounding():
    """In process: the simulation of the first test, replayed by `simulate_on_grid` from
    the command times the status logs (every digit): the same steps, the same tips to
    round-off. From times off by 0.4 ns either way (a log rounded to the nanosecond), the
    motion's switches still fall on the simulator's step ends (`SWITCH_RESOLUTION`), where
    the command's motion starts with its own acceleration as the simulator's did: the
    same steps, and the tips within 1e-8 of their peak (the motion itself moved by
    0.4 ns)."""
    config = config_from_values({**SMALL_SIM, "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0]})
    model = SailModel(config.sail)
    sim = Simulation(model, config)
    while sim.t < 0.5 - 1e-9:
        assert sim.step()
    t_deploy = sim.apply_motion(sim.plan_deploy(12.0)).t_start
    while sim.t < t_deploy + 2.0:
        assert sim.step()
    command = trajectory(["boom_a", "boom_b"], ([12.5, 11.5], 8.0), ([13.0, 11.0], 14.0))
    t_command = sim.apply_motion(sim.plan_trajectory(command)).t_start
    tips = []
    while sim.t < t_command + 15.0:
        assert sim.step()
        tips.append(model.tip_deflections(sim.q))
    tips = np.array(tips)
    logged = (float(repr(t_deploy)), float(repr(t_command)))
    for shift, bound in ((0.0, 1e-12), (-4e-10, 1e-8), (4e-10, 1e-8)):
        motion = commanded_motion(logged[0], logged[1] + shift, command)
        _, q, _ = model.simulate_on_grid(
            motion, sim.t + 0.5 * STEP, STEP, model.initial_coordinates([0.1, 0, 0, 0]),
            max_step=MODEL_STEP,
        )  # fmt: skip
        replayed = model.tip_deflections(q[-len(tips) :])
        assert np.abs(replayed - tips).max() <= bound * np.abs(tips).max(), shift


def test_a_simulator_restarted_under_the_recorder_is_recorded_as_another_run(
    processes, operator, tmp_path
):
    """A simulator stopped and started again with more boom modes while the recorder runs:
    the recorder fetches the new simulator's parameters and stores them as a new record
    where that happened, and `sail-ros report` refuses the log in one line saying what
    changed, rather than read both runs as one with the old mode counts."""
    bag = tmp_path / "bag"
    recorder = processes("recorder", "-o", str(bag))
    counts = []
    for boom_modes in (2, 3):
        sail = {"sail.n_boom_modes": boom_modes, "sail.n_membrane_modes": 2}
        sim = processes("sim", parameters={**sail, "time_scale": 4.0})
        stored = "again: it appeared anew" if counts else "parameters of 'sail_sim'"
        recorder.wait_for_lines([stored])
        operator.wait_for_simulator(subscribers=2)  # the simulator and the recorder
        operator.spin_for(0.5)
        assert sim.stop(signal.SIGINT) == 0, sim.log()
        counts.append(boom_modes)
    operator.spin_until_quiet()
    assert recorder.stop(signal.SIGINT) == 0, recorder.log()
    records = [d for n, d in BagReader(bag).metadata() if n == topics.PARAMETERS_METADATA]
    assert [r["sail.n_boom_modes"] for r in records] == ["2", "3"]
    code, _, err = run_tool("report", [str(bag), "--out", str(tmp_path / "report")])
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(
        f"error: '{bag}' holds more than one run of the simulator: the sail parameters change "
        "(sail.n_boom_modes 2 -> 3)"
    ), err


@pytest.mark.timing
def test_the_stall_of_allowed_values_is_refused_and_the_simulator_stays_answering(
    processes, operator
):
    """The fault that stalled a simulator: max_substep_rate raised to 1e7 at run time
    (allowed), then min_length 7 mm (refused: a moving grid step there would take tens of
    seconds), then a deployment to 7.5 mm (rejected, outside the limits kept). The
    simulator keeps publishing, answers its reset at once and ends within 2 s of a SIGINT
    (it went 25 s without a state, its reset unanswered, and took 29 s to stop); at start
    the same values are refused with exit code 2 and one line."""
    sim = processes("sim", parameters={"sail.n_boom_modes": 4, "sail.n_membrane_modes": 6})
    operator.wait_for_simulator()

    def set_parameter(name, value):
        parameter = Parameter(name, value=value).to_parameter_msg()
        request = SetParameters.Request(parameters=[parameter])
        return operator.call(operator.set_parameters, request).results[0]

    assert set_parameter("max_substep_rate", 1e7).successful
    refused = set_parameter("min_length", 0.007)
    assert not refused.successful and refused.reason.startswith("min_length = 0.007 m")
    operator.deploy.publish(Float64(data=0.0075))
    status = operator.wait_for_status(
        lambda s: s[key.REJECTED] == "1", 5.0, "the deployment to be rejected"
    )
    assert "outside [min_length, max_length] = [5, " in status[key.LAST_REJECTION]
    states = len(operator.states[topics.BOOM_STATE])
    asked = time.monotonic()
    assert operator.call(operator.reset, Trigger.Request(), timeout=2.0).success
    assert time.monotonic() - asked < 2.0
    operator.spin_until(
        lambda: len(operator.states[topics.BOOM_STATE]) > states + 10, 2.0, "states after it"
    )
    assert sim.stop(signal.SIGINT, timeout=2.0) == 0, sim.log()

    short = {"max_substep_rate": 1e7, "min_length": 0.007, "initial_lengths": [0.007]}
    counts = {"sail.n_boom_modes": 4, "sail.n_membrane_modes": 6}
    refused_start = processes("sim", parameters={**short, **counts})
    assert refused_start.process.wait(30.0) == 2
    (line,) = [text for text in refused_start.log().splitlines() if "ERROR" in text]
    assert "min_length = 0.007 m would need " in line and "Traceback" not in refused_start.log()
    # at the automatic count the model such a start needs is refused before it is built
    refused_start = processes("sim", parameters=short)
    assert refused_start.process.wait(30.0) == 2
    (line,) = [text for text in refused_start.log().splitlines() if "ERROR" in text]
    assert "initial_lengths = [0.007, 0.007, 0.007, 0.007] m: the automatic membrane " in line
