"""Time series read back from a simulator log (recorder or `sail-ros deploy`).

Reads the topics of `sail_ros.topics` from an MCAP file or bag folder with
`sail_ros.bag.BagReader`, which also reads a file cut short (a killed
recorder) up to its last complete record. Times are the messages' header
stamps [ns]: simulation time since the run's epoch (`stamp_ns`).

The time axis `t` [s] of every series is `(stamp - origin) / 1e9`. The
origin is the run's epoch (the stamp of simulation time 0) when the log
tells it, so that `t` is simulation time: a `sail-ros deploy` log states it
in its `sail_deploy_scenario` metadata; in a recorder log each /diagnostics
message pairs its stamp with `sim_time_s`. Otherwise (no /diagnostics) the
origin is the first state message's stamp: time since the first sample.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bag import BagReader
from sail_ros.messages import hub as hub_msg
from sail_ros.messages import state as state_msg
from sail_ros.model import SailParameters, yaml_values


@dataclasses.dataclass(frozen=True)
class JointSeries:
    """One JointState topic: stamps [ns] (k,), joint names, position, velocity and
    effort (k, j; (k, 0) where the topic leaves one empty)."""

    stamp_ns: np.ndarray
    names: list[str]
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray


@dataclasses.dataclass(frozen=True)
class LogSeries:
    """What a log holds, as arrays.

    Attributes:
        path: the file or folder read.
        incomplete: files read only up to their last complete record.
        topic_counts: messages per topic.
        parameters: the `sail_sim_parameters` record (name -> YAML text), or None.
        origin_ns: stamp [ns] of t = 0; `simulation_time` says whether that is
            the run's epoch (t is simulation time) or the first sample.
        joints: the JointState topics of the state (`topics.STATE_TOPICS`) that the log
            holds, by relative name; `boom`, `tips`, `modal`, `moments` name them, and
            `field` gives a record field through the message mapping.
        diagnostics: stamps [ns] (k,) and the integrator status values per
            key as text lists, or None when the log has no /diagnostics.
        hub: a free hub's `/sail/hub_state` as stamps [ns] (k,) and (k, 6) values
            (`StateSample.hub`: z_h [m], theta_x, theta_y [rad], their rates), or None.
        scenario: the scenario document of a `sail-ros deploy` log (its
            `sail_deploy_scenario` record), or None.
        namespace: the simulator's namespace in the log ("/", "/sat2").
        hub_commands: the `/sail/hub_wrench_cmd` commands (a controller's, `send`'s) as
            header stamps [ns] (k,) (a controller stamps the sample it answers), log
            times [ns] (k,) and (k, 3) F_z [N], tau_x, tau_y [N m], or None.
        controller: a controller's statuses (`sail_control: controller` in the
            namespace) as stamps [ns] (k,) and their values per key as text lists, or None.
    """

    path: Path
    incomplete: list[Path]
    topic_counts: dict[str, int]
    parameters: dict[str, str] | None
    origin_ns: int
    simulation_time: bool
    joints: dict[str, JointSeries]
    diagnostics: tuple[np.ndarray, dict[str, list[str]]] | None
    scenario: dict | None = None
    namespace: str = "/"  # the simulator's, whose topics were read
    hub: tuple[np.ndarray, np.ndarray] | None = None
    hub_commands: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    controller: tuple[np.ndarray, dict[str, list[str]]] | None = None

    @property
    def boom(self) -> JointSeries | None:
        return self.joints.get(topics.BOOM_STATE)

    @property
    def tips(self) -> JointSeries | None:
        return self.joints.get(topics.TIP_DEFLECTION)

    @property
    def modal(self) -> JointSeries | None:
        return self.joints.get(topics.MODAL_STATE)

    @property
    def moments(self) -> JointSeries | None:
        return self.joints.get(topics.ROOT_MOMENT)

    def field(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """The state record's field `name` (`model.record.SAMPLE_FIELDS`) as stamps [ns]
        (k,) and values (k, n), from the message that carries it
        (`messages.state`); None when the log holds no values of it."""
        if name == state_msg.HUB_FIELD:
            return self.hub
        topic, array = state_msg.JOINT_FIELDS[name]
        series = self.joints.get(topic)
        values = None if series is None else getattr(series, array)
        if values is None or not values.size:
            return None
        return series.stamp_ns, values

    def seconds(self, stamp_ns) -> np.ndarray:
        """Stamps [ns] on the log's time axis [s]."""
        return (np.asarray(stamp_ns, dtype=np.int64) - self.origin_ns) / 1e9

    def sail_parameters(self) -> SailParameters | None:
        """`SailParameters` from the recorded `sail.<field>` values (None if not recorded).

        An automatic membrane count (`n_membrane_modes` 0) is pinned to the one the
        simulator ran: the membrane coordinates of `/sail/modal_state`, or, without them,
        the count its recorded initial lengths resolve.

        Raises ValueError naming the parameter when a recorded value is invalid.
        """
        if not self.parameters:
            return None
        params = topics.sail_parameters_from_record(self.parameters)
        if params is None or params.n_membrane_modes:
            return params
        if self.modal is not None:
            count = sum(name.startswith("membrane_ab_") for name in self.modal.names)
            return params.replace(n_membrane_modes=count) if count else params
        lengths = self.parameters.get("initial_lengths")
        try:
            shortest = min(yaml_values.load(lengths)) if lengths else 0.0
        except (TypeError, ValueError, yaml.YAMLError):
            shortest = 0.0
        return params.resolved(shortest)


