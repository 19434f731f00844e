"""An offline deployment run: the sail's state on a time grid under a scenario.

The same integration as the live simulator (`SailModel.simulate`, the
exponential-midpoint stepper of `sail_ros.model.stepper`), run as fast as
the machine allows; the wall time gives the achieved real-time factor.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from sail_ros.analysis.scenario import Scenario
from sail_ros.model import SailModel
from sail_ros.model.sail_model import StateSample
from sail_ros.model.stepper import DEFAULT_MAX_STEP


@dataclasses.dataclass(frozen=True)
class DeploymentRun:
    """States of one run at the output times.

    Attributes:
        t: output times [s], (k,).
        lengths, rates: boom lengths [m] and extension rates [m/s], (k, 4).
        q, qd: generalised coordinates [m] and velocities [m/s], (k, n).
        tips, tip_rates: boom-tip deflections [m] and their rates [m/s], (k, 4).
        wall_seconds: wall time of the integration [s].
        root_moments: root bending moments [N m] of booms a..d, (k, 4).
    """

    t: np.ndarray
    lengths: np.ndarray
    rates: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tips: np.ndarray
    tip_rates: np.ndarray
    wall_seconds: float
    root_moments: np.ndarray

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall second."""
        return float(self.t[-1] - self.t[0]) / max(self.wall_seconds, 1e-9)

    def subset(self, mask) -> DeploymentRun:
        """The run at the output times selected by `mask` (boolean or indices)."""
        return dataclasses.replace(
            self,
            t=self.t[mask],
            lengths=self.lengths[mask],
            rates=self.rates[mask],
            q=self.q[mask],
            qd=self.qd[mask],
            tips=self.tips[mask],
            tip_rates=self.tip_rates[mask],
            root_moments=self.root_moments[mask],
        )

    def sample(self, i: int) -> StateSample:
        """The state at output time `i`."""
        return StateSample(
            float(self.t[i]),
            self.lengths[i],
            self.rates[i],
            self.q[i],
            self.qd[i],
            self.tips[i],
            self.tip_rates[i],
            self.root_moments[i],
        )

    def index_of(self, t: float) -> int:
        """Index of the output time nearest to `t` [s]."""
        return int(np.argmin(np.abs(self.t - t)))


def output_times(duration: float, rate_hz: float, extra=()) -> np.ndarray:
    """A uniform grid of `rate_hz` [Hz] over [0, duration] [s], with the end and
    the `extra` times [s] merged in."""
    if not rate_hz > 0:
        raise ValueError(f"output rate must be > 0 Hz, got {rate_hz!r}")
    count = int(np.floor(duration * rate_hz + 1e-9))
    grid = np.arange(count + 1) / rate_hz
    merged = np.concatenate([grid, [duration], np.asarray(list(extra), dtype=float)])
    # merge times closer than 1 us: they are the same sample
    merged = np.unique(np.round(merged, 6))
    return merged[(merged >= 0.0) & (merged <= duration)]


def run_deployment(
    model: SailModel, scenario: Scenario, t_eval, max_step: float = DEFAULT_MAX_STEP, progress=None
) -> DeploymentRun:
    """Integrate the scenario and sample it at `t_eval` [s] (and at its load switches,
    which thereby fall on step boundaries).

    Args:
        model: the sail model (its parameters should include `scenario.sail`).
        scenario: boom motion, initial state, duration.
        t_eval: increasing output times within [0, scenario.duration].
        max_step: largest integration step [s].
        progress: optional callable `progress(t)` after each output time.
    """
    q0, qd0 = scenario.initial_state(model)
    if scenario.loads is not None:
        switches = [t for t in scenario.loads.switch_times if 0.0 < t < scenario.duration]
        t_eval = np.union1d(np.asarray(t_eval, dtype=float), switches)
    started = time.perf_counter()
    t, q, qd = model.simulate(
        scenario.profile,
        scenario.duration,
        q0,
        qd0,
        t_eval=t_eval,
        loads=scenario.loads,
        progress=progress,
        max_step=max_step,
    )
    wall = time.perf_counter() - started
    motion = [scenario.profile(ti) for ti in t]
    lengths = np.array([m[0] for m in motion], dtype=float)
    rates = np.array([m[1] for m in motion], dtype=float)
    return DeploymentRun(
        t,
        lengths,
        rates,
        q,
        qd,
        model.tip_deflections(q),
        model.tip_deflections(qd),
        wall,
        model.root_moments(q, lengths),
    )
