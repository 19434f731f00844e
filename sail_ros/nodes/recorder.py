"""Node `sail_recorder`: record topics into MCAP bags that rosbag2, Foxglove and rosbags read.

Subscribes (raw, no deserialisation) to the configured topics as soon as a
publisher of each appears in the graph, learning its type and QoS from the
publishers; to the simulator's command topics at once, twice each as the
simulator listens (a command from `sail-ros send` is published by a process
that exits once it is answered, often before the graph's next poll), a sample
arriving on both written once. It hands the CDR bytes to a `BagWriter` in its own
thread (`sail_ros.bag.recording.Recording`, the one owner of the files, the
splits and the parameters stored). Log time is the DDS reception time and
publish time the DDS source time [ns since the Unix epoch]. The parameters of
the simulator node are stored in every file as the MCAP metadata record
`sail_sim_parameters` (the values when the file starts, and again when the node
starts anew under the recorder: a restarted simulator's sail may differ), and each
change of them, with its time, as a record `sail_sim_parameter_changes`.

SIGINT/SIGTERM: take what DDS has already received, finish the file(s)
(summary, metadata.yaml) and exit 0. A write error (disk full, no
permission): log the path and the OS error, exit 1; what was written stays
readable up to its last complete chunk. Any other error while recording: log
it, finish the file(s), exit 1. A bad parameter: exit 2, before any file is
created.

    sail-ros recorder -o run1
    sail-ros recorder --all-topics --max-file-duration-s 600
    sail-ros recorder --ros-args --params-file config/recorder.yaml
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
import sys
import time
import traceback

from rcl_interfaces.msg import ParameterEvent
from rcl_interfaces.srv import GetParameters, ListParameters
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.exceptions import NameValidationException
from rclpy.executors import SingleThreadedExecutor
from rclpy.expand_topic_name import expand_topic_name
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.qos import qos_profile_parameter_events

from sail_ros.bag import (
    COMPRESSIONS,
    BagWriteError,
    BagWriter,
    DefinitionNotFoundError,
    message_definition,
    qos,
)
from sail_ros.bag.parameter_fetch import ASK, ASK_AGAIN, WARN_ABSENT, ParameterFetch
from sail_ros.bag.recording import Recording
from sail_ros.messages.parameters import parameter_update, yaml_texts
from sail_ros.model.fields import setting, settings_of
from sail_ros.options import docstring_examples
from sail_ros.ros.parameters import (
    ConfigError,
    declare,
    destroyed_if_refused,
    make_parser,
    node_options,
    overrides,
)
from sail_ros.ros.program import StopSignals, bounded_teardown, message_class, run_node
from sail_ros.ros.taking import take_waiting
from sail_ros.runtime.intake import Repeats
from sail_ros.topics import (
    COMMAND_TOPICS,
    HUB_WRENCH_CMD,
    LATCHED_COMMAND_QOS,
    PARAMETER_CHANGES_METADATA,
    PARAMETER_EVENTS,
    PARAMETERS_METADATA,
    RECORDED_TOPICS,
    TOPICS,
)

NODE_NAME = "sail_recorder"
DROPPED_METADATA = "sail_recorder_dropped"  # topic -> messages dropped for a slow disk
GRAPH_PERIOD_S = 0.1  # how often new topics are looked for (rosbag2 polls every 0.1 s too)
PARAMETER_WAIT_WARNING_S = 5.0  # warn once if the parameter node is still absent
SERVICE_TIMEOUT_S = 5.0  # a parameter request without answer is retried after this
DRAIN_QUIET_S = 0.1  # at shutdown, stop taking messages once none came for this long
DRAIN_MAX_S = 2.0  # ... or after this long, if publishers keep sending
# most messages taken from one subscription per executor callback (why in batches:
# sail_ros.ros.taking)
TAKE_BATCH = 1000
# after taking messages, let the next ones gather in DDS this long [s]: a wake-up then
# takes several (log times are DDS's reception times, so they do not change)
GATHER_S = 0.01


@dataclasses.dataclass(frozen=True)
class RecorderSettings:
    """The recorder's parameters (node `sail_recorder`)."""

    output: str = setting(
        "",
        "",
        "bag folder to create (must be absent or empty); holds "
        "<name>_<index>.mcap and metadata.yaml; empty: sail_<UTC time> in the "
        "working directory",
        short="-o",
    )
    topics: list = setting(
        list(RECORDED_TOPICS),
        "",
        "topics to record; each is subscribed once a publisher of it appears, the "
        "simulator's command topics at once (ignored when all_topics is true)",
    )
    all_topics: bool = setting(
        False,
        "",
        "record every topic with a publisher, except hidden ones "
        "(a name part starting with '_'), including topics that appear later",
    )
    compression: str = setting("zstd", "", "chunk compression", choices=tuple(COMPRESSIONS))
    chunk_size_bytes: int = setting(
        1 << 20,
        "",
        "close a chunk when its messages reach this size [bytes]",
        minimum=1024,
        maximum=1 << 30,
    )
    max_chunk_duration_s: float = setting(
        1.0,
        "",
        "close a chunk at most this long after its first "
        "message [s]; a kill loses at most this much",
        minimum=0.01,
        maximum=3600.0,
    )
    max_file_size_bytes: int = setting(
        0,
        "",
        "start a new file when the current one reaches this size [bytes]; 0: never (else >= 1024)",
        minimum=0,
    )
    max_file_duration_s: float = setting(
        0.0,
        "",
        "start a new file when the current one spans this much log time [s]; 0: never",
        minimum=0.0,
    )
    parameter_node: str = setting(
        "sail_sim",
        "",
        "node whose parameters are stored in each file "
        f"as metadata '{PARAMETERS_METADATA}', and each change of them with its time as "
        f"'{PARAMETER_CHANGES_METADATA}' (relative: in the recorder's namespace); "
        "empty: none",
    )
    queue_messages: int = setting(
        10000,
        "",
        "messages that may wait for the writer [messages]; beyond, when the disk is slower "
        f"than the traffic, messages are dropped, counted per topic and stored as metadata "
        f"'{DROPPED_METADATA}' (bounded memory)",
        minimum=10,
        maximum=10_000_000,
    )
    qos_depth: int = setting(
        1000,
        "",
        "history depth of each subscription [messages]: how many "
        "may wait while the recorder is busy (1000: 5 s of a 200 Hz topic)",
        minimum=1,
        maximum=100000,
    )


