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
import warnings
from typing import NamedTuple

import numpy as np

from sail_ros.analysis.scenario import Scenario, check_scenario
from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL
from sail_ros.integrate.driver import run
from sail_ros.integrate.errors import AccuracyWarning
from sail_ros.integrate.observers import RangeWatch
from sail_ros.integrate.peaks import Peaks
from sail_ros.model import SailModel
from sail_ros.model.hub import hold_loads_over
from sail_ros.model.loads import input_function
from sail_ros.model.profiles import motion_over
from sail_ros.model.record import StateSample, take
from sail_ros.policy import OutOfRangeError, Policy


class Accuracy(NamedTuple):
    """How a run was stepped: the tolerance `rtol` asked (None: fixed steps) and its
    absolute floors per output (`atol`, `integrate.control.atol_floors`), the achieved error
    estimate relative to each output's peak (`SailStepper.
    relative_error_estimate`: tips, tip_rates, root_moments, root_moment_rates) and in
    the outputs' units (`error`), the steps taken and refused, and one line when the
    estimate exceeds twice the run's tolerance (`warning`, "" if not)."""

    rtol: float | None
    relative_error: dict
    steps: int
    rejected: int
    error: dict | None = None
    warning: str = ""
    atol: dict | None = None

    @classmethod
    def of(cls, run) -> Accuracy:
        """Of a `driver.Run`."""
        return cls(run.rtol, run.relative_error_estimate, run.steps, run.rejected,
                   run.error_estimate, run.accuracy_warning, run.atol)  # fmt: skip


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
    atol: dict | None = None,
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
        atol: its absolute floors per output kind, over the defaults (`SailStepper`).
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
            other output times, `rates` of no use: for a caller that reads only those (a
            Monte Carlo sample), no state is made inside the steps but at their ends.

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
        scenario.profile, q0=q0, qd0=qd0, max_step=max_step, rtol=rtol, atol=atol,
        inputs=input_function(scenario.loads, model.free_hub),
    )  # fmt: skip
    return stepped_run(model, scenario, stepper, watch, t_eval, rates=rates, states=states,
                       progress=progress)  # fmt: skip


def stepped_run(model, scenario, stepper, watch: RangeWatch, t_eval, **options) -> DeploymentRun:
    """`stepper` run over `scenario` to the output times `t_eval` [s] (`driver.run`, its
    `options`), seen by `watch`: the `DeploymentRun` with its wall time, outputs, true
    peaks and accuracy (whose warning it says rather than warns)."""
    started = time.perf_counter()
    with warnings.catch_warnings():  # said by the run's `accuracy.warning`
        warnings.simplefilter("ignore", AccuracyWarning)
        result = run(stepper, t_eval, scenario.duration, (watch,), **options)
    wall = time.perf_counter() - started
    t, q, qd = result
    lengths, rates, _ = motion_over(scenario.profile, t)
    sampled = model.sample(t, lengths, rates, q, qd)
    if watch.tips is not None:
        sampled = sampled._replace(tips=watch.tips[: t.size])
    accuracy = Accuracy.of(result)
    return DeploymentRun(sampled, wall, watch.peaks.peaks, watch.warning, result.alarm, accuracy)


def hold_reactions(model: SailModel, profile, t) -> np.ndarray:
    """What a free hub's holds supply at times `t` [s] (k,) while `profile` moves the
    booms (`SailModel.hold_loads`): (k, 3) of F_x, F_y [N] in the inertial x-y plane
    and tau_z [N m] about the body z axis; zero with point-symmetric motion."""
    return hold_loads_over(model.params, *motion_over(profile, np.asarray(t, dtype=float)))


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
    accuracy = run.accuracy
    rtol, atol = (DEFAULT_RTOL, None) if accuracy is None else (accuracy.rtol, accuracy.atol)
    rerun = run_deployment(
        finer, scenario, run.t, max_step, progress, initial, policy, rtol, rates=None,
        states=False, atol=atol,
    )  # fmt: skip
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
