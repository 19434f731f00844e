"""Batch integration: a whole run sampled at output times, on top of the stepper."""

from __future__ import annotations

import numpy as np

from sail_ros.integrate.control import time_slack
from sail_ros.integrate.sampling import GridSampler
from sail_ros.integrate.stepper import SailStepper
from sail_ros.integrate.system import LinearSystem


class Run(tuple):
    """`(t, q, qd)` of a run, unpacked like a tuple, and what the stepper reports about it:
    `rtol`, `atol` (the tolerance asked), `error_estimate` and
    `relative_error_estimate` (per output kind, `SailStepper.error_estimate`), `steps`
    and `rejected` (steps taken and refused)."""

    def __new__(cls, t, q, qd, stepper: SailStepper):
        run = super().__new__(cls, (t, q, qd))
        run.rtol, run.atol = stepper.rtol, dict(stepper.atol)
        run.error_estimate = stepper.error_estimate
        run.relative_error_estimate = stepper.relative_error_estimate
        run.steps, run.rejected = stepper.steps_taken, stepper.steps_rejected
        return run


def simulate(
    system: LinearSystem,
    profile,
    t_end: float,
    q0=None,
    qd0=None,
    t_eval=None,
    progress=None,
    inputs=None,
    observer=None,
    **options,
):
    """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`.

    Args:
        system: the structure (`stepper.LinearSystem`, e.g. a `SailModel`).
        profile: callable `t -> (lengths, rates, accelerations)` (see `profiles`).
        t_end: final time [s], > 0.
        q0: initial coordinates [m] (default 0).
        qd0: initial velocities [m/s] (default 0).
        t_eval: increasing output times in [0, t_end]; default a uniform
            grid with the stepper's `max_step` spacing (default 0.5 s).
        progress: optional callable `progress(t)` after each output time.
        inputs: callable `t -> u` or None. With `switch_times` [s] (`loads.input_function`
            of a `LoadSchedule`) steps end there; without, at every output time as well.
        observer: optional object that sees every step: `observer.start(stepper)`
            before the first, `observer.after_step(stepper)` after each accepted one
            (e.g. `peaks.OutputPeaks`).
        options: `SailStepper` options, `rtol`, `atol` (the tolerance), `max_step` [s],
            `resolved_frequency` [rad/s].

    Returns:
        `Run`, `(t, q, qd)`: times (k,), coordinates (k, n), velocities (k, n), with the
        stepper's error estimate.
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
    stepper = SailStepper(system, profile, q0=q0, qd0=qd0, inputs=inputs, **options)
    if observer is not None:
        observer.start(stepper)
        stepper.on_step = observer.after_step
    if t_eval is None:
        count = int(np.ceil(t_end / stepper.max_step - 1e-9))
        t_eval = np.linspace(0.0, t_end, count + 1)
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size == 0 or not np.all(np.isfinite(t_eval)):
        raise ValueError(f"t_eval must be a non-empty 1-D array of finite times, got {t_eval!r}")
    if np.any(np.diff(t_eval) < 0) or t_eval[0] < 0 or t_eval[-1] > t_end:
        raise ValueError(f"t_eval must increase within [0, t_end = {t_end}], got {t_eval!r}")
    q = np.empty((t_eval.size, system.n))
    qd = np.empty((t_eval.size, system.n))
    for done, reached in sample(stepper, t_eval, t_end, q, qd):
        if progress is not None:
            for t in t_eval[done:reached]:
                progress(t)
    return Run(t_eval.copy(), q, qd, stepper)


def sample(stepper: SailStepper, t_eval: np.ndarray, t_end: float, q, qd, rates="exact"):
    """Step `stepper` to `t_end` [s] and write its state at the output times `t_eval`
    (increasing, from its time on) into `q`, `qd` (each (k, n)); yields `(done,
    reached)` after each step, the outputs `t_eval[done:reached]` written.

    Steps end at `t_end` and at the inputs' switch times, and output times inside a
    step come from its continuous extension or, at rest, its exact propagator
    (`SailStepper.states_at`), so the steps do not depend on the output times; inputs
    whose switches are not known (a plain callable) and fixed steps (`rtol` None) end
    steps at output times too. What the
    stepper raises (a non-finite state, an observer's stop) ends it: the outputs
    written so far are those of the last yield. `rates`: as `SailStepper.states_at`."""
    inputs = stepper.inputs
    free = stepper.rtol is not None and (inputs is None or hasattr(inputs, "switch_times"))
    done = 0
    while done < t_eval.size:
        t = t_eval[done]
        while t - stepper.t > time_slack(t):
            stepper.advance_step(t_end if free else t)
        reached = done + int(
            np.searchsorted(t_eval[done:], stepper.t + time_slack(stepper.t), "right")
        )
        q[done:reached], qd[done:reached] = stepper.states_at(t_eval[done:reached], rates)
        yield done, reached
        done = reached


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
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
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
