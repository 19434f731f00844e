"""Driving the simulator from a terminal, as processes over real DDS (loopback).

`sail-ros send` and `sail-ros watch` against a running `sail-ros sim`: as processes
in the first tests, as the same `main` called in this process (its own rclpy context
and node, over the same DDS) where a test is about what the simulator does;
commands that must not vanish (a publisher that sends at once) and must not
come back (a restarted simulator); two sails in two namespaces; two demos at
once.
"""

import collections
import csv
import json
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from harness import SMALL_SIM, run_tool, wait_until
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bag import BagReader
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import state as state_msg

pytestmark = pytest.mark.multiprocess

FAST_STATUS = {"diagnostics_rate_hz": 10.0}  # watch waits for a status: not a second


def tool(ros_env, *args, timeout=60.0) -> subprocess.CompletedProcess:
    """Run `sail-ros <args>` to its end."""
    return subprocess.run(
        [sys.executable, "-m", "sail_ros.cli", *args],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def in_process(*args) -> subprocess.CompletedProcess:
    """Run `sail-ros <args>`'s `main` in this process, as `tool` runs its process."""
    code, out, err = run_tool(args[0], list(args[1:]))
    return subprocess.CompletedProcess(args, code, out, err)


def watch(ros_env, *ros_args, run=tool) -> dict:
    """One sample; waiting as long as processes starting on a busy machine may take."""
    result = run(*(() if run is in_process else (ros_env,)), "watch", "--once", "--json",
                 "--timeout", "30", *ros_args)  # fmt: skip
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


class Answers:
    """The answers on sail/command_status, heard by a node of the operator's context."""

    def __init__(self, operator):
        self.received: list[commands_msg.CommandAnswer] = []
        operator.create_subscription(
            DiagnosticArray,
            topics.COMMAND_STATUS,
            lambda array: self.received.extend(commands_msg.command_answers(array)),
            topics.COMMAND_STATUS_QOS,
        )


def test_send_and_watch_drive_the_simulator(processes, ros_env, tmp_path):
    sim = processes(
        "sim",
        parameters={**SMALL_SIM, "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0], **FAST_STATUS},
    )
    recorder = processes("recorder", "-o", str(tmp_path / "bag"))
    recorder.wait_for_lines(["recording /sail/deploy_cmd ", "recording /sail/boom_length_cmd "])
    first = watch(ros_env)  # waits for the simulator
    assert first["boom_length_m"] == {"a": 10.0, "b": 10.0, "c": 10.0, "d": 10.0}
    assert 0.0 < abs(first["tip_deflection_m"]["a"]) <= 0.1 + 1e-9  # it swings from 0.1 m

    deployed = tool(ros_env, "send", "deploy", "12")
    assert deployed.returncode == 0, deployed.stderr
    assert deployed.stdout.startswith("accepted: deploy to 12 m")
    # the rest in this process: the same mains, without a process start each
    refused = in_process("send", "deploy", "500")
    assert refused.returncode == 1
    assert "rejected: target = 500 m is outside [min_length, max_length]" in refused.stdout
    moved = in_process("send", "move", "--booms", "a", "c", "--point", "10", "14", "13")
    assert moved.returncode == 0, moved.stderr
    assert "accepted: trajectory for boom_a, boom_c" in moved.stdout

    view = watch(ros_env, run=in_process)
    assert view[key.ACCEPTED] == 2 and view[key.REJECTED] == 1
    assert view[key.LAST_REJECTION].startswith("target = 500 m")
    assert view["last_answer"].startswith("accepted: trajectory")
    assert view["boom_length_m"]["b"] > 10.0  # the deployment moves them

    # the recorder listens on every command topic, this clamped simulator not on the hub's:
    # a recorder alone is no simulator, and nothing is sent (no command left unanswered)
    alone = in_process("send", "--timeout", "2", "hub-wrench", "--torque-x", "0.1")
    assert alone.returncode == 1 and "simulator listening on /sail/hub_wrench_cmd" in alone.stderr

    assert in_process("send", "pause").stdout.startswith("paused at t = ")
    reset = in_process("send", "reset")
    assert reset.returncode == 0 and "reset to the initial state" in reset.stdout
    paused = watch(ros_env, run=in_process)
    assert paused[key.STATE] == "paused" and paused["boom_length_m"]["a"] == 10.0
    assert in_process("send", "resume").stdout.startswith("resumed at t = ")
    assert sim.stop(signal.SIGINT) == 0, sim.log()
    assert recorder.stop(signal.SIGINT) == 0, recorder.log()

    bag = BagReader(tmp_path / "bag")
    answers = [
        answer
        for m in bag.messages(["/sail/command_status"])
        for answer in commands_msg.command_answers(deserialize_message(m.data, DiagnosticArray))
    ]
    assert [a.outcome for a in answers] == ["accepted", "rejected", "accepted"]
    # and every command, though each sender exits as soon as it is answered
    deploys = [deserialize_message(m.data, Float64) for m in bag.messages(["/sail/deploy_cmd"])]
    assert [m.data for m in deploys] == [12.0, 500.0]
    assert len(list(bag.messages(["/sail/boom_length_cmd"]))) == 1
    assert not list(bag.messages(["/sail/hub_wrench_cmd"]))
    report = in_process("report", str(tmp_path / "bag"), "--out", str(tmp_path / "report"))
    assert report.returncode == 0, report.stderr


def test_loads_from_the_terminal_push_the_damped_sail(processes, ros_env, tmp_path):
    """`send tip-force` and `send pressure` load a damped sail; a force beyond the limit
    is rejected; the root moments, the load power and the dissipation are published
    and recorded; a reset takes the loads off."""
    sim = processes(
        "sim",
        parameters={
            **SMALL_SIM,
            "sail.mass_damping": 0.5,
            "sail.stiffness_damping": 1e-3,
            "diagnostics_rate_hz": 10.0,
        },
    )
    recorder = processes("recorder", "-o", str(tmp_path / "bag"))
    watch(ros_env, run=in_process)  # waits for the simulator
    pushed = in_process("send", "tip-force", "--booms", "b", "--values", "0.05")
    assert pushed.returncode == 0, pushed.stderr
    assert pushed.stdout.startswith("accepted: boom_b = 0.05 N (others held)")
    too_much = in_process("send", "tip-force", "--booms", "a", "--values", "5")
    assert too_much.returncode == 1
    assert "|boom_a| = 5 N exceeds max_tip_force = 1 N" in too_much.stdout
    pressed = in_process("send", "pressure", "--quadrants", "ab", "cd", "--values", "2e-3", "2e-3")
    assert pressed.returncode == 0, pressed.stderr
    bad = in_process("send", "pressure", "--quadrants", "ab", "--values", "1", "2")
    assert bad.returncode == 2
    assert "--values: one per name of --quadrants (1: ab), or one with --quadrants all; got 2" in (
        bad.stderr
    )
    time.sleep(2.0)
    view = watch(ros_env, run=in_process)
    assert view["root_moment_N_m"]["b"] > 0.0  # the force bends boom b towards +z
    assert view[key.DISSIPATION] >= 0.0 and view[key.LOAD_POWER] == view[key.LOAD_POWER]
    assert view[key.ACCEPTED] == 2 and view[key.REJECTED] == 1
    assert in_process("send", "reset").returncode == 0
    # the states after the reset, published before the recorder stops: seen by a watcher
    # (which the recorder, subscribed all along, then has too), the simulator stopped first
    watch(ros_env, run=in_process)
    assert sim.stop(signal.SIGINT) == 0, sim.log()
    assert recorder.stop(signal.SIGINT) == 0, recorder.log()

    bag = BagReader(tmp_path / "bag")
    moments = [deserialize_message(m.data, JointState) for m in
               bag.messages(["/sail/root_moment"])]  # fmt: skip
    assert moments and list(moments[-1].name) == list(topics.ROOT_JOINTS)
    assert max(m.effort[1] for m in moments) > 0.0
    statuses = [
        deserialize_message(m.data, DiagnosticArray) for m in bag.messages(["/diagnostics"])
    ]
    keys = {pair.key for array in statuses for pair in array.status[0].values}
    assert {key.LOAD_POWER, key.DISSIPATION} <= keys
    # the log runs again offline from what it records (motion, loads from the answers,
    # the state after the reset): its true peaks, the logged tips reproduced
    report = in_process("report", str(tmp_path / "bag"), "--out", str(tmp_path / "report"),
                  "--no-convergence")  # fmt: skip
    assert report.returncode == 0, report.stderr
    found = re.search(
        r"a rerun of the logged motion, loads and state \((\d+) runs: resets\) "
        r"reproduces the logged tips to ([0-9.e+-]+) of their peak",
        report.stdout,
    )
    # the recorder's log too: once a log lacked sail/shape and sail/command_status
    assert found and int(found[1]) == 2 and float(found[2]) < 1e-3, report.stdout + recorder.log()
    rows = {row["source"]: row for row in csv.DictReader((tmp_path / "report/peaks.csv").open())}
    sampled = max(abs(float(m.effort[1])) for m in moments)
    assert float(rows["rerun"]["peak_root_moment_b_N_m"]) >= sampled * (1 - 1e-3)


def test_send_without_a_simulator_is_a_clear_error(ros_env):
    started = time.monotonic()
    result = tool(ros_env, "send", "--timeout", "2", "deploy", "12", "--ros-args", "-r",
                  "__ns:=/nobody_here")  # fmt: skip
    assert time.monotonic() - started < 15.0
    assert result.returncode == 1
    assert result.stderr.startswith("error: no simulator listening on /nobody_here/sail/deploy_cmd")
    assert "Traceback" not in result.stderr
    bad = tool(ros_env, "send", "move", "--booms", "a", "c", "--point", "5", "12")
    assert bad.returncode == 2 and "needs a time and 2 length(s)" in bad.stderr


def test_commands_from_publishers_that_send_at_once_all_arrive(processes, operator):
    """Six trajectory commands, each from a fresh publisher that sends as soon as it
    sees the simulator (the documented way: transient local) and waits for its
    acknowledgement and its answer: every one is accepted. Without waiting for the
    answer two of them may land in one batch of the simulator's intake, where the newer
    supersedes the older, as documented."""
    answers = Answers(operator)
    processes("sim", parameters=SMALL_SIM)
    operator.wait_for_simulator()
    for i in range(6):
        node = Node(f"hand_written_{i}", context=operator.context)
        publisher = node.create_publisher(
            JointTrajectory, topics.BOOM_LENGTH_CMD, topics.LATCHED_COMMAND_QOS
        )
        wait_until(
            lambda p=publisher: p.get_subscription_count() >= 1,
            10.0,
            "the simulator",
            executor=operator.spinner,
        )
        command = JointTrajectory(joint_names=["boom_b"])
        command.points = [JointTrajectoryPoint(positions=[10.0 + 0.1 * (i + 1)])]
        command.points[0].time_from_start.sec = 5
        publisher.publish(command)
        assert publisher.wait_for_all_acked(Duration(seconds=5.0))
        operator.spin_until(lambda n=i + 1: len(answers.received) >= n, 10.0, f"answer {i + 1}")
        node.destroy_node()
    assert [a.outcome for a in answers.received] == ["accepted"] * 6
    assert all(a.topic == "/sail/boom_length_cmd" for a in answers.received)


def test_a_burst_beyond_the_command_queue_waits_and_is_answered_and_counted(processes, operator):
    """30 commands at once into a queue of 2 while the simulator integrates as fast as
    it can (its thread busy in 20 ms ticks): the burst waits for ticks to take the full
    queue instead of being rejected, each command gets exactly one answer, accepted or
    superseded by a newer one of its batch, and /diagnostics counts exactly those; what
    still finds the queue full after the wait is rejected (test_sim_node)."""
    answers = Answers(operator)
    processes("sim", parameters={**SMALL_SIM, "time_scale": 0.0, "max_queued_commands": 2})
    operator.wait_for_simulator()
    # reliable, volatile, keeping all 30 until acknowledged
    publisher = operator.create_publisher(Float64, topics.DEPLOY_CMD, QoSProfile(depth=100))
    wait_until(
        lambda: publisher.get_subscription_count() >= 1,
        10.0,
        "the simulator",
        executor=operator.spinner,
    )
    for k in range(30):
        publisher.publish(Float64(data=11.0 + 0.1 * k))
    assert publisher.wait_for_all_acked(Duration(seconds=10.0))
    operator.spin_until(lambda: len(answers.received) >= 30, 20.0, "30 answers")
    operator.spin_for(0.5)
    assert sorted(a.sequence for a in answers.received) == list(range(1, 31))
    outcomes = collections.Counter(a.outcome for a in answers.received)
    assert set(outcomes) <= {"accepted", "superseded"} and outcomes["accepted"] >= 1, outcomes
    status = operator.wait_for_status(lambda s: True, 5.0, "a status")
    assert int(status[key.DROPPED]) == int(status[key.REJECTED]) == 0
    assert int(status[key.ACCEPTED]) == outcomes["accepted"]
    assert int(status[key.SUPERSEDED]) == outcomes["superseded"]


def test_a_started_simulator_does_not_run_commands_published_before(processes, operator):
    """A transient-local publisher keeps its last command; a simulator started later
    receives it, says it ignored it, and does not move."""
    answers = Answers(operator)
    publisher = operator.create_publisher(Float64, topics.DEPLOY_CMD, topics.LATCHED_COMMAND_QOS)
    publisher.publish(Float64(data=20.0))
    time.sleep(0.2)  # the command is older than the simulator
    processes("sim", parameters=SMALL_SIM)
    operator.wait_for_simulator()
    operator.spin_until(lambda: answers.received, 10.0, "the answer")
    (answer,) = answers.received
    assert answer.outcome == "ignored"
    assert answer.message == "published before this simulator started; not run"
    operator.spin_for(1.0)
    last = operator.states[topics.BOOM_STATE][-1]
    assert list(last.position) == [10.0] * 4
    assert operator.status()[key.ACCEPTED] == "0"


def test_two_sails_in_two_namespaces_run_side_by_side(processes, ros_env, tmp_path):
    sat1 = processes(
        "sim", "--ros-args", "-r", "__ns:=/sat1", parameters={**SMALL_SIM, **FAST_STATUS}
    )
    sat2 = processes(
        "sim", "--ros-args", "-r", "__ns:=/sat2", parameters={**SMALL_SIM, **FAST_STATUS}
    )
    recorders = [
        processes("recorder", "-o", str(tmp_path / ns), "--ros-args", "-r", f"__ns:=/{ns}")
        for ns in ("sat1", "sat2")
    ]
    assert (
        watch(ros_env, "--ros-args", "-r", "__ns:=/sat1", run=in_process)["simulator"]
        == "/sat1/sail_sim"
    )
    sent = in_process("send", "deploy", "11", "--ros-args", "-r", "__ns:=/sat1")
    assert sent.returncode == 0, sent.stderr
    time.sleep(1.0)
    moving = watch(ros_env, "--ros-args", "-r", "__ns:=/sat1", run=in_process)
    resting = watch(ros_env, "--ros-args", "-r", "__ns:=/sat2", run=in_process)
    assert moving["boom_length_m"]["a"] > 10.0 and moving[key.ACCEPTED] == 1
    assert resting["boom_length_m"]["a"] == 10.0 and resting[key.ACCEPTED] == 0
    for recorder in recorders:  # each has its own simulator's parameters before they stop
        recorder.wait_for_lines(["parameters of 'sail_sim'"])
    for process in (sat1, sat2, *recorders):
        assert process.stop(signal.SIGINT) == 0, process.log()

    for ns, commands in (("sat1", 1), ("sat2", 0)):
        bag = BagReader(tmp_path / ns)
        names = set(bag.topics())
        own = {name for name in names if name.startswith(f"/{ns}/")}
        assert f"/{ns}/sail/boom_state" in own and f"/{ns}/sail/tip_deflection" in own
        assert names - own <= {"/diagnostics", "/clock", "/parameter_events"}  # global in ROS
        status = bag.topics().get(f"/{ns}/sail/command_status")
        assert (status.message_count if status else 0) == commands  # answers are kept
        parameters = dict(bag.metadata())[topics.PARAMETERS_METADATA]
        assert "sail.n_boom_modes" in parameters  # the simulator of its namespace
        report = in_process("report", str(tmp_path / ns), "--out", str(tmp_path / f"r_{ns}"))
        assert report.returncode == 0, report.stderr


def test_two_demos_at_once_each_log_only_their_own_run(ros_env, tmp_path):
    demo = [sys.executable, "-m", "sail_ros.cli", "demo", "--time-scale", "5", "-o"]
    demos = [
        subprocess.Popen(
            [*demo, str(tmp_path / name)],
            env=ros_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for name in ("one", "two")
    ]
    outputs = [demo.communicate(timeout=180)[0] for demo in demos]
    for demo, output in zip(demos, outputs, strict=True):
        assert demo.returncode == 0, output
    domains = [int(output.split("DDS domain ")[1].split(",")[0]) for output in outputs]
    assert domains[0] != domains[1]
    for name in ("one", "two"):
        bag = BagReader(tmp_path / name)
        answers = bag.topics()["/sail/command_status"].message_count
        assert answers == 1  # its own deployment, not the other's
        stamps = np.array(
            [
                (lambda h: h.stamp.sec * 10**9 + h.stamp.nanosec)(
                    deserialize_message(m.data, JointState).header
                )
                for m in bag.messages(["/sail/boom_state"])
            ]
        )
        steps = np.diff(stamps)
        # one simulator: a state every 20 ms of simulation time, except across the reset
        assert np.count_nonzero(steps <= 0) <= 1
        assert np.median(steps) == 20_000_000


@pytest.mark.timing
def test_a_publisher_that_behaves_like_ros2_topic_pub_once_reaches_the_simulator(
    processes, operator
):
    """What Jazzy's `ros2 topic pub --once --qos-durability transient_local` does
    (ros2cli 0.32): reliable, transient local, keep last 10; wait for one matching
    subscription; publish once; stay 0.1 s; exit. Five times, five answers.

    Timed, so alone: the publisher sees the simulator's subscription before the simulator
    sees the publisher, and the command reaches it only if the simulator's discovery
    catches up within those 0.1 s of wall time, which a machine saturated by other tests
    can delay past them."""
    answers = Answers(operator)
    processes("sim", parameters=SMALL_SIM)
    operator.wait_for_simulator()
    for i in range(5):
        node = Node(f"ros2_topic_pub_{i}", context=operator.context)
        publisher = node.create_publisher(Float64, topics.DEPLOY_CMD, topics.LATCHED_COMMAND_QOS)
        wait_until(
            lambda p=publisher: p.get_subscription_count() >= 1,
            10.0,
            "a matching subscription",
            executor=operator.spinner,
        )
        publisher.publish(Float64(data=10.5 + 0.5 * i))
        time.sleep(0.1)  # --keep-alive 0.1
        node.destroy_node()
    operator.spin_until(lambda: len(answers.received) >= 5, 10.0, "five answers")
    assert [a.outcome for a in answers.received] == ["accepted"] * 5


@pytest.mark.parametrize(("late", "after_s"), [("the last sample", 1.5), ("the root moments", 3.0)])
def test_watch_waits_for_the_newest_sample_its_status_counts(operator, ros_env, late, after_s):
    """The tail of a simulator's kept state history can reach a late subscriber after the
    rest, and one topic's history after another's (DDS resends what a loaded machine lost
    at the writer's next heartbeat): `watch --once` shows, on every state topic, the
    sample the status counts, not the newest to have arrived. A stand-in simulator (a node
    of the simulator's name) publishes three samples (booms at 10, 11, 12 m, root moments
    of 1, 2, 3 N m) and a status counting four; `after_s` after `watch` subscribed go out
    the fourth sample (13 m, 4 N m), or, with the other topics' four at once, the four
    root moments (a watcher that did not wait for them printed their moments as NaN about
    1.1 s after it subscribed)."""
    sim_name = "/" + topics.SIM_NODE
    simulator = Node(topics.SIM_NODE, context=operator.context)
    operator.spinner.add_node(simulator)
    state = {
        name: simulator.create_publisher(JointState, name, topics.STATE_QOS)
        for name in (topics.BOOM_STATE, topics.TIP_DEFLECTION, topics.ROOT_MOMENT)
    }
    status = simulator.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, topics.DIAGNOSTICS_QOS)
    simulator.create_publisher(DiagnosticArray, topics.COMMAND_STATUS, topics.COMMAND_STATUS_QOS)

    def publish_sample(i: int, moments: bool = True, others: bool = True) -> None:
        stamp, zero = i * 10**9, np.zeros(4)
        if others:
            lengths = np.full(4, 9.0 + i)
            state[topics.BOOM_STATE].publish(state_msg.boom_state(stamp, lengths, zero))
            state[topics.TIP_DEFLECTION].publish(state_msg.tip_deflection(stamp, zero, zero))
        if moments:
            state[topics.ROOT_MOMENT].publish(state_msg.root_moment(stamp, np.full(4, float(i))))

    last_only = late == "the last sample"
    for i in (1, 2, 3) if last_only else (1, 2, 3, 4):
        publish_sample(i, moments=last_only)
    values = {key.STATE: "paused", key.SIM_TIME: 4.0, key.STATE_SAMPLES: 4}
    simulator.create_timer(
        0.1,
        lambda: status.publish(
            diagnostics_msg.diagnostics(4 * 10**9, "OK", "paused", values, sim_name)
        ),
    )
    watching = subprocess.Popen(
        [sys.executable, "-m", "sail_ros.cli", "watch", "--once", "--json", "--timeout", "30"],
        env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        operator.spin_until(
            lambda: state[topics.BOOM_STATE].get_subscription_count() > 0, 30.0, "watch"
        )
        operator.spin_for(after_s)
        for i in (4,) if last_only else (1, 2, 3, 4):
            publish_sample(i, others=last_only)
        operator.spin_until(lambda: watching.poll() is not None, 30.0, "watch to print")
        out, err = watching.communicate()
    finally:
        if watching.poll() is None:
            watching.kill()
        operator.spinner.remove_node(simulator)
        simulator.destroy_node()
    assert watching.returncode == 0, err
    view = json.loads(out)
    assert view["boom_length_m"]["a"] == 13.0 and view["root_moment_N_m"]["a"] == 4.0


def test_a_hub_wrench_from_the_terminal_tilts_a_free_hub_and_watch_shows_it(processes, ros_env):
    """`send hub-wrench` to a simulator with a free hub: a torque about x within
    max_hub_torque is accepted and tilts the hub about x, which `watch` shows from
    /sail/hub_state; one beyond the limit is rejected in the policy's words (exit 1); a
    value that is not finite never leaves the terminal (exit 2)."""
    # a free hub's booms need 4.4 times the sub-steps: 1 m ones are more than real time
    # affords (runtime.affordable)
    processes(
        "sim",
        parameters={**SMALL_SIM, "sail.free_hub": True, **FAST_STATUS},
    )
    assert "hub" in watch(ros_env, run=in_process)  # waits for the simulator
    pushed = in_process("send", "hub-wrench", "--torque-x", "0.5")
    assert pushed.returncode == 0, pushed.stderr
    assert pushed.stdout.startswith("accepted: hub force_z = 0 N, torque_x = 0.5 N m")
    too_much = in_process("send", "hub-wrench", "--torque-y", "5")
    assert too_much.returncode == 1
    assert "|torque.y| = 5 N m exceeds max_hub_torque = 1 N m" in too_much.stdout
    bad = in_process("send", "hub-wrench", "--force", "nan")
    assert bad.returncode == 2 and bad.stderr == "error: --force = nan N is not finite\n"
    time.sleep(1.0)
    hub = watch(ros_env, run=in_process)["hub"]
    assert hub["theta_x_rad"] > 0.0 and hub["thd_x_rad_s"] > 0.0
    assert abs(hub["theta_y_rad"]) < 1e-3 * hub["theta_x_rad"]
    text = in_process("watch", "--once", "--timeout", "30")
    assert "  free hub: heave z_h " in text.stdout and "|theta|" in text.stdout
