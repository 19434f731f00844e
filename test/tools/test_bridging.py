"""The bridge's client book and command checks, without a node or a server."""

import pytest

from sail_ros import topics
from sail_ros.bridging.clients import ClientBook, command_refusal
from sail_ros.bridging.protocol import service_definitions
from sail_ros.messages import status as key

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
