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
    GYROSCOPIC_SKEW      G - G^T                   (canonical form)
    STIFFNESS_CANONICAL  K - N                     (canonical form)
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.integrals import BoomIntegrals, QuadrantIntegrals

BOOMS = ("a", "b", "c", "d")
# quadrant name, first boom, second boom (model.md §1 and Tab. 1)
QUADRANTS = (("ab", 0, 1), ("bc", 1, 2), ("cd", 2, 3), ("da", 3, 0))
# Outputs of one evaluation, in this order.
MASS, DAMPING, STIFFNESS_EQ, STIFFNESS, GYROSCOPIC, GYROSCOPIC_SKEW, STIFFNESS_CANONICAL = range(7)
N_OUTPUTS = 7
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

        # Constant term matrices, in the column order of the tables at the end of this module.
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
        self._boom_targets = np.stack(
            [(slots[:, None] * self.n + slots[None, :]).ravel() for slots in boom_slots]
        )
        quad_targets = []
        for q, (_, first, second) in enumerate(QUADRANTS):
            slots = np.concatenate([boom_slots[first], boom_slots[second], membrane_slots[q]])
            quad_targets.append((slots[:, None] * self.n + slots[None, :]).ravel())
        self._quad_targets = np.stack(quad_targets)
        self._plans = {}
        self._first = np.array([f for _, f, _ in QUADRANTS])
        self._second = np.array([s for _, _, s in QUADRANTS])

    def _plan(self, outputs: tuple[int, ...]):
        """Feature columns per (output, term) and scatter indices for `outputs`."""
        if outputs not in self._plans:
            k = len(outputs)
            offsets = (self.n * self.n * np.arange(k))[None, :, None]
            scatter = np.concatenate(
                [
                    (self._boom_targets[:, None, :] + offsets).ravel(),
                    (self._quad_targets[:, None, :] + offsets).ravel(),
                ]
            )
            self._plans[outputs] = (
                _BOOM_FEATURE_OF_TERM[list(outputs)],
                _QUAD_FEATURE_OF_TERM[list(outputs)],
                scatter,
            )
        return self._plans[outputs]

    def evaluate(self, lengths, rates, accelerations, outputs=ALL_OUTPUTS) -> np.ndarray:
        """The requested matrices stacked, shape (len(outputs), n, n).

        Arguments are arrays of 4 values (m, m/s, m/s^2), already validated;
        `outputs` a tuple of the output constants above, in any order.
        """
        L, Ld, Ldd = lengths, rates, accelerations
        rho_b, rho_m = self._rho_b, self._rho_m
        boom_features = np.stack(
            [
                np.zeros(4),
                rho_b * L,
                rho_b * Ld,
                rho_b * Ldd,
                -rho_b * Ld**2 / L,
                self._ei / L**3,
                -self._p / L,
            ],
            axis=1,
        )
        La, Lda, Ldda = L[self._first], Ld[self._first], Ldd[self._first]
        Lb, Ldb, Lddb = L[self._second], Ld[self._second], Ldd[self._second]
        quad_features = np.stack(
            [
                np.zeros(4),
                rho_m * La * Lb,
                rho_m * (Lda * Lb + La * Ldb),
                rho_m * Lb * Lda,
                rho_m * La * Ldb,
                rho_m * (Lda * Ldb + Lb * Ldda),
                rho_m * (Lda * Ldb + La * Lddb),
                -rho_m * Lb * Lda**2 / La,
                -rho_m * Lda * Ldb,
                -rho_m * La * Ldb**2 / Lb,
                self._n0 * Lb / La,
                self._n0 * La / Lb,
            ],
            axis=1,
        )
        boom_columns, quad_columns, scatter = self._plan(outputs)
        k = len(outputs)
        # coefficient of every (boom or quadrant, output, term), times the term matrices
        boom_values = boom_features[:, boom_columns].reshape(4 * k, -1) @ self._boom_terms
        quad_values = quad_features[:, quad_columns].reshape(4 * k, -1) @ self._quad_terms
        values = np.concatenate([boom_values.ravel(), quad_values.ravel()])
        out = np.bincount(scatter, weights=values, minlength=k * self.n * self.n)
        return out.reshape(k, self.n, self.n)


# Which feature (column of the feature arrays in `evaluate`) scales each term
# matrix in each output; column 0 is zero. Rows: outputs; columns: terms.
# Boom features: 0, rho L, rho Ld, rho Ldd, -rho Ld^2/L, EI/L^3, -P/L.
_BOOM_FEATURE_OF_TERM = np.zeros((N_OUTPUTS, 6), dtype=np.intp)
_BOOM_FEATURE_OF_TERM[MASS, 0] = 1
_BOOM_FEATURE_OF_TERM[DAMPING, [0, 1]] = 2  # Md and G - G^T
_BOOM_FEATURE_OF_TERM[STIFFNESS_EQ, 2:6] = [3, 4, 5, 6]  # Gd, -N, bending, axial load
_BOOM_FEATURE_OF_TERM[STIFFNESS, 4:6] = [5, 6]
_BOOM_FEATURE_OF_TERM[GYROSCOPIC, 2] = 2
_BOOM_FEATURE_OF_TERM[GYROSCOPIC_SKEW, 1] = 2
_BOOM_FEATURE_OF_TERM[STIFFNESS_CANONICAL, 3:6] = [4, 5, 6]
# Quadrant features: 0, rho La Lb, rho (Lda Lb + La Ldb), rho Lb Lda, rho La Ldb,
# rho (Lda Ldb + Lb Ldda), rho (Lda Ldb + La Lddb), -rho Lb Lda^2/La, -rho Lda Ldb,
# -rho La Ldb^2/Lb, N0 Lb/La, N0 La/Lb.
_QUAD_FEATURE_OF_TERM = np.zeros((N_OUTPUTS, 10), dtype=np.intp)
_QUAD_FEATURE_OF_TERM[MASS, 0] = 1
_QUAD_FEATURE_OF_TERM[DAMPING, 0:3] = [2, 3, 4]
_QUAD_FEATURE_OF_TERM[STIFFNESS_EQ, 3:10] = [5, 6, 7, 8, 9, 10, 11]
_QUAD_FEATURE_OF_TERM[STIFFNESS, 8:10] = [10, 11]
_QUAD_FEATURE_OF_TERM[GYROSCOPIC, 3:5] = [3, 4]
_QUAD_FEATURE_OF_TERM[GYROSCOPIC_SKEW, 1:3] = [3, 4]
_QUAD_FEATURE_OF_TERM[STIFFNESS_CANONICAL, 5:10] = [7, 8, 9, 10, 11]
