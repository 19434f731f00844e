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
* over a step, `a_j` turns by the phase integral `int omega_d dt` by Simpson's
  rule (the frequency at the middle from the middle's matrices,
  `middle_frequencies`; the trapezoidal rule's error, `h^3 omega'' / 12`, is
  0.15 rad per 0.3 s step for a mode of 1800 rad/s), decays at half of
  Eq. 2's damping on the mode, `(V^T C V)_jj` (the motion's part too: the mass
  the booms take on), scales by `sqrt(omega_0 / omega_1)` (the adiabatic
  invariant `E / omega`), and passes
  from the modes at the start to those at the end through their overlap
  `S = V_1^T M_1 V_0`, weighted by `sinc((phi_j - phi_k) / 2)`: modes that stay
  in phase over the step pass amplitude between them as the shapes turn,
  modes that do not exchange none (the averaged coupling of two modes
  turning at different rates).

Errors neglected (the error model of model.md §11): the gyroscopic and
`N` coupling of these modes to the others (relative size
`|Ld| beta / (L omega)`, below 1e-2 for them), the part of their static
response driven by the motion, and Simpson's phase error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sail_ros.model.assembly import CANONICAL_DAMPING, GYROSCOPIC, MASS, STIFFNESS_CANONICAL
from sail_ros.model.lapack import potrs as _potrs
from sail_ros.model.lapack import sygvd as _sygvd

# A mode is followed when it lies above this multiple of the system's resolved
# frequency (the first cantilever frequency of the shortest bare boom, above the
# first boom modes and, at deployment lengths, the membrane modes it couples to) and
# when a rational step of the halves would turn it by more than FOLLOW_PHASE rad: the
# whole step of the error estimate then turns the modes it carries by at most 2 rad,
# where the (4, 4) Pade lags at most 1.8e-5 rad, so the halves' difference from it
# measures the midpoint rule's error, not the approximant's lag (at 4 rad the lag is
# 6.3e-3 rad, which the estimate would read as an error of 2e-3 of the mode's amplitude,
# refuse steps for it and, the steps shortening, carry still more modes).
FOLLOW_ABOVE_RESOLVED = 3.0
FOLLOW_PHASE = 1.0
# ... and when the shapes change slowly beside the mode's own period: omega above
# FOLLOW_ADIABATIC times the fastest relative rate |Ld| / L of the booms (the neglected
# coupling goes as |Ld| / (L omega)). Measured: the second boom modes, followed at
# 2e-3 of this ratio (the reference deployment, 0.67 m/s at 12 m), keep the root
# moments within 0.1 % of peak; at 3e-3 (1.3 m/s at 11 m) they left 0.22 %.
FOLLOW_ADIABATIC = 500.0


# The matrices one moving step needs at a rational step's middle, in this order
# (`rational.moving_step`; `middle_frequencies`)
STEP_MATRICES = (MASS, CANONICAL_DAMPING, STIFFNESS_CANONICAL, GYROSCOPIC)


@dataclass(frozen=True)
class FrozenModes:
    """Modes of `(K, M)` at fixed lengths: frequencies `omega` [rad/s] ascending, `V`
    (n, k) with `V^T M V = I`, modal damping `d` [1/s], `MV = M V` and the damped
    frequencies `omega_d` [rad/s] (`_damped`); all n of them (`updates` 0), or the k
    highest carried on from a neighbouring length (`updated`, `updates` since the last
    full set). `below` [rad/s]: the highest mode a carried-on set leaves out, as the set
    it came from saw it (0 for all modes)."""

    omega: np.ndarray
    V: np.ndarray
    d: np.ndarray
    MV: np.ndarray
    omega_d: np.ndarray
    updates: int = 0
    below: float = 0.0

    @classmethod
    def of(cls, M: np.ndarray, K: np.ndarray, damping: tuple[float, float]) -> FrozenModes:
        """All modes, from the mass and elastic stiffness at the lengths and the Rayleigh
        coefficients `(alpha, beta)`: `V^T C_d V = diag(alpha + beta omega^2)`."""
        lam, V = _eigh(K, M)
        return cls._made(lam, V, M, damping, 0, 0.0)

    def updated(self, count: int, M, K, damping, factor) -> FrozenModes:
        """The `count` highest modes at new lengths (`M`, `K`) from these: one step of
        subspace iteration on `M^-1 K` from this set's `count` highest, then Rayleigh-Ritz
        (a third of a full eigenproblem's cost at n = 160). The subspace's error shrinks
        each time by `(omega_below / omega_lowest)^2`, the ratio of the highest mode left
        out to the lowest kept (below 1/9 where modes are followed, `FOLLOW_ABOVE_RESOLVED`);
        `factor` is the Cholesky factor of `M` (`scipy.linalg.cho_factor`)."""
        c, lower = factor
        Y, _ = _potrs(c, K @ self.V[:, -count:], lower=lower)
        MY = M @ Y
        lam, Z = _eigh(Y.T @ K @ Y, Y.T @ MY)
        below = float(self.omega[-count - 1]) if self.omega.size > count else self.below
        return self._made(lam, Y @ Z, M, damping, self.updates + 1, below, MY @ Z)

    @classmethod
    def _made(cls, lam, V, M, damping, updates, below, MV=None) -> FrozenModes:
        lam = np.maximum(lam, 0.0)
        alpha, beta = damping
        omega, d = np.sqrt(lam), alpha + beta * lam
        MV = M @ V if MV is None else MV
        return cls(omega, V, d, MV, _damped(omega, d), updates, below)


