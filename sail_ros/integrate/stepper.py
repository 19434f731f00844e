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
  approximant (`rational`: one complex `n x n` solve per conjugate pole pair;
  symplectic undamped, A-stable damped; a continuous extension inside the step).
* While the booms stand still, the step is exact (`rest`: each mode's own
  propagator from the modes of `(K, M)`, cached; energy kept to round-off).

The step is chosen to meet a tolerance on the outputs users read (tips, root
moments, their rates; `rtol` of each one's peak so far, `atol` floors): a step
of `h` is two midpoint steps of `h / 2`, and one of `h` from the same start
estimates their error (a third of the difference; the rule is of order 2). The
modes a midpoint step does not resolve are followed in their frozen modes
instead (`fast_modes`: phase `int omega dt`, adiabatic amplitude, overlaps of
the shapes). `max_step` and `WHOLE_STEP_PHASE` rad of the resolved frequency
(`omega_r`, by default the system's own bound at the current lengths: for the
sail the first cantilever frequency of the shortest bare boom) per step bound
the step from above; `rtol=None` takes fixed steps under `max_step` and
`PHASE_PER_STEP` rad per step alone. The sum of the accepted steps' estimates
is the achieved error estimate (`error_estimate`).

The stepper sees the structure only through `LinearSystem`: the matrices at
a boom motion (assembled, or as component blocks: `blocks.py`, which large
systems solve by eliminating each quadrant's membrane) and that frequency bound.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import numpy as np
import scipy.linalg

from sail_ros.integrate.fast_modes import (
    FreeVibration,
    FrozenModes,
    follow,
    follow_floor,
    followed,
    forcing_of,
    slow_part,
)
from sail_ros.integrate.rational import (
    PADE_POLES,
    STEP_MATRICES,
    Extension,
    extended_momentum,
    extension_weights,
    moving_step,
)
from sail_ros.integrate.rest import Rest, exact_propagator, rest_states, rest_step
from sail_ros.model.assembly import (
    DAMPING,
    GYROSCOPIC,
    MASS,
    STIFFNESS,
    STIFFNESS_EQ,
    STRUCTURAL_DAMPING,
)
from sail_ros.model.blocks import BlockMatrices, DenseMatrices
from sail_ros.model.layout import per_boom
from sail_ros.model.profiles import SWITCH_RESOLUTION


class LinearSystem(Protocol):
    """What the stepper needs of a structure (`SailModel` is one)."""

    n: int  # generalised coordinates

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """The matrices named by `outputs` (`assembly` names), stacked (k, n, n), at
        boom lengths [m], rates [m/s] and accelerations [m/s^2]: arrays of 4 values
        the stepper has already checked (a step must not check them again); for m
        motions at once, arrays (m, 4) giving (m, k, n, n)."""

    def resolved_frequency(self, lengths) -> float:
        """The highest angular frequency [rad/s] a step must resolve at `lengths`."""

    def assemble_blocks(self, outputs, lengths, rates, accelerations) -> BlockMatrices:
        """The same matrices as `assemble`, as component blocks (`blocks.py`); the
        moving step's products and solves use them."""

    def assemble_inputs(self, lengths) -> np.ndarray:
        """`B_u` (n, number of inputs): generalised forces per unit input at `lengths`
        (4 checked values)."""

    def output_rows(self, lengths) -> np.ndarray:
        """(8, n): the tip deflections [m] (4 rows) and root moments [N m] (4 rows) per
        unit coordinate at `lengths` (4 checked values); applied to `qd`, their rates."""

    def modes_of(self, M: np.ndarray, K: np.ndarray):
        """`(lam, V)`: eigenvalues `omega^2` and `M`-orthonormal modes of `(K, M)` at rest
        (`scipy.linalg.eigh(K, M)` for a structure held in place); rigid-body modes, if
        any, with `lam` exactly 0 (a free hub, model.md §13.6)."""


# Cholesky factorisation and solve without scipy's checks (samples inside a step: `M` is
# assembled from checked lengths and is positive definite)
potrf, potrs = scipy.linalg.lapack.get_lapack_funcs(("potrf", "potrs"), dtype=float)


def _cho_factor(M: np.ndarray):
    """`scipy.linalg.cho_factor(M, check_finite=False)` (the same LAPACK call, the same
    factor) without its wrapper's cost, for `M` assembled from checked lengths."""
    factor, info = potrf(M, lower=False, clean=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"the mass matrix is not positive definite (potrf info {info})")
    return factor, False


def _cho_solve(factor, b: np.ndarray) -> np.ndarray:
    """`scipy.linalg.cho_solve(factor, b, check_finite=False)`: the same LAPACK call."""
    c, lower = factor
    x, info = potrs(c, b, lower=lower)
    if info != 0:
        raise ValueError(f"illegal value in potrs argument {-info}")
    return x


class IntegrationError(RuntimeError):
    """The state became non-finite; `reset` starts again."""


def time_slack(t: float) -> float:
    """Within this [s] of each other, two times near `t` [s] are one: the round-off of
    a time reached by summing steps (plain floats: it is asked every step)."""
    return 1e-12 * max(1.0, abs(t))


# A stretch of time whose motion starts or ends within this fraction of it from its ends
# counts as at rest (the booms move for a microsecond at zero rate): whether a motion that
# starts at a step's end makes that step exact then does not hang on round-off in the
# motion's times (a command logged to the nanosecond replays the same steps).
STATIC_MARGIN = 1e-4
# The moving system's frequencies lie within this factor of its frozen modes' (the motion's
# gyroscopic and `N` terms shift them by `|Ld| beta / (L omega)`, below 1e-2: `fast_modes`)
CARRIED_MARGIN = 1.1
# times whose boom motion the stepper keeps (`_motion`)
MOTION_CACHE = 32
# rad: omega_r * h of one rational step. The (4,4) Padé lags a mode by ~4e-8 (omega h)^9
# rad per step: 2e-5 at 2 rad. A bound beneath the tolerance's choice (the modes above
# are followed, `fast_modes`); `sail_ros.nodes.sim_params` sizes sub-steps with it.
PHASE_PER_STEP = 2.0
# rad: omega_r * h of the error-controlled stepper's step of h, the estimate's whole
# rational step (its halves turn 1.5 rad each). There the Padé lags 5.9e-4 rad, which
# the estimate (a third of the halves' difference from the whole) reads as 2e-4 of the
# resolved mode's amplitude. At 4 rad (two rational steps of PHASE_PER_STEP) it lagged
# 6.3e-3, read as 2.1e-3: above the default tolerance wherever that mode rang, so steps
# at the bound were refused (the live sampler on a slow deployment at (20, 20): 59 of
# 121; 2 of the 54 attempts of a Monte Carlo sample) and a drawn undamped deployment left
# 0.24 % of peak on its root moments.
WHOLE_STEP_PHASE = 3.0
# The longest step [s], an upper bound for the tolerance's choice. The error-controlled
# step is within WHOLE_STEP_PHASE of the resolved frequency, which bounds it to 0.35 s
# at 10 m; this bounds it where the booms are longer (at 15 m the frequency rule allows
# 0.78 s). On the benchmark deployment (with the whole step's bound at 4 rad) 0.5 s took
# 55 steps where 0.2 s took 77, tips and root moments within 0.15 % of peak.
DEFAULT_MAX_STEP = 0.5
# Local error allowed per step on each output, relative to its peak so far (tips,
# tip rates, root moments, their rates): chosen by measurement so that whole runs
# stay within 0.2 % of peak on tips and root moments (model.md §11).
DEFAULT_RTOL = 1e-3
# Absolute floors per output [m, m/s, N m, N m/s]: the tolerance of a sail at rest.
DEFAULT_ATOL = {"tips": 1e-6, "tip_rates": 1e-5, "root_moments": 1e-4, "root_moment_rates": 1e-3}
OUTPUT_KINDS = tuple(DEFAULT_ATOL)
# A step's end takes the followed modes from its start's by one subspace iteration; every
# this many steps (and where the start has too few) all modes are found afresh.
MODES_REFRESH = 8
# Step size control: the next step is h (safety / err)^(1/3) (the midpoint rule's
# local error goes as h^3), grown at most GROWTH-fold, shrunk at most to SHRINK.
SAFETY, GROWTH, SHRINK = 0.8, 1.5, 0.2
# From this many coordinates the moving step solves by blocks (`blocks.py`): measured
# on one core, 1.5x faster at n = 160 (n_B = n_M = 20), slower at n = 80 where LAPACK
# on the whole matrix costs less than numpy's per-call overhead on 10 x 10 blocks.
BLOCK_SOLVE_MIN_COORDINATES = 120


def _rayleigh(system) -> tuple[float, float]:
    """`(alpha, beta)` of the system's Rayleigh damping, read off `C_d` against `M` and `K`
    at a length of 10 m at rest (`C_d = alpha M + beta K` at every length)."""
    lengths, zero = np.full(4, 10.0), np.zeros(4)
    M, K, C_d = system.assemble((MASS, STIFFNESS, STRUCTURAL_DAMPING), lengths, zero, zero)
    if not C_d.any():
        return 0.0, 0.0
    basis = np.stack([M.ravel(), K.ravel()], axis=1)
    (alpha, beta), *_ = np.linalg.lstsq(basis, C_d.ravel(), rcond=None)
    return float(alpha), float(beta)


class Trial(NamedTuple):
    """One attempted moving step: the state at its end, its error against the tolerance
    (<= 1 meets it), the estimated error per output (`OUTPUT_KINDS`, their units), and
    what `between` needs: the rational steps' extensions and the followed modes."""

    h: float
    q: np.ndarray
    p: np.ndarray
    qd: np.ndarray | None
    error: float
    estimate: np.ndarray
    extensions: tuple
    vibration: tuple  # (FreeVibration at the start, at the end) or ()
    middle: object = None  # the whole step's matrices (`STEP_MATRICES`), at its middle
    outputs: np.ndarray | None = None  # the end's largest outputs (`_outputs`)
    # [rad/s] the highest frozen mode the rational steps carry at the start (not followed)
    carried_frequency: float = math.inf


class SailStepper:
    """Holds the sail's state and advances it under a boom-motion profile.

    Args:
        system: the structure (`LinearSystem`, e.g. a `SailModel`).
        profile: callable `t -> (lengths, rates, accelerations)` (4 values
            each, SI); see `profiles`. May be replaced between steps.
        q0: initial coordinates (default 0).
        qd0: initial velocities [m/s] (default 0).
        t0: initial time [s].
        max_step: largest step [s] (an upper bound; the tolerance chooses below it).
        resolved_frequency: highest angular frequency [rad/s] a step must resolve
            (`PHASE_PER_STEP` rad per fixed step, `WHOLE_STEP_PHASE` per error-controlled
            one); None follows
            `system.resolved_frequency` at the current lengths.
        inputs: callable `t -> u` (the system's inputs, e.g. `loads.INPUT_NAMES`),
            or None for none. May be replaced between steps. If it has
            `switch_times` [s], `advance` ends steps there.
        rtol: local error allowed per moving step on each output (tips, tip rates,
            root moments, their rates), relative to its peak so far; None takes
            fixed steps (`max_step` and the frequency rule) with no estimate.
        atol: absolute floors per output kind (`OUTPUT_KINDS`: m, m/s, N m, N m/s),
            a mapping overriding `DEFAULT_ATOL`.
        on_step: callable `on_step(stepper)` after every accepted step, or None; it may
            ask `interpolant` for the outputs inside the step just taken, or keep its
            curve (`last_curve`) to sample later (`peaks`).
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
        if not (math.isfinite(max_step) and max_step > 0):
            raise ValueError(f"max_step must be finite and > 0, got {max_step!r}")
        if resolved_frequency is not None and not (
            math.isfinite(resolved_frequency) and resolved_frequency > 0
        ):
            raise ValueError(
                f"resolved_frequency must be finite and > 0, got {resolved_frequency!r}"
            )
        if rtol is not None and not (math.isfinite(rtol) and 0 < rtol < 1):
            raise ValueError(f"rtol must be None or in (0, 1), got {rtol!r}")
        floors = dict(DEFAULT_ATOL)
        for name, value in dict(atol or {}).items():
            if name not in floors:
                raise ValueError(f"atol: unknown output {name!r}; outputs are {', '.join(floors)}")
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"atol[{name!r}] must be finite and > 0, got {value!r}")
            floors[name] = float(value)
        self.system = system
        self.max_step = float(max_step)
        self.resolved_frequency = resolved_frequency
        self.rtol = None if rtol is None else float(rtol)
        self.atol = floors
        self._floors = np.array([floors[k] for k in OUTPUT_KINDS])
        self._static_cache: dict = {}
        self._mass_factor_cache = (b"", None)
        self._modes_cache: dict = {}
        self._rows_cache = (b"", None)
        # Rayleigh alpha [1/s], beta [s] from the system's damping: C_d = alpha M + beta K
        self._rayleigh = _rayleigh(system)
        self._profile = profile
        self._motion_cache: dict = {}  # t -> motion at t, of the current profile and piece
        self._assembly_cache: dict = {}
        self._factor_at = (math.nan, None)
        self.inputs = inputs
        self.on_step = on_step
        self.steps_taken = 0
        self.steps_rejected = 0
        self.reset(q0, qd0, t0)

    # state ------------------------------------------------------------------
    def reset(self, q0=None, qd0=None, t0: float = 0.0, profile=None):
        """Start again from `q0`, `qd0` (default rest) at time `t0` [s], under
        `profile` if given (else the current one). The error estimate starts again."""
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
        self._entered = self._t  # since when the profile's current piece applies
        self._motion_cache = {}  # the piece at a switch depends on `_entered`
        self._q = q
        M, G = self._mass_gyro(self._t)
        self._p = M @ qd + G @ q
        self._qd_cache = (self._t, qd.copy())
        self._last = None  # (t0, q0, qd0, Trial or Rest) of the last step, for `states_at`
        self._half_velocity = (None, None)  # (Trial, velocity at its middle), for `between`
        self._extension_of = (None, None)  # (Trial, its `Extension`), for `between`
        self._proposal = math.inf  # the error control's next step [s]
        self._estimate = np.zeros(len(OUTPUT_KINDS))
        self._peaks = np.zeros(len(OUTPUT_KINDS))
        self._observe(self._t, q, qd)

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
            self._qd_cache = (self._t, self._velocity(self._t, self._q, self._p))
        return self._qd_cache[1].copy()

    def _velocity(self, t, q, p, middle=None) -> np.ndarray:
        """`M^-1 (p - G q)` at `t`; `middle`: a step's matrices (`STEP_MATRICES`) at `t`,
        if at hand."""
        lengths, rates, accelerations = self._motion(t)
        # M is assembled from finite lengths and the state is checked after every
        # step: scipy's finiteness scans would only repeat that
        if rates.any():
            if isinstance(middle, DenseMatrices):  # a moving step's middle
                M, _, _, G = middle.matrices
                factor, _ = potrf(M, lower=True, clean=False)
                return potrs(factor, p - G @ q, lower=True)[0]
            if self._factor_at[0] == t:  # a step's end: its matrices are at hand
                _, G = self._mass_gyro(t)
                factor = self._factor_at[1]
            else:  # inside a step (a sample): M and G alone
                M, G = self.system.assemble((MASS, GYROSCOPIC), lengths, rates, accelerations)
                factor = _cho_factor(M)
            return _cho_solve(factor, p - G @ q)
        # G = 0 at rest, and M depends on the lengths alone: keep its factor
        return _cho_solve(self._mass_factor(lengths), p)

    @property
    def error_estimate(self) -> dict:
        """The estimated error accumulated since the start (or `reset`), per output kind
        (`OUTPUT_KINDS`) in its units [m, m/s, N m, N m/s]: the sum of every moving
        step's local estimate (an undamped sail does not forget an error), 0 for exact
        steps at rest and for fixed steps (`rtol` None), which estimate nothing."""
        return dict(zip(OUTPUT_KINDS, self._estimate.tolist(), strict=True))

    @property
    def relative_error_estimate(self) -> dict:
        """`error_estimate` over each output's peak so far [-] (nan while it is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(self._peaks > 0, self._estimate / self._peaks, math.nan)
        return dict(zip(OUTPUT_KINDS, ratio.tolist(), strict=True))

    @property
    def peaks(self) -> dict:
        """The largest magnitude of each output kind met so far, in its units."""
        return dict(zip(OUTPUT_KINDS, self._peaks.tolist(), strict=True))

    def _outputs(self, t, q, qd) -> np.ndarray:
        """Largest magnitude per output kind (4,) of the state `q`, `qd` at `t`."""
        return _largest(self._rows(self._motion(t)[0]), q, qd)

    def _observe(self, t, q, qd) -> None:
        if self.rtol is not None:
            self._peaks = np.maximum(self._peaks, self._outputs(t, q, qd))

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
        self._entered = self._t
        M, G = self._mass_gyro(self._t)
        self._p = M @ qd + G @ self._q

    def _set_profile(self, profile):
        self._profile = profile
        self._motion_cache = {}
        self._assembly_cache = {}
        self._factor_at = (math.nan, None)
        self._last = None

    def energy(self) -> float:
        """Mechanical energy `1/2 qd^T M qd + 1/2 q^T K q` [J] now."""
        lengths, _, _ = self._motion(self._t)
        zero = np.zeros(4)
        M, K = self.system.assemble((MASS, STIFFNESS), lengths, zero, zero)
        qd = self.qd
        return 0.5 * float(qd @ M @ qd) + 0.5 * float(self._q @ K @ self._q)

    # integration --------------------------------------------------------------
    def advance(self, t_end: float) -> None:
        """Integrate up to time `t_end` [s] (no-op if `t_end <= t`), with steps chosen by
        the tolerance (rejected and retried shorter where it is not met), ending at
        `t_end` and at the inputs' `switch_times`."""
        if not math.isfinite(t_end):
            raise ValueError(f"t_end must be finite, got {t_end!r}")
        while t_end - self._t > time_slack(t_end):
            self.advance_step(t_end)

    def advance_step(self, t_end: float) -> None:
        """One accepted step towards `t_end` [s] (not beyond it, nor beyond the next of
        the inputs' or the profile's `switch_times`). Where the output times fall plays
        no part: a batch run samples inside the steps (`states_at`), so its steps, and its
        results, are the same whichever times it outputs."""
        target = min(t_end, self.next_switch())
        smallest = 1e-6 * max(1.0, abs(target))
        while True:
            remaining = target - self._t
            limit = self.step_limit()
            # Equal steps to the target rather than full steps plus a short remainder:
            # an abrupt change of step size costs the midpoint rule accuracy.
            h = remaining / max(1, math.ceil(remaining / limit - 1e-9))
            if self._is_static(h) or self.rtol is None or h <= smallest:
                self.step(h)
                return
            if self.try_step(h):
                return

    def next_switch(self) -> float:
        """The next time [s] after now where the inputs or the profile switch (their
        `switch_times`), which no step passes; inf if none."""
        times = (
            *getattr(self.inputs, "switch_times", ()),
            *getattr(self._profile, "switch_times", ()),
        )
        later = [t for t in times if t > self._t + SWITCH_RESOLUTION]
        return min(later, default=math.inf)

    def _is_static(self, h) -> bool:
        """Whether the booms stand still over the next `h` [s], but for `STATIC_MARGIN` of
        it at either end (`sampling`: a motion that starts or ends there, at zero rate,
        is stepped exactly, whatever round-off puts its start on one side)."""
        is_static = getattr(self._profile, "is_static", None)
        margin = STATIC_MARGIN * h
        return is_static is not None and is_static(self._t + margin, self._t + h - margin)

    def step(self, h: float) -> None:
        """One step of length `h` [s], taken whatever its error: exact at rest; while the
        booms move, the exponential midpoint rule, and with `rtol` two of them and one
        over the whole step for the estimate, the high modes followed."""
        if self._is_static(h):
            t_mid = self._t + 0.5 * h
            lengths = self._motion(t_mid)[0]
            force = self._force(t_mid, lengths)
            with np.errstate(over="ignore", invalid="ignore"):
                q, p, rest = self._static_step(lengths, h, force)
            self._commit(h, q, p, rest)
        elif self.rtol is None:
            with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported on commit
                q, p, extension = self._rational_step(self._t, self._q, self._p, h)
            self._commit(h, q, p, Trial(h, q, p, None, 0.0, np.zeros(4), (extension,), ()))
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
        self._proposal = h * max(SHRINK, SAFETY * trial.error ** (-1.0 / 3.0))
        return False

    def _commit(self, h, q, p, trial) -> None:
        """Take the step's end `(q, p)` as the state (`trial`: the moving step's `Trial`
        or the `Rest` step's data), then `on_step`."""
        if not (np.isfinite(q).all() and np.isfinite(p).all()):
            raise IntegrationError(f"state became non-finite at t = {self._t + h:.6g} s")
        self._last = (self._t, self._q, self.qd, trial)
        self._q, self._p = q, p
        self._t += h
        self.steps_taken += 1
        moving = isinstance(trial, Trial)
        if moving and trial.qd is not None:
            self._qd_cache = (self._t, trial.qd)
        if moving and self.rtol is not None:
            self._estimate += trial.estimate
            self._proposal = h * min(GROWTH, SAFETY * max(trial.error, 1e-12) ** (-1.0 / 3.0))
            self._peaks = np.maximum(self._peaks, trial.outputs)
        self._enter_switch()
        if self.on_step is not None:
            self.on_step(self)

    def _enter_switch(self) -> None:
        """At a switch of a piecewise profile (`profiles.SwitchedProfile`), the next piece
        from now on, as a live simulator takes a new motion (`profile`): `q` and `qd`
        kept, the momenta recomputed with the new piece's matrices."""
        times = getattr(self._profile, "switch_times", ())
        if not any(self._entered < s and abs(self._t - s) <= SWITCH_RESOLUTION for s in times):
            return
        qd = self.qd  # at the end of the piece left
        self._motion_cache = {}
        self._assembly_cache = {}
        self._factor_at = (math.nan, None)
        self._entered = self._t
        M, G = self._mass_gyro(self._t)
        self._p = M @ qd + G @ self._q
        self._qd_cache = (self._t, qd)

    def _attempt(self, h: float) -> Trial:
        """Two rational steps of `h / 2` and one of `h`, the high modes followed over the
        step in both results; the error of the two halves is estimated as a third of
        their difference from the whole on the outputs (the rule is of order 2)."""
        t0, q0, p0 = self._t, self._q, self._p
        half, t1 = t0 + 0.5 * h, t0 + h
        # the three rational steps' middles, as `_rational_step` finds them
        mats = self._step_matrices((t0 + 0.5 * (0.5 * h), half + 0.5 * (0.5 * h), half))
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported on commit
            qh, ph, first = self._rational_step(t0, q0, p0, 0.5 * h, mats[0])
            q2, p2, second = self._rational_step(half, qh, ph, 0.5 * h, mats[1])
            q1, p1, _ = self._rational_step(t0, q0, p0, h, mats[2])
            lengths0, lengths1 = self._motion(t0)[0], self._motion(t1)[0]
            C1, K_extra1, _, M1, G1 = self._assembled(t1)
            factor, _ = self._mass_factor_at(t1)
            # (n, 2) in LAPACK's column order: no copy on the way in
            qd2, qd1 = potrs(factor, np.array([p2 - G1 @ q2, p1 - G1 @ q1]).T)[0].T
        vibration = ()
        modes0 = self._modes(t0)
        floor = follow_floor(0.5 * h, self._resolved(lengths0), self._relative_rate(t0, h))
        count = followed(modes0, floor)
        if count:
            modes1 = self._modes(t1, modes0, count)
            u = None if self.inputs is None else self._input(t0 + 0.5 * h)
            qd0 = self.qd
            start = FreeVibration.of(
                modes0,
                count,
                q0,
                qd0,
                forcing_of(modes0, count, self._held(u, lengths0), self._forcing(t0), q0, qd0),
            )
            # the end's slow part is the rational steps' (the halves' and the whole's agree
            # there to the error estimated)
            forcing = forcing_of(modes1, count, self._held(u, lengths1), (C1, K_extra1), q2, qd2)
            end = follow(start, modes1, h, forcing)
            # the whole step's followed modes are the halves': they leave the estimate
            dq, dqd = slow_part(modes1, count, q2 - q1), slow_part(modes1, count, qd2 - qd1)
            q2, qd2 = end.replace_in(q2, qd2)
            p2 = M1 @ qd2 + G1 @ q2
            vibration = (start, end)
        else:
            dq, dqd = q2 - q1, qd2 - qd1
        rows = self._rows(lengths1)
        estimate = _largest(rows, dq, dqd) / 3.0
        outputs = _largest(rows, q2, qd2)
        with np.errstate(over="ignore", invalid="ignore"):
            scale = self._floors + self.rtol * np.maximum(self._peaks, outputs)
            error = float((estimate / scale).max())
        if not math.isfinite(error):
            error = math.inf
        # the highest mode not followed: the next below those followed, or, when a set
        # carried on (the highest modes only) is followed whole, below its lowest
        if count < modes0.omega.size:
            carried = float(modes0.omega[-count - 1])
        else:
            carried = float(modes0.omega[0]) if modes0.omega.size < self.system.n else 0.0
        return Trial(
            h, q2, p2, qd2, error, estimate, (first, second), vibration, mats[2], outputs, carried
        )

    def _forcing(self, t):
        """`(C, K_eq - K)` of Eq. 2 at `t`: how the motion couples the modes."""
        C, K_extra, _, _, _ = self._assembled(t)
        return C, K_extra

    def _assembled(self, t):
        """`C, K_eq - K, K, M, G` at `t`, kept for the last two times asked (a step's end
        is the next one's start)."""
        found = self._assembly_cache.get(t)
        if found is None:
            if len(self._assembly_cache) >= 2:
                self._assembly_cache.pop(next(iter(self._assembly_cache)))
            C, K_eq, K, M, G = self.system.assemble(
                (DAMPING, STIFFNESS_EQ, STIFFNESS, MASS, GYROSCOPIC), *self._motion(t)
            )
            found = (C, K_eq - K, K, M, G)
            self._assembly_cache[t] = found
        return found

    def _held(self, u, lengths):
        """The generalised force of the inputs `u` (held over a step) at `lengths`."""
        if u is None or not u.any():
            return None
        return self.system.assemble_inputs(lengths) @ u

    def _modes(self, t, near: FrozenModes | None = None, count: int = 0) -> FrozenModes:
        """The frozen modes at the lengths at `t`, kept for the last two lengths asked (a
        step's end is the next one's start; a refused step's start is the retry's): the
        `count` highest carried on from `near` (`FrozenModes.updated`), all of them
        afresh every `MODES_REFRESH` steps or when `near` has fewer than `count`."""
        key = self._motion(t)[0].tobytes()
        found = self._modes_cache.get(key)
        if found is None or found.V.shape[1] < count:
            if len(self._modes_cache) >= 2:
                self._modes_cache.pop(next(iter(self._modes_cache)))
            _, _, K, M, _ = self._assembled(t)
            if near is not None and near.updates < MODES_REFRESH and near.V.shape[1] >= count:
                found = near.updated(count, M, K, self._rayleigh, self._mass_factor_at(t))
            else:
                found = FrozenModes.of(M, K, self._rayleigh)
            self._modes_cache[key] = found
        return found

    def _mass_factor_at(self, t):
        """The Cholesky factor of `M` at `t` (moving or not), kept for the last time asked."""
        if self._factor_at[0] != t:
            M = self._assembled(t)[3]
            self._factor_at = (t, _cho_factor(M))
        return self._factor_at[1]

    def _rows(self, lengths) -> np.ndarray:
        """`system.output_rows` at `lengths`, kept for the last lengths asked."""
        key = lengths.tobytes()
        if self._rows_cache[0] != key:
            self._rows_cache = (key, self.system.output_rows(lengths))
        return self._rows_cache[1]

    def _relative_rate(self, t0, h) -> float:
        """The largest `|Ld| / L` [1/s] of the booms at the step's ends and middle."""
        motions = (self._motion(t0 + f * h) for f in (0.0, 0.5, 1.0))
        # plain floats: numpy's cost per call is most of it for 12 values
        return max(
            abs(r) / L
            for lengths, rates, _ in motions
            for L, r in zip(lengths.tolist(), rates.tolist(), strict=True)
        )

    def _resolved(self, lengths) -> float:
        if self.resolved_frequency is not None:
            return self.resolved_frequency
        return self.system.resolved_frequency(lengths)

    def states_at(self, times, rates: str | None = "exact") -> tuple[np.ndarray, np.ndarray]:
        """`(q, qd)` (each (m, n)) at `times` [s] (m values) within the last step (its end:
        the state itself), from the step's continuous extension (`between`) or, at rest,
        the exact step from its start. `rates`: how a moving step's velocities inside it
        are found (`between`): "exact", or "extension" (no assembly nor factorisation per
        time; `q` the same to the bit) for a caller that reads positions only, or None
        for one that reads no velocities but the state at the step's end (`qd` nan inside
        the step; `q` the same to the bit)."""
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
        t0, q0, qd0, trial = self._last
        if inside.min() < t0 or inside.max() > self._t:
            raise ValueError(
                f"times {inside.tolist()!r} s are not all within the last step [{t0}, {self._t}] s"
            )
        fractions = (inside - t0) / (self._t - t0)
        if isinstance(trial, Rest):  # at rest: each mode's exact propagator from the start
            q[~end], qd[~end] = rest_states(trial, fractions)
            if rates is None:
                qd[~end] = math.nan
        else:
            q[~end], qd[~end] = self.between(fractions, qd0, self.qd, rates=rates)
        return q, qd

    def _velocities(self, times, q, p) -> np.ndarray:
        """`qd = M^-1 (p - G q)` (m, n) with `M`, `G` at each of `times` [s] (m,): the
        matrices of all m assembled in one pass, each `M` factored by Cholesky."""
        motions = [self._motion(float(t)) for t in times]
        stacked = (np.array([motion[i] for motion in motions]) for i in range(3))
        matrices = self.system.assemble((MASS, GYROSCOPIC), *stacked)
        qd = p - np.einsum("mij,mj->mi", matrices[:, 1], q)
        for M, row in zip(matrices[:, 0], qd, strict=True):
            factor, _ = potrf(M, lower=True, overwrite_a=True, clean=False)
            row[:], _ = potrs(factor, row, lower=True)
        return qd

    def between(self, fractions, qd0, qd1, rates="extension") -> tuple[np.ndarray, np.ndarray]:
        """`(q, qd)` (each (m, n)) inside the last step, a moving one, at `fractions`
        (m values in (0, 1)) of it, given the velocities `qd0`, `qd1` [m/s] at its ends.

        Each rational step's own resolvent solutions, recombined with the weights of
        the continuous extension `R_f` (`extension_weights`): `q(f) = c q0 + sum_k 2
        Re[w_k y_q,k]`, and, with the midpoint matrices, `M^-1 (p - G q)(f) = c qd*_0 +
        sum_k 2 Re[w_k u_k]`. `qd*_0` (the start's velocity under the midpoint matrices)
        is taken as the velocity at the rational step's start, and a term linear in `f`
        makes both ends exact; the difference is of the midpoint rule's own order (the
        change of `M`, `G` over the step). The followed modes (`fast_modes`) are put in
        as the start's free vibration turned on (first half) or the end's turned back
        (second half).

        `rates` says where the velocities come from: "extension", as above, at no cost
        (the live grid, `sampling`; off by about 0.3 % of peak on the reference
        deployment); "exact", the extension's canonical momenta `p(f)` and `qd = M^-1 (p
        - G q)` with the matrices at each sample's own time, so that the linear
        invariants (a free hub's momenta) hold at the samples as at the steps' ends and
        the rates are as accurate as the positions, at one assembly and one Cholesky
        factorisation per sample (the batch outputs, `states_at`); "slope", the time
        derivative of the curve `q(f)` itself, the slope a Hermite interpolation between
        samples needs (`interpolant`); None, none (`qd` nan: the positions alone)."""
        return self._extended(fractions, qd0, qd1, rates)

    def _extension(self) -> Extension:
        """The last step's continuous extension, kept for that step."""
        t0, _, _, trial = self._last
        if self._extension_of[0] is not trial:
            h = self._t - t0
            turning = 2.0 * math.pi * PADE_POLES.size * len(trial.extensions) / h
            shortening = float((self._motion(t0)[0] / self._motion(self._t)[0]).max())
            carried = trial.carried_frequency * CARRIED_MARGIN * max(1.0, shortening) ** 2
            extension = Extension(trial.extensions, trial.vibration, h, min(turning, carried))
            self._extension_of = (trial, extension)
        return self._extension_of[1]

    def _extended(self, fractions, qd0, qd1, rates):
        """`between`."""
        t0, _, _, trial = self._last
        h = self._t - t0
        ext = self._extension()
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        if rates == "slope":
            return ext.curve(fractions, None)
        parts = ext.parts
        # the ends of each rational step: the step's ends, and its middle when halved
        # (the extension's rates start and end there; exact rates need no ends)
        if parts == 2 and rates == "extension":
            if self._half_velocity[0] is not trial:
                q_half, _, _, _, p_half, _ = ext.extensions[1]
                middle = self._velocity(t0 + 0.5 * h, q_half, p_half, trial.middle)
                self._half_velocity = (trial, middle)
            qd_half = self._half_velocity[1]
            ends = ((qd0, qd_half), (qd_half, qd1))
        elif rates == "extension":
            ends = ((qd0, qd1),)
        q = np.empty((fractions.size, self._q.size))
        qd = np.full_like(q, math.nan) if rates is None else np.empty_like(q)
        part = np.minimum((fractions * parts).astype(int), parts - 1)
        for k in range(parts):
            inside = part == k
            if not inside.any():
                continue
            local = fractions[inside] * parts - k
            q_start, y_q, u, v, p_start, mats = ext.extensions[k]
            c, w = extension_weights(local)
            q_part = np.outer(c, q_start) + 2.0 * (w @ y_q).real
            if rates is None:  # positions only
                q[inside] = q_part
                if ext.vibration:
                    q[inside] = ext.kept(q_part, k) + ext.free(k, local, velocities=False)
                continue
            velocity = 2.0 * (w @ u).real  # sum_k 2 Re[w_k u_k]
            if rates == "exact":
                times = t0 + (k + local) * h / parts
                p = extended_momentum(mats, c, velocity, q_part, q_start, p_start)
                qd_part = self._velocities(times, q_part, p)
            else:
                start_qd, end_qd = ends[k]
                drift = np.outer(local, end_qd - start_qd - 2.0 * v)
                qd_part = np.outer(c, start_qd) + velocity + drift
            if ext.vibration:
                q_free, qd_free = ext.free(k, local)
                q_part = ext.kept(q_part, k) + q_free
                qd_part = ext.kept(qd_part, k) + qd_free
            q[inside], qd[inside] = q_part, qd_part
        return q, qd

    def step_limit(self) -> float:
        """The longest step [s] allowed now: `bound` and the error control's proposal."""
        return min(self.bound(), self._proposal)

    def bound(self) -> float:
        """The longest step [s] whatever the error: `max_step` and `PHASE_PER_STEP` rad of
        `resolved_frequency` per fixed step, `WHOLE_STEP_PHASE` per error-controlled one
        (default: `system.resolved_frequency` at the current lengths)."""
        lengths, _, _ = self._motion(self._t)
        phase = PHASE_PER_STEP if self.rtol is None else WHOLE_STEP_PHASE
        return min(self.max_step, phase / self._resolved(lengths))

    @property
    def proposal(self) -> float:
        """The error control's next step [s] (inf before its first moving step)."""
        return self._proposal

    def _motion(self, t):
        """The profile at `t`, checked; cached for the last `MOTION_CACHE` times, since a
        step asks for the same few times again and again (its ends, middles and quarters:
        step size, matrices, followed modes, velocities, publishing)."""
        motion = self._motion_cache.get(t)
        if motion is not None:
            return motion
        piece = getattr(self._profile, "piece", None)
        # at a switch: the piece that starts there once the stepper has reached it
        profile = self._profile if piece is None else piece(t, entered=t <= self._entered)
        values = profile(t)
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
        if len(self._motion_cache) >= MOTION_CACHE:
            self._motion_cache.clear()
        self._motion_cache[t] = motion
        return motion

    def _force(self, t, lengths) -> np.ndarray | None:
        """Generalised forces `B_u u(t)` [N] at `lengths`; None when there are none."""
        if self.inputs is None:
            return None
        return self._held(self._input(t), lengths)

    def _input(self, t) -> np.ndarray:
        """The inputs `u` at `t`, checked."""
        u = np.asarray(self.inputs(t), dtype=float)
        if u.ndim != 1 or not np.all(np.isfinite(u)):
            raise ValueError(f"inputs at t = {t:.6g} s must be finite values, got {u!r}")
        return u

    def _mass_gyro(self, t):
        _, _, _, M, G = self._assembled(t)
        return M, G

    def _rational_step(self, t0, q0, p0, h, mats=None):
        """One exponential-midpoint step of `h` [s] from `(q0, p0)` at `t0` with the
        rational approximant (`rational.moving_step`): `(q1, p1, extension)`; `mats`: the
        matrices at its middle if already assembled (`_step_matrices`)."""
        t_mid = t0 + 0.5 * h
        lengths = self._motion(t_mid)[0]
        force = self._force(t_mid, lengths)
        if mats is None:
            (mats,) = self._step_matrices((t_mid,))
        return moving_step(q0, p0, mats, h, force)

    def _step_matrices(self, times) -> list:
        """The matrices one moving step needs (`STEP_MATRICES`) at each of `times` [s]:
        dense ones assembled in one pass (numpy's cost per call is most of it), or as
        blocks (`BLOCK_SOLVE_MIN_COORDINATES`)."""
        motions = [self._motion(t) for t in times]
        if self.system.n >= BLOCK_SOLVE_MIN_COORDINATES:
            return [self.system.assemble_blocks(STEP_MATRICES, *motion) for motion in motions]
        stacked = (np.array([motion[i] for motion in motions]) for i in range(3))
        return [DenseMatrices(m) for m in self.system.assemble(STEP_MATRICES, *stacked)]

    def _static_step(self, lengths, h, force):
        """The exact step of `h` [s] at rest under the held generalised force `force`
        (None: none): `(q, p, Rest)` (`rest`), its propagator kept per lengths and
        `h` (a simulator at rest repeats them)."""
        key = (lengths.tobytes(), h)
        propagator = self._static_cache.get(key)
        if propagator is None:
            if len(self._static_cache) >= 16:
                self._static_cache.clear()
            propagator = exact_propagator(self.system, lengths, h)
            self._static_cache[key] = propagator
        return rest_step(propagator, self._q, self._p, h, force)

    def last_curve(self) -> Extension | Rest:
        """The last step's curve, what `interpolant` samples: at rest its `Rest` data
        (exact; its highest frequency `sqrt(max lam)`); moving its `Extension`, whose
        `slow` [rad/s] bounds the frequencies of all but the followed modes: the highest
        frozen mode the rational steps carry (`CARRIED_MARGIN` over it, and the rise of a
        boom's frequencies as `1 / L^2` where the step shortens it), at most the turning
        of their extensions (polynomials of degree 2 k = 4 in each rational step's
        fraction, k the Padé pole pairs, turning at most that often: `2 pi k` over a
        rational step)."""
        trial = self._last[3]
        return trial if isinstance(trial, Rest) else self._extension()

    def interpolant(self, fractions, rows) -> tuple[np.ndarray, np.ndarray]:
        """`rows q(t)` and its rate `rows qd(t)` [per s] (each (m, r)) at `fractions` (m
        values in [0, 1]) of the last step, for output rows `rows` (r, n): at rest each
        mode's exact propagator, moving the step's continuous extension (`between`); at
        `f = 1` the step's end (what `peaks` samples inside each step)."""
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        rows = np.asarray(rows, dtype=float)
        t0, _, qd0, trial = self._last
        if isinstance(trial, Rest):
            q, qd = rest_states(trial, fractions)
            return q @ rows.T, qd @ rows.T
        return self._extension().curve(fractions, rows)


def _largest(rows, q, qd) -> np.ndarray:
    """The largest magnitude of each output kind (`OUTPUT_KINDS`) in `rows q` and `rows qd`
    (`rows`: tips then root moments, 4 each)."""
    y = np.abs(rows @ np.array([q, qd]).T)  # (8, 2): q, qd
    return y.reshape(2, 4, 2).max(axis=1).ravel()  # tips (q, qd), moments (q, qd)
