"""The bridge node in this process: what it serves where, and what it refuses to start with."""

import pytest
from rclpy.parameter import Parameter

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
