"""Node `sail_replay`: republish a recorded bag with its recorded timing.

Plays an MCAP file or bag folder written by `sail_recorder` or by
`ros2 bag record -s mcap`, publishing each message's CDR bytes as recorded
(no deserialisation) at `log time / rate` after the start, with the QoS the
original publishers offered (reliability, durability, depth). By default it
also publishes `/clock` from the recorded log times, and the recorded
`/clock` messages are then not played (`--no-clock` plays them instead).
Needs nothing but the bag and the installed message packages; exits when
done unless `loop`.

    sail-ros replay run1
    sail-ros replay run1/run1_0.mcap --rate 2 --start-offset-s 10 --topics /sail/boom_state
    sail-ros replay run1 --loop --ros-args --params-file config/replay.yaml
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import sys
import threading
import time

from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from sail_ros import topics
from sail_ros.bag import BagReader, DamagedBagError, qos
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
from sail_ros.ros.program import bounded_teardown, message_class, run_node

NODE_NAME = "sail_replay"
ACK_POLL_S = 0.1  # s: how often the wait for acknowledgements looks at a stop
CLOCK_TOPIC = "/clock"


@dataclasses.dataclass(frozen=True)
class ReplaySettings:
    """The replay's parameters (node `sail_replay`)."""

    bag: str = setting(
        "", "", "MCAP file or bag folder to play (also the first positional argument)"
    )
    rate: float = setting(
        1.0, "", "playback speed factor: 2.0 plays twice as fast", minimum=0.001, maximum=1000.0
    )
    start_offset_s: float = setting(
        0.0, "", "start this far into the recording [s of log time]", minimum=0.0
    )
    loop: bool = setting(False, "", "play again from start_offset_s when done, until stopped")
    topics: list = setting([], "", "topics to play; empty: every recorded topic", item_type=str)
    clock: bool = setting(
        True,
        "",
        f"publish {CLOCK_TOPIC} from the recorded log times (and skip the "
        f"recorded {CLOCK_TOPIC}); false: play the recorded {CLOCK_TOPIC} like any topic",
    )
    clock_frequency_hz: float = setting(
        100.0,
        "",
        f"rate of generated {CLOCK_TOPIC} messages [Hz of wall time]",
        minimum=1.0,
        maximum=10000.0,
    )
    qos_depth: int = setting(
        100,
        "",
        "history depth of a publisher whose recorded QoS has none [messages]",
        minimum=1,
        maximum=100000,
    )
    delay_s: float = setting(
        0.0,
        "",
        "wait this long after creating the publishers, before the first message [s]",
        minimum=0.0,
    )
    wait_for_subscribers: int = setting(
        0,
        "",
        "before the first message, wait until every played "
        "topic has at least this many subscribers",
        minimum=0,
    )
    wait_for_all_acked_s: float = setting(
        0.0,
        "",
        "at the end, wait until every reliable subscriber acknowledged every message, "
        "at most this long [s]; 0: as long as it takes (a stop signal ends the wait)",
        minimum=0.0,
    )


SPECS = settings_of(ReplaySettings)


