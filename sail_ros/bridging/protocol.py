"""The Foxglove WebSocket protocol as the bridge speaks it (foxglove-sdk): channels and
services in CDR with `ros2msg` schemas (the recorder's), foxglove-sdk's own log routed
to a ROS logger, and its server callbacks handed on by client and channel id."""

from __future__ import annotations

import logging
import math
import re
import threading
import time

from foxglove import MessageSchema, Schema, ServiceSchema

from sail_ros import status as key
from sail_ros.bag.definitions import PRIMITIVE_TYPES, find_interface_file, full_type_name

MESSAGE_ENCODING = "cdr"
SCHEMA_ENCODING = "ros2msg"
# foxglove-sdk's report of a client whose queue is full (its log, target send_lossy)
_OUTBOX_FULL = re.compile(r"outbox for client (\S+) full")
_SDK_LOGGERS = ("foxglove", "foxglove_py")
# its lines as a client connects (after the handshake) and leaves
_CLIENT_JOINED = re.compile(r"^(Registered|Unregistered) client (\S+)$")
SERVER_LINES = 3  # the server's warnings and errors logged one by one per interval
SERVER_LOG_INTERVAL_S = 5.0  # ... beyond them, one line of counts per interval


def service_definitions(type_name: str) -> tuple[str, str]:
    """The request and response schema texts of the service `pkg/srv/Type`, as
    `<Type>_Request` and `<Type>_Response` messages: its `.srv` file split at `---`.

    Raises:
        DefinitionNotFoundError: the service is not installed.
        ValueError: a field is itself a message (not needed by the services served,
            whose fields are all primitive).
    """
    text = find_interface_file(full_type_name(type_name), ".srv").read_text()
    request, response = re.split(r"^---[ \t]*$\n?", text, maxsplit=1, flags=re.MULTILINE)
    for part in (request, response):
        for line in part.splitlines():
            field_type = line.split("#", 1)[0].split()[:1]
            base = re.sub(r"(<=\d+)?(\[.*\])?$", "", field_type[0]) if field_type else ""
            if base and base not in PRIMITIVE_TYPES:
                raise ValueError(f"{type_name}: field type {base} is not primitive")
    return request, response


def service_schema(type_name: str) -> ServiceSchema:
    """The protocol's schema of service `pkg/srv/Type`: request and response in CDR."""
    request, response = service_definitions(type_name)

    def schema(suffix: str, text: str) -> MessageSchema:
        return MessageSchema(
            encoding=MESSAGE_ENCODING,
            schema=Schema(name=type_name + suffix, encoding=SCHEMA_ENCODING, data=text.encode()),
        )

    return ServiceSchema(
        type_name, request=schema("_Request", request), response=schema("_Response", response)
    )


def full_type_or_none(type_name: str) -> str | None:
    """`pkg/msg/Type` of a client's schema name (`pkg/Type` too), or None."""
    try:
        return full_type_name(type_name)
    except ValueError:
        return None


