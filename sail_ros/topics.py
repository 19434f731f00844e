"""The simulator's log contract: what live and offline logs hold, in one place.

Shared by the live simulator (`sail_ros.nodes.sim`), the recorder, and the
offline tools that write and read the same messages in MCAP logs
(`sail_ros.analysis.log_export`, `log_series`), so "offline logs look like
live logs" holds by construction:

- the topic table `TOPICS` (name, message class, type name, QoS);
- the builders of every state message, pure functions of numbers (no node,
  no clock), and `state_messages`, the set published at every state sample;
- the stamps: simulation time as nanoseconds since the Unix epoch (`stamp_ns`);
- the metadata record names (`PARAMETERS_METADATA`, `PARAMETER_CHANGES_METADATA`,
  `SCENARIO_METADATA`);
- the flat parameter names `sail.<field>` <-> `SailParameters`.

Every quantity is SI. The pages under `msg_docs/` describe each topic field
by field. Nothing here imports rclpy's `Node`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Float64
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros.model import SailParameters, yaml_values
from sail_ros.model.record import StateSample

# -- names ------------------------------------------------------------------------------------
# Relative, so a node's namespace (`--ros-args -r __ns:=/sat2`) moves them all;
# /clock and /diagnostics are global, as ROS expects.

BOOM_STATE = "sail/boom_state"
MODAL_STATE = "sail/modal_state"
TIP_DEFLECTION = "sail/tip_deflection"
ROOT_MOMENT = "sail/root_moment"
SHAPE = "sail/shape"
HUB_STATE = "sail/hub_state"  # a free hub only
DIAGNOSTICS = "/diagnostics"
CLOCK = "/clock"
BOOM_LENGTH_CMD = "sail/boom_length_cmd"
DEPLOY_CMD = "sail/deploy_cmd"
PRESSURE_CMD = "sail/pressure_cmd"
TIP_FORCE_CMD = "sail/tip_force_cmd"
HUB_WRENCH_CMD = "sail/hub_wrench_cmd"  # a free hub only
COMMAND_STATUS = "sail/command_status"
RESET_SERVICE = "sail/reset"
PAUSE_SERVICE = "sail/pause"
SIM_NODE = "sail_sim"


def sail_namespaces(recorded_topics) -> list[str]:
    """The namespaces ("/", "/sat2", ...) in which a log holds a sail's boom state."""
    suffix = "/" + BOOM_STATE
    return sorted(
        (topic[: -len(suffix)] or "/") for topic in recorded_topics if topic.endswith(suffix)
    )


def moved(topic: str, source: str, target: str) -> str:
    """`topic` of a sail recorded in namespace `source`, played in namespace `target`:
    "/sat1/sail/boom_state" from "/sat1" to "/sat2" is "/sat2/sail/boom_state"; a topic
    outside `source` (/clock, /diagnostics) stays as it is."""
    prefix = source.rstrip("/") + "/"
    if not topic.startswith(prefix):
        return topic
    return absolute(topic[len(prefix) :], target)


