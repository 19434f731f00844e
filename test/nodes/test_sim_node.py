"""Node `sail_sim` in this process: a private rclpy Context, its own executor,
and a client node in the same context talking to it over (loopback) DDS."""

import contextlib
import errno
import math
import os
import threading
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from harness import SMALL_SIM, Serving, private_context
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, SetParameters
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from sail_ros import status as key
from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.model.fields import ConfigError
from sail_ros.nodes import sim as sim_node
from sail_ros.nodes.sim import SPECS, SimNode, main
from sail_ros.ros.commanding import command_publisher

pytestmark = pytest.mark.node

SMALL = {"sail.n_boom_modes": 4, "sail.n_membrane_modes": 6}  # whatever the defaults


@pytest.fixture
def ros(monkeypatch, tmp_path):
    """A private context on a test-private domain, localhost only; yields a factory
    `start(**parameters) -> (sim node, client node, spin_until)`."""
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path))
    stack = contextlib.ExitStack()
    context = stack.enter_context(private_context())
    serving = Serving(context)

    def start(**parameters):
        parameters = {**SMALL_SIM, **parameters}
        overrides = [Parameter(name, value=value) for name, value in parameters.items()]
        sim = SimNode(overrides, context=context)
        sim.start()
        client = Client(context)
        serving.add(sim, client)
        serving.spin_until(lambda: client.diagnostics, 5.0, "the first diagnostics")
        return sim, client, serving.spin_until

    yield start
    serving.close()
    stack.close()


class Client(Node):
    """Subscribes to the simulator's outputs and holds clients of its services."""

    def __init__(self, context):
        super().__init__("sim_test_client", context=context)
        self.boom_states, self.clocks, self.diagnostics = [], [], []
        self.create_subscription(
            JointState, topics.BOOM_STATE, self.boom_states.append, topics.STATE_QOS
        )
        self.create_subscription(Clock, topics.CLOCK, self.clocks.append, topics.CLOCK_QOS)
        self.create_subscription(
            DiagnosticArray,
            topics.DIAGNOSTICS,
            lambda m: self.diagnostics.append(diagnostics_msg.diagnostic_values(m)),
            topics.DIAGNOSTICS_QOS,
        )
        self.describe = self.create_client(DescribeParameters, "/sail_sim/describe_parameters")
        self.set = self.create_client(SetParameters, "/sail_sim/set_parameters")
        self.reset = self.create_client(Trigger, topics.RESET_SERVICE)
        self.pause = self.create_client(SetBool, topics.PAUSE_SERVICE)


def call(spin_until, client, request, timeout=5.0):
    spin_until(client.service_is_ready, timeout, f"service {client.srv_name}")
    future = client.call_async(request)
    spin_until(future.done, timeout, f"an answer from {client.srv_name}")
    return future.result()


def seconds(message) -> float:
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def test_parameters_are_described_over_the_parameter_services(ros):
    _, client, spin_until = ros()
    names = [spec.name for spec in SPECS]
    described = call(spin_until, client.describe, DescribeParameters.Request(names=names))
    by_name = {d.name: d for d in described.descriptors}
    assert set(by_name) == set(names)
    for spec in SPECS:
        descriptor = by_name[spec.name]
        assert descriptor.description == spec.description
        assert descriptor.read_only == spec.spec.read_only
    assert by_name["sail.boom_bending_stiffness"].read_only
    assert by_name["max_rate"].floating_point_range[0].from_value == pytest.approx(1e-6)
    assert by_name["sail.n_boom_modes"].integer_range[0].to_value == 30
    assert by_name["initial_lengths"].type == ParameterType.PARAMETER_DOUBLE_ARRAY


def test_writable_parameters_are_validated_then_applied(ros):
    sim, client, spin_until = ros()

    def set_parameter(name, value):
        parameter = Parameter(name, value=value).to_parameter_msg()
        request = SetParameters.Request(parameters=[parameter])
        return call(spin_until, client.set, request).results[0]

    result = set_parameter("min_length", 20.0)  # the initial lengths (10 m) would be too short
    assert not result.successful and result.reason == (
        "initial_lengths of boom a = 10 m is outside [min_length, max_length] = [20, 70.7107] m"
    )
    result = set_parameter("time_scale", 2.0)
    assert not result.successful and "read-only" in result.reason
    result = set_parameter("max_rate", float("nan"))
    assert not result.successful
    assert sim.config.policy.min_length == 5.0 and math.isfinite(sim.config.policy.max_rate)
    # an integer for a double, as `ros2 param set /sail_sim max_rate 2` sends it
    assert set_parameter("max_rate", 2).successful and sim.config.policy.max_rate == 2.0
    assert sim.get_parameter("max_rate").value == 2.0

    assert set_parameter("state_rate_hz", 10.0).successful
    # three samples of the new rate (stamped well after the change: some of the old rate
    # may still wait to be taken)
    later = sim.run.epoch_ns / 1e9 + sim.sim.t + 0.2

    def new_rate():
        return [seconds(m) for m in client.boom_states if seconds(m) > later]

    spin_until(lambda: len(new_rate()) >= 3, 5.0, "boom states at 10 Hz")
    assert np.diff(new_rate()[:3]) == pytest.approx([0.1, 0.1], abs=1e-6)


