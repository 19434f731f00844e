"""`SailStepper`: the sail's state, advanced under prescribed boom motion.

The shape of `scipy.integrate`'s solvers: the state and its steps here; the system at a
time and its one cache (`system.SystemAt`); the one place a step is chosen
(`control.StepControl`); the step formulas (`moving`: the exponential midpoint rule with
the rational approximant and the followed high modes, while the booms move; `rest`: the
exact step, while they stand still); dense output per step kind (`dense`). Batch runs
(`driver`) and the simulator's grid (`sampling`) both step through it.

The integrator works in canonical variables: with the kinetic energy `T = 1/2 qd^T M qd +
qd^T G q + 1/2 q^T N q` the momentum is `p = M qd + G q`, and Eq. 2 becomes
`qd = M^-1 (p - G q)`, `pd = G^T M^-1 (p - G q) - (K - N) q - C_d qd + Q` (model.md §4,
§11), in which `Md` and `Gd` no longer appear.
"""

from __future__ import annotations

import math

import numpy as np

from sail_ros.integrate import moving
from sail_ros.integrate.control import (
    DEFAULT_MAX_STEP,
    DEFAULT_RTOL,
    OUTPUT_KINDS,
    STATIC_MARGIN,
    StepControl,
    largest,
    time_slack,
)
from sail_ros.integrate.dense import MovingDense, RestDense
from sail_ros.integrate.errors import IntegrationError
from sail_ros.integrate.rest import rest_step
from sail_ros.integrate.system import LinearSystem, SystemAt
from sail_ros.model.profiles import SWITCH_RESOLUTION


