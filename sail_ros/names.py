"""The simulator's names without ROS: topics, joints, nodes, metadata records, stamps,
and the answers to commands.

What the log contract (`sail_ros.topics`, `sail_ros.messages`) and the simulator without
ROS (`sail_ros.runtime`) share; importing it loads no rclpy and no message package.
`topics` adds the message types and QoS, `messages` the builders.
"""

from __future__ import annotations

from typing import NamedTuple

from sail_ros.model.parameters import SAIL_PREFIX, SIMULATOR_NODE  # noqa: F401  (SAIL_PREFIX re-exported)

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


def integrator_status_name(node: str = SIM_NODE) -> str:
    """The /diagnostics status name of the simulator node `node` (its fully qualified
    name, or a name in the root namespace): "sail_sim: integrator",
    "sat2/sail_sim: integrator"; /diagnostics is global, the name tells sails apart."""
    return f"{node.lstrip('/')}: integrator"


CONTROLLER_NODE = "sail_control"  # the free hub's controller (nodes.control)


def controller_status_name(node: str = CONTROLLER_NODE) -> str:
    """The /diagnostics status name of the controller node `node` (its fully qualified
    name): "sail_control: controller"."""
    return f"{node.lstrip('/')}: controller"


# the simulator's node that takes the commands (`nodes.sim`): a sender waits for it
SIM_COMMANDS_NODE = SIM_NODE + "_commands"
# what the simulator publishes at every state sample (and /clock with them when it runs one)
STATE_TOPICS = (BOOM_STATE, MODAL_STATE, TIP_DEFLECTION, ROOT_MOMENT)
# what the simulator takes commands on (and HUB_WRENCH_CMD with a free hub)
COMMAND_TOPICS = (BOOM_LENGTH_CMD, DEPLOY_CMD, PRESSURE_CMD, TIP_FORCE_CMD)
# ROS's record of every parameter change, with its time and node (rcl_interfaces/ParameterEvent)
PARAMETER_EVENTS = "/parameter_events"

# -- metadata records ---------------------------------------------------------------------------

PARAMETERS_METADATA = "sail_sim_parameters"  # the simulator's parameters, name -> YAML text
# one record per parameter event that changed them: node, times, {name, old, new} list
PARAMETER_CHANGES_METADATA = "sail_sim_parameter_changes"
SCENARIO_METADATA = "sail_deploy_scenario"  # an offline run: its scenario (YAML) and epoch_ns

# -- stamps -------------------------------------------------------------------------------------


def stamp_ns_of(time) -> int:
    """[ns since the Unix epoch] of a `builtin_interfaces/Time` (`stamp`'s inverse)."""
    return int(time.sec) * 1_000_000_000 + int(time.nanosec)


def stamp_ns(epoch_ns: int, t: float) -> int:
    """The stamp [ns] of simulation time `t` [s] on a run that started at `epoch_ns`."""
    return int(epoch_ns) + round(t * 1e9)


# -- the answers to commands -------------------------------------------------------------------

ACCEPTED, REJECTED, IGNORED = "accepted", "rejected", "ignored"
SUPERSEDED = "superseded"  # a newer command replaced it before it started
# value of an accepted load command's answer: the four values held from then on
# ("[0.002, 0.0, 0.0, 0.0]", Pa or N), so a log tells every load from the answers alone
LOADS_HELD = "loads_held"
# value of every answer: how many subscriptions of the command's topic the simulator's
# graph showed when it answered (its own two, a recorder's, ...); a sender keeps its
# publisher until as many have the command (`SimClient.close`)
SUBSCRIBERS = "subscribers"


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
