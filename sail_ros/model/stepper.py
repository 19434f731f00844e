"""Time integration of Eq. 2 under prescribed boom motion.

The integrator works in canonical (Hamiltonian) variables. With the
kinetic energy `T = 1/2 qd^T M qd + qd^T G q + 1/2 q^T N q` the momentum is
`p = M qd + G q`, and Eq. 2 becomes (model.md §4)

    qd = M^-1 (p - G q)
    pd = G^T M^-1 (p - G q) - (K - N) q,        x = [q; p],  xd = B(t) x,

in which `Md` and `Gd` no longer appear. Damping `C_d` and the generalised
forces `Q = B_u u` of the inputs (model.md §12) add `- C_d qd + Q` to `pd`:
`xd = B x + f`, `f = [0; Q]`. Each step applies the exponential midpoint rule
`x1 = exp(h B) x0 + h phi_1(h B) f`, `B` and `f` taken at `t + h/2`
(second-order Magnus; `phi_1(z) = (e^z - 1) / z`; inputs held over the step):

* While the booms move, `exp` is replaced by its (4, 4) diagonal Padé
  approximant, split into partial fractions; each conjugate pole pair costs
  one complex `n x n` solve with the matrix
  `M + tau (G - G^T + C_d) + tau^2 (K - N)`; the same partial fractions give
  `phi_1` for free (the force only changes the right-hand side). Undamped, `B`
  is Hamiltonian and the step symplectic; high modes keep unit amplification
  (stable, energy-neutral) and only lag in phase; damped, none grows (the
  approximant is A-stable).
* While the booms stand still, the step is the exact propagator built from
  the eigenvectors of `(K, M)` and cached, so energy is conserved to
  round-off and a step is one matrix-vector product. Rayleigh damping is
  classical (`V^T C_d V` diagonal), so each mode is a damped oscillator with
  its own exact 2 x 2 propagator; a load held over the step moves the
  equilibrium to `K^-1 Q`, about which the same propagator acts; a rigid-body
  mode (`lam = 0` exactly, a free hub) has no equilibrium and takes the load as
  `eta + h etad + h^2 f / 2`.

Accuracy is set by the step: `h <= max_step` (default 0.05 s) and `h * omega_r <= 2` where
`omega_r` (`resolved_frequency`) is by default the system's own bound at the
current lengths (for the sail: the first cantilever frequency of the shortest
bare boom, an upper bound of the dominant boom-bending frequency); modes up
to `omega_r` are integrated with a phase error below ~2e-5 rad per step.

The stepper sees the structure only through `LinearSystem`: the matrices at
a boom motion (assembled, or as component blocks: `blocks.py`, which large
systems solve by eliminating each quadrant's membrane) and that frequency bound.
"""

from __future__ import annotations

import math
from math import factorial
from typing import Protocol

import numpy as np
import scipy.linalg

from sail_ros.model.assembly import (
    CANONICAL_DAMPING,
    GYROSCOPIC,
    MASS,
    STIFFNESS,
    STIFFNESS_CANONICAL,
    STRUCTURAL_DAMPING,
)
from sail_ros.model.blocks import BlockMatrices, DenseMatrices
from sail_ros.model.layout import per_boom


class LinearSystem(Protocol):
    """What the stepper needs of a structure (`SailModel` is one)."""

    n: int  # generalised coordinates

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """The matrices named by `outputs` (`assembly` names), stacked (k, n, n), at
        boom lengths [m], rates [m/s] and accelerations [m/s^2]: arrays of 4 values
        the stepper has already checked (a step must not check them again)."""

    def resolved_frequency(self, lengths) -> float:
        """The highest angular frequency [rad/s] a step must resolve at `lengths`."""

    def assemble_blocks(self, outputs, lengths, rates, accelerations) -> BlockMatrices:
        """The same matrices as `assemble`, as component blocks (`blocks.py`); the
        moving step's products and solves use them."""

    def assemble_inputs(self, lengths) -> np.ndarray:
        """`B_u` (n, number of inputs): generalised forces per unit input at `lengths`
        (4 checked values)."""

    def modes_of(self, M: np.ndarray, K: np.ndarray):
        """`(lam, V)`: eigenvalues `omega^2` and `M`-orthonormal modes of `(K, M)` at rest
        (`scipy.linalg.eigh(K, M)` for a structure held in place); rigid-body modes, if
        any, with `lam` exactly 0 (a free hub, model.md §13.6)."""


