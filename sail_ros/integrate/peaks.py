"""True peaks of the outputs users read: taken inside the integrator's own steps.

A peak read off printed or logged samples misses what happens between them: a
boom's root moment weighs its mode i by `beta_i^2`, so the higher boom modes,
tens to thousands of hertz, show in it (read from 200 Hz samples, the peak
moments of the reference deployment's small booms were off by up to 9.5 %).

`OutputPeaks` watches a `SailStepper` (its `on_step`): it samples the tip
deflections and root moments inside every step on the step's own curve
(`SailStepper.last_curve`: exact at rest, the step's continuous extension while the
booms move), up to `BATCH_STEPS` steps at a time, and keeps the largest |value| of
each output with its time. Between two samples the output is the cubic Hermite through their
values and rates (`PeakSearch`), whose error for a sine sampled every `phi` rad
is `phi^4 / 384` of its amplitude (a 1 kHz sampling misses up to 1 - cos(omega /
2 kHz) of it: 1 % of a 47 Hz mode). The samples are close enough that this error
stays within `PEAK_ERROR` of the amplitude of the step's slow part and, for its
followed modes (`fast_modes`), of each output's largest value: every
`PEAK_PHASE` rad of the slow part's highest frequency, closer where the followed
modes weigh enough in an output for their frequencies to matter
(`OutputPeaks.spacings`), at least every `MAX_SPACING_S`, and on both sides of
the middle of a step, where the followed modes' static response jumps.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from sail_ros.integrate.rational import Curves
from sail_ros.integrate.rest import Rest, rest_curve

PEAK_PHASE = 0.5  # rad of the slow part's highest frequency between two samples of a step
# the cubic Hermite's error over a sine sampled every PEAK_PHASE rad, of its amplitude
PEAK_ERROR = PEAK_PHASE**4 / 384.0
MAX_SPACING_S = 0.01  # s: at least 100 Hz, however slow the modes
BATCH_STEPS = 16  # steps sampled together (`OutputPeaks`) ...
# ... and no more than this many coordinates times steps: past it the stacked arrays
# outgrow the processor's caches, and batching saves nothing
BATCH_COORDINATES = 640


class Peak(NamedTuple):
    """The largest |value| of each output (4 booms a..d) and when it occurred [s]."""

    value: np.ndarray
    time_s: np.ndarray


class Peaks(NamedTuple):
    """Peak |tip deflection| [m] and |root moment| [N m] of each boom, with times; with a
    free hub `hub`: peak |z_h| [m], |theta_x|, |theta_y| and the tilt
    `sqrt(theta_x^2 + theta_y^2)` [rad] (None when clamped)."""

    tip_deflection: Peak
    root_moment: Peak
    hub: Peak | None = None


class SampledSteps(NamedTuple):
    """What `OutputPeaks` sampled of a batch of steps (S steps, m samples in all, in time
    order: each step's own samples and the fractions asked `also`).

    Attributes:
        t0, h: each step's start and length [s] (S,).
        lengths0, rates0, lengths1, rates1: the boom lengths [m] and rates [m/s] at each
            step's ends (S, 4).
        step: the step of each sample (m,).
        fractions: each sample's fraction of its step (m,).
        values: the `OutputPeaks.rows` values there (m, r; root moment rows not yet
            over L^2).
        rates: their rates [per s] (m, r).
        searched: whether a sample is the step's own (True) or asked `also` (m,).
        largest: the largest |value| of each row over each step's own samples (S, r;
            nan where one is).
    """

    t0: np.ndarray
    h: np.ndarray
    lengths0: np.ndarray
    rates0: np.ndarray
    lengths1: np.ndarray
    rates1: np.ndarray
    step: np.ndarray
    fractions: np.ndarray
    values: np.ndarray
    rates: np.ndarray
    searched: np.ndarray
    largest: np.ndarray

    def times(self) -> np.ndarray:
        """The samples' times [s] (m,)."""
        return self.t0[self.step] + self.fractions * self.h[self.step]


