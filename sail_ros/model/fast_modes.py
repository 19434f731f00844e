"""Following the modes a moving step does not resolve (model.md §11).

While the booms move, the high boom modes (up to thousands of rad/s) change
slowly: their frequencies and shapes follow the lengths, over seconds. The
rational step lags them in phase (its phase saturates where `omega h` is
large), which root moments, weighing boom mode `i` by `beta_i^2`, show. Here
the free vibration of those modes is carried from one step's end to the
next by the adiabatic approximation instead:

* at each end, the frozen modes of `(K, M)`: `K V = M V diag(omega^2)`,
  `V^T M V = I`, Rayleigh damping `d_j = alpha + beta omega_j^2` per mode;
* a mode's free vibration is its coordinate less its static response to
  the step's load, `e = V^T M q - V^T Q / omega^2`, and `v = V^T M qd`, held
  as the complex amplitude `a = e - i (v + d e / 2) / omega_d`
  (`omega_d^2 = omega^2 - d^2 / 4`), which turns at `omega_d` and decays at
  `d / 2`;
* over a step, `a_j` turns by the mean of its end frequencies times `h`
  (the phase integral `int omega_d dt` by the trapezoidal rule), scales by
  `sqrt(omega_0 / omega_1)` (the adiabatic invariant `E / omega`), and passes
  from the modes at the start to those at the end through their overlap
  `S = V_1^T M_1 V_0`, weighted by `sinc((phi_j - phi_k) / 2)`: modes that stay
  in phase over the step pass amplitude between them as the shapes turn,
  modes that do not exchange none (the averaged coupling of two modes
  turning at different rates).

Errors neglected (the error model of model.md §11): the gyroscopic and
`N` coupling of these modes to the others (relative size
`|Ld| beta / (L omega)`, below 1e-2 for them), the part of their static
response driven by the motion, and the trapezoidal rule's phase error
`h^2 / 12 |d omega / dt|` accumulated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

# A mode is followed when it lies above this multiple of the system's resolved
# frequency (the first cantilever frequency of the shortest bare boom, above the
# first boom modes and, at deployment lengths, the membrane modes it couples to) and
# when the rational step would turn it by more than FOLLOW_PHASE rad per step.
FOLLOW_ABOVE_RESOLVED = 3.0
FOLLOW_PHASE = 2.0
# ... and when the shapes change slowly beside the mode's own period: omega above
# FOLLOW_ADIABATIC times the fastest relative rate |Ld| / L of the booms (the neglected
# coupling goes as |Ld| / (L omega)). Measured: the second boom modes, followed at
# 2e-3 of this ratio (the reference deployment, 0.67 m/s at 12 m), keep the root
# moments within 0.1 % of peak; at 3e-3 (1.3 m/s at 11 m) they left 0.22 %.
FOLLOW_ADIABATIC = 500.0


@dataclass(frozen=True)
class FrozenModes:
    """Modes of `(K, M)` at fixed lengths: frequencies `omega` [rad/s] ascending, `V`
    (n, k) with `V^T M V = I`, modal damping `d` [1/s], `M` and `MV = M V`; all n of
    them (`updates` 0), or the k highest carried on from a neighbouring length
    (`updated`, `updates` since the last full set)."""

    omega: np.ndarray
    V: np.ndarray
    d: np.ndarray
    M: np.ndarray
    MV: np.ndarray
    updates: int = 0

    @classmethod
    def of(cls, M: np.ndarray, K: np.ndarray, damping: tuple[float, float]) -> FrozenModes:
        """All modes, from the mass and elastic stiffness at the lengths and the Rayleigh
        coefficients `(alpha, beta)`: `V^T C_d V = diag(alpha + beta omega^2)`."""
        lam, V = scipy.linalg.eigh(K, M, check_finite=False)
        return cls._made(lam, V, M, damping, 0)

    def updated(self, count: int, M, K, damping, factor) -> FrozenModes:
        """The `count` highest modes at new lengths (`M`, `K`) from these: one step of
        subspace iteration on `M^-1 K` from this set's `count` highest, then Rayleigh-Ritz
        (a third of a full eigenproblem's cost at n = 160). The subspace's error shrinks
        each time by `(omega_below / omega_lowest)^2`, the ratio of the highest mode left
        out to the lowest kept (below 1/9 where modes are followed, `FOLLOW_ABOVE_RESOLVED`);
        `factor` is the Cholesky factor of `M` (`scipy.linalg.cho_factor`)."""
        Y = scipy.linalg.cho_solve(factor, K @ self.V[:, -count:], check_finite=False)
        lam, Z = scipy.linalg.eigh(Y.T @ K @ Y, Y.T @ M @ Y, check_finite=False)
        return self._made(lam, Y @ Z, M, damping, self.updates + 1)

    @classmethod
    def _made(cls, lam, V, M, damping, updates) -> FrozenModes:
        lam = np.maximum(lam, 0.0)
        alpha, beta = damping
        return cls(np.sqrt(lam), V, alpha + beta * lam, M, M @ V, updates)


def followed(modes: FrozenModes, h: float, resolved: float, relative_rate: float) -> int:
    """How many of the highest modes a step of `h` [s] follows: those above
    `FOLLOW_ABOVE_RESOLVED` times `resolved` [rad/s], `FOLLOW_PHASE / h` and
    `FOLLOW_ADIABATIC` times `relative_rate` (the largest `|Ld| / L` [1/s])."""
    floor = max(
        FOLLOW_ABOVE_RESOLVED * resolved, FOLLOW_PHASE / h, FOLLOW_ADIABATIC * relative_rate
    )
    return int(np.count_nonzero(modes.omega > floor))


@dataclass(frozen=True)
class FreeVibration:
    """The free vibration of the `count` highest modes at one time: complex amplitudes
    `a` [m] (modal coordinates), and the modes' static response `s` to the load."""

    modes: FrozenModes
    count: int
    a: np.ndarray
    s: np.ndarray

    @classmethod
    def of(cls, modes: FrozenModes, count: int, q, qd, forcing) -> FreeVibration:
        """From `q`, `qd` and the generalised force on these modes from the load and the
        other modes (`forcing_of`)."""
        V = modes.V[:, -count:]
        w, d = modes.omega[-count:], modes.d[-count:]
        s = (V.T @ forcing) / w**2
        MV = modes.MV[:, -count:]
        e = MV.T @ q - s
        v = MV.T @ qd
        wd, decay = _damped(w, d)
        return cls(modes, count, e - 1j * (v + 0.5 * decay * e) / wd, s)

    def coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        """The modal coordinates `(e + s, v)` of these modes."""
        w, d = self.modes.omega[-self.count :], self.modes.d[-self.count :]
        wd, decay = _damped(w, d)
        e = self.a.real
        return e + self.s, -wd * self.a.imag - 0.5 * decay * e

    def turned(self, seconds) -> FreeVibration:
        """This vibration `seconds` [s] later (earlier if negative), in the same modes; an
        array of m times gives m vibrations, `a` of shape (m, count)."""
        w, d = self.modes.omega[-self.count :], self.modes.d[-self.count :]
        wd, decay = _damped(w, d)
        rate = 1j * wd - 0.5 * decay
        return FreeVibration(
            self.modes, self.count, self.a * np.exp(np.multiply.outer(seconds, rate)), self.s
        )

    def replace_in(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`q`, `qd` ((n,) or (m, n), one row per vibration) with these modes' part replaced
        by this vibration (and the static part)."""
        V = self.modes.V[:, -self.count :]
        e, v = self.coordinates()
        MV = self.modes.MV[:, -self.count :]
        return q + (e - q @ MV) @ V.T, qd + (v - qd @ MV) @ V.T


def _damped(w: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Damped frequency `omega_d` [rad/s] and decay rate `d` [1/s]. Past a damping ratio
    of 0.87 `omega_d` stays at `omega / 2`: such a mode is then taken to decay at
    `d / 2 >= 0.87 omega`, faster than its slow root `omega (zeta - sqrt(zeta^2 - 1))`
    beyond critical damping, but it has lost `e^-1.7` of its free vibration per
    followed step either way (`omega h > 2`)."""
    return np.sqrt(np.maximum(w**2 - 0.25 * d**2, 0.25 * w**2)), d


def slow_part(modes: FrozenModes, count: int, x: np.ndarray) -> np.ndarray:
    """`x` (coordinates or velocities) less its part in the `count` highest modes."""
    return x - modes.V[:, -count:] @ (modes.MV[:, -count:].T @ x)


def forcing_of(modes: FrozenModes, count: int, force, matrices, q, qd) -> np.ndarray:
    """The generalised force [N] that the load `force` (or None) and the other modes exert
    on the `count` highest ones, from `matrices = (C, K_eq - K)` of Eq. 2 (the motion's
    damping and gyroscopic terms, `Gd - N`) acting on the slow part of `q`, `qd`: the
    followed modes' forced response is its static response (the forcing is slow
    beside them, error `(omega_slow / omega)^2`)."""
    C, K_extra = matrices
    r = -(C @ slow_part(modes, count, qd)) - K_extra @ slow_part(modes, count, q)
    return r if force is None else r + force


def follow(start: FreeVibration, end_modes: FrozenModes, h: float, end_forcing) -> FreeVibration:
    """The free vibration `start` carried over a step of `h` [s] to the modes at its end,
    whose static response is taken under `end_forcing` (see the module docstring)."""
    m = start.count
    w0, w1 = start.modes.omega[-m:], end_modes.omega[-m:]
    wd0, d0 = _damped(w0, start.modes.d[-m:])
    wd1, d1 = _damped(w1, end_modes.d[-m:])
    phase = 0.5 * (wd0 + wd1) * h
    V0, V1 = start.modes.V[:, -m:], end_modes.V[:, -m:]
    overlap = end_modes.MV[:, -m:].T @ V0
    transfer = overlap * np.sinc((phase[:, None] - phase[None, :]) / (2.0 * np.pi))
    half = np.exp(0.5j * phase - 0.25 * (d0 + d1) * h * 0.5)
    a = np.sqrt(w0 / w1) * half * (transfer @ (half * start.a)) if m else start.a
    return FreeVibration(end_modes, m, a, (V1.T @ end_forcing) / w1**2)
