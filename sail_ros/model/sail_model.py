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

from sail_ros.model.assembly import (
    DAMPING,
    GYROSCOPIC,
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
from sail_ros.model.integrate import simulate, simulate_on_grid
from sail_ros.model.layout import (
    BOOM_DIRECTIONS,
    BOOMS,
    QUADRANTS,
    Layout,
    hub_tilt_axis,
    per_boom,
)
from sail_ros.model.loads import (
    CLAMPED,
    HUB_INPUT_NAMES,
    HUB_INPUT_UNITS,
    HUB_OUTPUT_NAMES,
    HUB_OUTPUT_UNITS,
    INPUT_NAMES,
    INPUT_UNITS,
    N_INPUTS,
    OUTPUT_NAMES,
    OUTPUT_UNITS,
    input_function,
    inputs,
)
from sail_ros.model.parameters import SailParameters
from sail_ros.model.record import StateSample
from sail_ros.model.stepper import SailStepper

# A free hub turns a boom's root from clamped into guided (hub heaving) or pinned (hub
# tilting) when light: the pinned-free frequency is the highest, (3.92660 / 1.87510)^2 =
# 4.39 times the clamped-free one (model.md §13.10), so the step rule's bound is raised
# by that factor.
FREE_HUB_FREQUENCY_FACTOR = float((pinned_free_root() / cantilever_roots(1)[0]) ** 2)


def without_rigid(eigenvalues, free_hub: bool) -> np.ndarray:
    """`eigenvalues` of Eq. 3 without the six smallest in modulus when the hub is free:
    its rigid-body modes, 0 at rest, slow while the booms move (the mass and tilt
    inertia change; model.md §13.6), far below the first elastic frequency. They are no
    vibration, so stability studies leave them out; the order is kept."""
    eigenvalues = np.asarray(eigenvalues)
    if not free_hub:
        return eigenvalues
    rigid = np.argsort(np.abs(eigenvalues), kind="stable")[:6]
    return np.delete(eigenvalues, rigid)


def boom_frequency_bound(params: SailParameters, length: float) -> float:
    """The highest frequency [rad/s] a time step must resolve on a boom of `length` [m]:
    its `cantilever_frequency`, times FREE_HUB_FREQUENCY_FACTOR with a free hub."""
    factor = FREE_HUB_FREQUENCY_FACTOR if params.free_hub else 1.0
    return factor * cantilever_frequency(params, length)


def cantilever_frequency(params: SailParameters, length: float) -> float:
    """First bending frequency [rad/s] of a bare boom of `length` [m] clamped at the
    hub: `beta_1^2 sqrt(EI / rho_B) / L^2` (it grows like 1/L^2 as the boom shortens)."""
    constant = float(cantilever_roots(1)[0] ** 2) * np.sqrt(
        params.boom_bending_stiffness / params.boom_linear_density
    )
    return constant / float(length) ** 2


def _in_plane_momenta(params: SailParameters, lengths, rates, accelerations):
    """`(P, Pd, H_z, Hd_z)` of the deploying material (model.md §13.3): in-plane momentum
    `P` (2,) [kg m/s] in the `sail` frame and its rate [N], spin momentum about z `H_z`
    [kg m^2/s] (the film's; booms carry none) and its rate [N m]."""
    rho_b, rho_m = params.boom_linear_density, params.membrane_areal_density
    L, Ld, Ldd = lengths, rates, accelerations
    P = rho_b * (L * Ld) @ BOOM_DIRECTIONS
    Pd = rho_b * (Ld**2 + L * Ldd) @ BOOM_DIRECTIONS
    spin = spin_rate = 0.0
    for _, a, b in QUADRANTS:
        e_a, e_b = BOOM_DIRECTIONS[a], BOOM_DIRECTIONS[b]
        area = L[a] * L[b]
        velocity = Ld[a] * e_a + Ld[b] * e_b
        P = P + rho_m * 0.5 * area * velocity
        Pd = Pd + rho_m * (
            0.5 * (Ld[a] * L[b] + L[a] * Ld[b]) * velocity
            + 0.5 * area * (Ldd[a] * e_a + Ldd[b] * e_b)
        )
        spin += rho_m * area * (L[a] * Ld[b] - L[b] * Ld[a]) / 6.0
        spin_rate += (rho_m / 6.0) * (
            L[a] ** 2 * (Ld[b] ** 2 + L[b] * Ldd[b]) - L[b] ** 2 * (Ld[a] ** 2 + L[a] * Ldd[a])
        )
    return P, Pd, spin, spin_rate


def _first_order(M, C, K) -> np.ndarray:
    """`A = [-M^-1 C, -M^-1 K; I, 0]` of `M qdd + C qd + K q = 0`, `x = [qd; q]`."""
    n = M.shape[0]
    factor = scipy.linalg.cho_factor(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, :n] = -scipy.linalg.cho_solve(factor, C)
    A[:n, n:] = -scipy.linalg.cho_solve(factor, K)
    A[n:, :n] = np.eye(n)
    return A


def _modal_eigenvalues(M, C, K) -> np.ndarray | None:
    """The eigenvalues of `M qdd + C qd + K q = 0` from the modes of `(K, M)` when they
    decouple it (at rest, with Rayleigh damping: `V^T C V` diagonal to round-off), each
    mode's two roots of `lambda^2 + d lambda + omega^2 = 0`; None otherwise (`K` not
    symmetric to round-off, or `C` coupling the modes). A symmetric eigenproblem of
    size n costs a fraction of the general one of size 2 n, and an undamped mode's
    roots are exactly imaginary."""
    if np.abs(K - K.T).max() > 1e-12 * np.abs(K).max():
        return None
    lam, V = scipy.linalg.eigh(0.5 * (K + K.T), M)
    modal = V.T @ C @ V
    d = np.diag(modal).copy()
    np.fill_diagonal(modal, 0.0)
    if np.abs(modal).max() > 1e-12 * max(np.abs(d).max(), np.sqrt(np.abs(lam).max())):
        return None
    root = np.sqrt((0.25 * d * d - lam).astype(complex))
    return np.concatenate([-0.5 * d + root, -0.5 * d - root])


class SailModel:
    """Modal model of the four-boom, four-quadrant sail.

    The reference integrals for `(n_B, n_M)` are built once (and cached across
    instances); every call below only scales and adds them.

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
        self.free_hub = self.params.free_hub
        self.layout = Layout(nb, nm, free_hub=self.free_hub)
        self.n = self.layout.n
        self.n_elastic = self.layout.n_elastic
        self.hub_slice = self.layout.hub_slice
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
                full_boom_length=self.params.full_boom_length,
            ),
            hub=self._hub_constants(),
        )
        self._cantilever_constant = boom_frequency_bound(self.params, 1.0)  # [rad/s at 1 m]
        self._stowed_limit = None  # [m] the longest boom the stowed material allows
        if self.free_hub and self.params.stowed_mass_on_hub:
            self._stowed_limit = self.params.full_boom_length * (1.0 + 1e-12)
        self._tip_rows = self._boom_rows(self.boom_integrals.tip)
        self._curvature_rows = self._boom_rows(self.boom_integrals.root_curvature)
        # (8, n): tip deflections, then root moments times L_k^2: the output rows free of
        # the lengths (`output_rows` divides the moments by L_k^2)
        self.length_free_rows = np.vstack(
            [self._tip_rows, self.params.boom_bending_stiffness * self._curvature_rows]
        )
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

    @property
    def input_names(self) -> tuple[str, ...]:
        """The inputs `u` in order: 4 pressures, 4 tip forces (`loads.INPUT_NAMES`),
        then, with a free hub, `hub_force_z`, `hub_torque_x`, `hub_torque_y`."""
        return INPUT_NAMES + (HUB_INPUT_NAMES if self.free_hub else ())

    @property
    def input_units(self) -> tuple[str, ...]:
        return INPUT_UNITS + (HUB_INPUT_UNITS if self.free_hub else ())

    @property
    def output_names(self) -> tuple[str, ...]:
        """The plant's outputs: 4 tip deflections, 4 root moments (`loads.OUTPUT_NAMES`),
        then, with a free hub, `hub_heave`, `hub_tilt_x`, `hub_tilt_y` and their rates."""
        return OUTPUT_NAMES + (HUB_OUTPUT_NAMES if self.free_hub else ())

    @property
    def output_units(self) -> tuple[str, ...]:
        return OUTPUT_UNITS + (HUB_OUTPUT_UNITS if self.free_hub else ())

    def _require_free_hub(self) -> None:
        if not self.free_hub:
            raise ValueError(CLAMPED)

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
        """`normal_modes` from `M` and `K` already assembled (`stepper.LinearSystem`)."""
        if not self.free_hub:
            return scipy.linalg.eigh(K, M)
        e, h = slice(0, self.n_elastic), self.hub_slice
        factor = scipy.linalg.cho_factor(M[h, h])
        lift = scipy.linalg.cho_solve(factor, M[h, e])  # M_hh^-1 M_hq
        reduced = M[e, e] - M[e, h] @ lift
        omega2, elastic = scipy.linalg.eigh(K[e, e], 0.5 * (reduced + reduced.T))
        V = np.zeros((self.n, self.n))
        lower = np.linalg.cholesky(M[h, h])
        V[h, :3] = np.linalg.inv(lower).T
        V[e, 3:] = elastic
        V[h, 3:] = -lift @ elastic
        return np.concatenate([np.zeros(3), omega2]), V

    def state_matrix(self, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """`A` of the first-order form `xd = A x`, `x = [qd; q]` (seed Eq. 3).

        `A = [-M^-1 C, -M^-1 K_eq; I, 0]`.
        """
        return _first_order(*self.matrices(lengths, rates, accelerations))

    def eigenvalues(self, lengths, rates=0.0) -> np.ndarray:
        """Eigenvalues [1/s] of Eq. 3 at frozen lengths with constant rates.

        Accelerations are zero. Sorted by imaginary part, then real part; any
        positive real part means the frozen system is unstable. With a free hub at
        rest, six are the rigid-body modes, exactly 0, and the others those of the
        reduced system `(M_r,qq, C_qq, K_qq)` (model.md §13.6); while booms move the
        rigid ones leave zero, the six smallest in modulus.
        """
        rates = per_boom(rates, "rates")
        eig = None
        if self.free_hub and not rates.any():
            M, C, K = self.matrices(lengths)
            e, h = slice(0, self.n_elastic), self.hub_slice
            reduced = M[e, e] - M[e, h] @ np.linalg.solve(M[h, h], M[h, e])
            eig = np.concatenate(
                [np.zeros(6), np.linalg.eigvals(_first_order(reduced, C[e, e], K[e, e]))]
            )
        elif not rates.any():
            eig = _modal_eigenvalues(*self.matrices(lengths))
        if eig is None:
            eig = np.linalg.eigvals(self.state_matrix(lengths, rates, 0.0))
        return eig[np.lexsort((eig.real, eig.imag))]

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
        first = [q.first for q in QUADRANTS]
        second = [q.second for q in QUADRANTS]
        scale = np.concatenate([lengths[first] * lengths[second], np.ones(4)])
        if not self.free_hub:
            return self._unit_inputs * scale
        matrix = np.zeros((self.n, N_INPUTS + 3))
        matrix[:, :N_INPUTS] = self._unit_inputs * scale
        hub = matrix[self.hub_slice]  # rows z_h, theta_x, theta_y (a view)
        area = lengths[first] * lengths[second]
        hub[0, :4] = 0.5 * area
        hub[0, 4:8] = 1.0
        hub[:, 8:] = np.eye(3)
        for j, quadrant in enumerate(QUADRANTS):
            for boom in (quadrant.first, quadrant.second):  # the arm: that boom's length
                axis, sign = hub_tilt_axis(boom)
                hub[1 + axis, j] += sign * area[j] * lengths[boom] / 6.0
        for k in range(4):
            axis, sign = hub_tilt_axis(k)
            hub[1 + axis, 4 + k] = sign * lengths[k]
        return matrix

    def load_vector(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0) -> np.ndarray:
        """Generalised forces `Q` (n,) [N] of the given pressures [Pa] (a scalar or 4
        values, quadrants ab, bc, cd, da), tip forces [N] (booms a..d) and hub wrench
        `(F_z [N], tau_x [N m], tau_y [N m])` (non-zero only with a free hub)."""
        u = inputs(pressures, tip_forces, hub_wrench, free_hub=self.free_hub)
        return self.input_matrix(lengths) @ u

    def static_deflection(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
        """Coordinates of the sail under constant loads: with a clamped hub at rest,
        `q = K^-1 Q`; with a free hub the deflection `q_s` riding on the uniformly
        accelerating rigid motion (inertia relief, model.md §13.6),
        `q_s = K_qq^-1 (Q_q - M_qh a)` with `a = rigid_body_acceleration(...)`, its hub
        entries 0.

        Raises:
            ValueError: the sail is buckled or neutrally stable (K not positive
                definite): it has no static answer; a hub wrench on a clamped hub.
        """
        M, K = self.mass_and_stiffness(lengths)
        Q = self.load_vector(lengths, pressures, tip_forces, hub_wrench)
        e = slice(0, self.n_elastic)
        deflection = np.zeros(self.n)
        if self.free_hub:
            Q = Q[e] - M[e, self.hub_slice] @ self._hub_acceleration(M, Q)
            K = K[e, e]
        try:
            deflection[e] = scipy.linalg.cho_solve(scipy.linalg.cho_factor(K), Q)
        except np.linalg.LinAlgError:
            why = (
                f"membrane_prestress = {self.params.membrane_prestress:g} Pa: the film "
                "has no out-of-plane stiffness"
                if self.params.membrane_prestress <= 0.0
                else "an axial load at or above buckling"
            )
            raise ValueError(
                f"the stiffness is not positive definite at these lengths ({why}): no "
                "static deflection"
            ) from None
        return deflection

    def rigid_body_acceleration(self, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
        """The free sail's uniform acceleration under constant loads (model.md §13.6):
        `a = M_hh^-1 Q_h` (3,) [m/s^2, rad/s^2, rad/s^2] of `z_h`, `theta_x`, `theta_y`.

        Raises:
            ValueError: the hub is clamped.
        """
        self._require_free_hub()
        M, _ = self.mass_and_stiffness(lengths)
        Q = self.load_vector(lengths, pressures, tip_forces, hub_wrench)
        return self._hub_acceleration(M, Q)

    def _hub_acceleration(self, M, Q) -> np.ndarray:
        h = self.hub_slice
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(M[h, h]), Q[h])

    def hold_loads(self, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
        """`(F_x [N], F_y [N], tau_z [N m])` the holds of a free hub supply (model.md
        §13.3): the force in the inertial x-y plane at the hub centre, the rate of the
        in-plane momentum `P` of the deploying material, and the torque about body z,
        the rate of its spin momentum `H_z`. Zero for point-symmetric motion."""
        motion = (
            self._lengths(lengths),
            per_boom(rates, "rates"),
            per_boom(accelerations, "accelerations"),
        )
        _, force, _, torque = _in_plane_momenta(self.params, *motion)
        return np.array([force[0], force[1], torque])

    def momenta(self, q, qd, lengths, rates=0.0) -> tuple[float, float, float]:
        """`(p_z [kg m/s], H_x [kg m^2/s], H_y [kg m^2/s])`: the linear momentum along
        inertial z and the angular momentum about the inertial x, y axes of hub,
        stowed and deployed material (model.md §13.5, first order):
        `p_z = (M qd + G q)_z`, `H_x = (M qd + G q)_thx - z_h P_y + theta_y H_z`,
        `H_y = (M qd + G q)_thy + z_h P_x - theta_x H_z`.

        Raises:
            ValueError: the hub is clamped.
        """
        self._require_free_hub()
        lengths, rates = self._lengths(lengths), per_boom(rates, "rates")
        M, G = self.assemble((MASS, GYROSCOPIC), lengths, rates, np.zeros(4))
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        canonical = (M @ qd + G @ q)[self.hub_slice]
        z, theta_x, theta_y = q[self.hub_slice]
        P, _, spin, _ = _in_plane_momenta(self.params, lengths, rates, np.zeros(4))
        return (
            float(canonical[0]),
            float(canonical[1] - z * P[1] + theta_y * spin),
            float(canonical[2] + z * P[0] - theta_x * spin),
        )

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

        Inputs `u`: `input_names`; outputs `y`: `output_names` (4 tip deflections
        [m] and 4 root moments [N m] relative to the hub; with a free hub then
        `z_h` [m], `theta_x`, `theta_y` [rad] and their rates, which hold double
        integrators: `A` is singular, model.md §13.6); `D = 0`.
        """
        lengths = self._lengths(lengths)
        M, C, K = self.matrices(lengths, rates, 0.0)
        n = self.n
        factor = scipy.linalg.cho_factor(M)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -scipy.linalg.cho_solve(factor, K)
        A[n:, n:] = -scipy.linalg.cho_solve(factor, C)
        inputs_matrix = self.input_matrix(lengths)
        B = np.zeros((2 * n, inputs_matrix.shape[1]))
        B[n:] = scipy.linalg.cho_solve(factor, inputs_matrix)
        C_out = np.zeros((len(self.output_names), 2 * n))
        C_out[:4, :n] = self._tip_rows
        C_out[4:8, :n] = (
            self.params.boom_bending_stiffness * self._curvature_rows / lengths[:, None] ** 2
        )
        if self.free_hub:
            hub = np.arange(self.n_elastic, n)
            C_out[8:11, hub] = np.eye(3)
            C_out[11:14, n + hub] = np.eye(3)
        return A, B, C_out, np.zeros((C_out.shape[0], B.shape[1]))

    def assemble(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """`evaluate` without the checks, for arrays of 4 already checked (the stepper's
        hot path; `stepper.LinearSystem`); only a length beyond the stowed material's
        reach is refused (free hub with `stowed_mass_on_hub`)."""
        if self._stowed_limit is not None and lengths.max() > self._stowed_limit:
            self._check_stowed(lengths, "lengths")
        return self.assembler.evaluate(outputs, lengths, rates, accelerations)

    def assemble_blocks(self, outputs, lengths, rates, accelerations):
        """`assemble` as unassembled boom and quadrant blocks, with the hub's rows and
        columns as a border when it is free (`blocks.BlockMatrices`;
        `stepper.LinearSystem`)."""
        if self._stowed_limit is not None and lengths.max() > self._stowed_limit:
            self._check_stowed(lengths, "lengths")
        return self.assembler.evaluate_blocks(outputs, lengths, rates, accelerations)

    def output_rows(self, lengths) -> np.ndarray:
        """(8, n): tip deflections [m] and root moments [N m] per unit coordinate at 4
        checked `lengths` (`loads.OUTPUT_NAMES`; `stepper.LinearSystem`)."""
        rows = self.length_free_rows.copy()
        rows[4:] /= np.asarray(lengths, dtype=float)[:, None] ** 2
        return rows

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

    def simulate(
        self,
        profile,
        t_end: float,
        q0=None,
        qd0=None,
        t_eval=None,
        loads=None,
        progress=None,
        observer=None,
        **options,
    ):
        """Integrate from t = 0 to `t_end` [s] under the boom motion `profile`; returns
        `(t, q, qd)`. `loads`: None, a constant pair `(pressures, tip_forces)` or
        triple `(pressures, tip_forces, hub_wrench)` (a free hub's `(F_z [N], tau_x
        [N m], tau_y [N m])`), or a callable `t ->` either (sampled at each step's
        midpoint; a load step lands on a step boundary when its time is one of
        `t_eval`). The other arguments are those of `integrate.simulate` (`observer`,
        e.g. `peaks.OutputPeaks(model)`, sees every step)."""
        return simulate(
            self,
            profile,
            t_end,
            q0=q0,
            qd0=qd0,
            t_eval=t_eval,
            progress=progress,
            observer=observer,
            inputs=input_function(loads, self.free_hub),
            **options,
        )

    def simulate_on_grid(
        self, profile, t_end: float, spacing: float, q0=None, qd0=None, loads=None, **options
    ):
        """`integrate.simulate_on_grid`: the states every `spacing` [s] to `t_end` [s],
        stepped and sampled as the simulator does; `loads` as in `simulate`."""
        return simulate_on_grid(
            self,
            profile,
            t_end,
            spacing,
            q0=q0,
            qd0=qd0,
            inputs=input_function(loads, self.free_hub),
            **options,
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

    def sample(self, t, lengths, rates, q, qd) -> StateSample:
        """The state at `t` [s] with its tip deflections, their rates, the root moments
        and a free hub's state `(z_h, theta_x, theta_y, zd_h, thd_x, thd_y)`; for a series
        (`t` (k,), the others with the times first) the record of arrays."""
        q, qd = np.asarray(q), np.asarray(qd)
        hub = None
        if self.free_hub:
            hub = np.concatenate([q[..., self.hub_slice], qd[..., self.hub_slice]], axis=-1)
        return StateSample(
            t=t,
            lengths=lengths,
            rates=rates,
            q=q,
            qd=qd,
            tips=self.tip_deflections(q),
            tip_rates=self.tip_deflections(qd),
            root_moments=self.root_moments(q, lengths),
            hub=hub,
        )

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