def absolute(name: str, namespace: str = "/") -> str:
    """`name` resolved in `namespace` ("/" or "/sat2"): "sail/boom_state" ->
    "/sat2/sail/boom_state"; an absolute name stays as it is."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


FRAME_ID = "sail"  # default body frame (model.md §1)
INERTIAL_FRAME_ID = "sail_inertial"  # default inertial frame of a free hub (model.md §13)
BOOM_JOINTS = ("boom_a", "boom_b", "boom_c", "boom_d")
TIP_JOINTS = tuple(f"{name}_tip" for name in BOOM_JOINTS)
ROOT_JOINTS = tuple(f"{name}_root" for name in BOOM_JOINTS)
QUADRANT_SURFACES = ("quadrant_ab", "quadrant_bc", "quadrant_cd", "quadrant_da")
# the load commands: which names each takes (JointState.name, its value in .effort)
LOAD_NAMES = {PRESSURE_CMD: QUADRANT_SURFACES, TIP_FORCE_CMD: BOOM_JOINTS}
HARDWARE_ID = SIM_NODE


def integrator_status_name(node: str = SIM_NODE) -> str:
    """The /diagnostics status name of the simulator node `node` (its fully qualified
    name, or a name in the root namespace): "sail_sim: integrator",
    "sat2/sail_sim: integrator"; /diagnostics is global, the name tells sails apart."""
    return f"{node.lstrip('/')}: integrator"


DIAGNOSTIC_NAME = integrator_status_name()

# -- QoS --------------------------------------------------------------------------------------
# Everything is reliable: a recorder or a slow subscriber gets every sample
# (within the depth); reliable publishers also serve best-effort subscribers
# (RViz, /clock users). The state is transient local: a subscriber that asks
# for it (`sail-ros watch`) gets the latest samples at once, also while the
# simulator is paused and publishes none; volatile subscribers get only new ones.
# Commands and their answers are kept (transient local) so that neither is
# lost to discovery order: see COMMAND_QOS.


def _reliable(depth: int, durability: DurabilityPolicy) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=durability,
    )


# boom_state, modal_state, tip_deflection, root_moment. A reliable publisher can
# resend a sample a subscriber missed only while it still holds it: 500 samples
# are 2.5 s at 200 samples/s (4x real time at 50 Hz), so a subscriber whose process
# stalls for a few hundred milliseconds (one recorder, on a loaded 2-core machine,
# took none for 370 ms) still gets every sample; 50 lost the samples of the stall.
STATE_QOS = _reliable(500, DurabilityPolicy.TRANSIENT_LOCAL)
# for subscribers that want the newest sample only (`sail-ros watch`): DDS delivers
# the kept history, but only the last sample reaches Python
NEWEST_STATE_QOS = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
SHAPE_QOS = _reliable(5, DurabilityPolicy.VOLATILE)  # big messages, low rate: keep few
DIAGNOSTICS_QOS = _reliable(10, DurabilityPolicy.VOLATILE)
CLOCK_QOS = _reliable(10, DurabilityPolicy.VOLATILE)
# Commands. Discovery is not symmetric in time: a publisher that sees the
# simulator's subscription may publish before the simulator has seen the
# publisher, and a volatile subscription drops what came before that moment.
# So the simulator listens twice on each command topic: transient local
# (LATCHED_COMMAND_QOS: from a transient-local publisher, as `sail-ros send`
# uses, it gets the command whenever it matches) and volatile (COMMAND_QOS:
# what `ros2 topic pub` and most publishers offer). A command that arrives on
# both counts once; one published before the simulator started is ignored, so
# a restarted simulator does not run old commands again.
COMMAND_QOS = _reliable(10, DurabilityPolicy.VOLATILE)
LATCHED_COMMAND_QOS = _reliable(10, DurabilityPolicy.TRANSIENT_LOCAL)
# The simulator's two subscriptions keep more: DDS holds a burst until the
# simulator's reception thread moves it into its own, counted queue
# (`max_queued_commands`); only more than this many at once, faster than that
# thread takes them, could be overwritten unseen.
COMMAND_INTAKE_DEPTH = 1000
COMMAND_INTAKE_QOS = tuple(
    _reliable(COMMAND_INTAKE_DEPTH, qos.durability) for qos in (LATCHED_COMMAND_QOS, COMMAND_QOS)
)
# The answer to every command; kept, so an answer published before its
# sender's subscription matched still reaches it.
COMMAND_STATUS_QOS = _reliable(50, DurabilityPolicy.TRANSIENT_LOCAL)


@dataclasses.dataclass(frozen=True)
class Topic:
    """One topic of the simulator: name, message class, `pkg/msg/Type`, QoS."""

    name: str
    message_type: type
    type_name: str
    qos: QoSProfile


TOPICS = {
    topic.name: topic
    for topic in (
        Topic(BOOM_STATE, JointState, "sensor_msgs/msg/JointState", STATE_QOS),
        Topic(MODAL_STATE, JointState, "sensor_msgs/msg/JointState", STATE_QOS),
        Topic(TIP_DEFLECTION, JointState, "sensor_msgs/msg/JointState", STATE_QOS),
        Topic(ROOT_MOMENT, JointState, "sensor_msgs/msg/JointState", STATE_QOS),
        Topic(SHAPE, MarkerArray, "visualization_msgs/msg/MarkerArray", SHAPE_QOS),
        Topic(HUB_STATE, Odometry, "nav_msgs/msg/Odometry", STATE_QOS),
        Topic(HUB_WRENCH_CMD, WrenchStamped, "geometry_msgs/msg/WrenchStamped", COMMAND_QOS),
        Topic(BOOM_LENGTH_CMD, JointTrajectory, "trajectory_msgs/msg/JointTrajectory", COMMAND_QOS),
        Topic(DEPLOY_CMD, Float64, "std_msgs/msg/Float64", COMMAND_QOS),
        Topic(PRESSURE_CMD, JointState, "sensor_msgs/msg/JointState", COMMAND_QOS),
        Topic(TIP_FORCE_CMD, JointState, "sensor_msgs/msg/JointState", COMMAND_QOS),
        Topic(
            COMMAND_STATUS,
            DiagnosticArray,
            "diagnostic_msgs/msg/DiagnosticArray",
            COMMAND_STATUS_QOS,
        ),
        Topic(CLOCK, Clock, "rosgraph_msgs/msg/Clock", CLOCK_QOS),
        Topic(DIAGNOSTICS, DiagnosticArray, "diagnostic_msgs/msg/DiagnosticArray", DIAGNOSTICS_QOS),
    )
}
TOPIC_QOS = {name: topic.qos for name, topic in TOPICS.items()}
# what the simulator publishes at every state sample (and /clock with them when it runs one)
STATE_TOPICS = (BOOM_STATE, MODAL_STATE, TIP_DEFLECTION, ROOT_MOMENT)
# what the simulator takes commands on (and HUB_WRENCH_CMD with a free hub)
COMMAND_TOPICS = (BOOM_LENGTH_CMD, DEPLOY_CMD, PRESSURE_CMD, TIP_FORCE_CMD)
# what a free hub adds: its state with every state sample, its wrench command
HUB_TOPICS = (HUB_STATE, HUB_WRENCH_CMD)
# ROS's record of every parameter change, with its time and node (rcl_interfaces/ParameterEvent)
PARAMETER_EVENTS = "/parameter_events"
# what a recorder of the simulator takes by default: everything in the table, and
# the parameter changes
RECORDED_TOPICS = (*TOPICS, PARAMETER_EVENTS)

# -- metadata records ---------------------------------------------------------------------------

PARAMETERS_METADATA = "sail_sim_parameters"  # the simulator's parameters, name -> YAML text
# one record per parameter event that changed them: node, times, {name, old, new} list
PARAMETER_CHANGES_METADATA = "sail_sim_parameter_changes"
SCENARIO_METADATA = "sail_deploy_scenario"  # an offline run: its scenario (YAML) and epoch_ns
SAIL_PREFIX = "sail."  # the simulator's parameter `sail.<field>` is SailParameters.<field>


def yaml_value(value) -> str:
    """A parameter value as one line of YAML: 100.0, true, [1, 2], abc."""
    if not isinstance(value, bool | int | float | str):  # an array; a byte array holds bytes
        value = [item[0] if isinstance(item, bytes) else item for item in value]
    text = yaml.safe_dump(value, default_flow_style=True, width=1 << 30)
    return text.removesuffix("\n...\n").strip()


# a free hub's fields (docs/model.md §13.8): written only when the hub is free, so a clamped
# sail's parameters are the ones it always had
HUB_FIELDS = ("free_hub", "hub_mass", "hub_inertia_x", "hub_inertia_y", "stowed_mass_on_hub")


def flat_sail_parameters(params: SailParameters) -> dict[str, object]:
    """`sail.<field>` -> value: the sail as the simulator's parameters (the hub's fields
    only with a free hub; absent, they take their defaults)."""
    return {
        SAIL_PREFIX + name: value
        for name, value in params.to_dict().items()
        if params.free_hub or name not in HUB_FIELDS
    }


def sail_parameters_from_flat(values: Mapping[str, object]) -> SailParameters:
    """`SailParameters` from the `sail.<field>` entries of `values` (others ignored).

    Raises:
        ValueError: a field is unknown or its value invalid, named `sail.<field>`.
    """
    fields = {
        name[len(SAIL_PREFIX) :]: value
        for name, value in values.items()
        if name.startswith(SAIL_PREFIX)
    }
    try:
        return SailParameters.from_dict(fields)
    except ValueError as error:
        raise ValueError(f"{SAIL_PREFIX}{error}") from None


def sail_parameters_from_record(record: Mapping[str, str]) -> SailParameters | None:
    """`SailParameters` from a recorded `PARAMETERS_METADATA` record (values as YAML
    text); None if the record has no `sail.` entry.

    Raises:
        ValueError: a recorded value is not YAML or not valid, naming it.
    """
    values = {}
    for name, text in record.items():
        if name.startswith(SAIL_PREFIX):
            try:
                values[name] = yaml_values.load(text)
            except yaml.YAMLError:
                raise ValueError(f"recorded parameter {name} = {text!r} is not YAML") from None
    if not values:
        return None
    try:
        return sail_parameters_from_flat(values)
    except ValueError as error:
        raise ValueError(f"recorded {PARAMETERS_METADATA}: {error}") from None


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


def root_moment(stamp_ns_: int, moments, frame_id: str = FRAME_ID) -> JointState:
    """`/sail/root_moment`: root bending moment `EI u''(0)` [N m] of each boom, in
    `effort` (positive when the boom bends towards +z of `frame_id`)."""
    message = JointState(name=list(ROOT_JOINTS))
    message.header.stamp = stamp(stamp_ns_)
    message.header.frame_id = frame_id
    message.effort = np.asarray(moments, dtype=float)
    return message


def hub_state(
    stamp_ns_: int, hub, frame_id: str = FRAME_ID, inertial_frame_id: str = INERTIAL_FRAME_ID
) -> Odometry:
    """`/sail/hub_state`: a free hub's pose and twist, `hub` = (z_h [m], theta_x, theta_y
    [rad], zd_h [m/s], thd_x, thd_y [rad/s]) (model.md §13.9): header frame
    `inertial_frame_id`, child `frame_id`; position (0, 0, z_h); orientation the unit
    quaternion of the rotation vector (theta_x, theta_y, 0); twist in the child frame,
    linear (0, 0, zd_h), angular (thd_x, thd_y, 0); covariances zero (the state is
    exact)."""
    z, theta_x, theta_y, zd, thd_x, thd_y = (float(v) for v in hub)
    message = Odometry(child_frame_id=frame_id)
    message.header.stamp = stamp(stamp_ns_)
    message.header.frame_id = inertial_frame_id
    message.pose.pose.position.z = z
    angle = math.hypot(theta_x, theta_y)
    half = math.sin(0.5 * angle) / angle if angle > 0 else 0.5  # sin(r/2)/r -> 1/2
    orientation = message.pose.pose.orientation
    orientation.x, orientation.y = half * theta_x, half * theta_y
    orientation.z, orientation.w = 0.0, math.cos(0.5 * angle)
    message.twist.twist.linear.z = zd
    message.twist.twist.angular.x, message.twist.twist.angular.y = thd_x, thd_y
    return message


def hub_from_odometry(message: Odometry) -> np.ndarray:
    """The inverse of `hub_state`: `(z_h, theta_x, theta_y, zd_h, thd_x, thd_y)` from a
    `/sail/hub_state`, the tilts the rotation vector of its orientation."""
    orientation = message.pose.pose.orientation
    sine = math.hypot(orientation.x, orientation.y)  # sin(r/2); z is 0
    angle = 2.0 * math.atan2(sine, orientation.w)
    scale = angle / sine if sine > 0 else 2.0  # r / sin(r/2) -> 2
    twist = message.twist.twist
    return np.array(
        [
            message.pose.pose.position.z,
            scale * orientation.x,
            scale * orientation.y,
            twist.linear.z,
            twist.angular.x,
            twist.angular.y,
        ]
    )


def hub_wrench_command(
    force_z: float, torque_x: float, torque_y: float, frame_id: str = ""
) -> WrenchStamped:
    """A `sail/hub_wrench_cmd`: force along z [N], torques about x and y [N m] on the hub."""
    message = WrenchStamped()
    message.header.frame_id = frame_id
    message.wrench.force.z = float(force_z)
    message.wrench.torque.x, message.wrench.torque.y = float(torque_x), float(torque_y)
    return message


def load_command(topic: str, values: Mapping[str, float]) -> JointState:
    """A `sail/pressure_cmd` (quadrant -> Pa) or `sail/tip_force_cmd` (boom -> N)."""
    message = JointState(name=list(values))
    message.effort = [float(v) for v in values.values()]
    return message


def clock(stamp_ns_: int) -> Clock:
    """`/clock`: the simulation time, for nodes with use_sim_time."""
    return Clock(clock=stamp(stamp_ns_))


def state_messages(
    stamp_ns_: int,
    sample: StateSample,
    coordinate_names,
    frame_id: str = FRAME_ID,
    with_clock: bool = False,
    inertial_frame_id: str = INERTIAL_FRAME_ID,
) -> list[tuple[str, object]]:
    """`(topic, message)` of every state topic at one sample, in publishing order:
    /clock first (if `with_clock`), then boom state, modal state, tip deflections,
    root moments, and a free hub's state."""
    messages = [(CLOCK, clock(stamp_ns_))] if with_clock else []
    messages += [
        (BOOM_STATE, boom_state(stamp_ns_, sample.lengths, sample.rates, frame_id)),
        (MODAL_STATE, modal_state(stamp_ns_, coordinate_names, sample.q, sample.qd, frame_id)),
        (TIP_DEFLECTION, tip_deflection(stamp_ns_, sample.tips, sample.tip_rates, frame_id)),
        (ROOT_MOMENT, root_moment(stamp_ns_, sample.root_moments, frame_id)),
    ]
    if sample.hub is not None:
        messages.append((HUB_STATE, hub_state(stamp_ns_, sample.hub, frame_id, inertial_frame_id)))
    return messages


