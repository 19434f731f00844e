"""`sail_recorder` and `sail_replay` as separate processes over real DDS.

A publisher process stands in for the simulator (node `sail_sim`, with
parameters); this test process holds a live subscriber that counts what was
published. Run as a script, this file is that publisher:

    python test/system/test_recorder_replay.py publish --count 100 --rate 100 --subscribers 2
"""

import argparse
import functools
import os
import re
import select
import signal
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from geometry_msgs.msg import Point
from harness import DOMAIN_ID, ROOT, private_context, wait_until
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros.bag import BagReader, BagWriter, default_qos_profile
from sail_ros.bag.recording import ParameterChange, parse_changes_record
from sail_ros.nodes import recorder as recorder_node
from sail_ros.nodes import replay as replay_node

pytestmark = pytest.mark.multiprocess

STREAMS = {"/sail/boom_state": JointState, "/sail/shape": MarkerArray}
LATCHED_TOPIC = "/sail/deploy_cmd"  # published once, transient local
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
LARGE_TOPIC = "/test/large"  # 1.2 MB messages, transient local, depth 20
SIM_PARAMETERS = {"sail_side": 100.0, "n_boom_modes": 4, "frames": ["a", "b"]}
CHANGED_SIDE = 120.0  # sail_side from --change-at on


# -- the publisher process -----------------------------------------------------------------


def stream_message(topic: str, i: int):
    """Message i of a stream: JointState of four booms, or a membrane MarkerArray."""
    if topic == "/sail/boom_state":
        message = JointState(
            name=[f"boom_{k}" for k in range(4)],
            position=[0.01 * i + k for k in range(4)],
            velocity=[-1.0 * i] * 4,
        )
    else:
        marker = Marker(ns="membrane", id=i, type=Marker.TRIANGLE_LIST)
        marker.points = [Point(x=float(k), y=0.5 * i, z=1e-4 * k * i) for k in range(60)]
        message = MarkerArray(markers=[marker])
        marker.header.stamp.sec = i
    if topic == "/sail/boom_state":
        message.header.stamp.sec = i
    return message


def publish_main(argv) -> int:
    """Publish --count messages per stream at --rate [Hz] once every stream has
    --subscribers subscribers (and, if asked, the parameters were fetched) and a line
    arrived on stdin; then idle until stdin closes."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--count", type=int, required=True)
    parser.add_argument("--rate", type=float, required=True)
    parser.add_argument("--subscribers", type=int, required=True)
    parser.add_argument("--prefix", default="", help="in front of every stream's topic")
    parser.add_argument(
        "--change-at",
        type=int,
        help=f"set sail_side to {CHANGED_SIDE} right after publishing message i of each stream",
    )
    parser.add_argument(
        "--after-parameter-fetch",
        action="store_true",
        help="also wait until the parameters' values were asked for (a recorder ends a file "
        "only once it holds them, however long the fetch takes on a busy machine)",
    )
    args = parser.parse_args(argv)
    rclpy.init()
    node = Node("sail_sim")
    for name, value in SIM_PARAMETERS.items():
        node.declare_parameter(name, value)
    fetched = [not args.after_parameter_fetch]
    if args.after_parameter_fetch:  # note the first answer of the node's own service
        (get_service,) = [s for s in node.services if s.service_name.endswith("/get_parameters")]
        answer = get_service.callback

        def answer_and_note(request, response):
            fetched[0] = True
            return answer(request, response)

        get_service.callback = answer_and_note
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    latched = node.create_publisher(Float64, LATCHED_TOPIC, LATCHED_QOS)
    latched.publish(Float64(data=0.25))  # before anyone listens: only durability delivers it
    # up to 500 messages kept until each reliable reader acknowledged them, as the
    # simulator's state topics keep: with 10 a reader slowed by a busy machine lost some
    publishers = {
        topic: node.create_publisher(cls, args.prefix + topic, min(args.count, 500))
        for topic, cls in STREAMS.items()
    }
    while (
        min(p.get_subscription_count() for p in publishers.values()) < args.subscribers
        or not fetched[0]
    ):
        if stdin_closed():
            return leave(node)
        executor.spin_once(timeout_sec=0.01)
    print("ready", flush=True)  # its own subscribers matched (`go` waits for this line)
    if not sys.stdin.readline():
        return leave(node)
    period, due = 1.0 / args.rate, time.monotonic()
    for i in range(args.count):
        if stdin_closed():
            return leave(node)
        for topic, publisher in publishers.items():
            publisher.publish(stream_message(topic, i))
        if i == args.change_at:
            node.set_parameters([Parameter("sail_side", value=CHANGED_SIDE)])
        due += period
        executor.spin_once(timeout_sec=max(0.0, due - time.monotonic()))
    print("published", flush=True)
    sys.stdin.readline()  # EOF when the test is done: parameters stay served until then
    return leave(node)


def stdin_closed() -> bool:
    """The test closed this process's standard input (the only line it writes, "go",
    was read before any call)."""
    return bool(select.select([sys.stdin], [], [], 0.0)[0]) and not sys.stdin.readline()


def leave(node: Node) -> int:
    """Leave the graph before exiting: a process that is killed stays in the
    subscribers' graph until its lease runs out."""
    node.destroy_node()
    rclpy.shutdown()
    return 0