def runs_of(t) -> list[slice]:
    """Index ranges of a log's runs in its times `t` [s]: where they increase (a reset
    repeats the last stamp)."""
    breaks = np.flatnonzero(np.diff(t) <= 0) + 1
    edges = [0, *breaks.tolist(), t.size]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _joint_series(messages, topic: str) -> JointSeries | None:
    if not messages:
        return None
    names = list(messages[0].name)
    for message in messages:  # in stamp order
        if list(message.name) != names:  # a reset keeps them: another simulator
            t = (_stamp(message) - _stamp(messages[0])) / 1e9
            raise AnotherRunError(
                f"{topic} changes from {len(names)} to {len(message.name)} joints "
                f"{t:.3f} s after its first message"
            )

    def field(name):
        rows = [getattr(m, name) for m in messages]
        width = len(names) if all(len(row) == len(names) for row in rows) else 0
        values = [row if width else [] for row in rows]
        return np.array(values, dtype=float).reshape(len(messages), width)

    return JointSeries(
        np.array([_stamp(m) for m in messages], dtype=np.int64),
        names,
        field("position"),
        field("velocity"),
        field("effort"),
    )


class AnotherRunError(ValueError):
    """What shows that a log holds more than one run of a simulator."""


def _stamp(message) -> int:
    return topics.stamp_ns_of(message.header.stamp)


def read_log(path, namespace: str | None = None) -> LogSeries:
    """Read the simulator topics and metadata of a log (ValueError if it is not one).

    A log holds one run of the simulator: one that was restarted under the recorder
    (another epoch, other sail parameters, other mode counts: a state of another size)
    is refused, saying what changed, rather than read as one run.

    Args:
        path: MCAP file or bag folder.
        namespace: the simulator's namespace ("/sat2"); None: the only one in the log.
    """
    try:
        return _read_log(path, namespace)
    except AnotherRunError as error:
        raise ValueError(
            f"'{path}' holds more than one run of the simulator: {error} (it started again "
            "under the recorder); a report covers one run: record each run on its own"
        ) from None


def _read_log(path, namespace: str | None) -> LogSeries:
    reader = BagReader(path)
    found = topics.sail_namespaces(reader.topics())
    if namespace is None:
        if len(found) > 1:
            raise ValueError(
                f"'{path}' holds sails in the namespaces {', '.join(found)}: "
                "say which with --namespace"
            )
        namespace = found[0] if found else "/"
    namespace = "/" + namespace.strip("/")
    state_topics = {topics.absolute(name, namespace): name for name in topics.STATE_TOPICS}
    sim_node = topics.absolute(topics.SIM_NODE, namespace)
    parameters, epoch_ns, scenario = None, None, None
    for name, record in reader.metadata():
        if name == topics.PARAMETERS_METADATA:
            _same_sail(parameters, record)
            parameters = dict(record)  # the last record wins (a split re-stores it)
        elif name == topics.SCENARIO_METADATA:
            if "epoch_ns" in record:
                epoch_ns = int(record["epoch_ns"])
            if "scenario" in record:
                try:
                    scenario = yaml_values.load(record["scenario"])
                except yaml.YAMLError:
                    raise ValueError(
                        f"'{path}': its {topics.SCENARIO_METADATA} record is not YAML"
                    ) from None
    joints: dict[str, list] = {name: [] for name in topics.STATE_TOPICS}
    diagnostics: list[DiagnosticArray] = []
    hub: list[Odometry] = []
    wrenches: list[tuple[int, WrenchStamped]] = []
    counts: dict[str, int] = {}
    hub_topic = topics.absolute(topics.HUB_STATE, namespace)
    wrench_topic = topics.absolute(topics.HUB_WRENCH_CMD, namespace)
    wanted = [*state_topics, topics.DIAGNOSTICS, hub_topic, wrench_topic]
    for message in reader.messages(topics=wanted):
        counts[message.topic] = counts.get(message.topic, 0) + 1
        if message.topic == topics.DIAGNOSTICS:
            diagnostics.append(deserialize_message(message.data, DiagnosticArray))
        elif message.topic == hub_topic:
            hub.append(deserialize_message(message.data, Odometry))
        elif message.topic == wrench_topic:
            wrenches.append((message.log_time_ns, deserialize_message(message.data, WrenchStamped)))
        else:
            name = state_topics[message.topic]
            joints[name].append(deserialize_message(message.data, JointState))
    for name in topics.STATE_TOPICS:  # an incomplete file is read in file order
        joints[name].sort(key=lambda m: topics.stamp_ns_of(m.header.stamp))
    series = {
        name: _joint_series(joints[name], topics.absolute(name, namespace))
        for name in topics.STATE_TOPICS
    }
    series = {name: s for name, s in series.items() if s is not None}
    present = list(series.values())
    if not present:
        raise ValueError(
            f"'{path}' holds none of {', '.join(state_topics)}: not a sail "
            "simulator log, or cut before its first state message"
        )
    status = _diagnostics(diagnostics, sim_node)
    if epoch_ns is None and status is not None:
        epoch_ns = _epoch_from_diagnostics(*status)
    first = min(int(s.stamp_ns[0]) for s in present)
    return LogSeries(
        path=Path(path),
        incomplete=reader.incomplete_files,
        topic_counts=counts,
        parameters=parameters,
        origin_ns=first if epoch_ns is None else epoch_ns,
        simulation_time=epoch_ns is not None,
        joints=series,
        diagnostics=status,
        scenario=scenario,
        namespace=namespace,
        hub=_hub_series(hub),
        hub_commands=_wrench_series(wrenches),
        controller=_statuses(
            diagnostics,
            topics.controller_status_name(topics.absolute(topics.CONTROLLER_NODE, namespace)),
        ),
    )


