"""The closed loop offline: the live controller's discrete loop on the model.

`run_closed_loop` runs a scenario with the controller of its `controller:` section
(`control.settings.DesignSettings`) through the model's stepper as `sail_control` runs beside
the simulator: the stepper goes to each sample time `t_k = k T`, the controller
(`control.loop.DiscreteController`, the same gains, period and delay model) takes the
measured outputs there and gives a command, and the command acts from `t_k +
loop_delay_s` until the next one replaces it (the stepper ends a step there). The
scenario's own loads act beside it (a tip force of the controller adds to the
scenario's). The state is kept at every sample; the true peaks and the range alarms
are those of `run_deployment` (`RangeWatch` sees every step).
"""

from __future__ import annotations

import bisect
import dataclasses

import numpy as np

from sail_ros.analysis.deployment import DeploymentRun, output_times, stepped_run
from sail_ros.analysis.scenario import Scenario, check_scenario
from sail_ros.control.design import HUB_WRENCH, TIP_FORCES, command_limits
from sail_ros.control.loop import DiscreteController
from sail_ros.control.schedule import GainSchedule, design_schedule
from sail_ros.control.settings import DesignSettings
from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL
from sail_ros.integrate.observers import RangeWatch
from sail_ros.model import IntegrationError, SailModel
from sail_ros.model.loads import input_function
from sail_ros.policy import Policy


def measurements(model: SailModel, q, qd, names) -> np.ndarray:
    """The measured outputs `names` (`design.measurement_names`) of one state: the hub's
    heave, tilts and their rates, then the tip deflections and their rates."""
    h = model.hub_slice
    values = [q[h], qd[h]]
    if len(names) > 6:
        values += [model.tip_deflections(q), model.tip_deflections(qd)]
    return np.concatenate(values)


class LoopInputs:
    """The scenario's loads (`base`, a callable `t -> u` or None, with its switch times)
    with the controller's commands added on their columns, each held from its time
    (`command(at, u)`) until the next: the steps end at the commands' times (those not
    yet passed are among the switch times)."""

    def __init__(self, base, size: int, columns):
        self._base, self._size, self._columns = base, size, columns
        self._times: list[float] = []
        self._commands: list[np.ndarray] = [np.zeros(len(columns))]  # before the first
        self._base_switches = tuple(getattr(base, "switch_times", ()))
        self.switch_times = self._base_switches

    def command(self, at: float, u, now: float) -> None:
        """The command `u` acts from `at` [s] on; `now` [s], the sample time it was made."""
        self._times.append(at)
        self._commands.append(np.asarray(u, dtype=float))
        later = tuple(t for t in self._times[-8:] if t >= now)
        self.switch_times = self._base_switches + later

    def __call__(self, t: float) -> np.ndarray:
        u = np.zeros(self._size) if self._base is None else np.array(self._base(t), dtype=float)
        u[self._columns] += self._commands[bisect.bisect_left(self._times, t)]
        return u


@dataclasses.dataclass(frozen=True)
class ClosedLoopRun:
    """A closed-loop run: its states at the sample times (`run`, a `DeploymentRun`), and
    per sample the command (`commands`, (k, nu), acting from `t + delay`), the demand
    before the limits and which channels met them (`saturated`); `inputs` their names,
    `schedule` the controller's gains."""

    run: DeploymentRun
    commands: np.ndarray
    demands: np.ndarray
    saturated: np.ndarray
    inputs: tuple[str, ...]
    schedule: GainSchedule
    limits: np.ndarray

    @property
    def saturated_samples(self) -> int:
        return int(self.saturated.any(axis=1).sum())


