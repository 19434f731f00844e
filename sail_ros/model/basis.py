"""Basis functions on the fixed reference domains (model.md §2).

* Cantilever (clamped-free Euler-Bernoulli) eigenfunctions `psi_i` on
  `xi in [0, 1]`, normalised to `int_0^1 psi_i^2 = 1`.
* Clamped right isosceles triangle eigenfunctions `phi_mn` on
  `D = {xi >= 0, eta >= 0, xi + eta <= 1}`, normalised to `int_D phi^2 = 1`.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.optimize import brentq

from sail_ros.model.layout import triangle_mode_indices


@functools.cache
def cantilever_roots(n: int) -> np.ndarray:
    """First `n` roots `beta_i` of `cos(b) cosh(b) + 1 = 0` (1.8751, 4.6941, ...).

    Solved as `cos(b) + 1/cosh(b) = 0`, which stays well scaled for large `b`;
    root `i` (1-based) lies within `(i - 1/2) pi +- pi/2`.
    """
    roots = np.empty(n)
    for i in range(n):
        centre = (i + 0.5) * np.pi
        with np.errstate(over="ignore"):  # cosh overflows past b ~ 710: 1/cosh is then 0
            roots[i] = brentq(
                lambda b: np.cos(b) + 1.0 / np.cosh(b),
                centre - 0.5 * np.pi + 1e-9,
                centre + 0.5 * np.pi - 1e-9,
                xtol=1e-15,
                rtol=4 * np.finfo(float).eps,
            )
    roots.flags.writeable = False
    return roots


def cantilever_modes(n: int, xi, derivative: int = 0) -> np.ndarray:
    """Cantilever eigenfunctions (or a derivative d^k/dxi^k) at points `xi`.

    Returns an array of shape `(n, len(xi))`. The textbook form
    `cosh(bx) - cos(bx) - s (sinh(bx) - sin(bx))`,
    `s = (cosh b + cos b) / (sinh b + sin b)`, subtracts numbers of size
    `e^b` and loses every digit beyond about the 8th mode. Writing
    `cosh(bx) - s sinh(bx) = e^(-bx) + (1 - s) sinh(bx)` and expanding
    `(1 - s) sinh(bx)` with all exponentials scaled by `e^-b` leaves only
    terms of order one:

        psi = e^(-bx) - cos(bx) + s sin(bx)
              + c (e^(b(x-1)) - e^(-b(x+1))) / d,
        s = (1 + e^(-2b) + 2 cos(b) e^(-b)) / d,
        c = sin(b) - cos(b) - e^(-b),
        d = 1 - e^(-2b) + 2 sin(b) e^(-b).

    With this sign convention `psi_i(1) = 2 (-1)^(i+1)` and
    `int_0^1 psi_i^2 = 1` exactly (no numerical normalisation needed).
    """
    xi = np.asarray(xi, dtype=float)
    b = cantilever_roots(n)[:, None]
    x = xi[None, :]
    eb = np.exp(-b)
    d = 1.0 - eb**2 + 2.0 * np.sin(b) * eb
    s = (1.0 + eb**2 + 2.0 * np.cos(b) * eb) / d
    c = (np.sin(b) - np.cos(b) - eb) / d
    bx = b * x
    grow = np.exp(b * (x - 1.0))  # e^(b(x-1)) <= 1 on [0, 1]
    decay = np.exp(-b * (x + 1.0))
    e_bx = np.exp(-bx)
    k = derivative % 4
    # d/dx of [e^-bx, cos, sin, grow, decay] cycle with period 4 (2 for exps)
    sign_e = (-1.0) ** derivative
    trig = {
        0: -np.cos(bx) + s * np.sin(bx),
        1: np.sin(bx) + s * np.cos(bx),
        2: np.cos(bx) - s * np.sin(bx),
        3: -np.sin(bx) - s * np.cos(bx),
    }[k]
    hyper = grow - decay if derivative % 2 == 0 else grow + decay
    return b**derivative * (sign_e * e_bx + trig + c * hyper)


def triangle_modes(n: int, xi, eta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clamped-triangle eigenfunctions and their gradients at points `(xi, eta)`.

    `phi_mn = 2 [sin(m pi xi) sin(n pi eta) - (-1)^(m+n) sin(n pi xi) sin(m pi eta)]`,
    zero on all three edges of `D`, `int_D phi^2 = 1`, Laplacian eigenvalue
    `pi^2 (m^2 + n^2)`. Returns `(phi, dphi/dxi, dphi/deta)`, each of shape
    `(n, len(xi))`.
    """
    pairs = np.array(triangle_mode_indices(n), dtype=float)
    m = pairs[:, 0:1] * np.pi
    k = pairs[:, 1:2] * np.pi
    sign = (-1.0) ** (pairs[:, 0:1] + pairs[:, 1:2])
    x = np.asarray(xi, dtype=float)[None, :]
    y = np.asarray(eta, dtype=float)[None, :]
    smx, cmx, skx, ckx = np.sin(m * x), np.cos(m * x), np.sin(k * x), np.cos(k * x)
    smy, cmy, sky, cky = np.sin(m * y), np.cos(m * y), np.sin(k * y), np.cos(k * y)
    phi = 2.0 * (smx * sky - sign * skx * smy)
    phi_xi = 2.0 * (m * cmx * sky - sign * k * ckx * smy)
    phi_eta = 2.0 * (k * smx * cky - sign * m * skx * cmy)
    return phi, phi_xi, phi_eta


def triangle_eigenvalues(n: int) -> np.ndarray:
    """`pi^2 (m^2 + n^2)` of the first `n` triangle modes (Laplacian on D)."""
    pairs = np.array(triangle_mode_indices(n), dtype=float)
    return np.pi**2 * (pairs[:, 0] ** 2 + pairs[:, 1] ** 2)