SPECS = settings_of(RecorderSettings)


def default_output() -> str:
    """`sail_<UTC date-time>`, like rosbag2's `rosbag2_<date-time>`."""
    return "sail_" + datetime.datetime.now(datetime.UTC).strftime("%Y_%m_%d-%H_%M_%S")


def is_hidden(topic: str) -> bool:
    """ROS hides names with a part starting with '_' (e.g. service event topics)."""
    return any(part.startswith("_") for part in topic.split("/"))


class Recorder(Node):
    """The `sail_recorder` node; `run` records until stopped.

    Its arguments are `ros.parameters.node_options`'s.

    Raises:
        ConfigError: a parameter has a value the recorder cannot use.
        BagWriteError: the bag cannot be created.
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        with destroyed_if_refused(self):
            self._set_up()

    def _set_up(self) -> None:
        """The checks, the bag and the subscriptions (raises ConfigError)."""
        self.config = declare(self, SPECS)
        self._wanted = {self._resolve(topic) for topic in self.config["topics"]}
        self._recording: dict[str, list] = {}  # topic -> its subscriptions
        self._announced: set[str] = set()  # topics the bag has a channel for
        self._commands: dict[str, object] = {}  # command topics subscribed at start
        # a command taken by both its subscriptions, which are drained one after the other
        self._repeats = Repeats(2 * max(self.config["qos_depth"], TAKE_BATCH))
        self._foreign: set[str] = set()  # command topics with a publisher of another type
        self._publishers_seen: dict[str, int] = {}  # command topic -> publishers last polled
        self._ignored: set[str] = set()
        self._received = 0  # messages taken from DDS, for draining at shutdown

        # every check that can fail comes before the bag is created; the fetch's state is
        # this (the executor's) thread's: its answer goes to the writer thread as an event
        parameter_node = self.config["parameter_node"].rstrip("/")
        self._parameter_node = parameter_node
        self._fetch = ParameterFetch(PARAMETER_WAIT_WARNING_S, SERVICE_TIMEOUT_S)
        full_name = None
        if parameter_node:
            full_name = self._create_parameter_clients(parameter_node)

        output = self.config["output"] or default_output()
        try:
            writer = BagWriter(
                output,
                compression=self.config["compression"],
                chunk_size=self.config["chunk_size_bytes"],
                max_chunk_duration_s=self.config["max_chunk_duration_s"],
                max_file_size_bytes=self.config["max_file_size_bytes"],
                max_file_duration_s=self.config["max_file_duration_s"],
            )
        except ValueError as error:
            raise ConfigError(str(error)) from None
        self.bag = Recording(
            writer,
            max_messages=self.config["queue_messages"],
            parameter_node=full_name,
            parameters_record=PARAMETERS_METADATA,
            changes_record=PARAMETER_CHANGES_METADATA,
            dropped_record=DROPPED_METADATA,
            parameters_wait_s=PARAMETER_WAIT_WARNING_S,
        )
        try:
            self._subscribe_commands()
            self._poll_timer = self.create_timer(GRAPH_PERIOD_S, self._poll)
            if full_name is not None:
                self.create_subscription(
                    ParameterEvent,
                    PARAMETER_EVENTS,
                    functools.partial(self._on_parameter_event, full_name),
                    qos_profile_parameter_events,
                )
            self.get_logger().info(f"recording into '{writer.path}'")
        except BaseException:
            self.bag.close()  # a complete (empty) bag rather than a file without summary
            raise

    def _create_parameter_clients(self, parameter_node: str) -> str:
        """The parameter services' clients; returns the node's full name."""
        try:
            self._list_client = self.create_client(
                ListParameters, f"{parameter_node}/list_parameters"
            )
            self._get_client = self.create_client(GetParameters, f"{parameter_node}/get_parameters")
        except NameValidationException as error:
            reason = str(error).splitlines()[0].split(": ", 1)[-1].rstrip(":")
            raise ConfigError(
                f"parameter_node: {self.config['parameter_node']!r} is not a "
                f"valid node name ({reason})"
            ) from None
        return expand_topic_name(parameter_node, self.get_name(), self.get_namespace())

    # -- running ----------------------------------------------------------------------------

    def run(self, stop: StopSignals) -> int:
        """Record until a stop signal, a write error or an error in a callback; returns
        the exit code. The bag is finished (summary, metadata.yaml) whatever happens."""
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self)
        error = None
        try:
            self._poll()
            while not stop.event.is_set() and not self.bag.failed.is_set():
                received = self._received
                executor.spin_once(timeout_sec=0.1)
                if self._received != received:
                    time.sleep(GATHER_S)
            self._poll_timer.cancel()
            if stop.received:
                self.get_logger().info(f"{stop.received}: finishing the recording")
            if not self.bag.failed.is_set():
                self._drain(executor)
        except Exception as exception:  # a bug, not a condition the recorder knows
            error = exception
            self.get_logger().error(
                "recording stopped by an unexpected error:\n" + traceback.format_exc().rstrip()
            )
        finally:
            for subscriptions in self._recording.values():
                for subscription in subscriptions:
                    self.destroy_subscription(subscription)
            self.bag.close()
            executor.remove_node(self)
        return self._report(error)

    def _drain(self, executor) -> None:
        """Take what DDS already holds, until nothing arrives for DRAIN_QUIET_S (and
        a parameter request in flight is answered)."""
        start = last_change = time.monotonic()
        last_count = self._received
        while time.monotonic() - start < DRAIN_MAX_S and (
            time.monotonic() - last_change < DRAIN_QUIET_S or self._fetch.in_flight
        ):
            executor.spin_once(timeout_sec=0.02)
            if self._received != last_count:
                last_count, last_change = self._received, time.monotonic()

    def _report(self, error: Exception | None = None) -> int:
        """Log what was recorded; 1 if the recording failed (`error` or a write error)."""
        logger = self.get_logger()
        if self._parameter_node and self.bag.parameters is None:
            logger.warning(
                f"parameter node '{self._parameter_node}' never answered: no "
                f"'{PARAMETERS_METADATA}' metadata in the bag"
            )
        writer = self.bag.writer
        counts = writer.topic_counts
        files = ", ".join(path.name for path in writer.files)
        where = f"{len(writer.files)} file(s) in '{writer.path.resolve()}': {files}"
        if self.bag.error is not None:
            logger.error(f"recording failed: {self.bag.error}")
            logger.error(
                f"{sum(counts.values())} messages were written to {where}; those in "
                "chunks completed before the failure are readable"
            )
        elif error is not None:
            logger.error(
                f"recording failed: {error!r}; {sum(counts.values())} messages "
                f"received before it are in {where}"
            )
        else:
            logger.info(f"{sum(counts.values())} messages in {where}")
        for topic, count in sorted(counts.items()):
            logger.info(f"  {topic}: {count} messages")
        if self.bag.change_count:
            logger.info(
                f"  {self.bag.change_count} parameter change(s) of '{self._parameter_node}' "
                f"(metadata '{PARAMETER_CHANGES_METADATA}')"
            )
        for topic, count in sorted(self.bag.dropped.items()):
            logger.warning(
                f"  {topic}: {count} messages dropped (the disk was too slow; "
                f"counts in metadata '{DROPPED_METADATA}')"
            )
        return 1 if self.bag.error is not None or error is not None else 0

    # -- topics -----------------------------------------------------------------------------

    def _resolve(self, topic: str) -> str:
        try:
            return self.resolve_topic_name(topic)
        except Exception as error:  # rclpy raises several kinds for a bad name
            raise ConfigError(f"topics: {topic!r} is not a valid topic name ({error})") from None

    def _poll(self) -> None:
        self._subscribe_new_topics()
        if self._parameter_node:
            self._poll_parameters()

    def _subscribe_commands(self) -> None:
        """Subscribe to the simulator's command topics to be recorded now, not once a
        publisher appears, and twice each, transient local and volatile, as the
        simulator does (`topics.COMMAND_QOS`): a command sent by a short-lived publisher
        then reaches the bag whichever way discovery goes. The bag's channel is made
        when the graph shows a publisher, or with the first message (`_announce`)."""
        quiet = SubscriptionEventCallbacks(use_default_callbacks=False)  # as the simulator's
        for name in (*COMMAND_TOPICS, HUB_WRENCH_CMD):
            topic = self._resolve(name)
            if not (topic in self._wanted or self.config["all_topics"]):
                continue
            kind = self._commands[topic] = TOPICS[name]
            self._recording[topic] = [
                self.create_subscription(
                    kind.message_type,
                    topic,
                    functools.partial(self._on_message, topic),
                    qos.subscription_for([offer], self.config["qos_depth"]),
                    event_callbacks=quiet,
                    raw=True,
                )
                for offer in (LATCHED_COMMAND_QOS, kind.qos)
            ]
            self.get_logger().info(
                f"recording {topic} ({kind.type_name}, reliable, transient_local and volatile)"
            )

    def _subscribe_new_topics(self) -> None:
        for topic, _ in self.get_topic_names_and_types():
            if topic in self._commands:  # subscribed at start: its channel, or a warning,
                count = self.count_publishers(topic)  # once its publishers change
                if count != self._publishers_seen.get(topic):
                    self._publishers_seen[topic] = count
                    self._announce(topic, at_message=False)
                continue
            if topic in self._recording or topic in self._ignored:
                continue
            if not (topic in self._wanted or (self.config["all_topics"] and not is_hidden(topic))):
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if publishers:
                self._subscribe(topic, publishers)

    def _subscribe(self, topic: str, publishers) -> None:
        logger = self.get_logger()
        type_names = sorted({p.topic_type for p in publishers})
        if len(type_names) > 1:
            logger.warning(
                f"not recording {topic}: publishers disagree on its type ({', '.join(type_names)})"
            )
            self._ignored.add(topic)
            return
        type_name = type_names[0]
        try:
            msg_class = message_class(type_name)
        except (ImportError, ValueError) as error:
            logger.warning(f"not recording {topic}: type {type_name} is not installed ({error})")
            self._ignored.add(topic)
            return
        try:  # a channel without its definition is one no reader can decode
            message_definition(type_name)
        except (DefinitionNotFoundError, ValueError) as error:
            logger.error(f"not recording {topic}: no message definition of {type_name} ({error})")
            self._ignored.add(topic)
            return
        offered = [p.qos_profile for p in publishers]
        if len({(p.reliability, p.durability) for p in offered}) > 1:
            logger.warning(
                f"{topic}: publishers offer different reliability/durability; "
                "subscribing with what all of them serve"
            )
        self._add_to_bag(topic, type_name, publishers)
        request = qos.subscription_for(offered, self.config["qos_depth"])
        self._recording[topic] = [
            self.create_subscription(
                msg_class, topic, functools.partial(self._on_message, topic), request, raw=True
            )
        ]
        logger.info(
            f"recording {topic} ({type_name}, {request.reliability.name.lower()}, "
            f"{request.durability.name.lower()})"
        )

    def _add_to_bag(self, topic: str, type_name: str, publishers) -> None:
        """Give the bag a channel of `topic`, with the QoS its `publishers` offer."""
        type_hash = str(publishers[0].topic_type_hash)
        self.bag.add_topic(
            topic,
            type_name,
            [qos.entry_of(p.qos_profile) for p in publishers],
            type_hash if type_hash.startswith("RIHS01_") else None,
        )
        self._announced.add(topic)

    def _announce(self, topic: str, at_message: bool) -> None:
        """The channel of a command topic subscribed at start (`_subscribe_commands`),
        with its publishers' QoS once the graph shows them; if its first message came
        from a publisher already gone (`at_message`), with the QoS `sail-ros send`
        offers. A publisher of another type is named once: it is not recorded."""
        type_name = self._commands[topic].type_name
        found = self.get_publishers_info_by_topic(topic)
        publishers = [p for p in found if p.topic_type == type_name]
        others = sorted({p.topic_type for p in found} - {type_name})
        if others and topic not in self._foreign:
            self._foreign.add(topic)
            self.get_logger().warning(
                f"not recording {topic} from publishers of {', '.join(others)}: the "
                f"simulator's command is {type_name}"
            )
        if topic in self._announced:
            return
        if publishers:
            self._add_to_bag(topic, type_name, publishers)
        elif at_message:
            entries = [qos.recorded_entry(LATCHED_COMMAND_QOS)]
            self.bag.add_topic(topic, type_name, entries, None)  # the installed type's hash
            self._announced.add(topic)
            self.get_logger().info(
                f"{topic}: its first publisher left before the graph showed it; its QoS is "
                "taken as sail-ros send's (reliable, transient_local)"
            )

    def _on_message(self, topic: str, data: bytes, info: dict) -> None:
        """One message of `topic` from the executor, then whatever else already waits on
        any subscription (at most `TAKE_BATCH` each): the executor's wake-up and wait set
        are paid once per batch, not per message, and a recorder that fell behind
        catches up instead of letting DDS overwrite what it has not taken."""
        self._record(topic, data, info)
        for name, subscriptions in self._recording.items():
            for subscription in subscriptions:
                for taken in take_waiting(subscription, TAKE_BATCH):
                    self._record(name, *taken)

    def _record(self, topic: str, data: bytes, info: dict) -> None:
        if topic in self._commands:
            if self._repeats.seen(topic, info):
                return  # a command both its subscriptions took
            if topic not in self._announced:
                self._announce(topic, at_message=True)
        log_time = info.get("received_timestamp") or time.time_ns()
        publish_time = info.get("source_timestamp") or log_time
        sequence = (info.get("publication_sequence_number") or 0) & 0xFFFFFFFF
        if not self.bag.write(topic, data, log_time, publish_time, sequence):
            self.get_logger().warning(
                f"the disk is slower than the traffic: dropping messages of {topic} "
                f"({sum(self.bag.dropped.values())} so far; queue_messages = "
                f"{self.config['queue_messages']})",
                throttle_duration_sec=5.0,
            )
        self._received += 1

    # -- simulator parameters ---------------------------------------------------------------

    def _on_parameter_event(self, node: str, event: ParameterEvent, info) -> None:
        if event.node == node:
            log_time = info.get("received_timestamp") or time.time_ns()
            self.bag.parameter_event(parameter_update(event, log_time))

    def _poll_parameters(self) -> None:
        """Fetch the node's values once it appears (again, after it was gone: a node that
        starts anew may have missed telling its declarations to this one); its events
        carry every later change."""
        ready = self._list_client.service_is_ready() and self._get_client.service_is_ready()
        action = self._fetch.poll(ready)
        if action == WARN_ABSENT:
            self.get_logger().warning(
                f"parameter node '{self._parameter_node}' not "
                "found yet; its parameters are stored once it appears"
            )
        if action == ASK_AGAIN:
            self.get_logger().warning(
                f"'{self._parameter_node}' did not answer a parameter "
                f"request within {SERVICE_TIMEOUT_S} s; asking again"
            )
        if action not in (ASK, ASK_AGAIN):
            return
        future = self._list_client.call_async(ListParameters.Request(depth=0))  # 0: all
        future.add_done_callback(self._on_parameter_names)

    def _on_parameter_names(self, future) -> None:
        names = list(future.result().result.names)
        request = GetParameters.Request(names=names)
        self._get_client.call_async(request).add_done_callback(
            functools.partial(self._on_parameter_values, names)
        )

    def _on_parameter_values(self, names: list[str], future) -> None:
        fetches = self._fetch.answered()
        values = yaml_texts(names, future.result().values)
        self.bag.parameters_fetched(values, time.time_ns())
        if fetches == 1:
            self.get_logger().info(f"stored {len(values)} parameters of '{self._parameter_node}'")
        else:
            self.get_logger().info(
                f"stored {len(values)} parameters of '{self._parameter_node}' again: it "
                "appeared anew (a restart: its sail may differ)"
            )


def main(argv=None) -> int:
    """`sail-ros recorder [options] [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = make_parser(NODE_NAME, __doc__.split("\n\n")[0], SPECS, docstring_examples(__doc__))
    return run_node(NODE_NAME, parser, argv, _record)


def _record(namespace, stop) -> int:
    try:
        recorder = Recorder(overrides(namespace, SPECS))
    except BagWriteError as error:
        get_logger(NODE_NAME).error(f"cannot start recording: {error}")
        # an output folder already holding files is a bad argument; the rest, the machine
        return 2 if isinstance(error.error, FileExistsError) else 1
    try:
        return recorder.run(stop)
    finally:
        with bounded_teardown():
            recorder.destroy_node()


if __name__ == "__main__":
    sys.exit(main())
