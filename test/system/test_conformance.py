"""Every kind of log the project writes, decoded message by message by three strict readers.

The logs, made by as few processes in as few seconds as possible: one
simulator (time scale 2, so /clock too) and a deploy command, recorded at once
by a plain recorder, by a recorder splitting files every 0.3 s of log time and
by one that is killed (SIGKILL) and then `sail-ros bag recover`ed; meanwhile
`sail-ros deploy --mcap` (the one study tool that writes MCAP), played by
`sail-ros replay` on a DDS domain of its own and recorded again there.

The readers: rosbags (`AnyReader` and its `deserialize`, which refuses a
message with more than 3 bytes after its last field), mcap-ros2-support's
decoder, and Foxglove's JavaScript stack run with node
(`test/js/decode_logs.mjs`: @mcap/core's indexed reader, @mcap/support's
decompression, @foxglove/rosmsg's schema parser,
@foxglove/rosmsg2-serialization's CDR reader, which tells where its decoding
stopped: nothing may follow the last field but the zeros up to the next 4-byte
boundary, the end alignment DDS adds on the way). They
agree with each other and with the project's reader (`BagReader` and rclpy;
`log_series`) on every name and value of every message; and what a raw
subscriber in this process received live is, byte for byte, what was logged.

Needs node 20 and the packages of test/js/package-lock.json, which
scripts/test.sh installs (`npm ci`).
"""

import array
import collections
import contextlib
import dataclasses
import io
import json
import math
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from harness import DOMAIN_ID, JS, Tool, private_context, ros_value, spare_domain, wait_until
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rcl_interfaces.msg import ParameterEvent
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from std_msgs.msg import Float64

from sail_ros import topics
from sail_ros.analysis.log_series import read_log
from sail_ros.bag import BagReader, bag_files
from sail_ros.ros.program import message_class
from sail_ros.tools import bag as bag_tool
from sail_ros.tools import deploy

pytestmark = pytest.mark.multiprocess

SIM_PARAMETERS = {
    "time_scale": 2.0,  # /clock is published, from the state templates and with the status
    "state_rate_hz": 10.0,  # few messages (each is decoded by four readers)
    "initial_tip_deflection": [0.1, -0.02, 0.03, 0.0],
    "shape_divisions": 2,  # small shapes: 16 triangles, decoded by four readers
    "diagnostics_rate_hz": 5.0,
}
SPLIT_S = 0.3  # the splitting recorder's --max-file-duration-s
RUN_S = 2.0  # simulated time after the deploy command is accepted [s]
LISTENED = {topics.absolute(name): topic for name, topic in topics.TOPICS.items()}
# every node publishes parameter events (no one publisher to follow): listened to so
# that the replay, which plays them, sees this process subscribed
LISTENED[topics.PARAMETER_EVENTS] = topics.Topic(
    topics.PARAMETER_EVENTS,
    ParameterEvent,
    "rcl_interfaces/msg/ParameterEvent",
    QoSProfile(depth=1000),
)
TOLERANCE = 1e-12  # relative (absolute below 1)
HISTORY_DEPTH = 1000  # messages each raw subscription keeps until taken


# -- the logs --------------------------------------------------------------------------------


class RawListener(Node):
    """Keeps the CDR bytes (raw subscriptions) and DDS source timestamps of everything
    published on the simulator's topics, spinning in a thread of its own. Each topic's
    QoS, but a history of HISTORY_DEPTH (as the recorder's): DDS keeps what arrives
    while this process waits for a core, so nothing is lost to a 100 Hz /clock."""

    def __init__(self, context):
        super().__init__("conformance_listener", context=context)
        self.received = {topic: [] for topic in LISTENED}
        for topic, spec in LISTENED.items():
            self.create_subscription(
                spec.message_type,
                topic,
                lambda data, info, topic=topic: self.received[topic].append(
                    (info["source_timestamp"], data)
                ),
                QoSProfile(
                    history=spec.qos.history,
                    depth=HISTORY_DEPTH,
                    reliability=spec.qos.reliability,
                    durability=spec.qos.durability,
                ),
                raw=True,
            )
        self.spinner = SingleThreadedExecutor(context=context)
        self.spinner.add_node(self)
        self._thread = threading.Thread(target=self.spinner.spin, daemon=True)
        self._thread.start()

    def take(self) -> dict[str, list]:
        """What was received so far; new lists take what comes next."""
        taken, self.received = self.received, {topic: [] for topic in LISTENED}
        return taken

    def wait_until(self, condition, timeout: float, what: str, running=()) -> None:
        """Until `condition()`; fails naming `what` after `timeout` [s], or at once if
        one of the `running` tools exits."""
        wait_until(condition, timeout, what, step=0.02, running=running)

    def wait_until_quiet(self, quiet: float = 0.3, timeout: float = 10.0) -> None:
        """Until nothing arrived for `quiet` [s]: what was in flight is taken."""
        state = {"count": -1, "since": time.monotonic()}

        def calm():
            count = sum(len(kept) for kept in self.received.values())
            if count != state["count"]:
                state.update(count=count, since=time.monotonic())
            return time.monotonic() - state["since"] > quiet

        self.wait_until(calm, timeout, f"{quiet} s without a message")

    def close(self) -> None:
        self.spinner.shutdown()
        self._thread.join(5.0)
        self.destroy_node()


