"""The simulator's configuration: three tables, one validator of a whole set.

Every parameter of node `sail_sim` is a field of one of three tables, declared
once with its unit, range and meaning (`model.fields.setting`):

- `sail.<field>`: the sail (`SailParameters`; read-only: they fix the model);
- the policy (`sail_ros.policy.Policy`: limits and alarms, shared with the tools);
- `SimSettings`: the simulator's own (time grid, rates, initial state, ...).

`config_from_values` turns a full set of values (parameter name -> value) into a
`SimConfig`, or raises `ConfigError` naming the parameter; the node calls it at
start-up and on every change of a writable parameter, so the two paths cannot
disagree. `PARAMETERS` lists every parameter (name, field) for the node to
declare; config/sim.yaml holds the same defaults (tested).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL
from sail_ros.model import SailParameters
from sail_ros.model.fields import (
    ConfigError,
    Setting,
    check_fields,
    default_of,
    fields_of,
    setting,
)
from sail_ros.model.layout import per_boom
from sail_ros.model.parameters import LIVE_DEFAULTS, MAX_MEMBRANE_MODES, SAIL_PREFIX
from sail_ros.policy import Policy


@dataclasses.dataclass(frozen=True)
class SimSettings:
    """The simulator's own settings (SI units)."""

    initial_lengths: list = setting(
        [10.0], "m", "boom lengths at start and after sail/reset: one value for all booms or "
        "four (a, b, c, d), within [min_length, max_length]; a change applies at the next "
        "reset", minimum=1e-3, maximum=1e4, read_only=False, sizes=(1, 4),
    )  # fmt: skip
    initial_tip_deflection: list = setting(
        [0.0, 0.0, 0.0, 0.0], "m", "tip deflection of each boom at start and after "
        "sail/reset, +z of the sail frame, as that boom's first cantilever mode; one value "
        "or four (a, b, c, d), within tip_error_fraction of the boom's length; a change "
        "applies at the next reset", minimum=-1e4, maximum=1e4, read_only=False,
        sizes=(1, 4),
    )  # fmt: skip
    initial_hub_velocity: list = setting(
        [0.0, 0.0, 0.0], "m/s, rad/s", "the free hub's heave rate and tilt rates (zd_h, "
        "thd_x, thd_y) at start and after sail/reset; the hub starts at the inertial frame; "
        "a change applies at the next reset", minimum=-1e3, maximum=1e3, read_only=False,
        sizes=(3,),
    )  # fmt: skip
    deploy_duration: float = setting(
        0.0, "s", "duration of a sail/deploy_cmd motion; 0: the fastest within max_rate and "
        "max_acceleration", minimum=0.0, maximum=1e6, read_only=False,
    )  # fmt: skip
    state_rate_hz: float = setting(
        50.0, "Hz", "boom_state, modal_state, tip_deflection, root_moment (and /clock) per "
        "second of simulation time, rounded to whole integration steps", minimum=0.01,
        maximum=1000.0, read_only=False,
    )  # fmt: skip
    shape_rate_hz: float = setting(
        5.0, "Hz", "sail/shape markers per second of simulation time, rounded to whole "
        "integration steps; 0: none", minimum=0.0, maximum=1000.0, read_only=False,
    )  # fmt: skip
    diagnostics_rate_hz: float = setting(
        1.0, "Hz", "/diagnostics per second of wall time; also the window of the step "
        "statistics it reports (the real-time factor is measured over at least 0.5 s)",
        minimum=0.01, maximum=100.0, read_only=False,
    )  # fmt: skip
    integration_step: float = setting(
        0.01, "s", "time step of the simulation grid: every sample falls on it; split "
        "further where the shortest boom's first bending mode needs it", minimum=1e-4,
        maximum=0.2,
    )  # fmt: skip
    max_model_step: float = setting(
        DEFAULT_MAX_STEP, "s", "longest model step while the booms move, in whole "
        "integration steps (the samples between are interpolated; model_rtol chooses "
        "the steps below it); at rest every integration step is one exact step; the "
        "model's own default", minimum=1e-4, maximum=2.0,
    )  # fmt: skip
    model_rtol: float = setting(
        DEFAULT_RTOL, "-", "local error allowed per moving model step on tips, root "
        "moments and their rates, relative to each one's peak so far; the model's own "
        "default (whole runs within 0.2 % of peak); 0: fixed steps of max_model_step "
        "(and the resolved frequency's bound), no estimate", minimum=0.0, maximum=0.1,
    )  # fmt: skip
    time_scale: float = setting(
        1.0, "-", "simulation seconds per wall-clock second: 1 follows the wall clock; other "
        "values publish /clock; 0 or negative: as fast as possible", minimum=-1.0,
        maximum=1000.0,
    )  # fmt: skip
    realtime_priority: int = setting(
        0, "-", "real-time priority of the integration thread while paced: 1-99 schedules "
        "it first-in first-out (Linux SCHED_FIFO), ahead of every normally scheduled thread "
        "on the machine, so that a busy machine does not make it late; needs CAP_SYS_NICE "
        "or an rtprio limit (ulimit -r), else a warning and normal scheduling; 0: normal "
        "scheduling", minimum=0, maximum=99,
    )  # fmt: skip
    frame_id: str = setting("sail", "", "frame of every published state and marker")
    inertial_frame_id: str = setting(
        "sail_inertial", "", "the inertial frame sail/hub_state is given in (free hub)"
    )
    shape_divisions: int = setting(
        10, "-", "mesh subdivisions of each quadrant edge in sail/shape", minimum=1, maximum=50
    )
    max_queued_commands: int = setting(
        100, "-", "most commands waiting for the simulator at once; a burst that fills them "
        "has a tick take them at once and waits for it (at most 0.1 s), then one more is "
        "rejected on sail/command_status and counted in /diagnostics (a motion command a "
        "newer one replaces before it started is answered superseded and leaves the queue)",
        minimum=1, maximum=10000,
    )  # fmt: skip
    command_wait_s: float = setting(
        0.0, "s", "with a controller closing the loop on a free hub (sail_control): how long "
        "of wall time the simulation waits, before a step, for a hub wrench command acting "
        "at or before that step's sample (stamped so), then goes on without it (counted); "
        "the clock waits too, so the run is the same however late the commands come; 0: "
        "never waits", minimum=0.0, maximum=10.0, read_only=False,
    )  # fmt: skip
    solar_pressure: float = setting(
        0.0, "Pa", "uniform pressure on every quadrant, on top of sail/pressure_cmd, +z of "
        "the sail frame (an ideal reflector facing the sun at 1 AU: 2 x 1361 W/m^2 / c = "
        "9.08e-6 Pa); within +-max_pressure; applies from the next step", minimum=-1e3,
        maximum=1e3, read_only=False,
    )  # fmt: skip

    def __post_init__(self):
        check_fields(self)


