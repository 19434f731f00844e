"""Boom motion: lengths, rates and accelerations of the four booms against time.

A profile (`Profile`) is any callable `t -> (lengths, rates, accelerations)`
returning three arrays of 4 values (order a, b, c, d; m, m/s, m/s^2). The
profiles here also answer `is_static(t0, t1)`, which lets the stepper reuse
an exact propagator while the booms stand still, and `t_end`, when they stop.
`BoomMotion` combines them: each boom follows its own profile.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from sail_ros.model.layout import per_boom

_BOOMS = np.arange(4)
_BOOMS_K = range(4)


class Profile(Protocol):
    """The motion of the four booms against time."""

    def __call__(self, t: float) -> tuple:
        """`(lengths [m], rates [m/s], accelerations [m/s^2])` at `t` [s], 4 values each
        (a scalar stands for all four)."""

    def is_static(self, t0: float, t1: float) -> bool:
        """True if no boom moves between `t0` and `t1` [s] (optional for a profile)."""


def motion_over(profile, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`profile`'s `(lengths [m], rates [m/s], accelerations [m/s^2])` at each of `times`
    [s] (m,), each (m, 4): in one pass where the profile can (its `over`), else one call
    per time."""
    over = getattr(profile, "over", None)
    found = None if over is None else over(times)
    if found is not None:
        return found
    columns = [np.empty((len(times), 4)) for _ in range(3)]
    for i, t in enumerate(times):
        for column, values in zip(columns, profile(float(t)), strict=True):
            column[i] = values
    return tuple(columns)


class StaticProfile:
    """Booms held at fixed lengths [m]."""

    def __init__(self, lengths):
        self.lengths = per_boom(lengths, "lengths", positive=True)
        self._zero = np.zeros(4)

    def __call__(self, t):
        return self.lengths, self._zero, self._zero

    def is_static(self, t0, t1) -> bool:
        return True

    def extremes(self):
        """`(lowest, highest length [m], largest |rate| [m/s], |acceleration| [m/s^2])`
        of each boom (4 values each) over the whole profile."""
        return self.lengths, self.lengths, self._zero, self._zero


