"""The simulator without ROS: the sail's state on a fixed time grid, commands, reset.

`Simulation` samples a `SailStepper` one grid step (`integration_step`) at a
time (`sampling.GridSampler`), so published samples fall on the grid whatever
the wall clock does. At rest each grid step is one exact step; while the
booms move one model step spans as many grid steps as `max_model_step` and
the stepper's accuracy rule allow, and the samples inside are interpolated;
a grid step is split into equal sub-steps where the shortest boom's first
cantilever frequency needs it (`omega_1 h_sub <= PHASE_PER_STEP`).

The model's time `t_model` may therefore be ahead of the latest sample `t`:
motion and load commands start at `t_model`, after the samples already
computed; a reset acts at `t`.
"""

from __future__ import annotations

import math
import time

import numpy as np

from sail_ros.integrate.sampling import GridSampler
from sail_ros.model import BoomMotion, IntegrationError, SailModel, StaticProfile
from sail_ros.model.record import StateSample
from sail_ros.names import PRESSURE_CMD
from sail_ros.runtime.commands import (
    BoomState,
    CommandError,
    Plan,
    Rules,
    plan_deploy,
    plan_hub_wrench,
    plan_load,
    plan_trajectory,
)
from sail_ros.runtime.config import SimConfig

RUNNING, PAUSED, ERROR = "running", "paused", "error"


class StepStatistics:
    """Wall time per grid step [s] over a window: count, mean, max."""

    def __init__(self):
        self.count, self.total, self.largest = 0, 0.0, 0.0

    def add(self, seconds: float) -> None:
        self.count += 1
        self.total += seconds
        self.largest = max(self.largest, seconds)

    def take(self) -> tuple[int, float, float]:
        """`(count, mean, max)` of the window so far; a new window starts."""
        window = (self.count, self.total / self.count if self.count else 0.0, self.largest)
        self.count, self.total, self.largest = 0, 0.0, 0.0
        return window


class ScheduledInputs:
    """Inputs `t -> u` that switch from `levels[0]` to `levels[i + 1]` at `times[i]`
    [s], increasing (the stepper ends its steps there: `switch_times`)."""

    def __init__(self, times, levels):
        self.switch_times = tuple(float(t) for t in times)
        self._levels = levels

    def __call__(self, t: float) -> np.ndarray:
        return self._levels[int(np.searchsorted(self.switch_times, t, "right"))]


