"""Stability of the frozen system (seed Eq. 3) against membrane prestress and extension rate.

At a frozen boom length `L` with a constant extension rate `Ld` (all booms,
`Ldd = 0`) Eq. 2 has constant coefficients; in first-order form
`xd = A x`, `x = [qd; q]`, `A = [-M^-1 C, -M^-1 K_eq; I, 0]` with
`C = Md + G - G^T` and `K_eq = Gd + K - N` (model.md §7). Any eigenvalue of
`A` with a positive real part means the frozen system is unstable.

What the terms do (model.md §5):

- `Md` is proportional to `Ld`: damping while deploying, negative damping
  while retracting. Retraction is therefore unstable at every prestress;
  its largest real part tends to `|Ld| / L` as the membrane stiffens.
- `N` grows with `Ld^2` and lowers the stiffness; a slack membrane
  (`N0 = sigma h` small against `rho_M Ld^2`, the axially moving string's
  critical speed `sqrt(N0 / rho_M)`) diverges. Deployment is stable above a
  critical prestress that scales with `Ld^2`.

Numerical threshold: at zero rate the exact eigenvalues are `+-i omega`; the
computed ones carry round-off real parts of order `eps |A|` (~1e-15 1/s here).
A configuration counts as unstable when

    max Re(lambda) > INSTABILITY_RTOL * max |lambda|,   INSTABILITY_RTOL = 1e-9,

six orders above round-off and far below any physical growth rate of
interest (0.01 m/s retraction of a 70 m boom grows at 1.4e-4 1/s, 3e-5 of
max |lambda|).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence

import numpy as np
import scipy.linalg

from sail_ros.analysis.execution import run_cases
from sail_ros.model import SailModel, SailParameters
from sail_ros.model.linear import without_rigid

INSTABILITY_RTOL = 1e-9
BISECTION_RTOL = 1e-4  # relative width of the final prestress bracket

STABLE = "stable"  # stable at every prestress of the grid
UNSTABLE = "unstable"  # unstable at every prestress of the grid
CRITICAL = "critical"  # unstable below the critical prestress, stable above it


class FrozenSystem:
    """Eq. 3 at one length and rate for any prestress, without rebuilding the model.

    The prestress enters only through the membrane tension `N0 = sigma h`, and
    linearly (the tension stiffness, and its share of the Rayleigh damping), so
    `C(sigma) = C_0 + sigma C_1` and `K_eq(sigma) = K_0 + sigma K_1` with the
    matrices of two models, at 0 and 1 Pa, computed once."""

    def __init__(self, params: SailParameters, length: float, rate: float):
        # one model for every prestress: the automatic membrane count of the one given
        params = params.resolved(length).fixed_modes()
        slack = SailModel(params.replace(membrane_prestress=0.0))
        unit = SailModel(params.replace(membrane_prestress=1.0))
        M, C0, K0 = slack.matrices(length, rate, 0.0)
        _, C1, K1 = unit.matrices(length, rate, 0.0)
        factor = scipy.linalg.cho_factor(M)
        self._MC0 = scipy.linalg.cho_solve(factor, C0)
        self._MC1 = scipy.linalg.cho_solve(factor, C1) - self._MC0
        self._MK0 = scipy.linalg.cho_solve(factor, K0)
        self._MK1 = scipy.linalg.cho_solve(factor, K1) - self._MK0
        self.n = slack.n
        self.free_hub = slack.free_hub

    def eigenvalues(self, prestress: float) -> np.ndarray:
        """Eigenvalues [1/s] of `A = [-M^-1 C, -M^-1 K_eq; I, 0]` at `prestress` [Pa],
        sorted as `SailModel.eigenvalues` sorts them (with a free hub's six rigid-body
        ones)."""
        n = self.n
        A = np.zeros((2 * n, 2 * n))
        A[:n, :n] = -(self._MC0 + prestress * self._MC1)
        A[:n, n:] = -(self._MK0 + prestress * self._MK1)
        A[n:, :n] = np.eye(n)
        eig = np.linalg.eigvals(A)
        return eig[np.lexsort((eig.real, eig.imag))]


@functools.lru_cache(maxsize=64)
def frozen_system(params: SailParameters, length: float, rate: float) -> FrozenSystem:
    """The `FrozenSystem` at `length` [m] and `rate` [m/s], cached per process."""
    return FrozenSystem(params, float(length), float(rate))


def frozen_eigenvalues(
    params: SailParameters, length: float, rate: float, prestress: float
) -> np.ndarray:
    """Eigenvalues [1/s] of Eq. 3 at boom length `length` [m] (all booms),
    constant rate `rate` [m/s] and membrane prestress `prestress` [Pa]."""
    return frozen_system(params, length, rate).eigenvalues(prestress)


def growth(params, length, rate, prestress) -> tuple[float, float]:
    """`(max Re(lambda), max |lambda|)` [1/s] of the frozen system, a free hub's six
    rigid-body eigenvalues left out (`without_rigid`)."""
    eigenvalues = without_rigid(frozen_eigenvalues(params, length, rate, prestress),
                                params.free_hub)  # fmt: skip
    return float(eigenvalues.real.max()), float(np.abs(eigenvalues).max())


def is_unstable(max_real: float, max_abs: float, rtol: float = INSTABILITY_RTOL) -> bool:
    """The instability criterion `max Re > rtol * max |lambda|` (module docstring), of
    scalars or arrays alike."""
    return max_real > rtol * max_abs


@dataclasses.dataclass(frozen=True)
class PrestressSweep:
    """The largest real part against prestress at one length and rate.

    Attributes:
        length: boom length [m].
        rate: extension rate [m/s] (> 0 deployment, < 0 retraction).
        prestress: membrane prestress grid [Pa], ascending.
        max_real: max Re(lambda) [1/s] per prestress.
        max_abs: max |lambda| [1/s] per prestress.
        status: STABLE, UNSTABLE (throughout the grid) or CRITICAL.
        critical_prestress: with CRITICAL, the prestress [Pa] below which
            the frozen system is unstable (the highest crossing, bisected to
            BISECTION_RTOL); else None.
        monotone: False when stable and unstable prestresses alternate more
            than once on the grid (windows of stability).
    """

    length: float
    rate: float
    prestress: np.ndarray
    max_real: np.ndarray
    max_abs: np.ndarray
    status: str
    critical_prestress: float | None
    monotone: bool

    @property
    def unstable(self) -> np.ndarray:
        """Instability flag per prestress."""
        return is_unstable(self.max_real, self.max_abs)


def critical_prestress(
    params, length, rate, low: float, high: float, rtol: float = BISECTION_RTOL
) -> float:
    """Bisect (in log prestress) a bracket with `low` [Pa] unstable and `high`
    [Pa] stable down to `high / low <= 1 + rtol`; returns the bracket's middle [Pa]."""
    while high / low > 1.0 + rtol:
        middle = math.sqrt(low * high)
        if is_unstable(*growth(params, length, rate, middle)):
            low = middle
        else:
            high = middle
    return math.sqrt(low * high)


