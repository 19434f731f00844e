"""Deployment scenarios: how the booms move and how the sail starts, read from YAML.

A scenario file (see config/scenario_reference.yaml; every key, unit, default and
range in docs/scenarios.md, made from the sections here)::

    scenario:
      description: free text
      duration: 15.0                 # simulated time [s]
      profile:                       # one profile for all booms ...
        type: cycloidal              # cycloidal | waypoints | static
        start: 10.0                  # m, one value or [a, b, c, d]
        end: 15.0                    # m
        duration: 15.0               # s
      # ... or one per boom:  profile: {a: {type: ...}, b: ..., c: ..., d: ...}
      initial:                       # optional; default: at rest, undeflected
        mode_state: {a: 0.1}         # boom -> tip deflection [m], first cantilever mode
        q0: {boom_a_mode_2: 0.01}    # coordinate name -> value, or a list of n values
      snapshots: [0.0, 3.0, 6.0]     # figure times [s] (optional)
      loads:                         # optional: piecewise constant, held until changed
        - {at: 0.0, pressures: [2.0e-3, 0.0, 1.0e-3, 0.0]}   # Pa on ab, bc, cd, da
        - {at: 3.0, tip_forces: [0.0, 0.05, 0.0, 0.0]}       # N at the tips of a..d
    sail:                            # optional: overrides of the sail parameters
      membrane_prestress: 5000.0
    controller:                      # optional: close the loop (free hub; docs/control.md)
      weight_tilt: 2.5e5             # fields of control.DesignSettings; {} for the defaults

Errors name the entry by its path, down to the element:
`scenario.loads[1].tip_forces.b must be a number, got 'x'`. What a scenario may
ask of the booms and loads is the simulator's policy (`check_scenario`): lengths
within [min_length, max_length] along the whole motion, rates and accelerations,
initial tip deflections, loads.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from sail_ros.analysis.schema import (
    Section,
    check_each,
    check_number,
    check_times,
    key,
)
from sail_ros.control.settings import DesignSettings
from sail_ros.model import (
    CycloidalProfile,
    SailModel,
    StaticProfile,
    WaypointProfile,
    yaml_values,
)
from sail_ros.model.layout import BOOMS, QUADRANT_NAMES, Layout
from sail_ros.model.loads import LoadSchedule
from sail_ros.model.profiles import BoomMotion, JammedProfile
from sail_ros.policy import Policy
from sail_ros.spelling import did_you_mean

POSITIVE = {"minimum": 0.0, "above_minimum": True}

TOP = Section(
    "top level",
    "A scenario file holds a `scenario:` section and may hold a `sail:` section.",
    (
        key("scenario", "mapping", "", "the scenario (`scenario`, below)"),
        key(
            "sail", "mapping", "", "overrides of the sail parameters (fields of "
            "`SailParameters`, below); `--set` on the command line wins over them",
            default=None, absent="the sail of `--config` and `--set`",
        ),
        key(
            "controller", "mapping", "", "closes the loop: the hub's controller "
            "(`sail_control`'s design, the table `controller` below; `{}` for its "
            "defaults), run offline as the node runs live (docs/control.md); needs "
            "`free_hub: true`", default=None, absent="open loop",
        ),
    ),
)  # fmt: skip
SCENARIO = Section(
    "scenario",
    "The run: how long, how the booms move, how the sail starts, what loads it.",
    (
        key("description", "text", "", "free text; outputs and figure titles show it",
            default=""),
        key("duration", "number", "s", "simulated time", **POSITIVE),
        key("profile", "mapping", "", "how the booms move: one profile (a mapping with "
            "`type`, below) for all booms, or a mapping `a`, `b`, `c`, `d` of one profile "
            "each"),
        key("initial", "mapping", "", "the state at t = 0 (`scenario.initial`, below)",
            default=None, absent="at rest, undeflected"),
        key("snapshots", "times", "s", "times of the snapshot figure, each within "
            "[0, duration]", default=None, absent="6 times evenly over [0, duration]"),
        key("loads", "list", "", "load steps (`scenario.loads[i]`, below), piecewise "
            "constant: each holds until a later one changes it", default=None,
            absent="no loads"),
    ),
)  # fmt: skip
STOP_AT = key(
    "stop_at", "booms", "m", "a jam: the boom stops dead where it first reaches this length "
    "and holds (a length it never reaches: no jam)", default=None, absent="no jam",
    **POSITIVE,
)  # fmt: skip
PROFILE_TYPES = ("cycloidal", "waypoints", "static")
TYPE_DOC = f"one of {', '.join(PROFILE_TYPES)}"
PROFILES = {
    "cycloidal": Section(
        "scenario.profile, type cycloidal",
        "The smooth deployment of model.md §9: `L = L0 + (Lf - L0) (tau - sin(2 pi tau) / "
        "(2 pi))`, `tau = (t - t0) / T`; rate and acceleration 0 at both ends, peak rate "
        "`2 (Lf - L0) / T`, peak acceleration `2 pi (Lf - L0) / T^2`.",
        (
            key("type", "text", "", TYPE_DOC),
            key("start", "booms", "m", "initial lengths L0; the booms rest there before t0",
                **POSITIVE),
            key("end", "booms", "m", "final lengths Lf; the booms rest there after t0 + "
                "duration", **POSITIVE),
            key("duration", "number", "s", "deployment time T", **POSITIVE),
            key("t0", "number", "s", "start time", default=0.0),
            STOP_AT,
        ),
    ),
    "waypoints": Section(
        "scenario.profile, type waypoints",
        "The booms through waypoints along a cubic spline (continuous rate and "
        "acceleration); they hold the last length after the last time.",
        (
            key("type", "text", "", TYPE_DOC),
            key("times", "times", "s", "waypoint times, at least 2, strictly increasing"),
            key("lengths", "waypoint lengths", "m", "the lengths at those times: one per "
                "time for all booms, or 4 per time", **POSITIVE),
            key("start_rates", "booms", "m/s", "rates at the first waypoint", default=0.0),
            key("end_rates", "booms", "m/s", "rates at the last waypoint (leave 0: the booms "
                "hold after it)", default=0.0),
            STOP_AT,
        ),
    ),
    "static": Section(
        "scenario.profile, type static",
        "The booms held at fixed lengths.",
        (
            key("type", "text", "", TYPE_DOC),
            key("lengths", "booms", "m", "the lengths", **POSITIVE),
        ),
    ),
}  # fmt: skip
INITIAL = Section(
    "scenario.initial",
    "The state at t = 0 adds up: every `mode_state` entry, then `q0`. The tip "
    "deflections it gives must lie within `tip_error_fraction` of each boom's length "
    "(the simulator's `initial_tip_deflection` rule).",
    (
        key("mode_state", "mapping", "m", "boom (`a`, `b`, `c`, `d`) -> its tip deflection, "
            "the boom bent in its first cantilever mode", default=None, absent="none"),
        key("q0", "coordinates", "m", "generalised coordinates: name (`boom_a_mode_1`, "
            "`membrane_ab_mode_2_1`, ...: `SailModel.coordinate_names`) -> value, or a "
            "list of all n", default=None, absent="0"),
        key("qd0", "coordinates", "m/s", "generalised velocities, in the same forms",
            default=None, absent="0"),
    ),
)  # fmt: skip
LOAD = Section(
    "scenario.loads[i]",
    "One load step: from `at` on, the pressures and tip forces given (the others held "
    "from the step before; 0 before the first). Steps land on integration step "
    "boundaries.",
    (
        key("at", "number", "s", "when the step applies: within [0, duration], later than "
            "the step before"),
        key("pressures", "quadrants", "Pa", "uniform pressure on each quadrant, +z of the "
            "sail frame; |value| <= max_pressure", default=None, absent="held"),
        key("tip_forces", "booms", "N", "force at each boom tip, +z; |value| <= "
            "max_tip_force", default=None, absent="held"),
    ),
)  # fmt: skip
SECTIONS = (TOP, SCENARIO, *PROFILES.values(), INITIAL, LOAD)
# what a check names when a scenario comes from a file (`Scenario.labels`)
FILE_LABELS = {"profile": "scenario.profile", "initial": "scenario.initial"}

# model.md §9 and seed Fig. 3: all booms 10 m -> 15 m in 15 s (cycloidal),
# boom a bent in its first mode with a 0.1 m tip deflection.
REFERENCE = {
    "scenario": {
        "description": "reference deployment (model.md §9, seed Fig. 3)",
        "duration": 15.0,
        "profile": {"type": "cycloidal", "start": 10.0, "end": 15.0, "duration": 15.0},
        "initial": {"mode_state": {"a": 0.1}},
        "snapshots": [0.0, 3.0, 6.0, 9.0, 12.0, 15.0],
    }
}


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A validated scenario.

    Attributes:
        description: free text.
        duration: simulated time [s].
        profile: the boom motion, `t -> (lengths, rates, accelerations)`.
        initial: the `initial` mapping as given (applied by `initial_state`).
        snapshots: figure times [s] within [0, duration].
        sail: overrides of `SailParameters` fields.
        document: the whole scenario as plain data (for logs).
        loads: the load schedule (`LoadSchedule`), None for an unloaded run.
        labels: how errors name the profile and the initial state ("profile",
            "initial"): their place in the file, or the options that made them.
        controller: the controller's design (`controller:` section), None: open loop.
    """

    description: str
    duration: float
    profile: object
    initial: dict
    snapshots: tuple[float, ...]
    sail: dict
    document: dict
    loads: LoadSchedule | None = None
    labels: dict = dataclasses.field(default_factory=lambda: dict(FILE_LABELS))
    controller: DesignSettings | None = None

    @property
    def shortest_length(self) -> float:
        """The shortest any boom gets over the profile [m] (what the automatic membrane
        mode count resolves, `SailParameters.resolved`)."""
        return float(np.min(self.profile.extremes()[0]))

    def initial_state(self, model: SailModel) -> tuple[np.ndarray, np.ndarray]:
        """`(q0, qd0)` for `model` (coordinates [m], velocities [m/s])."""
        q0 = np.zeros(model.n)
        for boom, tip in (self.initial.get("mode_state") or {}).items():
            q0 += model.mode_state(boom, tip)
        q0 += _coordinates(self.initial.get("q0"), model, "scenario.initial.q0")
        qd0 = _coordinates(self.initial.get("qd0"), model, "scenario.initial.qd0")
        return q0, qd0

    def check_coordinates(self, layout: Layout) -> None:
        """ValueError if the initial state names a coordinate `layout` lacks or gives the
        wrong number of values: checked before a model's integrals are computed."""
        for field in ("q0", "qd0"):
            _coordinates(self.initial.get(field), layout, f"scenario.initial.{field}")


