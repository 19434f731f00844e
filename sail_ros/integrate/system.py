"""The structure at the times a stepper asks about, each thing computed once and kept.

A step asks for the same few times again and again (its ends, middles and quarters: the
boom motion, the matrices, the mass matrix's factor, the frozen modes, the output rows,
the exact propagator at rest). `SystemAt` is the one owner of those: one cache, whose
one rule drops the least recently used entries past a memory budget. What depends on
the time goes with the profile's current piece (`new_piece`); what depends on the
lengths alone (modes, rows, the propagator at rest) stays.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Protocol

import numpy as np
import scipy.linalg

from sail_ros.integrate.fast_modes import STEP_MATRICES, FrozenModes
from sail_ros.integrate.rest import exact_propagator
from sail_ros.model.assembly import (
    DAMPING,
    GYROSCOPIC,
    MASS,
    STIFFNESS,
    STIFFNESS_EQ,
    STRUCTURAL_DAMPING,
)
from sail_ros.model.blocks import BlockMatrices, DenseMatrices
from sail_ros.model.lapack import potrf, potrs  # `M` is positive definite
from sail_ros.model.layout import per_boom


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

    hub_slice: slice | None  # the cyclic coordinates (a free hub's), or None

    def modes_of(self, M: np.ndarray, K: np.ndarray):
        """`(lam, V)`: eigenvalues `omega^2` and `M`-orthonormal modes of `(K, M)` at rest
        (`scipy.linalg.eigh(K, M)` for a structure held in place); rigid-body modes, if
        any, with `lam` exactly 0 (a free hub, model.md §13.6)."""


# [bytes] what one stepper keeps of the structure at the times it asked about: the two
# ends of a step and its middles at several hundred coordinates (a set of matrices is
# 23 MB at 756)
CACHE_BYTES = 192 * 2**20
# A step's end takes the followed modes from its start's by one subspace iteration; every
# this many steps (and where the start has too few) all modes are found afresh.
MODES_REFRESH = 8
# From this many coordinates the moving step solves by blocks (`blocks.py`), faster on one
# core at n = 160 (n_B = n_M = 20); below, LAPACK on the whole matrix costs less than
# numpy's per-call overhead on 10 x 10 blocks.
BLOCK_SOLVE_MIN_COORDINATES = 120
# Samples whose velocities are found in one pass (`SystemAt.velocities`)
SAMPLES_AT_ONCE = 16
# the kinds of entry that depend on the time (the profile's piece), not the lengths alone
_TIMED = ("motion", "matrices", "factor")


def cho_factor(M: np.ndarray):
    """`scipy.linalg.cho_factor(M, check_finite=False)` (the same LAPACK call, the same
    factor) without its wrapper's cost."""
    factor, info = potrf(M, lower=False, clean=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"the mass matrix is not positive definite (potrf info {info})")
    return factor, False


def cho_solve(factor, b: np.ndarray) -> np.ndarray:
    """`scipy.linalg.cho_solve(factor, b, check_finite=False)`: the same LAPACK call."""
    c, lower = factor
    x, info = potrs(c, b, lower=lower)
    if info != 0:
        raise ValueError(f"illegal value in potrs argument {-info}")
    return x