def test_as_fast_as_possible_publishes_clock(ros):
    sim, client, spin_until = ros(time_scale=0.0, shape_rate_hz=0.0)
    started = time.monotonic()
    spin_until(lambda: sim.sim.t > 20.0, 60.0, "20 s of simulation time")
    assert sim.sim.t / (time.monotonic() - started) > 2.0  # well ahead of the wall clock
    spin_until(lambda: len(client.clocks) > 100, 5.0, "/clock")
    # simulation times on the integration grid (samples are dropped: the client is slower)
    stamps = np.array([c.clock.sec * 10**9 + c.clock.nanosec for c in client.clocks])
    clock = stamps - sim.run.epoch_ns
    assert np.all(np.diff(clock) >= 0)
    assert clock / 1e7 == pytest.approx(np.round(clock / 1e7), abs=1e-6)


def test_clock_never_repeats_a_stamp(ros):
    """/clock moves forward with every message: through statuses (20 a second here, each
    at the latest sample's time), a pause and a reset (whose own sample repeats the stamp
    of the state it leaves), so a `use_sim_time` node never sees its clock stand still."""
    sim, client, spin_until = ros(
        time_scale=2.0, diagnostics_rate_hz=20.0, shape_rate_hz=0.0, state_rate_hz=20.0
    )
    spin_until(lambda: sim.sim.t > 0.5, 5.0, "0.5 s of simulation")
    call(spin_until, client.pause, SetBool.Request(data=True))
    spin_until(lambda: len(client.diagnostics) > 10, 5.0, "statuses while paused")
    call(spin_until, client.pause, SetBool.Request(data=False))
    spin_until(lambda: sim.sim.t > 1.0, 5.0, "1 s of simulation")
    call(spin_until, client.reset, Trigger.Request())
    reset_at = sim.sim.t
    spin_until(lambda: sim.sim.t > reset_at + 0.5, 5.0, "0.5 s after the reset")
    stamps = np.array([c.clock.sec * 10**9 + c.clock.nanosec for c in client.clocks])
    assert len(stamps) > 30 and np.all(np.diff(stamps) > 0), np.diff(stamps).min()


def test_pause_resume_and_reset(ros):
    sim, client, spin_until = ros(
        initial_tip_deflection=[0.0, 0.05, 0.0, 0.0], diagnostics_rate_hz=20.0
    )
    spin_until(lambda: sim.sim.t > 0.3, 5.0, "0.3 s of simulation")
    answer = call(spin_until, client.pause, SetBool.Request(data=True))
    assert answer.success and answer.message.startswith("paused at t = ")
    spin_until(lambda: client.diagnostics[-1][key.STATE] == "paused", 2.0, "state paused")
    held = sim.sim.t
    deadline = time.monotonic() + 0.3
    spin_until(lambda: time.monotonic() > deadline, 1.0, "0.3 s of pause")
    assert sim.sim.t == held  # and no state published again, none stamped after the pause
    stamps = [seconds(m) for m in client.boom_states]
    assert np.all(np.diff(stamps) > 0) and stamps[-1] <= sim.run.epoch_ns / 1e9 + held + 1e-6
    assert call(spin_until, client.pause, SetBool.Request(data=True)).message == "already paused"
    assert call(spin_until, client.pause, SetBool.Request(data=False)).success
    spin_until(lambda: sim.sim.t > held + 0.2, 2.0, "the simulation to go on")
    # paced again from where it stopped, not catching up the paused time
    assert sim.sim.t < held + 1.0

    assert not np.allclose(sim.sim.q, sim.sim.model.initial_coordinates([0, 0.05, 0, 0]))
    # paused, so that no tick moves the state between the reset and this check
    assert call(spin_until, client.pause, SetBool.Request(data=True)).success
    answer = call(spin_until, client.reset, Trigger.Request())
    assert answer.success and "reset to the initial state" in answer.message
    assert answer.message.endswith("(paused)")
    assert sim.sim.q == pytest.approx(sim.sim.model.initial_coordinates([0, 0.05, 0, 0]), abs=1e-15)
    assert sim.sim.t >= held  # time goes on: stamps never go backwards