def stamp_s(data: bytes, topic: str) -> float:
    message = deserialize_message(data, LISTENED[topic].message_type)
    stamp = message.clock if topic == topics.CLOCK else message.header.stamp
    return stamp.sec + stamp.nanosec * 1e-9


def has_chunk(folder: Path) -> bool:
    """Whether a live recording in `folder` holds a complete chunk."""
    try:
        return any(True for _ in BagReader(folder).messages())
    except (OSError, ValueError):  # not created yet, or its header not yet written
        return False


@dataclasses.dataclass
class Logs:
    """The logs made, and the bytes received live while they were."""

    folders: dict[str, Path]  # log kind -> bag folder
    live: dict[str, dict[str, list]]  # log kind -> topic -> (source time [ns], bytes)
    incomplete: list[Path]  # the killed recorder's files, before `bag recover`


def stop_all(tools, timeout=20.0) -> None:
    """SIGINT to every tool at once, then each must exit with 0 within `timeout` [s]."""
    for tool in tools:
        tool.process.send_signal(signal.SIGINT)
    for tool in tools:
        try:
            code = tool.process.wait(timeout)
        except subprocess.TimeoutExpired:
            tool.process.kill()
            pytest.fail(f"{tool.log_path.stem} did not exit within {timeout} s:\n{tool.log()}")
        assert code == 0, tool.log()


def sim_arguments() -> list[str]:
    return [
        "--ros-args",
        *[
            item
            for name, value in SIM_PARAMETERS.items()
            for item in ("-p", f"{name}:={ros_value(value)}")
        ],
    ]