def _nbytes(value, depth: int = 3) -> int:
    """The memory the arrays held by `value` take [bytes] (tuples, lists and objects'
    attributes searched `depth` levels deep)."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if depth == 0:
        return 0
    if isinstance(value, tuple | list):
        if all(type(item) is np.ndarray for item in value):  # a motion, a set of matrices
            return sum(item.nbytes for item in value)
        return sum(_nbytes(item, depth - 1) for item in value)
    if hasattr(value, "__dict__"):  # dataclasses (`FrozenModes`) too
        return sum(_nbytes(item, depth - 1) for item in vars(value).values())
    return 0


class Cache:
    """Values by key (`(kind, ...)`), the least recently used dropped once all of them
    take more than `budget` [bytes] (the newest is always kept)."""

    def __init__(self, budget: int = CACHE_BYTES):
        self.budget = budget
        self._items: OrderedDict = OrderedDict()
        self._bytes = 0

    def get(self, key):
        found = self._items.get(key)
        if found is not None:
            self._items.move_to_end(key)
            return found[0]
        return None

    def put(self, key, value):
        old = self._items.pop(key, None)
        if old is not None:
            self._bytes -= old[1]
        size = _nbytes(value)
        self._items[key] = (value, size)
        self._bytes += size
        while self._bytes > self.budget and len(self._items) > 1:
            _, (_, dropped) = self._items.popitem(last=False)
            self._bytes -= dropped
        return value

    def drop(self, kinds) -> None:
        """Forget the entries of `kinds`."""
        for key in [key for key in self._items if key[0] in kinds]:
            self._bytes -= self._items.pop(key)[1]


def rayleigh_of(system) -> tuple[float, float]:
    """`(alpha, beta)` of the system's Rayleigh damping, read off `C_d` against `M` and `K`
    at a length of 10 m at rest (`C_d = alpha M + beta K` at every length)."""
    lengths, zero = np.full(4, 10.0), np.zeros(4)
    M, K, C_d = system.assemble((MASS, STIFFNESS, STRUCTURAL_DAMPING), lengths, zero, zero)
    if not C_d.any():
        return 0.0, 0.0
    basis = np.stack([M.ravel(), K.ravel()], axis=1)
    (alpha, beta), *_ = np.linalg.lstsq(basis, C_d.ravel(), rcond=None)
    return float(alpha), float(beta)


class SystemAt:
    """`system` (a `LinearSystem`) under the boom motion `profile`, at the times asked.

    `resolved_frequency` [rad/s]: the highest frequency a step must resolve, or None for
    the system's own at the current lengths. `entered` [s]: since when the profile's
    current piece applies (a piecewise profile's `piece`: at a switch, the piece that
    starts there once the stepper has reached it)."""

    def __init__(self, system: LinearSystem, profile, resolved_frequency: float | None = None):
        if resolved_frequency is not None and not (
            math.isfinite(resolved_frequency) and resolved_frequency > 0
        ):
            raise ValueError(
                f"resolved_frequency must be finite and > 0, got {resolved_frequency!r}"
            )
        self.system = system
        self.profile = profile
        self.resolved_frequency = resolved_frequency
        self.entered = -math.inf
        self.rayleigh = rayleigh_of(system)  # alpha [1/s], beta [s]
        # coordinates whose canonical momenta no step may change but through the loads (a
        # free hub's: `LinearSystem.hub_slice`), or None
        self.invariant = getattr(system, "hub_slice", None)
        self._cache = Cache()

    def new_piece(self, entered: float, profile=None) -> None:
        """The profile's piece (or a new `profile`) applies from `entered` [s] on: what
        depends on the time is asked afresh."""
        if profile is not None:
            self.profile = profile
        self.entered = entered
        self._cache.drop(_TIMED)

    # the motion -----------------------------------------------------------------------
    def motion(self, t):
        """`(lengths, rates, accelerations)` at `t` [s], 4 values each, checked (scalars
        stand for all booms; the messages name the field, time and value)."""
        key = ("motion", t)
        motion = self._cache.get(key)
        if motion is None:
            motion = self._cache.put(key, self._motion(t))
        return motion

    def _profile_at(self, t: float):
        """The profile that gives the motion at `t` [s]: a piecewise profile's piece there
        (`entered`), or the profile."""
        piece = getattr(self.profile, "piece", None)
        return self.profile if piece is None else piece(t, entered=t <= self.entered)

    def _motion(self, t):
        """`motion` at `t` [s], evaluated and checked, not kept."""
        values = self._profile_at(t)(t)
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
        else:
            lengths, rates, accelerations = values
            motion = (
                per_boom(lengths, f"lengths at t = {t:.6g} s", positive=True),
                per_boom(rates, f"rates at t = {t:.6g} s"),
                per_boom(accelerations, f"accelerations at t = {t:.6g} s"),
            )
        return motion

    def motions_inside(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`motion` at each of `times` [s] (m,), all inside one step (one piece of the
        profile), each (m, 4): in one pass where the profile can (`motion_over`); samples'
        times, asked once, not kept (a step's own times are)."""
        over = getattr(self._profile_at(float(times[times.size // 2])), "over", None)
        found = None if over is None else over(times)
        if found is None:
            motions = [self._cache.get(("motion", t)) or self._motion(t) for t in times.tolist()]
            return tuple(np.array([motion[i] for motion in motions]) for i in range(3))
        lengths, rates, accelerations = found
        if not (np.isfinite(found).all() and lengths.min() > 0):
            for t in times.tolist():  # the same error as a single time's
                self._motion(t)
        return lengths, rates, accelerations

    def is_static(self, t0: float, t1: float) -> bool:
        """Whether the booms stand still over [t0, t1] [s] (the profile says)."""
        is_static = getattr(self.profile, "is_static", None)
        return is_static is not None and is_static(t0, t1)

    def resolved(self, lengths) -> float:
        """The frequency [rad/s] a step must resolve at `lengths`."""
        if self.resolved_frequency is not None:
            return self.resolved_frequency
        return self.system.resolved_frequency(lengths)

    def relative_rate(self, t0: float, h: float) -> float:
        """The largest `|Ld| / L` [1/s] of the booms at a step's ends and middle."""
        motions = (self.motion(t0 + f * h) for f in (0.0, 0.5, 1.0))
        # plain floats: numpy's cost per call is most of it for 12 values
        return max(
            abs(r) / L
            for lengths, rates, _ in motions
            for L, r in zip(lengths.tolist(), rates.tolist(), strict=True)
        )

    # matrices and factors ----------------------------------------------------------------
    def matrices(self, t):
        """`C, K_eq - K, K, M, G` of Eq. 2 at `t` [s]."""
        key = ("matrices", t)
        found = self._cache.get(key)
        if found is None:
            C, K_eq, K, M, G = self.system.assemble(
                (DAMPING, STIFFNESS_EQ, STIFFNESS, MASS, GYROSCOPIC), *self.motion(t)
            )
            found = self._cache.put(key, (C, K_eq - K, K, M, G))
        return found

    def mass_factor(self, t):
        """The Cholesky factor of `M` at `t` [s] (`cho_factor`)."""
        key = ("factor", t)
        found = self._cache.get(key)
        if found is None:
            found = self._cache.put(key, cho_factor(self.matrices(t)[3]))
        return found

    def rest_factor(self, lengths):
        """The Cholesky factor of `M` at `lengths` (at rest `M` depends on them alone)."""
        key = ("rest factor", lengths.tobytes())
        found = self._cache.get(key)
        if found is None:
            zero = np.zeros(4)
            (M,) = self.system.assemble((MASS,), lengths, zero, zero)
            found = self._cache.put(key, scipy.linalg.cho_factor(M))
        return found

    def rows(self, lengths) -> np.ndarray:
        """`system.output_rows` at `lengths`."""
        key = ("rows", lengths.tobytes())
        found = self._cache.get(key)
        if found is None:
            found = self._cache.put(key, self.system.output_rows(lengths))
        return found

    def modes(self, t, near: FrozenModes | None = None, count: int = 0) -> FrozenModes:
        """The frozen modes at the lengths at `t` [s]: the `count` highest carried on
        from `near` (`FrozenModes.updated`), all of them afresh every `MODES_REFRESH`
        steps or when `near` has fewer than `count`."""
        key = ("modes", self.motion(t)[0].tobytes())
        found = self._cache.get(key)
        if found is None or found.V.shape[1] < count:
            _, _, K, M, _ = self.matrices(t)
            if near is not None and near.updates < MODES_REFRESH and near.V.shape[1] >= count:
                found = near.updated(count, M, K, self.rayleigh, self.mass_factor(t))
            else:
                found = FrozenModes.of(M, K, self.rayleigh)
            self._cache.put(key, found)
        return found

    def propagator(self, lengths, h: float):
        """The exact step's propagator at rest over `h` [s] (`rest.exact_propagator`)."""
        key = ("propagator", lengths.tobytes(), h)
        found = self._cache.get(key)
        if found is None:
            found = self._cache.put(key, exact_propagator(self.system, lengths, h))
        return found

    def step_matrices(self, times) -> list:
        """The matrices one moving step needs (`STEP_MATRICES`) at each of `times` [s]:
        dense ones assembled in one pass (numpy's cost per call is most of it), or as
        blocks (`BLOCK_SOLVE_MIN_COORDINATES`)."""
        motions = [self.motion(t) for t in times]
        if self.system.n >= BLOCK_SOLVE_MIN_COORDINATES:
            return [self.system.assemble_blocks(STEP_MATRICES, *motion) for motion in motions]
        stacked = (np.array([motion[i] for motion in motions]) for i in range(3))
        return [DenseMatrices(m) for m in self.system.assemble(STEP_MATRICES, *stacked)]

    def held(self, u, lengths):
        """The generalised force of the inputs `u` (held over a step) at `lengths`; None
        when there is none."""
        if u is None or not u.any():
            return None
        return self.system.assemble_inputs(lengths) @ u

    # velocities from momenta --------------------------------------------------------------
    def velocity(self, t, q, p, middle=None) -> np.ndarray:
        """`qd = M^-1 (p - G q)` at `t` [s]; `middle`: a moving step's matrices
        (`STEP_MATRICES`) at `t`, if at hand."""
        lengths, rates, accelerations = self.motion(t)
        if rates.any():
            if isinstance(middle, DenseMatrices):  # a moving step's middle
                M, _, _, G = middle.matrices
                factor, _ = potrf(M, lower=True, clean=False)
                return potrs(factor, p - G @ q, lower=True)[0]
            at_hand = self._cache.get(("matrices", t))
            if at_hand is not None:  # a step's end
                return cho_solve(self.mass_factor(t), p - at_hand[4] @ q)
            # inside a step (a sample): M and G alone
            M, G = self.system.assemble((MASS, GYROSCOPIC), lengths, rates, accelerations)
            return cho_solve(cho_factor(M), p - G @ q)
        # G = 0 at rest, and M depends on the lengths alone
        return cho_solve(self.rest_factor(lengths), p)

    def velocities(self, times, q, p, qd_guess=None) -> np.ndarray:
        """`qd = M^-1 (p - G q)` (m, n) with `M`, `G` at each of `times` [s] (m,): the
        matrices of all m assembled in one pass, each `M` factored by Cholesky. With
        `qd_guess`, the momenta are those of `q`, `qd_guess` but on `invariant`, where they
        are `p`'s (the followed modes put in at samples, `moving._replaced`). From
        `BLOCK_SOLVE_MIN_COORDINATES` on, by blocks, one time after another."""
        times = np.asarray(times, dtype=float)
        if not times.size:
            return np.empty_like(q)
        if times.size > SAMPLES_AT_ONCE:  # the assembly's scatter indices grow with them
            return np.concatenate([
                self.velocities(times[i : i + SAMPLES_AT_ONCE], q[i : i + SAMPLES_AT_ONCE],
                                p[i : i + SAMPLES_AT_ONCE],
                                None if qd_guess is None else qd_guess[i : i + SAMPLES_AT_ONCE])
                for i in range(0, times.size, SAMPLES_AT_ONCE)
            ])  # fmt: skip
        motions = self.motions_inside(times)
        if self.system.n >= BLOCK_SOLVE_MIN_COORDINATES:
            return self._velocities_by_blocks(list(zip(*motions, strict=True)), q, p, qd_guess)
        matrices = self.system.assemble((MASS, GYROSCOPIC), *motions)
        if qd_guess is not None:
            kept = p
            p = (matrices[:, 0] @ qd_guess[..., None])[..., 0]
            p += (matrices[:, 1] @ q[..., None])[..., 0]
            if self.invariant is not None:
                p[:, self.invariant] = kept[:, self.invariant]
        qd = p - (matrices[:, 1] @ q[..., None])[..., 0]  # stacked products, not einsum's
        for M, row in zip(matrices[:, 0], qd, strict=True):
            factor, _ = potrf(M, lower=True, overwrite_a=True, clean=False)
            row[:], _ = potrs(factor, row, lower=True)
        return qd

    def _velocities_by_blocks(self, motions, q, p, qd_guess) -> np.ndarray:
        """`velocities` with `M` and `G` as blocks at each motion (a solve by blocks costs
        a fraction of the dense Cholesky factor at hundreds of coordinates)."""
        qd = np.empty_like(q)
        for i, motion in enumerate(motions):
            blocks = self.system.assemble_blocks((MASS, GYROSCOPIC), *motion)
            guess = np.zeros_like(q[i]) if qd_guess is None else qd_guess[i]
            Mqd, Gq = blocks.matvec(np.stack([guess, q[i]]))
            momenta = p[i] if qd_guess is None else Mqd + Gq
            if qd_guess is not None and self.invariant is not None:
                momenta[self.invariant] = p[i][self.invariant]
            qd[i] = blocks.solve(momenta - Gq)
        return qd

    def momentum(self, t, q, qd) -> np.ndarray:
        """`p = M qd + G q` at `t` [s]."""
        _, _, _, M, G = self.matrices(t)
        return M @ qd + G @ q

    def energy(self, t, q, qd) -> float:
        """`1/2 qd^T M qd + 1/2 q^T K q` [J] at the lengths at `t` [s]."""
        zero = np.zeros(4)
        M, K = self.system.assemble((MASS, STIFFNESS), self.motion(t)[0], zero, zero)
        return 0.5 * float(qd @ M @ qd) + 0.5 * float(q @ K @ q)
