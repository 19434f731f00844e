"""The deflected sail sampled on a mesh, in the `sail` frame (model.md §7).

Basis functions are evaluated once on a structured triangulation of the
reference triangle `D` and on points along `[0, 1]`; sampling a state is then
two matrix products. Used for plots, RViz/Foxglove meshes and figures.
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.basis import cantilever_modes, triangle_modes
from sail_ros.model.layout import BOOM_DIRECTIONS, BOOMS, QUADRANTS, per_boom
from sail_ros.model.sail_model import SailModel


def reference_triangulation(divisions: int):
    """Points `(xi, eta)` with `xi, eta = i/r, j/r`, `i + j <= r`, and triangles.

    Returns `(xi, eta, triangles)`; `triangles` index the points, (T, 3).
    """
    r = divisions
    index = {}
    xi, eta = [], []
    for i in range(r + 1):
        for j in range(r + 1 - i):
            index[i, j] = len(xi)
            xi.append(i / r)
            eta.append(j / r)
    triangles = []
    for i in range(r):
        for j in range(r - i):
            triangles.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if i + j + 1 < r:
                triangles.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    return np.array(xi), np.array(eta), np.array(triangles, dtype=np.int64)


class SailSurface:
    """Samples the membrane surface `w` and the boom lines `u_k` of a state.

    Args:
        model: the sail model.
        divisions: subdivisions of each quadrant edge (mesh resolution).
    """

    def __init__(self, model: SailModel, divisions: int = 12):
        if int(divisions) != divisions or divisions < 1:
            raise ValueError(f"divisions must be an integer >= 1, got {divisions!r}")
        self.model = model
        nb, nm = model.n_boom_modes, model.n_membrane_modes
        self.xi, self.eta, triangles = reference_triangulation(int(divisions))
        points = self.xi.size
        phi, _, _ = triangle_modes(nm, self.xi, self.eta)
        self._quadrant_basis = np.vstack(
            [cantilever_modes(nb, self.xi), cantilever_modes(nb, self.eta), phi]
        )  # S at the mesh points, (n~, P)
        self.triangles = np.concatenate([triangles + k * points for k in range(4)])
        self.boom_stations = np.linspace(0.0, 1.0, 2 * int(divisions) + 1)
        self._boom_basis = cantilever_modes(nb, self.boom_stations)
        self._slots = [model.layout.quadrant_slots(quadrant) for quadrant in QUADRANTS]

    def vertices(self, q, lengths) -> np.ndarray:
        """Mesh vertices (4 P, 3) [m] of the deflected membrane, quadrant by
        quadrant (ab, bc, cd, da); `triangles` indexes them."""
        q = np.asarray(q, dtype=float)
        lengths = per_boom(lengths, "lengths", positive=True)
        parts = []
        for (_, first, second), slots in zip(QUADRANTS, self._slots, strict=True):
            plane = np.outer(self.xi * lengths[first], BOOM_DIRECTIONS[first]) + np.outer(
                self.eta * lengths[second], BOOM_DIRECTIONS[second]
            )
            height = q[slots] @ self._quadrant_basis
            parts.append(np.column_stack([plane, height]))
        return np.concatenate(parts)

    def boom_lines(self, q, lengths) -> np.ndarray:
        """Points along each boom, (4, stations, 3) [m], hub to tip."""
        q = np.asarray(q, dtype=float)
        lengths = per_boom(lengths, "lengths", positive=True)
        lines = np.empty((4, self.boom_stations.size, 3))
        for k, boom in enumerate(BOOMS):
            lines[k, :, :2] = np.outer(self.boom_stations * lengths[k], BOOM_DIRECTIONS[k])
            lines[k, :, 2] = q[self.model.boom_slice(boom)] @ self._boom_basis
        return lines
