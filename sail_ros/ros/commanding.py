"""A volatile publisher of a simulator command topic, as most ROS tools publish; a
command's CDR bytes read as its type.

The simulator listens twice on each command topic (`topics.COMMAND_QOS`): a
volatile publisher matches its volatile subscription and not its transient-local
one, as meant. rclpy's default event handler would warn of that mismatch once per
simulator; the project's own volatile publishers (the bridge, the benchmarks, the
tests' operator) leave it out.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.serialization import deserialize_message

from sail_ros import topics


def command_publisher(node: Node, name: str):
    """A publisher on command topic `name` (`topics.TOPICS`), volatile, without the
    incompatible-QoS warning the simulator's transient-local subscription would bring."""
    quiet = PublisherEventCallbacks(incompatible_qos=lambda event: None)
    return node.create_publisher(
        topics.TOPICS[name].message_type, name, topics.COMMAND_QOS, event_callbacks=quiet
    )


def decode(data: bytes, message_type):
    """The message of `message_type` that CDR bytes `data` hold (rclpy's reader, as a typed
    subscription would take it).

    Raises:
        ValueError: they hold none; the text is rmw's reason without its source places.
    """
    try:
        return deserialize_message(data, message_type)
    except Exception as error:  # rclpy's RMWError
        raise ValueError(str(error).split(",", 1)[0]) from None
