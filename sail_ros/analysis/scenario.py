"""Deployment scenarios: how the booms move and how the sail starts, read from YAML.

A scenario file (see config/scenario_reference.yaml) holds::

    scenario:
      description: free text
      duration: 15.0                 # simulated time [s]
      profile:                       # one profile for all booms ...
        type: cycloidal              # cycloidal | waypoints | static
        start: 10.0                  # m, one value or [a, b, c, d]
        end: 15.0                    # m
        duration: 15.0               # s
        t0: 0.0                      # s (optional)
      # ... or one per boom:  profile: {a: {type: ...}, b: ..., c: ..., d: ...}
      initial:                       # optional; default: at rest, undeflected
        mode_state: {a: 0.1}         # boom -> tip deflection [m], first cantilever mode
        q0: {boom_a_mode_2: 0.01}    # coordinate name -> value, or a list of n values
        qd0: [...]                   # velocities, same forms
      snapshots: [0.0, 3.0, 6.0]     # figure times [s] (optional)
      loads:                         # optional: piecewise constant, held until changed
        - {at: 0.0, pressures: [2.0e-3, 0.0, 1.0e-3, 0.0]}   # Pa on ab, bc, cd, da
        - {at: 3.0, tip_forces: [0.0, 0.05, 0.0, 0.0]}       # N at the tips of a..d
        - {at: 7.0, tip_forces: 0.0}                         # one value: all four
    sail:                            # optional: overrides of the sail parameters
      membrane_prestress: 5000.0
      mass_damping: 0.02             # Rayleigh alpha [1/s]; stiffness_damping: beta [s]

Profile types (`sail_ros.model.profiles`):

- `cycloidal`: `start`, `end` [m], `duration` [s], optional `t0` [s];
- `waypoints`: `times` [s], `lengths` [m] (one per time, or 4 per time),
  optional `start_rates`, `end_rates` [m/s];
- `static`: `lengths` [m].

Any profile may add `stop_at` [m] (one or 4 values): a jam, the boom stops
dead where it first reaches that length and holds.

The initial state adds up: every `mode_state` entry, then `q0`. Load steps
land on integration step boundaries (their times join the output grid). Errors name
the offending entry by its path, e.g. `scenario.profile.start`.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from sail_ros.model import (
    CycloidalProfile,
    SailModel,
    StaticProfile,
    WaypointProfile,
    yaml_values,
)
from sail_ros.model.loads import LoadSchedule
from sail_ros.model.profiles import BoomMotion, JammedProfile

BOOMS = ("a", "b", "c", "d")
PROFILE_KEYS = {
    "cycloidal": ({"start", "end", "duration"}, {"t0"}),
    "waypoints": ({"times", "lengths"}, {"start_rates", "end_rates"}),
    "static": ({"lengths"}, set()),
}

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
        loads: the load schedule (`LoadSchedule`), None for an unloaded run.
        sail: overrides of `SailParameters` fields.
        document: the whole scenario as plain data (for logs).
    """

    description: str
    duration: float
    profile: object
    initial: dict
    snapshots: tuple[float, ...]
    sail: dict
    document: dict
    loads: LoadSchedule | None = None

    def initial_state(self, model: SailModel) -> tuple[np.ndarray, np.ndarray]:
        """`(q0, qd0)` for `model` (coordinates [m], velocities [m/s])."""
        q0 = np.zeros(model.n)
        for boom, tip in (self.initial.get("mode_state") or {}).items():
            q0 += model.mode_state(boom, tip)
        q0 += _coordinates(self.initial.get("q0"), model, "scenario.initial.q0")
        qd0 = _coordinates(self.initial.get("qd0"), model, "scenario.initial.qd0")
        return q0, qd0


def load_scenario(path) -> Scenario:
    """Read and validate a scenario YAML file (ValueError names the entry)."""
    path = Path(path)
    document = yaml_values.load_file(path, "scenario")
    try:
        return scenario_from_dict(document)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def reference_scenario() -> Scenario:
    """The reference deployment of model.md §9 (= config/scenario_reference.yaml)."""
    return scenario_from_dict(REFERENCE)