def run_closed_loop(
    model: SailModel,
    scenario: Scenario,
    design: DesignSettings,
    policy: Policy | None = None,
    schedule: GainSchedule | None = None,
    progress=None,
    max_step: float = DEFAULT_MAX_STEP,
    rtol: float | None = DEFAULT_RTOL,
    atol: dict | None = None,
) -> ClosedLoopRun:
    """Run `scenario` on `model` with the controller `design` (module docstring).

    Args:
        model: the plant (free hub).
        scenario: the boom motion, initial state, loads and duration.
        design: the controller's design (`scenario.controller`, usually).
        policy: the limits and alarms (default: the simulator's defaults); its
            max_hub_force, max_hub_torque, max_tip_force are the commands' limits.
        schedule: the gains (default designed for `model`'s sail, `design_schedule`).
        progress: optional callable `progress(t)` after each sample.
        max_step: largest integration step [s] (`SailStepper`).
        rtol: the stepper's tolerance (None: fixed steps).
        atol: its absolute floors per output kind, over the defaults (`SailStepper`).

    Raises:
        ValueError: the scenario asks what the policy refuses; the sail is clamped; a
            design point has no stabilising Riccati solution.

    A run that leaves the linear range or becomes non-finite stops: the result holds the
    samples before, and its `run.alarm` says why.
    """
    policy = Policy() if policy is None else policy
    check_scenario(scenario, model, policy)
    schedule = design_schedule(model.params, design) if schedule is None else schedule
    limits = command_limits(policy, schedule.inputs)
    controller = DiscreteController(schedule, limits)
    columns = HUB_WRENCH + (TIP_FORCES if len(schedule.inputs) > 3 else [])
    base = input_function(scenario.loads, model.free_hub)
    inputs = LoopInputs(base, len(model.input_names), columns)
    times = output_times(scenario.duration, design.state_rate_hz)
    q0, qd0 = scenario.initial_state(model)
    watch = RangeWatch(model, policy)
    stepper = model.stepper(
        scenario.profile, q0=q0, qd0=qd0, max_step=max_step, rtol=rtol, atol=atol,
        inputs=inputs,
    )  # fmt: skip
    k = times.size
    commands, demands = np.zeros((k, len(columns))), np.zeros((k, len(columns)))
    saturated = np.zeros((k, len(columns)), dtype=bool)

    def sample(i: int, t: float, q, qd) -> None:
        """The controller at sample `i`: the measured outputs in, the command out, acting
        from `t + loop_delay_s`."""
        lengths = np.asarray(scenario.profile(t)[0], dtype=float) * np.ones(4)
        y = measurements(model, q, qd, schedule.measurements)
        if not np.all(np.isfinite(y)):
            raise IntegrationError(f"the state became non-finite at t = {t:.6g} s")
        command = controller.step(y, float(np.mean(lengths)))
        commands[i], demands[i], saturated[i] = command.u, command.demand, command.saturated
        inputs.command(t + design.loop_delay_s, command.u, t)
        if progress is not None:
            progress(t)

    run_ = stepped_run(model, scenario, stepper, watch, times, at_outputs=sample)
    kept = run_.t.size
    return ClosedLoopRun(
        run_, commands[:kept], demands[:kept], saturated[:kept], schedule.inputs, schedule, limits
    )


def summary(closed: ClosedLoopRun, open_loop: DeploymentRun | None = None) -> dict:
    """The closed loop in numbers (SI), against `open_loop` (the same scenario without
    the controller) when given: the design, the peaks of the commands, the saturated
    samples, the true peak tilt and heave and the tip peaks of both runs, and what the
    hub does over the run's last tenth (its largest |tilt| and |heave| there)."""
    run, schedule = closed.run, closed.schedule
    settings = schedule.settings
    last = run.t >= run.t[-1] - 0.1 * (run.t[-1] - run.t[0])
    report = {
        "design_model": settings.design_model_text(),
        "state_rate_hz": settings.state_rate_hz,
        "loop_delay_s": settings.loop_delay_s,
        "schedule_lengths_m": [float(v) for v in schedule.lengths],
        "inputs": list(closed.inputs),
        "limits": [float(v) for v in closed.limits],
        "peak_command": [float(v) for v in np.abs(closed.commands).max(axis=0, initial=0.0)],
        "samples": int(run.t.size),
        "saturated_samples": closed.saturated_samples,
        "saturations": [int(v) for v in closed.saturated.sum(axis=0)],
        "peak_tilt_rad": float(run.peaks.hub.value[3]),
        "peak_heave_m": float(run.peaks.hub.value[0]),
        "peak_tip_deflection_m": [float(v) for v in run.peaks.tip_deflection.value],
        "final_tilt_rad": float(np.hypot(run.hub[last, 1], run.hub[last, 2]).max()),
        "final_heave_m": float(np.abs(run.hub[last, 0]).max()),
    }
    if open_loop is not None and open_loop.peaks is not None:
        report |= {
            "open_loop_peak_tilt_rad": float(open_loop.peaks.hub.value[3]),
            "open_loop_peak_heave_m": float(open_loop.peaks.hub.value[0]),
            "open_loop_peak_tip_deflection_m": [
                float(v) for v in open_loop.peaks.tip_deflection.value
            ],
            "open_loop_alarm": open_loop.alarm,
        }
    return report