# (prefix, table): every simulator parameter is `prefix + field name` of one table
TABLES = (("", SimSettings), ("", Policy), (SAIL_PREFIX, SailParameters))
# name -> dataclass field, in declaration order
PARAMETERS = {prefix + field.name: field for prefix, table in TABLES for field in fields_of(table)}
# the simulator's own defaults where they differ from the tables' (`LIVE_DEFAULTS`)
SIM_DEFAULTS = {SAIL_PREFIX + name: value for name, value in LIVE_DEFAULTS.items()}
DEFAULTS = {name: SIM_DEFAULTS.get(name, default_of(field)) for name, field in PARAMETERS.items()}
SETTINGS = [  # for the node
    dataclasses.replace(Setting.of(name, field), default=DEFAULTS[name])
    for name, field in PARAMETERS.items()
]


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """Validated parameters of the simulator: the sail, the policy, the settings."""

    sail: SailParameters
    policy: Policy
    settings: SimSettings
    initial_lengths: np.ndarray  # (4,) m
    initial_tip_deflection: np.ndarray  # (4,) m
    initial_hub_velocity: np.ndarray  # (3,) m/s, rad/s, rad/s (free hub)

    def __getattr__(self, name):  # the settings read as the configuration's own
        if name == "settings":  # not set yet (a copy being made)
            raise AttributeError(name)
        return getattr(self.settings, name)

    @property
    def resolved_sail(self) -> SailParameters:
        """The sail the model is built with: an automatic membrane count resolved at the
        shortest of the initial lengths (`SailParameters.resolved`).

        Raises:
            ConfigError: the automatic count there is more than `MAX_MEMBRANE_MODES` (a
                model that big cannot run in real time, and a capped one is not converged).
        """
        shortest = float(self.initial_lengths.min())
        sail = self.sail.resolved(shortest)
        if not sail.n_membrane_modes and sail.membrane_mode_need > MAX_MEMBRANE_MODES:
            raise ConfigError(
                f"initial_lengths = {self.initial_lengths.tolist()} m: the automatic membrane "
                f"count at {sail.resolved_length:g} m is {sail.membrane_mode_need} modes per "
                f"quadrant, more than {MAX_MEMBRANE_MODES}; start the booms longer, or set "
                f"sail.n_membrane_modes or sail.resolved_length"
            )
        return sail

    def live_counts_note(self) -> str | None:
        """The start-up line that says the simulator keeps fewer membrane modes than the
        offline tools would here (its default `membrane_band`), or None."""
        sail, offline_band = self.sail, SailParameters().membrane_band
        if sail.n_membrane_modes or sail.membrane_band == offline_band:
            return None
        shortest = float(self.initial_lengths.min())
        offline = sail.replace(membrane_band=offline_band).resolved(shortest).membrane_modes
        return (
            f"membrane_band {sail.membrane_band:g} keeps {self.resolved_sail.membrane_modes} "
            f"membrane modes per quadrant where the offline tools' {offline_band:g} keeps "
            f"{offline}, so that the model steps in real time; `sail-ros deploy --set "
            f"membrane_band={sail.membrane_band:g} --convergence` says how far such a run's "
            "peaks are from converged (docs/model.md §10.1)"
        )

    @property
    def as_fast_as_possible(self) -> bool:
        return self.settings.time_scale <= 0.0

    def steps_between(self, rate_hz: float) -> int:
        """Integration steps between two publications at `rate_hz` [Hz of sim time]
        (0: never)."""
        if rate_hz <= 0.0:
            return 0
        return max(1, round(1.0 / (rate_hz * self.settings.integration_step)))