def scenario_from_dict(document) -> Scenario:
    """Validate a scenario document (the YAML structure above)."""
    if not isinstance(document, dict) or not isinstance(document.get("scenario"), dict):
        raise ValueError(f"expected a mapping with a 'scenario' section, got {document!r}")
    _known(document, {"scenario", "sail"}, "top level")
    body = document["scenario"]
    _known(
        body, {"description", "duration", "profile", "initial", "snapshots", "loads"}, "scenario"
    )
    duration = _positive(body.get("duration"), "scenario.duration")
    profile = _motion(body.get("profile"), "scenario.profile")
    initial = body.get("initial") or {}
    if not isinstance(initial, dict):
        raise ValueError(f"scenario.initial must be a mapping, got {initial!r}")
    _known(initial, {"mode_state", "q0", "qd0"}, "scenario.initial")
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
        _finite(tip, f"scenario.initial.mode_state.{boom}")
    snapshots = body.get("snapshots", np.linspace(0.0, duration, 6).tolist())
    if not isinstance(snapshots, list) or not snapshots:
        raise ValueError(
            f"scenario.snapshots must be a non-empty list of times [s], got {snapshots!r}"
        )
    for i, t in enumerate(snapshots):
        _finite(t, f"scenario.snapshots[{i}]")
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
        tuple(float(t) for t in snapshots),
        dict(sail),
        document,
        _loads(body.get("loads"), duration, "scenario.loads"),
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
        if not isinstance(step, dict) or "at" not in step:
            raise ValueError(f"{here} must be a mapping with 'at' [s], got {step!r}")
        _known(step, {"at", "pressures", "tip_forces"}, here)
        t = _finite(step["at"], f"{here}.at")
        if not 0.0 <= t <= duration:
            raise ValueError(f"{here}.at = {t!r} s is outside [0, duration = {duration:g} s]")
        steps.append((t, step.get("pressures"), step.get("tip_forces")))
    try:
        return LoadSchedule(steps)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None


def _motion(spec, where: str):
    if not isinstance(spec, dict):
        raise ValueError(
            f"{where} must be a mapping (type: cycloidal | waypoints | static, "
            f"or one profile per boom a, b, c, d), got {spec!r}"
        )
    if "type" in spec:
        return _profile(spec, where)
    if set(spec) != set(BOOMS):
        raise ValueError(
            f"{where} needs 'type', or one profile for each boom a, b, c, d; "
            f"got keys {sorted(spec)}"
        )
    return BoomMotion(_profile(spec[boom], f"{where}.{boom}") for boom in BOOMS)


def _profile(spec, where: str):
    if not isinstance(spec, dict):
        raise ValueError(f"{where} must be a mapping with a 'type', got {spec!r}")
    kind = spec.get("type")
    if kind not in PROFILE_KEYS:
        raise ValueError(f"{where}.type must be one of {', '.join(PROFILE_KEYS)}, got {kind!r}")
    required, optional = PROFILE_KEYS[kind]
    missing = sorted(required - set(spec))
    if missing:
        raise ValueError(f"{where} ({kind}) needs {', '.join(missing)}")
    _known(spec, required | optional | {"type", "stop_at"}, where)
    arguments = {key: value for key, value in spec.items() if key not in ("type", "stop_at")}
    try:
        if kind == "cycloidal":
            profile = CycloidalProfile(**arguments)
        elif kind == "waypoints":
            profile = WaypointProfile(**arguments)
        else:
            profile = StaticProfile(**arguments)
        if "stop_at" in spec:
            profile = JammedProfile(profile, spec["stop_at"])
        return profile
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None


def _coordinates(spec, model: SailModel, where: str) -> np.ndarray:
    values = np.zeros(model.n)
    if spec is None:
        return values
    if isinstance(spec, dict):
        names = model.coordinate_names
        for name, value in spec.items():
            if name not in names:
                raise ValueError(
                    f"{where}: unknown coordinate {name!r}; coordinates are "
                    f"{names[0]} ... {names[-1]} (SailModel.coordinate_names)"
                )
            values[names.index(name)] = _finite(value, f"{where}.{name}")
        return values
    array = np.asarray(spec, dtype=float)
    if array.shape != (model.n,) or not np.all(np.isfinite(array)):
        raise ValueError(
            f"{where} must be a mapping of coordinate names or {model.n} finite "
            f"values (n_B = {model.n_boom_modes}, n_M = {model.n_membrane_modes}), "
            f"got {len(spec) if hasattr(spec, '__len__') else spec!r} values"
        )
    return array


def _known(mapping: dict, allowed: set, where: str) -> None:
    unknown = sorted(set(mapping) - allowed)
    if unknown:
        raise ValueError(
            f"{where}: unknown key(s) {', '.join(map(repr, unknown))}; "
            f"known: {', '.join(sorted(allowed))}"
        )


def _finite(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _positive(value, where: str) -> float:
    if _finite(value, where) <= 0:
        raise ValueError(f"{where} must be > 0, got {value!r}")
    return float(value)
