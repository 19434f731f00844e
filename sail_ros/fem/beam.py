"""Hermite cubic Euler-Bernoulli elements for one boom clamped at the hub.

The boom `[0, L]` is cut into `n` equal elements of length `h = L / n`. On the
element `[s_e, s_e + h]`, with `t = (s - s_e) / h` in `[0, 1]`, the deflection
[m] is

    u(s) = N1(t) u_e + N2(t) theta_e + N3(t) u_e+1 + N4(t) theta_e+1

    N1 = 1 - 3 t^2 + 2 t^3        N2 = h (t - 2 t^2 + t^3)
    N3 = 3 t^2 - 2 t^3            N4 = h (t^3 - t^2)

with nodal deflections `u` [m] and slopes `theta = du/ds` [rad]: `u` and `u'`
are continuous, as the bending energy `1/2 EI int (u'')^2 ds` requires. The hub
node is clamped (`u = theta = 0`) and carries no unknowns, so the boom DOF
vector is `[u_1, theta_1, u_2, theta_2, ..., u_n, theta_n]` (node `n` is the
tip).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

# Gauss-Legendre points per element; exact to degree 7, and the mass integrand
# N N^T is of degree 6.
GAUSS_POINTS = 4


def hermite_shapes(t: np.ndarray, h: float, derivative: int) -> np.ndarray:
    """The four Hermite shape functions (or their `s`-derivatives) at `t`.

    Args:
        t: local coordinates in `[0, 1]`, shape `(q,)`.
        h: element length [m].
        derivative: 0, 1 or 2, the order of `d/ds` applied.

    Returns:
        Array `(q, 4)`: `d^k N_i / ds^k` for `i = 1..4`, in m^-k per unit
        deflection DOF and m^(1-k) per unit slope DOF.
    """
    t2, t3 = t * t, t * t * t
    if derivative == 0:
        return np.stack(
            [1 - 3 * t2 + 2 * t3, h * (t - 2 * t2 + t3), 3 * t2 - 2 * t3, h * (t3 - t2)], axis=-1
        )
    if derivative == 1:
        return np.stack(
            [(6 * t2 - 6 * t) / h, 1 - 4 * t + 3 * t2, (6 * t - 6 * t2) / h, 3 * t2 - 2 * t],
            axis=-1,
        )
    if derivative == 2:
        return np.stack(
            [(12 * t - 6) / h**2, (6 * t - 4) / h, (6 - 12 * t) / h**2, (6 * t - 2) / h], axis=-1
        )
    raise ValueError(f"derivative must be 0, 1 or 2, got {derivative!r}")


class HermiteBoom:
    """A cantilever boom of length `L` [m] meshed with `n` Hermite elements.

    Attributes:
        length: boom length `L` [m].
        n_elements: number of equal elements `n`.
        element_length: `h = L / n` [m].
        n_dofs: `2 n` (deflection and slope at each node but the clamped hub).
    """

    def __init__(self, length: float, n_elements: int):
        if not length > 0:
            raise ValueError(f"boom length must be > 0, got {length!r}")
        if isinstance(n_elements, bool) or not isinstance(n_elements, int) or n_elements < 1:
            raise ValueError(f"boom elements must be an integer >= 1, got {n_elements!r}")
        self.length = float(length)
        self.n_elements = n_elements
        self.element_length = self.length / n_elements
        self.n_dofs = 2 * n_elements

    def evaluate(self, s: np.ndarray, derivative: int = 0) -> sp.csr_matrix:
        """Sparse matrix `E` with `(E p)_j = d^k u / ds^k (s_j)` for boom DOFs `p`.

        Each row has the (up to) four shape functions of the element holding
        `s_j`; a point on an inner node is given to the element on its right,
        which is harmless because `u` and `u'` are continuous there.

        Args:
            s: positions along the boom [m], each in `[0, L]`.
            derivative: 0 (deflection), 1 (slope) or 2 (curvature).
        """
        s = np.asarray(s, dtype=float).ravel()
        h, n = self.element_length, self.n_elements
        element = np.clip(np.floor(s / h).astype(int), 0, n - 1)
        shapes = hermite_shapes(s / h - element, h, derivative)
        # element e owns unclamped DOFs 2e .. 2e+3; the hub's two are dropped
        cols = 2 * element[:, None] + np.arange(4) - 2
        rows = np.broadcast_to(np.arange(s.size)[:, None], cols.shape)
        kept = cols >= 0
        return sp.csr_matrix((shapes[kept], (rows[kept], cols[kept])), shape=(s.size, self.n_dofs))

    def quadrature(self) -> tuple[np.ndarray, np.ndarray]:
        """Gauss points [m] and weights [m] over the whole boom, exact to degree 7."""
        nodes, weights = np.polynomial.legendre.leggauss(GAUSS_POINTS)
        h = self.element_length
        s = (np.arange(self.n_elements)[:, None] + (nodes + 1) / 2) * h
        return s.ravel(), np.tile(weights * h / 2, self.n_elements)

    def matrices(
        self, linear_density: float, bending_stiffness: float, axial_load: float = 0.0
    ) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Consistent mass and stiffness of the boom.

            M = rho_B int N N^T ds                           [kg]
            K = EI int N'' N''^T ds - P int N' N'^T ds        [N/m]

        from `T = 1/2 rho_B int u_t^2 ds` and
        `V = 1/2 EI int (u'')^2 ds - 1/2 P int (u')^2 ds` (model.md §4); the
        compressive axial load `P` [N] softens the boom (geometric stiffness).
        """
        s, weights = self.quadrature()
        W = sp.diags(weights)
        N, dN, ddN = (self.evaluate(s, derivative) for derivative in range(3))
        M = linear_density * (N.T @ W @ N)
        K = bending_stiffness * (ddN.T @ W @ ddN) - axial_load * (dN.T @ W @ dN)
        return M.tocsr(), K.tocsr()
