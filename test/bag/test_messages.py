"""The message builders and their bytes: the state, shape and diagnostics messages, and
the serializers that write them without building them. No ROS runtime."""

import copy

import numpy as np
import pytest
from geometry_msgs.msg import Point
from harness import SMALL
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros import topics
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import shape as shape_msg
from sail_ros.messages import state as state_msg
from sail_ros.messages.cdr import ShapeSerializer, StateSerializer, serialize
from sail_ros.model import (
    SailModel,
)
from sail_ros.model.shape import SailSurface

pytestmark = pytest.mark.model


@pytest.fixture(scope="module")
def model():
    return SailModel(SMALL)


# -- message builders ---------------------------------------------------------------------------


def test_state_messages_carry_stamp_frame_names_and_values():
    stamp = topics.stamp_ns(1_700_000_000_123_000_000, 2.5)
    message = state_msg.boom_state(stamp, [10.0, 11.0, 12.0, 13.0], [0.0, 0.1, 0.2, 0.3])
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1_700_000_002, 623_000_000)
    assert message.header.frame_id == "sail" and message.name == list(topics.BOOM_JOINTS)
    assert list(message.position) == [10.0, 11.0, 12.0, 13.0]
    assert list(message.velocity) == [0.0, 0.1, 0.2, 0.3]
    tips = state_msg.tip_deflection(stamp, [0.1, 0, 0, 0], [0, 0, 0, 0], frame_id="body")
    assert tips.name == ["boom_a_tip", "boom_b_tip", "boom_c_tip", "boom_d_tip"]
    assert tips.header.frame_id == "body"
    status = diagnostics_msg.diagnostics(stamp, "WARN", "why", {"state": "running", "overruns": 3})
    assert status.status[0].level == diagnostics_msg.LEVELS["WARN"]
    assert diagnostics_msg.diagnostic_values(status) == {"state": "running", "overruns": "3"}


def test_shape_markers_draw_the_deflected_membrane_and_the_booms(model):
    surface = SailSurface(model, 4)
    q = model.initial_coordinates([0.1, 0.0, 0.0, -0.05])
    lengths = [10.0, 11.0, 12.0, 13.0]
    vertices = surface.vertices(q, lengths)
    markers = shape_msg.shape(
        5, vertices, surface.triangles, surface.boom_lines(q, lengths)
    ).markers
    membrane, booms = markers[0], markers[1:]
    assert (membrane.ns, membrane.type, membrane.header.frame_id) == (
        "membrane",
        Marker.TRIANGLE_LIST,
        "sail",
    )
    assert len(membrane.points) == len(membrane.colors) == 3 * len(surface.triangles)
    corner = surface.triangles[7, 1]
    assert (membrane.points[7 * 3 + 1].x, membrane.points[7 * 3 + 1].z) == (
        vertices[corner, 0],
        vertices[corner, 2],
    )
    # colours scale with the largest |height| (0.1 m at tip a): red there, half blue at tip d
    heights = [p.z for p in membrane.points]
    top, bottom = membrane.colors[int(np.argmax(heights))], membrane.colors[int(np.argmin(heights))]
    assert (top.r, top.g, top.b) == (1.0, 0.0, 0.0)
    assert (bottom.r, bottom.g, bottom.b) == pytest.approx((0.5, 0.5, 1.0))
    assert [(m.ns, m.id, m.type) for m in booms] == [
        ("booms", k, Marker.LINE_STRIP) for k in range(4)
    ]
    tip_a = booms[0].points[-1]
    assert (tip_a.x, tip_a.y, tip_a.z) == pytest.approx((10.0, 0.0, 0.1))
    assert booms[3].points[-1].y == pytest.approx(-13.0)
    assert all(m.pose.orientation.w == 1.0 for m in markers)


def test_shared_vertex_points_serialise_as_one_point_per_corner(model):
    """The membrane marker shares one Point per vertex among its corners: what rclpy's
    serialiser writes decodes to the message built with one Point per corner (bytes
    are not compared: the CDR alignment padding is not initialised)."""
    surface = SailSurface(model, 6)
    q = model.initial_coordinates([0.1, -0.02, 0.03, -0.05])
    lengths = [10.0, 11.0, 12.0, 13.0]
    vertices, triangles = surface.vertices(q, lengths), surface.triangles
    message = shape_msg.shape(5, vertices, triangles, surface.boom_lines(q, lengths))
    corners = vertices[triangles.ravel()]
    scale = max(np.abs(corners[:, 2]).max(), shape_msg.MIN_COLOUR_RANGE)
    expected = copy.deepcopy(message)
    expected.markers[0].points = [Point(x=x, y=y, z=z) for x, y, z in corners.tolist()]
    expected.markers[0].colors = shape_msg.height_colours(corners[:, 2], scale)
    decoded = deserialize_message(serialize_message(message), MarkerArray)
    assert decoded == expected
    assert [p.z for p in decoded.markers[0].points] == corners[:, 2].tolist()


def test_shape_bytes_are_those_of_the_message_built_from_objects(model):
    """What the simulator publishes on /sail/shape (CDR filled with numpy) is, byte for
    byte, the serialised message `messages.shape.shape` builds: every stamp, point and colour,
    frame after frame (each fills a fresh copy of the template)."""
    surface = SailSurface(model, 6)
    serializer = ShapeSerializer(surface.triangles, surface.boom_stations.size, "body")
    lengths = [10.0, 11.0, 12.0, 13.0]
    for stamp_ns, tips in (
        (1_700_000_000_123_456_789, [0.1, -0.02, 0.03, -0.05]),
        (5, [0.0, 0.0, 0.0, 0.0]),  # flat: the colour scale's floor
        (2_000_000_000_000_000_001, [-0.3, 0.2, 0.0, 0.01]),
    ):
        q = model.initial_coordinates(tips)
        vertices, booms = surface.vertices(q, lengths), surface.boom_lines(q, lengths)
        data = serializer.serialize(stamp_ns, vertices, booms)
        built = shape_msg.shape(stamp_ns, vertices, surface.triangles, booms, "body")
        assert data == serialize(built)
        assert deserialize_message(data, MarkerArray) == built


def test_state_bytes_are_those_of_the_messages_built_from_objects(model):
    """What the simulator publishes on the state topics (CDR filled with numpy) is,
    byte for byte, the serialised messages `messages.state.state_messages` builds, topic by
    topic."""
    for with_clock in (False, True):
        serializer = StateSerializer(model.coordinate_names, "body", with_clock=with_clock)
        rng = np.random.default_rng(7)
        for stamp_ns in (1_700_000_000_123_456_789, 5, 2_000_000_000_000_000_001):
            q, qd = rng.normal(size=model.n), rng.normal(size=model.n)
            lengths, rates = rng.uniform(5.0, 20.0, 4), rng.normal(size=4)
            sample = model.sample(1.5, lengths, rates, q, qd)
            built = state_msg.state_messages(
                stamp_ns, sample, model.coordinate_names, "body", with_clock=with_clock
            )
            sent = serializer.serialize(stamp_ns, sample)
            assert [name for name, _ in sent] == [name for name, _ in built]
            for (_, data), (name, message) in zip(sent, built, strict=True):
                assert data == serialize(message), name
                assert deserialize_message(data, type(message)) == message, name