def summary_lines(numbers: dict) -> list[str]:
    """`summary` as lines for a terminal."""
    lengths = numbers["schedule_lengths_m"]
    lines = [
        f"  closed loop (docs/control.md): design model {numbers['design_model']}, "
        f"{numbers['state_rate_hz']:g} Hz, loop delay {numbers['loop_delay_s']:g} s, gains at "
        f"{len(lengths)} lengths {lengths[0]:.4g}-{lengths[-1]:.4g} m",
    ]
    commands = ", ".join(
        f"|{name}| {peak:.4g} (limit {limit:g})"
        for name, peak, limit in zip(
            numbers["inputs"], numbers["peak_command"], numbers["limits"], strict=True
        )
    )
    per = ", ".join(
        f"{name} {count}" for name, count in zip(numbers["inputs"], numbers["saturations"],
                                                 strict=True)
    )  # fmt: skip
    lines.append(f"    peak commands {commands}")
    lines.append(
        f"    {numbers['saturated_samples']} of {numbers['samples']} samples saturated "
        f"({per}); the estimate takes the saturated command (anti-windup)"
    )
    tilt, heave = numbers["peak_tilt_rad"], numbers["peak_heave_m"]
    tips = "  ".join(f"{1e3 * v:.4g}" for v in numbers["peak_tip_deflection_m"])
    if "open_loop_peak_tilt_rad" in numbers:
        open_tilt = numbers["open_loop_peak_tilt_rad"]
        ratio = f" (1/{open_tilt / tilt:.3g} of open loop)" if tilt > 0 else ""
        lines.append(
            f"    peak tilt |theta| {1e3 * tilt:.4g} mrad{ratio}; open loop "
            f"{1e3 * open_tilt:.4g} mrad"
        )
        lines.append(
            f"    peak heave |z_h| {1e3 * heave:.4g} mm; open loop "
            f"{1e3 * numbers['open_loop_peak_heave_m']:.4g} mm"
        )
        open_tips = "  ".join(f"{1e3 * v:.4g}" for v in numbers["open_loop_peak_tip_deflection_m"])
        lines.append(f"    peak |tip| a..d [mm] {tips}; open loop {open_tips}")
        if numbers["open_loop_alarm"]:
            lines.append(f"    (the open loop stopped: {numbers['open_loop_alarm']})")
    else:
        lines.append(f"    peak tilt |theta| {1e3 * tilt:.4g} mrad, peak heave |z_h| "
                     f"{1e3 * heave:.4g} mm, peak |tip| a..d [mm] {tips}")  # fmt: skip
    lines.append(
        f"    over the last tenth of the run: |theta| <= {1e3 * numbers['final_tilt_rad']:.4g} "
        f"mrad, |z_h| <= {1e3 * numbers['final_heave_m']:.4g} mm"
    )
    return lines


def last_run(log) -> tuple[np.ndarray, np.ndarray]:
    """A live log's free hub over its last run: times [s] from the run's start (the last
    reset, which repeats the stamp of the sample before it; else the first sample) and
    the hub's (k, 6) values (`StateSample.hub`)."""
    if log.hub is None:
        raise ValueError("the log holds no /sail/hub_state (a free hub's)")
    stamps, hub = log.hub
    repeats = np.flatnonzero(np.diff(stamps) <= 0)
    start = int(repeats[-1]) + 1 if repeats.size else 0
    return (stamps[start:] - stamps[start]) / 1e9, hub[start:]


def tilt_agreement(t, hub, closed: ClosedLoopRun) -> tuple[float, float, int]:
    """How closely a hub's tilt history (`t` [s], `hub` (k, 6), e.g. `last_run` of a live
    log) follows an offline closed loop's at the same times: the largest
    |theta - theta_offline| [rad] (the tilt vector's difference), the offline peak |theta|
    [rad] over those times, and how many times were compared (those of both)."""
    offline = closed.run
    keys = np.round(offline.t, 6)
    common = np.isin(np.round(t, 6), keys)
    rows = np.searchsorted(keys, np.round(t[common], 6))
    theirs = offline.hub[rows, 1:3]
    difference = np.hypot(*(hub[common, 1:3] - theirs).T)
    peak = float(np.hypot(*theirs.T).max(initial=0.0))
    return float(difference.max(initial=0.0)), peak, int(common.sum())
