"""The Foxglove WebSocket protocol as the bridge speaks it (foxglove-sdk): channels and
services in CDR with `ros2msg` schemas (the recorder's), foxglove-sdk's own log routed
to a ROS logger, and its server callbacks handed on by client and channel id."""

from __future__ import annotations

import logging
import re

from foxglove import MessageSchema, Schema, ServiceSchema

from sail_ros.bag.definitions import PRIMITIVE_TYPES, find_interface_file, full_type_name

MESSAGE_ENCODING = "cdr"
SCHEMA_ENCODING = "ros2msg"
# foxglove-sdk's report of a client whose queue is full (its log, target send_lossy)
_OUTBOX_FULL = re.compile(r"outbox for client (\S+) full")
_SDK_LOGGERS = ("foxglove", "foxglove_py")


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


class ServerLog(logging.Handler):
    """foxglove-sdk's own log lines (its server, in Rust, logs through Python's logging)
    into a ROS logger; its reports of a client's full queue to `on_slow_client(address)`.
    `attach` before the server starts (the SDK reads the levels once), `detach` after."""

    def __init__(self, logger, on_slow_client):
        super().__init__(logging.INFO)
        self._logger = logger
        self._on_slow_client = on_slow_client

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
        elif record.levelno >= logging.ERROR:
            self._logger.error(f"foxglove server: {text}")
        elif record.levelno >= logging.WARNING:
            self._logger.warning(f"foxglove server: {text}")
        else:
            self._logger.info(f"foxglove server: {text}")


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