BOOM_LINE_WIDTH = 0.2  # m, drawn width of a boom in RViz
BOOM_COLOUR = ColorRGBA(r=0.25, g=0.25, b=0.25, a=1.0)
MIN_COLOUR_RANGE = 1e-3  # m: below this the membrane is drawn as flat (white)


COLOUR_LEVELS = 32  # per sign: heights are drawn in 2 * 32 + 1 shades


def _diverging(v: float) -> ColorRGBA:
    return ColorRGBA(r=min(1.0, 1.0 + v), g=1.0 - abs(v), b=min(1.0, 1.0 - v), a=1.0)


# shared, immutable-by-convention colour objects: building 1000s per message is slow
_PALETTE = [_diverging(level / COLOUR_LEVELS) for level in range(-COLOUR_LEVELS, COLOUR_LEVELS + 1)]


# the same shades as float32 RGBA rows, as CDR holds them (`messages.cdr`)
_PALETTE_RGBA = np.array([[c.r, c.g, c.b, c.a] for c in _PALETTE], dtype="<f4")


def _height_levels(heights, scale: float) -> np.ndarray:
    v = np.clip(np.asarray(heights, dtype=float) / scale, -1.0, 1.0)
    return np.rint(v * COLOUR_LEVELS).astype(int) + COLOUR_LEVELS