def load_scenario(path, check_points=None) -> Scenario:
    """Read and validate a scenario YAML file (ValueError names the entry);
    `check_points` as in `scenario_from_dict`."""
    path = Path(path)
    document = yaml_values.load_file(path, "scenario")
    try:
        return scenario_from_dict(document, check_points=check_points)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def _what(document) -> str:
    """What a document that is no scenario holds, in a few words: its top-level keys (a
    study file: 'study'), or its type."""
    if isinstance(document, dict):
        keys = ", ".join(repr(key) for key in list(document)[:5])
        more = ", ..." if len(document) > 5 else ""
        hint = " (a study file: sail-ros montecarlo runs it)" if "study" in document else ""
        return f"a mapping of {keys}{more}{hint}" if document else "an empty mapping"
    return f"a {type(document).__name__}"


def scenario_from_dict(document, labels: dict | None = None, check_points=None) -> Scenario:
    """Validate a scenario document (the YAML structure above); `labels` as
    `Scenario.labels`. `check_points(count, what)` (`Policy.check_points`), if given,
    checks the number of each waypoint profile's points before anything is made of them."""
    if not isinstance(document, dict) or not isinstance(document.get("scenario"), dict):
        raise ValueError(f"expected a mapping with a 'scenario' section, got {_what(document)}")
    TOP.check_keys(document, "top level")
    body = SCENARIO.check_keys(document["scenario"], "scenario")
    duration = SCENARIO.number(body, "duration", "scenario")
    profile = _motion(body["profile"], "scenario.profile", check_points)
    initial = INITIAL.check_keys(body.get("initial") or {}, "scenario.initial")
    modes = initial.get("mode_state") or {}
    if not isinstance(modes, dict):
        raise ValueError(
            f"scenario.initial.mode_state must map booms (a, b, c, d) to tip "
            f"deflections [m], got {modes!r}"
        )
    for boom, tip in modes.items():
        if boom not in BOOMS:
            raise ValueError(
                f"scenario.initial.mode_state: boom must be one of a, b, c, d, got {boom!r}"
            )
        check_number(tip, f"scenario.initial.mode_state.{boom}", INITIAL["mode_state"].spec)
    for name in ("q0", "qd0"):  # the values now; the names and counts with the model
        _coordinate_values(initial.get(name), f"scenario.initial.{name}", INITIAL[name].spec)
    snapshots = body.get("snapshots", np.linspace(0.0, duration, 6).tolist())
    times = check_times(snapshots, "scenario.snapshots", SCENARIO["snapshots"].spec)
    for i, t in enumerate(times):
        if not 0.0 <= t <= duration:
            raise ValueError(
                f"scenario.snapshots[{i}] = {t!r} s is outside [0, duration = {duration:g} s]"
            )
    sail = document.get("sail") or {}
    if not isinstance(sail, dict):
        raise ValueError(f"sail must be a mapping of SailParameters fields, got {sail!r}")
    return Scenario(
        str(body.get("description", "")),
        duration,
        profile,
        dict(initial),
        tuple(times),
        dict(sail),
        document,
        _loads(body.get("loads"), duration, "scenario.loads"),
        {**FILE_LABELS, **(labels or {})},
        controller_settings((document["controller"] or {}) if "controller" in document else None),
    )