# -- fixtures ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def listener_node(ros_env):
    """A live subscriber in this process (its own context) on the test's domain."""
    with private_context() as context:
        node = Listener(context)
        yield node
        node.spin_until(node.alone, 30.0, "the other processes' endpoints to leave")
        node.spinner.shutdown()
        node.destroy_node()


@pytest.fixture
def listener(listener_node):
    """The module's listener, emptied before and after the test: what one test received
    (also one that failed) never counts in the next."""
    listener_node.clear()
    yield listener_node
    listener_node.clear()


class Listener(Node):
    """Collects (receive time [s], CDR bytes) per topic, and when each was published."""

    def __init__(self, context):
        super().__init__("test_listener", context=context)
        self.spinner = SingleThreadedExecutor(context=context)
        self.spinner.add_node(self)
        self.received: dict[str, list] = {}
        self.published: dict[str, list[float]] = {}  # DDS source timestamps [s]
        self._taken = 0  # messages taken so far
        for topic, cls in STREAMS.items():
            self.listen(topic, cls, QoSProfile(depth=1000))
        self.listen(LATCHED_TOPIC, Float64, LATCHED_QOS)
        self.listen(
            LARGE_TOPIC,
            MarkerArray,
            QoSProfile(depth=20, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )
        self.listen("/clock", Clock, QoSProfile(depth=1000))

    def listen(self, topic, cls, qos):
        self.received[topic] = []
        self.published[topic] = []
        self.create_subscription(
            cls,
            topic,
            functools.partial(self._keep, topic),
            qos,
            raw=True,
        )

    def _keep(self, topic, data, info):
        """(DDS reception time [s], CDR bytes): the time the sample reached this process,
        not when the executor got round to it."""
        self.received[topic].append((info["received_timestamp"] / 1e9, data))
        self.published[topic].append(info["source_timestamp"] / 1e9)
        self._taken += 1

    def spin_some(self, timeout: float = 0.02) -> None:
        """Take every message that has arrived, waiting up to `timeout` [s] for the first:
        one callback per turn would fall behind two 100 Hz streams while a turn also reads
        a bag from disk, and a reader's history (depth 1000) then drops the oldest."""
        self.spinner.spin_once(timeout_sec=timeout)
        while True:
            taken = self._taken
            self.spinner.spin_once(timeout_sec=0.0)
            if self._taken == taken:
                return

    def clear(self):
        for messages in (*self.received.values(), *self.published.values()):
            messages.clear()

    def spin_until(self, condition, timeout: float, what: str):
        wait_until(condition, timeout, what, between=self.spin_some)

    def alone(self) -> bool:
        """No other process's endpoint matches one of this node's. Fast DDS removes a
        killed process's endpoints when its lease runs out (20 s), on a thread of its own;
        the node is destroyed only after that, not while that thread may still be
        unmatching its readers and writers."""
        return not any(
            [self.get_publishers_info_by_topic(topic) for topic in self.received]
            + [self.get_subscriptions_info_by_topic(t) for t in ("/parameter_events", "/rosout")]
        )

    def publisher_counts(self, prefix="") -> dict[str, int]:
        return {t: len(self.get_publishers_info_by_topic(prefix + t)) for t in STREAMS}


def start(args, env, **kwargs) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def start_tool(tool, args, env) -> subprocess.Popen:
    return start(["-m", "sail_ros.cli", tool, *args], env)


def start_publisher(
    env, count, rate, subscribers, prefix="", after_parameter_fetch=False, change_at=None
) -> subprocess.Popen:
    return start(
        [
            __file__,
            "publish",
            "--count",
            str(count),
            "--rate",
            str(rate),
            "--subscribers",
            str(subscribers),
            "--prefix",
            prefix,
            *(["--after-parameter-fetch"] if after_parameter_fetch else []),
            *(["--change-at", str(change_at)] if change_at is not None else []),
        ],
        # the script imports the tests' harness, as the tests do
        dict(
            env,
            PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "test"), env.get("PYTHONPATH")])),
        ),
        stdin=subprocess.PIPE,
    )


def finish(process: subprocess.Popen, timeout: float = 20.0) -> tuple[int, str, str]:
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGABRT)  # its threads' stacks (PYTHONFAULTHANDLER)
        try:
            out, err = process.communicate(timeout=10.0)
        except subprocess.TimeoutExpired:
            process.kill()
            out, err = process.communicate()
        pytest.fail(f"process did not exit within {timeout} s:\n{err}")
    return process.returncode, out, err


