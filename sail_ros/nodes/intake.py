"""Which arriving commands the simulator acts on, and the queue they wait in.

The simulator listens on each command topic twice (transient local and
volatile, see `topics.COMMAND_QOS`), so a command from a transient-local
publisher may arrive on both subscriptions; and a transient-local publisher
that outlives a simulator hands its last commands to the next one. Both are
told apart by what DDS says of each sample: the publisher's source timestamp
and sequence number.

Commands are taken from DDS on their own executor thread, so a long tick
cannot make DDS overwrite them, and wait in a bounded `CommandQueue` for the
simulator's thread; one that finds the queue full is dropped and counted.
"""

from __future__ import annotations

import collections
import threading

DUPLICATE, STALE = "duplicate", "stale"


class CommandIntake:
    """Decides, per arriving command, whether to act on it.

    Args:
        started_ns: when the simulator started [ns since the Unix epoch].
        memory: how many recent commands are remembered to recognise a repeat.
    """

    def __init__(self, started_ns: int, memory: int = 256):
        self.started_ns = int(started_ns)
        self._seen: collections.OrderedDict[tuple, None] = collections.OrderedDict()
        self._memory = memory

    def admit(self, topic: str, info: dict) -> str | None:
        """None to act on the command, else why not: DUPLICATE (it already came on
        the other subscription) or STALE (written before the simulator started).

        Args:
            topic: the command topic.
            info: rclpy's message info of the sample (`source_timestamp`,
                `publication_sequence_number`).
        """
        source = int(info.get("source_timestamp") or 0)
        key = (topic, source, int(info.get("publication_sequence_number") or 0))
        if source and key in self._seen:
            return DUPLICATE
        if source:
            self._seen[key] = None
            if len(self._seen) > self._memory:
                self._seen.popitem(last=False)
        if source and source < self.started_ns:
            return STALE
        return None


class CommandQueue:
    """Commands waiting for the simulator's thread: at most `capacity`, thread-safe.

    Args:
        capacity: most commands waiting at once; one more is refused (`offer`)
            and counted in `dropped`.
    """

    def __init__(self, capacity: int):
        self.capacity = int(capacity)
        self.dropped = 0
        self._items: collections.deque = collections.deque()
        self._lock = threading.Lock()

    def offer(self, item) -> bool:
        """Queue `item`; False (and one more `dropped`) if the queue is full."""
        with self._lock:
            if len(self._items) >= self.capacity:
                self.dropped += 1
                return False
            self._items.append(item)
            return True

    def take(self) -> list:
        """Everything waiting, oldest first; the queue is empty afterwards."""
        with self._lock:
            items = list(self._items)
            self._items.clear()
            return items
