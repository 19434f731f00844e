"""The MCAP files of `sail_ros.bag` as rosbag2 writes them, read back independently.

Messages are built with the rclpy classes and serialised by rosbags (exact
CDR), written with `BagWriter`, then read with the `mcap` library (+ the
mcap_ros2 decoder), with rosbags and with `BagReader`, and decoded by rclpy.
"""

import array
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros.bag import (
    BagReader,
    BagWriteError,
    BagWriter,
    DefinitionNotFoundError,
    default_qos_profile,
    mcap_storage,
    message_definition,
    parse_qos_profiles,
    type_hash,
)
from sail_ros.bag.definitions import SEPARATOR, find_interface_file

pytestmark = pytest.mark.model

STORE = get_typestore(Stores.ROS2_JAZZY)
T0 = 1_700_000_000_000_000_000  # ns
TOPICS = {
    "/sail/boom_state": JointState,
    "/sail/shape": MarkerArray,
    "/sail/deploy_cmd": Float64,
    "/clock": Clock,
    "/diagnostics": DiagnosticArray,
}
LATCHED = default_qos_profile(durability="transient_local", history="keep_last", depth=1)


def type_name(msg_or_class) -> str:
    cls = msg_or_class if isinstance(msg_or_class, type) else type(msg_or_class)
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


def to_rosbags(msg):
    """The rosbags object of an rclpy message, field by field."""
    fields = {}
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        if hasattr(value, "get_fields_and_field_types"):
            value = to_rosbags(value)
        elif isinstance(value, list):
            value = [
                to_rosbags(v) if hasattr(v, "get_fields_and_field_types") else v for v in value
            ]
        elif isinstance(value, array.array | np.ndarray):
            value = np.asarray(value)
        elif isinstance(value, bytes):  # rclpy's `byte`, an integer to rosbags
            value = value[0]
        fields[name] = value
    return STORE.types[type_name(msg)](**fields)


def cdr(msg) -> bytes:
    """Exact CDR bytes (rclpy's serialize_message under Fast DDS pads them)."""
    return bytes(STORE.serialize_cdr(to_rosbags(msg), type_name(msg)))


def sample(topic: str, i: int):
    """Message number i of a topic: distinct values in every field kind."""
    stamp = Time(sec=i, nanosec=7 * i)
    if topic == "/sail/boom_state":
        message = JointState(
            name=[f"boom_{k}" for k in range(4)],
            position=[0.5 * i + k for k in range(4)],
            velocity=[-0.25 * i] * 4,
            effort=[],
        )
        message.header.stamp, message.header.frame_id = stamp, "sail"
        return message
    if topic == "/sail/shape":
        marker = Marker(
            ns="membrane",
            id=i,
            type=Marker.TRIANGLE_LIST,
            points=[Point(x=float(i), y=float(k), z=1e-3 * k) for k in range(30)],
        )
        marker.header.stamp = stamp
        return MarkerArray(markers=[marker, Marker(ns="booms", id=i, text=f"t{i}")])
    if topic == "/sail/deploy_cmd":
        return Float64(data=0.1 * i)
    if topic == "/clock":
        return Clock(clock=stamp)
    return DiagnosticArray(
        status=[
            DiagnosticStatus(
                level=DiagnosticStatus.OK,
                name="sail",
                message=f"step {i}",
                values=[KeyValue(key="energy", value=str(1.5 * i))],
            )
        ]
    )


def write_samples(bag: BagWriter, count: int, step_ns: int = 10_000_000) -> list:
    """Write `count` rounds of every topic; returns (topic, msg, log, publish) in order."""
    for topic, cls in TOPICS.items():
        bag.add_topic(topic, type_name(cls), [LATCHED] if topic == "/sail/deploy_cmd" else None)
    written = []
    for i in range(count):
        for k, topic in enumerate(TOPICS):
            message = sample(topic, i)
            log_time = T0 + i * step_ns + k
            bag.write(topic, cdr(message), log_time, log_time - 1000)
            written.append((topic, message, log_time, log_time - 1000))
    return written


