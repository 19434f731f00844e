"""The state record: one definition of the sail's state at a time, its fields, units and
what each holds.

`StateSample` (one time) and a run's arrays (the same record, each field stacked over
the output times: `stack`, `take`) come from `SAMPLE_FIELDS`; so do the columns of a
states table (`column_names`, `columns`) and the plain-data view `watch` prints
(`view`). Which message carries which field is `sail_ros.messages.state`, the one
mapping through which the log reader (`LogSeries.field`) and `watch` read a sample back.

The first fields, up to `STEPPER_FIELDS`, are the integrator's own state (`StepperState`);
the others are computed from them (`SailModel.sample`).
"""

from __future__ import annotations

from collections import namedtuple
from typing import NamedTuple

import numpy as np

from sail_ros.model.layout import BOOMS


class SampleField(NamedTuple):
    """One field of the state record.

    Attributes:
        name: the attribute of `StateSample`.
        key: its name in tables and views, with its unit (`tip_deflection_m`).
        unit: SI unit of its values.
        per: what its values run over: "boom" (a..d), "coordinate" (`SailModel.
            coordinate_names`) or "hub" (`HUB_COMPONENTS`).
        doc: what it is.
    """

    name: str
    key: str
    unit: str
    per: str
    doc: str


SAMPLE_FIELDS = (
    SampleField("lengths", "boom_length_m", "m", "boom", "deployed boom length"),
    SampleField("rates", "boom_rate_m_s", "m/s", "boom", "boom extension rate"),
    SampleField(
        "q", "q", "m, rad", "coordinate", "generalised coordinates (a free hub's tilts in rad)"
    ),
    SampleField("qd", "qd", "m/s, rad/s", "coordinate", "generalised velocities"),
    SampleField(
        "tips",
        "tip_deflection_m",
        "m",
        "boom",
        "out-of-plane deflection of the boom tip relative to the hub (+z of the sail frame)",
    ),
    SampleField("tip_rates", "tip_rate_m_s", "m/s", "boom", "rate of the tip deflection"),
    SampleField(
        "root_moments",
        "root_moment_N_m",
        "N m",
        "boom",
        "root bending moment EI u''(0), positive when the boom bends towards +z",
    ),
    SampleField(
        "hub",
        "hub",
        "m, rad, m/s, rad/s",
        "hub",
        "a free hub's heave, tilts and their rates (None when clamped)",
    ),
)
FIELD_NAMES = tuple(field.name for field in SAMPLE_FIELDS)
STEPPER_FIELDS = FIELD_NAMES[:4]  # lengths, rates, q, qd: what the integrator carries
OPTIONAL_FIELDS = ("hub",)  # None when the sail has none

# a free hub's six values, each with its unit (model.md §13.8)
HUB_COMPONENTS = ("z_h_m", "theta_x_rad", "theta_y_rad", "zd_h_m_s", "thd_x_rad_s", "thd_y_rad_s")


def _docstring(title: str, shape: str) -> str:
    lines = [title, "", "Attributes:", f"    t: time [s]{shape}."]
    lines += [f"    {f.name}: {f.doc} [{f.unit}]{shape}." for f in SAMPLE_FIELDS]
    return "\n".join(lines)


StateSample = namedtuple(
    "StateSample", ("t", *FIELD_NAMES), defaults=(None,) * len(OPTIONAL_FIELDS)
)
StateSample.__doc__ = _docstring(
    "The sail's state at time `t`, or (`stack`) over times, each field then with the times first.",
    "",
)
StateSample.__module__ = __name__

StepperState = namedtuple("StepperState", ("t", *STEPPER_FIELDS))
StepperState.__doc__ = (
    "The integrator's own part of a `StateSample`: t [s], lengths [m], rates [m/s], q, qd."
)
StepperState.__module__ = __name__


def stack(samples) -> StateSample:
    """The samples as one record of arrays, each field with the times first (an optional
    field None when it is None in the first sample)."""
    samples = list(samples)
    if not samples:
        raise ValueError("stack: no samples")
    columns = zip(*samples, strict=True)
    return StateSample(*(None if values[0] is None else np.array(values) for values in columns))


def take(states: StateSample, index) -> StateSample:
    """The record of arrays at `index` (an int: one sample; a mask or indices: a record)."""
    return StateSample(*(None if values is None else values[index] for values in states))


def component_names(field: SampleField, coordinate_names=()) -> tuple[str, ...]:
    """The names of a field's values: booms a..d, the coordinates or the hub's."""
    if field.per == "boom":
        return BOOMS
    if field.per == "hub":
        return HUB_COMPONENTS
    return tuple(coordinate_names)


def table_fields(hub: bool) -> tuple[SampleField, ...]:
    """The fields of a states table and a view: per boom, and a free hub's (`hub`)."""
    return tuple(f for f in SAMPLE_FIELDS if f.per == "boom" or (hub and f.per == "hub"))


def column_names(hub: bool) -> list[str]:
    """A states table's columns after the time: `<boom>_<key>` per boom field (a_tip_deflection_m),
    then a free hub's `hub_<component>` (`hub`)."""
    names = []
    for field in table_fields(hub):
        prefix = "hub" if field.per == "hub" else None
        names += [f"{prefix}_{c}" if prefix else f"{c}_{field.key}" for c in component_names(field)]
    return names


def columns(states: StateSample) -> np.ndarray:
    """A record of arrays (k samples) as the table (k, len(column_names(hub))) whose
    columns `column_names` names; NaN where a field is absent (None)."""
    hub = states.hub is not None
    count = len(states.t)
    blocks = []
    for field in table_fields(hub):
        values = getattr(states, field.name)
        width = len(component_names(field))
        blocks.append(np.full((count, width), np.nan) if values is None else np.asarray(values))
    return np.hstack(blocks)


def view(sample: StateSample) -> dict[str, dict[str, float]]:
    """One sample as plain data: `{key: {component: value}}` per table field, the hub's
    only when present."""
    result = {}
    for field in table_fields(sample.hub is not None):
        values, names = getattr(sample, field.name), component_names(field)
        if values is None:
            result[field.key] = dict.fromkeys(names, float("nan"))
        else:
            result[field.key] = dict(zip(names, map(float, values), strict=True))
    return result
