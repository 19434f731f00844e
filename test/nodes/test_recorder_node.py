"""`sail_recorder` and `sail_replay` in this process: private contexts, real DDS on loopback.

The node under test and its peer (a publisher or a subscriber) live in two
contexts of this process, so they talk over DDS as separate processes would.
"""

import contextlib
import threading
import time

import pytest
import rclpy
from harness import private_context, wait_until
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, String

from sail_ros import topics
from sail_ros.bag import BagReader, BagWriter, type_hash
from sail_ros.nodes.recorder import Recorder
from sail_ros.nodes.replay import Replay
from sail_ros.ros.parameters import ConfigError
from sail_ros.ros.taking import take_waiting

pytestmark = pytest.mark.node

TOPIC = topics.absolute(topics.BOOM_STATE)


def state(i: int) -> JointState:
    message = JointState(name=list(topics.BOOM_JOINTS), position=[0.1 * i] * 4)
    message.header.stamp.sec = i
    return message


@pytest.fixture
def peer():
    """A second context on the test domain with one node and its executor."""
    with private_context() as context:
        node = Node("test_peer", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        yield node, executor
        executor.shutdown()
        node.destroy_node()


class Stop:
    """What `Recorder.run` waits on: an event, and what set it."""

    def __init__(self):
        self.event = threading.Event()
        self.received = "test"


def start_recording(context, executor, publisher, tmp_path, **parameters):
    """A recorder of TOPIC into tmp_path/bag, running in a thread, matched both ways
    with `publisher`; returns (recorder, its Stop, the list its exit code goes to,
    the thread)."""
    overrides = [
        Parameter("output", value=str(tmp_path / "bag")),
        Parameter("topics", value=[TOPIC]),
        Parameter("parameter_node", value=""),
    ] + [Parameter(name, value=value) for name, value in parameters.items()]
    recorder = Recorder(overrides, context=context)
    stop, result = Stop(), []
    runner = threading.Thread(target=lambda: result.append(recorder.run(stop)))
    runner.start()
    try:
        wait_until(
            lambda: publisher.get_subscription_count() >= 1, 10.0, "recorder", executor=executor
        )
        # both ends matched: the recorder's graph shows the publisher too
        wait_until(
            lambda: recorder.count_publishers(TOPIC) >= 1, 10.0, "its view", executor=executor
        )
    except BaseException:
        stop.event.set()
        runner.join(10.0)
        raise
    return recorder, stop, result, runner


def test_recorder_records_in_process(ros_context, peer, tmp_path):
    node, executor = peer
    publisher = node.create_publisher(JointState, TOPIC, topics.STATE_QOS)
    recorder, stop, result, runner = start_recording(
        ros_context, executor, publisher, tmp_path, max_chunk_duration_s=0.1
    )
    try:
        sent = [state(i) for i in range(30)]
        for message in sent:
            publisher.publish(message)
        assert publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
    finally:
        stop.event.set()
        runner.join(10.0)
    recorder.destroy_node()
    assert result == [0]
    recorded = [
        deserialize_message(m.data, JointState) for m in BagReader(tmp_path / "bag").messages()
    ]
    assert [m.header.stamp.sec for m in recorded] == list(range(30))
    assert [list(m.position) for m in recorded] == [list(m.position) for m in sent]


def deploy_topic(namespace: str) -> str:
    return f"/{namespace}{topics.absolute(topics.DEPLOY_CMD)}"


@contextlib.contextmanager
def recording_commands(context, tmp_path, namespace):
    """A recorder in `namespace` of its deploy command topic (`deploy_topic`) into
    tmp_path/bag, running in a thread while the block runs; stopped after it, which it
    must end with exit code 0. Each test takes a namespace of its own: the graph may show
    an earlier test's participants on this domain for a while after they are gone (a
    simulator's subscriptions, a client's publishers of the command topics)."""
    overrides = [
        Parameter("output", value=str(tmp_path / "bag")),
        Parameter("topics", value=[deploy_topic(namespace)]),
        Parameter("parameter_node", value=""),
    ]
    recorder = Recorder(overrides, context=context, namespace=namespace)
    stop, result = Stop(), []
    runner = threading.Thread(target=lambda: result.append(recorder.run(stop)))
    runner.start()
    try:
        yield recorder
    finally:
        stop.event.set()
        runner.join(10.0)
        recorder.destroy_node()
    assert result == [0]


def test_commands_of_short_lived_publishers_are_recorded_once(ros_context, peer, tmp_path):
    """The recorder listens on the command topics from its start, twice (transient local
    and volatile, as the simulator does): the commands of a transient-local publisher
    that is gone as soon as its readers have them (`sail-ros send`) and of a volatile
    one are all in the bag, each once, though the first came on both subscriptions."""
    node, executor = peer
    topic = deploy_topic("short_lived")
    with recording_commands(ros_context, tmp_path, "short_lived"):
        # subscribed before any publisher exists
        wait_until(
            lambda: node.count_subscribers(topic) == 2, 10.0, "subscriptions", executor=executor
        )
        latched = node.create_publisher(Float64, topic, topics.LATCHED_COMMAND_QOS)
        wait_until(
            lambda: latched.get_subscription_count() == 2, 10.0, "matches", executor=executor
        )
        for value in (11.0, 12.0, 13.0):
            latched.publish(Float64(data=value))
        assert latched.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
        node.destroy_publisher(latched)
        volatile = node.create_publisher(Float64, topic, topics.COMMAND_QOS)
        wait_until(
            lambda: volatile.get_subscription_count() == 1, 10.0, "a match", executor=executor
        )
        for value in (14.0, 15.0):
            volatile.publish(Float64(data=value))
        assert volatile.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
    bag = BagReader(tmp_path / "bag")
    values = [deserialize_message(m.data, Float64).data for m in bag.messages([topic])]
    assert values == [11.0, 12.0, 13.0, 14.0, 15.0]


def test_a_command_whose_publisher_the_graph_never_showed_gets_a_full_channel(
    ros_context, peer, tmp_path
):
    """A command that arrives before the recorder's graph shows its publisher, which is
    then gone: the channel has the type's hash and the QoS `sail-ros send` offers, so
    readers and a replay handle it as any other."""
    node, executor = peer
    topic = deploy_topic("unseen_publisher")
    with recording_commands(ros_context, tmp_path, "unseen_publisher") as recorder:
        recorder.get_publishers_info_by_topic = lambda name: []  # the graph lags behind
        latched = node.create_publisher(Float64, topic, topics.LATCHED_COMMAND_QOS)
        wait_until(
            lambda: latched.get_subscription_count() == 2, 10.0, "matches", executor=executor
        )
        latched.publish(Float64(data=12.0))
        assert latched.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
    bag = BagReader(tmp_path / "bag")
    channel = bag.topics()[topic]
    assert channel.type_hash == type_hash("std_msgs/msg/Float64")
    assert channel.type_hash.startswith("RIHS01_")
    assert [(q["reliability"], q["durability"]) for q in channel.offered_qos_profiles] == [
        ("reliable", "transient_local")
    ]
    assert [deserialize_message(m.data, Float64).data for m in bag.messages([topic])] == [12.0]


def test_a_publisher_of_another_type_on_a_command_topic_is_named_not_recorded(
    ros_context, peer, tmp_path, capfd
):
    """The recorder's subscriptions are of the simulator's command type: a publisher of
    another type on the same name is named once in its log, and nothing is recorded."""
    node, executor = peer
    topic = deploy_topic("foreign_type")
    with recording_commands(ros_context, tmp_path, "foreign_type") as recorder:
        foreign = node.create_publisher(String, topic, topics.COMMAND_QOS)
        wait_until(
            lambda: recorder.count_publishers(topic) == 1, 10.0, "its view", executor=executor
        )
        foreign.publish(String(data="deploy"))
        logged, deadline = "", time.monotonic() + 10.0
        while "not recording" not in logged:  # the next graph poll
            assert time.monotonic() < deadline, "no warning"
            time.sleep(0.05)
            logged += capfd.readouterr().err
    warning = f"not recording {topic} from publishers of std_msgs/msg/String: the simulator"
    assert warning in logged and logged.count("not recording") == 1
    assert topic not in BagReader(tmp_path / "bag").topics()


def test_take_waiting_takes_what_waits_in_order_with_its_dds_times(ros_context, peer):
    """The recorder's one call into rclpy's internals (`take_waiting`), against the
    installed rclpy: raw bytes and DDS's times of every message waiting, oldest first."""
    node, executor = peer
    publisher = node.create_publisher(JointState, TOPIC, QoSProfile(depth=100))
    taker = Node("taker", context=ros_context)
    subscription = taker.create_subscription(
        JointState, TOPIC, lambda *_: None, QoSProfile(depth=100), raw=True
    )
    try:
        wait_until(
            lambda: publisher.get_subscription_count() >= 1, 10.0, "taker", executor=executor
        )
        before_ns = time.time_ns()
        for i in range(30):
            publisher.publish(state(i))
        assert publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
        first = list(take_waiting(subscription, 10))
        rest = list(take_waiting(subscription, 1000))
        assert list(take_waiting(subscription, 1000)) == []
    finally:
        taker.destroy_node()
    taken = first + rest
    assert len(first) == 10 and len(taken) == 30
    stamps = [deserialize_message(data, JointState).header.stamp.sec for data, _ in taken]
    assert stamps == list(range(30))
    assert all(isinstance(data, bytes) for data, _ in taken)
    for _, info in taken:
        assert before_ns <= info["source_timestamp"] <= info["received_timestamp"]
    sequence = [info["publication_sequence_number"] for _, info in taken]
    assert sequence == list(range(sequence[0], sequence[0] + 30))


def test_recorder_rejects_a_bad_parameter_before_creating_the_bag(ros_context, tmp_path):
    with pytest.raises(ConfigError, match="compression must be one of zstd, lz4, none"):
        Recorder(
            [
                Parameter("output", value=str(tmp_path / "bag")),
                Parameter("compression", value="gzip"),
            ],
            context=ros_context,
        )
    assert not (tmp_path / "bag").exists()


def test_replay_plays_in_process(ros_context, peer, tmp_path):
    node, executor = peer
    bag, sent = tmp_path / "run.mcap", [serialize_message(state(i)) for i in range(20)]
    with BagWriter(bag) as writer:
        writer.add_topic(TOPIC, "sensor_msgs/msg/JointState")
        for i, data in enumerate(sent):
            writer.write(TOPIC, data, 1_000_000_000 + i * 10_000_000)
    received = []
    node.create_subscription(JointState, TOPIC, received.append, QoSProfile(depth=50))
    replay = Replay(
        [Parameter("bag", value=str(bag)), Parameter("wait_for_subscribers", value=1)],
        context=ros_context,
    )
    stop, result = threading.Event(), []
    player = threading.Thread(target=lambda: result.append(replay.play(stop)))
    player.start()
    try:
        wait_until(
            lambda: len(received) == len(sent), 10.0, "the replayed messages", executor=executor
        )
    finally:
        stop.set()
        player.join(10.0)
    replay.destroy_node()
    assert result == [0]
    assert [m.header.stamp.sec for m in received] == list(range(20))


def test_replay_rejects_an_offset_past_the_end(ros_context, tmp_path):
    bag = tmp_path / "run.mcap"
    with BagWriter(bag) as writer:
        writer.add_topic(TOPIC, "sensor_msgs/msg/JointState")
        writer.write(TOPIC, serialize_message(state(0)), 1_000_000_000)
    with pytest.raises(ConfigError, match="start_offset_s = 5 s is past the end of the bag"):
        Replay(
            [Parameter("bag", value=str(bag)), Parameter("start_offset_s", value=5.0)],
            context=ros_context,
        )


def test_replay_into_a_namespace_moves_the_sail_topics(ros_context, peer, tmp_path):
    node, executor = peer
    bag = tmp_path / "run.mcap"
    with BagWriter(bag) as writer:
        writer.add_topic(TOPIC, "sensor_msgs/msg/JointState")
        for i in range(5):
            writer.write(TOPIC, serialize_message(state(i)), 1_000_000_000 + i * 10_000_000)
    received = []
    node.create_subscription(JointState, "/sat9/sail/boom_state", received.append, 50)
    replay = Replay(
        [Parameter("bag", value=str(bag)), Parameter("wait_for_subscribers", value=1)],
        context=ros_context,
        namespace="/sat9",
    )
    stop, result = threading.Event(), []
    player = threading.Thread(target=lambda: result.append(replay.play(stop)))
    player.start()
    try:
        wait_until(lambda: len(received) == 5, 10.0, "the moved topic", executor=executor)
    finally:
        stop.set()
        player.join(10.0)
    replay.destroy_node()
    assert result == [0]


def test_a_slow_disk_drops_counted_messages_and_memory_stays_bounded(
    ros_context, peer, tmp_path, monkeypatch
):
    """Writing takes 20 ms a message, 300 messages come at once, 20 may wait: the
    excess is dropped, and every message is either in the bag or counted."""
    original = BagWriter.write

    def slow_write(self, topic, *args, **kwargs):
        time.sleep(0.02)
        return original(self, topic, *args, **kwargs)

    monkeypatch.setattr(BagWriter, "write", slow_write)
    node, executor = peer
    publisher = node.create_publisher(JointState, TOPIC, QoSProfile(depth=1000))
    recorder, stop, result, runner = start_recording(
        ros_context, executor, publisher, tmp_path, queue_messages=20, qos_depth=1000
    )
    try:
        for i in range(300):
            publisher.publish(state(i))
        assert publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
        time.sleep(0.5)
    finally:
        stop.event.set()
        runner.join(60.0)
    recorder.destroy_node()
    assert result == [0]
    bag = BagReader(tmp_path / "bag")
    written = sum(1 for _ in bag.messages())
    dropped = dict(bag.metadata())["sail_recorder_dropped"]
    assert int(dropped[TOPIC]) > 0
    assert written + int(dropped[TOPIC]) == 300
