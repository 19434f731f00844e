"""The whole sail: four booms and four membrane quadrants (seed Eq. 2 and 3).

    M qdd + (Md + G - G^T + S_h + C_d) qd + (Gd + K - N) q = B_u(L) u

with `q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]` (model.md §6), the
Rayleigh damping `C_d` and the inputs `u` (pressures and tip forces, `loads`)
of model.md §12; with both zero it is the seed's equation. With a free hub
(model.md §13) `q` ends with the hub's heave and tilts `z_h, theta_x, theta_y`,
`S_h` is the spin hold's gyroscopic term, `C_d` damps the motion relative to
the mean axes, and `u` ends with the hub wrench `F_z, tau_x, tau_y`.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from sail_ros.integrate.driver import simulate, simulate_on_grid
from sail_ros.integrate.stepper import SailStepper
from sail_ros.model import hub, linear
from sail_ros.model.assembly import (
    DAMPING,
    MASS,
    STIFFNESS,
    STIFFNESS_EQ,
    STRUCTURAL_DAMPING,
    Constants,
    SystemAssembler,
)
from sail_ros.model.basis import cantilever_roots, pinned_free_root
from sail_ros.model.integrals import (
    boom_integrals,
    check_affordable,
    default_quadrature_order,
    quadrant_integrals,
)
from sail_ros.model.layout import (
    BOOMS,
    QUADRANT_BOOMS,
    QUADRANTS,
    Layout,
    per_boom,
)
from sail_ros.model.linear import without_rigid
from sail_ros.model.loads import (
    N_INPUTS,
    input_function,
    inputs,
)
from sail_ros.model.parameters import SailParameters
from sail_ros.model.readout import Readout

# A free hub turns a boom's root from clamped into guided (hub heaving) or pinned (hub
# tilting) when light: the pinned-free frequency is the highest, (3.92660 / 1.87510)^2 =
# 4.39 times the clamped-free one (model.md §13.7), so the step rule's bound is raised
# by that factor.
FREE_HUB_FREQUENCY_FACTOR = float((pinned_free_root() / cantilever_roots(1)[0]) ** 2)


def boom_frequency_bound(params: SailParameters, length: float) -> float:
    """The highest frequency [rad/s] a time step must resolve on a boom of `length` [m]:
    its `cantilever_frequency`, times FREE_HUB_FREQUENCY_FACTOR with a free hub."""
    factor = FREE_HUB_FREQUENCY_FACTOR if params.free_hub else 1.0
    return factor * cantilever_frequency(params, length)


def cantilever_frequency(params: SailParameters, length: float) -> float:
    """First bending frequency [rad/s] of a bare boom of `length` [m] clamped at the
    hub (`cantilever_frequencies`)."""
    return float(cantilever_frequencies(params, float(length), 1)[0])


def cantilever_frequencies(params: SailParameters, lengths, n_modes: int) -> np.ndarray:
    """Bending frequencies [rad/s] of the first `n_modes` modes of bare booms of `lengths`
    [m] (any shape) clamped at the hub, `beta_j^2 sqrt(EI / rho_B) / L^2` (they grow
    like 1/L^2 as a boom shortens): shape `lengths.shape + (n_modes,)`."""
    constant = cantilever_roots(n_modes) ** 2 * np.sqrt(
        params.boom_bending_stiffness / params.boom_linear_density
    )
    return constant / np.asarray(lengths, dtype=float)[..., None] ** 2


class SailModel(Readout):
    """Modal model of the four-boom, four-quadrant sail.

    The reference integrals for `(n_B, n_M)` are built once (and cached across
    instances and, on disk, across processes: `integral_store`); every call below only
    scales and adds them.

    Args:
        params: physical parameters and mode counts (`n_membrane_modes` 0: the automatic
            count, `SailParameters.membrane_modes`).
        quadrature_order: Gauss points per direction for the reference
            integrals; the default resolves every basis product.
    """

    def __init__(self, params: SailParameters | None = None, quadrature_order: int | None = None):
        self.params = params if params is not None else SailParameters()
        nb, nm = self.params.n_boom_modes, self.params.membrane_modes
        self.n_boom_modes, self.n_membrane_modes = nb, nm
        order = quadrature_order or default_quadrature_order(nb, nm)
        check_affordable(nb, nm, order)
        layout = Layout(nb, nm, free_hub=self.params.free_hub)
        super().__init__(layout, boom_integrals(nb, order), self.params.boom_bending_stiffness)
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
                full_boom_length=self.params.full_boom_length,
            ),
            hub=self._hub_constants(),
        )
        self._cantilever_constant = boom_frequency_bound(self.params, 1.0)  # [rad/s at 1 m]
        self._stowed_limit = None  # [m] the longest boom the stowed material allows
        if self.free_hub and self.params.stowed_mass_on_hub:
            self._stowed_limit = self.params.full_boom_length * (1.0 + 1e-12)
        self._unit_inputs = self._unit_input_matrix()

    def _hub_constants(self):
        """`(m_h, J_x, J_y, stowed)` for the assembler, or None with a clamped hub."""
        if not self.free_hub:
            return None
        p = self.params
        return p.hub_mass, p.hub_inertia_x, p.hub_inertia_y, p.stowed_mass_on_hub

    def _lengths(self, lengths) -> np.ndarray:
        """4 checked lengths [m]; with stowed material on a free hub, none above `L_f`."""
        lengths = per_boom(lengths, "lengths", positive=True)
        if self.free_hub and self.params.stowed_mass_on_hub:
            self._check_stowed(lengths, "lengths")
        return lengths

    def _check_stowed(self, lengths, name) -> None:
        full = self.params.full_boom_length
        # a length that rounds to L_f is L_f (a profile that ends there)
        over = lengths > full * (1.0 + 1e-12)
        if not over.any():
            return
        k = int(np.argmax(over))
        raise ValueError(
            f"{name}: boom {BOOMS[k]} is {float(lengths[k])!r} m, longer than the full boom "
            f"length a / sqrt(2) = {full:.6g} m, with the stowed material on the hub "
            f"(stowed_mass_on_hub)"
        )

    # matrices ----------------------------------------------------------------
    def evaluate(self, outputs, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """Matrices named by `outputs` (see `assembly`), stacked (len(outputs), n, n);
        lengths, rates and accelerations are checked (`per_boom`)."""
        return self.assemble(
            outputs,
            self._lengths(lengths),
            per_boom(rates, "rates"),
            per_boom(accelerations, "accelerations"),
        )

    def matrices(self, lengths, rates=0.0, accelerations=0.0):
        """`M, C, K` of `M qdd + C qd + K q = Q` (seed Eq. 2, model.md §12, §13).

        `C = Md + G - G^T + S_h + C_d` (with the Rayleigh damping `C_d` and, free hub,
        the spin hold's `S_h`) and `K = Gd + K_elastic - N` (model.md §4).

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
        `-sqrt(-omega^2)`, so negative entries mark divergent modes. With a free
        hub the first three are the rigid-body modes, exactly 0.0, and the others
        solve `K_qq v = omega^2 M_r,qq v` (model.md §13.6).
        """
        if self.free_hub:
            omega2 = self.normal_modes(lengths)[0]
        else:
            M, K = self.mass_and_stiffness(lengths)
            omega2 = scipy.linalg.eigh(K, M, eigvals_only=True)
        return np.sign(omega2) * np.sqrt(np.abs(omega2))

    def normal_modes(self, lengths):
        """`(omega^2, V)` at rest: eigenvalues [rad^2/s^2], ascending, and `M`-orthonormal
        mode vectors as columns (`V^T M V = I`, `K V = M V diag(omega^2)`).

        With a free hub (model.md §13.6) the first three are the rigid-body modes,
        `omega^2 = 0.0` exactly, `V = [0; L^-T]` with `M_hh = L L^T`; the others solve
        `K_qq v = omega^2 M_r,qq v` and are lifted to `(v, -M_hh^-1 M_hq v)`.
        """
        M, K = self.mass_and_stiffness(lengths)
        return self.modes_of(M, K)

    def modes_of(self, M: np.ndarray, K: np.ndarray):
        """`normal_modes` from `M` and `K` already assembled (`integrate.system.LinearSystem`)."""
        return hub.free_modes(self, M, K) if self.free_hub else scipy.linalg.eigh(K, M)

    def state_matrix(self, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """`A` of the first-order form `xd = A x`, `x = [qd; q]` (seed Eq. 3;
        `linear.state_matrix`)."""
        return linear.state_matrix(self, lengths, rates, accelerations)

    def eigenvalues(self, lengths, rates=0.0) -> np.ndarray:
        """Eigenvalues [1/s] of Eq. 3 at frozen lengths with constant rates, sorted by
        imaginary part, then real part (`linear.eigenvalues`)."""
        return linear.eigenvalues(self, lengths, rates)

    def elastic_eigenvalues(self, lengths, rates=0.0) -> np.ndarray:
        """`eigenvalues` without a free hub's six rigid-body ones (`without_rigid`): those
        a stability criterion judges (model.md §13.6)."""
        return without_rigid(self.eigenvalues(lengths, rates), self.free_hub)

    def structural_damping(self, lengths) -> np.ndarray:
        """The Rayleigh damping [N s/m] at these lengths: `C_d = alpha M + beta K`, with
        a free hub `alpha M_r + beta K`, `M_r = M - M[:,h] M_hh^-1 M[h,:]` (model.md
        §13.5: no damping of the rigid-body motion)."""
        return self.evaluate((STRUCTURAL_DAMPING,), lengths)[0]

    # loads and outputs (model.md §12, §13.5) ------------------------------------
    def _unit_input_matrix(self) -> np.ndarray:
        """`B_u`'s elastic rows with every quadrant's `L_a L_b` factor left out (n, 8)."""
        matrix = np.zeros((self.n, N_INPUTS))
        for j, quadrant in enumerate(QUADRANTS):
            matrix[self.layout.quadrant_slots(quadrant), j] += self.quadrant_integrals.s_mean
        for k in range(4):
            matrix[self.layout.boom_slots(k), 4 + k] = self.boom_integrals.tip
        return matrix

    def input_matrix(self, lengths) -> np.ndarray:
        """`B_u` (n, 8), free hub (n, 11): generalised forces per unit input, `Q = B_u u`,
        inputs in the order of `input_names` (4 pressures [Pa], 4 tip forces [N], then
        `F_z` [N], `tau_x`, `tau_y` [N m]).

        A pressure `p` on `Q_ab` does the virtual work `p L_a L_b <S>`, so it loads
        that quadrant's membrane modes and its two booms; a tip force `F` on boom
        k does `F psi(1)` on `p_k`. With a free hub they also push and tilt the hub
        (virtual work on the absolute deflection, model.md §13.5): `p L_a L_b / 2`
        on `z_h` and `p L_a L_b (L_a d_a + L_b d_b) / 6` on `theta`; `F` and
        `F L_k d_k`."""
        return self.assemble_inputs(self._lengths(lengths))

    def assemble_inputs(self, lengths) -> np.ndarray:
        """`input_matrix` for 4 already checked lengths (the stepper's hot path)."""
        first, second = QUADRANT_BOOMS
        scale = np.concatenate([lengths[first] * lengths[second], np.ones(4)])
        if not self.free_hub:
            return self._unit_inputs * scale
        return hub.with_hub_inputs(self, self._unit_inputs * scale, lengths)

    def load_vector(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0) -> np.ndarray:
        """Generalised forces `Q` (n,) [N] of the given pressures [Pa] (a scalar or 4
        values, quadrants ab, bc, cd, da), tip forces [N] (booms a..d) and hub wrench
        `(F_z [N], tau_x [N m], tau_y [N m])` (non-zero only with a free hub)."""
        u = inputs(pressures, tip_forces, hub_wrench, free_hub=self.free_hub)
        return self.input_matrix(lengths) @ u

    def static_deflection(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
        """Coordinates of the sail under constant loads (`linear.static_deflection`)."""
        return linear.static_deflection(self, lengths, pressures, tip_forces, hub_wrench)

    def rigid_body_acceleration(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
        """A free sail's uniform acceleration under constant loads (3,) [m/s^2, rad/s^2,
        rad/s^2] (`linear.rigid_body_acceleration`)."""
        return linear.rigid_body_acceleration(self, lengths, pressures, tip_forces, hub_wrench)

    def hold_loads(self, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """`(F_x [N], F_y [N], tau_z [N m])` a free hub's holds supply (`hub.hold_loads`)."""
        return hub.hold_loads(self, lengths, rates, accelerations)

    def momenta(self, q, qd, lengths, rates=0.0) -> tuple[float, float, float]:
        """`(p_z [kg m/s], H_x [kg m^2/s], H_y [kg m^2/s])` of a free sail (`hub.momenta`)."""
        return hub.momenta(self, q, qd, lengths, rates)

    def state_space(self, lengths, rates=0.0):
        """The linear plant `(A, B, C, D)` at frozen lengths [m] and constant rates [m/s],
        `x = [q; qd]` (model.md §12; `linear.state_space`)."""
        return linear.state_space(self, lengths, rates)

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """`evaluate` without the checks, for arrays of 4 already checked (the stepper's
        hot path; `integrate.system.LinearSystem`); only a length beyond the stowed material's
        reach is refused (free hub with `stowed_mass_on_hub`)."""
        if self._stowed_limit is not None and lengths.max() > self._stowed_limit:
            self._check_stowed(lengths, "lengths")
        return self.assembler.evaluate(outputs, lengths, rates, accelerations)

    def assemble_blocks(self, outputs, lengths, rates, accelerations):
        """`assemble` as unassembled boom and quadrant blocks, with the hub's rows and
        columns as a border when it is free (`blocks.BlockMatrices`;
        `integrate.system.LinearSystem`)."""
        if self._stowed_limit is not None and lengths.max() > self._stowed_limit:
            self._check_stowed(lengths, "lengths")
        return self.assembler.evaluate_blocks(outputs, lengths, rates, accelerations)

    def resolved_frequency(self, lengths) -> float:
        """The highest angular frequency [rad/s] a time step must resolve at these
        lengths: the first cantilever frequency of the shortest bare boom,
        `beta_1^2 sqrt(EI / rho_B) / L_min^2`, an upper bound of the dominant
        boom-bending frequency (the membrane only adds mass to a boom); with a free
        hub 4.39 times that (`FREE_HUB_FREQUENCY_FACTOR`: a light hub pins a boom's
        root, model.md §13.7)."""
        return self._cantilever_constant / float(np.asarray(lengths, dtype=float).min()) ** 2

    # time integration ----------------------------------------------------------
    def stepper(self, profile, q0=None, qd0=None, t0: float = 0.0, **options) -> SailStepper:
        """A `SailStepper` holding this model's state (see `stepper.py`).

        `options`: `rtol`, `atol` (the tolerance), `max_step` [s],
        `resolved_frequency` [rad/s], `inputs` (a callable `t -> u`, see `loads`).
        """
        return SailStepper(self, profile, q0=q0, qd0=qd0, t0=t0, **options)

    def simulate(self, profile, t_end: float, q0=None, qd0=None, t_eval=None, loads=None,
                 **options):  # fmt: skip
        """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`; returns
        `(t, q, qd)` at `t_eval` (`integrate.driver.simulate`: `progress`, `observer`,
        `rates`, the stepper's options). `loads`: None, a constant pair `(pressures, tip_forces)` or
        triple with a free hub's `hub_wrench` `(F_z [N], tau_x [N m], tau_y [N m])`, or a
        callable `t ->` either, or a `loads.LoadSchedule`."""
        inputs = input_function(loads, self.free_hub)
        return simulate(self, profile, t_end, q0, qd0, t_eval, inputs=inputs, **options)

    def simulate_on_grid(self, profile, t_end: float, spacing: float, q0=None, qd0=None,
                         loads=None, **options):  # fmt: skip
        """The states every `spacing` [s] to `t_end` [s], stepped and sampled as the
        simulator does (`integrate.driver.simulate_on_grid`); `loads` as in `simulate`."""
        inputs = input_function(loads, self.free_hub)
        return simulate_on_grid(self, profile, t_end, spacing, q0, qd0, inputs=inputs, **options)

    def energy(self, q, qd, lengths) -> float:
        """Mechanical energy `1/2 qd^T M qd + 1/2 q^T K q` [J] at the given lengths."""
        M, K = self.mass_and_stiffness(lengths)
        q, qd = np.asarray(q), np.asarray(qd)
        return 0.5 * float(qd @ M @ qd) + 0.5 * float(q @ K @ q)