@pytest.fixture(scope="module")
def logs(js_readers, ros_env, tmp_path_factory) -> Logs:
    """The simulator and its three recorders on the test's domain; the offline run
    while they start, and its replay and the replay's recorder on a domain of their
    own meanwhile."""
    root = tmp_path_factory.mktemp("conformance")
    folders = {kind: root / kind for kind in ("live", "split", "killed", "replayed", "deploy")}
    contexts, listeners, started = contextlib.ExitStack(), [], []

    def listen(domain):
        listeners.append(RawListener(contexts.enter_context(private_context(domain))))
        return listeners[-1]

    def start(tool, *args, env=ros_env):
        started.append(Tool(tool, args, env, root / f"{tool}_{len(started)}.log"))
        return started[-1]

    try:
        listener = listen(DOMAIN_ID)
        with spare_domain() as domain:  # held until this process's participant is in it
            replay_env = dict(ros_env, ROS_DOMAIN_ID=str(domain))
            replay_listener = listen(domain)
        sim = start("sim", *sim_arguments())
        recorders = {
            "live": start("recorder", "-o", str(folders["live"])),
            "split": start(
                "recorder", "-o", str(folders["split"]), "--max-file-duration-s", str(SPLIT_S)
            ),
            "killed": start(
                "recorder", "-o", str(folders["killed"]), "--max-chunk-duration-s", "0.2"
            ),
        }
        rerecorder = start(
            "recorder", "-o", str(folders["replayed"]), "--parameter-node", "", env=replay_env
        )
        with contextlib.redirect_stdout(io.StringIO()) as out:
            code = deploy.main(
                [
                    *("--duration", "4", "--to", "11", "--rate", "20"),
                    *("--set", "free_hub=true", "--set", "hub_mass=20.0"),  # Odometry too
                    *("--set", "n_membrane_modes=24"),  # the log's form is checked, not physics
                    *("--shape-rate", "5", "--shape-divisions", "2", "--mcap"),
                    str(folders["deploy"]),
                ]
            )
        assert code == 0, out.getvalue()
        # the offline log played and recorded again, once the recorder and this process
        # listen on every topic it plays
        replay = start(
            "replay",
            str(folders["deploy"]),
            *("--rate", "4", "--wait-for-subscribers", "2"),
            env=replay_env,
        )

        state = topics.absolute(topics.BOOM_STATE)
        listener.wait_until(  # the simulator publishes, each recorder and this process listen
            lambda: (
                listener.count_subscribers(state) >= 1 + len(recorders) and listener.received[state]
            ),
            30.0,
            "the simulator and the recorders' subscriptions",
            running=[sim, *recorders.values()],
        )
        deploy_cmd = listener.create_publisher(
            Float64, topics.DEPLOY_CMD, topics.LATCHED_COMMAND_QOS
        )
        deploy_cmd.publish(Float64(data=10.5))
        status = listener.received[topics.absolute(topics.COMMAND_STATUS)]
        listener.wait_until(
            lambda: status, 10.0, "the answer to the deploy command", [sim, *recorders.values()]
        )
        started_s = stamp_s(status[0][1], topics.absolute(topics.COMMAND_STATUS))

        def simulated(seconds):
            return lambda: stamp_s(listener.received[state][-1][1], state) > started_s + seconds

        listener.wait_until(
            lambda: simulated(0.5)() and has_chunk(folders["killed"]),
            20.0,
            "a chunk of the recorder to kill on disk",
            [sim, *recorders.values()],
        )
        recorders["killed"].process.send_signal(signal.SIGKILL)
        recorders["killed"].process.wait(10.0)
        listener.wait_until(
            lambda: simulated(RUN_S)() and len(bag_files(folders["split"])) >= 3,
            30.0,
            f"{RUN_S} s of simulated time and three split files",
            [sim, recorders["live"], recorders["split"]],
        )
        stop_all([sim])  # it exits once every sample is acknowledged
        assert replay.process.wait(30.0) == 0, replay.log()  # once all is acknowledged
        listener.wait_until_quiet()
        replay_listener.wait_until_quiet()
        stop_all([recorders["live"], recorders["split"], rerecorder])
        with contextlib.redirect_stdout(io.StringIO()) as out:
            code = bag_tool.main(["recover", str(folders["killed"]), "-o", str(root / "recovered")])
        assert code == 0, out.getvalue()
        incomplete = BagReader(folders.pop("killed")).incomplete_files
        folders["recovered"] = root / "recovered"
    finally:
        for tool in started:
            if tool.process.poll() is None:
                tool.process.kill()
                tool.process.wait()
        for node in listeners:
            node.close()
        contexts.close()
    live = listener.take()
    return Logs(
        folders,
        {"live": live, "split": live, "recovered": live, "replayed": replay_listener.take()},
        incomplete,
    )


# -- the readers, each giving {topic: [(log time [ns], plain value)]} per log -----------------
# A plain value is the message as nested dicts (fields in order), lists and scalars.


def plain_rclpy(value):
    if hasattr(value, "get_fields_and_field_types"):
        return {
            name: plain_rclpy(getattr(value, name)) for name in value.get_fields_and_field_types()
        }
    if isinstance(value, array.array | np.ndarray):
        return value.tolist()
    if isinstance(value, bytes):  # a `byte` field: one byte
        (number,) = value
        return number
    if isinstance(value, list):
        return [plain_rclpy(item) for item in value]
    return value


def plain_rosbags(value):
    if dataclasses.is_dataclass(value):  # constants are dataclass fields typed "ClassVar[...]"
        return {
            field.name: plain_rosbags(getattr(value, field.name))
            for field in dataclasses.fields(value)
            if not str(field.type).startswith("ClassVar")
            and field.name != "structure_needs_at_least_one_member"
        }
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list):
        return [plain_rosbags(item) for item in value]
    return value


def plain_mcap_ros2(value):
    if isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, bytes):  # uint8[] and byte[]
        return list(value)
    if isinstance(value, list):
        return [plain_mcap_ros2(item) for item in value]
    return {name: plain_mcap_ros2(getattr(value, name)) for name in value.__slots__}


def plain_json(value):
    """The JavaScript side's escapes back to numbers (see decode_logs.mjs)."""
    if isinstance(value, dict):
        if value.keys() == {"int"}:
            return int(value["int"])
        if value.keys() == {"float"}:
            return float(value["float"])
        return {key: plain_json(item) for key, item in value.items()}
    if isinstance(value, list):
        return [plain_json(item) for item in value]
    return value


