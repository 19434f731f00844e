"""The simulator's parameter changes in a log, each at its simulation time.

The recorder stores each event that changed the simulator's parameters as a
metadata record `sail_sim_parameter_changes` (`sail_ros.bag.recording`: the node,
the node's clock and the log time of the event, and name, old and new value of
each parameter). A log without that record has the events only on
`/parameter_events`: they are read from there, the old values followed from the
first `sail_sim_parameters` record.

A change's time `t_s` is on the log's time axis (`LogSeries.seconds`: simulation
time when the log tells the epoch): that of the state messages received around
it, interpolated between the last before and the first after in log time (the
first or last state's outside them).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from rcl_interfaces.msg import ParameterEvent
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from sail_ros import topics
from sail_ros.analysis.log_series import LogSeries
from sail_ros.bag import BagReader
from sail_ros.bag.recording import ParameterValues, parse_changes_record
from sail_ros.messages.parameters import parameter_update


@dataclasses.dataclass(frozen=True)
class LoggedChange:
    """One parameter's change: values as one line of YAML (None: had none / deleted)."""

    t_s: float  # on the log's time axis [s]
    log_time_ns: int  # when the recorder received it [ns since the Unix epoch]
    time_ns: int  # the simulator's clock at the change [ns]
    name: str
    old: str | None
    new: str | None


def parameter_changes(log: LogSeries, namespace: str | None = None) -> tuple[list, str]:
    """The changes of the simulator's parameters in `log`, in order, and where they
    were found ("" when nowhere: a log without parameter events).

    Args:
        log: the log, as `read_log` read it.
        namespace: the simulator's namespace; None: that of the log's sail.

    Raises:
        ValueError: a changes record does not parse (naming it).
    """
    if namespace is None:
        found = topics.sail_namespaces(log.topic_counts)
        namespace = found[0] if found else "/"
    node = topics.absolute(topics.SIM_NODE, "/" + namespace.strip("/"))
    reader = BagReader(log.path)
    events = [
        parse_changes_record(record)
        for name, record in reader.metadata()
        if name == topics.PARAMETER_CHANGES_METADATA
    ]
    source = topics.PARAMETER_CHANGES_METADATA
    if not events and topics.PARAMETER_EVENTS in reader.topics():
        events, source = _from_parameter_events(reader, node), topics.PARAMETER_EVENTS
    listed = [
        (time_ns, log_time_ns, change)
        for event_node, time_ns, log_time_ns, changes in events
        if event_node == node
        for change in changes
    ]
    if not listed:
        return [], source if events else ""
    when = _state_times(reader, log, namespace)
    return [
        LoggedChange(
            float(np.interp(log_time_ns, *when)), log_time_ns, time_ns, c.name, c.old, c.new
        )
        for time_ns, log_time_ns, c in listed
    ], source


def _from_parameter_events(reader: BagReader, node: str) -> list:
    """(node, time_ns, log_time_ns, changes) of each event of `node` on /parameter_events,
    the values starting from the first `sail_sim_parameters` record."""
    starts = [record for name, record in reader.metadata() if name == topics.PARAMETERS_METADATA]
    values = ParameterValues()
    values.snapshot(starts[0] if starts else {})
    events = []
    for message in reader.messages(topics=[topics.PARAMETER_EVENTS]):
        event = deserialize_message(message.data, ParameterEvent)
        if event.node == node:
            update = parameter_update(event, message.log_time_ns)
            events.append((node, update.time_ns, update.log_time_ns, values.apply(update)))
    return events


def _state_times(reader: BagReader, log: LogSeries, namespace: str) -> tuple:
    """Log times [ns] and their times on the log's axis [s] of the sail's state messages."""
    topic = topics.absolute(topics.BOOM_STATE, "/" + namespace.strip("/"))
    pairs = sorted(
        (
            message.log_time_ns,
            topics.stamp_ns_of(deserialize_message(message.data, JointState).header.stamp),
        )
        for message in reader.messages(topics=[topic])
    )
    if not pairs:
        return np.array([0]), np.array([np.nan])
    log_times, stamps = np.array(pairs, dtype=np.int64).T
    return log_times, log.seconds(stamps)
