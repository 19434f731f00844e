"""When a recorder asks a node for its parameters, as a plain state machine.

The recorder stores the parameters of one node (`parameter_node`) in every file, and
their changes from the node's parameter events. It asks for the values once the node's
parameter services are there; again when the node was gone and is back (a node that
starts anew may have missed telling its declarations); again when an answer is overdue;
and it warns once when the node is still absent a while after the start. `ParameterFetch`
decides that from what it is told, on an injected clock, so it is tested without ROS;
the recorder's executor thread alone calls it, as `bag.recording.Recording` alone owns
the files.
"""

from __future__ import annotations

import time

NOTHING, ASK, ASK_AGAIN, WARN_ABSENT = "nothing", "ask", "ask again", "warn absent"


class ParameterFetch:
    """What to do about the node's parameters at each poll.

    Args:
        warn_after_s: warn that the node is absent this long after the start [s], once,
            unless its values came before.
        timeout_s: an unanswered request is made again after this long [s].
        now: the clock [s] (monotonic).
    """

    def __init__(self, warn_after_s: float, timeout_s: float, now=time.monotonic):
        self._now = now
        self._started = now()
        self._warn_after_s, self._timeout_s = warn_after_s, timeout_s
        self._fetched = False  # the node's values, since it (last) appeared
        self.fetches = 0  # answers stored
        self._request_started: float | None = None
        self._warned_absent = False

    @property
    def in_flight(self) -> bool:
        """A request is waiting for its answer."""
        return self._request_started is not None

    def poll(self, ready: bool) -> str:
        """The action now, given whether the node's parameter services are `ready`:
        ASK (a request is now in flight), ASK_AGAIN (the last one went unanswered),
        WARN_ABSENT (once) or NOTHING."""
        if not ready:  # gone, or not there yet: fetched (again) once it is there
            self._fetched = False
            self._request_started = None
            if (
                not self._warned_absent
                and not self.fetches
                and self._now() - self._started > self._warn_after_s
            ):
                self._warned_absent = True
                return WARN_ABSENT
            return NOTHING
        action = ASK
        if self._request_started is not None:
            if self._now() - self._request_started < self._timeout_s:
                return NOTHING
            action = ASK_AGAIN
        elif self._fetched:
            return NOTHING
        self._request_started = self._now()
        return action

    def answered(self) -> int:
        """The node's values came; returns how many answers so far (1: the first)."""
        self._request_started = None
        self._fetched = True
        self.fetches += 1
        return self.fetches
