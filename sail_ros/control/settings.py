"""The controller's design as one table of fields (`model.fields.setting`).

`DesignSettings` holds what fixes the discrete controller: its sample rate and loop
delay, the design model and its mode counts, the lengths of the gain schedule, the
LQR weights and the Kalman filter's noises, and which inputs it commands. The node
`sail_control` declares each field as a ROS parameter of the same name, a scenario's
`controller:` section takes the same keys, and `sail-ros plant --controller` the
same `--set NAME=VALUE`: one check, one unit, one range for all three (errors name
the field and the value: `weight_tilt must be finite, got nan`).

Weights are those of the cost `sum z^T Q z + u^T R u` (Bryson: a weight of
1/x_max^2 makes x_max cost as much as a unit of the input whose weight is 1).
"""

from __future__ import annotations

import dataclasses
import math

from sail_ros.model import SailParameters
from sail_ros.model.fields import (
    Setting,
    check_fields,
    default_of,
    fields_of,
    setting,
    spec_of,
)
from sail_ros.model.parameters import LIVE_DEFAULTS, SAIL_PREFIX
from sail_ros.policy import Policy

MAX_DELAY_PERIODS = 50  # a longer loop delay is no design this controller makes sense for


@dataclasses.dataclass(frozen=True)
class DesignSettings:
    """The design of the discrete controller (SI units)."""

    state_rate_hz: float = setting(
        100.0, "Hz", "samples per second of simulation time: the simulator's state_rate_hz "
        "(the loop commands once per state sample; the design is discretised at its "
        "period); 100 Hz puts the reference sail's flexible modes below the Nyquist "
        "frequency (docs/control.md)", minimum=0.01, maximum=1000.0,
    )  # fmt: skip
    loop_delay_s: float = setting(
        0.0, "s", "simulation time from a state sample to its command taking effect (the "
        "command is stamped so, and the simulator holds a wrench stamped ahead until "
        "then); 0: from the sample's own time, which the simulator meets when its model "
        "does not run ahead (max_model_step = integration_step) and its steps wait for "
        "their commands (command_wait_s)", minimum=0.0, maximum=10.0,
    )  # fmt: skip
    design_boom_modes: int = setting(
        0, "-", "cantilever modes per boom of the design model; 0 (with "
        "design_membrane_modes 0): the rigid-body model of the hub and the deployed "
        "material alone, whose collocated hub feedback damps every flexible mode below the "
        "Nyquist frequency", minimum=0, maximum=30,
    )  # fmt: skip
    design_membrane_modes: int = setting(
        0, "-", "clamped-triangle modes per quadrant of the design model; 0 with "
        "design_boom_modes 0, else at least 1", minimum=0, maximum=100,
    )  # fmt: skip
    design_damping_ratio: float = setting(
        1e-3, "-", "damping ratio given to every elastic mode of a design model with "
        "modes (the Riccati equations need its undamped modes off the unit circle); the "
        "plant keeps its own", minimum=0.0, maximum=0.5, above_minimum=True,
    )  # fmt: skip
    schedule_lengths: list = setting(
        [], "m", "boom lengths of the gain schedule, increasing, at least 2 (the gains "
        "are interpolated at the mean boom length, held beyond the ends); empty: 24 "
        "lengths evenly in log from 1 m to the fully deployed length", minimum=1e-3,
        maximum=1e4,
    )  # fmt: skip
    weight_heave: float = setting(
        400.0, "1/m^2", "LQR weight of the hub's heave z_h", minimum=0.0, maximum=1e15
    )
    weight_tilt: float = setting(
        2.5e5, "1/rad^2", "LQR weight of each hub tilt theta_x, theta_y", minimum=0.0,
        maximum=1e15,
    )  # fmt: skip
    weight_heave_rate: float = setting(
        400.0, "s^2/m^2", "LQR weight of the heave rate", minimum=0.0, maximum=1e15
    )
    weight_tilt_rate: float = setting(
        1e4, "s^2/rad^2", "LQR weight of each tilt rate", minimum=0.0, maximum=1e15
    )
    weight_tip: float = setting(
        400.0, "1/m^2", "LQR weight of each boom-tip deflection (design models with modes)",
        minimum=0.0, maximum=1e15,
    )  # fmt: skip
    weight_tip_rate: float = setting(
        100.0, "s^2/m^2", "LQR weight of each tip deflection's rate (design models with "
        "modes)", minimum=0.0, maximum=1e15,
    )  # fmt: skip
    weight_force: float = setting(
        1.0, "1/N^2", "LQR weight of the hub force F_z", minimum=0.0, maximum=1e15,
        above_minimum=True,
    )  # fmt: skip
    weight_torque: float = setting(
        1.0, "1/(N m)^2", "LQR weight of each hub torque tau_x, tau_y", minimum=0.0,
        maximum=1e15, above_minimum=True,
    )  # fmt: skip
    weight_tip_force: float = setting(
        1.0, "1/N^2", "LQR weight of each boom-tip force (with tip_forces)", minimum=0.0,
        maximum=1e15, above_minimum=True,
    )  # fmt: skip
    wrench_noise: float = setting(
        3e-3, "N s^0.5", "Kalman filter: white noise on each hub wrench channel (N m s^0.5 "
        "for the torques), the model's unknown fast loads", minimum=0.0, maximum=1e6,
        above_minimum=True,
    )  # fmt: skip
    disturbance_noise: float = setting(
        1e-3, "N/s^0.5", "Kalman filter: random walk of the estimated constant disturbance "
        "on each hub wrench channel (N m/s^0.5 for the torques), fed back against the "
        "load: larger tracks a changing load faster", minimum=0.0, maximum=1e6,
        above_minimum=True,
    )  # fmt: skip
    hub_position_noise: float = setting(
        1e-7, "m, rad", "Kalman filter: noise of the measured heave and tilts; small keeps "
        "the feedback collocated (the measured hub state, not a model's)", minimum=0.0,
        maximum=1e3, above_minimum=True,
    )  # fmt: skip
    hub_rate_noise: float = setting(
        1e-7, "m/s, rad/s", "Kalman filter: noise of the measured heave and tilt rates; small "
        "keeps the rate feedback collocated, a damper on every flexible mode",
        minimum=0.0, maximum=1e3, above_minimum=True,
    )  # fmt: skip
    tip_noise: float = setting(
        1e-3, "m", "Kalman filter: noise of the measured tip deflections (design models "
        "with modes)", minimum=0.0, maximum=1e3, above_minimum=True,
    )  # fmt: skip
    tip_rate_noise: float = setting(
        1e-2, "m/s", "Kalman filter: noise of their measured rates (design models with "
        "modes)", minimum=0.0, maximum=1e3, above_minimum=True,
    )  # fmt: skip
    tip_forces: bool = setting(
        False,
        "",
        "command the boom-tip forces (sail/tip_force_cmd) besides the hub wrench; "
        "needs a design model with modes",
    )

    def __post_init__(self):
        check_fields(self)
        nb, nm = self.design_boom_modes, self.design_membrane_modes
        if (nb == 0) != (nm == 0):
            raise ValueError(
                f"design_boom_modes = {nb} and design_membrane_modes = {nm}: both 0 (the "
                "rigid-body design model) or both at least 1"
            )
        if self.tip_forces and nb == 0:
            raise ValueError(
                "tip_forces = true needs a design model with modes (design_boom_modes and "
                "design_membrane_modes >= 1): the rigid-body model does not see what a tip "
                "force does to its boom"
            )
        if self.tip_forces and self.loop_delay_s > 0:
            raise ValueError(
                f"tip_forces = true with loop_delay_s = {self.loop_delay_s:g} s: the simulator "
                "times hub wrenches alone (a tip force acts when it comes)"
            )
        lengths = self.schedule_lengths
        if len(lengths) == 1 or any(b <= a for a, b in zip(lengths, lengths[1:], strict=False)):
            raise ValueError(
                f"schedule_lengths must be empty or at least 2 increasing lengths [m], got "
                f"{lengths!r}"
            )
        if self.loop_delay_s * self.state_rate_hz > MAX_DELAY_PERIODS + 1e-9:
            raise ValueError(
                f"loop_delay_s = {self.loop_delay_s:g} s is more than {MAX_DELAY_PERIODS} "
                f"sample periods at state_rate_hz = {self.state_rate_hz:g} Hz"
            )

    @property
    def period(self) -> float:
        """The sample period [s]."""
        return 1.0 / self.state_rate_hz

    @property
    def rigid(self) -> bool:
        """The design model is the hub's rigid-body model (no modes)."""
        return self.design_boom_modes == 0

    def design_model_text(self) -> str:
        """The design model in words: `rigid body` or `(n_B, n_M) = (2, 1)`."""
        if self.rigid:
            return "rigid body"
        return f"(n_B, n_M) = ({self.design_boom_modes}, {self.design_membrane_modes})"

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields_of(cls))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def replace(self, **changes) -> DesignSettings:
        return dataclasses.replace(self, **changes)