class Decoded:
    """One reader's messages of one log, and what it could not decode or found left over."""

    def __init__(self):
        self.messages = collections.defaultdict(list)  # topic -> [(log time, plain value)]
        self.problems = collections.defaultdict(list)  # (file, topic) -> [(index, text)]

    def add(self, topic, log_time, value):
        self.messages[topic].append((int(log_time), value))

    def failed(self, file, topic, log_time, error):
        """A message not decoded, or with bytes left over: kept in its place, value None."""
        self.problems[file, topic].append((len(self.messages[topic]), error))
        self.messages[topic].append((int(log_time), None))

    def ordered(self) -> dict[str, list]:
        """Each topic's messages in log-time order."""
        return {
            topic: sorted(kept, key=lambda entry: entry[0]) for topic, kept in self.messages.items()
        }


def read_project(folder: Path) -> Decoded:
    decoded = Decoded()
    for message in BagReader(folder).messages():
        try:
            value = deserialize_message(message.data, message_class(message.type_name))
            decoded.add(message.topic, message.log_time_ns, plain_rclpy(value))
        except Exception as error:  # noqa: BLE001 (reported with its message)
            decoded.failed(folder.name, message.topic, message.log_time_ns, repr(error))
    return decoded


def read_rosbags(folder: Path) -> Decoded:
    decoded = Decoded()
    with AnyReader([folder]) as reader:
        for connection, log_time, raw in reader.messages():
            try:
                value = reader.deserialize(raw, connection.msgtype)
                decoded.add(connection.topic, log_time, plain_rosbags(value))
            except Exception as error:  # noqa: BLE001
                decoded.failed(
                    folder.name, connection.topic, log_time, f"{len(raw)} bytes: {error}"
                )
    return decoded


def read_mcap_ros2(folder: Path) -> Decoded:
    decoded, factory = Decoded(), DecoderFactory()
    for file in bag_files(folder):
        with file.open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            for channel in summary.channels.values():  # every schema, also without messages
                try:
                    schema = summary.schemas[channel.schema_id]
                    if factory.decoder_for(channel.message_encoding, schema) is None:
                        raise ValueError(f"no decoder for {channel.message_encoding}, {schema}")
                except Exception as error:  # noqa: BLE001
                    decoded.problems[file.name, channel.topic].append(("schema", repr(error)))
            for schema, channel, message in reader.iter_messages():
                try:
                    decoder = factory.decoder_for(channel.message_encoding, schema)
                    if decoder is None:
                        raise ValueError(f"no decoder for {channel.message_encoding}, {schema}")
                    value = plain_mcap_ros2(decoder(message.data))
                    decoded.add(channel.topic, message.log_time, value)
                except Exception as error:  # noqa: BLE001
                    decoded.failed(file.name, channel.topic, message.log_time, repr(error))
    return decoded


def padding_only(size: int, decoded: int, left_over: list[int]) -> bool:
    """Whether what follows the last field is at most the zeros up to the next 4-byte
    boundary: the end alignment a CDR writer may add, and DDS adds on the way (Fast
    DDS delivers a payload of 3573 bytes as 3576, without saying so in the header)."""
    return size == decoded or (size - decoded == -decoded % 4 and not any(left_over))