class IntegrationError(RuntimeError):
    """The state became non-finite; `reset` starts again."""


def _diagonal_pade_partial_fractions(order: int):
    """Constant term and (pole, residue) pairs of the (order, order) Padé
    approximant of exp(z), one pole of each conjugate pair (order even)."""
    c = [
        factorial(2 * order - j)
        * factorial(order)
        / (factorial(2 * order) * factorial(j) * factorial(order - j))
        for j in range(order + 1)
    ]
    numerator = np.polynomial.Polynomial(c)
    denominator = np.polynomial.Polynomial([cj * (-1) ** j for j, cj in enumerate(c)])
    poles = denominator.roots()
    residues = numerator(poles) / denominator.deriv()(poles)
    upper = poles.imag > 0
    return float((-1) ** order), poles[upper], residues[upper]


PADE_ORDER = 4
_PADE_CONSTANT, _PADE_POLES, _PADE_RESIDUES = _diagonal_pade_partial_fractions(PADE_ORDER)
_PADE_WEIGHTS = -_PADE_RESIDUES / _PADE_POLES  # r_k (hB - z_k)^-1 = -(r_k / z_k) (I - tau_k B)^-1


def _extension_conditions() -> np.ndarray:
    """The Taylor conditions on `(c, Re w_k, Im w_k)` of the continuous extension: the
    coefficient of `z^m` in `c + sum_k 2 Re[w_k / (1 - z / z_k)]` is
    `c [m = 0] + 2 Re sum_k w_k z_k^-m`, one row per m = 0 .. 2 k."""
    rows = []
    for m in range(2 * _PADE_POLES.size + 1):
        g = 2.0 * _PADE_POLES ** (-m)  # Re(w g) = Re w Re g - Im w Im g
        rows.append([float(m == 0), *np.column_stack([g.real, -g.imag]).ravel()])
    return np.array(rows)


_EXTENSION_FACTOR = scipy.linalg.lu_factor(_extension_conditions())
_WEIGHTS_CACHE: dict = {}  # (fractions, derivative) -> weights
_TAYLOR_DIVISORS = np.array([factorial(m) for m in range(2 * _PADE_POLES.size + 1)], float)


