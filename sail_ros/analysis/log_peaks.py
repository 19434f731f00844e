"""Peaks of a log's tip deflections and root moments, between its samples.

A log holds samples (50 Hz by default), not the run: its peaks are taken from
the cubic Hermite through each pair of samples with the rates the log holds
(`integrate.peaks.PeakSearch`): the tip rates of `/sail/tip_deflection`, and for
the root moments `d/dt (EI psi''(0)^T p / L^2)` from `/sail/modal_state`'s
velocities and `/sail/boom_state`'s rates. That interpolation is only as good
as the sampling: a boom mode of frequency omega sampled every `dt` with
`omega dt` above `RESOLVED_PHASE` rad is not resolved, and `LogPeaks` says how
much of each boom's peak such modes carry (from the logged modal coordinates),
so the reader knows how far to trust a peak. Where the stamps do not increase
(a reset publishes a fresh sample at the time of the last) the interpolation
starts again.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.analysis.log_series import LogSeries, runs_of
from sail_ros.integrate.peaks import Peak, Peaks, PeakSearch, with_tilt
from sail_ros.model import SailModel
from sail_ros.model.sail_model import cantilever_frequencies

RESOLVED_PHASE = 1.0  # rad of a mode between two samples that Hermite interpolation follows


@dataclasses.dataclass(frozen=True)
class LogPeaks:
    """Peaks of a log, per boom a..d.

    Attributes:
        peaks: peak |tip deflection| [m] and |root moment| [N m] with times [s on the
            log's time axis] (NaN where the log lacks the topic), and a free hub's
            (`Peaks.hub`: |z_h| [m], |theta_x|, |theta_y|, tilt |theta| [rad],
            interpolated with the logged rates of /sail/hub_state; None without it).
        interpolated: whether the tips and the root moments were interpolated with
            their rates (else: the largest sample).
        spacing_s: the median time between two samples [s].
        unresolved_tip, unresolved_moment: per boom, the largest |part| of the tip
            deflection [m] and root moment [N m] carried by boom modes the sampling does
            not resolve (`omega dt > RESOLVED_PHASE`); None without modal state.
        unresolved_frequency_hz: the lowest such mode's frequency [Hz] (inf if none).
    """

    peaks: Peaks
    interpolated: tuple[bool, bool]
    spacing_s: float
    unresolved_tip: np.ndarray | None
    unresolved_moment: np.ndarray | None
    unresolved_frequency_hz: float


def log_peaks(log: LogSeries, model: SailModel | None) -> LogPeaks:
    """The peaks of `log` (`read_log`); `model` (the log's sail) gives the root moments'
    rates and the modes' frequencies; None: the root moments are taken as sampled."""
    empty = Peak(np.full(4, np.nan), np.full(4, np.nan))
    tips, moments = empty, empty
    spacing = np.nan
    interpolated = [False, False]
    if log.tips is not None and log.tips.position.size:
        t = log.seconds(log.tips.stamp_ns)
        spacing = float(np.median(np.diff(t))) if t.size > 1 else np.nan
        rates = log.tips.velocity if log.tips.velocity.shape == log.tips.position.shape else None
        tips = _search(t, log.tips.position, rates)
        interpolated[0] = rates is not None
    rates = None
    if log.moments is not None and log.moments.effort.size:
        t = log.seconds(log.moments.stamp_ns)
        if np.isnan(spacing) and t.size > 1:
            spacing = float(np.median(np.diff(t)))
        rates = _moment_rates(log, model)
        moments = _search(t, log.moments.effort, rates)
        interpolated[1] = rates is not None
    unresolved = _unresolved(log, model, spacing)
    hub = None
    if log.hub is not None:
        stamps, values = log.hub  # z_h, theta_x, theta_y, then their rates
        hub = _search(log.seconds(stamps), *with_tilt(values[:, :3], values[:, 3:], first=1))
    return LogPeaks(Peaks(tips, moments, hub), tuple(interpolated), spacing, *unresolved)


def _search(t, values, rates) -> Peak:
    """Without rates the cubic between two samples is monotone (zero end slopes): the
    largest sample is the peak."""
    rates = np.zeros_like(values) if rates is None else rates
    search = PeakSearch(values.shape[1])
    for part in runs_of(t):
        search.restart()
        search.add(t[part], values[part], rates[part])
    return Peak(search.value, search.time)


def _moment_rates(log: LogSeries, model: SailModel | None):
    """d/dt of each root moment at its stamps [N m/s], or None when the log lacks what it
    takes (the model, the modal velocities, the boom rates at the same stamps)."""
    if model is None or log.modal is None or log.boom is None:
        return None
    stamps = log.moments.stamp_ns
    if not (
        np.array_equal(log.modal.stamp_ns, stamps)
        and np.array_equal(log.boom.stamp_ns, stamps)
        and log.modal.velocity.shape == (stamps.size, model.n)
    ):
        return None
    lengths, rates = log.boom.position, log.boom.velocity
    curvature = log.modal.velocity @ model.length_free_rows[4:].T
    return curvature / lengths**2 - 2.0 * rates * log.moments.effort / lengths


def _unresolved(log: LogSeries, model: SailModel | None, spacing: float):
    """`(tip, moment, lowest frequency)`: what boom modes the sampling cannot follow carry."""
    if model is None or log.modal is None or log.boom is None or not spacing > 0:
        return None, None, np.inf
    if not np.array_equal(log.modal.stamp_ns, log.boom.stamp_ns):
        return None, None, np.inf
    lengths = log.boom.position  # (k, 4)
    # bare-cantilever frequency of each boom mode at each sample [rad/s], (k, 4, nb)
    omega = cantilever_frequencies(model.params, lengths, model.n_boom_modes)
    unresolved = omega * spacing > RESOLVED_PHASE
    tips, moments = model.boom_mode_shares(log.modal.position, lengths)
    tip = np.sum(np.where(unresolved, tips, 0.0), axis=2)
    moment = np.sum(np.where(unresolved, moments, 0.0), axis=2)
    lowest = np.min(np.where(unresolved, omega, np.inf), initial=np.inf) / (2 * np.pi)
    return np.abs(tip).max(axis=0), np.abs(moment).max(axis=0), float(lowest)