def _wrench_series(messages) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    if not messages:
        return None
    messages.sort(key=lambda pair: pair[0])
    stamps = np.array([topics.stamp_ns_of(m.header.stamp) for _, m in messages], dtype=np.int64)
    logged = np.array([t for t, _ in messages], dtype=np.int64)
    values = np.array([[m.wrench.force.z, m.wrench.torque.x, m.wrench.torque.y]
                       for _, m in messages])  # fmt: skip
    return stamps, logged, values


def _hub_series(messages) -> tuple[np.ndarray, np.ndarray] | None:
    if not messages:
        return None
    messages.sort(key=lambda m: topics.stamp_ns_of(m.header.stamp))
    stamps = np.array([topics.stamp_ns_of(m.header.stamp) for m in messages], dtype=np.int64)
    return stamps, np.array([hub_msg.hub_from_odometry(m) for m in messages])


def _same_sail(before: dict | None, record) -> None:
    """A later `sail_sim_parameters` record (a split's, or a restarted simulator's) must
    give the sail the same values: they are read-only, so only a new start changes them."""
    if before is None:
        return
    changed = [
        f"{name} {before.get(name)} -> {record.get(name)}"
        for name in sorted(set(before) | set(record))
        if name.startswith(topics.SAIL_PREFIX) and before.get(name) != record.get(name)
    ]
    if changed:
        raise AnotherRunError(f"the sail parameters change ({', '.join(changed)})")


EPOCH_SLACK_NS = 1000  # statuses of one run agree on their epoch to round-off


def _epoch_from_diagnostics(stamps: np.ndarray, values: dict[str, list[str]]) -> int | None:
    """Stamp - sim_time_s of the /diagnostics messages that have both (the simulator
    stamps its status with the simulation time of the state), which one run keeps from
    start to end (pauses and resets included).

    Raises:
        AnotherRunError: a status gives another epoch (a simulator started anew).
    """
    epoch = None
    for stamp, text in zip(stamps, values.get(key.SIM_TIME, []), strict=False):
        try:
            this = int(stamp) - round(float(text) * 1e9)
        except ValueError:
            continue
        if epoch is None:
            epoch, first = this, int(stamp)
        elif abs(this - epoch) > EPOCH_SLACK_NS:
            raise AnotherRunError(
                f"its /diagnostics tell another start {(int(stamp) - first) / 1e9:.3f} s "
                f"after the first (epoch {epoch} -> {this} ns)"
            )
    return epoch


def _diagnostics(arrays: list[DiagnosticArray], sim_node: str):
    return _statuses(arrays, topics.integrator_status_name(sim_node))


def _statuses(arrays: list[DiagnosticArray], name: str):
    """The statuses called `name` as stamps [ns] and values per key (text), or None."""
    stamps, values = [], []
    for array in arrays:
        pairs = next(
            ({pair.key: pair.value for pair in status.values} for status in array.status
             if status.name == name),
            None,
        )  # fmt: skip
        if pairs:
            stamps.append(topics.stamp_ns_of(array.header.stamp))
            values.append(pairs)
    if not values:
        return None
    order = np.argsort(stamps, kind="stable")
    keys = sorted({name for pairs in values for name in pairs})
    return (
        np.asarray(stamps, dtype=np.int64)[order],
        {name: [values[i].get(name, "") for i in order] for name in keys},
    )