class _Queued(NamedTuple):
    """A step taken, not yet sampled: its start [s], lengths [m] and rates [m/s] at its
    ends, its curve (`SailStepper.last_curve`), the fractions asked `also` and the
    coordinates at its end."""

    t0: float
    lengths0: np.ndarray
    rates0: np.ndarray
    lengths1: np.ndarray
    rates1: np.ndarray
    curve: object
    also: np.ndarray
    q1: np.ndarray


class PeakSearch:
    """The largest |y| of each column over samples `(t, y, yd)` given in time order,
    and between consecutive samples over the cubic Hermite through their values and
    rates (the first sample of a chunk joins the last of the chunk before)."""

    def __init__(self, columns: int):
        self.value = np.zeros(columns)
        self.time = np.full(columns, math.nan)
        self._last: tuple[float, np.ndarray, np.ndarray] | None = None

    def add(self, t, y, yd) -> None:
        """Samples at times `t` [s] (m,), values `y` and rates `yd` per second (m, c)."""
        t = np.asarray(t, dtype=float)
        y, yd = np.atleast_2d(y), np.atleast_2d(yd)
        if self._last is not None:
            t0, y0, yd0 = self._last
            t, y, yd = np.append(t0, t), np.vstack([y0, y]), np.vstack([yd0, yd])
        self._last = (float(t[-1]), y[-1], yd[-1])
        self._keep(t, np.abs(y))
        if t.size > 1:
            # only the intervals whose cubic may pass a largest value so far (the same
            # maxima, and times, as from every interval): |p| <= max(|y0|, |y1|) + 4/27
            # (|d0| + |d1|) (`HERMITE_BOUND`)
            h = np.diff(t)[:, None]
            magnitudes, rates = np.abs(y), np.abs(yd)
            bound = np.maximum(magnitudes[:-1], magnitudes[1:])
            bound += HERMITE_BOUND * h * (rates[:-1] + rates[1:])
            near = np.flatnonzero(np.any(bound * (1.0 + 1e-9) >= self.value, axis=1))
            if near.size:
                times, values = _extrema(t[near], t[near + 1], y[near], y[near + 1],
                                         yd[near], yd[near + 1])  # fmt: skip
                self._keep(times, np.abs(values))

    def restart(self) -> None:
        """The next sample does not continue the last (e.g. the state was reset)."""
        self._last = None

    def _keep(self, times, magnitudes) -> None:
        """Keep, per column, the largest of `magnitudes` (k, c) at `times` (k,) or (k, c)."""
        rows = np.argmax(magnitudes, axis=0)
        columns = np.arange(magnitudes.shape[1])
        best = magnitudes[rows, columns]
        when = np.broadcast_to(np.asarray(times)[:, None] if np.ndim(times) == 1 else times,
                               magnitudes.shape)[rows, columns]  # fmt: skip
        better = best > self.value
        self.value = np.where(better, best, self.value)
        self.time = np.where(better, when, self.time)


# |p(s)| <= max(|y0|, |y1|) + HERMITE_BOUND (|d0| + |d1|) on [0, 1] for the cubic Hermite
# (its basis: h00 + h01 = 1, both in [0, 1]; |h10|, |h11| <= 4/27)
HERMITE_BOUND = 4.0 / 27.0


def _extrema(t0, t1, y0, y1, yd0, yd1) -> tuple[np.ndarray, np.ndarray]:
    """Times and values (each (2 k, c)) of the interior stationary points of the cubic
    Hermite from `(t0, y0, yd0)` to `(t1, y1, yd1)` ((k,), (k, c) each): the roots of its
    derivative, both signs stacked; an interval without one repeats its start (value
    and time), which changes no maximum."""
    h = (t1 - t0)[:, None]
    d0, d1 = yd0 * h, yd1 * h  # rates per unit of the interval's parameter s
    # p(s) = y0 + s (d0 + s (c2 + s c3)) on s in [0, 1]; p'(s) = a s^2 + b s + d0
    c2, c3 = hermite_cubic(y0, d0, y1, d1)
    a, b = 3.0 * c3, 2.0 * c2
    with np.errstate(invalid="ignore", divide="ignore"):
        discriminant = b * b - 4.0 * a * d0
        root = np.sqrt(np.maximum(discriminant, 0.0)) * _SIGNS_OF_ROOTS
        quadratic = np.abs(a) > 1e-12 * (np.abs(b) + np.abs(d0))
        s = np.where(quadratic, (root - b) / (2.0 * a), -d0 / b)  # (2, k, c)
        s = np.where((discriminant >= 0.0) & (s > 0.0) & (s < 1.0), s, 0.0)
    values = y0 + s * (d0 + s * (c2 + s * c3))
    count = y0.shape[1]
    return (t0[:, None] + s * h).reshape(-1, count), values.reshape(-1, count)