def test_schema_is_the_installed_msg_files_with_their_dependencies():
    definition = message_definition("sensor_msgs/msg/JointState")
    own = find_interface_file("sensor_msgs/msg/JointState", ".msg").read_text()
    header = find_interface_file("std_msgs/msg/Header", ".msg").read_text()
    assert definition.encoding == "ros2msg"
    assert definition.text.startswith(own)
    parts = definition.text.split(f"\n{SEPARATOR}\n")
    assert [p.splitlines()[0] for p in parts[1:]] == [
        "MSG: std_msgs/Header",
        "MSG: builtin_interfaces/Time",
    ]
    assert parts[1] == "MSG: std_msgs/Header\n" + header
    # each dependency once, even when several fields use it
    shape = message_definition("visualization_msgs/msg/MarkerArray").text
    headers = [line for line in shape.splitlines() if line.startswith("MSG: ")]
    assert len(headers) == len(set(headers))
    assert "MSG: geometry_msgs/Point" in headers and "MSG: std_msgs/ColorRGBA" in headers


def test_type_hash_agrees_with_rosbags():
    for cls in TOPICS.values():
        assert type_hash(type_name(cls)) == STORE.hash_rihs01(type_name(cls))


def test_unknown_type_is_a_clear_error():
    with pytest.raises(DefinitionNotFoundError, match="no_such_msgs/msg/Thing"):
        message_definition("no_such_msgs/msg/Thing")
    with pytest.raises(ValueError, match="'not a type'"):
        message_definition("not a type")


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_single_file_is_read_by_mcap_rosbags_and_rclpy(tmp_path, compression):
    path = tmp_path / "run.mcap"
    with BagWriter(path, compression=compression, chunk_size=4096) as bag:
        written = write_samples(bag, 40)
        bag.add_metadata("sail_sim_parameters", {"sail_side": "100.0", "n_boom_modes": "4"})
    assert bag.files == [path]

    # the mcap library, through the summary and with the ROS 2 decoder
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary.statistics.message_count == len(written)
        assert len(summary.chunk_indexes) > 1
        assert {c.compression for c in summary.chunk_indexes} == {
            "" if compression == "none" else compression
        }
        for schema in summary.schemas.values():
            assert schema.encoding == "ros2msg"
            assert schema.data.decode() == message_definition(schema.name).text
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "cdr"
            assert channel.metadata["topic_type_hash"] == type_hash(schema.name)
            offered = yaml.safe_load(channel.metadata["offered_qos_profiles"])
            expected = LATCHED if channel.topic == "/sail/deploy_cmd" else default_qos_profile()
            assert offered == [expected]
        metadata = {record.name: record.metadata for record in reader.iter_metadata()}
        assert metadata["sail_sim_parameters"] == {"sail_side": "100.0", "n_boom_modes": "4"}
        assert metadata["rosbag2"]["ROS_DISTRO"] == "jazzy"
        rosbag2 = yaml.safe_load(metadata["rosbag2"]["serialized_metadata"])
        assert rosbag2["version"] == 9 and rosbag2["storage_identifier"] == "mcap"
        assert rosbag2["message_count"] == len(written)
        decoded = list(reader.iter_decoded_messages())
    assert len(decoded) == len(written)
    for (_, channel, message, ros_msg), (topic, original, log, publish) in zip(
        decoded, written, strict=True
    ):
        assert (channel.topic, message.log_time, message.publish_time) == (topic, log, publish)
        if topic == "/sail/boom_state":
            assert list(ros_msg.position) == list(original.position)
            assert ros_msg.header.frame_id == "sail"
        if topic == "/sail/shape":
            z = original.markers[0].points[29].z
            assert ros_msg.markers[0].points[29].z == pytest.approx(z)

    # rosbags, independently of the mcap library; rclpy decodes the same bytes
    with AnyReader([path]) as reader:
        connections = {c.topic: c for c in reader.connections}
        assert {t: c.msgtype for t, c in connections.items()} == {
            t: type_name(cls) for t, cls in TOPICS.items()
        }
        latched = connections["/sail/deploy_cmd"].ext.offered_qos_profiles[0]
        assert latched.durability.name == "TRANSIENT_LOCAL" and latched.depth == 1
        rows = list(reader.messages())
        assert len(rows) == len(written)
        for (connection, log, raw), (topic, original, log_written, _) in zip(
            rows, written, strict=True
        ):
            assert (connection.topic, log) == (topic, log_written)
            assert deserialize_message(raw, TOPICS[topic]) == original
            value = reader.deserialize(raw, connection.msgtype)
            if topic == "/diagnostics":
                assert value.status[0].values[0].value == original.status[0].values[0].value

    # and our reader
    bag_messages = list(BagReader(path).messages())
    assert [(m.topic, m.log_time_ns, m.publish_time_ns) for m in bag_messages] == [
        (topic, log, publish) for topic, _, log, publish in written
    ]
    assert all(
        deserialize_message(m.data, TOPICS[m.topic]) == w[1]
        for m, w in zip(bag_messages, written, strict=True)
    )