def extension_weights(fractions, derivative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """`(c, w)` ((m,), (m, k)) of `R_f(z) = c + sum_k 2 Re[w_k / (1 - z / z_k)]`, the
    continuous extension of the step's Padé approximant to each fraction `f` of the
    step: same poles `z_k`, Taylor series equal to `exp(f z)` to order 4 (error
    ~(omega h)^5 for a mode), `R_1` the approximant itself. On the imaginary axis
    `|R_f| <= 1` for the fractions j / k, k <= 5 (an undamped mode is not amplified),
    at most 1.026 for k <= 20 (near f = 0 or 1, at omega h ~ 5.5); the extension only
    samples, nothing integrated grows. With `derivative`, the weights of `dR_f / df`
    (the same conditions on the derivative of the Taylor series)."""
    fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
    key = (fractions.tobytes(), derivative)
    if key in _WEIGHTS_CACHE:  # a sampler asks for the same fractions at every step
        return _WEIGHTS_CACHE[key]
    powers = np.arange(_TAYLOR_DIVISORS.size)[:, None]
    if derivative:  # d/df f^m / m! = m f^(m-1) / m!
        taylor = powers * fractions[None, :] ** np.maximum(powers - 1, 0)
    else:
        taylor = fractions[None, :] ** powers
    x = scipy.linalg.lu_solve(_EXTENSION_FACTOR, taylor / _TAYLOR_DIVISORS[:, None])
    if len(_WEIGHTS_CACHE) >= 64:
        _WEIGHTS_CACHE.clear()
    weights = _WEIGHTS_CACHE[key] = (x[0], (x[1::2] + 1j * x[2::2]).T)
    return weights


# matrices one moving step needs, in this order
_STEP_MATRICES = (MASS, CANONICAL_DAMPING, STIFFNESS_CANONICAL, GYROSCOPIC)
# rad: omega_r * h. The (4,4) Padé lags a mode by ~4e-8 (omega h)^9 rad per step: 2e-5
# at 2 rad. On the reference deployment the midpoint rule's error from the matrices'
# change over a step dominates: 49 steps at 2 rad left the tips 0.071 % of peak off,
# 63 steps at 1.5 rad 0.089 % (the bar is 0.2 %).
PHASE_PER_STEP = 2.0
# Root moments weigh boom mode i by beta_i^2, so they need the higher boom modes a
# load step excites: 0.05 s keeps them within 0.01 % of peak on the loaded, damped
# reference deployment (test_loads_damping), where 0.2 s left them at 1 % (the tips
# at 0.13 %).
DEFAULT_MAX_STEP = 0.05
# From this many coordinates the moving step solves by blocks (`blocks.py`): measured
# on one core, 1.5x faster at n = 160 (n_B = n_M = 20), slower at n = 80 where LAPACK
# on the whole matrix costs less than numpy's per-call overhead on 10 x 10 blocks.
BLOCK_SOLVE_MIN_COORDINATES = 120


class SailStepper:
    """Holds the sail's state and advances it under a boom-motion profile.

    Args:
        system: the structure (`LinearSystem`, e.g. a `SailModel`).
        profile: callable `t -> (lengths, rates, accelerations)` (4 values
            each, SI); see `profiles`. May be replaced between steps.
        q0: initial coordinates (default 0).
        qd0: initial velocities [m/s] (default 0).
        t0: initial time [s].
        max_step: largest internal step [s].
        resolved_frequency: highest angular frequency [rad/s] to integrate
            accurately; None follows `system.resolved_frequency` at the
            current lengths.
        inputs: callable `t -> u` (the system's inputs, e.g. `loads.INPUT_NAMES`),
            or None for none. May be replaced between steps.
        on_step: callable `on_step(stepper)` after every step, or None; it may ask
            `interpolant` for the outputs inside the step just taken (e.g. `peaks`).
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
        on_step=None,
    ):
        if not (math.isfinite(max_step) and max_step > 0):
            raise ValueError(f"max_step must be finite and > 0, got {max_step!r}")
        if resolved_frequency is not None and not (
            math.isfinite(resolved_frequency) and resolved_frequency > 0
        ):
            raise ValueError(
                f"resolved_frequency must be finite and > 0, got {resolved_frequency!r}"
            )
        self.system = system
        self.max_step = float(max_step)
        self.resolved_frequency = resolved_frequency
        self._static_cache: dict = {}
        self._mass_factor_cache = (b"", None)
        self._profile = profile
        self._motion_cache = (math.nan, None)  # (t, motion at t) of the current profile
        self.inputs = inputs
        self.on_step = on_step
        self._last_static = None  # the last step's data when it was a step at rest
        self.steps_taken = 0
        self.reset(q0, qd0, t0)

    # state ------------------------------------------------------------------
    def reset(self, q0=None, qd0=None, t0: float = 0.0, profile=None):
        """Start again from `q0`, `qd0` (default rest) at time `t0` [s], under
        `profile` if given (else the current one)."""
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
        if profile is not None:
            self._set_profile(profile)
        self._t = float(t0)
        self._q = q
        M, G = self._mass_gyro(self._t)
        self._p = M @ qd + G @ q
        self._qd_cache = (self._t, qd.copy())

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
        if self._qd_cache[0] != self._t:
            lengths, rates, _ = self._motion(self._t)
            # M is assembled from finite lengths and the state is checked after every
            # step: scipy's finiteness scans would only repeat that
            if rates.any():
                M, G = self._mass_gyro(self._t)
                qd = scipy.linalg.cho_solve(
                    scipy.linalg.cho_factor(M, check_finite=False),
                    self._p - G @ self._q,
                    check_finite=False,
                )
            else:  # G = 0 at rest, and M depends on the lengths alone: keep its factor
                qd = scipy.linalg.cho_solve(self._mass_factor(lengths), self._p, check_finite=False)
            self._qd_cache = (self._t, qd)
        return self._qd_cache[1].copy()

    def _mass_factor(self, lengths):
        """The Cholesky factor of `M` at `lengths`, kept for the last lengths asked."""
        key = lengths.tobytes()
        if self._mass_factor_cache[0] != key:
            zero = np.zeros(4)
            (M,) = self.system.assemble((MASS,), lengths, zero, zero)
            self._mass_factor_cache = (key, scipy.linalg.cho_factor(M))
        return self._mass_factor_cache[1]

    def boom_motion(self, t: float | None = None):
        """Boom lengths [m], rates [m/s], accelerations [m/s^2] now (or at `t` [s])."""
        return self._motion(self._t if t is None else t)

    @property
    def profile(self):
        return self._profile

    @profile.setter
    def profile(self, profile):
        """Replace the boom motion from now on, keeping `q` and `qd` continuous."""
        qd = self.qd
        self._set_profile(profile)
        M, G = self._mass_gyro(self._t)
        self._p = M @ qd + G @ self._q

    def _set_profile(self, profile):
        self._profile = profile
        self._motion_cache = (math.nan, None)

    def energy(self) -> float:
        """Mechanical energy `1/2 qd^T M qd + 1/2 q^T K q` [J] now."""
        lengths, _, _ = self._motion(self._t)
        zero = np.zeros(4)
        M, K = self.system.assemble((MASS, STIFFNESS), lengths, zero, zero)
        qd = self.qd
        return 0.5 * float(qd @ M @ qd) + 0.5 * float(self._q @ K @ self._q)

    # integration --------------------------------------------------------------
    def advance(self, t_end: float) -> None:
        """Integrate up to time `t_end` [s] (no-op if `t_end <= t`)."""
        if not math.isfinite(t_end):
            raise ValueError(f"t_end must be finite, got {t_end!r}")
        # Equal steps to t_end rather than full steps plus a short remainder:
        # an abrupt change of step size costs the midpoint rule accuracy.
        while t_end - self._t > 1e-12 * max(1.0, abs(t_end)):
            remaining = t_end - self._t
            count = max(1, math.ceil(remaining / self.step_limit() - 1e-9))
            self.step(remaining / count)

    def step(self, h: float) -> None:
        """One exponential-midpoint step of length `h` [s]; then `on_step(self)`."""
        t_mid = self._t + 0.5 * h
        lengths, rates, accelerations = self._motion(t_mid)
        is_static = getattr(self._profile, "is_static", None)
        force = self._force(t_mid, lengths)
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported below
            if is_static is not None and is_static(self._t, self._t + h):
                q, p = self._static_step(lengths, h, force)
            else:
                q, p = self._moving_step(lengths, rates, accelerations, h, force)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(p))):
            raise IntegrationError(f"state became non-finite at t = {self._t + h:.6g} s")
        self._q, self._p = q, p
        self._t += h
        self.steps_taken += 1
        if self.on_step is not None:
            self.on_step(self)

    def between(self, fractions, qd0, qd1) -> tuple[np.ndarray, np.ndarray]:
        """`(q, qd)` (each (m, n)) inside the last step, a moving one, at `fractions`
        (m values in (0, 1)) of it, given the velocities `qd0`, `qd1` [m/s] at its ends.

        The step's own resolvent solutions, recombined with the weights of the
        continuous extension `R_f` (`extension_weights`): `q(f) = c q0 + sum_k 2 Re[w_k
        y_q,k]`, and, with the midpoint matrices, `M^-1 (p - G q)(f) = c qd*_0 + sum_k 2
        Re[w_k u_k]`. `qd*_0` (the start's velocity under the midpoint matrices) is
        taken as `qd0` and a term linear in `f` makes both ends exact; the difference
        is of the midpoint rule's own order (the change of `M`, `G` over the step)."""
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        q0, y_q, u, v = self._extension
        c, w = extension_weights(fractions)
        q = c[:, None] * q0 + 2.0 * (w @ y_q).real
        qd = c[:, None] * qd0 + 2.0 * (w @ u).real + fractions[:, None] * (qd1 - qd0 - 2.0 * v)
        return q, qd

    def interpolant_frequency(self) -> float:
        """The highest angular frequency [rad/s] in the last step's interpolant: a step
        at rest holds its highest mode, `sqrt(max lambda)`; a moving step's extension is a
        polynomial of degree 2 k = 8 in the fraction, which turns at most that often over
        the step, counted as `2 pi k / h`."""
        if self._last_static is not None:
            lam = self._last_static[3][2]
            return float(np.sqrt(max(float(lam[-1]), 0.0)))
        return 2.0 * math.pi * _PADE_POLES.size / self._extension_step

    def interpolant(self, fractions, rows) -> tuple[np.ndarray, np.ndarray]:
        """`rows q(t)` and its time derivative [per s] (each (m, r)) at `fractions` (m
        values in [0, 1]) of the last step, for output rows `rows` (r, n): the step's own
        curve through its ends, whose derivative is consistent with it (what an
        interpolation between samples needs, e.g. `peaks`).

        A step at rest: each mode's exact propagator over `f h`, about the equilibrium of
        its load. A moving step: its continuous extension `R_f` (`between`) and the
        derivative of that polynomial in `f`; at `f = 1` it is the step's end."""
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        rows = np.asarray(rows, dtype=float)
        if self._last_static is not None:
            q0, p0, h, (_, V, lam, d, VtM), shift, rigid_force = self._last_static
            tau = fractions[:, None] * h
            c, s, sd, cd = _modal_propagator(lam, d, tau)
            eta0 = VtM @ (q0 - shift)  # q = shift + V eta, p = VtM^T etad, qd = V etad
            etad0 = V.T @ p0
            modes = rows @ V
            eta = c * eta0 + s * etad0 + 0.5 * tau**2 * rigid_force
            etad = sd * eta0 + cd * etad0 + tau * rigid_force
            return rows @ shift + eta @ modes.T, etad @ modes.T
        q0, y_q, _, _ = self._extension
        h = self._extension_step
        start, outputs = rows @ q0, y_q @ rows.T  # (r,), (k, r)
        c, w = extension_weights(fractions)
        dc, dw = extension_weights(fractions, derivative=True)
        values = c[:, None] * start + 2.0 * (w @ outputs).real
        return values, (dc[:, None] * start + 2.0 * (dw @ outputs).real) / h

    def step_limit(self) -> float:
        """The longest step [s] allowed now: `max_step`, and 2 rad of `resolved_frequency`
        (default: `system.resolved_frequency` at the current lengths)."""
        omega = self.resolved_frequency
        if omega is None:
            lengths, _, _ = self._motion(self._t)
            omega = self.system.resolved_frequency(lengths)
        return min(self.max_step, PHASE_PER_STEP / omega)

    def _motion(self, t):
        """The profile at `t`, checked; cached, since a step asks for the same time
        several times (step size, matrices, velocities, publishing)."""
        cached_t, motion = self._motion_cache
        if cached_t == t:
            return motion
        values = self._profile(t)
        try:  # three arrays of 4 (the usual case) checked as one
            stacked = np.array(values, dtype=float)
        except (TypeError, ValueError):  # ragged: a scalar among them, or wrong sizes
            stacked = None
        if (
            stacked is not None
            and stacked.shape == (3, 4)
            and np.isfinite(stacked).all()
            and stacked[0].min() > 0
        ):
            motion = (stacked[0], stacked[1], stacked[2])
        else:  # scalars stand for all booms; the messages name the field, time and value
            lengths, rates, accelerations = values
            motion = (
                per_boom(lengths, f"lengths at t = {t:.6g} s", positive=True),
                per_boom(rates, f"rates at t = {t:.6g} s"),
                per_boom(accelerations, f"accelerations at t = {t:.6g} s"),
            )
        self._motion_cache = (t, motion)
        return motion

    def _force(self, t, lengths) -> np.ndarray | None:
        """Generalised forces `B_u u(t)` [N] at `lengths`; None when there are none."""
        if self.inputs is None:
            return None
        u = np.asarray(self.inputs(t), dtype=float)
        if u.ndim != 1 or not np.all(np.isfinite(u)):
            raise ValueError(f"inputs at t = {t:.6g} s must be finite values, got {u!r}")
        if not u.any():
            return None
        return self.system.assemble_inputs(lengths) @ u

    def _mass_gyro(self, t):
        lengths, rates, accelerations = self._motion(t)
        M, G = self.system.assemble((MASS, GYROSCOPIC), lengths, rates, accelerations)
        return M, G

    def _moving_step(self, lengths, rates, accelerations, h, force):
        """x1 = R(h B) x0 + h phi_R(h B) f with R the (4,4) Padé approximant of exp and
        phi_R(z) = (R(z) - 1) / z, by partial fractions:
        R(hB) x = c0 x + sum_k 2 Re[r_k (hB - z_k)^-1 x],
        h phi_R(hB) f = sum_k 2 Re[(h r_k / z_k) (hB - z_k)^-1 f], and
        (hB - z)^-1 x = -(1/z) (I - tau B)^-1 x with tau = h / z; so
        x1 = c0 x0 + sum_k 2 Re[w_k (I - tau_k B)^-1 (x0 + tau_k f)], w_k = -r_k / z_k.

        (I - tau B) y = x  <=>  [M + tau (G - G^T + C_d) + tau^2 (K - N)] u
        = x_p - (G + tau (K - N)) x_q, y_q = x_q + tau u, y_p = M u + G y_q; the real
        matrices act on the sums over k: q1 = c0 q0 + 2 s, p1 = c0 p0 + 2 (M v + G s),
        v = Re sum_k w_k u_k, s = Re sum_k w_k y_q,k."""
        motion = (lengths, rates, accelerations)
        if self.system.n >= BLOCK_SOLVE_MIN_COORDINATES:
            mats = self.system.assemble_blocks(_STEP_MATRICES, *motion)
        else:
            mats = DenseMatrices(self.system.assemble(_STEP_MATRICES, *motion))
        q0, p0 = self._q, self._p
        taus = h / _PADE_POLES
        _, _, Kq, Gq = mats.matvec(q0)
        if force is not None:  # x_p = p0 + tau f
            Kq = Kq - force
        u = mats.solve_shifted(taus, (p0 - Gq)[None, :] - taus[:, None] * Kq[None, :])
        weighted = _PADE_WEIGHTS[:, None] * u
        v = weighted.sum(axis=0).real
        s = _PADE_WEIGHTS.real.sum() * q0 + (taus[:, None] * weighted).sum(axis=0).real
        self._extension = (q0, q0 + taus[:, None] * u, u, v)  # y_q,k, u_k: for `between`
        self._extension_step = h
        self._last_static = None
        zero = np.zeros_like(q0)
        Mv, _, _, Gs = mats.matvec(np.stack([v, zero, zero, s]))  # one call beats two
        return _PADE_CONSTANT * q0 + 2.0 * s, _PADE_CONSTANT * p0 + 2.0 * (Mv + Gs)

    def _static_step(self, lengths, h, force):
        key = (lengths.tobytes(), h)
        cached = self._static_cache.get(key)
        if cached is None:
            if len(self._static_cache) >= 16:
                self._static_cache.clear()
            cached = self._exact_propagator(lengths, h)
            self._static_cache[key] = cached
        propagator, V, lam, _, VtM = cached
        x = np.concatenate([self._q, self._p])
        n = self.system.n
        shift = np.zeros(n)  # the elastic modes' equilibrium under the load
        rigid_force = np.zeros(lam.size)  # modal force on the rigid-body modes (lam = 0)
        if force is None:
            x = propagator @ x
        else:  # elastic modes about their equilibrium q_s = K^-1 Q (p_s = 0: nothing moves
            # there); rigid ones (model.md §13.10) accelerate uniformly: eta += h^2 f / 2,
            # etad += h f
            rigid = lam == 0.0
            modal = V.T @ force
            elastic = ~rigid
            shift = V[:, elastic] @ (modal[elastic] / lam[elastic])
            rigid_force[rigid] = modal[rigid]
            x[:n] -= shift
            x = propagator @ x
            x[:n] += shift + V @ (0.5 * h * h * rigid_force)
            x[n:] += VtM.T @ (h * rigid_force)
        self._last_static = (self._q, self._p, h, cached, shift, rigid_force)  # `interpolant`
        return x[:n], x[n:]

    def _exact_propagator(self, lengths, h):
        """exp(h B) for fixed lengths (G = N = 0) from the modes of (K, M): the
        propagator, the mode matrix `V`, eigenvalues `lam` (omega^2; 0 for a free hub's
        rigid-body modes), modal damping `d` and `V^T M`.

        With V^T M V = I and K V = M V diag(lam): eta = V^T M q, etad = V^T p, and each
        mode moves by its own 2 x 2 propagator (`_modal_propagator`); Rayleigh damping
        is classical (`V^T C_d V = diag(d)`).
        """
        zero = np.zeros(4)
        M, K, C_d = self.system.assemble((MASS, STIFFNESS, STRUCTURAL_DAMPING), lengths, zero, zero)
        lam, V = self.system.modes_of(M, K)
        d = np.einsum("ij,ik,kj->j", V, C_d, V)  # diag(V^T C_d V): classical damping
        c, s, sd, cd = _modal_propagator(lam, d, h)
        VtM = V.T @ M  # eta = VtM q; q = V eta; p = VtM^T etad
        n = self.system.n
        P = np.empty((2 * n, 2 * n))
        P[:n, :n] = (V * c) @ VtM
        P[:n, n:] = (V * s) @ V.T
        P[n:, :n] = (VtM.T * sd) @ VtM
        P[n:, n:] = (VtM.T * cd) @ V.T
        return P, V, lam, d, VtM


def _modal_propagator(lam, d, tau):
    """`exp(tau [[0, 1], [-lam, -d]])` of every mode as its four entries `(c, s, sd, cd)`:
    `eta(tau) = c eta + s etad`, `etad(tau) = sd eta + cd etad`, for modal stiffness `lam`
    (omega^2; < 0 for a buckled mode) and damping `d` (n,), at times `tau` [s] (a scalar
    or an array broadcasting against (n,)).

    Undamped: `c = cos(omega tau)`, `s = sin(omega tau) / omega` (cosh and sinh for
    lam < 0; `s -> tau` at lam = 0). Damped: from the roots `r = -d/2 +- sqrt(d^2/4 -
    lam)` of each mode, `exp(tau A) = (r1 e^(r2 tau) - r2 e^(r1 tau)) / (r1 - r2) I +
    (e^(r1 tau) - e^(r2 tau)) / (r1 - r2) A`, in complex arithmetic; a critically
    damped mode (equal roots) takes its limit `e^(r tau) ((1 - r tau) I + tau A)`."""
    lam = np.asarray(lam, dtype=float)
    d = np.asarray(d, dtype=float)
    tau = np.asarray(tau, dtype=float)
    if not np.any(d):
        root = np.sqrt(np.abs(lam))
        c = np.where(lam >= 0, np.cos(root * tau), np.cosh(root * tau))
        s = np.where(
            lam >= 0,
            tau * np.sinc(root * tau / np.pi),
            np.sinh(root * tau) / np.where(root > 0, root, 1.0),
        )
        return c, s, -lam * s, c
    half = np.sqrt((0.25 * d * d - lam).astype(complex))
    r2 = -0.5 * d - half
    # r1 r2 = lam: the slow root of an overdamped mode without cancellation
    r1 = np.where(r2 != 0, lam / np.where(r2 != 0, r2, 1.0), -0.5 * d + half)
    e1, e2 = np.exp(r1 * tau), np.exp(r2 * tau)
    gap = r1 - r2
    equal = np.abs(gap) <= 1e-12 * np.maximum(np.abs(r1), 1.0)
    safe = np.where(equal, 1.0, gap)
    # exp(tau A) = a I + b A with A = [[0, 1], [-lam, -d]]
    a = np.where(equal, e1 * (1.0 - r1 * tau), (r1 * e2 - r2 * e1) / safe)
    b = np.where(equal, tau * e1, (e1 - e2) / safe)
    return a.real, b.real, (-lam * b).real, (a - d * b).real