def prestress_sweep(
    params: SailParameters, length: float, rate: float, prestresses: Sequence[float]
) -> PrestressSweep:
    """Max Re over `prestresses` [Pa] at `length` [m] and `rate` [m/s], and the
    critical prestress bracketed on the grid and bisected."""
    prestresses = np.asarray(prestresses, dtype=float)
    values = np.array([growth(params, length, rate, s) for s in prestresses])
    max_real, max_abs = values[:, 0], values[:, 1]
    unstable = is_unstable(max_real, max_abs)
    changes = int(np.count_nonzero(unstable[1:] != unstable[:-1]))
    if not unstable.any():
        status, critical = STABLE, None
    elif unstable[-1]:
        status, critical = UNSTABLE, None
    else:
        last = int(np.flatnonzero(unstable)[-1])
        status = CRITICAL
        critical = critical_prestress(
            params, length, rate, prestresses[last], prestresses[last + 1]
        )
    return PrestressSweep(
        float(length),
        float(rate),
        prestresses,
        max_real,
        max_abs,
        status,
        critical,
        monotone=changes <= 1,
    )


def _sweep_task(task):
    params_dict, length, rate, prestresses = task
    return prestress_sweep(SailParameters(**params_dict), length, rate, prestresses)


def stability_sweep(
    params: SailParameters,
    lengths: Sequence[float],
    rates: Sequence[float],
    prestresses: Sequence[float],
    client=None,
    progress: Callable[[int], None] | None = None,
) -> list[PrestressSweep]:
    """`prestress_sweep` for every (length, rate), one case each on Dask.

    Args:
        params: the sail (its own prestress is replaced along the grid).
        lengths: boom lengths [m].
        rates: extension rates [m/s].
        prestresses: membrane prestress grid [Pa], ascending, > 0.
        client: a `dask.distributed.Client` (see `execution.run_cases`); None runs here.
        progress: called with the number of grid points just finished.

    Returns:
        one sweep per (length, rate), lengths outer, in the order given.

    Raises:
        KeyboardInterrupt: when interrupted (the unfinished cases are cancelled).
    """
    prestresses = np.asarray(prestresses, dtype=float)
    if (
        prestresses.ndim != 1
        or prestresses.size < 2
        or np.any(prestresses <= 0)
        or np.any(np.diff(prestresses) <= 0)
    ):
        raise ValueError(
            f"prestresses must be >= 2 increasing values > 0 [Pa], got {prestresses.tolist()!r}"
        )
    for name, values in (("lengths", lengths), ("rates", rates)):
        if len(values) == 0 or not np.all(np.isfinite(values)):
            raise ValueError(f"{name} must be one or more finite values, got {list(values)!r}")
    if np.any(np.asarray(lengths) <= 0):
        raise ValueError(f"lengths must be > 0 [m], got {list(lengths)!r}")
    tasks = [
        (params.to_dict(), float(length), float(rate), prestresses)
        for length in lengths
        for rate in rates
    ]
    outcome = run_cases(
        _sweep_task,
        tasks,
        client,
        progress=None if progress is None else (lambda done: progress(done * prestresses.size)),
    )
    if outcome.interrupted:
        raise KeyboardInterrupt
    return outcome.results


def critical_curves(sweeps: Sequence[PrestressSweep]) -> dict[float, list[tuple[float, float]]]:
    """Per length [m]: (rate [m/s], critical prestress [Pa]) where the sweep has one."""
    curves: dict[float, list[tuple[float, float]]] = {}
    for sweep in sweeps:
        curves.setdefault(sweep.length, [])
        if sweep.status == CRITICAL:
            curves[sweep.length].append((sweep.rate, sweep.critical_prestress))
    return {length: sorted(points) for length, points in curves.items()}


def eigenvalue_loci(
    params: SailParameters, length: float, rate: float, prestresses: Sequence[float]
) -> list[np.ndarray]:
    """All eigenvalues [1/s] of Eq. 3 at each prestress [Pa] (one array each)."""
    return [frozen_eigenvalues(params, length, rate, s) for s in prestresses]