_SIGNS_OF_ROOTS = np.array([1.0, -1.0])[:, None, None]


class OutputPeaks:
    """A `SailStepper` observer (`SailModel.simulate(..., observer=...)`): the peak
    |tip deflection| and |root moment| of each boom over every step, with times, and a
    free hub's heave, tilts and tilt magnitude.

    Steps are kept as they are taken and sampled in batches of 1, 2, 4, ... up to
    `batch_steps` (`BATCH_STEPS`, `BATCH_COORDINATES`), and when the peaks are read
    (`flush`): numpy's cost per call, more than the arithmetic, is what a step's hundred
    samples cost (`rational.Curves`). A step's spacing (`spacings`) takes the outputs'
    largest values from below inside a batch (`_scales`), so its samples are never the
    farther apart.

    Args:
        model: the `SailModel` the stepper integrates.
        peak_phase: rad of the interpolant's slow part's highest frequency between two
            samples (`spacings`).
        max_spacing: longest time between two samples [s].
        batch_steps: steps sampled together (default `BATCH_STEPS`, fewer for large
            models: `BATCH_COORDINATES`).
        check: callable `check(SampledSteps)` before a batch's samples are searched,
            returning a time [s] after which none is (a run stopped there), or None.
    """

    # what `rows` holds, by index: tips a..d, root moments a..d, a free hub's z_h,
    # theta_x, theta_y
    TIP_ROWS, HUB_ROWS = [0, 1, 2, 3], [8, 9, 10]

    def __init__(
        self,
        model,
        peak_phase: float = PEAK_PHASE,
        max_spacing: float = MAX_SPACING_S,
        batch_steps: int | None = None,
        check=None,
    ):
        self.model = model
        self.peak_phase = float(peak_phase)
        self.max_spacing = float(max_spacing)
        if batch_steps is None:
            batch_steps = min(BATCH_STEPS, max(1, BATCH_COORDINATES // model.n))
        self.batch_steps = int(batch_steps)
        self.check = check
        # (8, n): tips, then EI psi''(0) on each boom; a free hub's z_h, theta_x, theta_y
        self.rows = model.length_free_rows
        self.free_hub = bool(model.free_hub)
        if self.free_hub:
            self.rows = np.vstack([self.rows, np.eye(model.n)[model.hub_slice]])
        # tips a..d, root moments a..d, then z_h, theta_x, theta_y and the tilt
        self._search = PeakSearch(12 if self.free_hub else 8)
        self._start = None  # (t, lengths, rates) at the start of the next step
        self._queue: list[_Queued] = []  # steps taken, not yet sampled
        self._stopped = math.inf  # the time [s] `check` stopped the samples at
        # the largest |output| sampled so far (root moments in N m, from below)
        self.scale = np.zeros(len(self.rows))
        self.samples = 0
        # steps in the next batch: 1, 2, 4, ... up to `batch_steps`, so that the first
        # steps, while `scale` grows from the start's outputs, see it grow
        self._batch = 1

    def start(self, stepper) -> None:
        """Take the stepper's state now as the first sample (before its first step)."""
        lengths, rates, _ = stepper.boom_motion()
        y, yd = stepper.q @ self.rows.T, stepper.qd @ self.rows.T
        self._start = (stepper.t, lengths, rates)
        self._grow_scale(np.abs(y)[None], lengths[None])
        self._search_samples(np.array([stepper.t]), y[None], yd[None], lengths[None],
                             rates[None])  # fmt: skip

    def after_step(self, stepper, also=None) -> None:
        """Keep the step just taken (`SailStepper.on_step`), with more fractions of it to
        sample `also` (k,); sample the steps kept when `batch_steps` are, or when this
        one is of another kind (at rest, or of other rational steps)."""
        t0, lengths0, rates0 = self._start
        lengths1, rates1, _ = stepper.boom_motion()
        curve = stepper.last_curve()
        if self._queue and _kind(self._queue[0].curve) != _kind(curve):
            self.flush()
        also = np.zeros(0) if also is None else np.asarray(also, dtype=float)
        queued = _Queued(t0, lengths0, rates0, lengths1, rates1, curve, also, stepper.q)
        self._queue.append(queued)
        self._start = (stepper.t, lengths1, rates1)
        if len(self._queue) >= self._batch:
            self._batch = min(2 * self._batch, self.batch_steps)
            self.flush()

    def flush(self) -> None:
        """Sample the steps kept (their own samples and those asked `also`), hand them to
        `check`, and search the samples up to the time it returns."""
        queue, self._queue = self._queue, []
        if not queue or math.isfinite(self._stopped):
            return
        sampled = self._sample(queue)
        stop = None if self.check is None else self.check(sampled)
        times = sampled.times()
        keep = sampled.searched
        if stop is not None:
            self._stopped = float(stop)
            keep = keep & (times <= stop)
        step = sampled.step[keep]
        # the boom lengths and rates at each sample: its step's motion cubic
        h = sampled.h[:, None]
        ends = (sampled.lengths0, sampled.rates0, sampled.lengths1, sampled.rates1)
        lengths, rates = cubic_motion(sampled.fractions[keep], h[step],
                                      motion_cubic(h, *ends)[:, step])  # fmt: skip
        y, yd = sampled.values[keep], sampled.rates[keep]
        self._search_samples(times[keep], y, yd, lengths, rates)

    def _sample(self, queue: list[_Queued]) -> SampledSteps:
        """The samples of the steps `queue` (`SampledSteps`)."""
        t0 = np.array([step.t0 for step in queue])
        lengths0, rates0, lengths1, rates1 = (
            np.array([step[i] for step in queue]) for i in range(1, 5)
        )
        longest = np.maximum(lengths0, lengths1)
        curves = [step.curve for step in queue]
        if isinstance(curves[0], Rest):
            h = np.array([rest.h for rest in curves])
            slow = np.array([math.sqrt(max(float(rest.lam[-1]), 0.0)) for rest in curves])
            spacing = self.spacings(slow)
            jumps = [()] * len(queue)
        else:
            batch = Curves(curves)
            h, slow = batch.h, np.array([curve.slow for curve in curves])
            omega, amplitude = batch.followed(self.rows)
            scale = self._scales(queue, longest)
            spacing = self.spacings(slow, omega, amplitude, np.minimum(lengths0, lengths1), scale)
            jumps = [curve.jumps() for curve in curves]
        counts = np.maximum(1, np.ceil(h / spacing - 1e-9)).astype(int)
        own = [step_fractions(int(count), jump) for count, jump in zip(counts, jumps, strict=True)]
        fractions = np.concatenate([part for f, queued in zip(own, queue, strict=True)
                                    for part in (f, queued.also)])  # fmt: skip
        sizes = np.array([[f.size, queued.also.size]
                          for f, queued in zip(own, queue, strict=True)])  # fmt: skip
        step = np.repeat(np.arange(len(queue)), sizes.sum(axis=1))
        searched = np.repeat(np.tile([True, False], len(queue)), sizes.ravel())
        if sizes[:, 1].any():  # each step's samples in time order
            order = np.argsort(step + 0.5 * fractions, kind="stable")
            step, fractions, searched = step[order], fractions[order], searched[order]
        if isinstance(curves[0], Rest):
            y, yd = self._rest_values(curves, step, fractions)
        else:
            y, yd = batch.curve(step, fractions, self.rows, grid=counts)
        # the largest |value| over each step's own samples
        starts = np.concatenate([[0], np.cumsum(sizes[:-1, 0])])
        largest = np.maximum.reduceat(np.abs(y[searched]), starts, axis=0)
        self._grow_scale(largest, longest)
        return SampledSteps(t0, h, lengths0, rates0, lengths1, rates1, step, fractions, y, yd,
                            searched, largest)  # fmt: skip

    def _rest_values(self, rests, step, fractions):
        """`rows q`, `rows qd` at `fractions` of the steps at rest `rests[step]`."""
        y, yd = np.empty((step.size, len(self.rows))), np.empty((step.size, len(self.rows)))
        for i, rest in enumerate(rests):
            inside = step == i
            y[inside], yd[inside] = rest_curve(rest, fractions[inside], self.rows)
        return y, yd

    def _grow_scale(self, largest, lengths) -> None:
        """`scale` from the largest |rows| (S, r) of samples of S steps where no boom is
        longer than `lengths` (S, 4) [m]: the root moments' over `L^2` (at most their
        value in N m)."""
        largest = largest.copy()
        largest[:, 4:8] /= lengths**2
        self.scale = np.maximum(self.scale, largest.max(axis=0))

    def _scales(self, queue: list[_Queued], lengths) -> np.ndarray:
        """(S, r): `scale` as each of the steps `queue` starts, from below: before the
        first, grown by the outputs at the ends of those before it (the samples' largest
        values are known only once sampled; boom lengths `lengths` (S, 4) [m], as
        `_grow_scale`)."""
        ends = np.abs(np.array([step.q1 for step in queue]) @ self.rows.T)
        ends[:, 4:8] /= lengths**2
        return np.maximum.accumulate(np.vstack([self.scale, ends[:-1]]), axis=0)

    def spacings(self, slow, omega=None, amplitude=None, shortest=None, scale=None) -> np.ndarray:
        """The time [s] between two samples of each of S steps (S,): `peak_phase` rad of
        its slow part's highest frequency `slow` [rad/s] (S,), and for its followed modes
        (mode j of frequency `omega_j` (S, k) [rad/s], amplitude `A_rj` (S, r, k) in output
        r, root moments in N m at the shortest boom lengths `shortest` (S, 4) [m]; null
        modes 0 and 0) the longest `d` with `sum_j A_rj (omega_j d)^4 <= peak_phase^4 S_r`,
        `S_r` the largest |output r| so far (`scale` (S, r), each step's: `_scales`; `sum_j
        A_rj` where 0): the cubic Hermite's error, `(omega d)^4 / 384` of a sine's
        amplitude, then stays within `PEAK_ERROR` of the output's largest value for the
        followed modes, as for the slow part of its own amplitude. At most
        `max_spacing`, and at least a quarter of `peak_phase` rad of the highest followed
        mode (an output still beside its followed modes' vibration is then held to
        `PEAK_ERROR / 256` of that vibration). `S_r` only grows, so a spacing from a
        smaller one (a batch's, from the outputs at the steps' ends before each) is never
        the longer."""
        with np.errstate(divide="ignore"):
            spacing = np.minimum(self.max_spacing, self.peak_phase / slow)
        spacing[~(slow > 0)] = self.max_spacing
        if omega is None or not omega.size:
            return spacing
        amplitude = amplitude.copy()
        amplitude[:, 4:8] /= shortest[:, :, None] ** 2  # N m, at most
        weight = np.einsum("srk,sk->sr", amplitude, omega**4)
        bound = weight > 0
        scale = np.where(scale > 0, scale, amplitude.sum(axis=2))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(bound, scale / weight, np.inf).min(axis=1)
            densest = 0.25 * self.peak_phase / omega.max(axis=1)
        followed = bound.any(axis=1)
        held = np.maximum(densest, self.peak_phase * ratio**0.25)
        return np.where(followed, np.minimum(spacing, held), spacing)

    def _search_samples(self, t, y, yd, lengths, rates) -> None:
        """Search samples at times `t` [s] (m,) of the rows `y` and their rates `yd` (m,
        r), the root moments' over `L^2` at the boom lengths `lengths` [m] and rates
        `rates` [m/s] (m, 4) (turned into N m here)."""
        moments = y[:, 4:8] / lengths**2
        y, yd = y.copy(), yd.copy()
        y[:, 4:8] = moments
        yd[:, 4:8] = yd[:, 4:8] / lengths**2 - 2.0 * rates * moments / lengths
        if self.free_hub:
            y, yd = with_tilt(y, yd)
        self._search.add(t, y, yd)
        self.samples += t.size

    @property
    def peaks(self) -> Peaks:
        """The peaks so far: of the tip deflections [m] and root moments [N m]."""
        self.flush()
        value, time = self._search.value, self._search.time
        hub = Peak(value[8:].copy(), time[8:].copy()) if self.free_hub else None
        return Peaks(
            Peak(value[:4].copy(), time[:4].copy()),
            Peak(value[4:8].copy(), time[4:8].copy()),
            hub,
        )


def _kind(curve) -> tuple:
    """What steps sampled together share: at rest, or moving with as many rational steps."""
    return ("rest",) if isinstance(curve, Rest) else ("moving", curve.parts)


def with_tilt(y, yd, first: int = 9):
    """`y`, `yd` with a last column: the tilt `|theta| = sqrt(theta_x^2 + theta_y^2)` of
    columns `first` and `first + 1`, and its rate `(theta . thetad) / |theta|` (0 where
    untilted)."""
    theta, thetad = y[:, first : first + 2], yd[:, first : first + 2]
    tilt = np.hypot(theta[:, 0], theta[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(tilt > 0.0, np.sum(theta * thetad, axis=1) / tilt, 0.0)
    return np.column_stack([y, tilt]), np.column_stack([yd, rate])


@functools.lru_cache(maxsize=128)
def step_fractions(count: int, jumps: tuple = ()) -> np.ndarray:
    """1/count, 2/count, ..., 1, and each of `jumps` with the fraction just before it
    (both sides of a jump), in order (read-only: shared by every step alike)."""
    fractions = np.arange(1, count + 1) / count
    if jumps:
        sides = [np.nextafter(f, 0.0) for f in jumps] + list(jumps)
        fractions = np.union1d(fractions, sides)
    fractions.flags.writeable = False
    return fractions


def hermite_motion(fractions, h, lengths0, rates0, lengths1, rates1):
    """Boom lengths [m] and rates [m/s] (m, 4) at `fractions` (m,) of steps of `h` [s]
    (m,), from the cubic Hermite through each step's ends (m, 4) (the profile itself
    would cost a call per sample; over one step the cubic is exact to ~h^4 of the
    motion's fourth derivative)."""
    h = np.asarray(h, dtype=float).reshape(-1, 1)
    cubic = motion_cubic(h, lengths0, rates0, lengths1, rates1)
    return cubic_motion(np.asarray(fractions, dtype=float), h, cubic)


def motion_cubic(h, lengths0, rates0, lengths1, rates1) -> np.ndarray:
    """(4, ..., 4): the power coefficients `c_j` (of `s^j`, s the fraction of a step of
    `h` [s], (..., 1)) of the cubic Hermite through the boom lengths [m] and rates [m/s]
    (..., 4) at the step's ends."""
    d0, d1 = rates0 * h, rates1 * h
    cubic = (lengths0, d0, *hermite_cubic(lengths0, d0, lengths1, d1))
    return np.stack(np.broadcast_arrays(*cubic))


def hermite_cubic(y0, d0, y1, d1):
    """`(c2, c3)`: the coefficients of `s^2` and `s^3` of the cubic Hermite `y0 + d0 s +
    c2 s^2 + c3 s^3` on `s` in [0, 1] through the values `y0`, `y1` and slopes (per unit
    of `s`) `d0`, `d1` at its ends."""
    rise = y1 - y0
    return 3.0 * rise - 2.0 * d0 - d1, d0 + d1 - 2.0 * rise


def cubic_motion(fractions, h, cubic) -> tuple[np.ndarray, np.ndarray]:
    """Boom lengths [m] and rates [m/s] (m, 4) at `fractions` (m,) of steps of `h` [s]
    ((m, 1) or scalar) from their `motion_cubic` (4, m, 4), by Horner's rule."""
    s = fractions[:, None]
    c0, c1, c2, c3 = cubic
    lengths = ((c3 * s + c2) * s + c1) * s + c0
    slope = (3.0 * c3 * s + 2.0 * c2) * s + c1
    return lengths, slope / h