def go(listener: Listener, publisher: subprocess.Popen, prefix="") -> None:
    """Let the publisher start once both ends matched: this process sees it, and it has
    its subscribers (its "ready" line). Seeing it here is not enough: a publisher that
    had not yet matched this listener could start on another subscriber (a recorder
    started next), and this listener would miss its first messages."""
    listener.spin_until(
        lambda: min(listener.publisher_counts(prefix).values()) >= 1, 20.0, "the publisher"
    )
    lines = []

    def answered() -> bool:
        if select.select([publisher.stdout], [], [], 0.0)[0]:
            lines.append(publisher.stdout.readline())
        return bool(lines)

    listener.spin_until(answered, 30.0, "the publisher's subscribers")
    assert lines == ["ready\n"], lines
    publisher.stdin.write("go\n")
    publisher.stdin.flush()


def decoded(topic: str, data: bytes):
    return deserialize_message(data, STREAMS.get(topic, Float64))


PARAMETER_EVENTS = "/parameter_events"
RECORDER_TOPICS = ["--topics", *STREAMS, LATCHED_TOPIC, PARAMETER_EVENTS]


@pytest.fixture(scope="module")
def recording(ros_env, listener_node, tmp_path_factory):
    """Recorder started before the topics exist, splitting files every 0.5 s of log
    time; 120 messages per stream over 1.2 s, once the recorder asked for the
    parameters, sail_side changed after message 60; SIGINT."""
    folder = tmp_path_factory.mktemp("rec") / "run"
    listener_node.clear()
    recorder = start_tool(
        "recorder",
        [
            "-o",
            str(folder),
            *RECORDER_TOPICS,
            "--max-chunk-duration-s",
            "0.2",
            "--max-file-duration-s",
            "0.5",
        ],
        ros_env,
    )
    publisher = start_publisher(
        ros_env, count=120, rate=100.0, subscribers=2, after_parameter_fetch=True, change_at=60
    )
    try:
        go(listener_node, publisher)
        counts = {}

        def complete() -> bool:
            counts.update({t: len(m) for t, m in listener_node.received.items()})
            return all(counts[t] == 120 for t in STREAMS) and counts[LATCHED_TOPIC] > 0

        deadline = time.monotonic() + 30.0
        while not complete():
            assert time.monotonic() < deadline, f"30 s and not 120 messages per stream: {counts}"
            listener_node.spin_some()
        received = {t: [data for _, data in m] for t, m in listener_node.received.items()}
        recorder.send_signal(signal.SIGINT)
        code, _, err = finish(recorder)
    finally:
        recorder.kill()
        finish(publisher)
    listener_node.clear()
    return folder, received, code, err


# -- tests ---------------------------------------------------------------------------------


def test_sigint_finishes_the_bag_with_every_received_message(recording):
    folder, received, code, err = recording
    assert code == 0, err
    assert "SIGINT: finishing the recording" in err
    for topic in STREAMS:
        assert f"{topic}: 120 messages" in err
    assert (folder / "metadata.yaml").exists()

    reader = BagReader(folder)
    assert reader.incomplete_files == []
    messages = list(reader.messages())
    for topic in STREAMS:
        recorded = [m for m in messages if m.topic == topic]
        assert [decoded(topic, m.data) for m in recorded] == [
            decoded(topic, data) for data in received[topic]
        ]
        assert all(0 <= m.log_time_ns - m.publish_time_ns < 1e9 for m in recorded)
    latched = [m for m in messages if m.topic == LATCHED_TOPIC]
    assert [decoded(LATCHED_TOPIC, m.data).data for m in latched] == [0.25]

    topics = reader.topics()
    assert {t: i.type_name for t, i in topics.items()} == {
        "/sail/boom_state": "sensor_msgs/msg/JointState",
        "/sail/shape": "visualization_msgs/msg/MarkerArray",
        LATCHED_TOPIC: "std_msgs/msg/Float64",
        PARAMETER_EVENTS: "rcl_interfaces/msg/ParameterEvent",
    }
    assert topics[LATCHED_TOPIC].offered_qos_profiles[0]["durability"] == "transient_local"
    assert topics["/sail/boom_state"].offered_qos_profiles[0]["reliability"] == "reliable"
    assert topics["/sail/boom_state"].type_hash.startswith("RIHS01_")

    # the change: once, between messages 60 and 61 on the publisher's clock, in the file
    # where the writer took it; every file starts with the values of its start
    states = [m for m in messages if m.topic == "/sail/boom_state"]
    changes = [
        (file, parse_changes_record(data))
        for file in reader.files
        for name, data in BagReader(file).metadata()
        if name == "sail_sim_parameter_changes"
    ]
    ((changed_in, (node, time_ns, log_time_ns, changed)),) = changes
    assert node == "/sail_sim"
    assert changed == [ParameterChange("sail_side", "100.0", str(CHANGED_SIDE))]
    assert states[60].publish_time_ns <= time_ns <= states[61].publish_time_ns
    assert states[58].log_time_ns < log_time_ns < states[-1].log_time_ns
    assert len(reader.files) >= 3  # 1.2 s of streams (after the latched message)
    after = reader.files.index(changed_in) + 1
    for index, file in enumerate(reader.files):
        found = [data for name, data in BagReader(file).metadata() if name == "sail_sim_parameters"]
        assert len(found) == 1, (file.name, err)  # the recorder's log says when they came
        (parameters,) = found
        values = {name: yaml.safe_load(parameters[name]) for name in SIM_PARAMETERS}
        assert values == {**SIM_PARAMETERS, "sail_side": CHANGED_SIDE if index >= after else 100.0}

    with AnyReader([folder]) as rosbags_reader:  # an independent reader agrees
        rows = [
            (c.topic, rosbags_reader.deserialize(raw, c.msgtype))
            for c, _, raw in rosbags_reader.messages()
            if c.topic in ("/sail/shape", PARAMETER_EVENTS)
        ]
    shapes = [m for topic, m in rows if topic == "/sail/shape"]
    assert [m.markers[0].points[59].z for m in shapes] == pytest.approx(
        [decoded("/sail/shape", d).markers[0].points[59].z for d in received["/sail/shape"]]
    )
    # ... and decodes the change on /parameter_events, where every node's changes are
    events = [m for topic, m in rows if topic == PARAMETER_EVENTS]
    assert [
        (event.node, p.name, p.value.double_value)
        for event in events
        for p in event.changed_parameters
    ] == [("/sail_sim", "sail_side", CHANGED_SIDE)]