def _eigh(K: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`scipy.linalg.eigh(K, M)`: eigenvalues ascending and `M`-orthonormal vectors."""
    lam, V, info = _sygvd(K, M)
    if info != 0:
        raise np.linalg.LinAlgError(f"the frozen modes' eigenproblem failed (sygvd info {info})")
    return lam, V


def follow_floor(h: float, resolved: float, relative_rate: float) -> float:
    """The frequency [rad/s] above which a step of `h` [s] follows a mode: `FOLLOW_ABOVE_
    RESOLVED` times `resolved` [rad/s], `FOLLOW_PHASE / h` and `FOLLOW_ADIABATIC` times
    `relative_rate` (the largest `|Ld| / L` [1/s]), whichever is highest."""
    return max(FOLLOW_ABOVE_RESOLVED * resolved, FOLLOW_PHASE / h, FOLLOW_ADIABATIC * relative_rate)


def followed(modes: FrozenModes, floor: float) -> int:
    """How many of the highest `modes` lie above `floor` [rad/s] (`follow_floor`)."""
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
        w, d, wd = modes.omega[-count:], modes.d[-count:], modes.omega_d[-count:]
        s = (V.T @ forcing) / w**2
        MV = modes.MV[:, -count:]
        e = MV.T @ q - s
        v = MV.T @ qd
        return cls(modes, count, e - 1j * (v + 0.5 * d * e) / wd, s)

    def coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        """The modal coordinates `(e + s, v)` of these modes."""
        count = self.count
        wd, decay = self.modes.omega_d[-count:], self.modes.d[-count:]
        e = self.a.real
        return e + self.s, -wd * self.a.imag - 0.5 * decay * e

    def replace_in(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`q`, `qd` ((n,) or (m, n)) with these modes' part replaced by this vibration
        (and the static part)."""
        V = self.modes.V[:, -self.count :]
        e, v = self.coordinates()
        MV = self.modes.MV[:, -self.count :]
        return q + (e - q @ MV) @ V.T, qd + (v - qd @ MV) @ V.T


def turning(a: np.ndarray, omega_d: np.ndarray, decay: np.ndarray | None):
    """`(on_e, on_v)` (..., 2 k each) of free vibrations `a` (..., k) of modes with damped
    frequencies `omega_d` [rad/s] and decay rates `decay` [1/s] (None: undamped): with
    `a(t) = a e^((i omega_d - d / 2) t)`, each mode's `e = Re a(t)` and `v = -omega_d Im
    a(t) - d e / 2` at `t` are the sums of its cosine and its sine column of
    `oscillation(t) * on_e` (of `* on_v`)."""
    b = omega_d * a if decay is None else (omega_d + 0.5j * decay) * a
    return np.concatenate([a.real, -a.imag], axis=-1), -np.concatenate([b.imag, b.real], axis=-1)


# the largest exponent `oscillation` takes (e^700 < the largest double, 1.8e308)
TURN_BACK_EXPONENT = 700.0


def turned(t, omega_d: np.ndarray, chirp: np.ndarray) -> np.ndarray:
    """The phase [rad] `omega_d t + chirp_0 t^2 + chirp_1 t^3` a mode of damped frequency
    `omega_d` [rad/s] and `chirp` (`chirps`) turns by in `t` [s] from its reference (its
    frequency changing over the step), broadcast over `t`, `omega_d` and `chirp[..., i]`."""
    return t * omega_d + t * t * (chirp[..., 0] + t * chirp[..., 1])


def oscillation(seconds, omega_d: np.ndarray, decay: np.ndarray, chirp) -> np.ndarray:
    """(m, 2k): `e^(-d t / 2) cos(phi(t))` of k modes, then `e^(-d t / 2) sin(phi(t))`,
    at `t` = each of `seconds` (m,) [s], for damped frequencies `omega_d` [rad/s], decay
    rates `decay` [1/s] (each (k,), or (m, k): each time its own modes; None for
    undamped modes) and `chirp` ((k, 2) or (m, k, 2)): `phi` the phase `turned`."""
    t = np.asarray(seconds, dtype=float)[:, None]
    phase = turned(t, omega_d, chirp)
    k = phase.shape[1]
    turns = np.empty((phase.shape[0], 2 * k))
    np.cos(phase, out=turns[:, :k])
    np.sin(phase, out=turns[:, k:])
    if decay is not None:
        # turned back (t < 0) a strongly damped mode grows: past e^TURN_BACK_EXPONENT its
        # amplitude at the end has underflowed to 0, which must stay 0, not 0 * inf
        turns *= np.tile(np.exp(np.minimum(-0.5 * t * decay, TURN_BACK_EXPONENT)), 2)
    return turns


def frequency_ratio(seconds, omega_d: np.ndarray, chirp) -> np.ndarray:
    """(m, k): each mode's frequency at `t` = each of `seconds` (m,) [s] over `omega_d`
    [rad/s] (`oscillation`'s phase's rate over its constant part; 1 for a null mode),
    what turns the velocities `turning` gives at `omega_d` into the phase's own."""
    t = np.asarray(seconds, dtype=float)[:, None]
    rate = omega_d + t * (2.0 * chirp[..., 0] + 3.0 * t * chirp[..., 1])
    return np.divide(rate, omega_d, out=np.ones_like(rate), where=omega_d > 0)


def chirps(omega_start, omega_middle, omega_end, h: float) -> tuple[np.ndarray, np.ndarray]:
    """`(from_start, from_end)` (each (k, 2)): the `chirp` (`oscillation`) of a step of
    `h` [s] whose modes' damped frequencies are `omega_start`, `omega_middle` and
    `omega_end` [rad/s] at its start, middle and end, the frequency the parabola through
    them: its phase from the start (`t >= 0`), and from the end (`t <= 0`). The two meet
    at the middle, where the phase is Simpson's rule over the step (`follow`)."""
    slope = (4.0 * omega_middle - 3.0 * omega_start - omega_end) / h
    curvature = 2.0 * (omega_start + omega_end - 2.0 * omega_middle) / h**2
    third = curvature / 3.0
    from_start = np.stack([0.5 * slope, third], axis=-1)
    from_end = np.stack([0.5 * slope + curvature * h, third], axis=-1)
    return from_start, from_end


def _damped(w: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Damped frequency `omega_d` [rad/s] of modes of frequency `w` [rad/s] and damping `d`
    [1/s] (decaying at `d / 2`). Past a damping ratio of 0.87 `omega_d` stays at
    `omega / 2`: such a mode is then taken to decay at `d / 2 >= 0.87 omega`, faster
    than its slow root `omega (zeta - sqrt(zeta^2 - 1))` beyond critical damping, but
    it has lost `e^-1.7` of its free vibration per followed step either way
    (`omega h > 2`)."""
    return np.sqrt(np.maximum(w**2 - 0.25 * d**2, 0.25 * w**2))


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


def middle_frequencies(start: FrozenModes, end: FrozenModes, count: int, middle, damping):
    """The damped frequencies [rad/s] of the `count` highest modes at a step's middle:
    each mode's Rayleigh quotient under the middle's mass and stiffness (`middle`, the
    step's matrices, `STEP_MATRICES`), the mean of its shapes' at the two ends (the
    quotient is stationary: a shape off by `e` gives `omega^2` off by `e^2`)."""
    mass, stiffness = STEP_MATRICES.index(MASS), STEP_MATRICES.index(STIFFNESS_CANONICAL)
    forms = []
    for modes in (start, end):
        V = modes.V[:, -count:]
        forms.append(middle.forms(stiffness, V) / middle.forms(mass, V))
    lam = np.maximum(0.5 * (forms[0] + forms[1]), 0.0)
    alpha, beta = damping
    return _damped(np.sqrt(lam), alpha + beta * lam)


def modal_damping(modes: FrozenModes, count: int, C: np.ndarray) -> np.ndarray:
    """`diag(V^T C V)` [1/s] of the `count` highest `modes` under Eq. 2's damping `C`
    (the Rayleigh damping and the motion's: the mass the deploying booms take on and
    shed damps or drives each mode at half this rate; its skew part adds nothing)."""
    V = modes.V[:, -count:]
    return np.einsum("jm,jm->m", V, C @ V)


def follow(
    start: FreeVibration, end_modes: FrozenModes, h: float, end_forcing, middle_omega_d, damping
) -> FreeVibration:
    """The free vibration `start` carried over a step of `h` [s] to the modes at its end,
    whose static response is taken under `end_forcing`: its phase turned by Simpson's
    rule through the damped frequencies `middle_omega_d` [rad/s] at the step's middle
    (`middle_frequencies`), its amplitude decayed by the trapezoidal rule through each
    mode's damping at the two ends, `damping = (start's, end's)` [1/s]
    (`modal_damping`); see the module docstring."""
    m = start.count
    w0, w1 = start.modes.omega[-m:], end_modes.omega[-m:]
    wd0, wd1 = start.modes.omega_d[-m:], end_modes.omega_d[-m:]
    phase = (wd0 + 4.0 * middle_omega_d + wd1) * (h / 6.0)
    V0, V1 = start.modes.V[:, -m:], end_modes.V[:, -m:]
    overlap = end_modes.MV[:, -m:].T @ V0
    transfer = overlap * np.sinc((phase[:, None] - phase[None, :]) / (2.0 * np.pi))
    # half the phase and half the decay on each side of the transfer
    half = np.exp(0.5j * phase - 0.125 * (damping[0] + damping[1]) * h)
    a = np.sqrt(w0 / w1) * half * (transfer @ (half * start.a)) if m else start.a
    return FreeVibration(end_modes, m, a, (V1.T @ end_forcing) / w1**2)
