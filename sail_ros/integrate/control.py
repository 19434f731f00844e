"""The step-size controller: the only place a step is chosen.

The step is chosen to meet a tolerance on the outputs users read (tips, root moments,
their rates; `rtol` of each one's peak so far, `atol` floors): a moving step's error is
estimated (`moving.attempt`) and the next step is `h SAFETY error^(-1/3)` (the
midpoint rule's local error goes as `h^3`). `max_step` and `WHOLE_STEP_PHASE` rad of the
resolved frequency bound it from above; `rtol=None` takes fixed steps under `max_step`
and `PHASE_PER_STEP` rad alone. No step passes the inputs' or the profile's switches
(`stops`); the live sampler's steps are whole grid intervals (`grid_intervals`).
"""

from __future__ import annotations

import math

import numpy as np

from sail_ros.model.profiles import SWITCH_RESOLUTION

# A stretch of time whose motion starts or ends within this fraction of it from its ends
# counts as at rest (the booms move for a microsecond at zero rate): whether a motion that
# starts at a step's end makes that step exact then does not hang on round-off in the
# motion's times (a command logged to the nanosecond replays the same steps).
STATIC_MARGIN = 1e-4
# rad: omega_r * h of one fixed rational step. The (4,4) Padé lags a mode by ~4e-8
# (omega h)^9 rad per step: 2e-5 at 2 rad.
PHASE_PER_STEP = 2.0
# rad: omega_r * h of an error-controlled step, the estimate's whole rational step (its
# halves turn 1.5 rad each): there the Padé lags 5.9e-4 rad, which the estimate reads as
# 2e-4 of the resolved mode's amplitude, a fifth of the default tolerance; a longer whole
# step would be read as the halves' error and refused wherever that mode rings. Past
# about 2.6 rad the halves' difference from a lag-free whole step no longer measures
# their error; the lag stands in for it (model.md §11, "the whole step's lag is kept").
WHOLE_STEP_PHASE = 3.0
# The longest step [s]: the phase bound allows 0.35 s at 10 m, this bounds longer booms'.
DEFAULT_MAX_STEP = 0.5
# Local error allowed per step on each output, relative to its peak so far (tips,
# tip rates, root moments, their rates), chosen so that whole runs stay within 0.2 % of
# peak on tips and root moments (model.md §11).
DEFAULT_RTOL = 1e-3
# Absolute floors per output [m, m/s, N m, N m/s]: the tolerance of a sail at rest.
DEFAULT_ATOL = {"tips": 1e-6, "tip_rates": 1e-5, "root_moments": 1e-4, "root_moment_rates": 1e-3}
ATOL_UNITS = {"tips": "m", "tip_rates": "m/s", "root_moments": "N m", "root_moment_rates": "N m/s"}
OUTPUT_KINDS = tuple(DEFAULT_ATOL)
# the next step is h SAFETY err^(-1/3), grown at most GROWTH-fold, shrunk at most to SHRINK
SAFETY, GROWTH, SHRINK = 0.9, 1.5, 0.2
# A step cut below this fraction of the one allowed (to end at a stop: a switch, a jump, the
# run's end) leaves the proposal as it was: its error says little of a full step's, whose
# high modes are followed rather than carried (`moving.attempt`)
CUT_STEP = 0.5
# The run's error estimate over the sum of its parts (`StepControl.account`): a local
# Richardson estimate is asymptotic and the steps turn the resolved modes by up to 3 rad;
# on 48 drawn deployments against DOP853 at rtol 1e-9 (`test_tolerance.drawn_deployments`,
# seed 24) the largest sum of a step's parts read at least 0.62 of the error made at 121
# output times (most inside steps; the least inside a step cut short at a load switch),
# so 1.7 times it bounds it (the tightest 1.05 times the error)
ESTIMATE_MARGIN = 1.7
# A whole run's tolerance, in rtol of peak: the tolerance is per step, and the default's
# whole runs stay within 2 rtol of peak (model.md §11)
RUN_TOLERANCE = 2.0
# A run whose error estimate exceeds this many times its run's tolerance warns
WARN_ABOVE = 2.0
# A plain callable's inputs are sampled at this many intervals over a step, and a change
# this many times every other interval's is looked at as a jump (`locate_jump`)
JUMP_SAMPLES, JUMP_RATIO = 8, 3.0


def time_slack(t: float) -> float:
    """Within this [s] of each other, two times near `t` [s] are one: the round-off of
    a time reached by summing steps (plain floats: it is asked every step)."""
    return 1e-12 * max(1.0, abs(t))


def atol_floors(atol: dict | None) -> dict:
    """The absolute floors per output kind (`OUTPUT_KINDS`, in `ATOL_UNITS`): `atol`'s
    over `DEFAULT_ATOL`. Raises ValueError naming an unknown kind or a floor not finite
    and > 0."""
    floors = dict(DEFAULT_ATOL)
    for name, value in dict(atol or {}).items():
        if name not in floors:
            raise ValueError(f"atol: unknown output {name!r}; outputs are {', '.join(floors)}")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"atol[{name!r}] must be finite and > 0, got {value!r}")
        floors[name] = float(value)
    return floors