def test_replay_republishes_with_recorded_values_and_timing(recording, ros_env, listener):
    folder, _, _, _ = recording
    recorded = [m for m in BagReader(folder).messages() if m.topic in STREAMS]
    offset_s, rate = 0.3, 2.0
    first_log = min(m.log_time_ns for m in recorded)
    expected = [m for m in recorded if m.log_time_ns >= first_log + offset_s * 1e9]
    replay = start_tool(
        "replay",
        [
            str(folder),
            "--rate",
            str(rate),
            "--start-offset-s",
            str(offset_s),
            "--topics",
            *STREAMS,
            "--wait-for-subscribers",
            "1",
        ],
        ros_env,
    )
    listener.spin_until(
        lambda: (
            sum(len(listener.received[t]) for t in STREAMS) == len(expected)
            or replay.poll() is not None
        ),
        30.0,
        "the replayed messages",
    )
    listener.spin_until(
        lambda: sum(len(listener.received[t]) for t in STREAMS) == len(expected),
        2.0,
        "the last replayed messages",
    )
    code, _, err = finish(replay)
    assert code == 0, err
    assert f"playing {len(expected)} messages (from {offset_s:g} s on)" in err
    # the time spent playing: the messages' span at `rate`, the wait for their
    # acknowledgements apart
    played = re.search(r"played (\d+) messages in ([0-9.]+) s", err)
    span = (expected[-1].log_time_ns - expected[0].log_time_ns) / 1e9 / rate
    assert int(played[1]) == len(expected) and span <= float(played[2]) < span + 0.5, err
    for topic in STREAMS:
        got = listener.received[topic]
        want = [m for m in expected if m.topic == topic]
        assert [decoded(topic, data) for _, data in got] == [decoded(topic, m.data) for m in want]
        # the recorded spacing, `rate` times faster: a message is published when due or
        # late, never early, so the least lag behind its due time is the same in the
        # replay's last quarter as in its first
        due = np.array([m.log_time_ns - first_log for m in want]) / 1e9 / rate
        lag = np.array(listener.published[topic]) - due
        quarter = len(lag) // 4
        drift = lag[-quarter:].min() - lag[:quarter].min()
        assert due[-quarter] - due[quarter - 1] > 0.2 and abs(drift) < 0.01, drift
    assert listener.received[LATCHED_TOPIC] == []  # not asked for
    clock = [deserialize_message(data, Clock).clock for _, data in listener.received["/clock"]]
    clock_ns = [c.sec * 1_000_000_000 + c.nanosec for c in clock]
    assert len(clock_ns) > 10 and clock_ns == sorted(clock_ns)
    assert clock_ns[0] >= first_log + round(offset_s * 1e9)  # the clock starts at the offset
    assert clock_ns[-1] <= expected[-1].log_time_ns + 20_000_000


def run_until_recorder_exits(recorder, ros_env, listener, count, rate):
    """Publish `count` messages per stream at `rate` [Hz] until the recorder exits on
    its own; its exit code and standard error."""
    publisher = start_publisher(ros_env, count=count, rate=rate, subscribers=2)
    try:
        go(listener, publisher)
        code, _, err = finish(recorder, timeout=30.0)
    finally:
        recorder.kill()
        finish(publisher)
    listener.clear()
    return code, err


