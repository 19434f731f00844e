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
(`W v - U^T u = 0`, then `-c U v` in the elastic rows). The border's columns
go through the block solve with the right-hand side (membranes eliminated,
then the booms, one factorisation for all of them), which leaves a small
`b x b` system for the border itself.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sail_ros.model.lapack import gesv_complex as _gesv
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


class Border:
    """The hub's rows and columns of `k` matrices, held flat (k, 3 n + 3 n_e): `rows`
    (k, 3, n) against every coordinate (the hub block included), then `columns`
    (k, n_e, 3) of the elastic rows."""

    def __init__(self, flat: np.ndarray, n: int, n_elastic: int):
        self.flat, self.n, self.n_elastic = flat, n, n_elastic

    @property
    def rows(self) -> np.ndarray:
        return self.flat[..., : 3 * self.n].reshape(*self.flat.shape[:-1], 3, self.n)

    @property
    def columns(self) -> np.ndarray:
        return self.flat[..., 3 * self.n :].reshape(*self.flat.shape[:-1], self.n_elastic, 3)


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

    def forms(self, index: int, V: np.ndarray) -> np.ndarray:
        """`diag(V^T A V)` of matrix `index` (`V` (n, m)): each column's quadratic form,
        block by block (m,)."""
        where = self.where
        nb, nbc = self.booms.shape[-1], where.n_boom_coordinates
        on_booms = V[:nbc].reshape(4, nb, -1)
        on_quadrants = V[where.quadrant_slots]  # (4, n~, m)
        out = np.einsum("bjm,bjm->m", on_booms, self.booms[index] @ on_booms)
        out += np.einsum("qjm,qjm->m", on_quadrants, self.quadrants[index] @ on_quadrants)
        if self.border is not None:
            n_e = where.n_elastic
            hub = V[n_e:]
            out += np.einsum("hm,hm->m", hub, self.border.rows[index] @ V)
            out += np.einsum("em,em->m", V[:n_e], self.border.columns[index] @ hub)
        if self.low_rank is not None:
            U, W = self.low_rank.U, self.low_rank.W
            projected = U.T @ V[: U.shape[0]]  # (3, m)
            forms = np.einsum("hm,hm->m", projected, np.linalg.solve(W, projected))
            out -= self.low_rank.coefficients[index] * forms
        return out

    def solve_shifted(self, taus: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`u_j = (A_0 + tau_j A_1 + tau_j^2 A_2)^-1 rhs_j` for complex `taus` (p,) and
        `rhs` (p, n), or (p, n, m) for m right-hand sides at once: the membrane blocks
        eliminated quadrant by quadrant, then the boom coordinates solved; with a border,
        its columns are solved for alongside the right-hand side (one factorisation), and
        the border from the small system left, `(Z - F S^-1 E) u_b = r_b - F S^-1 r`;
        returns complex, the shape of `rhs`."""
        return self._solve(taus[:, None] ** _POWERS, rhs)  # powers (p, 3): 1, tau, tau^2

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """`A_0^-1 rhs` (a mass matrix's solve), in real arithmetic, `rhs` (n,) or (n, m)
        for m right-hand sides; by blocks as `solve_shifted`."""
        return self._solve(np.ones((1, 1)), rhs[None])[0]

    def _solve(self, powers: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`(sum_i powers[j, i] A_i)^-1 rhs_j` for `powers` (p, c), complex or real."""
        single = rhs.ndim == 2
        rhs = rhs[..., None] if single else rhs
        m = rhs.shape[-1]
        count = powers.shape[1]
        booms = _combine(powers, self.booms[:count])  # (p, 4, n_B, n_B)
        quadrants = _combine(powers, self.quadrants[:count])  # (p, 4, n~, n~)
        if self.border is None:
            out = self._solve_blocks(booms, quadrants, rhs)
            return out[..., 0] if single else out
        n_e = self.where.n_elastic
        columns, rows, corner, border_rhs = self._border(powers, rhs)  # E, F, Z, r_b
        solved = self._solve_blocks(
            booms, quadrants, np.concatenate([rhs[:, :n_e], columns], axis=-1)
        )
        u_border = np.linalg.solve(
            corner - rows @ solved[..., m:], border_rhs - rows @ solved[..., :m]
        )
        u_elastic = solved[..., :m] - solved[..., m:] @ u_border
        out = np.concatenate([u_elastic, u_border[:, :3]], axis=1)
        return out[..., 0] if single else out

    def _solve_blocks(self, booms, quadrants, rhs):
        """`S^-1 rhs` on the elastic coordinates, `rhs` (p, n_e, m): each quadrant's
        membrane eliminated, then the `4 n_B` boom coordinates solved."""
        where = self.where
        nb = self.booms.shape[-1]
        nbc = where.n_boom_coordinates
        p, m = rhs.shape[0], rhs.shape[-1]
        edge, inner = slice(0, 2 * nb), slice(2 * nb, None)
        # membrane block: [S_mb | r_m] -> S_mm^-1 [S_mb | r_m]
        membrane_rhs = rhs[:, where.membrane_slots]  # (p, 4, n_M, m)
        eliminated = np.linalg.solve(
            quadrants[:, :, inner, inner],
            np.concatenate([quadrants[:, :, inner, edge], membrane_rhs], axis=-1),
        )
        to_edge, to_rhs = eliminated[..., : 2 * nb], eliminated[..., 2 * nb :]
        coupling = quadrants[:, :, edge, inner]  # S_bm
        schur = quadrants[:, :, edge, edge] - coupling @ to_edge
        boom_rhs_part = coupling @ to_rhs  # (p, 4, 2 n_B, m)
        # Quadrant q spans booms q (first) and q + 1 (second): boom b's diagonal block
        # gathers quadrant b's first and quadrant b - 1's second block.
        first, second = slice(0, nb), slice(nb, 2 * nb)
        grid = np.zeros((p, 4, 4, nb, nb), dtype=booms.dtype)  # (boom row, column) blocks
        grid[:, _BOOMS, _BOOMS] = (
            booms + schur[:, :, first, first] + schur[:, _PREVIOUS, second, second]
        )
        grid[:, _BOOMS, _NEXT] = schur[:, :, first, second]
        grid[:, _NEXT, _BOOMS] = schur[:, :, second, first]
        system = grid.transpose(0, 1, 3, 2, 4).reshape(p, nbc, nbc)
        boom_rhs = rhs[:, :nbc].reshape(p, 4, nb, m) - (
            boom_rhs_part[:, :, first] + boom_rhs_part[:, _PREVIOUS, second]
        )
        u_boom = np.linalg.solve(system, boom_rhs.reshape(p, nbc, m))  # (p, 4 n_B, m)
        u_edge = u_boom[:, where.quadrant_boom_slots]  # (p, 4, 2 n_B, m)
        u_membrane = to_rhs - to_edge @ u_edge
        return np.concatenate([u_boom, u_membrane.reshape(p, -1, m)], axis=1)

    def _border(self, powers, rhs):
        """The border of the shifted matrices: its columns on the elastic rows
        (p, n_e, b), its rows on the elastic columns (p, b, n_e), the corner
        (p, b, b) and its right-hand side (p, b, m): b = 3 (the hub's rows) or 6 (and
        the low-rank part's three), with `rhs` (p, n, m)."""
        p, n_e = powers.shape[0], self.where.n_elastic
        count = powers.shape[1]
        shifted = Border(_combine(powers, self.border.flat[:count]), self.where.n, n_e)
        hub_rows, columns = shifted.rows, shifted.columns  # (p, 3, n), (p, n_e, 3)
        rows, corner, border_rhs = hub_rows[:, :, :n_e], hub_rows[:, :, n_e:], rhs[:, n_e:]
        if self.low_rank is not None:  # aux v: W v - U^T u = 0; elastic rows - c(tau) U v
            U, W = self.low_rank.U, self.low_rank.W
            c = powers @ self.low_rank.coefficients[:count]  # (p,)
            columns = np.concatenate([columns, -c[:, None, None] * U], axis=-1)
            rows = np.concatenate([rows, np.broadcast_to(-U.T, (p, 3, n_e))], axis=1)
            zero = np.zeros((p, 3, 3), dtype=corner.dtype)
            corner = np.concatenate(
                [
                    np.concatenate([corner, zero], axis=-1),
                    np.concatenate([zero, np.broadcast_to(W, (p, 3, 3))], axis=-1),
                ],
                axis=1,
            )
            border_rhs = np.concatenate([border_rhs, np.zeros((p, 3, rhs.shape[-1]))], axis=1)
        return columns, rows, corner, border_rhs


def _combine(powers: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """`sum_i powers[:, i] blocks[i]` for real `blocks` (c, ...) and `powers` (p, c):
    complex powers' real and imaginary parts written straight into the complex result
    (no temporaries for the two parts and their sum)."""
    flat = blocks.reshape(blocks.shape[0], -1)
    if not np.iscomplexobj(powers):
        return (powers @ flat).reshape(powers.shape[0], *blocks.shape[1:])
    out = np.empty((powers.shape[0], flat.shape[1]), dtype=complex)
    parts = out.view(float).reshape(*out.shape, 2)
    np.matmul(powers.real, flat, out=parts[..., 0])
    np.matmul(powers.imag, flat, out=parts[..., 1])
    return out.reshape(powers.shape[0], *blocks.shape[1:])


class DenseMatrices:
    """`k` matrices held in full, `(k, n, n)`, with the operations of `BlockMatrices`
    the moving step uses (`matvec`, `forms`, `solve_shifted`): for small systems, where
    one LAPACK call on the whole matrix costs less than numpy's per-call overhead on many
    small blocks."""

    def __init__(self, matrices: np.ndarray):
        self.matrices = matrices

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """`A_i x_i` for every matrix `i` (`x` (k, n) or (n,)); returns (k, n)."""
        if x.ndim == 1:
            return self.matrices @ x
        return (self.matrices @ x[..., None])[..., 0]

    def forms(self, index: int, V: np.ndarray) -> np.ndarray:
        """`diag(V^T A V)` of matrix `index` (`V` (n, m)) (m,)."""
        return np.einsum("jm,jm->m", V, self.matrices[index] @ V)

    def solve_shifted(self, taus: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """`(A_0 + tau_j A_1 + tau_j^2 A_2)^-1 rhs_j`, dense; (p, n) complex (LAPACK's
        solve one system at a time: numpy's stacked solve costs more per call)."""
        systems = _combine(taus[:, None] ** _POWERS, self.matrices[:3])
        out = np.empty(rhs.shape, dtype=complex)
        for j, system in enumerate(systems):
            _, _, out[j], info = _gesv(system, rhs[j], overwrite_a=True)
            if info > 0:
                raise np.linalg.LinAlgError(f"singular shifted matrix (gesv info {info})")
        return out
