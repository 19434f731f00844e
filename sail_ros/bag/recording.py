"""`Recording`: a `BagWriter` run by a thread of its own, and a node's parameters in it.

A recorder's other threads only enqueue: topics, messages, the answer of a
parameter fetch, parameter events. The writer thread handles them in order and
is the one owner of the files and of what is stored in them:

- a message: a split is decided and done in the call that writes the message
  that is due, as rosbag2's SequentialWriter::write does (should_split_bagfile,
  then split_bagfile); a file ends only once it holds the parameters (unless
  none are expected, or `parameters_wait_s` passed without them since the first
  message), and each new
  file starts with the values of that moment;
- the parameters: each fetch (the first, and one after the node appeared again:
  a restarted node, whose read-only values may differ) is stored at once (metadata
  record `parameters_record`, name -> value as one line of YAML); every later event
  or fetch updates the values, and each change is stored where it happened as a
  `changes_record` (`changes_record_of`: the node, its times, and name, old and
  new value of each parameter it changed);
- drops: a message that finds the queue full is dropped and counted per topic
  by the thread that submitted it; the counts reach the writer with `close`.

Writing (compression, fsync) then never delays taking messages from DDS, and
memory stays bounded: at most `max_messages` wait.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
import time
from collections.abc import Callable, Mapping
from typing import NamedTuple

import yaml

from sail_ros.bag.writer import BagWriter


class ParameterChange(NamedTuple):
    """One parameter's change; values as one line of YAML, None where it had none
    (declared now) or has none (deleted)."""

    name: str
    old: str | None
    new: str | None


@dataclasses.dataclass(frozen=True)
class ParameterUpdate:
    """A node's parameter event in plain values (YAML text per parameter).

    Attributes:
        time_ns: the event's stamp: the node's clock when it changed [ns].
        log_time_ns: when the recorder received it [ns since the Unix epoch].
        declared, changed: name -> value; deleted: names.
    """

    time_ns: int
    log_time_ns: int
    declared: Mapping[str, str] = dataclasses.field(default_factory=dict)
    changed: Mapping[str, str] = dataclasses.field(default_factory=dict)
    deleted: tuple[str, ...] = ()


class ParameterValues:
    """A node's parameter values as a log tells them: the first fetched snapshot,
    then every event (and any later snapshot) on top; each step returns what changed.

    Events that come before the first snapshot are applied to it when it comes,
    without counting as changes: the snapshot is the start, and an event may reach
    the recorder before or after a fetch that already holds its value.
    """

    def __init__(self):
        self.values: dict[str, str] | None = None
        self._early: list[ParameterUpdate] = []

    def snapshot(self, values: Mapping[str, str]) -> list[ParameterChange]:
        if self.values is None:
            self.values = dict(values)
            for update in self._early:
                self._apply(update)
            self._early.clear()
            return []
        changes = [
            ParameterChange(name, self.values.get(name), values.get(name))
            for name in sorted(set(self.values) | set(values))
            if self.values.get(name) != values.get(name)
        ]
        self.values = dict(values)
        return changes

    def apply(self, update: ParameterUpdate) -> list[ParameterChange]:
        if self.values is None:
            self._early.append(update)
            return []
        return self._apply(update)

    def _apply(self, update: ParameterUpdate) -> list[ParameterChange]:
        changes = []
        for name, value in (*update.declared.items(), *update.changed.items()):
            if self.values.get(name) != value:
                changes.append(ParameterChange(name, self.values.get(name), value))
                self.values[name] = value
        for name in update.deleted:
            if name in self.values:
                changes.append(ParameterChange(name, self.values.pop(name), None))
        return changes


def changes_record_of(
    node: str, time_ns: int, log_time_ns: int, changes: list[ParameterChange]
) -> dict[str, str]:
    """The metadata record of one event's changes: `node`, `time_ns` (the node's
    clock), `log_time_ns` (received), and `changes`, a YAML list of
    {name, old, new} (values as YAML text; null where there is none)."""
    listed = [{"name": c.name, "old": c.old, "new": c.new} for c in changes]
    return {
        "node": node,
        "time_ns": str(time_ns),
        "log_time_ns": str(log_time_ns),
        "changes": yaml.safe_dump(
            listed, default_flow_style=True, sort_keys=False, width=1 << 30
        ).strip(),
    }


def parse_changes_record(record: Mapping[str, str]) -> tuple[str, int, int, list[ParameterChange]]:
    """(node, time_ns, log_time_ns, changes) of a `changes_record_of` record.

    Raises:
        ValueError: the record is not one (names the entry).
    """
    try:
        listed = yaml.safe_load(record["changes"])
        changes = [ParameterChange(c["name"], c["old"], c["new"]) for c in listed]
        return record["node"], int(record["time_ns"]), int(record["log_time_ns"]), changes
    except (KeyError, TypeError, ValueError, yaml.YAMLError) as error:
        raise ValueError(f"not a parameter changes record ({error!r}): {dict(record)!r}") from None


class Recording:
    """Owns `writer` in a thread of its own; every public method but `close` only
    enqueues (and `write` is for one thread, which owns `dropped`).

    Args:
        writer: the bag.
        max_messages: messages that may wait; a message beyond is dropped and counted.
        parameter_node: the node whose parameters are stored (its full name); None: none.
        parameters_record, changes_record, dropped_record: metadata record names
            of the values, of each event's changes, and of the drop counts.
        parameters_wait_s: how long after the first message a file that is due to end
            waits for the first parameters [s] (counted from the first message, not the
            start: a recorder started long before the node and its publishers still
            waits for them).
        clock: monotonic time [s] (injected by tests).
    """

    _STOP = object()

    def __init__(
        self,
        writer: BagWriter,
        *,
        max_messages: int,
        parameter_node: str | None,
        parameters_record: str,
        changes_record: str,
        dropped_record: str,
        parameters_wait_s: float = 5.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.writer = writer
        self.failed = threading.Event()
        self.error: Exception | None = None  # a BagWriteError unless something is broken
        self.dropped: dict[str, int] = {}  # the submitting thread's
        self._queue: queue.Queue = queue.Queue(maxsize=max_messages)
        self._node = parameter_node
        self._parameters_record = parameters_record
        self._changes_record = changes_record
        self._dropped_record = dropped_record
        self._wait_s = parameters_wait_s
        self._clock = clock
        # the writer thread's alone (read by others only after `close`)
        self._first_message: float | None = None  # clock() at the first message
        self._parameters = ParameterValues()
        self._file_has_parameters = False
        self.change_count = 0
        self._thread = threading.Thread(target=self._run, name="bag_writer", daemon=True)
        self._thread.start()

    @property
    def parameters(self) -> dict[str, str] | None:
        """The last values (None if never fetched); read it after `close`."""
        return self._parameters.values

    # -- from other threads: enqueue only ---------------------------------------------------

    def add_topic(self, *args) -> None:
        """`BagWriter.add_topic(*args)`, in turn."""
        self._put((self.writer.add_topic, args))

    def write(
        self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int, sequence: int
    ) -> bool:
        """Queue a message; False (and counted in `dropped`) if the queue is full."""
        try:
            self._queue.put_nowait(
                (self._write, (topic, data, log_time_ns, publish_time_ns, sequence))
            )
        except queue.Full:
            self.dropped[topic] = self.dropped.get(topic, 0) + 1
            return False
        return True

    def parameters_fetched(self, values: Mapping[str, str], log_time_ns: int) -> None:
        """The answer of a fetch of all the node's parameters (name -> YAML text)."""
        self._put((self._on_parameters, (dict(values), log_time_ns)))

    def parameter_event(self, update: ParameterUpdate) -> None:
        """An event of the node's parameters."""
        self._put((self._on_update, (update,)))

    def close(self) -> None:
        """Write what was queued and the drop counts, finish the files, end the thread."""
        if self.dropped:
            self._put((self._store_dropped, (dict(self.dropped),)))
        self._put(self._STOP)
        self._thread.join()

    def _put(self, item) -> None:
        """Queue `item`, waiting for a place while the writer works; a writer that
        failed takes nothing more, so then `item` is let go."""
        while not self.failed.is_set():
            try:
                self._queue.put(item, timeout=0.1)
                return
            except queue.Full:
                pass

    # -- the writer thread ------------------------------------------------------------------

    def _run(self) -> None:
        writer = self.writer
        try:
            while True:
                try:
                    item = self._queue.get(timeout=writer.seconds_to_next_tick())
                except queue.Empty:
                    item = None
                if item is self._STOP:
                    break
                if item is not None:
                    method, args = item
                    method(*args)
                writer.tick()
        except Exception as error:  # any failure must stop the recording loudly, not silently
            self.error = error
            self.failed.set()
        try:
            writer.close()
        except Exception as error:
            self.error = self.error or error
            self.failed.set()

    def _write(self, topic, data, log_time_ns, publish_time_ns, sequence) -> None:
        writer = self.writer
        if self._first_message is None:
            self._first_message = self._clock()
        if writer.split_due(log_time_ns) and self._file_may_end():
            writer.split()
            self._file_has_parameters = False
            if self._parameters.values is not None:
                self._store_parameters()
        writer.write(topic, data, log_time_ns, publish_time_ns, sequence, split=False)

    def _file_may_end(self) -> bool:
        return (
            self._node is None
            or self._file_has_parameters
            or self._clock() - self._first_message > self._wait_s
        )

    def _on_parameters(self, values: dict[str, str], log_time_ns: int) -> None:
        changes = self._parameters.snapshot(values)
        self._store_changes(log_time_ns, log_time_ns, changes)
        # every fetch, the first and one after the node appeared again, is a record of all
        # the values: a node started anew may have other read-only ones (the sail's)
        self._store_parameters()

    def _on_update(self, update: ParameterUpdate) -> None:
        changes = self._parameters.apply(update)
        self._store_changes(update.time_ns, update.log_time_ns, changes)

    def _store_parameters(self) -> None:
        self.writer.add_metadata(self._parameters_record, self._parameters.values)
        self._file_has_parameters = True

    def _store_changes(self, time_ns: int, log_time_ns: int, changes) -> None:
        if changes:
            record = changes_record_of(self._node, time_ns, log_time_ns, changes)
            self.writer.add_metadata(self._changes_record, record)
            self.change_count += len(changes)

    def _store_dropped(self, dropped: dict[str, int]) -> None:
        counts = {topic: str(count) for topic, count in sorted(dropped.items())}
        self.writer.add_metadata(self._dropped_record, counts)
