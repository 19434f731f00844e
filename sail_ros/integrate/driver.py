"""The one batch driver: a whole run sampled at output times, with observers.

`run` steps a `SailStepper` to the end and writes its state at the output times from the
steps' dense output, so the steps, and the results, do not depend on where the outputs
fall. Observers see every step (`start`, `after_step`, `finish`: the true peaks, the
range watch); one may end the run (`errors.StopError`), as a non-finite state does
(`errors.IntegrationError`): the outputs before it are kept and the run says why. A
sampled-data loop (`at_outputs`, a controller) reads the state at each output time and
may change the inputs from there on: the steps then end at the output times.
`SailModel.simulate`, `simulate_on_grid`, the deployment runs and the log reruns all run
through here.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from sail_ros.integrate.control import accuracy_warning, time_slack
from sail_ros.integrate.errors import AccuracyWarning, IntegrationError, StopError
from sail_ros.integrate.sampling import GridSampler
from sail_ros.integrate.stepper import SailStepper
from sail_ros.integrate.system import LinearSystem


class _KeptError(Exception):
    """A non-finite state ended a run whose outputs before it are kept."""


class Run(tuple):
    """`(t, q, qd)` of a run, unpacked like a tuple, and what the stepper reports about it:
    `rtol`, `atol` (the tolerance asked), `error_estimate` and `relative_error_estimate`
    (per output kind, `SailStepper.error_estimate`), `steps` and `rejected` (steps taken
    and refused); `alarm`, why the run stopped before the end ("" if it did not), and
    `stopped_at` [s], from when (inf: none); `accuracy_warning`, one line when the error
    estimate exceeds twice the run's tolerance ("" if not; the run warns it too,
    `errors.AccuracyWarning`)."""

    def __new__(cls, t, q, qd, stepper: SailStepper, alarm: str = "", stopped_at=math.inf):
        run = super().__new__(cls, (t, q, qd))
        run.rtol, run.atol = stepper.rtol, dict(stepper.atol)
        run.error_estimate = stepper.error_estimate
        run.relative_error_estimate = stepper.relative_error_estimate
        run.steps, run.rejected = stepper.steps_taken, stepper.steps_rejected
        run.alarm, run.stopped_at = alarm, stopped_at
        run.accuracy_warning = accuracy_warning(
            run.rtol, run.relative_error_estimate, run.atol, stepper.peaks
        )
        return run


def check_end(t_end: float, t0: float = 0.0) -> None:
    """ValueError unless `t_end` [s] is finite and after `t0` [s]."""
    if not (np.isfinite(t_end) and t_end > t0):
        raise ValueError(f"t_end must be finite and > {t0:g}, got {t_end!r}")


def check_times(t_eval, t_end: float, t0: float = 0.0) -> np.ndarray:
    """`t_eval` as increasing finite times within [t0, t_end] [s] (ValueError if not)."""
    check_end(t_end, t0)
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size == 0 or not np.all(np.isfinite(t_eval)):
        raise ValueError(f"t_eval must be a non-empty 1-D array of finite times, got {t_eval!r}")
    if np.any(np.diff(t_eval) < 0) or t_eval[0] < t0 or t_eval[-1] > t_end:
        raise ValueError(f"t_eval must increase within [{t0:g}, t_end = {t_end}], got {t_eval!r}")
    return t_eval


def run(
    stepper: SailStepper,
    t_eval,
    t_end: float,
    observers=(),
    rates: str | None = "exact",
    states: bool = True,
    progress=None,
    at_outputs=None,
    stop_at_outputs: bool = False,
    keep_on_error: bool = True,
) -> Run:
    """Step `stepper` to `t_end` [s] (or its last output time, if later outputs are not
    asked) and give its state at the output times `t_eval` (increasing, from its time on).

    Args:
        stepper: the `SailStepper`, at its start.
        t_eval: output times [s].
        t_end: the run's end [s].
        observers: objects with `start(stepper)`, `after_step(stepper)` and `finish()`,
            which see every step (`finish` after the last, or before a non-finite state
            ends the run: a `StopError` among the steps before it comes first).
        rates: the velocities at output times inside steps (`SailStepper.states_at`).
        states: False: no state at output times but where one is a step's end (`q`, `qd`
            nan elsewhere): for a caller whose observers take what it reads.
        progress: callable `progress(t)` after each step, or None.
        at_outputs: callable `at_outputs(i, t, q, qd)` at each output time in turn, which
            may give the stepper new inputs from then on, or None; the steps end there.
        stop_at_outputs: the steps end at the output times (fixed steps).
        keep_on_error: a state that becomes non-finite ends the run with the outputs
            before it (`Run.alarm`); False: `IntegrationError` is raised.
    """
    t_eval = check_times(t_eval, t_end, stepper.t)
    for observer in observers:
        observer.start(stepper)
    if observers:
        stepper.on_step = lambda s: [observer.after_step(s) for observer in observers]
    n = stepper.system.n
    q, qd = np.full((t_eval.size, n), np.nan), np.full((t_eval.size, n), np.nan)
    kept, alarm, stopped_at = 0, "", math.inf
    try:
        try:
            kept = _outputs(stepper, t_eval, 0, q, qd, rates, states, at_outputs)
            while kept < t_eval.size:
                stop = stop_at_outputs or at_outputs is not None
                target = t_eval[kept] if stop else t_end
                stepper.advance_step(target)
                kept = _outputs(stepper, t_eval, kept, q, qd, rates, states, at_outputs)
                if progress is not None:
                    progress(stepper.t)
        except IntegrationError as error:
            for observer in observers:
                observer.finish()
            if not keep_on_error:
                raise
            raise _KeptError(str(error)) from None
        for observer in observers:
            observer.finish()
    except (StopError, _KeptError) as error:
        alarm = str(error)
        stopped_at = getattr(error, "at", math.inf)
        # the outputs before the stop (the stepper may be steps on: an observer may see
        # steps in batches); none after a state that became non-finite, never taken
        if math.isfinite(stopped_at):
            before = int(np.searchsorted(t_eval, stopped_at, "left"))
            if states and before > kept:  # inside the last step
                q[kept:before], qd[kept:before] = stepper.states_at(t_eval[kept:before], rates)
            kept = before
    result = Run(t_eval[:kept].copy(), q[:kept], qd[:kept], stepper, alarm, stopped_at)
    if result.accuracy_warning:
        warnings.warn(result.accuracy_warning, AccuracyWarning, stacklevel=2)
    return result


def _outputs(stepper, t_eval, done, q, qd, rates, states, at_outputs) -> int:
    """Write the outputs from `done` up to the stepper's time; how many are written."""
    reached = done + int(np.searchsorted(t_eval[done:], stepper.t + time_slack(stepper.t), "right"))
    if reached == done:
        return done
    if states:
        q[done:reached], qd[done:reached] = stepper.states_at(t_eval[done:reached], rates)
    elif abs(t_eval[reached - 1] - stepper.t) <= time_slack(stepper.t):
        q[reached - 1], qd[reached - 1] = stepper.q, stepper.qd
    if at_outputs is not None:
        for i in range(done, reached):
            at_outputs(i, float(t_eval[i]), q[i], qd[i])
    return reached


