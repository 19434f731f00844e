"""A volatile publisher of a simulator command topic, as most ROS tools publish.

The simulator listens twice on each command topic (`topics.COMMAND_QOS`): a
volatile publisher matches its volatile subscription and not its transient-local
one, as meant. rclpy's default event handler would warn of that mismatch once per
simulator; the project's own volatile publishers (the bridge, the benchmarks, the
tests' operator) leave it out.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node

from sail_ros import topics


def command_publisher(node: Node, name: str):
    """A publisher on command topic `name` (`topics.TOPICS`), volatile, without the
    incompatible-QoS warning the simulator's transient-local subscription would bring."""
    quiet = PublisherEventCallbacks(incompatible_qos=lambda event: None)
    return node.create_publisher(
        topics.TOPICS[name].message_type, name, topics.COMMAND_QOS, event_callbacks=quiet
    )
