"""System matrices of Eq. 2 by lifting quadrant and boom matrices (model.md §5-§6).

The system coordinates are ordered

    q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]

(`n_B` per boom, `n_M` per quadrant). Each matrix of Eq. 2 is a sum over
booms and quadrants of a scalar coefficient times a constant reference
integral (`integrals.py`). The assembler precomputes, for every one of those
constant integrals, where its entries land in the system matrices (Tab. 1),
so one evaluation is: coefficients (a few dozen scalars), one small matrix
product per component, and one scatter-add (`numpy.bincount`) that builds
all requested matrices together:

    MASS                 M
    DAMPING              C = Md + G - G^T          (Eq. 2)
    STIFFNESS_EQ         K_eq = Gd + K - N         (Eq. 2)
    STIFFNESS            K, the elastic part (bending, axial load, tension)
    GYROSCOPIC           G                         (canonical form)
    STIFFNESS_CANONICAL  K - N                     (canonical form)
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.integrals import BoomIntegrals, QuadrantIntegrals

BOOMS = ("a", "b", "c", "d")
# quadrant name, first boom, second boom (model.md §1 and Tab. 1)
QUADRANTS = (("ab", 0, 1), ("bc", 1, 2), ("cd", 2, 3), ("da", 3, 0))
# Outputs of one evaluation, in this order.
MASS, DAMPING, STIFFNESS_EQ, STIFFNESS, GYROSCOPIC, STIFFNESS_CANONICAL = range(6)
N_OUTPUTS = 6
ALL_OUTPUTS = tuple(range(N_OUTPUTS))


class SystemAssembler:
    """Builds `M`, `C = Md + G - G^T`, `K_eq = Gd + K - N` and `K` from boom motion.

    Physical constants enter once here; `evaluate` takes only the boom lengths,
    rates and accelerations (4 values each, order a, b, c, d).
    """

    def __init__(
        self,
        boom: BoomIntegrals,
        quadrant: QuadrantIntegrals,
        n_boom_modes: int,
        n_membrane_modes: int,
        boom_linear_density: float,
        boom_bending_stiffness: float,
        boom_axial_load: float,
        membrane_areal_density: float,
        membrane_tension: float,
    ):
        nb, nm = n_boom_modes, n_membrane_modes
        self.n = 4 * nb + 4 * nm
        self._rho_b = boom_linear_density
        self._ei = boom_bending_stiffness
        self._p = boom_axial_load
        self._rho_m = membrane_areal_density
        self._n0 = membrane_tension

        # Constant term matrices; the coefficient code below follows this order.
        boom_terms = np.stack(
            [
                boom.psi_psi,  # 0: M, Md
                boom.psi_r - boom.psi_r.T,  # 1: G - G^T
                boom.psi_r,  # 2: Gd
                boom.r_r,  # 3: N
                boom.d2_d2,  # 4: bending K
                boom.d1_d1,  # 5: axial-load K
            ]
        )
        quad_terms = np.stack(
            [
                quadrant.s_s,  # 0: M, Md
                quadrant.s_ra - quadrant.s_ra.T,  # 1: G - G^T (boom 1 rate)
                quadrant.s_rb - quadrant.s_rb.T,  # 2: G - G^T (boom 2 rate)
                quadrant.s_ra,  # 3: Gd
                quadrant.s_rb,  # 4: Gd
                quadrant.ra_ra,  # 5: N
                quadrant.ra_rb,  # 6: N
                quadrant.rb_rb,  # 7: N
                quadrant.sxi_sxi,  # 8: K (tension)
                quadrant.seta_seta,  # 9: K (tension)
            ]
        )
        self._boom_terms = boom_terms.reshape(len(boom_terms), -1)
        self._quad_terms = quad_terms.reshape(len(quad_terms), -1)

        # Flat system index of every entry of every boom and quadrant block.
        boom_slots = [np.arange(k * nb, (k + 1) * nb) for k in range(4)]
        membrane_slots = [np.arange(4 * nb + q * nm, 4 * nb + (q + 1) * nm) for q in range(4)]
        targets = []
        for slots in boom_slots:
            targets.append((slots[:, None] * self.n + slots[None, :]).ravel())
        for q, (_, first, second) in enumerate(QUADRANTS):
            slots = np.concatenate([boom_slots[first], boom_slots[second], membrane_slots[q]])
            targets.append((slots[:, None] * self.n + slots[None, :]).ravel())
        self._flat_targets = np.concatenate(targets)
        self._scatters = {}

        self._first = np.array([f for _, f, _ in QUADRANTS])
        self._second = np.array([s for _, _, s in QUADRANTS])

    def _scatter(self, outputs: tuple[int, ...]) -> np.ndarray:
        """Flat indices into a stack of len(outputs) n x n matrices."""
        if outputs not in self._scatters:
            offsets = self.n * self.n * np.arange(len(outputs))[:, None]
            self._scatters[outputs] = (self._flat_targets[None, :] + offsets).ravel()
        return self._scatters[outputs]

    def evaluate(self, lengths, rates, accelerations, outputs=ALL_OUTPUTS) -> np.ndarray:
        """The requested matrices stacked, shape (len(outputs), n, n).

        Arguments are arrays of 4 values (m, m/s, m/s^2), already validated;
        `outputs` a tuple of MASS, DAMPING, STIFFNESS_EQ, STIFFNESS,
        GYROSCOPIC, STIFFNESS_CANONICAL (in any order).
        """
        L, Ld, Ldd = lengths, rates, accelerations
        rho_b, rho_m = self._rho_b, self._rho_m

        cb = np.zeros((4, N_OUTPUTS, 6))  # boom, output, term
        cb[:, MASS, 0] = rho_b * L
        cb[:, DAMPING, 0] = rho_b * Ld
        cb[:, DAMPING, 1] = rho_b * Ld
        cb[:, STIFFNESS_EQ, 2] = rho_b * Ldd
        cb[:, STIFFNESS_EQ, 3] = -rho_b * Ld**2 / L
        elastic_b = np.stack([self._ei / L**3, -self._p / L], axis=1)
        cb[:, STIFFNESS_EQ, 4:6] = elastic_b
        cb[:, STIFFNESS, 4:6] = elastic_b
        cb[:, GYROSCOPIC, 2] = rho_b * Ld
        cb[:, STIFFNESS_CANONICAL, 3] = -rho_b * Ld**2 / L
        cb[:, STIFFNESS_CANONICAL, 4:6] = elastic_b

        La, Lda, Ldda = L[self._first], Ld[self._first], Ldd[self._first]
        Lb, Ldb, Lddb = L[self._second], Ld[self._second], Ldd[self._second]
        cq = np.zeros((4, N_OUTPUTS, 10))  # quadrant, output, term
        cq[:, MASS, 0] = rho_m * La * Lb
        cq[:, DAMPING, 0] = rho_m * (Lda * Lb + La * Ldb)
        cq[:, DAMPING, 1] = rho_m * Lb * Lda
        cq[:, DAMPING, 2] = rho_m * La * Ldb
        cq[:, STIFFNESS_EQ, 3] = rho_m * (Lda * Ldb + Lb * Ldda)
        cq[:, STIFFNESS_EQ, 4] = rho_m * (Lda * Ldb + La * Lddb)
        cq[:, STIFFNESS_EQ, 5] = -rho_m * Lb * Lda**2 / La
        cq[:, STIFFNESS_EQ, 6] = -rho_m * Lda * Ldb
        cq[:, STIFFNESS_EQ, 7] = -rho_m * La * Ldb**2 / Lb
        tension_q = np.stack([self._n0 * Lb / La, self._n0 * La / Lb], axis=1)
        cq[:, STIFFNESS_EQ, 8:10] = tension_q
        cq[:, STIFFNESS, 8:10] = tension_q
        cq[:, GYROSCOPIC, 3] = rho_m * Lb * Lda
        cq[:, GYROSCOPIC, 4] = rho_m * La * Ldb
        cq[:, STIFFNESS_CANONICAL, 5:8] = cq[:, STIFFNESS_EQ, 5:8]
        cq[:, STIFFNESS_CANONICAL, 8:10] = tension_q

        k = len(outputs)
        cb = cb[:, list(outputs), :]
        cq = cq[:, list(outputs), :]
        boom_values = (cb.reshape(4 * k, 6) @ self._boom_terms).reshape(4, k, -1)
        quad_values = (cq.reshape(4 * k, 10) @ self._quad_terms).reshape(4, k, -1)
        values = np.concatenate(
            [
                boom_values.transpose(1, 0, 2).reshape(k, -1),
                quad_values.transpose(1, 0, 2).reshape(k, -1),
            ],
            axis=1,
        )
        out = np.bincount(self._scatter(outputs), weights=values.ravel(), minlength=k * self.n**2)
        return out.reshape(k, self.n, self.n)
