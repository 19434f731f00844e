"""Finite elements of one sail quadrant: the membrane riding on its two booms.

Quadrant `Q_ab` is the right isosceles triangle `{x >= 0, y >= 0, x + y <= L}`
in its local coordinates along `e_a` and `e_b` (model.md §1). Its deflection
[m] superimposes the membrane's own displacement on the booms' (seed Eq. 1):

    w(x, y) = u_a(x) + u_b(y) + v(x, y),     v = 0 on all three edges,

with `u_a`, `u_b` Hermite beam fields (`beam.py`) and `v` a P1 or P2 Lagrange
field on a triangle mesh. On the hypotenuse `w = u_a(x) + u_b(y)`: the sail
edge moves with the booms. For the quadrant DOF vector `[p_a, p_b, v]` the
membrane energies `T = 1/2 rho_M int w_t^2 dA` and
`V = 1/2 N0 int (w_x^2 + w_y^2) dA` give

    M = rho_M int S S^T dA,       K = N0 int (S_x S_x^T + S_y S_y^T) dA

where at every quadrature point

    S   = [B_a(x),   B_b(y),   N_v   ]      (w   = S p)
    S_x = [B_a'(x),  0,        N_v,x ]      (w_x = S_x p)
    S_y = [0,        B_b'(y),  N_v,y ]      (w_y = S_y p)

`B` are the boom evaluation rows and `N_v` the membrane basis. Stacking these
rows over all quadrature points into sparse matrices turns each integral into
one product `S^T diag(weights) S`; the boom-boom, boom-membrane and
membrane-membrane blocks all come out of it.

The mesh is structured, `n` divisions per leg, diagonals parallel to the
hypotenuse, so every triangle lies in one cell `[i h, (i+1) h] x [j h, (j+1) h]`.
When `n` is a multiple of the number of boom elements the boom functions are
cubic polynomials on every triangle, the degree-6 quadrature integrates all
products exactly, and the model is an exact Rayleigh-Ritz discretisation whose
frequencies bound the continuum's from above. Halving both mesh sizes gives
nested spaces, so the frequencies then decrease monotonically.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTriP1, ElementTriP2, MeshTri

from sail_ros.fem.beam import HermiteBoom

LAGRANGE_ELEMENTS = {1: ElementTriP1, 2: ElementTriP2}

# Degree of the products above: cubic boom times cubic boom in the mass.
QUADRATURE_ORDER = 6


def check_mesh(boom_elements: int, divisions: int, order: int) -> None:
    """Raise ValueError unless the quadrant mesh is usable with these booms.

    `divisions` must be a multiple of `boom_elements` so that each triangle
    lies in one boom element and the coupling integrals are exact.
    """
    if order not in LAGRANGE_ELEMENTS:
        raise ValueError(f"membrane order must be 1 or 2, got {order!r}")
    if isinstance(divisions, bool) or not isinstance(divisions, int) or divisions < 1:
        raise ValueError(f"membrane divisions must be an integer >= 1, got {divisions!r}")
    if divisions % boom_elements:
        raise ValueError(
            f"membrane divisions ({divisions}) must be a multiple of the boom elements "
            f"({boom_elements}) so that each triangle lies in one boom element"
        )


def quadrant_mesh(length: float, divisions: int) -> MeshTri:
    """Structured mesh of `{x, y >= 0, x + y <= L}` with `divisions**2` triangles.

    Node `(i, j)` sits at `(i h, j h)`, `h = L / divisions`, `i + j <= divisions`.
    Cell `(i, j)` holds the triangle `(i, j), (i+1, j), (i, j+1)` and, if the
    cell is inside the quadrant, also `(i+1, j), (i+1, j+1), (i, j+1)`.
    """
    n = divisions
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    inside = i + j <= n
    index = np.full((n + 1, n + 1), -1)
    index[inside] = np.arange(np.count_nonzero(inside))
    points = np.stack([i[inside], j[inside]]) * (length / n)

    ci, cj = i[:n, :n], j[:n, :n]
    lower = ci + cj <= n - 1
    upper = ci + cj <= n - 2
    a, b = ci[lower], cj[lower]
    c, d = ci[upper], cj[upper]
    triangles = np.hstack(
        [
            np.stack([index[a, b], index[a + 1, b], index[a, b + 1]]),
            np.stack([index[c + 1, d], index[c + 1, d + 1], index[c, d + 1]]),
        ]
    )
    return MeshTri(points, triangles)


class QuadrantFE:
    """Mass and stiffness integrals of one quadrant over `[p_first, p_second, v]`.

    Both legs have the length of `boom`; the first boom runs along `x`, the
    second along `y`, exactly as for every quadrant in its own local axes.

    Attributes:
        boom: the `HermiteBoom` both legs are meshed with.
        divisions: mesh divisions per leg.
        order: Lagrange order of `v` (1 or 2).
        n_triangles: `divisions**2`.
        n_membrane_dofs: nodal values of `v` inside the quadrant.
        n_dofs: `2 boom.n_dofs + n_membrane_dofs`.
        area_integral: `int S S^T dA` [m^2]; mass matrix per unit `rho_M`.
        gradient_integral: `int (S_x S_x^T + S_y S_y^T) dA` [-]; stiffness
            matrix per unit `N0`.
    """

    def __init__(self, boom: HermiteBoom, divisions: int, order: int):
        check_mesh(boom.n_elements, divisions, order)
        self.boom, self.divisions, self.order = boom, divisions, order
        mesh = quadrant_mesh(boom.length, divisions)
        basis = Basis(mesh, LAGRANGE_ELEMENTS[order](), intorder=QUADRATURE_ORDER)
        self.n_triangles = mesh.nelements

        # number the interior nodes; edge nodes (v = 0) get -1
        free = np.setdiff1d(np.arange(basis.N), basis.get_dofs().all())
        interior = np.full(basis.N, -1)
        interior[free] = np.arange(free.size)
        self.n_membrane_dofs = free.size
        self.n_dofs = 2 * boom.n_dofs + free.size

        # membrane basis at the quadrature points, rows ordered (element, point)
        n_points = basis.dx.size
        rows = np.broadcast_to(
            np.arange(n_points).reshape(basis.dx.shape), (basis.Nbfun, *basis.dx.shape)
        )
        cols = np.broadcast_to(interior[basis.element_dofs][:, :, None], rows.shape)
        kept = cols >= 0

        def membrane_rows(data: np.ndarray) -> sp.csr_matrix:
            return sp.csr_matrix(
                (data[kept], (rows[kept], cols[kept])), shape=(n_points, free.size)
            )

        fields = [basis.basis[i][0] for i in range(basis.Nbfun)]
        Nv = membrane_rows(np.stack([np.asarray(f) for f in fields]))
        Nv_x = membrane_rows(np.stack([f.grad[0] for f in fields]))
        Nv_y = membrane_rows(np.stack([f.grad[1] for f in fields]))

        x, y = (c.ravel() for c in basis.mapping.F(basis.X))
        zero = sp.csr_matrix((n_points, boom.n_dofs))
        S = sp.hstack([boom.evaluate(x), boom.evaluate(y), Nv], format="csr")
        S_x = sp.hstack([boom.evaluate(x, 1), zero, Nv_x], format="csr")
        S_y = sp.hstack([zero, boom.evaluate(y, 1), Nv_y], format="csr")

        W = sp.diags(basis.dx.ravel())
        self.area_integral = (S.T @ W @ S).tocsr()
        self.gradient_integral = (S_x.T @ W @ S_x + S_y.T @ W @ S_y).tocsr()