def height_colours(heights, scale: float) -> list[ColorRGBA]:
    """Diverging colour map of heights [m]: blue at -scale, white at 0, red at
    +scale, in 2 COLOUR_LEVELS + 1 shades."""
    return [_PALETTE[level] for level in _height_levels(heights, scale).tolist()]


def colour_array(heights, scale: float) -> np.ndarray:
    """`height_colours` as an (N, 4) float32 array of r, g, b, a."""
    return _PALETTE_RGBA[_height_levels(heights, scale)]


def shape(stamp_ns_: int, vertices, triangles, boom_lines, frame_id: str = FRAME_ID) -> MarkerArray:
    """`/sail/shape`: the deflected sail for RViz/Foxglove.

    Args:
        stamp_ns_: stamp [ns].
        vertices: membrane mesh points (P, 3) [m] in `frame_id` (`SailSurface.vertices`).
        triangles: vertex indices (T, 3) (`SailSurface.triangles`).
        boom_lines: points along each boom (4, S, 3) [m] (`SailSurface.boom_lines`).
        frame_id: frame of the markers.

    Returns:
        Marker `membrane`/0: TRIANGLE_LIST, one colour per point from its height
        (`height_colours`, scaled to the largest |height| of this frame, at least
        MIN_COLOUR_RANGE); markers `booms`/0..3: LINE_STRIPs of booms a..d.
    """
    header_stamp = stamp(stamp_ns_)
    vertices = np.asarray(vertices, dtype=float)
    corners = np.asarray(triangles).ravel().tolist()
    membrane = _marker(header_stamp, frame_id, "membrane", 0, Marker.TRIANGLE_LIST)
    membrane.scale.x = membrane.scale.y = membrane.scale.z = 1.0
    membrane.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    # one Point and one colour per mesh vertex, shared by the triangles that meet
    # there: a vertex is in about five corners, and building the objects is the cost
    points = [Point(x=x, y=y, z=z) for x, y, z in vertices.tolist()]
    membrane.points = [points[i] for i in corners]
    heights = vertices[:, 2]
    scale = max(float(np.max(np.abs(heights[corners]), initial=0.0)), MIN_COLOUR_RANGE)
    colours = height_colours(heights, scale)
    membrane.colors = [colours[i] for i in corners]
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


