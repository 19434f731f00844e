"""A stepper's state on a uniform time grid, with steps longer than the grid while the
booms move.

The simulator publishes on a fine grid (0.01 s by default) but the stepper's
tolerance allows longer steps while the booms move (up to `max_step`, 0.5 s by
default). A moving step is the costly one (rational solves and the frozen modes),
so `GridSampler` takes one step over as many whole grid intervals as the
tolerance accepts (a refused step is retried over fewer) and fills the grid
points inside from the step's continuous extension (`SailStepper.between`):
the rational steps' own resolvent solutions recombined for a fraction of the
step, accurate to `(omega h)^5` for a mode and not amplifying any, with the
followed high modes turned in phase (a cubic through the ends' `q` and `qd`
would overshoot the modes a step does not resolve, which the root moments show,
model.md §11). The step's end is the integrator's own state.

While the booms stand still over a grid interval, one exact step (the cached
propagator: a matrix-vector product) lands on the next grid point. A grid
interval longer than one allowed step is split into equal sub-steps.

So the stepper's time may run ahead of the latest sample by up to one
moving step less one grid interval; a change of motion or load given to the
stepper acts at the stepper's time, after the samples already computed.
"""

from __future__ import annotations

import math
from collections import deque

from sail_ros.integrate.stepper import SailStepper
from sail_ros.model.record import StepperState

# the state at a grid time: t [s], boom lengths [m] and rates [m/s], q, qd
GridPoint = StepperState


class GridSampler:
    """Samples of `stepper`'s state every `spacing` [s], starting at its current time.

    `point` is the latest sample; `advance` moves to the next grid time, stepping
    the model when it has not reached it yet.
    """

    def __init__(self, stepper: SailStepper, spacing: float):
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError(f"spacing must be finite and > 0, got {spacing!r}")
        self.stepper = stepper
        self.spacing = float(spacing)
        self._ahead: deque[GridPoint] = deque()  # samples computed, not yet reached
        self.restart()

    def restart(self) -> None:
        """Sample from the stepper's state as it is now (after `reset`, or at start);
        samples computed ahead are dropped."""
        self._ahead.clear()
        self.point = self._exact()

    def advance(self) -> GridPoint:
        """The sample one grid interval on (it becomes `point`).

        Raises:
            IntegrationError: the state became non-finite; `point` is unchanged.
        """
        if not self._ahead:
            self._step()
        self.point = self._ahead.popleft()
        return self.point

    def substeps(self, limit: float | None = None) -> int:
        """Equal sub-steps a moving grid interval needs under the step limit `limit` [s]
        (default the stepper's now, `SailStepper.step_limit`)."""
        limit = self.stepper.step_limit() if limit is None else limit
        return self.stepper.control.equal_steps(self.spacing, limit)

    def _advance(self) -> int:
        """One step of a whole number of grid intervals (as many as the tolerance accepts,
        `StepControl.grid_intervals`, a refused step retried over fewer; exact at rest),
        or, where one interval is more than a step may be, equal sub-steps over one.
        Returns the intervals the last step spans (1: the stepper is at the next grid
        time)."""
        stepper, spacing = self.stepper, self.spacing
        limit = stepper.step_limit()
        if stepper.is_static(spacing):
            stepper.step(spacing)  # exact at any length
            return 1
        until_stop = stepper.next_switch() - stepper.t
        intervals = stepper.control.grid_intervals(spacing, limit, stepper.bound(), until_stop)
        while intervals > 1:
            if stepper.rtol is None:
                stepper.step(intervals * spacing)
                return intervals
            if stepper.try_step(intervals * spacing):
                return intervals
            allowed = math.floor(stepper.step_limit() / spacing + 1e-9)
            intervals = min(intervals - 1, max(1, allowed))
        count = self.substeps(limit)
        for _ in range(count):
            stepper.step(spacing / count)
        return 1

    def _exact(self) -> GridPoint:
        stepper = self.stepper
        lengths, rates, _ = stepper.boom_motion()
        return GridPoint(stepper.t, lengths, rates, stepper.q, stepper.qd)

    def _step(self) -> None:
        start = self.point  # the stepper's state: nothing is ahead
        intervals = self._advance()
        if intervals > 1:
            self._ahead.extend(self._between(start, self._exact(), intervals))
        else:
            self._ahead.append(self._exact())

    def _between(self, start: GridPoint, end: GridPoint, intervals: int) -> list[GridPoint]:
        """The grid points after `start` up to `end` (included, exact), from the step's
        continuous extension (`SailStepper.between`)."""
        fractions = [j / intervals for j in range(1, intervals)]
        q, qd = self.stepper.between(fractions, start.qd, end.qd)
        points = []
        for j in range(1, intervals):
            t = start.t + j * self.spacing
            lengths, rates, _ = self.stepper.boom_motion(t)
            points.append(GridPoint(t, lengths, rates, q[j - 1], qd[j - 1]))
        points.append(end)
        return points