def accuracy_warning(
    rtol: float | None, relative: dict, atol: dict | None = None, peaks: dict | None = None
) -> str:
    """One line when a run's relative error estimate (per `OUTPUT_KINDS`) on tips or root
    moments exceeds `WARN_ABOVE` times the run's tolerance `RUN_TOLERANCE rtol` ("" if
    neither does, or with fixed steps). Its advice names the `atol` floors where one of
    them exceeds `rtol` times the output's peak (`peaks`): there the floor, not `rtol`,
    sets the steps."""
    if rtol is None:
        return ""
    bar = WARN_ABOVE * RUN_TOLERANCE * rtol
    over = [kind for kind in ("tips", "root_moments") if relative.get(kind, 0.0) > bar]
    if not over:  # nan (no peak yet) does not warn
        return ""
    floors, peaks = atol_floors(atol), peaks or {}
    binding = [kind for kind in over if floors[kind] > rtol * peaks.get(kind, math.inf)]
    if binding:
        named = ", ".join(f"{kind} = {floors[kind]:g} {ATOL_UNITS[kind]}" for kind in binding)
        advice = f"atol ({named}) is above rtol x peak there: a smaller atol tightens it"
    else:
        advice = "a smaller rtol or max_step tightens it"
    return (
        f"the run's error estimate is {100 * relative.get('tips', 0.0):.2g} % of peak on tips "
        f"and {100 * relative.get('root_moments', 0.0):.2g} % on root moments, above "
        f"{WARN_ABOVE:g} times its tolerance ({100 * RUN_TOLERANCE * rtol:.2g} % of peak at "
        f"rtol {rtol:g}); {advice}"
    )


def largest(rows, q, qd) -> np.ndarray:
    """The largest magnitude of each output kind (`OUTPUT_KINDS`) in `rows q` and `rows qd`
    (`rows`: tips then root moments, 4 each)."""
    y = np.abs(rows @ np.array([q, qd]).T)  # (8, 2): q, qd
    return y.reshape(2, 4, 2).max(axis=1).ravel()  # tips (q, qd), moments (q, qd)


