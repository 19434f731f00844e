"""The true peaks of a log run again, and how far they move on a finer model.

A log's samples miss what happens between them; a rerun does not: a `sail-ros deploy`
log's recorded scenario runs again within the limits it recorded, a live log's logged
motion, loads and state as `log_rerun.rerun_log` rebuilds them. The rerun's true peaks
(taken inside every integration step), how closely it reproduces the logged tips, and,
asked for, the peaks of one more rerun on a finer model (`convergence.converge`: four
more boom modes, the membrane band 1.25 times wider) against them.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from sail_ros.analysis.convergence import Convergence, converge
from sail_ros.analysis.deployment import carried_over, run_deployment
from sail_ros.analysis.log_rerun import rerun_log
from sail_ros.analysis.log_series import LogSeries
from sail_ros.analysis.scenario import check_scenario, scenario_from_dict
from sail_ros.integrate.errors import AccuracyWarning
from sail_ros.integrate.peaks import Peaks
from sail_ros.model import SailModel, SailParameters, yaml_values
from sail_ros.policy import OutOfRangeError, Policy

LIVE_RERUN = "the logged motion, loads and state"
SCENARIO_RERUN = "the recorded scenario"


@dataclasses.dataclass(frozen=True)
class RerunPeaks:
    """A log run again.

    Attributes:
        what: what ran again (`SCENARIO_RERUN` or `LIVE_RERUN`).
        params: the sail it ran on (the log's mode counts).
        peaks: its true peaks (times on the log's time axis), or None when it could not
            run (`not_possible` says why) or left the linear range.
        agreement: the largest difference from the logged tips over their peak [-].
        runs: how many runs the log held (a reset starts one).
        warnings: what the rerun's error estimate said, each once.
        convergence: the rerun on a finer model against it (`Convergence`), or None.
        finer_warnings: what that rerun's error estimate said, each once.
        not_possible: why the log cannot run again ("" when it could).
        stopped: the alarm of a rerun that left the linear range ("" if none did).
    """

    what: str
    params: SailParameters
    peaks: Peaks | None = None
    agreement: float = np.nan
    runs: int = 1
    warnings: tuple[str, ...] = ()
    convergence: Convergence | None = None
    finer_warnings: tuple[str, ...] = ()
    not_possible: str = ""
    stopped: str = ""

    @property
    def finer_params(self) -> SailParameters | None:
        """The finer rerun's sail (None without one)."""
        if self.convergence is None:
            return None
        finest = self.convergence.finest
        return self.params.replace(
            n_boom_modes=finest.n_boom_modes, n_membrane_modes=finest.n_membrane_modes
        )


def rerun_peaks(log: LogSeries, model: SailModel, limits: dict, finer: bool) -> RerunPeaks:
    """`log` (`read_log`) run again on `model` (its sail), and with `finer` once more on a
    finer model.

    Args:
        log: the log.
        model: the log's sail.
        limits: limits that replace those the log recorded (`Policy` fields; `--set`).
        finer: rerun on a finer model too (`convergence.converge`, one level).

    Raises:
        ValueError: a deploy log's scenario asks what its limits refuse, or a recorded
            limit is not one.
    """
    what, rerun = LIVE_RERUN, rerun_log
    if log.scenario is not None:
        what, rerun = SCENARIO_RERUN, _scenario_rerun(log, model, rerun_policy(log, limits))
    try:
        (peaks, agreement, runs), said = _noting_accuracy(rerun, log, model)
    except OutOfRangeError as error:
        return RerunPeaks(what, model.params, stopped=f"the rerun of {what}: {error}")
    except ValueError as error:
        return RerunPeaks(what, model.params, not_possible=str(error))
    found = RerunPeaks(what, model.params, peaks, agreement, runs, said)
    if not finer:
        return found
    try:
        convergence, finer_said = _noting_accuracy(
            converge,
            lambda finer: rerun(log, finer, carried_from=model)[0],
            model,
            peaks,
            max_levels=1,
        )
    except OutOfRangeError as error:
        return dataclasses.replace(found, stopped=str(error))
    return dataclasses.replace(found, convergence=convergence, finer_warnings=finer_said)


def _noting_accuracy(function, *args, **kwargs):
    """`function(*args, **kwargs)` and the distinct messages of the `AccuracyWarning`s it
    gave, which the report says once each."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", AccuracyWarning)
        result = function(*args, **kwargs)
    messages = dict.fromkeys(str(w.message) for w in said if w.category is AccuracyWarning)
    return result, tuple(messages)


def rerun_policy(log: LogSeries, limits: dict) -> Policy:
    """The limits a rerun keeps: those the log recorded (the simulator's parameters of
    the same names), changed by `limits`."""
    recorded = {
        name: yaml_values.load(log.parameters[name])
        for name in Policy.field_names()
        if log.parameters and name in log.parameters
    }
    return Policy(**{**recorded, **limits})


def _scenario_rerun(log: LogSeries, model: SailModel, policy: Policy):
    """A rerun of a deploy log's scenario within `policy`, as `log_rerun.rerun_log` runs a
    live log: `(log, model, carried_from=None) -> (peaks, agreement, runs)`, which raises
    OutOfRangeError with the alarm of a rerun that left the linear range.

    Raises:
        ValueError: the scenario asks what `policy` refuses (`check_scenario`).
    """
    scenario = scenario_from_dict(log.scenario)
    try:
        check_scenario(scenario, model, policy)
    except ValueError as error:
        raise ValueError(f"the recorded scenario: {error}") from None
    step = float(log.parameters.get("max_model_step", "0.05")) if log.parameters else 0.05

    def rerun(log, model, carried_from=None):
        if log.tips is None or not log.simulation_time:
            raise ValueError("the log holds no tip deflections on simulation time")
        t = log.seconds(log.tips.stamp_ns)
        initial = None
        if carried_from is not None:
            initial = tuple(
                carried_over(values, carried_from, model)
                for values in scenario.initial_state(carried_from)
            )
        if scenario.controller is not None:  # the recorded loop, closed again
            from sail_ros.analysis.closed_loop import run_closed_loop

            closed = run_closed_loop(model, scenario, scenario.controller, policy, max_step=step)
            run = closed.run.subset(np.isin(np.round(closed.run.t, 6), np.round(t, 6)))
        else:
            # the tips alone: the log's own model gives them as the log did, to the bit (no
            # velocities inside steps), a finer one from the peaks' pass over each step
            run = run_deployment(
                model, scenario, t, step, initial=initial, policy=policy, rates=None,
                states=carried_from is None,
            )  # fmt: skip
        if run.alarm:
            raise OutOfRangeError(run.alarm)
        if run.accuracy.warning:  # said once by the report
            warnings.warn(run.accuracy.warning, AccuracyWarning, stacklevel=1)
        logged = log.tips.position
        agreement = np.abs(run.tips - logged).max() / max(float(np.abs(logged).max()), 1e-300)
        return run.peaks, float(agreement), 1

    return rerun
