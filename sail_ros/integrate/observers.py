"""Observers of a run (`driver.run`): what sees every step.

`peaks.OutputPeaks` takes the true peaks; `RangeWatch` adds the check of the linear
range at the same samples, as the simulator's diagnostics make it.
"""

from __future__ import annotations

import math

import numpy as np

from sail_ros.integrate.control import time_slack
from sail_ros.integrate.errors import StopError
from sail_ros.integrate.peaks import HERMITE_BOUND, OutputPeaks, SampledSteps, hermite_motion


class RangeWatch:
    """Sees every step of a run: the true peaks (`peaks.OutputPeaks`), and the tip
    deflections (and a free hub's tilt) against the linear range at the peaks' samples
    inside the step (`peaks.MAX_SPACING_S` apart or closer, the simulator's default
    integration step), as the simulator checks its samples: `policy` says what is in
    range (`range_state`, `tip_warn_fraction`, `tilt_warn_rad`: a `sail_ros.policy.
    Policy`). The first warning is kept, an error stops the run (`errors.StopError`, the
    simulator's alarm text with the time; `stopped_at`).

    The peaks sample their steps in batches (`OutputPeaks.batch_steps`), so the check
    comes up to a batch after the step: a run stops with the error of its first step
    out of range, the stepper some steps further (`finish` checks the steps left)."""

    def __init__(self, model, policy, tip_times=None):
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
            raise StopError(self.error, self.stopped_at)

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
