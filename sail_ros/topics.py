"""The simulator's topic contract: names, QoS profiles and message builders.

Shared by the live simulator (`sail_ros.nodes.sim`) and the offline tools
that write the same messages into MCAP logs, so the builders are pure
functions of numbers: no node, no clock. Every stamp is simulation time as
nanoseconds since the Unix epoch (`stamp_ns`); every quantity is SI. The
pages under `msg_docs/` describe each topic field by field.
"""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

# -- names ------------------------------------------------------------------------------------

BOOM_STATE = "/sail/boom_state"
MODAL_STATE = "/sail/modal_state"
TIP_DEFLECTION = "/sail/tip_deflection"
SHAPE = "/sail/shape"
DIAGNOSTICS = "/diagnostics"
CLOCK = "/clock"
BOOM_LENGTH_CMD = "/sail/boom_length_cmd"
DEPLOY_CMD = "/sail/deploy_cmd"
RESET_SERVICE = "/sail/reset"
PAUSE_SERVICE = "/sail/pause"

FRAME_ID = "sail"  # default body frame (model.md §1)
BOOM_JOINTS = ("boom_a", "boom_b", "boom_c", "boom_d")
TIP_JOINTS = tuple(f"{name}_tip" for name in BOOM_JOINTS)
DIAGNOSTIC_NAME = "sail_sim: integrator"
HARDWARE_ID = "sail_sim"

# -- QoS --------------------------------------------------------------------------------------
# Everything is reliable and volatile: a recorder or a slow subscriber gets
# every sample (within the depth) and nothing is replayed to late joiners.
# Reliable publishers also serve best-effort subscribers (RViz, /clock users).