def controller_settings(section) -> DesignSettings | None:
    """The `controller:` section as `DesignSettings` (None: none); a ValueError names
    the key (`controller.weight_tilt must be finite, got nan`) or the nearest one."""
    if section is None:
        return None
    if not isinstance(section, dict):
        raise ValueError(
            f"controller must be a mapping of the controller's fields, got {section!r}"
        )
    known = DesignSettings.field_names()
    for name in section:
        if name not in known:
            hint = did_you_mean(str(name), known)
            raise ValueError(f"controller: unknown key {name!r}{hint}")
    try:
        return DesignSettings(**section)
    except ValueError as error:
        raise ValueError(f"controller.{error}") from None


def check_scenario(scenario: Scenario, model: SailModel, policy: Policy) -> None:
    """What the simulator would refuse, refused: the sail's range of lengths
    (`Policy.check_sail`); every boom's length, |rate| and |acceleration| along the
    whole motion (`Policy.check_motion` on the profile's `extremes`); the loads of every
    step (`Policy.check_load`); the initial tip deflections (`Policy.check_initial_tips`).

    Raises:
        ValueError: the first value outside, named by its place and with its limit.
    """
    policy.check_sail(model.params)
    policy.check_motion(scenario.profile, model.params, what=scenario.labels["profile"])
    if scenario.loads is not None:
        for i, t in enumerate(scenario.loads.switch_times):
            pressures, forces = scenario.loads(t)
            for values, names, what, pressure in (
                (pressures, QUADRANT_NAMES, "pressures", True),
                (forces, BOOMS, "tip_forces", False),
            ):
                for name, value in zip(names, values, strict=True):
                    policy.check_load(f"scenario.loads[{i}].{what}.{name}", value, pressure)
    q0, _ = scenario.initial_state(model)
    lengths = np.asarray(scenario.profile(0.0)[0], dtype=float) * np.ones(4)
    policy.check_initial_tips(
        model.tip_deflections(q0), lengths, f"{scenario.labels['initial']}: tip deflection"
    )


