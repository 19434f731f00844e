"""Which arriving commands the simulator acts on: each once, none from before it started.

The simulator listens on each command topic twice (transient local and
volatile, see `topics.COMMAND_QOS`), so a command from a transient-local
publisher may arrive on both subscriptions; and a transient-local publisher
that outlives a simulator hands its last commands to the next one. Both are
told apart by what DDS says of each sample: the publisher's source timestamp
and sequence number.
"""

from __future__ import annotations

import collections

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