def start_javascript(node: Path, folders: dict[str, Path], output: Path):
    """Every file of every log decoded in one node run, in the background; `finish`
    gives log kind -> `Decoded`."""
    files = {file: kind for kind, folder in folders.items() for file in bag_files(folder)}
    process = subprocess.Popen(
        [str(node), str(JS / "decode_logs.mjs"), str(output), *map(str, files)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )

    def finish() -> dict[str, Decoded]:
        log, _ = process.communicate(timeout=120)
        assert process.returncode == 0, f"decode_logs.mjs failed:\n{log}"
        answers = json.loads(output.read_text())
        decoded = {kind: Decoded() for kind in folders}
        for file, kind in files.items():
            read_answer(answers[str(file)], file.name, decoded[kind])
        return decoded

    return finish


def read_answer(answer: dict, name: str, log: Decoded) -> None:
    """One file's messages as decode_logs.mjs gave them."""
    if "error" in answer:
        log.problems[name, "(file)"].append((0, answer["error"]))
        return
    for entry in answer["schema_errors"]:
        log.problems[name, entry["topic"]].append(("schema", entry["error"]))
    for entry in answer["messages"]:
        topic = entry["topic"]
        if "error" in entry:
            log.failed(name, topic, entry["log_time"], entry["error"])
        elif not padding_only(entry["size"], entry["decoded"], entry["left_over"]):
            log.failed(
                name,
                topic,
                entry["log_time"],
                f"{entry['size']} bytes, decoded {entry['decoded']}: "
                f"{entry['size'] - entry['decoded']} left over, {entry['left_over']}",
            )
        else:
            log.add(topic, entry["log_time"], plain_json(entry["value"]))


@pytest.fixture(scope="module")
def decoded(logs, js_readers, tmp_path_factory) -> dict[str, dict[str, Decoded]]:
    """What each reader decoded: reader -> log kind -> `Decoded` (node in parallel)."""
    javascript = start_javascript(
        js_readers, logs.folders, tmp_path_factory.mktemp("javascript") / "decoded.json"
    )
    return {
        "project (BagReader, rclpy)": {k: read_project(f) for k, f in logs.folders.items()},
        "rosbags": {kind: read_rosbags(folder) for kind, folder in logs.folders.items()},
        "mcap_ros2": {kind: read_mcap_ros2(folder) for kind, folder in logs.folders.items()},
        "javascript (Foxglove)": javascript(),
    }


# -- comparison ------------------------------------------------------------------------------


def leaves(value, path=""):
    """(path, scalar) of every leaf of a plain value, in field order."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from leaves(item, f"{path}.{key}" if path else key)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from leaves(item, f"{path}[{index}]")
    else:
        yield path, value


def same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= TOLERANCE * max(1.0, abs(a), abs(b))


def difference(value, reference) -> str | None:
    """Where two plain values differ first (path and both values), or None."""
    mine, theirs = list(leaves(value)), list(leaves(reference))
    for (path, a), (reference_path, b) in zip(mine, theirs, strict=False):
        if path != reference_path:
            return f"field {path!r} where the reference has {reference_path!r}"
        if not same(a, b):
            gap = "" if isinstance(a, str) or isinstance(b, str) else f" (by {abs(a - b):.3g})"
            return f"{path} = {a!r}, reference {b!r}{gap}"
    if len(mine) != len(theirs):
        return f"{len(mine)} values, reference {len(theirs)}"
    return None


# -- tests -----------------------------------------------------------------------------------


def test_every_kind_of_log_was_made(logs):
    """What the comparison stands on: each log holds what its kind should."""
    counts = {
        k: {t: i.message_count for t, i in BagReader(f).topics().items()}
        for k, f in logs.folders.items()
    }
    sim_topics = [topics.absolute(name) for name in (*topics.STATE_TOPICS, topics.SHAPE)]
    for kind in ("live", "split"):
        for topic in [
            *sim_topics,
            topics.CLOCK,
            topics.DIAGNOSTICS,
            topics.absolute(topics.COMMAND_STATUS),
            topics.absolute(topics.DEPLOY_CMD),
        ]:
            assert counts[kind].get(topic, 0) > 0, (kind, topic, counts[kind])
    assert len(bag_files(logs.folders["split"])) >= 3
    assert logs.incomplete, "the killed recorder's file was finished"
    assert counts["recovered"].get(topics.absolute(topics.BOOM_STATE), 0) > 0
    for kind in ("deploy", "replayed"):  # a free hub's run: its nav_msgs/Odometry too
        for topic in [*sim_topics, topics.CLOCK, topics.absolute(topics.HUB_STATE)]:
            assert counts[kind].get(topic, 0) > 0, (kind, topic, counts[kind])


def test_no_reader_fails_or_finds_bytes_left_over(decoded):
    """Each reader, log, file and topic with problems: how many, and the first."""
    problems = [
        f"{reader}, log {kind}, {file}, {topic}: {len(found)} problem(s), the first in "
        + (f"message {found[0][0]}" if isinstance(found[0][0], int) else found[0][0])
        + f": {found[0][1]}"
        for reader, per_log in decoded.items()
        for kind, log in per_log.items()
        for (file, topic), found in log.problems.items()
    ]
    assert not problems, f"{len(problems)} readers, files and topics with problems:\n" + "\n".join(
        problems
    )


def test_every_reader_gives_every_message_with_the_same_names_and_values(decoded, logs):
    reference_name = "project (BagReader, rclpy)"
    reference = decoded[reference_name]
    disagreements = []
    for kind, folder in logs.folders.items():
        expected = {t: i.message_count for t, i in BagReader(folder).topics().items()}
        ordered = reference[kind].ordered()
        assert {t: len(m) for t, m in ordered.items()} == {
            t: n for t, n in expected.items() if n
        }, kind
        for reader, per_log in decoded.items():
            if reader == reference_name:
                continue
            theirs = per_log[kind].ordered()
            for topic, messages in ordered.items():
                got = theirs.get(topic, [])
                if len(got) != len(messages):
                    disagreements.append(
                        f"{reader}, log {kind}, {topic}: {len(got)} messages, "
                        f"{reference_name} {len(messages)}"
                    )
                    continue
                for index, ((time_a, a), (time_b, b)) in enumerate(zip(got, messages, strict=True)):
                    if a is None or b is None:
                        continue  # not decoded: test_no_reader_fails_or_finds_bytes_left_over
                    found = (
                        f"log time {time_a}, reference {time_b}"
                        if time_a != time_b
                        else difference(a, b)
                    )
                    if found:
                        disagreements.append(
                            f"{reader}, log {kind}, {topic} message {index}: {found}"
                        )
    assert not disagreements, (
        f"{len(disagreements)} disagreements with {reference_name}:\n"
        + "\n".join(disagreements[:20])
    )


def test_log_series_reads_the_values_every_reader_reads(decoded, logs):
    """`log_series` (what `sail-ros report` uses) against each strict reader; a topic no
    reader finds in a log is no series (the killed recorder's chunks, written before its
    subscription to a topic had matched, can hold none of that topic's messages: seen
    once for the tip deflections)."""
    series_of = {
        topics.BOOM_STATE: "boom",
        topics.TIP_DEFLECTION: "tips",
        topics.MODAL_STATE: "modal",
        topics.ROOT_MOMENT: "moments",
    }
    for kind, folder in logs.folders.items():
        series = read_log(folder)
        for name, attribute in series_of.items():
            read = getattr(series, attribute)
            for reader, per_log in decoded.items():
                where = f"log {kind}, {name}, log_series against {reader}"
                messages = sorted(
                    (m for _, m in per_log[kind].messages[topics.absolute(name)] if m is not None),
                    key=lambda m: (m["header"]["stamp"]["sec"], m["header"]["stamp"]["nanosec"]),
                )
                stamps = [
                    m["header"]["stamp"]["sec"] * 10**9 + m["header"]["stamp"]["nanosec"]
                    for m in messages
                ]
                if read is None:
                    assert not stamps, where
                    continue
                assert read.stamp_ns.tolist() == stamps, where
                assert all(m["name"] == read.names for m in messages), where
                for field in ("position", "velocity", "effort"):
                    values = np.array([m[field] for m in messages], dtype=float)
                    np.testing.assert_allclose(
                        getattr(read, field).reshape(values.shape),
                        values,
                        rtol=TOLERANCE,
                        atol=TOLERANCE,
                        err_msg=f"{where}: {field}",
                    )


def test_live_bytes_are_the_logged_bytes(logs):
    """The raw subscriber's bytes and the logged bytes of the same messages are the
    same: on every topic, every logged message published once this process received
    that topic is among what it received (and, for the finished recorders, the other
    way round)."""
    mismatches = []
    for kind, received in logs.live.items():
        logged = collections.defaultdict(list)
        for message in BagReader(logs.folders[kind]).messages():
            logged[message.topic].append((message.publish_time_ns, message.data))
        for topic, live in received.items():
            if not live or topic == topics.PARAMETER_EVENTS:
                continue
            pairs = [("logged", logged[topic], live, "received live")]
            if kind != "recovered":  # the killed recorder lost what came after its kill
                pairs.append(("received live", live, logged[topic], "logged"))
            for name, these, those, other in pairs:
                if not those:
                    mismatches.append(f"log {kind}, {topic}: nothing {other}")
                    continue
                first = min(stamp for stamp, _ in those)
                available = collections.Counter(data for _, data in those)
                for index, (stamp, data) in enumerate(sorted(these, key=lambda e: e[0])):
                    if stamp < first:
                        continue
                    if available[data] == 0:
                        mismatches.append(
                            f"log {kind}, {topic}: {name} message {index} ({len(data)} bytes, "
                            f"published at {stamp} ns) not {other}"
                        )
                    available[data] -= 1
    assert not mismatches, f"{len(mismatches)} mismatches:\n" + "\n".join(mismatches[:20])