def record_and_kill(ros_env, listener, folder, recorder_args, count, kill_after_s) -> None:
    """A recorder of RECORDER_TOPICS into `folder` (with `recorder_args`), `count`
    messages per stream at 100 Hz, and SIGKILL `kill_after_s` [s] after the first message
    reached this process (its DDS reception time)."""
    recorder = start_tool(
        "recorder", ["-o", str(folder), *RECORDER_TOPICS, *recorder_args], ros_env
    )
    publisher = start_publisher(ros_env, count=count, rate=100.0, subscribers=2)
    try:
        go(listener, publisher)
        listener.spin_until(
            lambda: listener.received["/sail/boom_state"], 30.0, "the first message"
        )
        kill_at = listener.received["/sail/boom_state"][0][0] + kill_after_s
        listener.spin_until(lambda: time.time() > kill_at, kill_after_s + 5.0, "the kill")
        recorder.send_signal(signal.SIGKILL)
        recorder.wait(10.0)
    finally:
        recorder.kill()
        finish(publisher)


def test_sigkill_leaves_the_bag_readable_up_to_its_last_chunk(ros_env, listener, tmp_path):
    """150 messages at 100 Hz, then a quiet second and a half, then SIGKILL: a chunk
    closes at most 0.2 s after its first message, also when nothing follows (the
    writer's tick), so the killed file, without summary, holds every message."""
    folder = tmp_path / "killed"
    record_and_kill(ros_env, listener, folder, ["--max-chunk-duration-s", "0.2"], 150, 3.0)
    received = [data for _, data in listener.received["/sail/boom_state"]]

    reader = BagReader(folder)
    assert reader.incomplete_files == reader.files
    assert not (folder / "metadata.yaml").exists()
    kept = [m.data for m in reader.messages(topics=["/sail/boom_state"])]
    assert len(received) == 150
    assert [decoded("/sail/boom_state", d) for d in kept] == [
        decoded("/sail/boom_state", d) for d in received
    ]


def test_sigkill_one_second_after_the_first_message_leaves_a_recoverable_log(
    ros_env, listener, tmp_path
):
    """A recorder killed 1 s after the first message reached it, start-up included (its log
    must hold more than a 62-byte header): the topics are on disk from their start,
    a file's first chunks close 0.1, 0.2, 0.4 s after their first message (the first may
    hold the latched message alone), and `sail-ros bag recover` makes of it a log that
    rosbags opens, holding the stream from its first message on (0.2 s at least)."""
    from sail_ros.tools import bag as bag_tool

    folder = tmp_path / "early"
    record_and_kill(ros_env, listener, folder, [], 1000, 1.0)  # chunks of 1 s, the default
    assert bag_tool.main(["recover", str(folder)]) == 0
    recovered = tmp_path / "early_recovered"
    assert set(BagReader(recovered).topics()) >= {*STREAMS, LATCHED_TOPIC}
    with AnyReader([recovered]) as reader:  # rosbags
        kept = [
            reader.deserialize(raw, c.msgtype).header.stamp.sec
            for c, _, raw in reader.messages()
            if c.topic == "/sail/boom_state"
        ]
    assert len(kept) >= 20 and kept == list(range(len(kept))), kept


# CI: a few trials; scripts/stress.sh runs 20 (SAIL_ROS_KILL_TRIALS)
KILL_TRIALS = int(os.environ.get("SAIL_ROS_KILL_TRIALS", "3"))
KILL_PREFIX = "/kill_trials"
CHUNK_S = 0.2  # the recorder's --max-chunk-duration-s in the kill trials
CLOSE_MARGIN_S = 0.3  # writing and closing a due chunk, at worst, on this machine


