"""The simulator's log contract: what live and offline logs hold, in one place.

Shared by the live simulator (`sail_ros.nodes.sim`), the recorder, and the
offline tools that write and read the same messages in MCAP logs
(`sail_ros.analysis.log_export`, `log_series`), so "offline logs look like
live logs" holds by construction:

- the topic table `TOPICS` (name, message class, type name, QoS);
- the stamps: simulation time as nanoseconds since the Unix epoch (`stamp_ns`);
- the metadata record names (`PARAMETERS_METADATA`, `PARAMETER_CHANGES_METADATA`,
  `SCENARIO_METADATA`);
- the flat parameter names `sail.<field>` <-> `SailParameters` (converted by
  `model.parameters`, re-exported here).

The builders of every message, pure functions of numbers (no node, no clock), are
in `sail_ros.messages`, one module per message. Every quantity is SI. The pages under
`msg_docs/` describe each topic field by field. Nothing here imports rclpy's `Node`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import yaml
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from sail_ros.model import SailParameters, yaml_values
from sail_ros.model.parameters import (  # noqa: F401  the flat names, re-exported
    HUB_FIELDS,
    flat_sail_parameters,
    sail_parameters_from_flat,
)
from sail_ros.names import (  # noqa: F401  the names, re-exported with the table
    BOOM_JOINTS,
    BOOM_LENGTH_CMD,
    BOOM_STATE,
    CLOCK,
    COMMAND_STATUS,
    COMMAND_TOPICS,
    CONTROL_ENABLE_SERVICE,
    CONTROLLER_NODE,
    DEPLOY_CMD,
    DIAGNOSTICS,
    FRAME_ID,
    HUB_STATE,
    HUB_WRENCH_CMD,
    INERTIAL_FRAME_ID,
    LOAD_NAMES,
    MODAL_STATE,
    PARAMETER_CHANGES_METADATA,
    PARAMETER_EVENTS,
    PARAMETERS_METADATA,
    PAUSE_SERVICE,
    PRESSURE_CMD,
    QUADRANT_SURFACES,
    RESET_SERVICE,
    ROOT_JOINTS,
    ROOT_MOMENT,
    SAIL_PREFIX,
    SCENARIO_METADATA,
    SHAPE,
    SIM_COMMANDS_NODE,
    SIM_NODE,
    STATE_TOPICS,
    TIP_DEFLECTION,
    TIP_FORCE_CMD,
    TIP_JOINTS,
    absolute,
    controller_status_name,
    integrator_status_name,
    moved,
    sail_namespaces,
    stamp_ns,
    stamp_ns_of,
)

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
# statuses: 100 are 5 s of them at 20 Hz, 1 s at the highest `diagnostics_rate_hz` (100),
# so a subscriber whose process stalls (as above) still gets every one, a warning among
# them (10 are half a second at 20 Hz)
DIAGNOSTICS_QOS = _reliable(100, DurabilityPolicy.VOLATILE)
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
# what a recorder of the simulator takes by default: everything in the table, and
# the parameter changes
RECORDED_TOPICS = (*TOPICS, PARAMETER_EVENTS)


def yaml_value(value) -> str:
    """A parameter value as one line of YAML: 100.0, true, [1, 2], abc."""
    if not isinstance(value, bool | int | float | str):  # an array; a byte array holds bytes
        value = [item[0] if isinstance(item, bytes) else item for item in value]
    text = yaml.safe_dump(value, default_flow_style=True, width=1 << 30)
    return text.removesuffix("\n...\n").strip()


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


# -- stamps -----------------------------------------------------------------------------------


def stamp(ns: int) -> Time:
    """`builtin_interfaces/Time` of `ns` [ns since the Unix epoch]."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)