def auto_lengths(full_length: float, count: int = 24, shortest: float = 1.0) -> list[float]:
    """The default schedule: `count` lengths [m] evenly in log from `shortest` to
    `full_length` (the fully deployed boom)."""
    high = max(full_length, shortest * 1.01)
    step = math.log(high / shortest) / (count - 1)
    return [shortest * math.exp(i * step) for i in range(count - 1)] + [high]


@dataclasses.dataclass(frozen=True)
class NodeSettings:
    """What the node `sail_control` adds to the design: its switch, its watchdog, its
    status, where its gains and its simulator are."""

    enabled: bool = setting(
        True, "", "command the hub; false: command a zero wrench once and hold it (the "
        "estimate goes on, so enabling again starts from it); also the service "
        "sail/control/enable", read_only=False,
    )  # fmt: skip
    stale_periods: float = setting(
        3.0, "-", "state periods without a state sample (wall time at the simulator's "
        "time_scale, at least its 5 ms tick) after which the state is stale: a zero wrench "
        "is commanded, once, until samples come again", minimum=1.0, maximum=1e4,
    )  # fmt: skip
    diagnostics_rate_hz: float = setting(
        1.0, "Hz", "/diagnostics per second of wall time; also the window of the latency "
        "statistics it reports", minimum=0.01, maximum=100.0, read_only=False,
    )  # fmt: skip
    gains_file: str = setting(
        "",
        "",
        "a gain schedule written by `sail-ros plant --controller --gains FILE` to "
        "use instead of designing at start; empty: design at start",
    )
    simulator_node: str = setting(
        "sail_sim",
        "",
        "the simulator whose parameters the controller checks before it "
        "commands (its sail, state_rate_hz and limits), in the controller's namespace",
    )

    def __post_init__(self):
        check_fields(self)