def test_command_times_read_minus_one_when_there_is_none(ros):
    sim, client, spin_until = ros(diagnostics_rate_hz=20.0)
    status = client.diagnostics[-1]
    assert (status[key.LAST_COMMAND_START], status[key.MOTION_END]) == ("-1.0", "-1.0")
    deploy = command_publisher(client, topics.DEPLOY_CMD)
    spin_until(lambda: deploy.get_subscription_count() >= 1, 5.0, "the deploy subscription")
    deploy.publish(Float64(data=11.0))
    spin_until(lambda: client.diagnostics[-1][key.ACCEPTED] == "1", 5.0, "the command")
    start = float(client.diagnostics[-1][key.LAST_COMMAND_START])
    assert 0.0 <= start < float(client.diagnostics[-1][key.MOTION_END])
    assert call(spin_until, client.reset, Trigger.Request()).success
    spin_until(
        lambda: client.diagnostics[-1][key.MOTION_END] == "-1.0", 2.0, "the status after the reset"
    )  # the reset ended the motion...
    assert float(client.diagnostics[-1][key.LAST_COMMAND_START]) == start  # ...not its record


def test_bytes_that_are_no_command_are_answered_and_counted(ros):
    """CDR bytes on a command topic that are no message of its type (too short for a
    Float64) are answered rejected, saying so, logged and counted, as the outcome counts
    must add up to every command received; the well-formed command after them runs."""
    sim, client, spin_until = ros(diagnostics_rate_hz=20.0, shape_rate_hz=0.0)
    answers = []
    client.create_subscription(
        DiagnosticArray,
        topics.COMMAND_STATUS,
        lambda m: answers.extend(commands_msg.command_answers(m)),
        topics.COMMAND_STATUS_QOS,
    )
    deploy = command_publisher(client, topics.DEPLOY_CMD)
    spin_until(lambda: deploy.get_subscription_count() >= 1, 5.0, "the deploy subscription")
    time.sleep(0.3)  # the simulator's side of the match too (volatile: nothing before it)
    deploy.publish(b"\x00\x01\x00\x00\x00")  # a CDR header and one byte of a double
    deploy.publish(Float64(data=11.0))
    spin_until(lambda: len(answers) >= 2, 5.0, "two answers")
    assert [a.outcome for a in answers] == ["rejected", "accepted"], answers
    assert answers[0].topic == "/sail/deploy_cmd"
    assert answers[0].message.startswith(
        "5 bytes are not a std_msgs/msg/Float64 in CDR (failed to deserialize ROS message"
    ), answers[0].message
    spin_until(lambda: client.diagnostics[-1][key.ACCEPTED] == "1", 5.0, "the counts")
    status = client.diagnostics[-1]
    assert status[key.REJECTED] == "1" and "5 bytes are not a" in status[key.LAST_REJECTION]


@pytest.mark.parametrize("wait", ["for a tick", "not at all"])
def test_a_burst_larger_than_the_queue_waits_for_a_tick_instead_of_being_rejected(
    ros, monkeypatch, wait
):
    """300 deploy commands at once at a queue of 10 (`max_queued_commands`), from a
    publisher that keeps them all: the commands' thread has a tick take each full queue
    rather than rejecting the rest, and every command ends accepted or superseded. With
    no wait (`QUEUE_WAIT_S` 0), what finds the queue full is rejected, saying why, and
    counted as dropped; the counts still add up."""
    if wait == "not at all":
        monkeypatch.setattr(sim_node, "QUEUE_WAIT_S", 0.0)
    sim, client, spin_until = ros(max_queued_commands=10, diagnostics_rate_hz=20.0)
    deep = QoSProfile(
        depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE
    )
    quiet = PublisherEventCallbacks(incompatible_qos=lambda event: None)
    deploy = client.create_publisher(Float64, topics.DEPLOY_CMD, deep, event_callbacks=quiet)
    spin_until(lambda: deploy.get_subscription_count() >= 1, 5.0, "the deploy subscription")
    time.sleep(0.5)  # the simulator's side of the match too (volatile: nothing before it)
    for i in range(300):
        deploy.publish(Float64(data=10.5 + 0.001 * i))
    outcomes = (key.ACCEPTED, key.SUPERSEDED, key.REJECTED)
    spin_until(
        lambda: sum(int(client.diagnostics[-1][name]) for name in outcomes) >= 300,
        10.0,
        "every command counted",
    )
    status = client.diagnostics[-1]
    assert sum(int(status[name]) for name in outcomes) == 300
    assert int(status[key.DROPPED]) == int(status[key.REJECTED]), status
    if wait == "for a tick":
        assert int(status[key.REJECTED]) == 0, status
    else:
        assert int(status[key.REJECTED]) > 0, status
        assert sim.run.queue.overflowed == int(status[key.DROPPED])


