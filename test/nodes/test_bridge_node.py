"""The bridge node in this process: what it serves where, what it refuses to start with,
and what it does with clients that misbehave."""

import asyncio
import json

import pytest
from harness import wait_until
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64
from tornado.httpclient import HTTPRequest
from tornado.websocket import websocket_connect

from sail_ros import status as key
from sail_ros import topics
from sail_ros.nodes.bridge import SERVABLE, Bridge, main
from sail_ros.ros.parameters import ConfigError

pytestmark = pytest.mark.node


def bridge(ros_context, namespace=None, **values):
    overrides = [Parameter("port", value=0)]
    overrides += [Parameter(name, value=value) for name, value in values.items()]
    return Bridge(overrides, context=ros_context, namespace=namespace)


def test_a_namespace_moves_every_channel_but_the_global_ones(ros_context):
    node = bridge(ros_context, namespace="/sat2")
    try:
        served = set(node.served)
        assert served == {topics.absolute(name, "/sat2") for name in SERVABLE}
        assert "/sat2/sail/boom_state" in served and "/diagnostics" in served
        commands = (*topics.COMMAND_TOPICS, topics.HUB_WRENCH_CMD)
        assert set(node._commands) == {f"/sat2/{name}" for name in commands}
        assert node.url.startswith("ws://127.0.0.1:") and not node.url.endswith(":0")
    finally:
        node.close()
        node.destroy_node()


def test_only_the_simulators_topics_are_served(ros_context):
    with pytest.raises(ConfigError, match=r"topics: 'sail/boom_stat' is not a topic"):
        bridge(ros_context, topics=["sail/boom_state", "sail/boom_stat"])


def test_the_address_must_be_an_ip_address(ros_context):
    with pytest.raises(ConfigError, match=r"address: 'localhots' is not an IP address"):
        bridge(ros_context, address="localhots")


def test_a_port_in_use_is_exit_1_with_the_reason(ros_context, capfd):
    node = bridge(ros_context)
    try:
        port = node.url.rsplit(":", 1)[1]
        assert main(["--port", port, "--topics", "/clock"]) == 1
        assert f"cannot listen on 127.0.0.1:{port}" in capfd.readouterr().err
    finally:
        node.close()
        node.destroy_node()


async def _connect(url: str):
    """A Foxglove WebSocket client (no library: the protocol's handshake and JSON), once the
    server sent its channels; None if the server closed the connection first."""
    request = HTTPRequest(url, headers={"Sec-WebSocket-Protocol": "foxglove.sdk.v1"})
    client = await websocket_connect(request)
    while True:
        message = await client.read_message()
        if message is None:
            return None
        if isinstance(message, str) and json.loads(message)["op"] == "advertise":
            return client


async def _read(client) -> int:
    """Read what `client` is sent until the connection closes; how many messages."""
    count = 0
    while await client.read_message() is not None:
        count += 1
    return count


def test_clients_beyond_max_clients_are_disconnected_and_bad_frames_counted(ros_context):
    """300 bad frames from a client are counted as the server's problems (their log lines
    are few: test_bridging); with max_clients 2, two more clients are disconnected as they
    connect (so what the clients' queues hold stays bounded whoever connects), counted;
    the clients' departure is seen."""
    node = bridge(ros_context, max_clients=2)

    async def run():
        clients = [await _connect(node.url) for _ in range(2)]
        statuses = asyncio.ensure_future(_read(clients[0]))  # each frame is answered
        for _ in range(300):
            await clients[0].write_message("not json")
        for _ in range(500):
            if node.status_values()[key.SERVER_PROBLEMS] == "300":
                break
            await asyncio.sleep(0.01)
        assert node.status_values()[key.SERVER_PROBLEMS] == "300"
        assert [await _connect(node.url) for _ in range(2)] == [None, None]
        values = node.status_values()
        assert values[key.CONNECTIONS] == "2" and values[key.REFUSED_CONNECTIONS] == "2"
        for client in clients[:2]:
            client.close()
        await statuses

    try:
        asyncio.run(run())
        wait_until(
            lambda: node.status_values()[key.CONNECTIONS] == "0", 5.0, "the clients gone", step=0.01
        )
    finally:
        node.close()
        node.destroy_node()


def test_a_command_dds_refuses_is_answered(ros_context):
    """A deploy command that decodes (rclpy's reader ignores what follows the message) but
    that DDS refuses to publish (1 MiB of trailing bytes): refused and counted, its client
    told, where the failed publish once ended the server's callback without a word."""
    node = bridge(ros_context)
    try:
        node.client_book.accept_channel(1, 1, "/sail/deploy_cmd")
        data = serialize_message(Float64(data=12.0)) + bytes(1 << 20)
        node.on_message_data(1, 1, data)
        values = node.status_values()
        assert values[key.REFUSED] == "1" and values[key.CLIENT_COMMANDS] == "0"
        assert values[key.LAST_REFUSAL].startswith(
            f"client 1: {len(data)} bytes on /sail/deploy_cmd could not be published on DDS "
            "(Failed to publish"
        ), values[key.LAST_REFUSAL]
    finally:
        node.close()
        node.destroy_node()
