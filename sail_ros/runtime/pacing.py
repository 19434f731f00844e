"""How far the simulation should be now, from the steady clock.

While running, the simulation time due is

    t_due = t_anchor + time_scale * (now - wall_anchor)

with both anchors set when the run (re)starts: at the first tick, on
resuming from a pause and after a reset from an error. It is computed from
the anchors every time, never accumulated, so it does not drift; paused
time does not count. As fast as possible (time_scale <= 0), every time is
due and only the per-tick work budget paces the simulation.

An overrun is a tick that finds the model more than one integration step
behind: the tick came more than a step late, or the tick before ran out of
budget with steps still due.

`RealTimeFactor` measures what the pacing achieves: simulation time advanced
per wall second over uninterrupted running windows of a minimum length.
"""

from __future__ import annotations

import math
import time

MIN_TICK_PERIOD_S = 0.005  # wall time between ticks at least this: executor overhead
# ... and at most this, whatever the publication rates: a tick's work stays within
# its budget, so a slow state rate never starves the integration
MAX_TICK_PERIOD_S = 0.05
PACED_BUDGET_S = 0.05  # wall time a paced tick may integrate before yielding
AFAP_BUDGET_S = 0.02  # ... and an as-fast-as-possible tick


class Pacer:
    """Simulation time due against the steady clock, and the overrun rule.

    Args:
        time_scale: simulation seconds per wall second; <= 0: as fast as possible.
        step: integration step [s of simulation time].
        tick_steps: integration steps per tick, normally those between two
            published samples: ticking more often only adds executor overhead.
        now: the steady clock [s] (injectable for tests).
    """

    def __init__(self, time_scale: float, step: float, tick_steps: int = 1, now=time.monotonic):
        self.time_scale = float(time_scale)
        self.step = float(step)
        self.now = now
        self.paced = self.time_scale > 0.0
        self.tick_steps = tick_steps
        self.budget = PACED_BUDGET_S if self.paced else AFAP_BUDGET_S
        self.running = False
        self._t_anchor = 0.0
        self._wall_anchor = 0.0
        self._last_tick: float | None = None
        self._last_due = 0.0

    @property
    def tick_period(self) -> float:
        """Wall time between ticks [s]: `tick_steps` steps, within [MIN_TICK_PERIOD_S,
        MAX_TICK_PERIOD_S]; 0 (every spin of the executor) as fast as possible."""
        if not self.paced:
            return 0.0
        period = self.tick_steps * self.step / self.time_scale
        return min(max(period, MIN_TICK_PERIOD_S), MAX_TICK_PERIOD_S)

    def run_from(self, t: float) -> None:
        """Start (again) at simulation time `t` [s], now."""
        self.running = True
        self._t_anchor, self._wall_anchor = float(t), self.now()
        self._last_tick = None

    def hold(self, t: float) -> None:
        """Stop the simulation time at `t` [s] (pause, error)."""
        self.running = False
        self._t_anchor = float(t)
        self._last_tick = None

    def due(self, wall: float | None = None) -> float:
        """Simulation time [s] the model should have reached at `wall` (default now)."""
        if not self.running:
            return self._t_anchor
        if not self.paced:
            return math.inf
        wall = self.now() if wall is None else wall
        return self._t_anchor + self.time_scale * (wall - self._wall_anchor)

    def tick(self, t_model: float, wall: float | None = None) -> tuple[float, float, bool]:
        """Begin a tick with the model at `t_model` [s] that woke at `wall` [s of the
        steady clock; default now].

        Returns:
            `(due, deadline, overrun)`: the simulation time to reach [s], the
            wall time [s] by which to stop integrating (the budget), and
            whether this tick is an overrun.
        """
        wall = self.now() if wall is None else wall
        due = self.due(wall)
        overrun = False
        if self.running and self.paced and self._last_tick is not None:
            late = wall - self._last_tick - self.tick_period
            left_behind = self._last_due - t_model
            overrun = late * self.time_scale > self.step or left_behind >= self.step * (1.0 - 1e-9)
        self._last_tick, self._last_due = wall, due
        return due, wall + self.budget, overrun


class RealTimeFactor:
    """Simulation seconds advanced per wall second, measured over uninterrupted
    running windows of at least `min_window` [s of wall time].

    A window starts when the simulation starts running (start, resume, reset)
    and is closed by `update` (each diagnostics message) once it is long
    enough; a shorter window goes on, so the measurement is never taken over
    a few milliseconds. A state change (`restart`) closes the window if it is
    long enough and starts a new one only if the simulation runs.

    Attributes:
        value: the last complete measurement; 0.0 before the first.
        window: the wall time it spans [s]; 0.0 before the first.
        current: whether `value` was measured since the last state change.
    """

    def __init__(self, min_window: float, now=time.monotonic):
        self.min_window = float(min_window)
        self.now = now
        self.value = 0.0
        self.window = 0.0
        self.current = False
        self._start: tuple[float, float] | None = None  # (wall, t) of the open window

    def restart(self, t: float, running: bool) -> None:
        """A state change at simulation time `t` [s]: `running` is the new state."""
        wall = self.now()
        self._close(t, wall)
        self.current = False
        self._start = (wall, float(t)) if running else None

    def update(self, t: float) -> bool:
        """Close the open window at simulation time `t` [s] if it is long enough (and
        open the next); True if that gave a new measurement."""
        wall = self.now()
        if not self._close(t, wall):
            return False
        self._start = (wall, float(t))
        return True

    def _close(self, t: float, wall: float) -> bool:
        if self._start is None or wall - self._start[0] < self.min_window:
            return False
        span = wall - self._start[0]
        self.value, self.window, self.current = (t - self._start[1]) / span, span, True
        return True
