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

A free hub (model.md §13) couples to every coordinate: its three rows and
columns are a `Border`, dense against the blocks. The mean-axes damping adds
`-c U W^-1 U^T` on the elastic coordinates (`LowRank`, `U = M_qh`,
`W = M_hh`), which the solve carries as three more border rows
(`W v - U^T u = 0`, then `-c U v` in the elastic rows). The membranes are
eliminated as before, border columns and all, which leaves a
`(4 n_B + b)` bordered system on the booms and the border.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sail_ros.model.layout import QUADRANTS, Layout

_POWERS = np.arange(3)
_BOOMS = np.arange(4)
_NEXT = (_BOOMS + 1) % 4  # quadrant b's second boom (QUADRANTS: ab, bc, cd, da)
_PREVIOUS = (_BOOMS - 1) % 4  # the quadrant whose second boom is boom b


class BlockLayout:
    """Where the component blocks of a layout sit (the booms' coordinates come first,
    the hub's, if free, last)."""

    def __init__(self, layout: Layout):
        self.n = layout.n
        self.n_elastic = layout.n_elastic
        nb = layout.n_boom_modes
        self.n_boom_coordinates = 4 * nb
        slots = np.stack([layout.quadrant_slots(q) for q in QUADRANTS])  # (4, n~)
        self.quadrant_slots = slots
        self.quadrant_boom_slots = slots[:, : 2 * nb]  # (4, 2 n_B): among the boom coordinates
        self.membrane_slots = slots[:, 2 * nb :]  # (4, n_M), in quadrant order, contiguous


class Border(NamedTuple):
    """The hub's rows and columns of `k` matrices: `rows` (k, 3, n) against every
    coordinate (the hub block included), `columns` (k, n_e, 3) of the elastic rows."""

    rows: np.ndarray
    columns: np.ndarray


class LowRank(NamedTuple):
    """`-coefficients[i] U W^-1 U^T` on the elastic block of matrix `i`: `U` (n_e, 3),
    `W` (3, 3) symmetric positive definite (the mean-axes damping: `U = M_qh`,
    `W = M_hh`, coefficient alpha)."""

    coefficients: np.ndarray
    U: np.ndarray
    W: np.ndarray