def test_sigkill_at_random_times_loses_only_the_open_chunk(ros_env, listener, tmp_path):
    """KILL_TRIALS recorders, each killed (SIGKILL) at a random moment of a 100 Hz stream, then
    `sail-ros bag recover`: rosbags and mcap's default reader open every recovered log;
    each holds an unbroken run of the live stream, equal message by message, up to
    messages received at most one chunk (plus its closing) before the kill."""
    from mcap.reader import make_reader

    from sail_ros.tools import bag as bag_tool

    rng = np.random.default_rng(20261201)
    streams = [KILL_PREFIX + topic for topic in STREAMS]  # no other test publishes there
    state_topic = streams[0]
    for topic, cls in zip(streams, STREAMS.values(), strict=True):
        listener.listen(topic, cls, QoSProfile(depth=1000))
    publisher = start_publisher(
        ros_env, count=100_000, rate=100.0, subscribers=1, prefix=KILL_PREFIX
    )

    def start_recorder(folder):
        return start_tool(
            "recorder",
            ["-o", str(folder), "--topics", *streams, "--max-chunk-duration-s", str(CHUNK_S)],
            ros_env,
        )

    # After processes were killed, Fast DDS 2.14 (shared memory on this host) can leave a
    # new one receiving nothing from a live one: seen once in ~460 trials, the graph
    # matched, no data and no service answer for 30 s (like eProsima/Fast-DDS#5469,
    # #2811). That is the transport's, not the recorder's: such a recorder is started
    # again, once in the whole test, and reported.
    restarted = []
    table = []
    try:
        go(listener, publisher, KILL_PREFIX)
        for trial in range(KILL_TRIALS):
            folder = tmp_path / f"trial_{trial}"
            listener.clear()
            recorder = start_recorder(folder)
            # a trial starts once a chunk with the state topic is on disk (the first chunk
            # may hold only the topics the recorder subscribed to first)
            if not chunk_within(listener, folder, 30.0, state_topic) and not restarted:
                recorder.kill()
                restarted.append((trial, recorder.communicate(timeout=10.0)[1]))
                folder = tmp_path / f"trial_{trial}_again"
                recorder = start_recorder(folder)
            if not chunk_within(listener, folder, 30.0, state_topic):  # what did it see?
                recorder.kill()
                _, log = recorder.communicate(timeout=10.0)
                raise AssertionError(f"trial {trial}: no chunk in 30 s; recorder:\n{log}")
            run_s = float(rng.uniform(0.3, 2.5))
            until = time.monotonic() + run_s
            listener.spin_until(lambda u=until: time.monotonic() > u, run_s + 5.0, "the run")
            recorder.send_signal(signal.SIGKILL)
            killed_at = time.time()
            _, log = recorder.communicate(timeout=10.0)  # its standard error
            # take what DDS already holds for this process: messages received before the
            # kill must all be in `live` (their reception time is DDS's, not the take's)
            listener.spin_until(
                lambda k=killed_at: (
                    listener.received[state_topic]
                    and listener.received[state_topic][-1][0] > k + 0.5
                ),
                10.0,
                "the live messages up to the kill",
            )
            live = {
                decoded("/sail/boom_state", data).header.stamp.sec: (received, data)
                for received, data in listener.received[state_topic]
            }

            assert bag_tool.main(["recover", str(folder)]) == 0
            recovered = tmp_path / f"trial_{trial}_recovered"
            with AnyReader([recovered]) as reader:  # rosbags
                rosbags_count = sum(1 for _ in reader.messages())
            mcap_count = 0
            for file in sorted(recovered.glob("*.mcap")):
                with file.open("rb") as stream:  # mcap's default reader, summary and all
                    mcap_count += sum(1 for _ in make_reader(stream).iter_messages())
            kept = [m.data for m in BagReader(recovered).messages([state_topic])]
            assert rosbags_count == mcap_count == sum(1 for _ in BagReader(recovered).messages())

            indices = [decoded("/sail/boom_state", data).header.stamp.sec for data in kept]
            assert indices, trial  # its first chunk was on disk before the kill
            assert indices == list(range(indices[0], indices[-1] + 1)), trial
            for index, data in zip(indices, kept, strict=True):
                assert decoded("/sail/boom_state", data) == decoded(
                    "/sail/boom_state", live[index][1]
                ), (trial, index)
            lost = [i for i in live if i > indices[-1]]
            lost_before = [i for i in lost if live[i][0] < killed_at - CHUNK_S - CLOSE_MARGIN_S]
            assert not lost_before, (trial, run_s, len(kept), len(lost), log)
            table.append((trial, run_s, len(kept), sum(1 for i in lost if live[i][0] < killed_at)))
    finally:
        finish(publisher)
    print("\ntrial  run [s]  boom_state kept  received live before the kill, not kept")
    for trial, run_s, kept_count, lost_count in table:
        print(f"{trial:5d}  {run_s:7.2f}  {kept_count:15d}  {lost_count:5d}")
    for trial, log in restarted:
        print(f"trial {trial}: the first recorder received nothing in 30 s, started again:\n{log}")


def chunk_within(listener: Listener, folder: Path, timeout: float, topic=None) -> bool:
    """Whether a chunk (holding `topic`, if given) is on disk in `folder` within `timeout`
    [s] (spinning `listener`)."""
    deadline = time.monotonic() + timeout
    while not recorded(folder, topic):
        if time.monotonic() > deadline:
            return False
        listener.spin_some()
    return True


def recorded(folder: Path, topic=None) -> bool:
    """Whether a (live) recording in `folder` holds a complete chunk (with a message of
    `topic`, if given)."""
    try:
        return any(True for _ in BagReader(folder).messages(None if topic is None else [topic]))
    except (OSError, ValueError):  # not created yet, or its header not yet written
        return False


def test_full_disk_is_a_clear_error_and_keeps_what_was_written(ros_env, listener, tmp_path):
    folder = tmp_path / "full"
    # bytes: RLIMIT_FSIZE makes writes past it fail as on a full disk. A chunk of 0.1 s
    # holds about 37 kB here, more when the recorder was held up and a backlog arrives
    # at once: room for several, so that the first one fits however the machine is loaded
    limit = 256 * 1024
    launcher = (
        "import os, resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit})); "
        "os.execv(sys.executable, [sys.executable, '-m', 'sail_ros.cli', *sys.argv[1:]])"
    )
    recorder = start(
        ["-c", launcher, "recorder", "-o", str(folder), "--topics", *STREAMS, "--compression",
         "none", "--max-chunk-duration-s", "0.1", "--parameter-node", ""],
        ros_env,
    )  # fmt: skip
    code, err = run_until_recorder_exits(recorder, ros_env, listener, count=2000, rate=200.0)
    assert code == 1, err
    assert f"cannot write '{folder / 'full_0.mcap'}': File too large" in err
    kept = list(BagReader(folder).messages(topics=["/sail/boom_state"]))
    assert len(kept) > 10
    assert [decoded("/sail/boom_state", m.data).header.stamp.sec for m in kept] == list(
        range(len(kept))
    )