LEVELS = {"OK": DiagnosticStatus.OK, "WARN": DiagnosticStatus.WARN, "ERROR": DiagnosticStatus.ERROR}


def diagnostics(
    stamp_ns_: int, level: str, message: str, values: dict, node: str = SIM_NODE
) -> DiagnosticArray:
    """`/diagnostics`: one status `<node>: integrator` (`integrator_status_name`).

    Args:
        stamp_ns_: stamp [ns].
        level: "OK", "WARN" or "ERROR".
        message: one line saying why the level is what it is.
        values: key -> value, written with `str` (round floats before).
        node: the simulator's fully qualified node name (also the hardware_id).
    """
    status = DiagnosticStatus(
        level=LEVELS[level],
        name=integrator_status_name(node),
        message=message,
        hardware_id=node.lstrip("/"),
    )
    status.values = [KeyValue(key=key, value=str(value)) for key, value in values.items()]
    array = DiagnosticArray(status=[status])
    array.header.stamp = stamp(stamp_ns_)
    return array


def diagnostic_values(array: DiagnosticArray, node: str = SIM_NODE) -> dict[str, str]:
    """The key/value pairs of the integrator status of simulator `node` (its fully
    qualified name) in `array`; empty if absent."""
    wanted = integrator_status_name(node)
    for status in array.status:
        if status.name == wanted:
            return {pair.key: pair.value for pair in status.values}
    return {}


