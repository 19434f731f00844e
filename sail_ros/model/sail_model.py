"""The whole sail: four booms and four membrane quadrants (seed Eq. 2 and 3).

    M qdd + (Md + G - G^T + C_d) qd + (Gd + K - N) q = B_u(L) u

with `q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]` (model.md §6), the
Rayleigh damping `C_d` and the inputs `u` (pressures and tip forces, `loads`)
of model.md §12; with both zero it is the seed's equation.
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
    STRUCTURAL_DAMPING,
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
from sail_ros.model.integrate import simulate, simulate_on_grid
from sail_ros.model.layout import BOOMS, QUADRANTS, Layout, per_boom
from sail_ros.model.loads import N_INPUTS, input_function, inputs
from sail_ros.model.parameters import SailParameters
from sail_ros.model.stepper import SailStepper


class StateSample(NamedTuple):
    """The state at time `t` [s]: boom lengths [m] and rates [m/s], coordinates q [m]
    and velocities qd [m/s], tip deflections [m] and their rates [m/s], root bending
    moments [N m]."""

    t: float
    lengths: np.ndarray
    rates: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tips: np.ndarray
    tip_rates: np.ndarray
    root_moments: np.ndarray


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
                mass_damping=self.params.mass_damping,
                stiffness_damping=self.params.stiffness_damping,
            ),
        )
        self._cantilever_constant = cantilever_frequency(self.params, 1.0)  # [rad/s at 1 m]
        self._tip_rows = self._boom_rows(self.boom_integrals.tip)
        self._curvature_rows = self._boom_rows(self.boom_integrals.root_curvature)
        self._unit_inputs = self._unit_input_matrix()

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
        """`M, C, K` of `M qdd + C qd + K q = Q` (seed Eq. 2, model.md §12).

        `C = Md + G - G^T + C_d` (with the Rayleigh damping `C_d`) and
        `K = Gd + K_elastic - N` (model.md §4).

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

    def structural_damping(self, lengths) -> np.ndarray:
        """The Rayleigh damping `C_d = alpha M + beta K` [N s/m] at these lengths."""
        return self.evaluate((STRUCTURAL_DAMPING,), lengths)[0]

    # loads and outputs (model.md §12) -------------------------------------------
    def _unit_input_matrix(self) -> np.ndarray:
        """`B_u` with every quadrant's `L_a L_b` factor left out (n, 8)."""
        matrix = np.zeros((self.n, N_INPUTS))
        for j, quadrant in enumerate(QUADRANTS):
            matrix[self.layout.quadrant_slots(quadrant), j] += self.quadrant_integrals.s_mean
        for k in range(4):
            matrix[self.layout.boom_slots(k), 4 + k] = self.boom_integrals.tip
        return matrix

    def input_matrix(self, lengths) -> np.ndarray:
        """`B_u` (n, 8): generalised forces per unit input, `Q = B_u u`, inputs in the
        order of `loads.INPUT_NAMES` (4 pressures [Pa], then 4 tip forces [N]).

        A pressure `p` on `Q_ab` does the virtual work `p L_a L_b <S>`, so it loads
        that quadrant's membrane modes and its two booms; a tip force `F` on boom
        k does `F psi(1)` on `p_k`."""
        return self.assemble_inputs(per_boom(lengths, "lengths", positive=True))

    def assemble_inputs(self, lengths) -> np.ndarray:
        """`input_matrix` for 4 already checked lengths (the stepper's hot path)."""
        first = [q.first for q in QUADRANTS]
        second = [q.second for q in QUADRANTS]
        scale = np.concatenate([lengths[first] * lengths[second], np.ones(4)])
        return self._unit_inputs * scale

    def load_vector(self, lengths, pressures=0.0, tip_forces=0.0) -> np.ndarray:
        """Generalised forces `Q` (n,) [N] of the given pressures [Pa] (a scalar or 4
        values, quadrants ab, bc, cd, da) and tip forces [N] (booms a..d)."""
        return self.input_matrix(lengths) @ inputs(pressures, tip_forces)

    def static_deflection(self, lengths, pressures=0.0, tip_forces=0.0) -> np.ndarray:
        """Coordinates `q = K^-1 Q` of the sail at rest under constant loads.

        Raises:
            ValueError: the sail is buckled or neutrally stable (K not positive
                definite): it has no static answer.
        """
        M, K = self.mass_and_stiffness(lengths)
        Q = self.load_vector(lengths, pressures, tip_forces)
        try:
            return scipy.linalg.cho_solve(scipy.linalg.cho_factor(K), Q)
        except np.linalg.LinAlgError:
            raise ValueError(
                "the stiffness is not positive definite at these lengths (an axial "
                "load at or above buckling): no static deflection"
            ) from None

    def root_moments(self, q, lengths) -> np.ndarray:
        """Root bending moments `EI u_k''(0) = (EI / L_k^2) psi''(0)^T p_k` [N m] of
        booms a..d: (4,) for one state, (k, 4) for a series (`lengths` then 4 values
        or (k, 4)). Converges more slowly with n_B than the tip deflection."""
        q = np.asarray(q, dtype=float)
        lengths = np.asarray(lengths, dtype=float)
        if lengths.ndim <= 1:
            lengths = per_boom(lengths, "lengths", positive=True)
        elif lengths.shape != q.shape[:-1] + (4,):
            raise ValueError(
                f"lengths must be a scalar, 4 values or one row of 4 per state, "
                f"got shape {lengths.shape}"
            )
        if q.shape[-1] != self.n:
            raise ValueError(f"q must have {self.n} values per state, got shape {q.shape}")
        return self.params.boom_bending_stiffness * (q @ self._curvature_rows.T) / lengths**2

    def state_space(self, lengths, rates=0.0):
        """The linear plant `xd = A x + B u`, `y = C x + D u` at frozen lengths [m]
        and constant rates [m/s] (accelerations 0), `x = [q; qd]` (model.md §12).

        Inputs `u`: `loads.INPUT_NAMES`; outputs `y`: `loads.OUTPUT_NAMES` (4 tip
        deflections [m], 4 root moments [N m]); `D = 0`.
        """
        lengths = per_boom(lengths, "lengths", positive=True)
        M, C, K = self.matrices(lengths, rates, 0.0)
        n = self.n
        factor = scipy.linalg.cho_factor(M)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -scipy.linalg.cho_solve(factor, K)
        A[n:, n:] = -scipy.linalg.cho_solve(factor, C)
        B = np.zeros((2 * n, N_INPUTS))
        B[n:] = scipy.linalg.cho_solve(factor, self.input_matrix(lengths))
        C_out = np.zeros((8, 2 * n))
        C_out[:4, :n] = self._tip_rows
        C_out[4:, :n] = (
            self.params.boom_bending_stiffness * self._curvature_rows / lengths[:, None] ** 2
        )
        return A, B, C_out, np.zeros((8, N_INPUTS))

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """`evaluate` without the checks, for arrays of 4 already checked (the stepper's
        hot path; `stepper.LinearSystem`)."""
        return self.assembler.evaluate(outputs, lengths, rates, accelerations)

    def assemble_blocks(self, outputs, lengths, rates, accelerations):
        """`assemble` as unassembled boom and quadrant blocks (`blocks.BlockMatrices`;
        `stepper.LinearSystem`)."""
        return self.assembler.evaluate_blocks(outputs, lengths, rates, accelerations)

    def output_rows(self, lengths) -> np.ndarray:
        """(8, n): tip deflections [m] and root moments [N m] per unit coordinate at 4
        checked `lengths` (`loads.OUTPUT_NAMES`; `stepper.LinearSystem`)."""
        moments = self.params.boom_bending_stiffness * self._curvature_rows / lengths[:, None] ** 2
        return np.concatenate([self._tip_rows, moments])

    def resolved_frequency(self, lengths) -> float:
        """The highest angular frequency [rad/s] a time step must resolve at these
        lengths: the first cantilever frequency of the shortest bare boom,
        `beta_1^2 sqrt(EI / rho_B) / L_min^2`, an upper bound of the dominant
        boom-bending frequency (the membrane only adds mass to a boom)."""
        return self._cantilever_constant / float(np.min(lengths)) ** 2

    # time integration ----------------------------------------------------------
    def stepper(self, profile, q0=None, qd0=None, t0: float = 0.0, **options) -> SailStepper:
        """A `SailStepper` holding this model's state (see `stepper.py`).

        `options`: `rtol`, `atol` (the tolerance), `max_step` [s],
        `resolved_frequency` [rad/s], `inputs` (a callable `t -> u`, see `loads`).
        """
        return SailStepper(self, profile, q0=q0, qd0=qd0, t0=t0, **options)

    def simulate(
        self,
        profile,
        t_end: float,
        q0=None,
        qd0=None,
        t_eval=None,
        loads=None,
        progress=None,
        **options,
    ):
        """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`; returns
        `(t, q, qd)`. `loads`: None, a constant pair `(pressures, tip_forces)` or a
        callable `t -> (pressures, tip_forces)` (sampled at each step's midpoint; a
        load step lands on a step boundary when its time is one of `t_eval`). The
        other arguments are those of `integrate.simulate`."""
        return simulate(
            self,
            profile,
            t_end,
            q0=q0,
            qd0=qd0,
            t_eval=t_eval,
            progress=progress,
            inputs=input_function(loads),
            **options,
        )

    def simulate_on_grid(
        self, profile, t_end: float, spacing: float, q0=None, qd0=None, loads=None, **options
    ):
        """`integrate.simulate_on_grid`: the states every `spacing` [s] to `t_end` [s],
        stepped and sampled as the simulator does; `loads` as in `simulate`."""
        return simulate_on_grid(
            self, profile, t_end, spacing, q0=q0, qd0=qd0, inputs=input_function(loads), **options
        )

    # derived quantities --------------------------------------------------------
    def _boom_rows(self, values) -> np.ndarray:
        """(4, n): row k holds `values` (one per mode) at boom k's coordinates."""
        rows = np.zeros((4, self.n))
        for k in range(4):
            rows[k, self.layout.boom_slots(k)] = values
        return rows

    def tip_deflections(self, q) -> np.ndarray:
        """Boom-tip deflections `u_k(L_k) = psi(1)^T p_k` [m] (4 values, a..d).

        `q` may be one state (n,) or a series (..., n); works for velocities too.
        """
        return np.asarray(q) @ self._tip_rows.T

    def sample(self, t: float, lengths, rates, q, qd) -> StateSample:
        """The state at `t` [s] with its tip deflections, their rates and the root
        moments."""
        tips, tip_rates = self.tip_deflections(q), self.tip_deflections(qd)
        moments = self.root_moments(q, lengths)
        return StateSample(t, lengths, rates, q, qd, tips, tip_rates, moments)

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
