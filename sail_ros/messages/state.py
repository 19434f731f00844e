"""The state messages: which message carries which field of the state record
(`model.record.SAMPLE_FIELDS`), their builders, and a sample read back.

Every field but a free hub's travels in a JointState array of one state topic; the
hub's six values in `/sail/hub_state` (Odometry, `messages.hub`). `state_messages` is
the set published at every state sample (its bytes: `messages.cdr.StateSerializer`);
the log reader (`analysis.log_series`) and `watch` read a sample back through
`JOINT_FIELDS`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from sail_ros.messages.hub import hub_from_odometry, hub_state
from sail_ros.model.record import StateSample
from sail_ros.topics import (
    BOOM_JOINTS,
    BOOM_STATE,
    CLOCK,
    FRAME_ID,
    HUB_STATE,
    INERTIAL_FRAME_ID,
    MODAL_STATE,
    ROOT_JOINTS,
    ROOT_MOMENT,
    TIP_DEFLECTION,
    TIP_JOINTS,
    stamp,
)

# record field -> (state topic, JointState array that holds it), in record order; the
# topics are `topics.STATE_TOPICS`
JOINT_FIELDS = {
    "lengths": (BOOM_STATE, "position"),
    "rates": (BOOM_STATE, "velocity"),
    "q": (MODAL_STATE, "position"),
    "qd": (MODAL_STATE, "velocity"),
    "tips": (TIP_DEFLECTION, "position"),
    "tip_rates": (TIP_DEFLECTION, "velocity"),
    "root_moments": (ROOT_MOMENT, "effort"),
}
HUB_FIELD = "hub"  # from `topics.HUB_STATE`, an Odometry


def sample(messages: Mapping[str, object]) -> StateSample:
    """The latest sample from the newest message per topic (`messages`: relative topic
    name -> message): a field whose topic is missing, or whose array the message leaves
    empty, is None; t [s] is NaN (a message's stamp is epoch + t)."""
    values = {}
    for name, (topic, array) in JOINT_FIELDS.items():
        message = messages.get(topic)
        data = None if message is None else getattr(message, array)
        values[name] = np.asarray(data, dtype=float) if data is not None and len(data) else None
    hub = messages.get(HUB_STATE)
    values[HUB_FIELD] = None if hub is None else hub_from_odometry(hub)
    return StateSample(math.nan, **values)


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
