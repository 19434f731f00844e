"""The whole sail: four booms and four membrane quadrants (seed Eq. 2 and 3).

    M qdd + (Md + G - G^T) qd + (Gd + K - N) q = 0

with `q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]` (model.md §6).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg

from sail_ros.model.assembly import (
    DAMPING,
    MASS,
    STIFFNESS,
    STIFFNESS_EQ,
    Constants,
    SystemAssembler,
)
from sail_ros.model.basis import cantilever_roots
from sail_ros.model.integrals import (
    boom_integrals,
    check_affordable,
    default_quadrature_order,
    quadrant_integrals,
)
from sail_ros.model.integrate import simulate
from sail_ros.model.layout import BOOMS, Layout, per_boom
from sail_ros.model.parameters import SailParameters
from sail_ros.model.stepper import SailStepper


class StateSample(NamedTuple):
    """The state at time `t` [s]: boom lengths [m] and rates [m/s], coordinates q [m]
    and velocities qd [m/s], tip deflections [m] and their rates [m/s]."""

    t: float
    lengths: np.ndarray
    rates: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tips: np.ndarray
    tip_rates: np.ndarray


def cantilever_frequency(params: SailParameters, length: float) -> float:
    """First bending frequency [rad/s] of a bare boom of `length` [m] clamped at the
    hub: `beta_1^2 sqrt(EI / rho_B) / L^2` (it grows like 1/L^2 as the boom shortens)."""
    constant = float(cantilever_roots(1)[0] ** 2) * np.sqrt(
        params.boom_bending_stiffness / params.boom_linear_density
    )
    return constant / float(length) ** 2


class SailModel:
    """Modal model of the four-boom, four-quadrant sail.

    The reference integrals for `(n_B, n_M)` are built once (and cached across
    instances); every call below only scales and adds them.

    Args:
        params: physical parameters and mode counts.
        quadrature_order: Gauss points per direction for the reference
            integrals; the default resolves every basis product.
    """

    def __init__(self, params: SailParameters | None = None, quadrature_order: int | None = None):
        self.params = params if params is not None else SailParameters()
        nb, nm = self.params.n_boom_modes, self.params.n_membrane_modes
        self.n_boom_modes, self.n_membrane_modes = nb, nm
        self.layout = Layout(nb, nm)
        self.n = self.layout.n
        order = quadrature_order or default_quadrature_order(nb, nm)
        check_affordable(nb, nm, order)
        self.boom_integrals = boom_integrals(nb, order)
        self.quadrant_integrals = quadrant_integrals(nb, nm, order)
        self.assembler = SystemAssembler(
            self.boom_integrals,
            self.quadrant_integrals,
            self.layout,
            Constants(
                boom_linear_density=self.params.boom_linear_density,
                boom_bending_stiffness=self.params.boom_bending_stiffness,
                boom_axial_load=self.params.boom_axial_load,
                membrane_areal_density=self.params.membrane_areal_density,
                membrane_tension=self.params.membrane_tension,
            ),
        )
        self._cantilever_constant = cantilever_frequency(self.params, 1.0)  # [rad/s at 1 m]
        self._tip_rows = self._tip_matrix()

    # layout ------------------------------------------------------------------
    def boom_slice(self, boom: str) -> slice:
        """Coordinates `p_k` of boom `k` in the system vector."""
        return self.layout.boom_slice(boom)

    def membrane_slice(self, quadrant: str) -> slice:
        """Coordinates `q_xy` of quadrant `xy` in the system vector."""
        return self.layout.membrane_slice(quadrant)

    @property
    def coordinate_names(self) -> list[str]:
        """One self-describing name per generalised coordinate (`Layout.coordinate_names`)."""
        return self.layout.coordinate_names

    # matrices ----------------------------------------------------------------
    def evaluate(self, outputs, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """Matrices named by `outputs` (see `assembly`), stacked (len(outputs), n, n);
        lengths, rates and accelerations are checked (`per_boom`)."""
        return self.assemble(
            outputs,
            per_boom(lengths, "lengths", positive=True),
            per_boom(rates, "rates"),
            per_boom(accelerations, "accelerations"),
        )

    def matrices(self, lengths, rates=0.0, accelerations=0.0):
        """`M, C, K` of `M qdd + C qd + K q = 0` (seed Eq. 2).

        `C = Md + G - G^T` and `K = Gd + K_elastic - N` (model.md §4).

        Args:
            lengths: boom lengths [m], a scalar (all booms) or 4 values (a, b, c, d).
            rates: extension rates [m/s], same form.
            accelerations: extension accelerations [m/s^2], same form.
        """
        M, C, K = self.evaluate((MASS, DAMPING, STIFFNESS_EQ), lengths, rates, accelerations)
        return M, C, K

    def mass_and_stiffness(self, lengths):
        """`M` and the elastic `K` (membrane tension, bending, axial load) [SI]."""
        M, K = self.evaluate((MASS, STIFFNESS), lengths)
        return M, K

    # analysis ----------------------------------------------------------------
    def natural_frequencies(self, lengths) -> np.ndarray:
        """Natural frequencies [rad/s], ascending, at fixed lengths (rates 0).

        Solves `K v = omega^2 M v`. A buckled configuration (an axial load
        above the critical one) has a negative eigenvalue; it is returned as
        `-sqrt(-omega^2)`, so negative entries mark divergent modes.
        """
        M, K = self.mass_and_stiffness(lengths)
        omega2 = scipy.linalg.eigh(K, M, eigvals_only=True)
        return np.sign(omega2) * np.sqrt(np.abs(omega2))

    def state_matrix(self, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """`A` of the first-order form `xd = A x`, `x = [qd; q]` (seed Eq. 3).

        `A = [-M^-1 C, -M^-1 K_eq; I, 0]`.
        """
        M, C, K = self.matrices(lengths, rates, accelerations)
        n = self.n
        factor = scipy.linalg.cho_factor(M)
        A = np.zeros((2 * n, 2 * n))
        A[:n, :n] = -scipy.linalg.cho_solve(factor, C)
        A[:n, n:] = -scipy.linalg.cho_solve(factor, K)
        A[n:, :n] = np.eye(n)
        return A

    def eigenvalues(self, lengths, rates=0.0) -> np.ndarray:
        """Eigenvalues [1/s] of Eq. 3 at frozen lengths with constant rates.

        Accelerations are zero. Sorted by imaginary part, then real part; any
        positive real part means the frozen system is unstable.
        """
        eig = np.linalg.eigvals(self.state_matrix(lengths, rates, 0.0))
        return eig[np.lexsort((eig.real, eig.imag))]

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """`evaluate` without the checks, for arrays of 4 already checked (the stepper's
        hot path; `stepper.LinearSystem`)."""
        return self.assembler.evaluate(outputs, lengths, rates, accelerations)

    def resolved_frequency(self, lengths) -> float:
        """The highest angular frequency [rad/s] a time step must resolve at these
        lengths: the first cantilever frequency of the shortest bare boom,
        `beta_1^2 sqrt(EI / rho_B) / L_min^2`, an upper bound of the dominant
        boom-bending frequency (the membrane only adds mass to a boom)."""
        return self._cantilever_constant / float(np.min(lengths)) ** 2

    # time integration ----------------------------------------------------------
    def stepper(self, profile, q0=None, qd0=None, t0: float = 0.0, **options) -> SailStepper:
        """A `SailStepper` holding this model's state (see `stepper.py`).

        `options`: `max_step` [s], `resolved_frequency` [rad/s].
        """
        return SailStepper(self, profile, q0=q0, qd0=qd0, t0=t0, **options)

    def simulate(
        self, profile, t_end: float, q0=None, qd0=None, t_eval=None, progress=None, **options
    ):
        """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`; returns
        `(t, q, qd)`. The arguments are those of `integrate.simulate`."""
        return simulate(
            self, profile, t_end, q0=q0, qd0=qd0, t_eval=t_eval, progress=progress, **options
        )

    # derived quantities --------------------------------------------------------
    def _tip_matrix(self) -> np.ndarray:
        rows = np.zeros((4, self.n))
        for k in range(4):
            rows[k, self.layout.boom_slots(k)] = self.boom_integrals.tip
        return rows

    def tip_deflections(self, q) -> np.ndarray:
        """Boom-tip deflections `u_k(L_k) = psi(1)^T p_k` [m] (4 values, a..d).

        `q` may be one state (n,) or a series (..., n); works for velocities too.
        """
        return np.asarray(q) @ self._tip_rows.T

    def sample(self, t: float, lengths, rates, q, qd) -> StateSample:
        """The state at `t` [s] with its tip deflections and their rates."""
        tips, tip_rates = self.tip_deflections(q), self.tip_deflections(qd)
        return StateSample(t, lengths, rates, q, qd, tips, tip_rates)

    def mode_state(self, boom: str = "a", tip_deflection: float = 0.1) -> np.ndarray:
        """Coordinates with boom `boom` bent in its first cantilever mode, all else 0.

        Args:
            boom: "a", "b", "c" or "d".
            tip_deflection: the tip deflection of that boom [m].
        """
        if not np.isfinite(tip_deflection):
            raise ValueError(f"tip_deflection must be finite, got {tip_deflection!r}")
        q = np.zeros(self.n)
        q[self.boom_slice(boom).start] = tip_deflection / self.boom_integrals.tip[0]
        return q

    def initial_coordinates(self, tip_deflections) -> np.ndarray:
        """Coordinates with each boom bent in its first cantilever mode to the given
        tip deflection [m] (a scalar or 4 values, booms a..d), membranes flat."""
        tips = per_boom(tip_deflections, "tip_deflections")
        return sum(self.mode_state(boom, float(tip)) for boom, tip in zip(BOOMS, tips, strict=True))

    def energy(self, q, qd, lengths) -> float:
        """Mechanical energy `1/2 qd^T M qd + 1/2 q^T K q` [J] at the given lengths."""
        M, K = self.mass_and_stiffness(lengths)
        q, qd = np.asarray(q), np.asarray(qd)
        return 0.5 * float(qd @ M @ qd) + 0.5 * float(q @ K @ q)
