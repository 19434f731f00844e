"""`messages.cdr.serialize`: exact CDR bytes. An independent writer (rosbags) gives
the same bytes for what an independent reader (rosbags) decodes from them."""

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseWithCovarianceStamped
from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, JointState
from std_msgs.msg import ByteMultiArray, Empty, Float64, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros.messages import shape as shape_msg
from sail_ros.messages.cdr import serialize

pytestmark = pytest.mark.model


def joint_state(names, position=(), velocity=(), effort=(), frame_id="sail"):
    message = JointState(name=names, position=position, velocity=velocity, effort=effort)
    message.header.frame_id = frame_id
    message.header.stamp.sec, message.header.stamp.nanosec = 1_700_000_000, 123_456_789
    return message


def marker_array():
    mesh = Marker(ns="membrane", id=3, type=Marker.TRIANGLE_LIST, text="é")  # 2 UTF-8 bytes
    mesh.points = [Point(x=0.5 * k, y=-1.0, z=1e-3 * k) for k in range(7)]
    mesh.colors = shape_msg.height_colours(np.linspace(-1.0, 1.0, 7), 1.0)
    mesh.mesh_file.filename, mesh.mesh_file.data = "m.stl", [1, 2, 3]
    return MarkerArray(markers=[mesh, Marker(ns="b", frame_locked=True)])


def parameter_event():
    value = ParameterValue(
        type=9, byte_array_value=[b"a", b"b", b"c"], bool_array_value=[True], integer_value=-5
    )
    value.string_array_value = ["x", "yyyy", ""]
    return ParameterEvent(node="/sail_sim", new_parameters=[Parameter(name="p", value=value)])


def trajectory():
    point = JointTrajectoryPoint(positions=[12.0], effort=[])
    point.time_from_start.sec = 3
    return JointTrajectory(joint_names=["boom_a"], points=[point, JointTrajectoryPoint()])


MESSAGES = {
    "joint state": joint_state(["boom_a", "boom_b", "boom_c", "boom_d"], [1.0] * 4, [2.0] * 4),
    "root moment": joint_state([f"boom_{k}_root" for k in "abcd"], effort=[0.5, 0.25, 0.0, -1.0]),
    "odd names, one value": joint_state(["a", "bcd", "ef"], velocity=[3.0]),
    "empty joint state": joint_state([], frame_id=""),
    "empty message": Empty(),
    "float": Float64(data=-2.5),
    "string": String(data="abc"),
    "clock": Clock(),
    "diagnostics": DiagnosticArray(
        status=[DiagnosticStatus(level=b"\x01", name="n", values=[KeyValue(key="k", value="vv")])]
    ),
    "markers": marker_array(),
    "trajectory": trajectory(),
    "parameter event": parameter_event(),
    "fixed arrays": CameraInfo(d=[0.1] * 5, height=3),
    "covariance": PoseWithCovarianceStamped(),
    "bytes": ByteMultiArray(data=[b"\x07"] * 5),
}


@pytest.fixture(scope="module")
def store():
    return get_typestore(Stores.ROS2_JAZZY)


def type_name(message) -> str:
    package, namespace = type(message).__module__.split(".")[:2]
    return f"{package}/{namespace}/{type(message).__name__}"


@pytest.mark.parametrize("message", MESSAGES.values(), ids=MESSAGES.keys())
def test_serialised_bytes_are_exactly_the_cdr_encoding(message, store):
    name = type_name(message)
    exact = serialize(message)
    padded = serialize_message(message)
    assert len(exact) <= len(padded) and exact[:4] == padded[:4] == b"\x00\x01\x00\x00"
    decoded = store.deserialize_cdr(exact, name)  # raises on bytes past the last field
    assert store.serialize_cdr(decoded, name) == exact  # padding zero, nothing after
    assert deserialize_message(exact, type(message)) == message
    assert serialize(message) == exact  # the same message, the same bytes


def test_padded_bytes_are_what_strict_readers_reject(store):
    """What rclpy's serialiser returns under Fast DDS: its size estimate (the cause of
    the 4 to 8 extra bytes the simulator's state messages once had)."""
    message = MESSAGES["root moment"]
    padded, exact = serialize_message(message), serialize(message)
    assert len(padded) - len(exact) > 3
    with pytest.raises(Exception, match="CDR message size mismatch"):
        store.deserialize_cdr(padded, type_name(message))