class CycloidalProfile:
    """The smooth deployment of model.md §9, per boom.

        L = L0 + (Lf - L0) (tau - sin(2 pi tau) / (2 pi)),   tau = (t - t0) / T

    Rate and acceleration are zero at both ends; peak rate `2 (Lf - L0) / T`,
    peak acceleration `2 pi (Lf - L0) / T^2`. Before `t0` the booms rest at
    `start`, after `t0 + T` at `end`.

    Args:
        start: initial lengths L0 [m] (scalar or 4 values).
        end: final lengths Lf [m].
        duration: T [s].
        t0: start time [s].
    """

    def __init__(self, start, end, duration: float, t0: float = 0.0):
        self.start = per_boom(start, "start", positive=True)
        self.end = per_boom(end, "end", positive=True)
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration must be finite and > 0, got {duration!r}")
        if not math.isfinite(t0):
            raise ValueError(f"t0 must be finite, got {t0!r}")
        self.duration, self.t0 = float(duration), float(t0)
        self._zero = np.zeros(4)
        self._ends = list(zip(self.start.tolist(), self.end.tolist(), strict=True))
        self._still = bool(np.array_equal(self.start, self.end))

    @staticmethod
    def peaks(travel, duration: float):
        """`(rate [m/s], acceleration [m/s^2])`: the largest of a cycloidal move of
        `travel` [m] (its magnitude) over `duration` [s], `2 |travel| / T` at mid-way and
        `2 pi |travel| / T^2` at a quarter and three quarters."""
        travel = np.abs(travel)
        return 2.0 * travel / duration, 2.0 * math.pi * travel / duration**2

    @classmethod
    def shortest_duration(cls, travel: float, max_rate: float, max_acceleration: float) -> float:
        """The shortest duration [s] of a cycloidal move of `travel` [m] whose peaks
        (`peaks`) stay within `max_rate` [m/s] and `max_acceleration` [m/s^2]: the rate
        falls like 1/T, the acceleration like 1/T^2; never below a millisecond."""
        if not (max_rate > 0 and max_acceleration > 0):
            raise ValueError(
                f"max_rate and max_acceleration must be > 0, got {max_rate!r}, {max_acceleration!r}"
            )
        rate, acceleration = cls.peaks(travel, 1.0)
        return max(rate / max_rate, math.sqrt(acceleration / max_acceleration), 1e-3)

    @property
    def t_end(self) -> float:
        return self.t0 + self.duration

    def __call__(self, t):
        tau = (t - self.t0) / self.duration
        if tau <= 0.0:
            return self.start, self._zero, self._zero
        if tau >= 1.0:
            return self.end, self._zero, self._zero
        lengths, rates, accelerations = np.array([self.boom_at(k, t) for k in _BOOMS_K]).T
        return lengths, rates, accelerations

    def over(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`(lengths [m], rates [m/s], accelerations [m/s^2])` at each of `times` [s] (m,),
        each (m, 4), in one pass (`motion_over`)."""
        tau = np.clip((np.asarray(times, dtype=float)[:, None] - self.t0) / self.duration, 0.0, 1.0)
        travel, angle = self.end - self.start, 2.0 * math.pi * tau
        moving = (tau > 0.0) & (tau < 1.0)
        lengths = np.where(
            tau >= 1.0, self.end, self.start + travel * (tau - np.sin(angle) / (2.0 * math.pi))
        )
        rates = np.where(moving, travel / self.duration * (1.0 - np.cos(angle)), 0.0)
        accelerations = np.where(
            moving, travel * (2.0 * math.pi / self.duration**2) * np.sin(angle), 0.0
        )
        return np.where(tau <= 0.0, self.start, lengths), rates, accelerations

    def boom_at(self, k: int, t: float) -> tuple[float, float, float]:
        """Boom `k`'s `(length [m], rate [m/s], acceleration [m/s^2])` at `t` [s] as plain
        floats (`BoomMotion` joins the booms of several profiles so)."""
        start, end = self._ends[k]
        tau = (t - self.t0) / self.duration
        if tau <= 0.0:
            return start, 0.0, 0.0
        if tau >= 1.0:
            return end, 0.0, 0.0
        travel = end - start
        angle = 2.0 * math.pi * tau
        return (
            start + travel * (tau - math.sin(angle) / (2.0 * math.pi)),
            travel / self.duration * (1.0 - math.cos(angle)),
            travel * (2.0 * math.pi / self.duration**2) * math.sin(angle),
        )

    def is_static(self, t0, t1) -> bool:
        return t1 <= self.t0 or t0 >= self.t_end or self._still

    def extremes(self):
        """As `StaticProfile.extremes`, the peaks of `peaks`."""
        rate, acceleration = self.peaks(self.end - self.start, self.duration)
        return (
            np.minimum(self.start, self.end),
            np.maximum(self.start, self.end),
            rate,
            acceleration,
        )


class WaypointProfile:
    """Booms through waypoints along a cubic spline (continuous rate and acceleration).

    Args:
        times: strictly increasing waypoint times [s], at least 2.
        lengths: waypoint lengths [m], shape (len(times),) for all booms alike
            or (len(times), 4) per boom.
        start_rates: rates at the first waypoint [m/s] (scalar or 4 values).
        end_rates: rates at the last waypoint [m/s]; the booms hold their last
            length after it, so leave this 0 unless the profile is replaced
            before then.
    """

    def __init__(self, times, lengths, start_rates=0.0, end_rates=0.0):
        times = np.asarray(times, dtype=float)
        if times.ndim != 1 or times.size < 2:
            raise ValueError(f"times must hold at least 2 values, got {times.tolist()!r}")
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise ValueError(
                f"times must be finite and strictly increasing, got {times.tolist()!r}"
            )
        lengths = np.asarray(lengths, dtype=float)
        if lengths.shape == times.shape:
            lengths = np.repeat(lengths[:, None], 4, axis=1)
        if lengths.shape != (times.size, 4):
            raise ValueError(
                f"lengths must have shape ({times.size},) or ({times.size}, 4), got {lengths.shape}"
            )
        if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
            raise ValueError(f"lengths must be finite and > 0, got {lengths.tolist()!r}")
        self.times, self.lengths = times, lengths
        self._start_rates = per_boom(start_rates, "start_rates")
        self._end_rates = per_boom(end_rates, "end_rates")
        # imported here: scipy.interpolate (and the scipy.optimize it brings) takes about
        # 0.2 s to import, which every command that never meets waypoints would pay
        from scipy.interpolate import CubicSpline

        self._spline = CubicSpline(
            times, lengths, axis=0, bc_type=((1, self._start_rates), (1, self._end_rates))
        )
        self._rate = self._spline.derivative(1)
        self._acceleration = self._spline.derivative(2)
        self._zero = np.zeros(4)

    @property
    def t_end(self) -> float:
        return float(self.times[-1])

    def __call__(self, t):
        # from the first waypoint on (a switch's resolution before it: a piece entered
        # there), the spline's own acceleration
        if t < self.times[0] - SWITCH_RESOLUTION:
            return self.lengths[0], self._start_rates, self._zero
        if t >= self.times[-1]:
            return self.lengths[-1], self._end_rates, self._zero
        return self._spline(t), self._rate(t), self._acceleration(t)

    def is_static(self, t0, t1) -> bool:
        after = t0 >= self.times[-1] and not np.any(self._end_rates)
        before = t1 <= self.times[0] and not np.any(self._start_rates)
        return bool(after or before)

    def extremes(self, samples_per_segment: int = 64):
        """As `StaticProfile.extremes`, from `samples_per_segment` samples of each segment
        (the spline's own overshoot included)."""
        t = np.concatenate(
            [
                np.linspace(a, b, samples_per_segment, endpoint=False)
                for a, b in zip(self.times[:-1], self.times[1:], strict=True)
            ]
            + [self.times[-1:]]
        )
        lengths = self._spline(t)
        return (
            lengths.min(axis=0),
            lengths.max(axis=0),
            np.abs(self._rate(t)).max(axis=0),
            np.abs(self._acceleration(t)).max(axis=0),
        )


class SampledProfile:
    """Booms through sampled lengths and rates (a log's boom states): on each interval
    the cubic Hermite through the lengths and rates at its ends, so lengths and rates
    are continuous and exact at the samples; before the first and after the last sample
    the booms hold.

    Args:
        times: strictly increasing sample times [s] (k,), at least 2.
        lengths: lengths [m] (k, 4).
        rates: rates [m/s] (k, 4).
    """

    def __init__(self, times, lengths, rates):
        self.times = np.asarray(times, dtype=float)
        self.lengths = np.asarray(lengths, dtype=float)
        self.rates = np.asarray(rates, dtype=float)
        k = self.times.size
        if k < 2 or np.any(np.diff(self.times) <= 0) or not np.all(np.isfinite(self.times)):
            raise ValueError("times must hold at least 2 finite, strictly increasing values")
        if self.lengths.shape != (k, 4) or self.rates.shape != (k, 4):
            raise ValueError(
                f"lengths and rates must have shape ({k}, 4), got {self.lengths.shape}, "
                f"{self.rates.shape}"
            )
        if not (np.all(np.isfinite(self.lengths)) and np.all(self.lengths > 0)):
            raise ValueError("lengths must be finite and > 0")
        self._zero = np.zeros(4)
        # intervals over which nothing moves (equal lengths, zero rates at both ends)
        still = (self.rates[:-1] == 0) & (self.rates[1:] == 0)
        still &= self.lengths[:-1] == self.lengths[1:]
        self._still = np.all(still, axis=1)

    @property
    def t_end(self) -> float:
        return float(self.times[-1])

    def __call__(self, t):
        # from the first sample on (a switch's resolution before it: a piece entered
        # there), the Hermite's own rate
        if t < self.times[0] - SWITCH_RESOLUTION:
            return self.lengths[0], self._zero, self._zero
        if t >= self.times[-1]:
            return self.lengths[-1], self._zero, self._zero
        i = max(int(np.searchsorted(self.times, t, side="right")) - 1, 0)
        h = self.times[i + 1] - self.times[i]
        s = (t - self.times[i]) / h
        y0, y1 = self.lengths[i], self.lengths[i + 1]
        d0, d1 = self.rates[i] * h, self.rates[i + 1] * h
        lengths = (2 * s**3 - 3 * s**2 + 1) * y0 + (s**3 - 2 * s**2 + s) * d0
        lengths += (3 * s**2 - 2 * s**3) * y1 + (s**3 - s**2) * d1
        rates = (6 * s**2 - 6 * s) * y0 + (3 * s**2 - 4 * s + 1) * d0
        rates += (6 * s - 6 * s**2) * y1 + (3 * s**2 - 2 * s) * d1
        accelerations = (12 * s - 6) * y0 + (6 * s - 4) * d0 + (6 - 12 * s) * y1 + (6 * s - 2) * d1
        return lengths, rates / h, accelerations / h**2

    def is_static(self, t0, t1) -> bool:
        first = int(np.searchsorted(self.times, t0, side="right")) - 1
        last = int(np.searchsorted(self.times, t1, side="left"))
        if last <= 0 or first >= self.times.size - 1:
            return True  # wholly before the first or after the last sample
        return bool(np.all(self._still[max(first, 0) : min(last, self._still.size)]))


class JammedProfile:
    """A profile whose booms jam: each stops dead where it first reaches its
    `stop_lengths` [m] (a length it never reaches: no jam), then holds.

    Args:
        profile: the motion without the jam (a profile with `t_end`).
        stop_lengths: where each boom stops [m] (scalar or 4 values).
    """

    def __init__(self, profile, stop_lengths):
        self.profile = profile
        self.stop_lengths = per_boom(stop_lengths, "stop_lengths", positive=True)
        end = float(getattr(profile, "t_end", math.inf))
        if not math.isfinite(end):
            raise ValueError("a jam needs a profile that ends (t_end)")
        self.jam_times = np.array([self._reached(k, end) for k in range(4)])

    def _reached(self, k: int, end: float) -> float:
        """First time [s] boom k reaches its stop length (inf if never), to 1e-12 s."""
        start_length = self.profile(-1e9)[0][k]
        target = self.stop_lengths[k]
        grid = np.linspace(-1e-9, end, 2001)
        lengths = np.array([self.profile(t)[0][k] for t in grid])
        crossed = np.flatnonzero((lengths - target) * np.sign(target - start_length) >= 0)
        if target == start_length:
            return -math.inf
        if crossed.size == 0:
            return math.inf
        low, high = grid[max(crossed[0] - 1, 0)], grid[crossed[0]]
        for _ in range(60):
            middle = 0.5 * (low + high)
            beyond = (self.profile(middle)[0][k] - target) * np.sign(target - start_length) >= 0
            low, high = (low, middle) if beyond else (middle, high)
        return high

    @property
    def t_end(self) -> float:
        return float(min(np.max(self.jam_times), self.profile.t_end))

    def __call__(self, t):
        lengths, rates, accelerations = (np.array(v, dtype=float) for v in self.profile(t))
        jammed = t >= self.jam_times
        lengths[jammed] = self.stop_lengths[jammed]
        rates[jammed] = 0.0
        accelerations[jammed] = 0.0
        return lengths, rates, accelerations

    def is_static(self, t0, t1) -> bool:
        return bool(np.all(t0 >= self.jam_times)) or self.profile.is_static(t0, t1)

    def extremes(self):
        """Those of the motion without the jam (stopping dead is the failure modelled, not
        a commanded motion): a boom stops within its travel."""
        return self.profile.extremes()


# s: times this close count as the same switch (commands are logged to the nanosecond: a
# replay's switch may lie that far from where the simulator's step ended)
SWITCH_RESOLUTION = 1e-9


class SwitchedProfile:
    """`profiles[i]` from `times[i]` [s] on (increasing times): a motion as commands
    changed it, each taking over at its own time. The stepper ends its steps at the
    switches (`switch_times`), as the live simulator's steps end where a command takes
    effect, so an offline replay steps as the simulator stepped."""

    def __init__(self, times, profiles):
        self.times = np.asarray(times, dtype=float)
        self.profiles = tuple(profiles)
        if self.times.size != len(self.profiles) or np.any(np.diff(self.times) <= 0):
            raise ValueError("SwitchedProfile: one profile per time, times increasing")
        self.switch_times = tuple(float(t) for t in self.times[1:])

    def piece(self, t, entered: bool = True):
        """The profile in force at `t` [s]; at a switch time (within SWITCH_RESOLUTION)
        the one that starts there, or (`entered` False) the one that ends there (the
        stepper's end of a step)."""
        if entered:
            index = np.searchsorted(self.times, t + SWITCH_RESOLUTION, side="right")
        else:
            index = np.searchsorted(self.times, t - SWITCH_RESOLUTION, side="left")
        return self.profiles[max(int(index) - 1, 0)]

    def __call__(self, t):
        return self.piece(t)(t)

    def is_static(self, t0, t1) -> bool:
        return self.piece(t0) is self.piece(t1) and self.piece(t0).is_static(t0, t1)


class BoomMotion:
    """Booms a..d, each following its own 4-boom profile (only its column is used).

    A boom-length command may name only some booms; the others keep doing
    what they were doing (holding, or finishing an earlier command):
    `replaced` gives the motion with a new profile for some booms.

    Args:
        profiles: 4 profiles, one per boom (the same object may serve several).
    """

    def __init__(self, profiles):
        self.profiles = tuple(profiles)
        if len(self.profiles) != 4:
            raise ValueError(f"need one profile per boom (4), got {len(self.profiles)}")
        self._distinct = list({id(p): p for p in self.profiles}.values())
        # which distinct profile drives each boom: one gather per call, not 12 lookups
        owner = {id(p): j for j, p in enumerate(self._distinct)}
        self._owner = np.array([owner[id(p)] for p in self.profiles])
        # profiles that give one boom's motion alone (`CycloidalProfile.boom_at`): each
        # evaluated for its own boom only
        self._per_boom = all(hasattr(p, "boom_at") for p in self._distinct)

    def replaced(self, profile, booms) -> BoomMotion:
        """This motion with `profile` for the booms at indices `booms` (0 = a)."""
        return BoomMotion(profile if k in booms else p for k, p in enumerate(self.profiles))

    def __call__(self, t):
        if len(self._distinct) == 1:
            return self._distinct[0](t)
        if self._per_boom:
            columns = np.array([p.boom_at(k, t) for k, p in enumerate(self.profiles)]).T
            return columns[0], columns[1], columns[2]
        values = np.array([p(t) for p in self._distinct], dtype=float)
        lengths, rates, accelerations = values[self._owner, :, _BOOMS].T.copy()
        return lengths, rates, accelerations

    def is_static(self, t0, t1) -> bool:
        return all(p.is_static(t0, t1) for p in self._distinct)

    def over(self, times):
        """As `CycloidalProfile.over`, each boom from its own profile; None unless every
        profile has `over`."""
        if not all(hasattr(p, "over") for p in self._distinct):
            return None
        found = {id(p): p.over(times) for p in self._distinct}
        return tuple(
            np.column_stack([found[id(p)][part][:, k] for k, p in enumerate(self.profiles)])
            for part in range(3)
        )

    def extremes(self):
        """As `StaticProfile.extremes`, each boom from its own profile."""
        found = {id(p): p.extremes() for p in self._distinct}
        return tuple(
            np.array([found[id(p)][part][k] for k, p in enumerate(self.profiles)])
            for part in range(4)
        )

    @property
    def t_end(self) -> float:
        """When the last boom stops [s] (-inf if none was ever commanded)."""
        return max(getattr(p, "t_end", -np.inf) for p in self._distinct)