def _fifo_threads() -> dict[str, int]:
    """Name -> SCHED_FIFO priority of this process's live Python threads that have it."""
    return {
        thread.name: os.sched_getparam(thread.native_id)[0]
        for thread in threading.enumerate()
        if os.sched_getscheduler(thread.native_id) == os.SCHED_FIFO
    }


def test_realtime_priority_puts_the_integration_thread_alone_on_fifo_scheduling(ros):
    sim, client, spin_until = ros(realtime_priority=40, diagnostics_rate_hz=20.0)
    spin_until(lambda: sim.sim.t > 0.2, 5.0, "0.2 s of simulation")
    if sim.run.realtime_priority == 0:  # refused: then so is any thread here
        with pytest.raises(PermissionError):
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(40))
        assert _fifo_threads() == {}
    else:
        assert sim.run.realtime_priority == 40
        assert _fifo_threads() == {"sail_sim ticks": 40}
    assert client.diagnostics[-1][key.REALTIME_PRIORITY] == str(sim.run.realtime_priority)


def test_realtime_priority_is_not_used_as_fast_as_possible(ros):
    sim, client, _ = ros(realtime_priority=40, time_scale=0.0, shape_rate_hz=0.0)
    assert sim.run.realtime_priority == 0 and _fifo_threads() == {}
    assert client.diagnostics[-1][key.REALTIME_PRIORITY] == "0"


def test_a_refused_realtime_priority_leaves_normal_scheduling(ros, monkeypatch):
    def refuse(*_):
        raise PermissionError(errno.EPERM, os.strerror(errno.EPERM))

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    sim, client, spin_until = ros(realtime_priority=40)
    spin_until(lambda: sim.sim.t > 0.1, 5.0, "the simulation to run")
    assert sim.run.realtime_priority == 0 and _fifo_threads() == {}
    assert client.diagnostics[-1][key.REALTIME_PRIORITY] == "0"


def test_bad_parameter_values_stop_the_start(ros):
    with pytest.raises(ConfigError, match="parameter max_rate: .*out of range"):
        ros(max_rate=500.0)
    with pytest.raises(ConfigError, match="initial_lengths must hold 1 or 4 values"):
        ros(initial_lengths=[10.0, 11.0])
    with pytest.raises(ConfigError, match="parameter realtime_priority: .*out of range"):
        ros(realtime_priority=100)


def test_booms_shorter_than_the_model_affords_are_refused_at_start_and_at_run_time(ros):
    """min_length 7 mm with max_substep_rate 1e7 (both within their ranges) would make a
    moving grid step take tens of seconds, the simulator deaf to services and signals
    meanwhile: refused at start, and as a change at run time, whichever of the two
    parameters comes last; the simulator goes on and answers its reset."""
    short = {"max_substep_rate": 1e7, "min_length": 0.007, "initial_lengths": [0.007]}
    with pytest.raises(ConfigError, match=r"^min_length = 0\.007 m would need \d+ sub-steps"):
        ros(**short)
    sim, client, spin_until = ros(**SMALL, diagnostics_rate_hz=20.0)

    def set_parameters(**values):
        parameters = [Parameter(n, value=v).to_parameter_msg() for n, v in values.items()]
        return call(spin_until, client.set, SetParameters.Request(parameters=parameters))

    assert set_parameters(max_substep_rate=1e7).results[0].successful
    (result,) = set_parameters(min_length=0.007).results
    assert not result.successful
    assert result.reason.startswith("min_length = 0.007 m would need "), result.reason
    assert "the shortest affordable min_length here is " in result.reason
    assert sim.config.policy.min_length == 5.0
    assert call(spin_until, client.reset, Trigger.Request()).success