def _loads(spec, duration: float, where: str) -> LoadSchedule | None:
    if spec is None:
        return None
    if not isinstance(spec, list) or not spec:
        raise ValueError(
            f"{where} must be a list of steps {{at: s, pressures: Pa, tip_forces: N}}, got {spec!r}"
        )
    steps = []
    for i, step in enumerate(spec):
        here = f"{where}[{i}]"
        LOAD.check_keys(step, here)
        t = LOAD.number(step, "at", here)
        if not 0.0 <= t <= duration:
            raise ValueError(f"{here}.at = {t!r} s is outside [0, duration = {duration:g} s]")
        pressures, forces = step.get("pressures"), step.get("tip_forces")
        if pressures is not None:
            pressures = check_each(
                pressures, f"{here}.pressures", QUADRANT_NAMES, LOAD["pressures"].spec
            )
        if forces is not None:
            forces = check_each(forces, f"{here}.tip_forces", BOOMS, LOAD["tip_forces"].spec)
        steps.append((t, pressures, forces))
    try:
        return LoadSchedule(steps)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None


def _motion(spec, where: str, check_points=None):
    if not isinstance(spec, dict):
        raise ValueError(
            f"{where} must be a mapping (type: cycloidal | waypoints | static, "
            f"or one profile per boom a, b, c, d), got {spec!r}"
        )
    if "type" in spec:
        return _profile(spec, where, check_points)
    if set(spec) != set(BOOMS):
        raise ValueError(
            f"{where} needs 'type', or one profile for each boom a, b, c, d; "
            f"got keys {sorted(spec)}"
        )
    return BoomMotion(_profile(spec[boom], f"{where}.{boom}", check_points) for boom in BOOMS)


