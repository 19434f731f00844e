"""Which arriving commands the simulator acts on, the bounded queue they wait in, and
the rule that lets a burst of motion commands cost one plan.

The simulator listens on each command topic twice (transient local and
volatile, see `topics.COMMAND_QOS`), so a command from a transient-local
publisher may arrive on both subscriptions; and a transient-local publisher
that outlives a simulator hands its last commands to the next one. Both are
told apart by what DDS says of each sample: the publisher's source timestamp
and sequence number (`CommandIntake`).

Commands are taken from DDS on their own thread and wait in a bounded
`CommandQueue` for the simulator's thread; a burst that fills it waits for a
tick to take it (`nodes.sim`), and a command that still finds it full is
rejected. The simulator's thread takes everything waiting as one batch
(`split_batch`): a motion command that a newer motion command of the same batch
replaces (a deploy replaces every boom's motion, a trajectory its booms') never
starts, so it is answered "superseded" without being planned, and only the
newest are planned (newest first; if one is rejected, the next older one has its
turn, which is what acting on them one by one would leave). Bytes that are no
message of the topic's type (`Undecodable`) wait and are answered rejected like
any other command. Every command ends
accepted, superseded, rejected or ignored (published before the simulator
started), each answered and counted.
"""

from __future__ import annotations

import collections
import threading
from typing import NamedTuple

from sail_ros.names import BOOM_JOINTS, BOOM_LENGTH_CMD, DEPLOY_CMD

DUPLICATE, STALE = "duplicate", "stale"


class Pending(NamedTuple):
    """A command waiting for the simulator: its topic (as subscribed), the message, and
    DDS's sample info (`source_timestamp`, `publication_sequence_number`)."""

    topic: str
    message: object
    info: dict


class Undecodable(NamedTuple):
    """A command's bytes that are no message of its topic's type (the node's CDR reader
    said why): it waits and is answered rejected like any command, and counted."""

    size: int  # bytes
    type_name: str  # the topic's type, pkg/msg/Type
    reason: str

    def __str__(self) -> str:
        return f"{self.size} bytes are not a {self.type_name} in CDR ({self.reason})"


class Repeats:
    """Recognises a sample already taken: one that a transient-local and a volatile
    subscription of the same topic both receive (`topics.COMMAND_QOS`), told by what
    DDS says of it, its source timestamp and the publisher's sequence number.

    Args:
        memory: how many recent samples are remembered (a repeat arrives within the
            same burst).
    """

    def __init__(self, memory: int = 256):
        self._seen: collections.OrderedDict[tuple, None] = collections.OrderedDict()
        self._memory = memory
        self._lock = threading.Lock()

    def seen(self, topic: str, info: dict) -> bool:
        """Whether this sample of `topic` (rclpy's message info) was taken before; a
        sample without a source timestamp never counts as seen. Thread-safe."""
        source = int(info.get("source_timestamp") or 0)
        if not source:
            return False
        key = (topic, source, int(info.get("publication_sequence_number") or 0))
        with self._lock:
            if key in self._seen:
                return True
            self._seen[key] = None
            if len(self._seen) > self._memory:
                self._seen.popitem(last=False)
        return False


class CommandIntake:
    """Decides, per arriving command, whether to act on it.

    Args:
        started_ns: when the simulator started [ns since the Unix epoch].
        memory: how many recent commands are remembered to recognise a repeat.
    """

    def __init__(self, started_ns: int, memory: int = 256):
        self.started_ns = int(started_ns)
        self._repeats = Repeats(memory)

    def admit(self, topic: str, info: dict) -> str | None:
        """None to act on the command, else why not: DUPLICATE (it already came on
        the other subscription) or STALE (written before the simulator started).

        Args:
            topic: the command topic.
            info: rclpy's message info of the sample (`source_timestamp`,
                `publication_sequence_number`).
        """
        if self._repeats.seen(topic, info):
            return DUPLICATE
        source = int(info.get("source_timestamp") or 0)
        if source and source < self.started_ns:
            return STALE
        return None


class CommandQueue:
    """Commands waiting for the simulator's thread: at most `capacity`, thread-safe.

    Args:
        capacity: most commands waiting at once; one more is refused (`offer`) and
            counted in `overflowed`.
    """

    def __init__(self, capacity: int):
        self.capacity = int(capacity)
        self.overflowed = 0
        self._items: collections.deque = collections.deque()
        self._lock = threading.Lock()
        self._taken = threading.Condition(self._lock)  # notified when `take` empties it

    def offer(self, item) -> bool:
        """Queue `item`; False (and one more `overflowed`) if the queue is full."""
        with self._lock:
            if len(self._items) >= self.capacity:
                self.overflowed += 1
                return False
            self._items.append(item)
            return True

    def full(self) -> bool:
        """Whether one more would be refused."""
        with self._lock:
            return len(self._items) >= self.capacity

    def wait_for_room(self, timeout: float) -> bool:
        """Wait at most `timeout` [s] until one more would be accepted; whether it would."""
        with self._taken:
            return self._taken.wait_for(lambda: len(self._items) < self.capacity, timeout)

    def take(self) -> list:
        """Everything waiting, oldest first; the queue is empty afterwards."""
        with self._lock:
            items = list(self._items)
            self._items.clear()
            self._taken.notify_all()
            return items


def booms_moved(pending: Pending) -> frozenset[int] | None:
    """The booms (indices, 0 = a) a motion command would move if accepted; None for a
    command that moves none (a load) or whose boom names are not all known and distinct
    (it can replace nothing: it will be rejected)."""
    if pending.topic == DEPLOY_CMD:
        return frozenset(range(4))
    if pending.topic != BOOM_LENGTH_CMD:
        return None
    names = list(getattr(pending.message, "joint_names", []))
    if not names or len(set(names)) != len(names):
        return None
    if not all(name in BOOM_JOINTS for name in names):
        return None
    return frozenset(BOOM_JOINTS.index(name) for name in names)


def split_batch(batch: list[Pending]) -> tuple[list[int], list[int], list[int]]:
    """The indices of a batch's (oldest first) undecodable commands, oldest first; of its
    motion commands, newest first; and of the other commands, oldest first: the order in
    which they are tried."""
    motion_topics = (DEPLOY_CMD, BOOM_LENGTH_CMD)
    unread = [i for i, pending in enumerate(batch) if isinstance(pending.message, Undecodable)]
    read = [i for i in range(len(batch)) if i not in set(unread)]
    motion = [i for i in read if batch[i].topic in motion_topics]
    others = [i for i in read if batch[i].topic not in motion_topics]
    return unread, motion[::-1], others


def covered(batch: list[Pending], index: int, accepted) -> bool:
    """Whether a newer accepted motion command of `batch` (indices `accepted`) moves every
    boom that command `index` would move."""
    booms = booms_moved(batch[index])
    if booms is None:
        return False
    return any(j > index and booms <= booms_moved(batch[j]) for j in accepted)
