"""Locally serialised messages are trimmed to exact CDR, which strict readers accept."""

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import JointState

from sail_ros.bag import trim_cdr

pytestmark = pytest.mark.model


def test_trimmed_joint_state_is_exact():
    message = JointState(name=["boom_a", "boom_b", "boom_c"], position=[1.0, 2.0, 3.0])
    message.header.frame_id = "sail"
    raw = serialize_message(message)
    exact = trim_cdr(raw, "sensor_msgs/msg/JointState")
    assert raw.startswith(exact) and len(exact) <= len(raw)
    store = get_typestore(Stores.ROS2_JAZZY)
    decoded = store.deserialize_cdr(exact, "sensor_msgs/msg/JointState")
    assert list(decoded.name) == ["boom_a", "boom_b", "boom_c"]
    assert deserialize_message(exact, JointState) == message
    if len(raw) - len(exact) > 3:  # what the trimming is for
        with pytest.raises(Exception, match="size mismatch"):
            store.deserialize_cdr(raw, "sensor_msgs/msg/JointState")


def test_trim_rejects_bytes_of_another_kind():
    with pytest.raises(ValueError, match="little-endian CDR"):
        trim_cdr(b"\x00\x00\x00\x00", "std_msgs/msg/Float64")
    with pytest.raises(ValueError, match="is not a sensor_msgs/msg/JointState message"):
        trim_cdr(b"\x00\x01\x00\x00\x01", "sensor_msgs/msg/JointState")