STATE_QOS = QoSProfile(  # boom_state, modal_state, tip_deflection
    history=HistoryPolicy.KEEP_LAST, depth=50,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
SHAPE_QOS = QoSProfile(  # big messages, low rate: keep few
    history=HistoryPolicy.KEEP_LAST, depth=5,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
DIAGNOSTICS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
CLOCK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
# Commands: volatile, so a command latched by its publisher is never re-run by
# a simulator that starts later; reliable, so none is lost.
COMMAND_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

TOPIC_QOS = {
    BOOM_STATE: STATE_QOS,
    MODAL_STATE: STATE_QOS,
    TIP_DEFLECTION: STATE_QOS,
    SHAPE: SHAPE_QOS,
    DIAGNOSTICS: DIAGNOSTICS_QOS,
    CLOCK: CLOCK_QOS,
    BOOM_LENGTH_CMD: COMMAND_QOS,
    DEPLOY_CMD: COMMAND_QOS,
}

# -- builders ---------------------------------------------------------------------------------


def stamp(stamp_ns: int) -> Time:
    """`builtin_interfaces/Time` of `stamp_ns` [ns since the Unix epoch]."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def stamp_ns(epoch_ns: int, t: float) -> int:
    """The stamp [ns] of simulation time `t` [s] on a run that started at `epoch_ns`."""
    return int(epoch_ns) + round(t * 1e9)


def _joint_state(stamp_ns_, frame_id, names, position, velocity) -> JointState:
    message = JointState(name=list(names))
    message.header.stamp = stamp(stamp_ns_)
    message.header.frame_id = frame_id
    message.position = np.asarray(position, dtype=float)
    message.velocity = np.asarray(velocity, dtype=float)
    return message


def boom_state(stamp_ns_: int, lengths, rates, frame_id: str = FRAME_ID) -> JointState:
    """`/sail/boom_state`: deployed length [m] and extension rate [m/s] of booms a..d."""
    return _joint_state(stamp_ns_, frame_id, BOOM_JOINTS, lengths, rates)


def modal_state(stamp_ns_: int, names, q, qd, frame_id: str = FRAME_ID) -> JointState:
    """`/sail/modal_state`: generalised coordinates `q` [m] and velocities `qd` [m/s]
    named by `SailModel.coordinate_names` (model.md §6 order)."""
    return _joint_state(stamp_ns_, frame_id, names, q, qd)


def tip_deflection(stamp_ns_: int, tips, tip_rates, frame_id: str = FRAME_ID) -> JointState:
    """`/sail/tip_deflection`: out-of-plane deflection [m] (+z of `frame_id`) of
    each boom tip and its rate [m/s]."""
    return _joint_state(stamp_ns_, frame_id, TIP_JOINTS, tips, tip_rates)


def clock(stamp_ns_: int) -> Clock:
    """`/clock`: the simulation time, for nodes with use_sim_time."""
    return Clock(clock=stamp(stamp_ns_))


BOOM_LINE_WIDTH = 0.2  # m, drawn width of a boom in RViz
BOOM_COLOUR = ColorRGBA(r=0.25, g=0.25, b=0.25, a=1.0)
MIN_COLOUR_RANGE = 1e-3  # m: below this the membrane is drawn as flat (white)


COLOUR_LEVELS = 32  # per sign: heights are drawn in 2 * 32 + 1 shades


def _diverging(v: float) -> ColorRGBA:
    return ColorRGBA(r=min(1.0, 1.0 + v), g=1.0 - abs(v), b=min(1.0, 1.0 - v), a=1.0)


# shared, immutable-by-convention colour objects: building 1000s per message is slow
_PALETTE = [_diverging(level / COLOUR_LEVELS)
            for level in range(-COLOUR_LEVELS, COLOUR_LEVELS + 1)]


def height_colours(heights, scale: float) -> list[ColorRGBA]:
    """Diverging colour map of heights [m]: blue at -scale, white at 0, red at
    +scale, in 2 COLOUR_LEVELS + 1 shades."""
    v = np.clip(np.asarray(heights, dtype=float) / scale, -1.0, 1.0)
    levels = np.rint(v * COLOUR_LEVELS).astype(int) + COLOUR_LEVELS
    return [_PALETTE[level] for level in levels.tolist()]


def shape(stamp_ns_: int, vertices, triangles, boom_lines, frame_id: str = FRAME_ID) -> MarkerArray:
    """`/sail/shape`: the deflected sail for RViz/Foxglove.

    Args:
        stamp_ns_: stamp [ns].
        vertices: membrane mesh points (P, 3) [m] in `frame_id` (`SailSurface.vertices`).
        triangles: vertex indices (T, 3) (`SailSurface.triangles`).
        boom_lines: points along each boom (4, S, 3) [m] (`SailSurface.boom_lines`).

    Returns:
        Marker `membrane`/0: TRIANGLE_LIST, one colour per point from its height
        (`height_colours`, scaled to the largest |height| of this frame, at least
        MIN_COLOUR_RANGE); markers `booms`/0..3: LINE_STRIPs of booms a..d.
    """
    header_stamp = stamp(stamp_ns_)
    corners = np.asarray(vertices, dtype=float)[np.asarray(triangles).ravel()]
    membrane = _marker(header_stamp, frame_id, "membrane", 0, Marker.TRIANGLE_LIST)
    membrane.scale.x = membrane.scale.y = membrane.scale.z = 1.0
    membrane.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    membrane.points = [Point(x=x, y=y, z=z) for x, y, z in corners.tolist()]
    heights = corners[:, 2]
    scale = max(float(np.max(np.abs(heights), initial=0.0)), MIN_COLOUR_RANGE)
    membrane.colors = height_colours(heights, scale)
    markers = [membrane]
    for k, line in enumerate(np.asarray(boom_lines, dtype=float)):
        boom = _marker(header_stamp, frame_id, "booms", k, Marker.LINE_STRIP)
        boom.scale.x = BOOM_LINE_WIDTH
        boom.color = BOOM_COLOUR
        boom.points = [Point(x=x, y=y, z=z) for x, y, z in line.tolist()]
        markers.append(boom)
    return MarkerArray(markers=markers)


def _marker(header_stamp: Time, frame_id: str, ns: str, marker_id: int, kind: int) -> Marker:
    marker = Marker(ns=ns, id=marker_id, type=kind, action=Marker.ADD)
    marker.header.stamp = header_stamp
    marker.header.frame_id = frame_id
    marker.pose.orientation.w = 1.0  # identity: points are already in frame_id
    return marker


LEVELS = {"OK": DiagnosticStatus.OK, "WARN": DiagnosticStatus.WARN,
          "ERROR": DiagnosticStatus.ERROR}


def diagnostics(stamp_ns_: int, level: str, message: str, values: dict) -> DiagnosticArray:
    """`/diagnostics`: one status `sail_sim: integrator` (hardware_id `sail_sim`).

    Args:
        level: "OK", "WARN" or "ERROR".
        message: one line saying why the level is what it is.
        values: key -> value, written with `str` (round floats before).
    """
    status = DiagnosticStatus(level=LEVELS[level], name=DIAGNOSTIC_NAME, message=message,
                              hardware_id=HARDWARE_ID)
    status.values = [KeyValue(key=key, value=str(value)) for key, value in values.items()]
    array = DiagnosticArray(status=[status])
    array.header.stamp = stamp(stamp_ns_)
    return array


def diagnostic_values(array: DiagnosticArray) -> dict[str, str]:
    """The key/value pairs of the integrator status in `array` (empty if absent)."""
    for status in array.status:
        if status.name == DIAGNOSTIC_NAME:
            return {pair.key: pair.value for pair in status.values}
    return {}
