"""When a run's loads change, in a few words for its figures: from a scenario's load
schedule, or from the load commands a live simulator accepted (its answers in the log,
`log_rerun.applied_loads`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.analysis.log_rerun import HeldLoads, applied_loads, solar_pressure
from sail_ros.analysis.log_series import LogSeries
from sail_ros.analysis.scenario import scenario_from_dict
from sail_ros.model.layout import BOOMS, QUADRANT_NAMES

# per load kind: the name and the unit of each component, and the scale to that unit
KINDS = (
    ("pressures", tuple(f"p_{q}" for q in QUADRANT_NAMES), "mPa", 1e3),
    ("tip_forces", tuple(f"F_{b}" for b in BOOMS), "N", 1.0),
    ("hub_force", ("F_z",), "N", 1.0),
    ("hub_torques", ("tau_x", "tau_y"), "N m", 1.0),
)


@dataclasses.dataclass(frozen=True)
class LoadChange:
    """A change of the loads: when [s, on the run's or the log's time axis] and what
    ("F_b 0.05 N", "F_b off", "p_ab 2 mPa, p_cd 1 mPa")."""

    t_s: float
    text: str


def run_description(log: LogSeries) -> str:
    """What a log holds, for its figures' titles: a `sail-ros deploy` log's scenario
    description, a live simulator's run by its log's name."""
    if log.scenario is not None:
        description = scenario_from_dict(log.scenario).description
        return description or f"scenario of {log.path.name}"
    return f"live run, {log.path.name}"


def _components(pressures, tip_forces, hub_wrench=None) -> dict[str, np.ndarray]:
    wrench = np.zeros(3) if hub_wrench is None else np.asarray(hub_wrench, dtype=float)
    return {
        "pressures": np.asarray(pressures, dtype=float),
        "tip_forces": np.asarray(tip_forces, dtype=float),
        "hub_force": wrench[:1],
        "hub_torques": wrench[1:],
    }


def _text(before: dict, after: dict) -> str:
    """The components that differ, with their new values ("off" when zero)."""
    parts = []
    for kind, names, unit, scale in KINDS:
        for name, old, new in zip(names, before[kind], after[kind], strict=True):
            if new != old:
                parts.append(f"{name} {scale * new:.3g} {unit}" if new else f"{name} off")
    return ", ".join(parts)


def _changes(steps) -> list[LoadChange]:
    """`(t, components)` in time order as the changes they make from no load."""
    held, changes = _components(np.zeros(4), np.zeros(4)), []
    for t, values in steps:
        text = _text(held, values)
        if text:
            changes.append(LoadChange(float(t), text))
        held = values
    return changes


def schedule_changes(schedule) -> list[LoadChange]:
    """The changes of a scenario's `LoadSchedule` (none for None)."""
    if schedule is None:
        return []
    return _changes((t, _components(*schedule(t))) for t in schedule.switch_times)


def log_changes(log: LogSeries) -> list[LoadChange]:
    """The changes of the loads of a logged run: a `sail-ros deploy` log's from its
    recorded scenario; a live simulator's its solar pressure from the first sample, each
    accepted load command from when the simulator applied it, and the loads a reset
    zeroes (all but the solar pressure). None without simulation time or without the
    answers' held values (a log whose answers do not hold them)."""
    if log.scenario is not None:
        return schedule_changes(scenario_from_dict(log.scenario).loads)
    if not log.simulation_time or log.boom is None:
        return []
    try:
        commands = applied_loads(log)
    except ValueError:
        return []
    solar = solar_pressure(log)
    t = log.seconds(log.boom.stamp_ns)
    resets = t[1:][np.diff(t) <= 0]
    events = [(float(t[0]), "start", None)] + [(float(r), "reset", None) for r in resets]
    events += [(time, topic, values) for time, topic, values in commands]
    held = HeldLoads()
    steps = []
    for time, what, values in sorted(events, key=lambda event: event[0]):
        if what in ("start", "reset"):
            held.reset()
        else:
            held.apply(what, values)
        components = _components(*held.inputs(solar))
        if steps and steps[-1][0] == time:
            steps.pop()
        steps.append((time, components))
    return _changes(steps)
