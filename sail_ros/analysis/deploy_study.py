"""`sail-ros deploy`'s study: a scenario run open or closed loop, its convergence, its
holds, on the times its table, log and figures ask for.

`study` is the one call: it refuses, before anything is allocated, a request whose
outputs would not fit or whose scenario names coordinates the model lacks, builds the
model, runs the scenario (with a controller section: closed loop, and open loop for the
comparison), reruns it on finer models when asked (`analysis.convergence`) and takes a
free hub's hold reactions. What it found is a `DeployStudy`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sail_ros.analysis.convergence import converge, finer_parameters
from sail_ros.analysis.deployment import (
    hold_peaks,
    output_count,
    output_times,
    rerun_peaks,
    run_deployment,
    sample_bytes,
)
from sail_ros.analysis.scenario import check_scenario
from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL, atol_floors
from sail_ros.model import SailModel, SailParameters
from sail_ros.model.layout import Layout
from sail_ros.policy import OutOfRangeError, Policy


@contextlib.contextmanager
def _silent(what, total):
    yield None


@dataclasses.dataclass(frozen=True)
class DeployRequest:
    """What a deploy run is asked for: the options of `sail-ros deploy`, named so in errors.

    Attributes:
        every: the table's interval [s].
        rate: state samples per simulated second of the log and the figures [Hz].
        max_step: the largest integration step [s].
        rtol: the stepper's tolerance (0: fixed steps of `max_step`).
        atol: its absolute floors per output kind (`integrate.control.atol_floors`; None: the
            defaults).
        snapshots: the snapshot times [s].
        convergence: None (no reruns), () (the ladder) or `(n_B, n_M)` (one rerun).
        shape_rate: /sail/shape messages per simulated second in the log [Hz] (0: none).
        shape_divisions: mesh subdivisions of each quadrant edge in /sail/shape.
        mcap: the log to write (a .mcap file or a new bag folder), or None.
        figures: the folder of the figures, or None.
        source: the scenario's file, named in errors ("": the reference deployment).
    """

    every: float = 1.0
    rate: float = 50.0
    max_step: float = DEFAULT_MAX_STEP
    rtol: float = DEFAULT_RTOL
    atol: dict | None = None
    snapshots: tuple = ()
    convergence: tuple | None = None
    shape_rate: float = 5.0
    shape_divisions: int = 10
    mcap: Path | None = None
    figures: Path | None = None
    source: str = ""

    @property
    def outputs(self) -> bool:
        """A log or figures are written: the fine grid of `rate` is needed."""
        return bool(self.mcap or self.figures)

    def check(self, duration: float) -> None:
        """ValueError naming the option of a value a run of `duration` [s] cannot take."""
        if not self.every > 0:
            raise ValueError(f"--every must be > 0, got {self.every}")
        if not self.rate > 0:
            raise ValueError(f"--rate must be > 0 Hz, got {self.rate}")
        if not (math.isfinite(self.max_step) and self.max_step > 0):
            raise ValueError(f"--max-step must be finite and > 0 s, got {self.max_step}")
        if not 0.0 <= self.rtol < 1.0:
            raise ValueError(f"--rtol must be in [0, 1) (0: fixed steps), got {self.rtol}")
        atol_floors(self.atol)
        if self.shape_rate < 0 or self.shape_rate > self.rate:
            raise ValueError(
                f"--shape-rate must be in [0, --rate = {self.rate:g}] Hz, got {self.shape_rate}"
            )
        if self.shape_divisions < 1:
            raise ValueError(f"--shape-divisions must be >= 1, got {self.shape_divisions}")
        for t in self.snapshots:
            if not 0.0 <= t <= duration:
                raise ValueError(f"--snapshots: {t:g} s is outside [0, {duration:g}] s")
        if self.convergence is not None and len(self.convergence) not in (0, 2):
            got = list(self.convergence)
            raise ValueError(f"--convergence takes no value or two (N_B N_M), got {got}")
        mcap = self.mcap
        if (
            mcap is not None
            and mcap.suffix != ".mcap"
            and mcap.exists()
            and (not mcap.is_dir() or any(mcap.iterdir()))
        ):
            raise ValueError(f"--mcap {mcap}: exists; give a new bag folder or a .mcap file")


@dataclasses.dataclass
class DeployStudy:
    """What `study` found: the run (closed loop: its run), the model, the table's times
    [s], the log's grid [s], the reruns (`analysis.convergence.Convergence`) or None,
    a free hub's hold peaks or None, a closed loop, its open-loop comparison and its
    summary (`analysis.closed_loop.summary`) or None, and the alarm that stopped the run
    or its reruns ("" if none)."""

    result: object
    model: SailModel
    table_times: np.ndarray
    grid: np.ndarray
    convergence: object = None
    holds: object = None
    closed: object = None
    open_loop: object = None
    controller: dict | None = None
    stopped: str = ""


def study(
    scenario, params: SailParameters, policy: Policy, request: DeployRequest,
    check: Callable = lambda method, *args: method(*args), progress=_silent,
) -> DeployStudy:  # fmt: skip
    """Run `scenario` on the sail `params` within `policy` as `request` asks.

    Args:
        scenario: the scenario (`analysis.scenario.Scenario`).
        params: the sail, its membrane count resolved for the scenario.
        policy: the limits and alarms.
        request: what is asked (the table, the log and figures, the reruns).
        check: calls a check of the policy (`check(method, *args)`), so its error can
            say where the limits came from.
        progress: `progress(what, total)`, a context giving a callable of the simulated
            time reached [s] (or None), around each run (None the first).

    Raises:
        ValueError: the request or the scenario asks what the model or the policy refuse.
    """
    duration = scenario.duration
    request.check(duration)
    if request.convergence:  # explicit counts: checked before the run
        finer_parameters(params, *request.convergence)
    _output_size(request, duration, params.coordinates)
    table_times = np.unique(np.append(np.arange(0.0, duration, request.every), duration))
    grid = output_times(duration, request.rate)
    if request.outputs:
        t_eval = output_times(duration, request.rate, extra=[*table_times, *request.snapshots])
    else:  # the table alone: no fine grid, whose short steps would slow the run
        t_eval = table_times
    try:  # what the scenario names: its coordinates, before the model's integrals
        scenario.check_coordinates(
            Layout(params.n_boom_modes, params.membrane_modes, params.free_hub)
        )
    except ValueError as error:
        raise ValueError(f"{request.source or 'the reference deployment'}: {error}") from None
    model = SailModel(params)
    check(check_scenario, scenario, model, policy)
    found = DeployStudy(None, model, table_times, grid)
    rtol = request.rtol or None
    if scenario.controller is not None:
        found.closed, found.open_loop = _closed_loop(model, scenario, policy, request, t_eval,
                                                     progress)  # fmt: skip
        found.result = found.closed.run
        from sail_ros.analysis.closed_loop import summary

        found.controller = summary(found.closed, found.open_loop)
    else:
        with progress(None, duration) as reached:
            found.result = run_deployment(
                model, scenario, t_eval, request.max_step, reached, policy=policy, rtol=rtol,
                atol=request.atol,
            )  # fmt: skip
    found.stopped = found.result.alarm
    if request.convergence is not None and not found.stopped:

        def rerun(finer):
            what = f"rerun at (n_B, n_M) = ({finer.n_boom_modes}, {finer.n_membrane_modes})"
            with progress(what, duration) as reached:
                return rerun_peaks(
                    model, scenario, found.result, finer, request.max_step, reached, policy
                )

        try:
            counts = request.convergence or None
            found.convergence = converge(rerun, model, found.result.peaks, counts)
        except OutOfRangeError as error:
            found.stopped = str(error)
    if model.free_hub:  # over the time the run reached
        found.holds = hold_peaks(model, scenario.profile, float(found.result.t[-1]))
    return found


def _output_size(request: DeployRequest, duration: float, n: int) -> None:
    """Refuse, before anything is allocated, a run whose outputs would not fit
    (`Policy.check_output`), naming the estimate; `n` coordinates."""
    samples = output_count(duration, 1.0 / request.every)
    what = f"the run over {duration:g} s (a table row every {request.every:g} s"
    if request.outputs:
        samples += output_count(duration, request.rate) + len(request.snapshots)
        what += f", {request.rate:g} Hz for --mcap/--figures"
    Policy.check_output(
        samples, sample_bytes(n), what + ")", "a shorter duration, a longer --every, a lower --rate"
    )


def _closed_loop(model, scenario, policy, request, t_eval, progress):
    """The scenario with its controller (`analysis.closed_loop`), and without it on the
    output times `t_eval` for the comparison."""
    from sail_ros.analysis.closed_loop import run_closed_loop

    if request.convergence is not None:
        raise ValueError(
            "--convergence reruns the open loop; a scenario with a controller section "
            "runs closed (raise n_boom_modes and n_membrane_modes with --set instead)"
        )
    design = scenario.controller
    ratio = design.state_rate_hz / request.rate
    if request.mcap and abs(ratio - round(ratio)) > 1e-9:
        raise ValueError(
            f"--rate {request.rate:g} Hz: the log of a closed loop takes every state "
            f"sample's multiple; it must divide the controller's state_rate_hz = "
            f"{design.state_rate_hz:g} Hz"
        )
    rtol = request.rtol or None
    with progress("closed loop", scenario.duration) as reached:
        closed = run_closed_loop(model, scenario, design, policy, progress=reached,
                                 max_step=request.max_step, rtol=rtol,
                                 atol=request.atol)  # fmt: skip
    with progress("open loop", scenario.duration) as reached:
        open_loop = run_deployment(model, scenario, t_eval, request.max_step, reached,
                                   policy=policy, rtol=rtol, atol=request.atol)  # fmt: skip
    return closed, open_loop