def config_from_values(values: dict) -> SimConfig:
    """A `SimConfig` from parameter name -> value (missing names take their default).

    Raises:
        ConfigError: a value of the wrong type, out of range, or inconsistent
            with another (the message names the parameter and says why).
    """
    values = {**DEFAULTS, **values}
    try:
        settings, policy, sail = (
            _table(table, prefix, values) for prefix, table in TABLES
        )  # fmt: skip
        policy.check_sail(sail)
        lengths = _per_boom(settings.initial_lengths, "initial_lengths")
        policy.check_lengths(lengths, "initial_lengths", sail)
        tips = _per_boom(settings.initial_tip_deflection, "initial_tip_deflection")
        policy.check_initial_tips(tips, lengths, "initial_tip_deflection")
        if abs(settings.solar_pressure) > policy.max_pressure:
            raise ValueError(
                f"|solar_pressure| = {abs(settings.solar_pressure):g} Pa exceeds max_pressure = "
                f"{policy.max_pressure:g} Pa"
            )
    except ValueError as error:
        raise ConfigError(str(error)) from None
    step = settings.integration_step
    for name in ("state_rate_hz", "shape_rate_hz"):
        if getattr(settings, name) * step > 1.0 + 1e-9:
            raise ConfigError(
                f"{name} = {getattr(settings, name):g} Hz is faster than the integration "
                f"step allows (at most 1 / integration_step = {1 / step:g} Hz)"
            )
    hub = np.array(settings.initial_hub_velocity, dtype=float)
    return SimConfig(sail, policy, settings, lengths, tips, hub)


def _table(table, prefix: str, values: dict):
    """One table's instance from `values`; its errors name the parameter (`prefix`)."""
    try:
        return table(**{f.name: values[prefix + f.name] for f in fields_of(table)})
    except ValueError as error:
        raise ValueError(f"{prefix}{error}") from None


def _per_boom(values, name: str) -> np.ndarray:
    """A list of 1 or 4 values (checked by the table) as the model's 4 per-boom values."""
    items = list(values)
    return per_boom(items[0] if len(items) == 1 else items, name)