def simulate(system: LinearSystem, profile, t_end: float, q0=None, qd0=None, t_eval=None,
             progress=None, inputs=None, observer=None, rates="exact",
             **options) -> Run:  # fmt: skip
    """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`.

    Args:
        system: the structure (`LinearSystem`, e.g. a `SailModel`).
        profile: callable `t -> (lengths, rates, accelerations)` (see `profiles`).
        t_end: final time [s], > 0.
        q0: initial coordinates [m] (default 0).
        qd0: initial velocities [m/s] (default 0).
        t_eval: increasing output times in [0, t_end]; default a uniform grid with the
            stepper's `max_step` spacing (default 0.5 s).
        progress: optional callable `progress(t)` after each step.
        inputs: callable `t -> u` or None (with `switch_times` [s], steps end there).
        observer: optional object that sees every step: `start(stepper)`,
            `after_step(stepper)` (e.g. `peaks.OutputPeaks`), and at the end `finish()`, or
            else `flush()`, if it has one.
        rates: the velocities at output times inside steps (`SailStepper.states_at`):
            "exact", "extension" (off by about 0.3 % of peak) or None (`qd` nan there),
            for a caller that reads the coordinates alone; `q` the same to the bit.
        options: `SailStepper` options, `rtol`, `atol` (the tolerance), `max_step` [s],
            `resolved_frequency` [rad/s].

    Returns:
        `Run`, `(t, q, qd)`: times (k,), coordinates (k, n), velocities (k, n), with the
        stepper's error estimate.
    """
    stepper = SailStepper(system, profile, q0=q0, qd0=qd0, inputs=inputs, **options)
    if t_eval is None:
        check_end(t_end)
        count = int(np.ceil(t_end / stepper.max_step - 1e-9))
        t_eval = np.linspace(0.0, t_end, count + 1)
    observers = () if observer is None else (_Observer(observer),)
    # fixed steps end at the output times
    return run(stepper, t_eval, t_end, observers, rates, progress=progress,
               stop_at_outputs=stepper.rtol is None,
               keep_on_error=False)  # fmt: skip


class _Observer:
    """An observer that may lack `finish`: its `flush` ends it then (`peaks.OutputPeaks`),
    or nothing."""

    def __init__(self, observer):
        self.observer = observer
        self.start, self.after_step = observer.start, observer.after_step

    def finish(self) -> None:
        finish = getattr(self.observer, "finish", None) or getattr(self.observer, "flush", None)
        if finish is not None:
            finish()


def simulate_on_grid(
    system: LinearSystem,
    profile,
    t_end: float,
    spacing: float,
    q0=None,
    qd0=None,
    progress=None,
    **options,
):
    """The state every `spacing` [s] from t = 0 to `t_end` [s] as the simulator samples
    it (`sampling.GridSampler`: exact steps at rest; moving steps of whole grid intervals
    chosen by the tolerance, up to `max_step`, the grid points inside from the step's
    continuous extension).

    Args and returns as `simulate`, with the grid in place of `t_eval`.
    """
    check_end(t_end)
    stepper = SailStepper(system, profile, q0=q0, qd0=qd0, **options)
    sampler = GridSampler(stepper, spacing)
    count = int(np.floor(t_end / sampler.spacing + 1e-9))
    q = np.empty((count + 1, system.n))
    qd = np.empty((count + 1, system.n))
    t = np.empty(count + 1)
    point = sampler.point
    for i in range(count + 1):
        if i:
            point = sampler.advance()
        t[i], q[i], qd[i] = point.t, point.q, point.qd
        if progress is not None:
            progress(point.t)
    return Run(t, q, qd, stepper)
