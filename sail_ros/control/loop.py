"""The discrete loop, one step per state sample, and the stale-state watchdog.

`DiscreteController.step(y, length)` takes the measurements of one sample and the mean
boom length, and returns the command to hold until the next sample:

    e^ = e^- + M (y - C e^-)             (the filtered estimate, `GainSchedule.at(length)`)
    v  = -K e^,   u = clip(v, -limit, limit)
    e^-_next = F e^ + G u                (the prediction, with the command applied)

**Anti-windup**: the prediction takes the saturated command `u`, the one the plant
gets, not `v`: the estimate of the state and of the disturbance stays that of the
plant, so nothing winds up while a channel saturates, and the loop leaves saturation
without the overshoot of an integrator that kept counting (the observer form of
Astrom and Rundqwist). Every sampled command with a channel at its limit is counted,
per channel.

The same object serves the node and the offline loop: `hold` when the plant is given
another command (a zero wrench while the state is stale), `skip` for samples that
never came (the plant held the last command), `restart` after a reset.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_ros.control.schedule import GainSchedule


@dataclasses.dataclass(frozen=True)
class Command:
    """One sample's command: `u` as held (saturated), `demand` before the limits,
    `saturated` whether each channel met its limit."""

    u: np.ndarray
    demand: np.ndarray
    saturated: np.ndarray


class DiscreteController:
    """The estimate, the command and the counts of one discrete loop (module docstring).

    Args:
        schedule: the design points over boom length.
        limits: the largest |command| of each input (`schedule.inputs`), e.g.
            max_hub_force [N], max_hub_torque [N m] twice.
    """

    def __init__(self, schedule: GainSchedule, limits):
        self.schedule = schedule
        self.limits = np.asarray(limits, dtype=float)
        if self.limits.shape != (len(schedule.inputs),) or np.any(self.limits < 0):
            raise ValueError(
                f"limits: one value >= 0 per input ({', '.join(schedule.inputs)}), got {limits!r}"
            )
        self.samples = 0  # steps taken
        self.saturated_samples = 0  # steps with at least one channel at its limit
        self.saturations = np.zeros(len(schedule.inputs), dtype=int)  # per channel
        self.restart()

    def restart(self) -> None:
        """Forget the estimate: the next step starts from what its measurements say (the
        least-squares state of the smallest norm), the disturbance zero."""
        self._prior = np.zeros(self.schedule.size)
        self._fresh = True
        self._filtered: np.ndarray | None = None
        self._point = None
        self.u = np.zeros(len(self.schedule.inputs))  # the command the plant holds

    @property
    def disturbance(self) -> np.ndarray:
        """The estimated constant disturbance on the hub wrench channels [N, N m, N m]."""
        estimate = self._prior if self._filtered is None else self._filtered
        return estimate[-3:].copy()

    def step(self, y, length: float) -> Command:
        """The command for the sample `y` (the schedule's measurements, SI) with the mean
        boom length `length` [m]; held by the plant until the next sample."""
        y = np.asarray(y, dtype=float)
        if y.shape != (len(self.schedule.measurements),) or not np.all(np.isfinite(y)):
            raise ValueError(
                f"measurements: {len(self.schedule.measurements)} finite values "
                f"({', '.join(self.schedule.measurements)}), got {y!r}"
            )
        point = self.schedule.at(float(length))
        if self._fresh:  # the filter's steady gain would take many samples to get there
            self._prior = np.linalg.pinv(point.C) @ y
            self._fresh = False
        filtered = self._prior + point.M @ (y - point.C @ self._prior)
        demand = -point.K @ filtered
        u = np.clip(demand, -self.limits, self.limits)
        saturated = np.abs(demand) > self.limits
        self.samples += 1
        self.saturations += saturated
        self.saturated_samples += bool(saturated.any())
        self._filtered, self._point = filtered, point
        self._predict(u)
        return Command(u, demand, saturated)

    def hold(self, u) -> None:
        """The plant holds `u` from the last sample on instead (e.g. a zero wrench while
        the state is stale): the prediction is made again with it."""
        u = np.asarray(u, dtype=float)
        if self._filtered is not None:
            self._predict(u)
        else:
            self.u = u.copy()

    def skip(self, count: int) -> None:
        """`count` samples did not come: the plant held the command over them, and the
        prediction goes on without measurements."""
        if self._point is None:
            return
        for _ in range(count):
            self._prior = self._point.F @ self._prior + self._point.G @ self.u

    def _predict(self, u: np.ndarray) -> None:
        self.u = u.copy()
        self._prior = self._point.F @ self._filtered + self._point.G @ u


class StaleWatch:
    """Whether state samples still come: stale once more than `limit_s` [s] (of the
    clock the caller gives) passed since the last one.

    `seen(now)` at each sample returns True when it ends a stale spell; `check(now)`
    returns True once, when a spell begins; `stale` says whether one is under way. Before
    the first sample nothing is stale (there is nothing to hold yet)."""

    def __init__(self, limit_s: float):
        if not (math.isfinite(limit_s) and limit_s > 0):
            raise ValueError(f"stale limit must be finite and > 0 s, got {limit_s!r}")
        self.limit_s = float(limit_s)
        self.last: float | None = None
        self.stale = False
        self.spells = 0  # stale spells so far

    def seen(self, now: float) -> bool:
        self.last = now
        ended, self.stale = self.stale, False
        return ended

    def check(self, now: float) -> bool:
        if self.stale or self.last is None or now - self.last <= self.limit_s:
            return False
        self.stale = True
        self.spells += 1
        return True
