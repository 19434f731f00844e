"""The bridge's client book, command checks and server log, without a node or a server."""

import logging

import pytest

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bridging.clients import ClientBook, command_refusal
from sail_ros.bridging.protocol import (
    SERVER_LINES,
    SERVER_LOG_INTERVAL_S,
    ServerLog,
    service_definitions,
)

pytestmark = pytest.mark.model

COMMANDS = {"/sail/deploy_cmd": topics.TOPICS[topics.DEPLOY_CMD]}


def test_a_client_counts_while_it_holds_a_subscription():
    book = ClientBook(channels=7)
    book.url = "ws://127.0.0.1:8765"
    book.subscribe(1, 10)
    book.subscribe(1, 11)
    book.subscribe(2, 10)
    book.unsubscribe(1, 10)
    assert book.status_values()[key.CLIENTS] == "2"
    book.unsubscribe(1, 11)
    values = book.status_values()
    assert values[key.CLIENTS] == "1" and values[key.CHANNELS] == "7"
    assert values[key.BRIDGE_URL] == "ws://127.0.0.1:8765"


def test_counts_refusals_and_slow_clients_reach_the_status():
    book = ClientBook(channels=1)
    book.count(key.SERVED)
    book.count(key.SERVED)
    book.refused("first")
    book.refused("second")
    book.slow("127.0.0.1:5000")
    book.slow("127.0.0.1:5000")
    values = book.status_values()
    assert values[key.SERVED] == "2" and values[key.REFUSED] == "2"
    assert values[key.LAST_REFUSAL] == "second"
    assert values[key.SLOW_REPORTS] == "2" and values[key.SLOW_CLIENTS] == "127.0.0.1:5000"


def test_accepted_channels_map_to_their_topic_until_dropped():
    book = ClientBook(channels=1)
    book.accept_channel(3, 1, "/sail/deploy_cmd")
    assert book.topic_of(3, 1) == "/sail/deploy_cmd" and book.topic_of(3, 2) is None
    book.drop_channel(3, 1)
    assert book.topic_of(3, 1) is None


@pytest.mark.parametrize(
    ("topic", "schema", "encoding", "reason"),
    [
        ("/sail/deploy_cmd", "std_msgs/msg/Float64", "cdr", None),
        ("/sail/deploy_cmd", "std_msgs/Float64", "cdr", None),
        ("/sail/boom_state", "std_msgs/msg/Float64", "cdr", "not a command topic"),
        ("/sail/deploy_cmd", "std_msgs/msg/Float32", "cdr", "schema 'std_msgs/msg/Float32'"),
        ("/sail/deploy_cmd", "std_msgs/msg/Float64", "json", "encoding 'json', expected cdr"),
    ],
)
def test_a_client_publishes_only_a_command_in_cdr_of_its_type(topic, schema, encoding, reason):
    found = command_refusal(topic, schema, encoding, COMMANDS)
    assert (found is None) if reason is None else (reason in found)


def test_service_schemas_split_the_srv_file():
    request, response = service_definitions("std_srvs/srv/SetBool")
    assert "bool data" in request and "bool success" in response and "string message" in response


class Logger:
    """A ROS logger's three levels, kept."""

    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(("info", text))

    def warning(self, text):
        self.lines.append(("warning", text))

    def error(self, text):
        self.lines.append(("error", text))


def test_the_servers_bad_frame_lines_are_a_few_and_a_count():
    """20000 bad frames make the server log 20000 errors: three reach the log one by one,
    the rest one line of counts when the interval ends; every one is counted. Its lines
    as clients connect and leave reach `on_client`."""
    now = [0.0]
    logger, joined = Logger(), []
    server = ServerLog(logger, print, lambda *a: joined.append(a), clock=lambda: now[0])
    record = logging.makeLogRecord
    server.emit(record({"levelno": logging.INFO, "msg": "Registered client 127.0.0.1:5000"}))
    for _ in range(20000):
        server.emit(record({"levelno": logging.ERROR, "msg": "Invalid message from x: bad"}))
    server.emit(record({"levelno": logging.WARNING, "msg": "Failed to parse advertised"}))
    server.emit(record({"levelno": logging.INFO, "msg": "Unregistered client 127.0.0.1:5000"}))
    assert joined == [("127.0.0.1:5000", True), ("127.0.0.1:5000", False)]
    assert server.problems == 20001
    errors = [text for level, text in logger.lines if level == "error"]
    assert errors == ["foxglove server: Invalid message from x: bad"] * SERVER_LINES
    server.roll()  # within the interval: nothing yet
    assert len(logger.lines) == SERVER_LINES + 2
    now[0] += SERVER_LOG_INTERVAL_S
    server.roll()
    assert logger.lines[-1] == ("warning", (
        "foxglove server: 19997 error, 1 warning line(s) not logged one by one in the last "
        "5 s (the last: Failed to parse advertised); /diagnostics counts them (server_problems)"
    ))  # fmt: skip
    server.emit(record({"levelno": logging.ERROR, "msg": "again"}))  # a new interval
    assert logger.lines[-1] == ("error", "foxglove server: again")


def test_connections_beyond_the_limit_are_refused_and_counted():
    book = ClientBook(channels=1)
    assert book.connect("a:1", 2) and book.connect("a:2", 2)
    assert not book.connect("a:3", 2)
    book.disconnect("a:3")  # the refused one's departure changes nothing
    values = book.status_values()
    assert values[key.CONNECTIONS] == "2" and values[key.REFUSED_CONNECTIONS] == "1"
    assert book.take_left() and not book.take_left()
    book.disconnect("a:1")
    assert book.connect("a:4", 2) and book.status_values()[key.CONNECTIONS] == "2"
