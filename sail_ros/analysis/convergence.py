"""How far a run's peaks are from the continuum: reruns with more modes until they settle.

A run's peaks converge slowly in the membrane modes (the film's spectrum is dense and
takes the booms' energy away through the modes around their frequencies; docs/model.md,
"Mode counts"), hardly at all in the boom modes beyond eight. `converge` reruns a
scenario on a ladder of finer models, each keeping membrane modes up to `REFINE` times
the band of the one before (about 1.6 times the modes) and four more boom modes, until
two successive levels agree within `bar`, and gives the run's peaks against the finest.

A change is measured against the largest peak of its kind (the largest |tip| of the four
booms, the largest |root moment|): a small boom's peak moving by a tenth of itself while
the largest is a hundred times it is converged for the question the run answers. The
change against each boom's own peak is given too.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.integrate.peaks import Peaks
from sail_ros.model import SailModel
from sail_ros.model.parameters import MAX_BOOM_MODES, MAX_MEMBRANE_MODES

# a peak is converged when the next finer model moves it by at most this fraction of the
# largest peak of its kind
BAR = 0.01
# each level keeps membrane modes up to this multiple of the band of the one before
REFINE = 1.25
BOOM_MODES_STEP = 4
MAX_LEVELS = 3


@dataclasses.dataclass(frozen=True)
class Change:
    """How the peaks of one run differ from another's (`finer`).

    Attributes:
        tips, moments: per boom a..d, `(this - finer)` of the peak |tip deflection| and
            |root moment| over the finer run's largest peak of that kind [-].
        tips_own, moments_own: the same over each boom's own finer peak (0 where it is 0).
    """

    tips: np.ndarray
    moments: np.ndarray
    tips_own: np.ndarray
    moments_own: np.ndarray

    @classmethod
    def between(cls, peaks: Peaks, finer: Peaks) -> Change:
        parts = []
        for mine, theirs in (
            (peaks.tip_deflection.value, finer.tip_deflection.value),
            (peaks.root_moment.value, finer.root_moment.value),
        ):
            difference = np.asarray(mine) - np.asarray(theirs)
            largest = float(np.max(theirs))
            parts.append(difference / largest if largest > 0 else np.zeros(4))
            parts.append(
                np.divide(difference, theirs, out=np.zeros(4), where=np.asarray(theirs) != 0)
            )
        tips, tips_own, moments, moments_own = parts
        return cls(tips, moments, tips_own, moments_own)

    def largest(self) -> float:
        """The largest |change| against the largest peak of its kind [-]."""
        return float(np.max(np.abs(np.concatenate([self.tips, self.moments]))))


@dataclasses.dataclass(frozen=True)
class Level:
    """One rerun: its mode counts, its peaks, and how the level before it differs."""

    n_boom_modes: int
    n_membrane_modes: int
    peaks: Peaks
    change_before: Change  # the previous level's (or the run's) peaks against these


@dataclasses.dataclass(frozen=True)
class Convergence:
    """The ladder of reruns (`converge`).

    Attributes:
        n_boom_modes, n_membrane_modes: the run's own mode counts.
        levels: the reruns, coarsest first.
        bar: the change two successive levels must stay within.
        converged: the last two levels (the run and the first, if one) agree within it.
        stopped: why the ladder ended before that ("" when converged).
        change: the run's peaks against the finest level's.
    """

    n_boom_modes: int
    n_membrane_modes: int
    levels: tuple[Level, ...]
    bar: float
    converged: bool
    stopped: str
    change: Change

    @property
    def finest(self) -> Level:
        return self.levels[-1]

    @property
    def holds(self) -> bool:
        """The run's peaks are within `bar` of the finest level's and the ladder settled
        (`warning` says nothing)."""
        return self.converged and self.change.largest() <= self.bar

    def warning(self, hint: str) -> str:
        """One line when the run's peaks are not within the bar of the finest rerun's, or
        the reruns did not settle ("" if both hold); `hint` says how to refine."""
        moved = [
            f"{what} {boom} {100 * change:+.2f} %"
            for what, changes in (("tip", self.change.tips), ("moment", self.change.moments))
            for boom, change in zip("abcd", changes, strict=True)
            if abs(change) > self.bar
        ]
        parts = []
        if moved:
            parts.append(
                f"peaks not converged: against (n_B, n_M) = ({self.finest.n_boom_modes}, "
                f"{self.finest.n_membrane_modes}) they are off by more than "
                f"{100 * self.bar:g} % of the largest of their kind ({', '.join(moved)}); {hint}"
            )
        if self.stopped:
            parts.append(f"the reruns did not settle: {self.stopped}")
        return f"warning: {'; '.join(parts)}" if parts else ""


def finer_parameters(params, n_boom_modes: int | None = None, n_membrane_modes: int | None = None):
    """The parameters of the next level: the counts given, else four more boom modes (up to
    `MAX_BOOM_MODES`) and the membrane band `REFINE` times wider (an explicit count times
    `REFINE^2`), up to `MAX_MEMBRANE_MODES`. None when neither count can grow."""
    nb = n_boom_modes or min(params.n_boom_modes + BOOM_MODES_STEP, MAX_BOOM_MODES)
    if n_membrane_modes:
        finer = params.replace(n_boom_modes=nb, n_membrane_modes=n_membrane_modes)
    elif params.n_membrane_modes:
        count = min(round(params.n_membrane_modes * REFINE**2), MAX_MEMBRANE_MODES)
        finer = params.replace(n_boom_modes=nb, n_membrane_modes=count)
    else:
        finer = params.replace(n_boom_modes=nb, membrane_band=params.membrane_band * REFINE)
        if finer.membrane_mode_need > MAX_MEMBRANE_MODES:
            finer = finer.replace(n_membrane_modes=MAX_MEMBRANE_MODES)
    if nb < params.n_boom_modes or finer.membrane_modes < params.membrane_modes:
        raise ValueError(
            f"convergence: mode counts ({nb}, {finer.membrane_modes}) must grow from the "
            f"run's (n_B, n_M) = ({params.n_boom_modes}, {params.membrane_modes})"
        )
    if (nb, finer.membrane_modes) == (params.n_boom_modes, params.membrane_modes):
        return None
    return finer


def converge(
    rerun,
    model: SailModel,
    peaks: Peaks,
    counts=None,
    bar: float = BAR,
    max_levels: int = MAX_LEVELS,
) -> Convergence:
    """Reruns on finer models until two successive levels agree within `bar`.

    Args:
        rerun: `rerun(finer_model) -> Peaks`, the run repeated on a finer model.
        model: the run's model.
        peaks: the run's peaks.
        counts: `(n_B, n_M)` of a single rerun instead of the ladder, or None.
        bar: the largest change against the largest peak of its kind that counts as
            converged.
        max_levels: the most reruns.

    Raises:
        ValueError: `counts` do not grow from the run's.
    """
    params, levels, previous = model.params, [], peaks
    for _ in range(1 if counts else max_levels):
        finer = finer_parameters(params, *(counts or (None, None)))
        if finer is None:
            break
        finer_model = SailModel(finer)
        fine = rerun(finer_model)
        change = Change.between(previous, fine)
        levels.append(Level(finer.n_boom_modes, finer_model.n_membrane_modes, fine, change))
        if levels[-1].change_before.largest() <= bar:
            break
        params, previous = finer, fine
    if not levels:
        raise ValueError(
            f"convergence: the run's (n_B, n_M) = ({model.n_boom_modes}, "
            f"{model.n_membrane_modes}) are the largest counts there are"
        )
    converged = levels[-1].change_before.largest() <= bar
    stopped = ""
    if not converged:
        stopped = (
            f"{len(levels)} rerun(s) up to (n_B, n_M) = ({levels[-1].n_boom_modes}, "
            f"{levels[-1].n_membrane_modes}) still moved the peaks by "
            f"{100 * levels[-1].change_before.largest():.2g} % of the largest"
        )
    return Convergence(
        model.n_boom_modes,
        model.n_membrane_modes,
        tuple(levels),
        bar,
        converged,
        stopped,
        Change.between(peaks, levels[-1].peaks),
    )