# -- answers to commands ------------------------------------------------------------------------

ACCEPTED, REJECTED, IGNORED = "accepted", "rejected", "ignored"
SUPERSEDED = "superseded"  # a newer command replaced it before it started
# value of an accepted load command's answer: the four values held from then on
# ("[0.002, 0.0, 0.0, 0.0]", Pa or N), so a log tells every load from the answers alone
LOADS_HELD = "loads_held"
_OUTCOME_LEVELS = {
    ACCEPTED: DiagnosticStatus.OK,
    REJECTED: DiagnosticStatus.ERROR,
    IGNORED: DiagnosticStatus.WARN,
    SUPERSEDED: DiagnosticStatus.WARN,
}


class CommandAnswer(NamedTuple):
    """What the simulator did with one command (`sail/command_status`).

    Attributes:
        topic: the command topic, as the simulator resolved it.
        outcome: "accepted", "superseded" (a newer command replaced it before it
            started), "rejected" or "ignored" (published before the simulator started).
        message: the plan ("deploy to 12 m: ...") or the reason.
        source_timestamp_ns: when its publisher wrote it [ns, the publisher's clock].
        sequence: the publisher's sequence number of the command.
        values: further key/value pairs (t_start_s, t_end_s of an accepted motion;
            t_start_s and LOADS_HELD of an accepted load).
    """

    topic: str
    outcome: str
    message: str
    source_timestamp_ns: int
    sequence: int
    values: dict[str, str]


def command_status(stamp_ns_: int, answer: CommandAnswer) -> DiagnosticArray:
    """`sail/command_status`: one status per command; level OK (accepted), ERROR
    (rejected) or WARN (ignored), name `sail_sim: <topic>`, the answer's fields
    as values."""
    status = DiagnosticStatus(
        level=_OUTCOME_LEVELS[answer.outcome],
        name=f"{SIM_NODE}: {answer.topic}",
        message=answer.message,
        hardware_id=SIM_NODE,
    )
    pairs = {
        "topic": answer.topic,
        "outcome": answer.outcome,
        "source_timestamp_ns": str(answer.source_timestamp_ns),
        "publication_sequence_number": str(answer.sequence),
        **answer.values,
    }
    status.values = [KeyValue(key=key, value=str(value)) for key, value in pairs.items()]
    array = DiagnosticArray(status=[status])
    array.header.stamp = stamp(stamp_ns_)
    return array


def command_answer(array: DiagnosticArray) -> CommandAnswer | None:
    """The answer in a `sail/command_status` message (None if it holds none)."""
    for status in array.status:
        pairs = {pair.key: pair.value for pair in status.values}
        if "outcome" in pairs and "topic" in pairs:
            return CommandAnswer(
                topic=pairs.pop("topic"),
                outcome=pairs.pop("outcome"),
                message=status.message,
                source_timestamp_ns=int(pairs.pop("source_timestamp_ns")),
                sequence=int(pairs.pop("publication_sequence_number")),
                values=pairs,
            )
    return None