class SplitsWithRecords(BagWriter):
    """Adds a record to every new file: splits decided and done before each write, as a
    caller that owns the splits does (`split_due`, `split`, then `write(split=False)`)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.new_files = []

    def write(self, topic, data, log_time_ns, *args, **kwargs):
        if self.split_due(log_time_ns):
            self.new_files.append(self.split())
            self.add_metadata("sail_sim_parameters", {"index": str(len(self.new_files))})
        super().write(topic, data, log_time_ns, *args, split=False, **kwargs)


def test_folder_splits_by_size_and_writes_rosbag2_metadata(tmp_path):
    folder = tmp_path / "sail_run"
    limit = 24576  # bytes: every file starts with its ~17 KB of schemas, then ~2 KB chunks
    bag = SplitsWithRecords(folder, chunk_size=2048, max_file_size_bytes=limit)
    with bag:
        bag.add_metadata("sail_sim_parameters", {"index": "0"})
        written = write_samples(bag, 60)
    new_files = bag.new_files
    files = sorted(folder.glob("*.mcap"), key=lambda p: int(p.stem.rsplit("_", 1)[1]))
    assert len(files) >= 3
    assert [f.name for f in files] == [f"sail_run_{i}.mcap" for i in range(len(files))]
    assert new_files == files[1:]
    for f in files:  # only the last chunk (and the summary) may cross the limit
        with f.open("rb") as stream:
            chunks = make_reader(stream).get_summary().chunk_indexes
        assert max(c.chunk_start_offset for c in chunks) < limit

    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == [f.name for f in files]
    assert info["message_count"] == len(written) == sum(f["message_count"] for f in info["files"])
    assert info["starting_time"]["nanoseconds_since_epoch"] == written[0][2]
    assert info["duration"]["nanoseconds"] == written[-1][2] - written[0][2]
    counts = {
        t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]
    }
    assert counts == {topic: 60 for topic in TOPICS}
    assert bag.topic_counts == counts

    reader = BagReader(folder)
    assert reader.files == files and not reader.incomplete_files
    assert [
        int(data["index"]) for name, data in reader.metadata() if name == "sail_sim_parameters"
    ] == list(range(len(files)))
    assert {t: i.message_count for t, i in reader.topics().items()} == counts
    assert [(m.topic, m.log_time_ns) for m in reader.messages()] == [(w[0], w[2]) for w in written]

    # rosbags reads the folder through metadata.yaml (its QoS must equal the files')
    with AnyReader([folder]) as rosbags_reader:
        assert rosbags_reader.message_count == len(written)
        assert {c.topic: c.digest for c in rosbags_reader.connections} == {
            t: type_hash(type_name(cls)) for t, cls in TOPICS.items()
        }
        values = [
            rosbags_reader.deserialize(raw, c.msgtype)
            for c, _, raw in rosbags_reader.messages()
            if c.topic == "/sail/deploy_cmd"
        ]
    assert [v.data for v in values] == pytest.approx([0.1 * i for i in range(60)])


def test_metadata_yaml_appears_whole_or_not_at_all(tmp_path, monkeypatch):
    """It is written under a temporary name and renamed: a failure on the way leaves
    neither it nor the temporary file, and the writer says so."""
    folder = tmp_path / "run"
    bag = BagWriter(folder)
    write_samples(bag, 3)

    def failing_rename(self, target):
        raise OSError(5, "Input/output error", str(self))

    monkeypatch.setattr(Path, "replace", failing_rename)
    with pytest.raises(BagWriteError, match="metadata.yaml': Input/output error"):
        bag.close()
    assert sorted(path.name for path in folder.iterdir()) == ["run_0.mcap"]
    assert BagReader(folder).incomplete_files == []  # the file itself was finished


def test_folder_splits_by_log_time(tmp_path):
    folder = tmp_path / "timed"
    with BagWriter(folder, max_file_duration_s=0.25) as bag:
        write_samples(bag, 100, step_ns=10_000_000)  # 1 s of log time
    summaries = bag.close()
    assert len(summaries) == 4
    assert all(s.end_time_ns - s.start_time_ns < 250_000_000 for s in summaries)
    assert sum(s.message_count for s in summaries) == 100 * len(TOPICS)


def test_file_cut_anywhere_reads_up_to_its_last_complete_chunk(tmp_path):
    path = tmp_path / "whole.mcap"
    with BagWriter(path, compression="lz4", chunk_size=1500, fsync=False) as bag:
        written = write_samples(bag, 30)
    data = path.read_bytes()
    expected = [(topic, log) for topic, _, log, _ in written]
    previous, counts = 0, set()
    for cut in range(0, len(data), len(data) // 50):
        cut_path = tmp_path / f"cut_{cut}.mcap"
        # a zero-filled tail, as a power cut may leave
        cut_path.write_bytes(data[: max(cut, 40)] + bytes(50))
        reader = BagReader(cut_path)
        assert reader.incomplete_files == [cut_path]
        got = [(m.topic, m.log_time_ns) for m in reader.messages()]
        assert got == expected[: len(got)]  # a prefix, in order
        assert len(got) >= previous  # the more of the file, the more messages
        assert sum(i.message_count for i in reader.topics().values()) == len(got)
        previous = len(got)
        counts.add(previous)
    assert min(counts) == 0 and max(counts) == len(expected) and len(counts) > 10


def test_killed_writer_leaves_its_closed_chunks_readable(tmp_path, monkeypatch):
    monkeypatch.setattr(mcap_storage, "FIRST_CHUNK_S", 0.5)  # the file's first chunk too
    path = tmp_path / "killed.mcap"
    bag = BagWriter(path, chunk_size=1 << 20, max_chunk_duration_s=0.5)  # > the writes
    written = write_samples(bag, 5)
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(path, copy)
    assert list(BagReader(copy).messages()) == []  # all in the open chunk: not on disk yet
    # ... but its topics are: schemas and channels go to the disk when declared
    assert set(BagReader(copy).topics()) == set(TOPICS)

    deadline = time.monotonic() + 5.0
    while path.stat().st_size == copy.stat().st_size and time.monotonic() < deadline:
        bag.tick()  # closes the chunk once it is max_chunk_duration_s old
        time.sleep(0.01)
    shutil.copyfile(path, copy)  # the file as a kill would leave it
    recovered = list(BagReader(copy).messages())
    assert [(m.topic, m.log_time_ns, m.data) for m in recovered] == [
        (topic, log, cdr(message)) for topic, message, log, _ in written
    ]
    bag.close()


def test_a_files_first_chunks_close_sooner_each_twice_as_late(tmp_path):
    """A kill early in a file loses at most about the second half of it: its first chunk
    closes FIRST_CHUNK_S after its first message, each next one may last twice as long as
    the one before, up to max_chunk_duration_s (0.1, 0.2, 0.4, 0.5, 0.5 s here)."""
    path = tmp_path / "early.mcap"
    bag = BagWriter(path, max_chunk_duration_s=0.5)
    bag.add_topic("/clock", type_name(Clock))
    copy = tmp_path / "copy.mcap"

    def on_disk() -> int:
        shutil.copyfile(path, copy)  # the file as a kill would leave it
        return sum(1 for _ in BagReader(copy).messages())

    durations = []
    for i in range(5):
        bag.write("/clock", cdr(sample("/clock", i)), T0 + i)
        opened = time.monotonic()
        durations.append(bag.seconds_to_next_tick())
        while on_disk() == i:  # closed by the tick once due, with nothing after it
            assert time.monotonic() - opened < durations[-1] + 1.0, i
            bag.tick()
            time.sleep(0.005)
        assert time.monotonic() - opened >= durations[-1] - 0.01
    expected = [mcap_storage.FIRST_CHUNK_S * 2**k for k in range(3)] + [0.5, 0.5]
    assert durations == pytest.approx(expected, abs=0.01)
    bag.close()
    assert [m.log_time_ns for m in BagReader(path).messages()] == [T0 + i for i in range(5)]


def test_reads_a_bag_written_by_rosbags(tmp_path):
    """An independent rosbag2 writer (version 9, MCAP storage) as a stand-in for ros2 bag."""
    folder = tmp_path / "foreign"
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(
            "/sail/boom_state", type_name(JointState), typestore=STORE
        )
        for i in range(10):
            writer.write(connection, T0 + i, cdr(sample("/sail/boom_state", i)))
    reader = BagReader(folder)
    info = reader.topics()["/sail/boom_state"]
    assert (info.type_name, info.message_count) == (type_name(JointState), 10)
    messages = list(reader.messages())
    assert [m.log_time_ns for m in messages] == [T0 + i for i in range(10)]
    assert deserialize_message(messages[3].data, JointState) == sample("/sail/boom_state", 3)


def test_qos_profiles_of_metadata_version_8_are_normalised():
    text = (
        "- history: 1\n  depth: 5\n  reliability: 2\n  durability: 1\n"
        "  deadline: {sec: 0, nsec: 0}\n  lifespan: {sec: 0, nsec: 0}\n  liveliness: 1\n"
        "  liveliness_lease_duration: {sec: 0, nsec: 0}\n"
        "  avoid_ros_namespace_conventions: false\n"
    )
    (profile,) = parse_qos_profiles(text)
    assert (
        profile["history"],
        profile["reliability"],
        profile["durability"],
        profile["liveliness"],
    ) == ("keep_last", "best_effort", "transient_local", "automatic")


def test_bad_arguments_name_the_field_and_value(tmp_path):
    with pytest.raises(
        ValueError,
        match=r"^compression must be one of zstd, lz4, none, "
        r"got 'gzip'$",
    ):
        BagWriter(tmp_path / "a", compression="gzip")
    with pytest.raises(ValueError, match="chunk_size must be >= 1, got 0"):
        BagWriter(tmp_path / "a", chunk_size=0)
    with pytest.raises(ValueError, match="max_file_size_bytes must be 0 .* got 5"):
        BagWriter(tmp_path / "a", max_file_size_bytes=5)
    with pytest.raises(ValueError, match="needs a folder"):
        BagWriter(tmp_path / "a.mcap", max_file_duration_s=10.0)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("")
    with pytest.raises(BagWriteError, match="full': folder exists and is not empty"):
        BagWriter(tmp_path / "full")
    (tmp_path / "afile").write_text("")
    with pytest.raises(BagWriteError, match="afile.*Not a directory"):
        BagWriter(tmp_path / "afile" / "bag")
    BagWriter(tmp_path / "x.mcap").close()
    with pytest.raises(BagWriteError, match="x.mcap': File exists"):
        BagWriter(tmp_path / "x.mcap")
    BagWriter(tmp_path / "x.mcap", overwrite=True).close()
    with BagWriter(tmp_path / "ok.mcap") as bag:
        with pytest.raises(ValueError, match="'/nope' was not declared"):
            bag.write("/nope", b"", 0)
        with pytest.raises(ValueError, match="absolute name"):
            bag.add_topic("relative", "std_msgs/msg/Float64")
        with pytest.raises(TypeError, match="'n'"):
            bag.add_metadata("m", {"n": 4})
    with pytest.raises(FileNotFoundError, match="'missing' does not exist"):
        BagReader("missing")
    (tmp_path / "text.mcap").write_text("not mcap")
    with pytest.raises(ValueError, match="is not an MCAP file"):
        BagReader(tmp_path / "text.mcap")


def test_type_without_definition_is_refused_not_written_with_an_empty_schema(tmp_path):
    bag = BagWriter(tmp_path / "x.mcap")
    with pytest.raises(
        DefinitionNotFoundError,
        match=r"no custom_msgs/msg/Thing\.(msg|idl) under share/ of any prefix",
    ):
        bag.add_topic("/custom", "custom_msgs/msg/Thing")
    bag.close()
    assert BagReader(tmp_path / "x.mcap").topics() == {}


def test_definitions_are_found_without_ament_prefix_path(monkeypatch):
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    definition = message_definition("sensor_msgs/msg/JointState")
    assert definition.encoding == "ros2msg" and "MSG: std_msgs/Header" in definition.text
    assert type_hash("sensor_msgs/msg/JointState").startswith("RIHS01_")