class StepControl:
    """The tolerance, the bounds and the next step, with the error estimate accumulated.

    Args:
        max_step: largest step [s].
        rtol: local error allowed per moving step on each output relative to its peak
            so far; None: fixed steps with no estimate.
        atol: absolute floors per output kind (`OUTPUT_KINDS`), overriding `DEFAULT_ATOL`.
    """

    def __init__(self, max_step, rtol, atol):
        if not (math.isfinite(max_step) and max_step > 0):
            raise ValueError(f"max_step must be finite and > 0, got {max_step!r}")
        if rtol is not None and not (math.isfinite(rtol) and 0 < rtol < 1):
            raise ValueError(f"rtol must be None or in (0, 1), got {rtol!r}")
        floors = atol_floors(atol)
        self.max_step = float(max_step)
        self.rtol = None if rtol is None else float(rtol)
        self.atol = floors
        self.floors = np.array([floors[k] for k in OUTPUT_KINDS])
        self.restart()

    def restart(self) -> None:
        """No proposal yet (inf), the estimate and the peaks at 0."""
        self.proposal = math.inf
        self.allowed = math.inf  # the last `limit`
        self.combined = np.zeros(len(OUTPUT_KINDS))
        self.peaks = np.zeros(len(OUTPUT_KINDS))

    @property
    def estimate(self) -> np.ndarray:
        """The run's error estimate per output kind [their units]: `ESTIMATE_MARGIN` times
        the largest over the moving steps of the local errors carried to a step's end
        (`account`) plus the error of its dense output inside it."""
        return ESTIMATE_MARGIN * self.combined

    def account(self, difference, inside) -> None:
        """A moving step's contribution to the run's estimate: `difference`, the largest
        magnitude per output kind of the steps' run less the run of local extrapolations
        at the step's end (`moving.attempt`: the local errors carried to it), and
        `inside`, its dense output's error estimate."""
        self.combined = np.maximum(self.combined, difference + inside)

    def bound(self, resolved: float) -> float:
        """The longest step [s] whatever the error: `max_step` and `PHASE_PER_STEP` rad of
        `resolved` [rad/s] per fixed step, `WHOLE_STEP_PHASE` per error-controlled one."""
        phase = PHASE_PER_STEP if self.rtol is None else WHOLE_STEP_PHASE
        return min(self.max_step, phase / resolved)

    def limit(self, resolved: float) -> float:
        """The longest step [s] allowed now: `bound` and the proposal."""
        self.allowed = min(self.bound(resolved), self.proposal)
        return self.allowed

    @staticmethod
    def equal_steps(length: float, limit: float) -> int:
        """How many equal steps cover `length` [s], none above `limit` [s]."""
        return max(1, math.ceil(length / limit - 1e-9))

    @staticmethod
    def equal_step(remaining: float, limit: float) -> float:
        """A step [s] of equal steps to a target `remaining` [s] away, none above `limit`:
        an abrupt change of step size costs the midpoint rule accuracy."""
        return remaining / StepControl.equal_steps(remaining, limit)

    def grid_intervals(self, spacing: float, limit: float, bound: float, until_stop: float) -> int:
        """How many grid intervals of `spacing` [s] the next moving step tries: as many as
        `limit` [s] allows, two where one is allowed and the error and `bound` would allow
        two (steps of one interval propose 1.5 at most, which would keep them at one for
        ever), never past the next stop `until_stop` [s] away (a stop within
        `STATIC_MARGIN` of a grid time is on it)."""
        intervals = max(1, math.floor(limit / spacing + 1e-9))
        if (
            intervals == 1
            and self.rtol is not None
            and self.proposal >= spacing
            and bound >= 2 * spacing * (1 - 1e-9)
        ):
            intervals = 2
        if math.isfinite(until_stop):
            before = math.floor(until_stop / spacing + STATIC_MARGIN)
            intervals = max(1, min(intervals, before))
        return intervals

    def error(self, estimate, outputs) -> float:
        """The estimate's largest ratio to the tolerance (<= 1 meets it): `atol` floors and
        `rtol` of each output's peak so far or at the step's end."""
        with np.errstate(over="ignore", invalid="ignore"):
            scale = self.floors + self.rtol * np.maximum(self.peaks, outputs)
            error = float((estimate / scale).max())
        return error if math.isfinite(error) else math.inf

    def accepted(self, h: float, trial) -> None:
        """A moving step of `h` [s] was taken: the next step proposed from its error, the
        outputs' peaks grown by its end's (its estimate goes to `account`)."""
        if self.rtol is None:
            return
        proposal = h * min(GROWTH, SAFETY * max(trial.error, 1e-12) ** (-1.0 / 3.0))
        if h < CUT_STEP * self.allowed:  # a step cut short to reach a stop
            proposal = max(proposal, self.proposal)
        self.proposal = proposal
        self.peaks = np.maximum(self.peaks, trial.outputs)

    def refused(self, h: float, error: float) -> None:
        """A moving step of `h` [s] missed the tolerance by `error`: a shorter proposal."""
        self.proposal = h * max(SHRINK, SAFETY * error ** (-1.0 / 3.0))

    def observe(self, outputs) -> None:
        """The outputs' magnitudes at a state (their peaks so far grow)."""
        if self.rtol is not None:
            self.peaks = np.maximum(self.peaks, outputs)

    @staticmethod
    def locate_jump(inputs, t0: float, t1: float) -> float | None:
        """The time [s] of the first jump of `inputs` (a plain callable `t -> u`, whose
        switches are not known) inside (t0, t1], or None: the inputs sampled at
        `JUMP_SAMPLES` equal intervals; an interval whose change in one input stands out
        (`JUMP_RATIO` times a neighbouring interval's) is bisected down to
        `SWITCH_RESOLUTION`, and if the change is still half of what it was there, it is
        a jump and a step ends at its far side (a smooth input's change shrinks with the
        interval; a held value's does not)."""
        times = np.linspace(t0, t1, JUMP_SAMPLES + 1)
        times[0] = min(t0 + SWITCH_RESOLUTION, 0.5 * (t0 + times[1]))
        u = np.array([inputs(t) for t in times], dtype=float).reshape(times.size, -1)
        change = np.abs(np.diff(u, axis=0))  # (JUMP_SAMPLES, inputs)
        quieter = np.empty_like(change)  # the quieter neighbour's change
        quieter[0], quieter[-1] = change[1], change[-2]
        np.minimum(change[:-2], change[2:], out=quieter[1:-1])
        candidates = np.argwhere((change > JUMP_RATIO * quieter) & (change > 0))
        for interval, channel in sorted(candidates.tolist()):
            a, b = float(times[interval]), float(times[interval + 1])
            ua, ub = u[interval, channel], u[interval + 1, channel]
            while b - a > SWITCH_RESOLUTION:
                m = 0.5 * (a + b)
                um = float(np.asarray(inputs(m), dtype=float).ravel()[channel])
                if abs(um - ua) >= abs(ub - um):
                    b, ub = m, um
                else:
                    a, ua = m, um
            if abs(ub - ua) >= 0.5 * change[interval, channel]:
                return b
        return None

    @staticmethod
    def next_stop(t: float, *sources) -> float:
        """The next time [s] after `t` where one of `sources` (the inputs, the profile)
        switches (`switch_times`), which no step passes; inf if none."""
        times = [s for source in sources for s in getattr(source, "switch_times", ())]
        later = [s for s in times if s > t + SWITCH_RESOLUTION]
        return min(later, default=math.inf)
