"""The simulator's log contract: what live and offline logs hold, in one place.

Shared by the live simulator (`sail_ros.nodes.sim`), the recorder, and the
offline tools that write and read the same messages in MCAP logs
(`sail_ros.analysis.log_export`, `log_series`), so "offline logs look like
live logs" holds by construction:

- the topic table `TOPICS` (name, message class, type name, QoS);
- the stamps: simulation time as nanoseconds since the Unix epoch (`stamp_ns`);
- the metadata record names (`PARAMETERS_METADATA`, `PARAMETER_CHANGES_METADATA`,
  `SCENARIO_METADATA`);
- the flat parameter names `sail.<field>` <-> `SailParameters`.

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
from sail_ros.model.parameters import SIMULATOR_NODE

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
CONTROL_ENABLE_SERVICE = "sail/control/enable"  # the hub controller's switch
SIM_NODE = SIMULATOR_NODE  # the node whose params-file section holds the sail


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
CONTROLLER_NODE = "sail_control"  # the free hub's controller (nodes.control)


def controller_status_name(node: str = CONTROLLER_NODE) -> str:
    """The /diagnostics status name of the controller node `node` (its fully qualified
    name): "sail_control: controller"."""
    return f"{node.lstrip('/')}: controller"


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


# the simulator's node that takes the commands (`nodes.sim`): a sender waits for it
SIM_COMMANDS_NODE = SIM_NODE + "_commands"

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


# -- stamps -----------------------------------------------------------------------------------


def stamp(stamp_ns: int) -> Time:
    """`builtin_interfaces/Time` of `stamp_ns` [ns since the Unix epoch]."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def stamp_ns_of(time: Time) -> int:
    """[ns since the Unix epoch] of a `builtin_interfaces/Time` (`stamp`'s inverse)."""
    return int(time.sec) * 1_000_000_000 + int(time.nanosec)


def stamp_ns(epoch_ns: int, t: float) -> int:
    """The stamp [ns] of simulation time `t` [s] on a run that started at `epoch_ns`."""
    return int(epoch_ns) + round(t * 1e9)