class Replay(Node):
    """The `sail_replay` node; `play` publishes the bag.

    Its arguments are `ros.parameters.node_options`'s.

    Raises:
        ConfigError: a parameter has a value the replay cannot use (no bag,
            nothing to play, an offset past the end).
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        with destroyed_if_refused(self):
            self._set_up()

    def _set_up(self) -> None:
        """The bag, the topics to play and their publishers (raises ConfigError)."""
        self.config = declare(self, SPECS)
        if not self.config["bag"]:
            raise ConfigError("bag: no bag given (a file or folder, e.g. `sail-ros replay run1`)")
        try:
            self.reader = BagReader(self.config["bag"])
        except (FileNotFoundError, ValueError) as error:
            raise ConfigError(f"bag: {error}") from None
        for path in self.reader.incomplete_files:
            self.get_logger().warning(
                f"'{path}' has no summary (recording interrupted): playing it up to its "
                f"last complete chunk (`sail-ros bag recover {self.config['bag']}` writes a "
                "complete copy that every reader opens)"
            )
        recorded = self.reader.topics()
        wanted = self.config["topics"] or list(recorded)
        missing = sorted(set(wanted) - set(recorded))
        if missing:
            self.get_logger().warning(f"not in the bag: {', '.join(missing)}")
        if self.config["clock"]:
            wanted = [topic for topic in wanted if topic != CLOCK_TOPIC]
        self._players = {}
        self._names = self._played_names(recorded)
        for topic in sorted(set(wanted) & set(recorded)):
            info = recorded[topic]
            try:
                msg_class = message_class(info.type_name)
            except (ImportError, ValueError) as error:
                self.get_logger().warning(
                    f"not playing {topic}: type {info.type_name!r} is not installed ({error})"
                )
                continue
            profile = qos.publisher_for(info.offered_qos_profiles, self.config["qos_depth"])
            self._players[topic] = self.create_publisher(msg_class, self._names[topic], profile)
        if not self._players:
            raise ConfigError(
                f"topics: nothing to play from '{self.config['bag']}' (it has: "
                f"{', '.join(sorted(recorded)) or 'no topics'})"
            )
        try:
            self._message_count = self._count_messages(
                sum(recorded[topic].message_count for topic in self._players)
            )
        except DamagedBagError as error:
            raise ConfigError(f"bag: {error}") from None
        self._published = 0  # messages, all passes
        self._clock_publisher = None
        if self.config["clock"]:
            self._clock_publisher = self.create_publisher(Clock, CLOCK_TOPIC, QoSProfile(depth=10))

    def _played_names(self, recorded) -> dict[str, str]:
        """Recorded topic -> the topic it is played on: as recorded, or, when this node
        runs in a namespace, the recorded sail's topics moved into it (/clock and
        /diagnostics stay global)."""
        namespace = self.get_namespace()
        if namespace == "/":
            return {topic: topic for topic in recorded}
        sails = topics.sail_namespaces(recorded)
        if len(sails) != 1:
            raise ConfigError(
                f"bag: to play into namespace {namespace}, the bag must hold one sail; it "
                f"holds {len(sails)} ({', '.join(sails) or 'none'})"
            )
        return {topic: topics.moved(topic, sails[0], namespace) for topic in recorded}

    def _count_messages(self, recorded: int) -> int:
        """The messages each pass plays: those from start_offset_s on (`recorded`: all).

        Raises:
            ConfigError: there are none (no messages, or the offset is past the end).
        """
        offset_s = self.config["start_offset_s"]
        if recorded and not offset_s:
            return recorded
        first = last = None
        count = 0
        for message in self.reader.messages(topics=self._players):  # as `_play_once` does
            if first is None:
                first = last = message.log_time_ns
                start = first + round(offset_s * 1e9)
            last = max(last, message.log_time_ns)
            count += message.log_time_ns >= start
        if first is None:
            raise ConfigError(
                f"bag: '{self.config['bag']}' has no messages on the topics to "
                f"play ({', '.join(self._players)})"
            )
        if not count:
            raise ConfigError(
                f"start_offset_s = {offset_s:g} s is past the end of the bag "
                f"(span {(last - first) / 1e9:.2f} s)"
            )
        return count

    def play(self, stop: threading.Event) -> int:
        """Publish the bag (again and again if `loop`) until done or `stop`; exit code."""
        logger = self.get_logger()
        if not self._wait_for_subscribers(stop):
            return 0
        code = 0
        started = time.monotonic()
        offset_s = self.config["start_offset_s"]
        logger.info(
            f"playing {self._message_count} messages"
            + (f" (from {offset_s:g} s on)" if offset_s else "")
            + f" on {len(self._players)} topic(s) from '{self.config['bag']}' at rate "
            f"{self.config['rate']}" + (", looping" if self.config["loop"] else "")
        )
        while not stop.is_set():
            try:
                count = self._play_once(stop)
            except DamagedBagError as error:  # found where playing reaches it
                logger.error(f"bag: {error}; stopped after {self._published} messages")
                code = 2
                break
            if not count and not stop.is_set():  # would loop without end doing nothing
                logger.error("a pass over the bag played no message; stopping")
                code = 1
                break
            if not self.config["loop"]:
                break
        playing_s = time.monotonic() - started
        self._wait_for_acknowledgements(stop)
        waited_s = time.monotonic() - started - playing_s
        logger.info(
            f"played {self._published} messages in {playing_s:.2f} s"
            + (f", then {waited_s:.2f} s until the subscribers acknowledged them"
               if waited_s >= 0.005 else "")
        )  # fmt: skip
        return code

    def _wait_for_subscribers(self, stop: threading.Event) -> bool:
        """Honour delay_s and wait_for_subscribers; False if stopped meanwhile."""
        needed = self.config["wait_for_subscribers"]
        if needed:
            self.get_logger().info(f"waiting for {needed} subscriber(s) on each topic")
        while needed and not stop.is_set():
            if all(p.get_subscription_count() >= needed for p in self._players.values()):
                break
            stop.wait(0.01)
        return not stop.wait(self.config["delay_s"])

    def _play_once(self, stop: threading.Event) -> int:
        rate = self.config["rate"]
        period = 1.0 / self.config["clock_frequency_hz"]
        messages = self.reader.messages(topics=self._players)
        played = 0
        bag_start = wall_start = next_tick = None
        for message in messages:
            if bag_start is None:
                bag_start = message.log_time_ns + round(self.config["start_offset_s"] * 1e9)
                wall_start = next_tick = time.monotonic()
            if message.log_time_ns < bag_start:
                continue
            due = wall_start + (message.log_time_ns - bag_start) / 1e9 / rate
            while True:  # until due, publishing /clock on its ticks
                now = time.monotonic()
                if self._clock_publisher is not None and next_tick <= min(now, due):
                    bag_time = bag_start + round((next_tick - wall_start) * rate * 1e9)
                    self._publish_clock(bag_time)
                    next_tick = max(next_tick + period, now)  # no burst after a stall
                    continue
                if now >= due:
                    break
                wake = due if self._clock_publisher is None else min(due, next_tick)
                if stop.wait(wake - now):
                    return played
            self._players[message.topic].publish(message.data)
            played += 1
            self._published += 1
        return played

    def _publish_clock(self, time_ns: int) -> None:
        message = Clock()
        message.clock.sec, message.clock.nanosec = divmod(time_ns, 1_000_000_000)
        self._clock_publisher.publish(message)

    def _wait_for_acknowledgements(self, stop: threading.Event) -> None:
        """Keep the publishers until every reliable subscriber acknowledged every message:
        destroying them earlier drops what is still in flight (large messages, a busy
        machine). Ends early on `stop`, or after wait_for_all_acked_s if that is > 0,
        saying which topics were not acknowledged. A subscriber that vanished without
        a word stops counting once DDS drops it (its lease, at most 20 s)."""
        limit = self.config["wait_for_all_acked_s"]
        deadline = time.monotonic() + limit if limit > 0 else math.inf
        pending = dict(self._players)
        while pending and not stop.is_set() and time.monotonic() < deadline:
            slice_s = min(ACK_POLL_S, max(0.0, deadline - time.monotonic()))
            for topic, publisher in list(pending.items()):
                if publisher.wait_for_all_acked(Duration(nanoseconds=round(slice_s * 1e9))):
                    del pending[topic]
        if pending:
            why = "stopped" if stop.is_set() else f"after {limit:g} s"
            self.get_logger().warning(
                f"{why}: not every subscriber acknowledged the messages of "
                f"{', '.join(sorted(pending))}; some may not have arrived"
            )


def main(argv=None) -> int:
    """`sail-ros replay FILE [options] [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = make_parser(NODE_NAME, __doc__.split("\n\n")[0], SPECS, docstring_examples(__doc__))
    parser.add_argument(
        "bag_path", nargs="?", metavar="FILE", help="MCAP file or bag folder (same as --bag)"
    )
    return run_node(NODE_NAME, parser, argv, _replay)


def _replay(namespace, stop) -> int:
    if namespace.bag_path is not None:
        namespace.bag = namespace.bag_path
    replay = Replay(overrides(namespace, SPECS))
    # parameter services keep answering while the main thread plays
    executor = SingleThreadedExecutor(context=replay.context)
    executor.add_node(replay)
    done = threading.Event()
    spinner = threading.Thread(target=_spin, args=(executor, done))
    spinner.start()
    try:
        return replay.play(stop.event)
    finally:
        done.set()
        spinner.join()  # before anything it waits on is destroyed
        executor.shutdown()
        with bounded_teardown():
            replay.destroy_node()


def _spin(executor, done: threading.Event) -> None:
    with contextlib.suppress(ExternalShutdownException):  # the replay is ending anyway
        while not done.is_set():
            executor.spin_once(timeout_sec=0.1)


if __name__ == "__main__":
    sys.exit(main())
