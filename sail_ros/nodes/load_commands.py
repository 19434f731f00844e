"""The load commands: pressures on the quadrants and forces at the boom tips.

`sail/pressure_cmd` and `sail/tip_force_cmd` are `sensor_msgs/JointState`
messages naming what they load (`quadrant_ab` ... / `boom_a` ...) with the
value in `effort` (Pa / N, +z of the sail frame). Named values change, the
others are held. A command is checked whole before anything changes: an
unknown or repeated name, a missing or non-finite value, or one beyond the
limit rejects it with the reason (`CommandError`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sail_ros import topics
from sail_ros.nodes.commands import CommandError


class LoadChange(NamedTuple):
    """An accepted load command: the new values (4,) of the loaded kind, and a summary."""

    values: np.ndarray
    summary: str


def plan_load(topic: str, message, current: np.ndarray, limit: float) -> LoadChange:
    """The loads after `message` on `topic` (PRESSURE_CMD or TIP_FORCE_CMD).

    Args:
        topic: which load command.
        message: a JointState-like object with `name` and `effort`.
        current: the values held now (4,), [Pa] or [N].
        limit: largest |value| allowed (`max_pressure` [Pa] / `max_tip_force` [N]).

    Raises:
        CommandError: why the command is refused; nothing changes.
    """
    known = topics.LOAD_NAMES[topic]
    unit, parameter = (
        ("Pa", "max_pressure") if topic == topics.PRESSURE_CMD else ("N", "max_tip_force")
    )
    names, values = list(message.name), list(message.effort)
    if not names:
        raise CommandError(f"names nothing to load; names are {', '.join(known)}")
    if len(values) != len(names):
        raise CommandError(
            f"has {len(names)} name(s) but {len(values)} effort value(s): one value per name"
        )
    unknown = [name for name in names if name not in known]
    if unknown:
        raise CommandError(
            f"unknown name(s) {', '.join(map(repr, unknown))}; names are {', '.join(known)}"
        )
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise CommandError(f"names {', '.join(repeated)} more than once")
    new = np.array(current, dtype=float)
    for name, value in zip(names, values, strict=True):
        value = float(value)
        if not math.isfinite(value):
            raise CommandError(f"{name} = {value} {unit} is not finite")
        if abs(value) > limit:
            raise CommandError(
                f"|{name}| = {abs(value):g} {unit} exceeds {parameter} = {limit:g} {unit}"
            )
        new[known.index(name)] = value
    summary = ", ".join(f"{name} = {new[known.index(name)]:g} {unit}" for name in names)
    return LoadChange(new, summary + " (others held)" if len(names) < 4 else summary)