class LineThrottle:
    """Log lines without flooding, from any thread: in each `SERVER_LOG_INTERVAL_S`, the
    first `SERVER_LINES` one by one, the rest as one line of counts by severity when the
    interval ends (`roll`, or the next line), naming the last one held back and the
    status key `counted` that counts them all.

    Args:
        logger: a ROS logger.
        prefix: put before every line ("foxglove server: ").
        counted: the /diagnostics key that counts what the lines report.
        clock: monotonic time [s] (injected by tests).
    """

    def __init__(self, logger, prefix: str, counted: str, clock=time.monotonic):
        self._logger, self._prefix, self._counted, self._clock = logger, prefix, counted, clock
        self._lock = threading.Lock()
        self._shown = 0  # lines logged one by one in this interval
        self._held: dict[str, int] = {}  # severity -> lines held back in this interval
        self._last_held = ""
        self._window_end = -math.inf

    def line(self, severity: str, text: str) -> None:
        """`text` at `severity` ("warning" or "error"), or held back and counted."""
        with self._lock:
            summary = self._roll(self._clock())
            shown = self._shown < SERVER_LINES
            if shown:
                self._shown += 1
            else:
                self._held[severity] = self._held.get(severity, 0) + 1
                self._last_held = text
        if summary:
            self._logger.warning(summary)
        if shown and severity == "error":
            self._logger.error(self._prefix + text)
        elif shown:
            self._logger.warning(self._prefix + text)

    def roll(self, end: bool = False) -> None:
        """At the end of an interval (or of the program, `end`): one line with the lines
        held back, if any."""
        with self._lock:
            summary = self._roll(math.inf if end else self._clock())
        if summary:
            self._logger.warning(summary)

    def _roll(self, now: float) -> str:
        """The summary of the interval if it ended (a new one starts), else "" (lock held)."""
        if now < self._window_end:
            return ""
        summary = ""
        if self._held:
            counts = ", ".join(f"{count} {severity}" for severity, count in self._held.items())
            summary = (
                f"{self._prefix}{counts} line(s) not logged one by one in the last "
                f"{SERVER_LOG_INTERVAL_S:g} s (the last: {self._last_held}); /diagnostics "
                f"counts them ({self._counted})"
            )
        self._shown, self._held = 0, {}
        self._window_end = now + SERVER_LOG_INTERVAL_S
        return summary


class ServerLog(logging.Handler):
    """foxglove-sdk's own log lines (its server, in Rust, logs through Python's logging)
    into a ROS logger; its reports of a client's full queue to `on_slow_client(address)`,
    of a client connected or gone to `on_client(address, connected)`. `attach` before the
    server starts (the SDK reads the levels once), `detach` after.

    The server logs a line for every bad frame a client sends (and for every message it
    failed to send to one that went away): its warnings and errors go through a
    `LineThrottle` (`roll` ends its intervals), and `problems` counts them all.
    """

    def __init__(self, logger, on_slow_client, on_client=None, clock=time.monotonic):
        super().__init__(logging.INFO)
        self._logger = logger
        self._on_slow_client = on_slow_client
        self._on_client = on_client or (lambda address, connected: None)
        self._lines = LineThrottle(logger, "foxglove server: ", key.SERVER_PROBLEMS, clock)
        self._count = threading.Lock()  # the server's threads log at once
        self.problems = 0  # warnings and errors the server logged

    def attach(self) -> ServerLog:
        for name in _SDK_LOGGERS:
            sdk_logger = logging.getLogger(name)
            sdk_logger.setLevel(logging.INFO)
            sdk_logger.propagate = False
            sdk_logger.addHandler(self)
        return self

    def detach(self) -> None:
        for name in _SDK_LOGGERS:
            logging.getLogger(name).removeHandler(self)

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        slow = _OUTBOX_FULL.search(text)
        if slow:
            self._on_slow_client(slow.group(1))
        elif record.levelno >= logging.WARNING:
            with self._count:
                self.problems += 1
            self._lines.line("error" if record.levelno >= logging.ERROR else "warning", text)
        else:
            self._logger.info(f"foxglove server: {text}")
            joined = _CLIENT_JOINED.search(text)
            if joined:
                self._on_client(joined.group(2), joined.group(1) == "Registered")

    def roll(self, end: bool = False) -> None:
        """`LineThrottle.roll` of the server's lines."""
        self._lines.roll(end)


class Listener:
    """foxglove-sdk's server callbacks (`foxglove.websocket.ServerListener`), handed on to
    `target` by client id and channel id (or the client's channel itself)."""

    def __init__(self, target):
        self._target = target

    def on_subscribe(self, client, channel) -> None:
        self._target.on_subscribe(client.id, channel.id)

    def on_unsubscribe(self, client, channel) -> None:
        self._target.on_unsubscribe(client.id, channel.id)

    def on_client_advertise(self, client, channel) -> None:
        self._target.on_client_advertise(client.id, channel)

    def on_client_unadvertise(self, client, client_channel_id: int) -> None:
        self._target.on_client_unadvertise(client.id, client_channel_id)

    def on_message_data(self, client, client_channel_id: int, data: bytes) -> None:
        self._target.on_message_data(client.id, client_channel_id, data)