def damaged_copy(path: Path, chunk: int = 0) -> Path:
    """A copy of the MCAP file `path` whose chunk number `chunk` fails its CRC."""
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        offset = make_reader(stream).get_summary().chunk_indexes[chunk].chunk_start_offset
    data = bytearray(path.read_bytes())
    crc_at = offset + 1 + 8 + 8 + 8 + 8  # opcode, length, start, end, uncompressed size
    struct.pack_into("<I", data, crc_at, struct.unpack_from("<I", data, crc_at)[0] ^ 0xFFFF)
    copy = path.with_name("damaged_" + path.name)
    copy.write_bytes(bytes(data))
    return copy


def test_unwritable_output_and_bad_parameters_exit_with_a_clear_error(ros_env, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    bag = tmp_path / "run.mcap"
    with BagWriter(bag, chunk_size=2000, fsync=False) as writer:
        writer.add_topic("/sail/boom_state", "sensor_msgs/msg/JointState")
        for i in range(100):
            writer.write(
                "/sail/boom_state", serialize_message(stream_message("/sail/boom_state", i)), i
            )
    # five participants that leave at the same moment: each discovers no other, for Fast
    # DDS can deadlock removing one while others leave (`ros.program.bounded_teardown`)
    alone = {**ros_env, "ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}
    unwritable = start_tool("recorder", ["-o", str(blocker / "bag")], alone)
    occupied = tmp_path / "occupied"  # a folder that holds files: a bad argument
    occupied.mkdir()
    (occupied / "notes.txt").write_text("mine")
    taken = start_tool("recorder", ["-o", str(occupied)], alone)
    gzip = start_tool(
        "recorder", ["-o", str(tmp_path / "x"), "--ros-args", "-p", "compression:=gzip"], alone
    )
    missing = start_tool("replay", [str(tmp_path / "no_such_bag")], alone)
    damaged = start_tool(
        "replay", [str(damaged_copy(bag, chunk=1)), "--rate", "100", "--no-clock"], alone
    )
    code, _, err = finish(unwritable)
    assert code == 1 and f"cannot write '{blocker / 'bag'}': Not a directory" in err, err
    code, _, err = finish(taken)
    assert code == 2 and f"cannot write '{occupied}': folder exists and is not empty" in err, err
    assert [p.name for p in occupied.iterdir()] == ["notes.txt"]
    code, _, err = finish(gzip)
    assert code == 2 and "compression must be one of zstd, lz4, none, got 'gzip'" in err, err
    code, _, err = finish(missing)
    assert code == 2 and f"bag: '{tmp_path / 'no_such_bag'}' does not exist" in err, err
    code, _, err = finish(damaged)  # played up to the damaged chunk, then one line
    assert code == 2 and "Traceback" not in err, err
    (line,) = [line for line in err.splitlines() if "ERROR" in line]
    assert f"bag: '{tmp_path / 'damaged_run.mcap'}' is damaged: CRCValidationError" in line
    played = int(line.rsplit("stopped after ", 1)[1].split()[0])
    assert 0 < played < 100


def test_replay_offset_past_the_end_is_an_error_even_when_looping(recording, ros_env):
    folder = recording[0]
    times = [m.log_time_ns for m in BagReader(folder).messages()]
    span = f"(span {(max(times) - times[0]) / 1e9:.2f} s)"
    looping = start_tool("replay", [str(folder), "--start-offset-s", "100", "--loop"], ros_env)
    once = start_tool("replay", [str(folder), "--start-offset-s", "100"], ros_env)
    for process in (looping, once):  # a loop over nothing must end, not spin a core
        code, _, err = finish(process)
        assert code == 2, err
        assert f"start_offset_s = 100 s is past the end of the bag {span}" in err, err


def test_replay_stops_looping_when_a_pass_plays_nothing(recording, monkeypatch):
    monkeypatch.setattr(replay_node.Replay, "_play_once", lambda self, stop: 0)
    rclpy.init(domain_id=DOMAIN_ID)  # the global context, which the tools' nodes use
    try:
        replay = replay_node.Replay(
            [
                Parameter("bag", value=str(recording[0])),
                Parameter("loop", value=True),
                Parameter("wait_for_all_acked_s", value=0.0),
            ]
        )
        stop, result = threading.Event(), []
        player = threading.Thread(target=lambda: result.append(replay.play(stop)))
        player.start()
        player.join(5.0)
        stop.set()  # ends the loop, which would otherwise go on without end
        player.join()
        replay.destroy_node()
        assert result == [1]
    finally:
        rclpy.shutdown()


def test_replay_waits_until_its_last_messages_are_delivered(ros_env, listener, tmp_path):
    """1.2 MB messages published within 20 ms: the replay keeps its publishers until
    every one is acknowledged (a replay that left after a fixed second would, on a busy
    machine, leave the subscriber without the last ones).

    Recorded transient local: the listener gets them whichever side of the
    discovery comes first (a volatile subscriber that sees the replay's publisher
    after the first messages went out would not get those, by DDS durability).
    """
    bag, count = tmp_path / "large.mcap", 20
    writer = BagWriter(bag)
    latched = default_qos_profile(durability="transient_local", history="keep_last", depth=count)
    writer.add_topic(LARGE_TOPIC, "visualization_msgs/msg/MarkerArray", [latched])
    marker = Marker(ns="membrane", points=[Point(x=float(k)) for k in range(50_000)])
    start_ns, written = time.time_ns(), []
    for i in range(count):
        marker.id = i
        written.append(serialize_message(MarkerArray(markers=[marker])))
        writer.write(LARGE_TOPIC, written[-1], start_ns + i * 1_000_000)
    writer.close()
    for _ in range(3):
        listener.clear()
        replay = start_tool("replay", [str(bag), "--wait-for-subscribers", "1"], ros_env)
        code, _, err = finish(replay)
        assert code == 0, err
        assert "not every subscriber acknowledged" not in err, err
        # acknowledged: everything is in this process, only rclpy has yet to take it
        listener.spin_until(lambda: len(listener.received[LARGE_TOPIC]) >= count, 2.0, "all")
        assert [data for _, data in listener.received[LARGE_TOPIC]] == written  # in order


def test_config_files_hold_the_defaults():
    for node in (recorder_node, replay_node):
        document = yaml.safe_load(
            (ROOT / f"config/{node.NODE_NAME.removeprefix('sail_')}.yaml").read_text()
        )
        values = document[node.NODE_NAME]["ros__parameters"]
        defaults = {spec.name: spec.default for spec in node.SPECS}
        assert values == {name: value for name, value in defaults.items() if name in values}
        assert set(defaults) - set(values) <= {"output", "topics"}
    assert replay_node.SPECS[-1].name == "wait_for_all_acked_s"
    assert replay_node.SPECS[-1].default == 0.0  # until acknowledged


def test_recorder_checks_parameter_node_before_creating_the_bag(ros_env, tmp_path):
    folder = tmp_path / "rec1"
    process = start_tool("recorder", ["-o", str(folder), "--parameter-node", "bad name"], ros_env)
    code, _, err = finish(process)
    assert code == 2, err
    assert "parameter_node: 'bad name' is not a valid node name (" in err, err
    assert "Traceback" not in err
    assert not folder.exists()  # not even an MCAP file without summary


RECORDER_WITH = """
import sys
from sail_ros.nodes import recorder
{patch}
sys.exit(recorder.main(sys.argv[1:]))
"""
FAIL_ON_MESSAGE_51 = """
original = recorder.Recorder._record  # once per message, also within a batch
def record(self, topic, data, info):
    if self._received == 50:
        raise RuntimeError("injected failure")
    original(self, topic, data, info)
recorder.Recorder._record = record
"""
FAIL_IN_INIT = """
def create_timer(self, *args, **kwargs):
    raise RuntimeError("injected failure")
recorder.Recorder.create_timer = create_timer
"""


def test_error_in_a_callback_still_finishes_the_bag(ros_env, listener, tmp_path):
    folder = tmp_path / "broken"
    recorder = start(
        ["-c", RECORDER_WITH.format(patch=FAIL_ON_MESSAGE_51), "-o", str(folder), "--topics",
         *STREAMS, "--parameter-node", ""],
        ros_env,
    )  # fmt: skip
    code, err = run_until_recorder_exits(recorder, ros_env, listener, count=300, rate=100.0)
    assert code == 1, err
    assert "recording stopped by an unexpected error" in err
    assert "RuntimeError: injected failure" in err
    assert "recording failed: RuntimeError('injected failure'); 50 messages" in err
    reader = BagReader(folder)  # finished: summary and metadata.yaml
    assert reader.incomplete_files == [] and (folder / "metadata.yaml").exists()
    assert sum(info.message_count for info in reader.topics().values()) == 50
    assert len(list(reader.messages())) == 50


def test_failed_start_after_the_bag_was_created_finishes_it(ros_env, tmp_path):
    folder = tmp_path / "unstarted"
    recorder = start(
        ["-c", RECORDER_WITH.format(patch=FAIL_IN_INIT), "-o", str(folder), "--parameter-node", ""],
        ros_env,
    )
    code, _, err = finish(recorder)
    assert code == 1 and "RuntimeError: injected failure" in err, err
    reader = BagReader(folder)
    assert reader.incomplete_files == [] and (folder / "metadata.yaml").exists()


if __name__ == "__main__":
    if sys.argv[1:2] != ["publish"]:
        sys.exit(f"usage: {Path(__file__).name} publish --count N --rate HZ --subscribers K")
    sys.exit(publish_main(sys.argv[2:]))
