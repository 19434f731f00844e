"""The parameters of node `sail_sim`: the table, and the one validator of a whole set.

Each parameter is declared once from `SPECS` (`parameters.ParamSpec`: the
descriptor text with the unit, range, array sizes, read-only where it fixes
the model's structure or the time grid). `config_from_values` turns a full
set of values into a `SimConfig`, or raises `ConfigError` naming the
parameter; the node calls it at start-up and on every change of a writable
parameter, so the two paths cannot disagree. config/sim.yaml lists the same
defaults.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_ros.model import SailParameters
from sail_ros.model.layout import per_boom
from sail_ros.model.parameters import MAX_BOOM_MODES, MAX_MEMBRANE_MODES
from sail_ros.model.sail_model import cantilever_frequency
from sail_ros.model.stepper import DEFAULT_MAX_STEP, PHASE_PER_STEP
from sail_ros.nodes.commands import Limits
from sail_ros.nodes.parameters import ConfigError, ParamSpec
from sail_ros.topics import SAIL_PREFIX, sail_parameters_from_flat

_DEFAULT_SAIL = SailParameters()
_SAIL_SPECS = [
    (
        "sail_side",
        "side a of the square sail [m]; the fully deployed boom length is a/sqrt(2)",
        0.0,
        1e4,
    ),
    ("boom_bending_stiffness", "bending stiffness EI of each boom [N m^2]", 0.0, 1e12),
    ("boom_linear_density", "mass per length rho_B of each boom [kg/m]", 0.0, 1e6),
    ("membrane_thickness", "film thickness h [m]", 0.0, 1e-2),
    ("membrane_density", "film density rho [kg/m^3]; areal density rho h", 0.0, 1e5),
    ("membrane_prestress", "isotropic film prestress sigma [Pa]; tension N0 = sigma h", 0.0, 1e10),
    ("boom_axial_load", "axial compression P the membrane puts on each boom [N]", 0.0, 1e12),
    ("n_boom_modes", "cantilever modes per boom n_B [-]", 1, MAX_BOOM_MODES),
    ("n_membrane_modes", "clamped-triangle modes per quadrant n_M [-]", 1, MAX_MEMBRANE_MODES),
    (
        "mass_damping",
        "Rayleigh alpha of the damping C_d = alpha M + beta K [1/s]",
        0.0,
        1e6,
    ),
    (
        "stiffness_damping",
        "Rayleigh beta of the damping C_d = alpha M + beta K [s]; a mode of frequency "
        "omega has the damping ratio alpha / (2 omega) + beta omega / 2",
        0.0,
        1e6,
    ),
]

SPECS = [
    ParamSpec(
        SAIL_PREFIX + name,
        getattr(_DEFAULT_SAIL, name),
        f"{text} (docs/model.md §10; fixes the model)",
        True,
        low,
        high,
    )
    for name, text, low, high in _SAIL_SPECS
] + [
    ParamSpec(
        "initial_lengths",
        [10.0],
        "boom lengths at start and after sail/reset [m]: one "
        "value for all booms or four (a, b, c, d), within [min_length, max_length]; a change "
        "applies at the next reset",
        False,
        1e-3,
        1e4,
        sizes=(1, 4),
    ),
    ParamSpec(
        "initial_tip_deflection",
        [0.0, 0.0, 0.0, 0.0],
        "tip deflection of each boom at "
        "start and after sail/reset [m], +z of the sail frame, as that boom's first cantilever "
        "mode; one value or four (a, b, c, d); a change applies at the next reset",
        False,
        -10.0,
        10.0,
        sizes=(1, 4),
    ),
    ParamSpec(
        "min_length",
        1.0,
        "shortest boom length a command may ask for or pass through [m]",
        False,
        1e-3,
        1e4,
    ),
    ParamSpec(
        "max_length",
        70.71,
        "longest boom length a command may ask for or pass through [m] "
        "(default: the 100 m sail fully deployed, a/sqrt(2) rounded down)",
        False,
        1e-3,
        1e4,
    ),
    ParamSpec(
        "max_rate", 1.0, "largest |extension rate| of a commanded motion [m/s]", False, 1e-6, 100.0
    ),
    ParamSpec(
        "max_acceleration",
        0.5,
        "largest |extension acceleration| of a commanded motion [m/s^2]",
        False,
        1e-6,
        100.0,
    ),
    ParamSpec(
        "deploy_duration",
        0.0,
        "duration of a sail/deploy_cmd motion [s]; 0: the fastest "
        "within max_rate and max_acceleration",
        False,
        0.0,
        1e6,
    ),
    ParamSpec(
        "state_rate_hz",
        50.0,
        "boom_state, modal_state, tip_deflection (and /clock) per "
        "second of simulation time [Hz], rounded to whole integration steps",
        False,
        0.01,
        1000.0,
    ),
    ParamSpec(
        "shape_rate_hz",
        5.0,
        "sail/shape markers per second of simulation time [Hz], "
        "rounded to whole integration steps; 0: none",
        False,
        0.0,
        1000.0,
    ),
    ParamSpec(
        "diagnostics_rate_hz",
        1.0,
        "/diagnostics per second of wall time [Hz]; also the "
        "window of the step statistics it reports (the real-time factor is measured over "
        "at least 0.5 s)",
        False,
        0.01,
        100.0,
    ),
    ParamSpec(
        "integration_step",
        0.01,
        "time step of the simulation grid [s]: every sample falls on it; split "
        "further where the shortest boom's first bending mode needs it",
        True,
        1e-4,
        0.2,
    ),
    ParamSpec(
        "max_model_step",
        DEFAULT_MAX_STEP,
        "longest model step while the booms move [s], in whole integration steps "
        "(the samples between are interpolated, cubic Hermite); at rest every "
        "integration step is one exact step; the model's own default",
        True,
        1e-4,
        0.2,
    ),
    ParamSpec(
        "time_scale",
        1.0,
        "simulation seconds per wall-clock second [-]: 1 follows the "
        "wall clock; other values publish /clock; 0 or negative: as fast as possible",
        True,
        -1.0,
        1000.0,
    ),
    ParamSpec(
        "realtime_priority",
        0,
        "real-time priority of the integration thread while paced [-]: 1-99 schedules it "
        "first-in first-out (Linux SCHED_FIFO), ahead of every normally scheduled thread "
        "on the machine, so that a busy machine does not make it late; needs CAP_SYS_NICE "
        "or an rtprio limit (ulimit -r), else a warning and normal scheduling; a time_scale "
        "the model cannot keep up with then takes a core from everything else; 0: normal "
        "scheduling",
        True,
        0,
        99,
    ),
    ParamSpec("frame_id", "sail", "frame of every published state and marker", True),
    ParamSpec(
        "shape_divisions",
        10,
        "mesh subdivisions of each quadrant edge in sail/shape [-]",
        True,
        1,
        50,
    ),
    ParamSpec(
        "max_trajectory_points",
        1000,
        "most points a sail/boom_length_cmd may hold [-]; a longer one is rejected whole "
        "(planning it would hold up the integration)",
        False,
        1,
        100000,
    ),
    ParamSpec(
        "max_pressure",
        0.01,
        "largest |pressure| a sail/pressure_cmd may set on a quadrant [Pa] (solar "
        "radiation pressure at 1 AU is at most 9.1e-6 Pa); also bounds solar_pressure",
        False,
        0.0,
        1e3,
    ),
    ParamSpec(
        "max_tip_force",
        1.0,
        "largest |force| a sail/tip_force_cmd may set at a boom tip [N]",
        False,
        0.0,
        1e4,
    ),
    ParamSpec(
        "solar_pressure",
        0.0,
        "uniform pressure on every quadrant, on top of sail/pressure_cmd [Pa], +z of the "
        "sail frame (an ideal reflector facing the sun at 1 AU: 2 x 1361 W/m^2 / c = "
        "9.08e-6 Pa); within +-max_pressure; applies from the next step",
        False,
        -1e3,
        1e3,
    ),
    ParamSpec(
        "max_substep_rate",
        3200.0,
        "most sub-steps per second of simulation the shortest allowed boom may need "
        "[1/s]: a boom's first bending frequency, which the sub-steps resolve, grows like "
        "1/L^2, so this bounds min_length from below (a sub-step costs ~0.1 ms at the "
        "default mode counts, ~0.4 ms at n_B = n_M = 10)",
        False,
        1.0,
        1e7,
    ),
    ParamSpec(
        "max_queued_commands",
        100,
        "most commands waiting for the simulator at once [-]; one more is dropped, "
        "answered as ignored on sail/command_status and counted in /diagnostics",
        True,
        1,
        10000,
    ),
    ParamSpec(
        "tip_warn_fraction",
        0.1,
        "WARN once a boom-tip deflection exceeds this fraction of its boom's length [-]: "
        "the linear (small-deflection) model is leaving its range",
        False,
        1e-6,
        10.0,
    ),
    ParamSpec(
        "tip_error_fraction",
        0.3,
        "stop the integration with ERROR once a boom-tip deflection exceeds this fraction "
        "of its boom's length [-] (the results mean nothing beyond; sail/reset recovers); "
        "above tip_warn_fraction",
        False,
        1e-6,
        10.0,
    ),
]
SPEC_BY_NAME = {spec.name: spec for spec in SPECS}
DEFAULTS = {spec.name: spec.default for spec in SPECS}


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """Validated parameters of the simulator (SI units; see SPECS)."""

    sail: SailParameters
    initial_lengths: np.ndarray  # (4,) m
    initial_tip_deflection: np.ndarray  # (4,) m
    limits: Limits
    deploy_duration: float
    state_rate_hz: float
    shape_rate_hz: float
    diagnostics_rate_hz: float
    integration_step: float
    max_model_step: float  # s
    time_scale: float
    realtime_priority: int  # 0: normal scheduling
    frame_id: str
    shape_divisions: int
    max_queued_commands: int
    solar_pressure: float  # Pa
    tip_warn_fraction: float  # [-] of the boom length
    tip_error_fraction: float  # [-] of the boom length

    @property
    def as_fast_as_possible(self) -> bool:
        return self.time_scale <= 0.0

    def steps_between(self, rate_hz: float) -> int:
        """Integration steps between two publications at `rate_hz` [Hz of sim time]
        (0: never)."""
        if rate_hz <= 0.0:
            return 0
        return max(1, round(1.0 / (rate_hz * self.integration_step)))


def config_from_values(values: dict) -> SimConfig:
    """A `SimConfig` from parameter name -> value (missing names take their default).

    Raises:
        ConfigError: a value of the wrong type, out of range, or inconsistent
            with another (the message names the parameter and says why).
    """
    values = {**DEFAULTS, **values}
    for name, value in values.items():
        spec = SPEC_BY_NAME.get(name)
        if spec is not None:
            spec.check(value)
    try:
        sail = sail_parameters_from_flat(values)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    limits = Limits(
        float(values["min_length"]),
        float(values["max_length"]),
        float(values["max_rate"]),
        float(values["max_acceleration"]),
        int(values["max_trajectory_points"]),
        float(values["max_pressure"]),
        float(values["max_tip_force"]),
    )
    if abs(values["solar_pressure"]) > limits.max_pressure:
        raise ConfigError(
            f"|solar_pressure| = {abs(values['solar_pressure']):g} Pa exceeds max_pressure = "
            f"{limits.max_pressure:g} Pa"
        )
    if not limits.min_length < limits.max_length:
        raise ConfigError(
            f"min_length ({limits.min_length:g} m) must be below max_length "
            f"({limits.max_length:g} m)"
        )
    _check_affordable(sail, limits.min_length, float(values["max_substep_rate"]))
    lengths = _per_boom(values["initial_lengths"], "initial_lengths")
    if np.any(lengths < limits.min_length) or np.any(lengths > limits.max_length):
        raise ConfigError(
            f"initial_lengths {lengths.tolist()} m must lie in [min_length, "
            f"max_length] = [{limits.min_length:g}, {limits.max_length:g}] m"
        )
    if not values["tip_warn_fraction"] < values["tip_error_fraction"]:
        raise ConfigError(
            f"tip_warn_fraction ({values['tip_warn_fraction']:g}) must be below "
            f"tip_error_fraction ({values['tip_error_fraction']:g})"
        )
    step = float(values["integration_step"])
    for name in ("state_rate_hz", "shape_rate_hz"):
        if values[name] * step > 1.0 + 1e-9:
            raise ConfigError(
                f"{name} = {values[name]:g} Hz is faster than the integration "
                f"step allows (at most 1 / integration_step = {1 / step:g} Hz)"
            )
    return SimConfig(
        sail=sail,
        initial_lengths=lengths,
        initial_tip_deflection=_per_boom(
            values["initial_tip_deflection"], "initial_tip_deflection"
        ),
        limits=limits,
        deploy_duration=float(values["deploy_duration"]),
        state_rate_hz=float(values["state_rate_hz"]),
        shape_rate_hz=float(values["shape_rate_hz"]),
        diagnostics_rate_hz=float(values["diagnostics_rate_hz"]),
        integration_step=step,
        max_model_step=float(values["max_model_step"]),
        time_scale=float(values["time_scale"]),
        realtime_priority=int(values["realtime_priority"]),
        frame_id=str(values["frame_id"]),
        shape_divisions=int(values["shape_divisions"]),
        max_queued_commands=int(values["max_queued_commands"]),
        solar_pressure=float(values["solar_pressure"]),
        tip_warn_fraction=float(values["tip_warn_fraction"]),
        tip_error_fraction=float(values["tip_error_fraction"]),
    )


def _check_affordable(sail: SailParameters, min_length: float, most: float) -> None:
    """Refuse a min_length whose booms would need more than `most` sub-steps per second
    of simulation (each resolves the shortest boom's first bending frequency to
    `PHASE_PER_STEP` rad), whatever the integration step."""
    needed = cantilever_frequency(sail, min_length) / PHASE_PER_STEP
    if needed > most:
        shortest = min_length * math.sqrt(needed / most)  # the rate goes like 1/L^2
        raise ConfigError(
            f"min_length = {min_length:g} m would need {needed:.4g} sub-steps per second "
            f"of simulation, more than max_substep_rate = {most:g}: the shortest "
            f"affordable min_length here is {math.ceil(shortest * 1e3) / 1e3:g} m"
        )


def _per_boom(values, name: str) -> np.ndarray:
    """A list of 1 or 4 values (checked by `_check`) as the model's 4 per-boom values."""
    items = list(values)
    try:
        return per_boom(items[0] if len(items) == 1 else items, name)
    except ValueError as error:
        raise ConfigError(str(error)) from None