class Simulation:
    """The sail's state, stepped on a grid of `config.integration_step` [s] from t = 0.

    Commands act at `t_model`, a reset at `t` (the module's docstring). After an
    `IntegrationError` the state stays at its last finite value and `step`
    refuses to go on until `reset`.
    """

    def __init__(self, model: SailModel, config: SimConfig):
        self.model = model
        self.step_size = config.integration_step
        self.policy = config.policy  # the range alarms and the limits of commands
        self.range_warning = ""  # why the motion nears the end of the linear range
        self.motion = BoomMotion([StaticProfile(config.initial_lengths)] * 4)
        self.stepper = model.stepper(
            self.motion,
            q0=model.initial_coordinates(config.initial_tip_deflection),
            qd0=self._initial_velocities(config),
            max_step=config.max_model_step,
            rtol=config.model_rtol or None,
        )
        self.sampler = GridSampler(self.stepper, self.step_size)
        self.solar_pressure = config.solar_pressure  # [Pa] on every quadrant, on top
        self.pressures = np.zeros(4)  # commanded, per quadrant ab, bc, cd, da [Pa]
        self.tip_forces = np.zeros(4)  # commanded, per boom a..d [N]
        self.hub_wrench = np.zeros(3)  # commanded on a free hub: F_z [N], tau_x, tau_y [N m]
        # hub wrenches commanded to act later: (time [s], values), in time order
        self.pending_wrenches: list[tuple[float, np.ndarray]] = []
        self.commanded_until = -math.inf  # [s] when the latest hub wrench command acts
        self._use_loads()
        self.steps = 0  # grid steps taken since start
        self.paused = False
        self.error: str | None = None
        self.accepted = 0
        self.rejected = 0
        self.last_command = ""  # summary of the last accepted command
        self.last_command_start = math.nan  # its start time [s]
        self.last_rejection = ""
        self.step_times = StepStatistics()

    # -- state ------------------------------------------------------------------------------

    @property
    def t(self) -> float:
        """Simulation time [s] of the latest sample."""
        return self.sampler.point.t

    @property
    def t_model(self) -> float:
        """The model's time [s], >= `t`: where commands start."""
        return self.stepper.t

    @property
    def q(self) -> np.ndarray:
        """Generalised coordinates at `t`."""
        return self.sampler.point.q

    @property
    def qd(self) -> np.ndarray:
        """Generalised velocities at `t`."""
        return self.sampler.point.qd

    @property
    def lengths(self) -> np.ndarray:
        """Boom lengths [m] at `t`."""
        return self.sampler.point.lengths

    @property
    def state(self) -> str:
        """One of "error", "paused" or "running"."""
        return ERROR if self.error else PAUSED if self.paused else RUNNING

    def boom_state(self) -> BoomState:
        """The booms at `t_model`, where a command starts."""
        return BoomState(self.t_model, *self.stepper.boom_motion())

    def sample(self) -> StateSample:
        point = self.sampler.point
        return self.model.sample(point.t, point.lengths, point.rates, point.q, point.qd)

    def relative_error_estimate(self) -> float:
        """The stepper's accumulated error estimate relative to peak, the larger of the
        tips' and the root moments' (`SailStepper.relative_error_estimate`; nan before a
        moving step or with fixed steps)."""
        estimate = self.stepper.relative_error_estimate
        finite = [v for v in (estimate["tips"], estimate["root_moments"]) if math.isfinite(v)]
        return max(finite, default=math.nan)

    def balance(self) -> tuple[float, float, float]:
        """`(energy, load power, dissipation)` at `t`: the mechanical energy [J]
        (`SailModel.energy`, model.md §7), the loads' power `qd^T Q` and the damping's
        dissipation `qd^T C_d qd` [W], loads as commanded (no damping matrix is assembled
        without damping); inf or nan once the state has blown up."""
        lengths, q, qd = self.lengths, self.q, self.qd
        params = self.model.params
        damped = params.mass_damping > 0.0 or params.stiffness_damping > 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            energy = self.model.energy(q, qd, lengths)
            load = float(qd @ (self.model.input_matrix(lengths) @ self.inputs()))
            dissipation = 0.0
            if damped:
                dissipation = float(qd @ self.model.structural_damping(lengths) @ qd)
        return energy, load, dissipation

    def inputs(self) -> np.ndarray:
        """The model's inputs now (8, or 11 with a free hub): pressures [Pa] (commanded +
        solar), tip forces [N], and the hub wrench [N, N m, N m]."""
        parts = [self.pressures + self.solar_pressure, self.tip_forces]
        if self.model.free_hub:
            parts.append(self.hub_wrench)
        return np.concatenate(parts)

    def _initial_velocities(self, config: SimConfig) -> np.ndarray | None:
        """A free hub's initial heave and tilt rates, as velocities (None: at rest)."""
        if not self.model.free_hub or not config.initial_hub_velocity.any():
            return None
        qd0 = np.zeros(self.model.n)
        qd0[self.model.hub_slice] = config.initial_hub_velocity
        return qd0

    def _use_loads(self) -> None:
        """Hand the loads to the stepper: held constant from the next step on (so a change
        lands on a step boundary), and the hub wrenches still to act from their times
        (switch times, where the stepper ends its steps)."""
        u = self.inputs()
        if self.pending_wrenches:
            later = []
            for _, wrench in self.pending_wrenches:
                later.append(u.copy())
                later[-1][-3:] = wrench
            self.stepper.inputs = ScheduledInputs(
                [t for t, _ in self.pending_wrenches], [u, *later]
            )
        else:
            self.stepper.inputs = (lambda t: u) if u.any() else None

    def _take_due_wrenches(self) -> None:
        """The pending hub wrenches the model has reached become the one held."""
        due = [item for item in self.pending_wrenches if item[0] <= self.stepper.t + 1e-9]
        if due:
            self.hub_wrench = due[-1][1]
            self.pending_wrenches = self.pending_wrenches[len(due) :]
            self._use_loads()

    def substeps(self) -> int:
        """Equal sub-steps a moving grid step needs now (`SailStepper.step_limit`)."""
        return self.sampler.substeps()

    # -- stepping ---------------------------------------------------------------------------

    def step(self) -> bool:
        """Advance one grid step; False (and `error` set) if the state became non-finite."""
        if self.error:
            return False
        started = time.perf_counter()
        try:
            self.sampler.advance()
        except IntegrationError as error:
            self.error = str(error)
            return False
        self.step_times.add(time.perf_counter() - started)
        self.steps += 1
        if self.pending_wrenches:
            self._take_due_wrenches()
        return self._within_range()

    def _within_range(self) -> bool:
        """Check the tip deflections (and a free hub's tilt) against the linear range (the
        policy's `range_state`): set `range_warning` past the warning limit, stop with
        `error` past the error one, before anything absurd goes out."""
        point = self.sampler.point
        hub = point.q[self.model.hub_slice] if self.model.free_hub else None
        tips = self.model.tip_deflections(point.q)
        warning, error = self.policy.range_state(tips, point.lengths, hub)
        self.range_warning = warning
        if error:
            self.error = error
            return False
        return True

    def reset(self, config: SimConfig) -> None:
        """Back to the initial lengths (at rest) and tip deflections of `config`, at
        `t` (what was computed beyond is dropped); clears an error. The pause state is
        kept."""
        self.motion = BoomMotion([StaticProfile(config.initial_lengths)] * 4)
        self.stepper.reset(
            self.model.initial_coordinates(config.initial_tip_deflection),
            self._initial_velocities(config),
            self.t,
            profile=self.motion,
        )
        self.sampler.restart()
        self.error = None
        self.range_warning = ""
        self.policy = config.policy
        self.pressures, self.tip_forces = np.zeros(4), np.zeros(4)
        self.hub_wrench = np.zeros(3)
        self.pending_wrenches = []
        self.commanded_until = -math.inf
        self._use_loads()

    def set_solar_pressure(self, pressure: float) -> None:
        """The uniform pressure [Pa] on every quadrant, on top of the commanded ones."""
        self.solar_pressure = float(pressure)
        self._use_loads()

    # -- commands ---------------------------------------------------------------------------

    @property
    def rules(self) -> Rules:
        """What a command must respect now: the policy, for this sail."""
        return Rules(self.policy, self.model.params)

    def wrench(self, message, frame_id: str, at: float | None = None):
        """Apply a `sail/hub_wrench_cmd` (see `plan_hub_wrench`) from `t_model` on, or from
        `at` [s] (its stamp's simulation time) if that is later: a later command replaces
        those still to act at or after its time; returns the `LoadChange`.

        Raises:
            CommandError: why (counted in `rejected`); the wrench is unchanged.
        """

        def apply():
            self._refuse_when_stopped()
            change = plan_hub_wrench(
                message, self.rules, frame_id, self.model.free_hub, self.t_model, at
            )
            start = self.t_model if change.t_start is None else change.t_start
            self.pending_wrenches = [item for item in self.pending_wrenches if item[0] < start]
            if change.t_start is None:
                self.hub_wrench = change.values
            else:
                self.pending_wrenches.append((start, change.values))
            self._use_loads()
            self.commanded_until = max(self.commanded_until, start)
            self.accepted += 1
            self.last_command, self.last_command_start = change.summary, start
            return change

        return self._counted(apply)

    def load(self, topic: str, message):
        """Apply a `sail/pressure_cmd` or `sail/tip_force_cmd` (see `plan_load`) from
        `t_model` on; returns the `LoadChange`.

        Raises:
            CommandError: why (counted in `rejected`); the loads are unchanged.
        """
        return self._counted(lambda: self._apply_load(topic, message))

    def plan_deploy(self, target: float, duration: float = 0.0) -> Plan:
        """The motion of a deployment to `target` [m] from the booms at `t_model`, not yet
        applied (nothing is counted). Raises CommandError."""
        self._refuse_when_stopped()
        return plan_deploy(target, self.boom_state(), self.rules, duration)

    def plan_trajectory(self, trajectory) -> Plan:
        """The motion of a trajectory command from the booms at `t_model`, not yet applied
        (nothing is counted). Raises CommandError."""
        self._refuse_when_stopped()
        return plan_trajectory(trajectory, self.boom_state(), self.rules)

    def apply_motion(self, plan: Plan) -> Plan:
        """Follow `plan` from now on (its booms; the others carry on); counted accepted."""
        self.motion = self.motion.replaced(plan.profile, plan.booms)
        self.stepper.profile = self.motion
        self.accepted += 1
        self.last_command, self.last_command_start = plan.summary, plan.t_start
        return plan

    def count_rejection(self, error: Exception) -> None:
        """A command refused: counted, and its reason kept for the diagnostics."""
        self.rejected += 1
        self.last_rejection = str(error)

    def _apply_load(self, topic: str, message):
        pressure = topic == PRESSURE_CMD
        self._refuse_when_stopped()
        change = plan_load(
            topic, message, self.pressures if pressure else self.tip_forces, self.rules
        )
        if pressure:
            self.pressures = change.values
        else:
            self.tip_forces = change.values
        self._use_loads()
        self.accepted += 1
        self.last_command, self.last_command_start = change.summary, self.t_model
        return change

    def _refuse_when_stopped(self) -> None:
        if self.error:
            raise CommandError(f"the integration stopped ({self.error}); call sail/reset first")

    def _counted(self, act):
        try:
            return act()
        except CommandError as error:
            self.count_rejection(error)
            raise
