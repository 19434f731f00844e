"""Which message carries which field of the state record (`model.record.SAMPLE_FIELDS`).

Every field but a free hub's travels in a JointState array of one state topic; the
hub's six values in `/sail/hub_state` (Odometry, `topics.hub_from_odometry`). The log
reader (`analysis.log_series`) and `watch` read a sample back through this table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sail_ros import topics
from sail_ros.model.record import StateSample

# record field -> (state topic, JointState array that holds it), in record order; the
# topics are `topics.STATE_TOPICS`
JOINT_FIELDS = {
    "lengths": (topics.BOOM_STATE, "position"),
    "rates": (topics.BOOM_STATE, "velocity"),
    "q": (topics.MODAL_STATE, "position"),
    "qd": (topics.MODAL_STATE, "velocity"),
    "tips": (topics.TIP_DEFLECTION, "position"),
    "tip_rates": (topics.TIP_DEFLECTION, "velocity"),
    "root_moments": (topics.ROOT_MOMENT, "effort"),
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
    hub = messages.get(topics.HUB_STATE)
    values[HUB_FIELD] = None if hub is None else topics.hub_from_odometry(hub)
    return StateSample(math.nan, **values)
