"""Time-invariant integrals on the reference domains (model.md §5).

Every matrix of the model is a scalar coefficient (a function of the boom
lengths, rates and accelerations) times one of these integrals. They are
computed once per `(n_B, n_M)` and cached, so nothing is integrated over the
physical domain at run time.

Notation (model.md §3): on a boom `[0, 1]`, `psi` and `psi' = dpsi/dxi`; on
the unit triangle `D`, the quadrant vector functions

    S     = [psi(xi);  psi(eta);  phi]
    S_xi  = [psi'(xi); 0;         dphi/dxi]
    S_eta = [0;        psi'(eta); dphi/deta]
    R_a   = (1 - xi) S_xi,   R_b = (1 - eta) S_eta

and `<f g^T>` is the integral of the outer product over the domain.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from numpy.polynomial.legendre import leggauss

from sail_ros.model.basis import (
    SeparableSum,
    cantilever_modes,
    cantilever_modes_and_slopes,
    cantilever_roots,
    triangle_mode_indices,
    triangle_mode_terms,
    trig_table,
)
from sail_ros.model.integral_store import stored_arrays


def default_quadrature_order(n_boom_modes: int, n_membrane_modes: int) -> int:
    """Gauss points per direction that resolve every product of two basis functions.

    A product of two basis functions oscillates with angular frequency at most
    `2 max(beta_nB, pi m_max)`; Gauss-Legendre with a margin of 40 points over
    that integrates it to machine precision (the tests refine the rule and see
    no change in the 9th digit of any frequency).
    """
    beta_max = cantilever_roots(n_boom_modes)[-1]
    m_max = max(m for m, _ in triangle_mode_indices(n_membrane_modes))
    return int(2.0 * max(beta_max, np.pi * m_max)) + 40


# Points per chunk of the triangle rule: few enough for a chunk's functions to stay in a
# few MB of cache, enough for numpy's cost per call to be spread thin.
_CHUNK_POINTS = 8192


def _chunk_rows(order: int) -> int:
    """Rows of the tensor rule (distinct `u`) per chunk of about `_CHUNK_POINTS` points."""
    return max(1, _CHUNK_POINTS // order)


def integral_bytes(n_boom_modes: int, n_membrane_modes: int, order: int) -> int:
    """Peak working memory [bytes] of building the quadrant integrals, 8 bytes a number.

    The row moments (3 powers of `1 - eta`, `order` rows, `n_Y x n_Z`), the functions of
    one chunk of points with their weighted copies and temporaries (about 12 `n_Y` per
    point), one gathered `order x n x n_M` moment tensor at a time (with its two
    weighted factors) and the nine results `n~ x n~`; `n_Z = 2 (j_max + 1)` sines and
    cosines, `n_Y = 2 n_B + n_Z` functions of `eta`, `n~ = 2 n_B + n_M`.
    """
    n_z = 2 * (max(m for m, _ in triangle_mode_indices(n_membrane_modes)) + 1)
    n_y = 2 * n_boom_modes + n_z
    moments = 3 * order * n_y * n_z
    chunk = 12 * n_y * _chunk_rows(order) * order
    gathered = 3 * order * max(n_boom_modes, n_membrane_modes) * n_membrane_modes
    results = 9 * (2 * n_boom_modes + n_membrane_modes) ** 2
    return 8 * (moments + chunk + gathered + results)


def available_memory_bytes() -> int | None:
    """Memory the machine can still give [bytes] (Linux MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as stream:
            for line in stream:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def check_affordable(n_boom_modes: int, n_membrane_modes: int, order: int) -> None:
    """Refuse, before allocating anything, mode counts whose integrals would not fit.

    Raises:
        ValueError: naming the mode counts, the estimate and what is available.
    """
    need, have = integral_bytes(n_boom_modes, n_membrane_modes, order), available_memory_bytes()
    if have is not None and need > 0.8 * have:
        raise ValueError(
            f"n_boom_modes = {n_boom_modes}, n_membrane_modes = {n_membrane_modes} need about "
            f"{need / 2**30:.3g} GiB to build their integrals ({order} x {order} quadrature "
            f"points); this machine has {have / 2**30:.3g} GiB available"
        )


def gauss_unit_interval(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [0, 1]."""
    x, w = leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w


def collapsed_gauss_triangle(order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Collapsed Gauss rule on D: `xi = u`, `eta = (1 - u) v`, weight `(1 - u)`."""
    u, wu = gauss_unit_interval(order)
    v, wv = gauss_unit_interval(order)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    xi = uu.ravel()
    eta = ((1.0 - uu) * vv).ravel()
    weight = (np.outer(wu, wv) * (1.0 - uu)).ravel()
    return xi, eta, weight


def _gram(f: np.ndarray, g: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """<f g^T> = sum_q w_q f(x_q) g(x_q)^T."""
    return (f * weight) @ g.T


@dataclasses.dataclass(frozen=True)
class BoomIntegrals:
    """Integrals over a boom's reference interval, each `n_B x n_B`."""

    psi_psi: np.ndarray  # <psi psi^T> (= I)
    psi_r: np.ndarray  # <psi ((1-xi) psi')^T>
    r_r: np.ndarray  # <(1-xi)^2 psi' psi'^T>
    d2_d2: np.ndarray  # <psi'' psi''^T> (= diag beta^4)
    d1_d1: np.ndarray  # <psi' psi'^T>
    tip: np.ndarray  # psi(1), the tip values (+-2)
    root_curvature: np.ndarray  # psi''(0) (= 2 beta^2)
    # vectors (n_B,) of the free hub (model.md §13.4)
    psi_mean: np.ndarray  # <psi>
    xi_psi: np.ndarray  # <xi psi>
    r_mean: np.ndarray  # <(1-xi) psi'>
    xi_r: np.ndarray  # <xi (1-xi) psi'>


@dataclasses.dataclass(frozen=True)
class QuadrantIntegrals:
    """Integrals over the unit triangle, each `n~ x n~` with `n~ = 2 n_B + n_M`."""

    s_s: np.ndarray  # <S S^T>
    s_ra: np.ndarray  # <S R_a^T>
    s_rb: np.ndarray  # <S R_b^T>
    ra_ra: np.ndarray  # <R_a R_a^T>
    ra_rb: np.ndarray  # <R_a R_b^T + R_b R_a^T>
    rb_rb: np.ndarray  # <R_b R_b^T>
    sxi_sxi: np.ndarray  # <S_xi S_xi^T>
    seta_seta: np.ndarray  # <S_eta S_eta^T>
    s_mean: np.ndarray  # <S> (n~,): the work of a uniform pressure
    # vectors (n~,) of the free hub (model.md §13.4)
    xi_s: np.ndarray  # <xi S>
    eta_s: np.ndarray  # <eta S>
    ra_mean: np.ndarray  # <R_a>
    xi_ra: np.ndarray  # <xi R_a>
    eta_ra: np.ndarray  # <eta R_a>
    rb_mean: np.ndarray  # <R_b>
    xi_rb: np.ndarray  # <xi R_b>
    eta_rb: np.ndarray  # <eta R_b>


def _freeze(obj):
    for field in dataclasses.fields(obj):
        getattr(obj, field.name).flags.writeable = False
    return obj


@functools.cache
def boom_integrals(n_boom_modes: int, order: int) -> BoomIntegrals:
    x, w = gauss_unit_interval(order)
    psi = cantilever_modes(n_boom_modes, x)
    d1 = cantilever_modes(n_boom_modes, x, 1)
    d2 = cantilever_modes(n_boom_modes, x, 2)
    r = (1.0 - x) * d1
    return _freeze(
        BoomIntegrals(
            psi_psi=_gram(psi, psi, w),
            psi_r=_gram(psi, r, w),
            r_r=_gram(r, r, w),
            d2_d2=_gram(d2, d2, w),
            d1_d1=_gram(d1, d1, w),
            tip=cantilever_modes(n_boom_modes, [1.0])[:, 0].copy(),
            root_curvature=cantilever_modes(n_boom_modes, [0.0], 2)[:, 0].copy(),
            psi_mean=psi @ w,
            xi_psi=psi @ (x * w),
            r_mean=r @ w,
            xi_r=r @ (x * w),
        )
    )


class _RowRule:
    """The collapsed rule as a sum over its rows `u_i` of sums over `v_j`.

    On row `i`, `xi = u_i`, `eta_ij = (1 - u_i) v_j` and the weight is
    `omega_i wv_j` with `omega_i = wu_i (1 - u_i)`. A function of `xi` is constant
    along a row, so every integral reduces to the row moments of the functions of
    `eta`, `Y = [psi; psi'; T]` against the trig table `T` (sines then cosines of
    `j pi eta`, `trig_table`):

        moments[c][i, f, z] = sum_j wv_j (1 - eta_ij)^c Y_f(eta_ij) T_z(eta_ij),  c = 0, 1, 2.

    The membrane modes are `SeparableSum`s of `T` rows. (Two functions of `eta` alone
    need no moments: `D` is symmetric in `xi` and `eta`, so their integral is that of
    the same functions of `xi`, `xi_xi`.)
    The methods' `c1`, `c2` are the powers of `(1 - xi)` and `(1 - eta)` in the weight;
    `a`, `b` are functions of `xi` at the `u_i` (`(k, order)`), `y_rows` a slice of `Y`.
    """

    def __init__(self, n_boom_modes: int, n_membrane_modes: int, order: int):
        u, wu = gauss_unit_interval(order)  # the same rule in u and in v
        self.u, self.v, self.wv, self.omega = u, u, wu, wu * (1.0 - u)
        self.j_max, *self.membrane = triangle_mode_terms(n_membrane_modes)
        self.nb = nb = n_boom_modes
        n_z = 2 * (self.j_max + 1)
        # rows of Y: psi, psi', then T (T_z is row trig.start + z)
        self.psi = slice(0, nb)
        self.dpsi = slice(nb, 2 * nb)
        self.trig = slice(2 * nb, 2 * nb + n_z)
        self.one = self.j_max + 1  # cos(0 pi eta), the row of T that is 1
        self.xi_trig = trig_table(self.j_max, u)
        self.moments = np.empty((3, order, 2 * nb + n_z, n_z))
        self._chunk_buffers: dict = {}
        for start in range(0, order, _chunk_rows(order)):
            self._add_rows(slice(start, start + _chunk_rows(order)))

    def _add_rows(self, rows: slice) -> None:
        """The moments of the points of `rows`."""
        eta = (1.0 - self.u[rows, None]) * self.v  # (rows, order)
        # Arrays of a chunk's size are written into buffers kept for the whole build:
        # allocated afresh, each would be mapped, touched and unmapped at every chunk.
        weighted, psi, dpsi = self._buffers(eta.shape)
        cantilever_modes_and_slopes(self.nb, eta, out=(psi, dpsi))
        trig = trig_table(self.j_max, eta)
        np.multiply(psi, self.wv, out=weighted[self.psi])
        np.multiply(dpsi, self.wv, out=weighted[self.dpsi])
        np.multiply(trig, self.wv, out=weighted[self.trig])
        for c in range(3):  # batched over rows: (rows, n_Y, order) @ (rows, order, n_Z)
            self.moments[c, rows] = weighted.transpose(1, 0, 2) @ trig.transpose(1, 2, 0)
            weighted *= 1.0 - eta

    def _buffers(self, shape: tuple[int, int]):
        """`(weighted, psi, dpsi)` for chunks of `shape` (rows, points)."""
        if shape not in self._chunk_buffers:
            nb, n_y = self.nb, self.trig.stop
            self._chunk_buffers[shape] = (
                np.empty((n_y, *shape)),
                np.empty((nb, *shape)),
                np.empty((nb, *shape)),
            )
        return self._chunk_buffers[shape]

    def _row_weights(self, c1: int) -> np.ndarray:
        """Row weights `omega_i (1 - u_i)^c1`."""
        return self.omega * (1.0 - self.u) ** c1

    def xi_xi(self, a: np.ndarray, b: np.ndarray, c1: int) -> np.ndarray:
        """`<a(xi) b(xi)^T (1 - xi)^c1>`."""
        row_sums = self.moments[0, :, self.trig.start + self.one, self.one]  # sum_j wv_j
        return (a * (self._row_weights(c1) * row_sums)) @ b.T

    def xi_eta(self, a: np.ndarray, y_rows: slice, c1: int, c2: int) -> np.ndarray:
        """`<a(xi) Y_rows(eta)^T (1 - xi)^c1 (1 - eta)^c2>`."""
        return (a * self._row_weights(c1)) @ self.moments[c2, :, y_rows, self.one]

    def xi_membrane(self, a: np.ndarray, f: SeparableSum, c1: int, c2: int) -> np.ndarray:
        """`<a(xi) f^T (1 - xi)^c1 (1 - eta)^c2>`: per term, the row sums of f's
        eta factor times its xi factor, against `a`."""
        row_sums = self.moments[c2, :, self.trig, self.one]
        return sum(
            (
                (a * self._row_weights(c1))
                @ (self.xi_trig[f.xi_row[t]].T * row_sums[:, f.eta_row[t]])
            )
            * f.coef[t]
            for t in range(2)
        )

    def eta_membrane(self, y_rows: slice, f: SeparableSum, c1: int, c2: int) -> np.ndarray:
        """`<Y_rows(eta) f^T (1 - xi)^c1 (1 - eta)^c2>`."""
        return sum(
            np.einsum(
                "ib,igb->gb",
                self._row_weights(c1)[:, None] * self.xi_trig[f.xi_row[t]].T,
                self.moments[c2][:, y_rows][:, :, f.eta_row[t]],
            )
            * f.coef[t]
            for t in range(2)
        )

    def membrane_membrane(self, f: SeparableSum, g: SeparableSum, c1: int, c2: int) -> np.ndarray:
        """`<f g^T (1 - xi)^c1 (1 - eta)^c2>`: the four products of their terms."""
        total = 0.0
        for t in range(2):
            f_xi = self._row_weights(c1)[:, None] * self.xi_trig[f.xi_row[t]].T
            f_eta = self.moments[c2][:, self.trig.start + f.eta_row[t]]
            for s in range(2):
                moments = f_eta[:, :, g.eta_row[s]]
                product = np.einsum("ia,ib,iab->ab", f_xi, self.xi_trig[g.xi_row[s]].T, moments)
                total = total + np.outer(f.coef[t], g.coef[s]) * product
        return total


def _assemble(nb: int, nm: int, blocks: dict[str, np.ndarray]) -> np.ndarray:
    """The `n~ x n~` matrix from its nonzero blocks, keyed by row and column block:
    `x` the xi-boom, `e` the eta-boom, `m` the membrane coordinates."""
    span = {"x": slice(0, nb), "e": slice(nb, 2 * nb), "m": slice(2 * nb, 2 * nb + nm)}
    matrix = np.zeros((2 * nb + nm, 2 * nb + nm))
    for key, block in blocks.items():
        matrix[span[key[0]], span[key[1]]] = block
    return matrix


@functools.cache
def quadrant_integrals(n_boom_modes: int, n_membrane_modes: int, order: int) -> QuadrantIntegrals:
    """The quadrant integrals on the collapsed rule of `order^2` points (`_built`), kept
    in this process and, between processes, on disk (`integral_store`)."""
    names = tuple(field.name for field in dataclasses.fields(QuadrantIntegrals))

    def build() -> dict[str, np.ndarray]:
        built = _built(n_boom_modes, n_membrane_modes, order)
        return {name: getattr(built, name) for name in names}

    key = f"quadrant_integrals_{n_boom_modes}_{n_membrane_modes}_{order}"
    return _freeze(QuadrantIntegrals(**stored_arrays(key, names, build)))


def _built(n_boom_modes: int, n_membrane_modes: int, order: int) -> QuadrantIntegrals:
    """The quadrant integrals on the collapsed rule of `order^2` points, block by block.

    Only the nonzero blocks of `S = [A; B; P]`, `R_a = (1 - xi) [A'; 0; P_xi]`,
    `R_b = (1 - eta) [0; B'; P_eta]` are integrated (`A = psi(xi)`, `B = psi(eta)`,
    `P = phi`), each through the `_RowRule` method for its kinds of factor.
    """
    nb, nm = n_boom_modes, n_membrane_modes
    rule = _RowRule(nb, nm, order)
    a, da = cantilever_modes_and_slopes(nb, rule.u)
    ones = np.ones((1, order))
    psi, dpsi = rule.psi, rule.dpsi
    p, p_xi, p_eta = rule.membrane
    xx, xe, xm = rule.xi_xi, rule.xi_eta, rule.xi_membrane
    em, mm = rule.eta_membrane, rule.membrane_membrane

    # the boom blocks of the eta boom are those of the xi boom (`D` is symmetric)
    a_a, a_ra, ra_ra, da_da = xx(a, a, 0), xx(a, da, 1), xx(da, da, 2), xx(da, da, 0)

    def symmetric(blocks: dict[str, np.ndarray]) -> np.ndarray:
        """The blocks on and above the diagonal, mirrored below it."""
        return _assemble(nb, nm, blocks | {k[::-1]: v.T for k, v in blocks.items() if k[0] != k[1]})

    # vectors: `<f(xi) (1 - eta)^c2 S>` and the same for R_a, R_b; eta = 1 - (1 - eta)
    u = rule.u[None, :]
    one = slice(rule.trig.start + rule.one, rule.trig.start + rule.one + 1)
    zeros = np.zeros(nb)

    def s_vector(f, c2):
        return np.concatenate(
            [xe(f * a, one, 0, c2)[:, 0], xe(f, psi, 0, c2)[0], xm(f, p, 0, c2)[0]]
        )

    def ra_vector(f, c2):
        return np.concatenate([xe(f * da, one, 1, c2)[:, 0], zeros, xm(f, p_xi, 1, c2)[0]])

    def rb_vector(f, c2):
        return np.concatenate([zeros, xe(f, dpsi, 0, c2 + 1)[0], xm(f, p_eta, 0, c2 + 1)[0]])

    ra_rb = _assemble(
        nb,
        nm,
        {
            "xe": xe(da, dpsi, 1, 1),
            "xm": xm(da, p_eta, 1, 1),
            "me": em(dpsi, p_xi, 1, 1).T,
            "mm": mm(p_xi, p_eta, 1, 1),
        },
    )
    return QuadrantIntegrals(
        s_s=symmetric(
            {
                "xx": a_a,
                "xe": xe(a, psi, 0, 0),
                "xm": xm(a, p, 0, 0),
                "ee": a_a,
                "em": em(psi, p, 0, 0),
                "mm": mm(p, p, 0, 0),
            }
        ),
        s_ra=_assemble(
            nb,
            nm,
            {
                "xx": a_ra,
                "xm": xm(a, p_xi, 1, 0),
                "ex": xe(da, psi, 1, 0).T,
                "em": em(psi, p_xi, 1, 0),
                "mx": xm(da, p, 1, 0).T,
                "mm": mm(p, p_xi, 1, 0),
            },
        ),
        s_rb=_assemble(
            nb,
            nm,
            {
                "xe": xe(a, dpsi, 0, 1),
                "xm": xm(a, p_eta, 0, 1),
                "ee": a_ra,
                "em": em(psi, p_eta, 0, 1),
                "me": em(dpsi, p, 0, 1).T,
                "mm": mm(p, p_eta, 0, 1),
            },
        ),
        ra_ra=symmetric({"xx": ra_ra, "xm": xm(da, p_xi, 2, 0), "mm": mm(p_xi, p_xi, 2, 0)}),
        ra_rb=ra_rb + ra_rb.T,
        rb_rb=symmetric({"ee": ra_ra, "em": em(dpsi, p_eta, 0, 2), "mm": mm(p_eta, p_eta, 0, 2)}),
        sxi_sxi=symmetric({"xx": da_da, "xm": xm(da, p_xi, 0, 0), "mm": mm(p_xi, p_xi, 0, 0)}),
        seta_seta=symmetric(
            {"ee": da_da, "em": em(dpsi, p_eta, 0, 0), "mm": mm(p_eta, p_eta, 0, 0)}
        ),
        s_mean=np.concatenate([xx(ones, a, 0)[0], xe(ones, psi, 0, 0)[0], xm(ones, p, 0, 0)[0]]),
        xi_s=s_vector(u, 0),
        eta_s=s_vector(ones, 0) - s_vector(ones, 1),
        ra_mean=ra_vector(ones, 0),
        xi_ra=ra_vector(u, 0),
        eta_ra=ra_vector(ones, 0) - ra_vector(ones, 1),
        rb_mean=rb_vector(ones, 0),
        xi_rb=rb_vector(u, 0),
        eta_rb=rb_vector(ones, 0) - rb_vector(ones, 1),
    )