def _profile(spec, where: str, check_points=None):
    if not isinstance(spec, dict):
        raise ValueError(f"{where} must be a mapping with a 'type', got {spec!r}")
    kind = spec.get("type")
    if kind not in PROFILES:
        raise ValueError(f"{where}.type must be one of {', '.join(PROFILES)}, got {kind!r}")
    section = PROFILES[kind]
    section.check_keys(spec, f"{where} ({kind})")
    times = spec.get("times")
    if check_points is not None and kind == "waypoints" and isinstance(times, list):
        check_points(len(times), f"{where}.times")
    values = {}
    for entry in section.keys:
        if entry.name == "type" or (entry.name not in spec and entry.default is None):
            continue
        value = spec.get(entry.name, entry.default)
        here = f"{where}.{entry.name}"
        if entry.kind == "booms":
            values[entry.name] = check_each(value, here, BOOMS, entry.spec)
        elif entry.kind == "times":
            values[entry.name] = check_times(value, here, entry.spec, at_least=2)
        elif entry.kind == "waypoint lengths":
            values[entry.name] = _waypoint_lengths(value, here, entry.spec)
        else:
            values[entry.name] = check_number(value, here, entry.spec)
    stop_at = values.pop("stop_at", None)
    try:
        if kind == "cycloidal":
            profile = CycloidalProfile(**values)
        elif kind == "waypoints":
            profile = WaypointProfile(**values)
        else:
            profile = StaticProfile(**values)
        return profile if stop_at is None else JammedProfile(profile, stop_at)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None


def _waypoint_lengths(value, where: str, spec) -> list:
    """Per waypoint one length [m] for all booms or 4, each checked and named; as one
    length per waypoint, or 4 per waypoint if any has 4."""
    if not isinstance(value, list) or not value:
        raise ValueError(f"{where} must be a list of lengths, one per time, got {value!r}")
    checked = [check_each(item, f"{where}[{i}]", BOOMS, spec) for i, item in enumerate(value)]
    if any(isinstance(item, list) for item in value):
        return [item.tolist() for item in checked]
    return [float(item[0]) for item in checked]


def _coordinate_values(spec, where: str, unit_spec) -> list[tuple[object, float]]:
    """(name or index, value) of a mapping of coordinate names or a list of values, each
    value checked and named by its place."""
    if spec is None:
        return []
    if isinstance(spec, dict):
        return [(name, check_number(v, f"{where}.{name}", unit_spec)) for name, v in spec.items()]
    if not isinstance(spec, list):
        raise ValueError(f"{where} must be a mapping of coordinate names or a list, got {spec!r}")
    return [(i, check_number(v, f"{where}[{i}]", unit_spec)) for i, v in enumerate(spec)]


def _coordinates(spec, model: SailModel | Layout, where: str) -> np.ndarray:
    values = np.zeros(model.n)
    entries = _coordinate_values(spec, where, INITIAL["q0"].spec)
    if isinstance(spec, dict):
        names = model.coordinate_names
        for name, value in entries:
            if name not in names:
                raise ValueError(
                    f"{where}: unknown coordinate {name!r}; coordinates are "
                    f"{names[0]} ... {names[-1]} (SailModel.coordinate_names)"
                )
            values[names.index(name)] = value
    elif spec is not None:
        if len(entries) != model.n:
            raise ValueError(
                f"{where} must be a mapping of coordinate names or {model.n} values (n_B = "
                f"{model.n_boom_modes}, n_M = {model.n_membrane_modes}), got {len(entries)}"
            )
        values[:] = [value for _, value in entries]
    return values