class BlockMatrices:
    """`k` matrices held as boom blocks `(k, 4, n_B, n_B)` and quadrant blocks
    `(k, 4, n~, n~)` (what `SystemAssembler.evaluate_blocks` returns), with a free
    hub's `border` and the mean-axes damping's `low_rank` part."""

    def __init__(
        self,
        booms: np.ndarray,
        quadrants: np.ndarray,
        where: BlockLayout,
        border: Border | None = None,
        low_rank: LowRank | None = None,
    ):
        self.booms = booms
        self.quadrants = quadrants
        self.where = where
        self.border = border
        self.low_rank = low_rank

    def dense(self) -> np.ndarray:
        """The matrices added up, `(k, n, n)` (for checks; the step never needs them)."""
        k, n, nb = self.booms.shape[0], self.where.n, self.booms.shape[-1]
        n_e = self.where.n_elastic
        out = np.zeros((k, n, n))
        for b in range(4):
            out[:, b * nb : (b + 1) * nb, b * nb : (b + 1) * nb] += self.booms[:, b]
        for q, slots in enumerate(self.where.quadrant_slots):
            out[:, slots[:, None], slots[None, :]] += self.quadrants[:, q]
        if self.border is not None:
            out[:, n_e:, :] = self.border.rows
            out[:, :n_e, n_e:] = self.border.columns
        if self.low_rank is not None:
            U, W = self.low_rank.U, self.low_rank.W
            correction = U @ np.linalg.solve(W, U.T)
            out[:, :n_e, :n_e] -= self.low_rank.coefficients[:, None, None] * correction
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
        parts = [on_booms.reshape(k, nbc), on_quadrants[:, :, 2 * nb :].reshape(k, -1)]
        if self.border is None:
            return np.concatenate(parts, axis=1)
        n_e = where.n_elastic
        elastic = np.concatenate(parts, axis=1)
        elastic += (self.border.columns @ x[:, n_e:, None])[..., 0]
        if self.low_rank is not None:
            U, W = self.low_rank.U, self.low_rank.W
            projected = np.linalg.solve(W, U.T @ x[:, :n_e].T)  # (3, k)
            elastic -= self.low_rank.coefficients[:, None] * (U @ projected).T
        hub = (self.border.rows @ x[..., None])[..., 0]
        return np.concatenate([elastic, hub], axis=1)

    def solve_shifted(self, taus: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`u_j = (A_0 + tau_j A_1 + tau_j^2 A_2)^-1 rhs_j` for complex `taus` (p,) and
        `rhs` (p, n): the membrane blocks eliminated quadrant by quadrant, then the
        boom coordinates (and the border, with a free hub) solved; returns (p, n)
        complex."""
        where = self.where
        nb = self.booms.shape[-1]
        nbc = where.n_boom_coordinates
        powers = taus[:, None] ** _POWERS  # (p, 3): 1, tau, tau^2
        booms = _combine(powers, self.booms[:3])  # (p, 4, n_B, n_B)
        quadrants = _combine(powers, self.quadrants[:3])  # (p, 4, n~, n~)
        p, first, second = taus.size, slice(0, nb), slice(nb, 2 * nb)
        columns, rows, corner, border_rhs = self._border(powers, rhs)  # b border coordinates
        b = corner.shape[-1]
        edge, inner = slice(0, 2 * nb), slice(2 * nb, None)
        # membrane block: [S_mb | S_m,border | r_m] -> S_mm^-1 [S_mb | S_m,border | r_m]
        membrane_rhs = rhs[:, where.membrane_slots][..., None]  # (p, 4, n_M, 1)
        membrane_border = columns[:, where.membrane_slots]  # (p, 4, n_M, b)
        eliminated = np.linalg.solve(
            quadrants[:, :, inner, inner],
            np.concatenate([quadrants[:, :, inner, edge], membrane_border, membrane_rhs], axis=-1),
        )
        to_edge, to_border, to_rhs = (
            eliminated[..., : 2 * nb],
            eliminated[..., 2 * nb : 2 * nb + b],
            eliminated[..., -1:],
        )
        coupling = quadrants[:, :, edge, inner]  # S_bm
        schur = quadrants[:, :, edge, edge] - coupling @ to_edge
        boom_rhs_part = (coupling @ to_rhs)[..., 0]
        # Quadrant q spans booms q (first) and q + 1 (second): boom b's diagonal block
        # gathers quadrant b's first and quadrant b - 1's second block.
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
        boom_rhs = boom_rhs.reshape(p, nbc, 1)
        if b:
            system, boom_rhs = _bordered(
                system, boom_rhs, columns, rows, corner, border_rhs, coupling, eliminated, where
            )
        solution = np.linalg.solve(system, boom_rhs)  # (p, 4 n_B + b, 1)
        u_boom, u_border = solution[:, :nbc], solution[:, nbc:]
        u_edge = u_boom[:, where.quadrant_boom_slots]  # (p, 4, 2 n_B, 1)
        u_membrane = to_rhs[..., 0] - (to_edge @ u_edge)[..., 0]
        if b:
            u_membrane -= (to_border @ u_border[:, None])[..., 0]
        parts = [u_boom[..., 0], u_membrane.reshape(p, -1)]
        if self.border is not None:
            parts.append(u_border[:, :3, 0])
        return np.concatenate(parts, axis=1)

    def _border(self, powers, rhs):
        """The border of the shifted matrices: its columns on the elastic rows
        (p, n_e, b), its rows on the elastic columns (p, b, n_e), the corner
        (p, b, b) and its right-hand side (p, b): b = 0 (clamped hub), 3 (the hub's
        rows) or 6 (and the low-rank part's three)."""
        p, n_e = powers.shape[0], self.where.n_elastic
        if self.border is None:
            empty = np.zeros((p, n_e, 0), dtype=complex)
            return empty, empty.transpose(0, 2, 1), np.zeros((p, 0, 0), complex), rhs[:, :0]
        hub_rows = _combine(powers, self.border.rows[:3])  # (p, 3, n)
        columns = _combine(powers, self.border.columns[:3])  # (p, n_e, 3)
        rows, corner, border_rhs = hub_rows[:, :, :n_e], hub_rows[:, :, n_e:], rhs[:, n_e:]
        if self.low_rank is not None:  # aux v: W v - U^T u = 0; elastic rows - c(tau) U v
            U, W = self.low_rank.U, self.low_rank.W
            c = powers @ self.low_rank.coefficients[:3]  # (p,)
            columns = np.concatenate([columns, -c[:, None, None] * U], axis=-1)
            rows = np.concatenate([rows, np.broadcast_to(-U.T, (p, 3, n_e))], axis=1)
            zero = np.zeros((p, 3, 3), dtype=complex)
            corner = np.concatenate(
                [
                    np.concatenate([corner, zero], axis=-1),
                    np.concatenate([zero, np.broadcast_to(W, (p, 3, 3))], axis=-1),
                ],
                axis=1,
            )
            border_rhs = np.concatenate([border_rhs, np.zeros((p, 3))], axis=1)
        return columns, rows, corner, border_rhs


def _bordered(system, boom_rhs, columns, rows, corner, border_rhs, coupling, eliminated, where):
    """The boom system (p, 4 n_B, 4 n_B) and its right-hand side (p, 4 n_B, 1) with the
    border appended, the membranes eliminated from it too: `(p, 4 n_B + b, ...)`.

    `columns`, `rows`: the border against the elastic coordinates; `coupling` the
    quadrants' boom-membrane blocks `S_bm` and `eliminated` `S_mm^-1 [S_mb | E_m | r_m]`."""
    p, nbc = boom_rhs.shape[0], where.n_boom_coordinates
    nb, b = nbc // 4, corner.shape[-1]
    first, second = slice(0, nb), slice(nb, 2 * nb)
    to_edge, to_border = eliminated[..., : 2 * nb], eliminated[..., 2 * nb : 2 * nb + b]
    to_rhs = eliminated[..., -1:]
    membrane_rows = rows[:, :, where.membrane_slots].transpose(0, 2, 1, 3)  # (p, 4, b, n_M)
    # boom rows, border columns: E_b - S_bm S_mm^-1 E_m, gathered onto each boom
    edge_border = coupling @ to_border  # (p, 4, 2 n_B, b)
    boom_border = columns[:, :nbc].reshape(p, 4, nb, b) - (
        edge_border[:, :, first] + edge_border[:, _PREVIOUS, second]
    )
    # border rows, boom columns: F_b - F_m S_mm^-1 S_mb
    border_edge = membrane_rows @ to_edge  # (p, 4, b, 2 n_B)
    border_boom = rows[:, :, :nbc].reshape(p, b, 4, nb) - (
        border_edge[..., first] + border_edge[:, _PREVIOUS][..., second]
    ).transpose(0, 2, 1, 3)
    reduced_corner = corner - (membrane_rows @ to_border).sum(axis=1)
    reduced_rhs = border_rhs - (membrane_rows @ to_rhs)[..., 0].sum(axis=1)
    bordered = np.empty((p, nbc + b, nbc + b), dtype=complex)
    bordered[:, :nbc, :nbc] = system
    bordered[:, :nbc, nbc:] = boom_border.reshape(p, nbc, b)
    bordered[:, nbc:, :nbc] = border_boom.reshape(p, b, nbc)
    bordered[:, nbc:, nbc:] = reduced_corner
    return bordered, np.concatenate([boom_rhs, reduced_rhs[..., None]], axis=1)


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
