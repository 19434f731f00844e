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
    cantilever_modes,
    cantilever_roots,
    triangle_mode_indices,
    triangle_modes,
)


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


def integral_bytes(n_boom_modes: int, n_membrane_modes: int, order: int) -> int:
    """Peak memory [bytes] of building the quadrant integrals: every basis function and
    derivative at every one of the `order^2` points of the triangle rule (the vector
    functions S, S_xi, S_eta, R_a, R_b of size 2 n_B + n_M, the triangle modes and
    their gradients, the cantilever values), 8 bytes each."""
    rows = 5 * (2 * n_boom_modes + n_membrane_modes) + 3 * n_membrane_modes + 6 * n_boom_modes
    return 8 * rows * order * order


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
        )
    )


@functools.cache
def quadrant_integrals(n_boom_modes: int, n_membrane_modes: int, order: int) -> QuadrantIntegrals:
    xi, eta, w = collapsed_gauss_triangle(order)
    zero = np.zeros((n_boom_modes, xi.size))
    phi, phi_xi, phi_eta = triangle_modes(n_membrane_modes, xi, eta)
    s = np.vstack([cantilever_modes(n_boom_modes, xi), cantilever_modes(n_boom_modes, eta), phi])
    s_xi = np.vstack([cantilever_modes(n_boom_modes, xi, 1), zero, phi_xi])
    s_eta = np.vstack([zero, cantilever_modes(n_boom_modes, eta, 1), phi_eta])
    ra = (1.0 - xi) * s_xi
    rb = (1.0 - eta) * s_eta
    ra_rb = _gram(ra, rb, w)
    return _freeze(
        QuadrantIntegrals(
            s_s=_gram(s, s, w),
            s_ra=_gram(s, ra, w),
            s_rb=_gram(s, rb, w),
            ra_ra=_gram(ra, ra, w),
            ra_rb=ra_rb + ra_rb.T,
            rb_rb=_gram(rb, rb, w),
            sxi_sxi=_gram(s_xi, s_xi, w),
            seta_seta=_gram(s_eta, s_eta, w),
            s_mean=s @ w,
        )
    )