class SailStepper:
    """Holds the sail's state and advances it under a boom-motion profile.

    Args:
        system: the structure (`LinearSystem`, e.g. a `SailModel`).
        profile: callable `t -> (lengths, rates, accelerations)` (4 values each, SI); see
            `profiles`. May be replaced between steps.
        q0: initial coordinates (default 0).
        qd0: initial velocities [m/s] (default 0).
        t0: initial time [s].
        max_step: largest step [s] (an upper bound; the tolerance chooses below it).
        resolved_frequency: highest angular frequency [rad/s] a step must resolve; None
            follows `system.resolved_frequency` at the current lengths.
        inputs: callable `t -> u` (the system's inputs, e.g. `loads.INPUT_NAMES`), or None.
            May be replaced between steps. If it has `switch_times` [s], no step passes
            them.
        rtol: local error allowed per moving step on each output (tips, tip rates, root
            moments, their rates), relative to its peak so far; None takes fixed steps.
        atol: absolute floors per output kind (`OUTPUT_KINDS`: m, m/s, N m, N m/s).
        on_step: callable `on_step(stepper)` after every accepted step, or None.
    """

    def __init__(
        self,
        system: LinearSystem,
        profile,
        q0=None,
        qd0=None,
        t0: float = 0.0,
        max_step: float = DEFAULT_MAX_STEP,
        resolved_frequency: float | None = None,
        inputs=None,
        rtol: float | None = DEFAULT_RTOL,
        atol=None,
        on_step=None,
    ):
        self.control = StepControl(max_step, rtol, atol)
        self.system = system
        self.at = SystemAt(system, profile, resolved_frequency)
        self.inputs = inputs
        self.on_step = on_step
        self.steps_taken = 0
        self.steps_rejected = 0
        self.reset(q0, qd0, t0)

    max_step = property(lambda self: self.control.max_step)
    rtol = property(lambda self: self.control.rtol)
    atol = property(lambda self: self.control.atol)
    proposal = property(lambda self: self.control.proposal)
    resolved_frequency = property(lambda self: self.at.resolved_frequency)

    # state ------------------------------------------------------------------------------
    def reset(self, q0=None, qd0=None, t0: float = 0.0, profile=None):
        """Start again from `q0`, `qd0` (default rest) at time `t0` [s], under `profile`
        if given (else the current one). The error estimate starts again."""
        n = self.system.n
        q = np.zeros(n) if q0 is None else np.array(q0, dtype=float)
        qd = np.zeros(n) if qd0 is None else np.array(qd0, dtype=float)
        for name, value in (("q0", q), ("qd0", qd)):
            if value.shape != (n,):
                raise ValueError(f"{name} must have {n} values, got shape {value.shape}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be finite, got {value.tolist()!r}")
        if not math.isfinite(t0):
            raise ValueError(f"t0 must be finite, got {t0!r}")
        self._t = float(t0)
        self.at.new_piece(self._t, profile)
        self._q = q
        self._p = self.at.momentum(self._t, q, qd)
        self._qd = (self._t, qd.copy())  # the velocity at a time, kept
        self._companion = (q.copy(), self._p.copy())  # the run of local extrapolations
        self._last = None  # (t0, q0, qd0, dense output) of the last step
        # (inputs, time [s]): a plain callable's inputs do not jump from now until then
        self._searched = (None, -math.inf)
        self.control.restart()
        self.control.observe(self._outputs(self._t, q, qd))

    @property
    def t(self) -> float:
        """Current time [s]."""
        return self._t

    @property
    def q(self) -> np.ndarray:
        """Current generalised coordinates (copy)."""
        return self._q.copy()

    @property
    def qd(self) -> np.ndarray:
        """Current generalised velocities `M^-1 (p - G q)` [m/s] (copy)."""
        if self._qd[0] != self._t:
            self._qd = (self._t, self.at.velocity(self._t, self._q, self._p))
        return self._qd[1].copy()

    @property
    def error_estimate(self) -> dict:
        """The estimated error of the run since the start (or `reset`), per output kind
        (`OUTPUT_KINDS`) in its units [m, m/s, N m, N m/s]: `StepControl.estimate`, from
        the moving steps' local errors carried along by the run of local extrapolations
        (an undamped sail does not forget an error) and their dense output's; exact
        steps at rest and fixed steps (`rtol` None) add nothing."""
        return dict(zip(OUTPUT_KINDS, self.control.estimate.tolist(), strict=True))

    @property
    def relative_error_estimate(self) -> dict:
        """`error_estimate` over each output's peak so far [-] (nan while it is 0)."""
        peaks, estimate = self.control.peaks, self.control.estimate
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(peaks > 0, estimate / peaks, math.nan)
        return dict(zip(OUTPUT_KINDS, ratio.tolist(), strict=True))

    @property
    def peaks(self) -> dict:
        """The largest magnitude of each output kind met so far, in its units."""
        return dict(zip(OUTPUT_KINDS, self.control.peaks.tolist(), strict=True))

    def _outputs(self, t, q, qd) -> np.ndarray:
        return largest(self.at.rows(self.at.motion(t)[0]), q, qd)

    def boom_motion(self, t: float | None = None):
        """Boom lengths [m], rates [m/s], accelerations [m/s^2] now (or at `t` [s])."""
        return self.at.motion(self._t if t is None else t)

    @property
    def profile(self):
        return self.at.profile

    @profile.setter
    def profile(self, profile):
        """Replace the boom motion from now on, keeping `q` and `qd` continuous."""
        self._new_piece(profile)
        self._last = None

    def energy(self) -> float:
        """Mechanical energy `1/2 qd^T M qd + 1/2 q^T K q` [J] now."""
        return self.at.energy(self._t, self._q, self.qd)

    # choosing steps ---------------------------------------------------------------------
    def advance(self, t_end: float) -> None:
        """Integrate up to time `t_end` [s] (no-op if `t_end <= t`), ending at `t_end` and
        at the inputs' and the profile's switches."""
        if not math.isfinite(t_end):
            raise ValueError(f"t_end must be finite, got {t_end!r}")
        while t_end - self._t > time_slack(t_end):
            self.advance_step(t_end)

    def advance_step(self, t_end: float) -> None:
        """One accepted step towards `t_end` [s] (not beyond it, nor beyond the next
        switch): equal steps to the target, refused and retried shorter where the
        tolerance is not met. Where output times fall plays no part (dense output)."""
        target = min(t_end, self.next_switch())
        smallest = 1e-6 * max(1.0, abs(target))
        while True:
            h = self.control.equal_step(target - self._t, self.step_limit())
            if self.inputs is not None and not hasattr(self.inputs, "switch_times"):
                jump = self._jump_within(h)
                if jump is not None and jump < self._t + h - SWITCH_RESOLUTION:
                    target = jump  # steps end where a plain callable's inputs jump
                    continue
            if self.is_static(h) or self.rtol is None or h <= smallest:
                self.step(h)
                return
            if self.try_step(h):
                return

    def _jump_within(self, h: float) -> float | None:
        """The first jump of a plain callable's inputs in a step of `h` [s] from now
        (`StepControl.locate_jump`), or None. A stretch searched once is not searched
        again (a step retried shorter, or cut to end at the jump found)."""
        inputs, clear_until = self._searched
        t1 = self._t + h
        if inputs is self.inputs and t1 <= clear_until + time_slack(t1):
            return None
        jump = self.control.locate_jump(self._input, self._t, t1)
        self._searched = (self.inputs, t1 if jump is None else jump)
        return jump

    def next_switch(self) -> float:
        """The next time [s] where the inputs or the profile switch; inf if none."""
        return self.control.next_stop(self._t, self.inputs, self.at.profile)

    def is_static(self, h) -> bool:
        """Whether the booms stand still over the next `h` [s], but for `STATIC_MARGIN` of
        it at either end (a motion that starts or ends there, at zero rate, is stepped
        exactly, whatever round-off puts its start on one side)."""
        margin = STATIC_MARGIN * h
        return self.at.is_static(self._t + margin, self._t + h - margin)

    def step_limit(self) -> float:
        """The longest step [s] allowed now: `bound` and the error control's proposal."""
        return self.control.limit(self.at.resolved(self.at.motion(self._t)[0]))

    def bound(self) -> float:
        """The longest step [s] whatever the error (`StepControl.bound`)."""
        return self.control.bound(self.at.resolved(self.at.motion(self._t)[0]))

    # taking steps -----------------------------------------------------------------------
    def step(self, h: float) -> None:
        """One step of `h` [s], taken whatever its error: exact at rest; moving, the
        estimated moving step (`moving.attempt`), or one rational step without `rtol`."""
        if self.is_static(h):
            t_mid = self._t + 0.5 * h
            lengths = self.at.motion(t_mid)[0]
            force = self._force(t_mid, lengths)
            propagator = self.at.propagator(lengths, h)
            with np.errstate(over="ignore", invalid="ignore"):
                q, p, rest = rest_step(propagator, self._q, self._p, h, force)
                self._companion = rest_step(propagator, *self._companion, h, force)[:2]
            self._commit(h, q, p, RestDense(rest))
            return
        if self.rtol is None:
            trial = moving.fixed(self.at, self._force, self._t, self._q, self._p, h)
        else:
            trial = self._attempt(h)
        self._commit(h, trial.q, trial.p, trial)

    def try_step(self, h: float) -> bool:
        """A moving step of `h` [s] if it meets the tolerance (True); else the state is
        kept and the next proposal (`step_limit`) shortened (False)."""
        trial = self._attempt(h)
        if trial.error <= 1.0:
            self._commit(h, trial.q, trial.p, trial)
            return True
        self.steps_rejected += 1
        self.control.refused(h, trial.error)
        return False

    def _attempt(self, h: float) -> moving.Trial:
        return moving.attempt(self.at, self._force, self._input_or_none, self._t, self._q,
                              self._p, self.qd, h, self.control.error,
                              self._companion if self.rtol is not None else None)  # fmt: skip

    def _commit(self, h, q, p, taken) -> None:
        """Take the step's end `(q, p)` as the state (`taken`: a moving step's `Trial` or
        the dense output at rest), then `on_step`."""
        if not (np.isfinite(q).all() and np.isfinite(p).all()):
            raise IntegrationError(f"state became non-finite at t = {self._t + h:.6g} s")
        t0 = self._t
        dense = taken if isinstance(taken, RestDense) else MovingDense(self.at, t0, h, taken)
        self._last = (t0, self._q, self.qd, dense)
        self._q, self._p = q, p
        self._t += h
        self.steps_taken += 1
        if isinstance(taken, moving.Trial):
            if taken.qd is not None:
                self._qd = (self._t, taken.qd)
            self.control.accepted(h, taken)
            self._account(taken)
        self._enter_switch()
        if self.on_step is not None:
            self.on_step(self)

    def _account(self, trial) -> None:
        """The run's error estimate (`StepControl.account`) after the moving step `trial`:
        the run of local extrapolations against the steps' at its end, and inside it the
        dense output's error (`Trial.interpolation`)."""
        if trial.companion is None:  # fixed steps: no estimate
            self._companion = (self._q, self._p)
            return
        q_c, p_c, distance = trial.companion
        self._companion = (q_c, p_c)
        self.control.account(distance, trial.interpolation)

    def _enter_switch(self) -> None:
        """At a switch of a piecewise profile (`profiles.SwitchedProfile`), the next piece
        from now on, as a live simulator takes a new motion: `q` and `qd` kept, the
        momenta recomputed with the new piece's matrices."""
        times = getattr(self.at.profile, "switch_times", ())
        entered = self.at.entered
        if not any(entered < s and abs(self._t - s) <= SWITCH_RESOLUTION for s in times):
            return
        self._new_piece()

    def _new_piece(self, profile=None) -> None:
        """A new motion (or the profile's next piece) from now on: `q` and `qd` (and the
        companion run's) kept, the momenta recomputed with the new piece's matrices."""
        qd = self.qd  # at the end of the piece left
        q_c = self._companion[0]
        qd_c = self.at.velocity(self._t, q_c, self._companion[1])
        self.at.new_piece(self._t, profile)
        self._p = self.at.momentum(self._t, self._q, qd)
        self._companion = (q_c, self.at.momentum(self._t, q_c, qd_c))
        self._qd = (self._t, qd)

    def _input_or_none(self, t):
        return None if self.inputs is None else self._input(t)

    def _force(self, t, lengths) -> np.ndarray | None:
        """Generalised forces `B_u u(t)` [N] at `lengths`; None when there are none."""
        if self.inputs is None:
            return None
        return self.at.held(self._input(t), lengths)

    def _input(self, t) -> np.ndarray:
        """The inputs `u` at `t`, checked (unless the inputs say they are: `checked`, as
        `loads.input_function`'s)."""
        if getattr(self.inputs, "checked", False):
            return self.inputs(t)
        u = np.asarray(self.inputs(t), dtype=float)
        if u.ndim != 1 or not np.isfinite(u).all():
            raise ValueError(f"inputs at t = {t:.6g} s must be finite values, got {u!r}")
        return u

    # dense output -----------------------------------------------------------------------
    def states_at(self, times, rates: str | None = "exact") -> tuple[np.ndarray, np.ndarray]:
        """`(q, qd)` (each (m, n)) at `times` [s] (m values) within the last step (its end:
        the state itself), from the step's dense output (`dense`). `rates`: "exact", or
        "extension" (no assembly nor factorisation per time; `q` the same to the bit), or
        None (`qd` nan inside the step) for a caller that reads positions only."""
        if rates not in ("exact", "extension", None):
            raise ValueError(
                f"rates must be 'exact' or 'extension', got {rates!r} (or None: no rates)"
            )
        times = np.asarray(times, dtype=float)
        q, qd = np.empty((times.size, self._q.size)), np.empty((times.size, self._q.size))
        end = np.abs(times - self._t) <= time_slack(self._t)
        q[end], qd[end] = self._q, self.qd
        inside = times[~end]
        if inside.size == 0:
            return q, qd
        if self._last is None:
            raise ValueError(f"times {inside.tolist()!r} s: no step has been taken yet")
        t0, _, qd0, dense = self._last
        if inside.min() < t0 or inside.max() > self._t:
            raise ValueError(
                f"times {inside.tolist()!r} s are not all within the last step [{t0}, {self._t}] s"
            )
        fractions = (inside - t0) / (self._t - t0)
        q[~end], qd[~end] = dense.states(fractions, qd0, self.qd, rates)
        return q, qd

    def between(self, fractions, qd0, qd1, rates="extension") -> tuple[np.ndarray, np.ndarray]:
        """`(q, qd)` (each (m, n)) inside the last step, a moving one, at `fractions` of
        it, given the velocities `qd0`, `qd1` [m/s] at its ends (`MovingDense.states`)."""
        return self._last[3].states(fractions, qd0, qd1, rates)

    def last_curve(self):
        """The last step's curve, what `peaks` samples: at rest its `Rest` data (exact),
        moving its `Extension` (`MovingDense.extension`)."""
        return self._last[3].curve_data

    def interpolant(self, fractions, rows) -> tuple[np.ndarray, np.ndarray]:
        """`rows q(t)` and its rate `rows qd(t)` [per s] (each (m, r)) at `fractions` (m
        values in [0, 1]) of the last step, for output rows `rows` (r, n)."""
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        return self._last[3].curve(fractions, np.asarray(rows, dtype=float))