# the limits of the policy the controller saturates at (the simulator's, checked against it)
LIMIT_NAMES = ("max_hub_force", "max_hub_torque", "max_tip_force")


def _fixed(field):
    """A field of another table as a read-only setting of the node (the design is made
    at start: a limit changed later would not be the one it saturates at)."""
    spec = spec_of(field)
    return setting(
        default_of(field), spec.unit, spec.doc + "; the simulator's, at most", minimum=spec.minimum,
        maximum=spec.maximum, above_minimum=spec.above_minimum,
    )  # fmt: skip


# the node's parameters, name -> field: the design, the node's own, the limits, the sail
NODE_PARAMETERS = {
    **{f.name: f for f in fields_of(DesignSettings)},
    **{f.name: f for f in fields_of(NodeSettings)},
    **{f.name: _fixed(f) for f in fields_of(Policy) if f.name in LIMIT_NAMES},
    **{SAIL_PREFIX + f.name: f for f in fields_of(SailParameters)},
}
NODE_SETTINGS = [  # the sail's defaults the simulator's: the plant it runs
    dataclasses.replace(
        Setting.of(name, field),
        default=LIVE_DEFAULTS.get(name.removeprefix(SAIL_PREFIX), default_of(field))
        if name.startswith(SAIL_PREFIX)
        else default_of(field),
    )
    for name, field in NODE_PARAMETERS.items()
]
