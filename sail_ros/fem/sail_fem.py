"""Finite-element model of the whole sail: four booms and four quadrants.

Independent of the modal model (`sail_ros.model`): the same continuum
(model.md §1-§4 at constant length, rates zero), discretised with local
elements instead of global eigenfunctions, to cross-check it as the seed
checks itself against FEM (its Tab. 2).

Global unknowns, in the order of model.md §6:

    [p_a, p_b, p_c, p_d, v_ab, v_bc, v_cd, v_da]

`p_k` are the Hermite DOFs of boom `k` (`beam.py`), `v_q` the interior nodal
values of quadrant `q`'s membrane displacement (`membrane.py`). Quadrant
`Q_ab` couples booms a (along its x) and b (along its y), `Q_bc` b and c,
`Q_cd` c and d, `Q_da` d and a (seed Tab. 1). All four quadrants have the same
matrices in their local axes; they differ only in where they are scattered.

Free vibration solves `K x = omega^2 M x`.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

from sail_ros.fem.beam import HermiteBoom
from sail_ros.fem.membrane import QuadrantFE, check_mesh
from sail_ros.model.parameters import SailParameters

# (first boom, second boom) of Q_ab, Q_bc, Q_cd, Q_da; booms a, b, c, d = 0..3
QUADRANT_BOOMS = ((0, 1), (1, 2), (2, 3), (3, 0))

# Extra Lanczos eigenpairs beyond those asked for: a multiple eigenvalue at the
# edge of the wanted set (up to 4-fold here) must not lose copies.
EIGEN_MARGIN = 4


def factorize(A: sp.spmatrix) -> sp.linalg.SuperLU:
    """Sparse LU of a symmetric matrix.

    A symmetric fill-reducing ordering with preference for diagonal pivots
    keeps the factor small (SuperLU's default column ordering fills the
    strips that couple each boom to its two quadrants some 10 times more).
    """
    return sp.linalg.splu(
        A.tocsc(),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.1,
        options={"SymmetricMode": True},
    )


def _scatter(block: sp.spmatrix, index: np.ndarray) -> tuple[np.ndarray, ...]:
    """COO triplets of `block` placed at global rows and columns `index`."""
    coo = block.tocoo()
    return index[coo.row], index[coo.col], coo.data


class SailFEM:
    """Finite-element model of the four-boom, four-quadrant sail.

    Args:
        params: physical parameters (the mode counts are not used).
        boom_elements: Hermite elements per boom `NB`.
        membrane_divisions: mesh divisions per quadrant leg `ND`, a multiple
            of `NB` (each quadrant has `ND**2` triangles).
        membrane_order: Lagrange order of the membrane field, 1 or 2.

    More than about 64 boom elements buys nothing in double precision: the
    Hermite error in the frequencies is then below 1e-10 while the round-off
    of the bending energy, a sum of terms `EI/h^3` cancelling to `EI/L^3`,
    grows like `eps (L/h)^4`. Refine the membrane further instead.

    Special membranes:
        - `rho_M = N0 = 0`: there is no membrane; only the booms are solved.
        - `rho_M = 0 < N0`: the massless membrane follows the booms
          statically; its DOFs are condensed out (exact without inertia).
        - `N0 = 0 < rho_M`: a slack membrane is a mechanism with infinitely
          many zero frequencies; rejected with ValueError.
    """

    def __init__(
        self,
        params: SailParameters,
        boom_elements: int = 32,
        membrane_divisions: int = 64,
        membrane_order: int = 2,
    ):
        HermiteBoom(1.0, boom_elements)  # validates the element count
        check_mesh(boom_elements, membrane_divisions, membrane_order)
        if params.membrane_tension == 0 and params.membrane_areal_density > 0:
            raise ValueError(
                "membrane prestress 0 with non-zero membrane density: the slack "
                "membrane has no stiffness (all its frequencies are zero)"
            )
        self.params = params
        self.boom_elements = boom_elements
        self.membrane_divisions = membrane_divisions
        self.membrane_order = membrane_order
        self._cached: tuple[float, tuple[sp.csr_matrix, sp.csr_matrix]] | None = None

    # sizes -------------------------------------------------------------
    @property
    def has_membrane(self) -> bool:
        """False when `rho_M = N0 = 0`: the booms are then all there is."""
        return self.params.membrane_tension > 0 or self.params.membrane_areal_density > 0

    @property
    def n_boom_dofs(self) -> int:
        """DOFs of one boom: deflection and slope at each unclamped node."""
        return 2 * self.boom_elements

    @property
    def n_membrane_dofs(self) -> int:
        """Interior nodes of one quadrant: `(m-1)(m-2)/2`, `m = order * ND`."""
        m = self.membrane_order * self.membrane_divisions
        return (m - 1) * (m - 2) // 2 if self.has_membrane else 0

    @property
    def n_dofs(self) -> int:
        """Size of the assembled `M` and `K`."""
        return 4 * (self.n_boom_dofs + self.n_membrane_dofs)

    def mesh_description(self) -> str:
        """One line naming the mesh, e.g. for a report next to the frequencies."""
        booms = f"4 x {self.boom_elements} Hermite beam elements"
        if not self.has_membrane:
            return f"{booms}, no membrane ({self.n_dofs} DOFs)"
        return (
            f"{booms}, 4 x {self.membrane_divisions**2} P{self.membrane_order} "
            f"triangles ({4 * self.n_membrane_dofs} membrane DOFs, "
            f"{self.n_dofs} in all)"
        )

    # matrices ----------------------------------------------------------
    def _length(self, length: float | None) -> float:
        return self.params.full_boom_length if length is None else float(length)

    def matrices(self, length: float | None = None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Global mass [kg] and stiffness [N/m] matrices for boom length `length` [m].

        `length` defaults to the fully deployed `a / sqrt(2)`; all four booms
        share it. The matrices of the last length asked for are kept.
        """
        L = self._length(length)
        if self._cached is None or self._cached[0] != L:
            self._cached = (L, self._assemble(L))
        return self._cached[1]

    def _assemble(self, L: float) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        p = self.params
        boom = HermiteBoom(L, self.boom_elements)
        nb, nm = self.n_boom_dofs, self.n_membrane_dofs
        boom_dofs = [k * nb + np.arange(nb) for k in range(4)]
        M_boom, K_boom = boom.matrices(
            p.boom_linear_density, p.boom_bending_stiffness, p.boom_axial_load
        )
        mass = [_scatter(M_boom, dofs) for dofs in boom_dofs]
        stiffness = [_scatter(K_boom, dofs) for dofs in boom_dofs]
        if self.has_membrane:
            quadrant = QuadrantFE(boom, self.membrane_divisions, self.membrane_order)
            M_q = p.membrane_areal_density * quadrant.area_integral
            K_q = p.membrane_tension * quadrant.gradient_integral
            for q, (first, second) in enumerate(QUADRANT_BOOMS):
                dofs = np.concatenate(
                    [boom_dofs[first], boom_dofs[second], 4 * nb + q * nm + np.arange(nm)]
                )
                mass.append(_scatter(M_q, dofs))
                stiffness.append(_scatter(K_q, dofs))

        def build(triplets):
            rows, cols, data = (np.concatenate(part) for part in zip(*triplets, strict=True))
            return sp.csr_matrix((data, (rows, cols)), shape=(self.n_dofs, self.n_dofs))

        return build(mass), build(stiffness)

    def _condensed(self, L: float) -> tuple[sp.spmatrix, sp.spmatrix]:
        """`M`, `K` with a massless membrane's DOFs condensed out.

        With `rho_M = 0` the membrane rows of `M` vanish, so the membrane is in
        static equilibrium with the booms: `v = -K_vv^-1 K_vb p` and
        `K_red = K_bb - K_bv K_vv^-1 K_vb` on the boom DOFs (dense, small).
        """
        M, K = self.matrices(L)
        if self.params.membrane_areal_density > 0 or not self.has_membrane:
            return M, K
        b = slice(0, 4 * self.n_boom_dofs)
        v = slice(4 * self.n_boom_dofs, self.n_dofs)
        K_vb = K[v, b].toarray()
        K_red = K[b, b].toarray() - K[b, v] @ factorize(K[v, v]).solve(K_vb)
        return M[b, b], sp.csr_matrix(K_red)

    # eigenvalues -------------------------------------------------------
    def eigenvalues(self, k: int = 12, length: float | None = None) -> np.ndarray:
        """Lowest `k` eigenvalues `omega^2` [rad^2/s^2] of `K x = omega^2 M x`, ascending.

        Shift-invert Lanczos about 0 (ARPACK): it resolves the lowest
        eigenvalues to relative accuracy even when `K` spans many decades
        (stiff booms, soft membrane), where a dense solver's absolute error
        `eps |M^-1 K|` can swamp them. The Ritz values themselves carry the
        round-off of the solves (~1e-8 relative at 1e5 DOFs), so `K` and `M`
        are projected once more on the Ritz vectors (Rayleigh-Ritz), whose
        eigenvalues err only quadratically in the vectors' errors. Only a model
        too small for the Lanczos margin is solved densely. A negative value
        means the boom load `P` exceeds the (discrete) buckling load.
        """
        M, K = self._condensed(self._length(length))
        n = M.shape[0]
        k = min(k, n)
        if k + EIGEN_MARGIN >= n:
            return scipy.linalg.eigh(
                K.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[0, k - 1]
            )
        K_inverse = sp.linalg.LinearOperator(K.shape, matvec=factorize(K).solve, dtype=float)
        start = np.random.default_rng(0).standard_normal(n)  # not symmetric: all irreps
        _, V = sp.linalg.eigsh(
            K, k=k + EIGEN_MARGIN, M=M, sigma=0.0, which="LM", OPinv=K_inverse, v0=start
        )
        K_V, M_V = V.T @ (K @ V), V.T @ (M @ V)
        return scipy.linalg.eigh(
            (K_V + K_V.T) / 2, (M_V + M_V.T) / 2, eigvals_only=True, subset_by_index=[0, k - 1]
        )

    def natural_frequencies(self, k: int = 12, length: float | None = None) -> np.ndarray:
        """Lowest `k` natural frequencies `omega` [rad/s], ascending.

        `length` [m] is the common boom length (default `a / sqrt(2)`). A
        statically unstable (buckled) mode, `omega^2 < 0`, is returned as
        `-sqrt(-omega^2)`, minus its divergence rate [1/s].
        """
        values = self.eigenvalues(k, length)
        return np.sign(values) * np.sqrt(np.abs(values))


def fem_convergence(
    params: SailParameters, levels=((8, 8, 2), (16, 16, 2), (32, 32, 2), (64, 64, 2)), k: int = 6
) -> list[tuple[dict, np.ndarray]]:
    """Lowest `k` frequencies [rad/s] on a sequence of meshes.

    Args:
        params: physical parameters.
        levels: `(boom_elements, membrane_divisions, membrane_order)` per mesh;
            halving both sizes from one level to the next makes the spaces
            nested, so every frequency decreases monotonically.
        k: number of frequencies.

    Returns:
        One `(settings, frequencies)` per level; `settings` holds the three
        mesh parameters, `n_dofs`, `description` and the wall time `seconds`
        of assembly plus eigensolution.
    """
    results = []
    for boom_elements, divisions, order in levels:
        start = time.perf_counter()
        fem = SailFEM(params, boom_elements, divisions, order)
        frequencies = fem.natural_frequencies(k)
        settings = {
            "boom_elements": boom_elements,
            "membrane_divisions": divisions,
            "membrane_order": order,
            "n_dofs": fem.n_dofs,
            "description": fem.mesh_description(),
            "seconds": time.perf_counter() - start,
        }
        results.append((settings, frequencies))
    return results
