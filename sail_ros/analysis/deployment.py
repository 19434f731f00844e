"""An offline deployment run: the sail's state on a time grid under a scenario.

The same integration as the live simulator (the exponential-midpoint stepper of
`sail_ros.integrate.stepper`), run as fast as the machine allows; the wall time
gives the achieved real-time factor. The same policy too (`sail_ros.policy`): a
scenario the simulator would refuse is refused before the run, and a run whose
tip deflections leave the linear range stops there with the simulator's alarm,
keeping what it computed before.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import NamedTuple

import numpy as np

from sail_ros.analysis.scenario import Scenario, check_scenario
from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL, time_slack
from sail_ros.integrate.driver import sample
from sail_ros.integrate.peaks import HERMITE_BOUND, OutputPeaks, Peaks, SampledSteps, hermite_motion
from sail_ros.model import IntegrationError, SailModel
from sail_ros.model.loads import input_function
from sail_ros.model.profiles import motion_over
from sail_ros.model.record import StateSample, take
from sail_ros.policy import OutOfRangeError, Policy


class Accuracy(NamedTuple):
    """How a run was stepped: the tolerance `rtol` asked (None: fixed steps), the
    achieved error estimate relative to each output's peak (`SailStepper.
    relative_error_estimate`: tips, tip_rates, root_moments, root_moment_rates), the
    steps taken and refused."""

    rtol: float | None
    relative_error: dict
    steps: int
    rejected: int


@dataclasses.dataclass(frozen=True)
class DeploymentRun:
    """States of one run at the output times.

    Attributes:
        states: the state record (`record.StateSample`) with each field over the
            output times: `t` (k,) [s], `lengths`, `rates`, `tips`, `tip_rates`,
            `root_moments` (k, 4), `q`, `qd` (k, n), a free hub's `hub` (k, 6) or None;
            each is an attribute of the run too (`run.tips`).
        wall_seconds: wall time of the integration [s].
        peaks: the true peaks of the whole run, per boom with their times, taken
            inside every integration step (`peaks.OutputPeaks`), not from `t`.
        warning: the first time a tip deflection passed the policy's
            tip_warn_fraction, as the simulator's diagnostics say it ("" if never).
        alarm: why the run stopped before the end ("" if it did not): the simulator's
            alarm (`Policy.range_state`, or a non-finite state); `t` ends before it.
        accuracy: the tolerance and the achieved error estimate (`Accuracy`).
    """

    states: StateSample
    wall_seconds: float
    peaks: Peaks | None = None
    warning: str = ""
    alarm: str = ""
    accuracy: Accuracy | None = None

    def __getattr__(self, name):
        if name in StateSample._fields:
            return getattr(self.states, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall second."""
        return float(self.t[-1] - self.t[0]) / max(self.wall_seconds, 1e-9)

    def subset(self, mask) -> DeploymentRun:
        """The run at the output times selected by `mask` (boolean or indices)."""
        return dataclasses.replace(self, states=take(self.states, mask))

    def sample(self, i: int) -> StateSample:
        """The state at output time `i`."""
        return take(self.states, i)

    def index_of(self, t: float) -> int:
        """Index of the output time nearest to `t` [s]."""
        return int(np.argmin(np.abs(self.t - t)))


def sample_bytes(n: int) -> int:
    """Memory an output time of a run of `n` coordinates takes [bytes]: its time,
    coordinates, velocities and 20 per-boom values, twice (the selections the log and
    the figures make)."""
    return 2 * 8 * (1 + 2 * n + 20)


def output_count(duration: float, rate_hz: float) -> int:
    """How many times a uniform grid of `rate_hz` [Hz] over [0, duration] [s] holds."""
    if not rate_hz > 0:
        raise ValueError(f"output rate must be > 0 Hz, got {rate_hz!r}")
    return math.floor(duration * rate_hz + 1e-9) + 1


def output_times(duration: float, rate_hz: float, extra=()) -> np.ndarray:
    """A uniform grid of `rate_hz` [Hz] over [0, duration] [s], with the end and
    the `extra` times [s] merged in."""
    grid = np.arange(output_count(duration, rate_hz)) / rate_hz
    merged = np.concatenate([grid, [duration], np.asarray(list(extra), dtype=float)])
    # merge times closer than 1 us: they are the same sample
    merged = np.unique(np.round(merged, 6))
    return merged[(merged >= 0.0) & (merged <= duration)]


class RangeWatch:
    """Sees every step of a run: the true peaks (`peaks.OutputPeaks`), and the tip
    deflections (and a free hub's tilt) against the policy's linear range at the peaks'
    samples inside the step (`peaks.MAX_SPACING_S` apart or closer, the simulator's
    default integration step), as the simulator checks its samples
    (`Policy.range_state`): the first warning is kept, an error stops the run
    (`OutOfRangeError`, the simulator's alarm text with the time; `stopped_at`).

    The peaks sample their steps in batches (`OutputPeaks.batch_steps`), so the check
    comes up to a batch after the step: a run stops with the error of its first step
    out of range, the stepper some steps further (`finish` checks the steps left)."""

    def __init__(self, model: SailModel, policy: Policy, tip_times=None):
        self.model, self.policy = model, policy
        self.peaks = OutputPeaks(model, check=self._check)
        self.warning = ""
        self.error = ""
        self.stopped_at = math.inf
        self._t0 = 0.0
        # the tips and a free hub's z_h, theta_x, theta_y among the peaks' rows
        self._columns = OutputPeaks.TIP_ROWS + (OutputPeaks.HUB_ROWS if model.free_hub else [])
        # with `tip_times` [s] (increasing): the tip deflections [m] there, (k, 4), taken
        # in the peaks' pass over each step; `tips_reached` of them are at or before the
        # stepper's time, `tips_taken` taken
        self.tip_times = None if tip_times is None else np.asarray(tip_times, dtype=float)
        self.tips = None if tip_times is None else np.full((self.tip_times.size, 4), np.nan)
        self.tips_reached = self.tips_taken = 0

    def start(self, stepper) -> None:
        self.peaks.start(stepper)
        self._t0 = stepper.t
        if self.tip_times is not None:
            taken = self._tip_times_until(stepper.t)
            self.tips[:taken] = self.model.tip_deflections(stepper.q)
            self.tips_reached = self.tips_taken = taken

    def _tip_times_until(self, t: float) -> int:
        """How many of `tip_times` are at or before `t` [s] (to round-off)."""
        return int(self.tip_times.searchsorted(t + time_slack(t), "right"))

    def after_step(self, stepper) -> None:
        t0, t1 = self._t0, stepper.t
        self._t0 = t1
        also = None
        if self.tip_times is not None:
            reached = self._tip_times_until(t1)
            times = self.tip_times[self.tips_reached : reached]
            also = np.minimum(np.maximum((times - t0) / (t1 - t0), 0.0), 1.0)
            self.tips_reached = reached
        self.peaks.after_step(stepper, also=also)
        self._raise()

    def finish(self) -> None:
        """Check the steps not yet checked (the run's end, or a non-finite state)."""
        self.peaks.flush()
        self._raise()

    def _raise(self) -> None:
        if self.error:
            raise OutOfRangeError(self.error)

    def _check(self, sampled: SampledSteps) -> float | None:
        """`OutputPeaks.check`: the tips at `tip_times` taken; the samples of each step
        against the range, in time order; the time of the first error, or None."""
        if self.tips is not None:
            at_tips = sampled.values[~sampled.searched][:, OutputPeaks.TIP_ROWS]
            self.tips[self.tips_taken : self.tips_taken + len(at_tips)] = at_tips
            self.tips_taken += len(at_tips)
        # needed only where a tip may be near its range: no boom is shorter inside a step
        # than min(L0, L1) - 4/27 h (|Ld0| + |Ld1|)
        shortest = np.minimum(sampled.lengths0, sampled.lengths1)
        shortest -= (
            HERMITE_BOUND * sampled.h[:, None] * (np.abs(sampled.rates0) + np.abs(sampled.rates1))
        )
        # (a nan or inf tip is not within)
        within = (shortest > 0).all(axis=1) & (
            sampled.largest[:, OutputPeaks.TIP_ROWS] <= self.policy.tip_warn_fraction * shortest
        ).all(axis=1)
        if within.all() and not self.model.free_hub:
            return None  # every tip finite and in range at every sample: nothing more to see
        for step in np.flatnonzero(~within | self.model.free_hub):
            stop = self._check_step(sampled, step, bool(within[step]))
            if stop is not None:
                return stop
        return None

    def _check_step(self, sampled: SampledSteps, step: int, within: bool) -> float | None:
        """One step's own samples against the range (`_check`)."""
        mine = (sampled.step == step) & sampled.searched
        fractions, values = sampled.fractions[mine], sampled.values[mine][:, self._columns]
        h = sampled.h[step]
        ends = (sampled.lengths0[step], sampled.rates0[step], sampled.lengths1[step],
                sampled.rates1[step])  # fmt: skip
        lengths = hermite_motion(fractions, np.full(fractions.size, h), *ends)[0]
        near = np.zeros(fractions.size, dtype=bool)
        if not within:
            near = np.max(np.abs(values[:, :4]) / lengths, axis=1) > self.policy.tip_warn_fraction
        if self.model.free_hub:
            near |= np.hypot(values[:, 5], values[:, 6]) > self.policy.tilt_warn_rad
        finite = np.isfinite(values).all(axis=1)
        for i in np.flatnonzero(near | ~finite):
            t, row = sampled.t0[step] + fractions[i] * h, values[i]
            hub = np.append(row[4:], [0.0] * 3) if self.model.free_hub else None
            warning, error = self.policy.range_state(row[:4], lengths[i], hub)
            if error:
                self.stopped_at = t
                self.error = f"integration stopped at t = {t:.6g} s: {error}"
                return t
            if warning and not self.warning:
                self.warning = f"at t = {t:.6g} s: {warning}"
        return None


def run_deployment(
    model: SailModel,
    scenario: Scenario,
    t_eval,
    max_step: float = DEFAULT_MAX_STEP,
    progress=None,
    initial=None,
    policy: Policy | None = None,
    rtol: float | None = DEFAULT_RTOL,
    rates: str | None = "exact",
    states: bool = True,
) -> DeploymentRun:
    """Integrate the scenario and sample it at `t_eval` [s] (and at its load switches,
    which thereby fall on step boundaries); the peaks of the tips and root moments
    over the whole run come from inside every step (`DeploymentRun.peaks`).

    Args:
        model: the sail model (its parameters should include `scenario.sail`).
        scenario: boom motion, initial state, duration.
        t_eval: increasing output times within [0, scenario.duration].
        max_step: largest integration step [s].
        progress: optional callable `progress(t)` after each output time.
        initial: `(q0, qd0)` instead of the scenario's initial state for `model`.
        policy: the limits and alarms (default: the simulator's defaults).
        rtol: the stepper's tolerance (`SailStepper`; None: fixed steps of `max_step`).
        rates: the velocities at output times inside moving steps
            (`SailStepper.states_at`): "exact", or "extension" (cheaper, off by about
            0.3 % of peak; the coordinates, the steps' ends and the peaks the same to
            the bit) for a caller that reads positions only, or None (cheaper still:
            `qd` nan at output times inside steps) for one that reads velocities only
            at the steps' ends (the run's last output time is one).
        states: False: the tip deflections alone at `t_eval`, taken in the pass over
            each step that finds the peaks (the steps' curve `SailStepper.interpolant`,
            the state's own tips to round-off), and the state at the start and the end;
            `q`, `qd`, `tip_rates`, `root_moments` (a free hub's `hub`) nan at the
            other output times, `rates` of no use: for a caller that reads only those
            (a Monte Carlo sample: 9-12 % less of its CPU, measured).

    Raises:
        ValueError: the scenario asks what the policy refuses (`check_scenario`).

    A run that leaves the linear range or becomes non-finite stops: the result holds
    the output times before, and `alarm` says why.
    """
    policy = Policy() if policy is None else policy
    check_scenario(scenario, model, policy)
    q0, qd0 = scenario.initial_state(model) if initial is None else initial
    t_eval = np.asarray(t_eval, dtype=float)
    if (
        t_eval.ndim != 1
        or np.any(np.diff(t_eval) < 0)
        or not (t_eval.size and t_eval[0] >= 0.0 and t_eval[-1] <= scenario.duration)
    ):
        raise ValueError(
            f"output times must increase within [0, duration = {scenario.duration:g} s], "
            f"got {t_eval!r}"
        )
    if scenario.loads is not None:
        switches = [t for t in scenario.loads.switch_times if 0.0 < t < scenario.duration]
        t_eval = np.union1d(t_eval, switches)
    watch = RangeWatch(model, policy, tip_times=None if states else t_eval)
    stepper = model.stepper(
        scenario.profile, q0=q0, qd0=qd0, max_step=max_step, rtol=rtol,
        inputs=input_function(scenario.loads, model.free_hub), on_step=watch.after_step,
    )  # fmt: skip
    watch.start(stepper)
    q, qd = np.full((t_eval.size, model.n), np.nan), np.full((t_eval.size, model.n), np.nan)
    kept, alarm = 0, ""
    started = time.perf_counter()
    try:
        try:
            if states:
                for _, reached in sample(stepper, t_eval, scenario.duration, q, qd, rates):
                    kept = reached  # the outputs written so far
                    if progress is not None:
                        progress(stepper.t)
            else:  # the watch takes the tips; the state where an output falls on a step's end
                kept = watch.tips_reached
                while True:
                    if kept and abs(t_eval[kept - 1] - stepper.t) <= time_slack(stepper.t):
                        q[kept - 1], qd[kept - 1] = stepper.q, stepper.qd
                    if kept == t_eval.size:
                        break
                    stepper.advance_step(scenario.duration)
                    kept = watch.tips_reached
                    if progress is not None:
                        progress(stepper.t)
        except IntegrationError:
            watch.finish()  # the steps before it: a range error among them came first
            raise
        watch.finish()
    except (OutOfRangeError, IntegrationError) as error:
        alarm = str(error)
        # the outputs before the first step that left the range, and inside it before
        # it did (the stepper may be some steps on; none after a state that became
        # non-finite: that step was not taken)
        if math.isfinite(watch.stopped_at):
            before = int(np.searchsorted(t_eval, watch.stopped_at, "left"))
            if states and before > kept:  # inside the last step
                q[kept:before], qd[kept:before] = stepper.states_at(t_eval[kept:before], rates)
            kept = before
    wall = time.perf_counter() - started
    t, q, qd = t_eval[:kept], q[:kept], qd[:kept]
    lengths, rates, _ = motion_over(scenario.profile, t)
    sampled = model.sample(t, lengths, rates, q, qd)
    if watch.tips is not None:
        sampled = sampled._replace(tips=watch.tips[:kept])
    accuracy = Accuracy(
        stepper.rtol,
        stepper.relative_error_estimate,
        stepper.steps_taken,
        stepper.steps_rejected,
    )
    return DeploymentRun(sampled, wall, watch.peaks.peaks, watch.warning, alarm, accuracy)


def hold_reactions(model: SailModel, profile, t) -> np.ndarray:
    """What a free hub's holds supply at times `t` [s] (k,) while `profile` moves the
    booms (`SailModel.hold_loads`): (k, 3) of F_x, F_y [N] in the inertial x-y plane
    and tau_z [N m] about the body z axis; zero with point-symmetric motion."""
    return np.array([model.hold_loads(*profile(float(ti))) for ti in np.asarray(t)])


HOLD_SPACING_S = 0.01  # the holds follow the boom motion alone: sampled this finely


class HoldPeaks(NamedTuple):
    """The largest reactions a free hub's holds supply over a run (`hold_peaks`): the
    in-plane force |(F_x, F_y)| [N] and the spin torque |tau_z| [N m], each with its
    time [s], sampled every `spacing_s` [s]."""

    force: float  # [N]
    force_time_s: float
    torque: float  # [N m]
    torque_time_s: float
    spacing_s: float


def hold_peaks(model: SailModel, profile, duration: float, spacing=HOLD_SPACING_S) -> HoldPeaks:
    """The peak hold reactions while `profile` moves the booms over [0, duration] [s],
    from `hold_reactions` every `spacing` [s] (the first time of the largest)."""
    t = np.linspace(0.0, duration, max(1, math.ceil(duration / spacing - 1e-9)) + 1)
    holds = hold_reactions(model, profile, t)
    force, torque = np.hypot(holds[:, 0], holds[:, 1]), np.abs(holds[:, 2])
    i, j = int(np.argmax(force)), int(np.argmax(torque))
    return HoldPeaks(float(force[i]), float(t[i]), float(torque[j]), float(t[j]),
                     float(t[1] - t[0]) if t.size > 1 else 0.0)  # fmt: skip


def rerun_peaks(
    model: SailModel,
    scenario: Scenario,
    run: DeploymentRun,
    finer: SailModel,
    max_step: float = DEFAULT_MAX_STEP,
    progress=None,
    policy: Policy | None = None,
) -> Peaks:
    """The true peaks of `scenario` run again on `finer`, a model with more modes than
    `model` (whose run is `run`), from the same initial deflection: the cantilever and
    triangle functions of the coarser model are the first ones of the finer (the bases
    are nested), so its coordinates carry over by name and the new ones start at 0.

    Raises:
        OutOfRangeError: the rerun left the linear range (its alarm).
    """
    q0, qd0 = scenario.initial_state(model)
    initial = (carried_over(q0, model, finer), carried_over(qd0, model, finer))
    rtol = run.accuracy.rtol if run.accuracy is not None else DEFAULT_RTOL
    rerun = run_deployment(
        finer, scenario, run.t, max_step, progress, initial, policy, rtol, rates=None, states=False
    )
    if rerun.alarm:
        raise OutOfRangeError(
            f"the rerun at (n_B, n_M) = ({finer.n_boom_modes}, {finer.n_membrane_modes}): "
            f"{rerun.alarm}"
        )
    return rerun.peaks


def carried_over(values, model: SailModel, finer: SailModel) -> np.ndarray:
    """Coordinates (or velocities) of `model` as those of `finer`, a model with more
    modes: by name, the new ones 0 (the bases are nested)."""
    index = {name: i for i, name in enumerate(finer.coordinate_names)}
    carried = np.zeros(finer.n)
    for name, value in zip(model.coordinate_names, values, strict=True):
        carried[index[name]] = value
    return carried
