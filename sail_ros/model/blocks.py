"""The sail's matrices as their component blocks, never added into n x n matrices.

Every matrix of Eq. 2 is a sum of four boom blocks (`n_B x n_B`, on one boom's
coordinates) and four quadrant blocks (`n~ x n~`, `n~ = 2 n_B + n_M`, on
`[p_first, p_second, q_quadrant]`; model.md §6). The moving step needs two
things of them: products with vectors, and solutions of

    S(tau) u = r,    S(tau) = A_0 + tau A_1 + tau^2 A_2,    tau complex.

A quadrant's membrane coordinates couple only to its own two booms, so
`S(tau)` is a bordered block-diagonal matrix: each quadrant's `n_M x n_M`
membrane block is eliminated on its own, which leaves a `4 n_B x 4 n_B`
system on the boom coordinates (the Schur complement). At (20, 20) that is a
third of the arithmetic of the dense `n x n` solve, and nothing is gathered
out of a full matrix.
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.layout import QUADRANTS, Layout

_POWERS = np.arange(3)
_BOOMS = np.arange(4)
_NEXT = (_BOOMS + 1) % 4  # quadrant b's second boom (QUADRANTS: ab, bc, cd, da)
_PREVIOUS = (_BOOMS - 1) % 4  # the quadrant whose second boom is boom b


class BlockLayout:
    """Where the component blocks of a layout sit (the booms' coordinates come first)."""

    def __init__(self, layout: Layout):
        self.n = layout.n
        nb = layout.n_boom_modes
        self.n_boom_coordinates = 4 * nb
        slots = np.stack([layout.quadrant_slots(q) for q in QUADRANTS])  # (4, n~)
        self.quadrant_slots = slots
        self.quadrant_boom_slots = slots[:, : 2 * nb]  # (4, 2 n_B): among the boom coordinates
        self.membrane_slots = slots[:, 2 * nb :]  # (4, n_M), in quadrant order, contiguous


class BlockMatrices:
    """`k` matrices held as boom blocks `(k, 4, n_B, n_B)` and quadrant blocks
    `(k, 4, n~, n~)` (what `SystemAssembler.evaluate_blocks` returns)."""

    def __init__(self, booms: np.ndarray, quadrants: np.ndarray, where: BlockLayout):
        self.booms = booms
        self.quadrants = quadrants
        self.where = where

    def dense(self) -> np.ndarray:
        """The matrices added up, `(k, n, n)` (for checks; the step never needs them)."""
        k, n, nb = self.booms.shape[0], self.where.n, self.booms.shape[-1]
        out = np.zeros((k, n, n))
        for b in range(4):
            out[:, b * nb : (b + 1) * nb, b * nb : (b + 1) * nb] += self.booms[:, b]
        for q, slots in enumerate(self.where.quadrant_slots):
            out[:, slots[:, None], slots[None, :]] += self.quadrants[:, q]
        return out

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """`A_i x_i` for every matrix `i`: `x` of shape (k, n) or (n,) (the same vector
        for all); returns (k, n)."""
        where = self.where
        k, nb = self.booms.shape[0], self.booms.shape[-1]
        nbc = where.n_boom_coordinates
        x = np.broadcast_to(x, (k, where.n))
        on_booms = (self.booms @ x[:, :nbc].reshape(k, 4, nb, 1))[..., 0]
        on_quadrants = (self.quadrants @ x[:, where.quadrant_slots][..., None])[..., 0]
        on_booms += on_quadrants[:, :, :nb] + on_quadrants[:, _PREVIOUS, nb : 2 * nb]
        return np.concatenate(
            [on_booms.reshape(k, nbc), on_quadrants[:, :, 2 * nb :].reshape(k, -1)], axis=1
        )

    def solve_shifted(self, taus: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`u_j = (A_0 + tau_j A_1 + tau_j^2 A_2)^-1 rhs_j` for complex `taus` (p,) and
        `rhs` (p, n): the membrane blocks eliminated quadrant by quadrant, then the
        boom coordinates solved; returns (p, n) complex."""
        where = self.where
        nb = self.booms.shape[-1]
        nbc = where.n_boom_coordinates
        powers = taus[:, None] ** _POWERS  # (p, 3): 1, tau, tau^2
        booms = _combine(powers, self.booms[:3])  # (p, 4, n_B, n_B)
        quadrants = _combine(powers, self.quadrants[:3])  # (p, 4, n~, n~)
        edge, inner = slice(0, 2 * nb), slice(2 * nb, None)
        # membrane block: [S_mb | r_m] -> S_mm^-1 [S_mb | r_m]
        membrane_rhs = rhs[:, where.membrane_slots][..., None]  # (p, 4, n_M, 1)
        eliminated = np.linalg.solve(
            quadrants[:, :, inner, inner],
            np.concatenate([quadrants[:, :, inner, edge], membrane_rhs], axis=-1),
        )
        border = quadrants[:, :, edge, inner]  # S_bm
        schur = quadrants[:, :, edge, edge] - border @ eliminated[..., :-1]
        boom_rhs_part = (border @ eliminated[..., -1:])[..., 0]
        # Quadrant q spans booms q (first) and q + 1 (second): boom b's diagonal block
        # gathers quadrant b's first and quadrant b - 1's second block.
        p, first, second = taus.size, slice(0, nb), slice(nb, 2 * nb)
        grid = np.zeros((p, 4, 4, nb, nb), dtype=complex)  # (boom row, boom column) blocks
        grid[:, _BOOMS, _BOOMS] = (
            booms + schur[:, :, first, first] + schur[:, _PREVIOUS, second, second]
        )
        grid[:, _BOOMS, _NEXT] = schur[:, :, first, second]
        grid[:, _NEXT, _BOOMS] = schur[:, :, second, first]
        system = grid.transpose(0, 1, 3, 2, 4).reshape(p, nbc, nbc)
        boom_rhs = rhs[:, :nbc].reshape(p, 4, nb) - (
            boom_rhs_part[:, :, first] + boom_rhs_part[:, _PREVIOUS, second]
        )
        u_boom = np.linalg.solve(system, boom_rhs.reshape(p, nbc, 1))  # (p, 4 n_B, 1)
        u_edge = u_boom[:, where.quadrant_boom_slots]  # (p, 4, 2 n_B, 1)
        u_membrane = eliminated[..., -1] - (eliminated[..., :-1] @ u_edge)[..., 0]
        return np.concatenate([u_boom[..., 0], u_membrane.reshape(p, -1)], axis=1)


def _combine(powers: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """`sum_i powers[:, i] blocks[i]` for real `blocks` (3, ...) and complex `powers`
    (p, 3): the real and imaginary parts written straight into the complex result
    (a third of the time of forming them apart and adding)."""
    flat = blocks.reshape(blocks.shape[0], -1)
    out = np.empty((powers.shape[0], flat.shape[1]), dtype=complex)
    parts = out.view(float).reshape(*out.shape, 2)
    np.matmul(powers.real, flat, out=parts[..., 0])
    np.matmul(powers.imag, flat, out=parts[..., 1])
    return out.reshape(powers.shape[0], *blocks.shape[1:])


class DenseMatrices:
    """`k` matrices held in full, `(k, n, n)`, with the operations of `BlockMatrices`:
    for small systems, where one LAPACK call on the whole matrix costs less than
    numpy's per-call overhead on many small blocks."""

    def __init__(self, matrices: np.ndarray):
        self.matrices = matrices

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """`A_i x_i` for every matrix `i` (`x` (k, n) or (n,)); returns (k, n)."""
        return (self.matrices @ np.broadcast_to(x, self.matrices.shape[:2])[..., None])[..., 0]

    def solve_shifted(self, taus: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`(A_0 + tau_j A_1 + tau_j^2 A_2)^-1 rhs_j`, dense; (p, n) complex."""
        systems = _combine(taus[:, None] ** _POWERS, self.matrices[:3])
        return np.linalg.solve(systems, rhs[..., None])[..., 0]