@pytest.mark.timing
def test_a_grid_step_of_seconds_blocks_neither_the_services_nor_the_stop(ros):
    """A grid step that takes 2 s (a model costlier than it was measured at start): a
    reset asked meanwhile is answered once the step ends, while the executor answers
    everything else at once (it waited for the step inside the reset before), and the
    node stops within a second, without waiting for the step."""
    sim, client, spin_until = ros(**SMALL, diagnostics_rate_hz=20.0, shape_rate_hz=0.0)
    original, slow = sim.sim.step, threading.Event()

    def step():
        if not slow.is_set():
            slow.set()
            time.sleep(2.0)
        return original()

    sim.sim.step = step
    spin_until(slow.is_set, 5.0, "the slow step")
    spin_until(client.reset.service_is_ready, 5.0, "the reset service")
    reset = client.reset.call_async(Trigger.Request())
    asked = time.monotonic()
    names = DescribeParameters.Request(names=["max_rate"])
    described = call(spin_until, client.describe, names)
    assert described.descriptors[0].name == "max_rate" and time.monotonic() - asked < 1.0
    assert not reset.done()
    spin_until(reset.done, 5.0, "the reset's answer")
    assert reset.result().success and "reset to the initial state" in reset.result().message
    slow.clear()  # one more slow step, under way as the node stops
    spin_until(slow.is_set, 5.0, "the next slow step")
    stopping = time.monotonic()
    sim.close()
    assert time.monotonic() - stopping < 1.0 + sim_node.ACK_TIMEOUT_S


def test_an_integer_is_taken_for_a_double_as_ros_users_type_it(ros):
    """`-p time_scale:=2` (rclpy reads an INTEGER) starts a simulator at 2x."""
    sim, client, spin_until = ros(time_scale=2, max_rate=2)
    assert sim.config.time_scale == 2.0 and sim.config.policy.max_rate == 2.0
    assert sim.get_parameter("time_scale").type_ == Parameter.Type.DOUBLE


def test_main_exits_2_on_a_bad_parameter(monkeypatch, tmp_path):
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path))
    assert main(["--ros-args", "-p", "max_length:=0.5"]) == 2
    assert main(["--definitely-not-an-option"]) == 2


def test_a_free_hub_publishes_its_state_and_takes_its_wrench(ros):
    """`sail.free_hub`: /sail/hub_state (nav_msgs/Odometry, sail_inertial -> sail) with
    every state sample, its orientation the quaternion of the tilt vector; a wrench on
    /sail/hub_wrench_cmd is answered and moves the hub; the modal state names the hub's
    coordinates."""
    from nav_msgs.msg import Odometry

    sim, client, spin_until = ros(
        **{
            "sail.free_hub": True,
            "sail.hub_mass": 20.0,
            "sail.hub_inertia_x": 10.0,
            "sail.hub_inertia_y": 10.0,
        },  # fmt: skip
        initial_hub_velocity=[0.0, 0.02, -0.01],
    )
    hubs, answers = [], []
    client.create_subscription(Odometry, topics.HUB_STATE, hubs.append, topics.STATE_QOS)
    client.create_subscription(
        DiagnosticArray,
        topics.COMMAND_STATUS,
        lambda m: answers.extend(commands_msg.command_answers(m)),
        topics.COMMAND_STATUS_QOS,
    )
    spin_until(lambda: len(hubs) > 20, 5.0, "hub states")
    last = hubs[-1]
    assert last.header.frame_id == "sail_inertial" and last.child_frame_id == "sail"
    theta_x = float(np.asarray(sim.sim.sample().hub)[1])  # not the same sample: the rate
    assert last.twist.twist.angular.x == pytest.approx(0.02, rel=0.2)
    assert last.pose.pose.orientation.w == pytest.approx(1.0, abs=1e-3) and theta_x > 0
    q = last.pose.pose.orientation
    assert q.x**2 + q.y**2 + q.z**2 + q.w**2 == pytest.approx(1.0, abs=1e-12)
    wrench = command_publisher(client, topics.HUB_WRENCH_CMD)
    spin_until(lambda: wrench.get_subscription_count() >= 1, 5.0, "the wrench subscription")
    wrench.publish(hub_msg.hub_wrench_command(0.5, 0.0, 0.0))
    spin_until(lambda: answers, 5.0, "the answer")
    assert answers[-1].outcome == "accepted" and answers[-1].topic == "/sail/hub_wrench_cmd"
    spin_until(lambda: hubs[-1].twist.twist.linear.z > 0.0, 5.0, "the hub heaving up")
    assert sim.sim.model.coordinate_names[-3:] == ["hub_heave", "hub_tilt_x", "hub_tilt_y"]
