"""Basis functions on the fixed reference domains (model.md §2).

* Cantilever (clamped-free Euler-Bernoulli) eigenfunctions `psi_i` on
  `xi in [0, 1]`, normalised to `int_0^1 psi_i^2 = 1`.
* Clamped right isosceles triangle eigenfunctions `phi_mn` on
  `D = {xi >= 0, eta >= 0, xi + eta <= 1}`, normalised to `int_D phi^2 = 1`.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from sail_ros.model.layout import triangle_mode_indices
from sail_ros.model.roots import bracketed_root


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
            roots[i] = bracketed_root(
                lambda b: np.cos(b) + 1.0 / np.cosh(b),
                centre - 0.5 * np.pi + 1e-9,
                centre + 0.5 * np.pi - 1e-9,
                xtol=1e-15,
                rtol=4 * np.finfo(float).eps,
            )
    roots.flags.writeable = False
    return roots


@functools.cache
def pinned_free_root() -> float:
    """The first non-zero root `b` of `tan(b) = tanh(b)` (3.92660): a beam pinned at one
    end and free at the other vibrates at `b^2 sqrt(EI / rho_B) / L^2`. Solved as
    `sin(b) - cos(b) tanh(b) = 0` in `(pi, 3 pi / 2)`."""
    return float(
        bracketed_root(
            lambda b: np.sin(b) - np.cos(b) * np.tanh(b),
            np.pi + 1e-3,
            1.5 * np.pi,
            xtol=1e-15,
            rtol=4 * np.finfo(float).eps,
        )
    )


def _cantilever_constants(b: np.ndarray) -> tuple[np.ndarray, ...]:
    """`(b, s, c, e^-b)` of `cantilever_modes` for the roots `b` (any shape)."""
    eb = np.exp(-b)
    d = 1.0 - eb**2 + 2.0 * np.sin(b) * eb
    s = (1.0 + eb**2 + 2.0 * np.cos(b) * eb) / d
    c = (np.sin(b) - np.cos(b) - eb) / d
    return b, s, c, eb


def _cantilever_parts(n: int, xi) -> tuple[np.ndarray, ...]:
    """Every transcendental of `cantilever_modes` at points `xi` (any shape).

    Returns `(b, s, c, e^(-bx), cos(bx), sin(bx), e^(b(x-1)), e^(-b(x+1)))`, the
    per-mode constants of shape `(n, 1, ...)`, the rest `(n, *xi.shape)`.
    `e^(-b(x+1)) = e^(-bx) e^(-b)` needs no exponential of its own (for large `b`
    it underflows to 0, harmlessly: every term stays of order one or below).
    """
    xi = np.asarray(xi, dtype=float)
    b = cantilever_roots(n).reshape((n,) + (1,) * xi.ndim)
    b, s, c, eb = _cantilever_constants(b)
    e_bx = np.exp(-b * xi)
    grow = np.exp(b * (xi - 1.0))  # e^(b(x-1)) <= 1 on [0, 1]
    return b, s, c, e_bx, *_cos_sin(b, xi), grow, e_bx * eb


# Past the first few roots, neighbours differ by pi + epsilon, |epsilon| < this: the
# rotation by epsilon x is then exact to round-off from its second-order expansion.
_ROTATION_EPSILON = 1e-6


class _Rotation:
    """`cos(b_i xi)`, `sin(b_i xi)` for the cantilever roots `b_i` in turn (`next`).

    numpy's float64 sine and cosine cost ~16 ns a value here, most of the integrals'
    time. Root `i` tends to `(i - 1/2) pi`; once neighbours differ by `pi + epsilon`
    with `|epsilon| < _ROTATION_EPSILON`, each mode is the one before rotated by that
    angle (`cos(pi xi)`, `sin(pi xi)` once, `epsilon xi` to second order): a few
    products a mode. The difference of two neighbouring roots is exact in floating
    point, so the phase is `b_i xi` to a few units in the last place, as when
    evaluated directly (whose argument `b_i xi` is itself rounded).
    """

    def __init__(self, roots: np.ndarray, xi: np.ndarray):
        self.roots, self.xi = roots, xi
        self.epsilon = np.diff(roots) - np.pi
        small = np.abs(self.epsilon) < _ROTATION_EPSILON
        self.direct = roots.size if not small.any() else int(np.argmax(small)) + 1
        self.i = 0
        self.pi_turn = None

    def next(self) -> tuple[np.ndarray, np.ndarray]:
        i, xi = self.i, self.xi
        self.i += 1
        if i < self.direct:
            self.cos, self.sin = np.cos(self.roots[i] * xi), np.sin(self.roots[i] * xi)
            return self.cos, self.sin
        if self.pi_turn is None:
            self.pi_turn = np.cos(np.pi * xi), np.sin(np.pi * xi)
        cos_pi, sin_pi = self.pi_turn
        angle = self.epsilon[i - 1] * xi
        keep = 1.0 - 0.5 * angle * angle
        c_step = cos_pi * keep - sin_pi * angle
        s_step = sin_pi * keep + cos_pi * angle
        self.cos, self.sin = (
            self.cos * c_step - self.sin * s_step,
            self.sin * c_step + self.cos * s_step,
        )
        return self.cos, self.sin


def _cos_sin(b: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`cos(b xi)`, `sin(b xi)` for the roots `b` (shape `(n, 1, ...)`) at points `xi`,
    each `(n, *xi.shape)` (`_Rotation`)."""
    turns = _Rotation(b.reshape(-1), xi)
    pairs = [turns.next() for _ in range(b.shape[0])]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def cantilever_modes(n: int, xi, derivative: int = 0) -> np.ndarray:
    """Cantilever eigenfunctions (or a derivative d^k/dxi^k) at points `xi`.

    Returns an array of shape `(n, *np.shape(xi))`. The textbook form
    `cosh(bx) - cos(bx) - s (sinh(bx) - sin(bx))`,
    `s = (cosh b + cos b) / (sinh b + sin b)`, subtracts numbers of size
    `e^b` and loses every digit beyond about the 8th mode. Writing
    `cosh(bx) - s sinh(bx) = e^(-bx) + (1 - s) sinh(bx)` and expanding
    `(1 - s) sinh(bx)` with all exponentials scaled by `e^-b` leaves only
    terms of order one::

        psi = e^(-bx) - cos(bx) + s sin(bx)
              + c (e^(b(x-1)) - e^(-b(x+1))) / d,
        s = (1 + e^(-2b) + 2 cos(b) e^(-b)) / d,
        c = sin(b) - cos(b) - e^(-b),
        d = 1 - e^(-2b) + 2 sin(b) e^(-b).

    With this sign convention `psi_i(1) = 2 (-1)^(i+1)` and
    `int_0^1 psi_i^2 = 1` exactly (no numerical normalisation needed).
    """
    b, s, c, e_bx, cos_bx, sin_bx, grow, decay = _cantilever_parts(n, xi)
    # d/dx of [e^-bx, cos, sin, grow, decay] cycle with period 4 (2 for exps)
    sign_e = (-1.0) ** derivative
    trig = {
        0: -cos_bx + s * sin_bx,
        1: sin_bx + s * cos_bx,
        2: cos_bx - s * sin_bx,
        3: -sin_bx - s * cos_bx,
    }[derivative % 4]
    hyper = grow - decay if derivative % 2 == 0 else grow + decay
    return b**derivative * (sign_e * e_bx + trig + c * hyper)


def cantilever_modes_and_slopes(n: int, xi, out=None) -> tuple[np.ndarray, np.ndarray]:
    """`(psi, dpsi/dxi)` at points `xi`, as `cantilever_modes` with derivative 0 and 1
    but sharing their transcendentals; each of shape `(n, *np.shape(xi))`, written into
    `out` (a pair of such arrays) if given.

    Mode by mode, so that every temporary is one mode's worth: the integrals call this
    on thousands of points, and arrays of all modes at once would be allocated, touched
    and given back to the system at every chunk, a page fault for every page.
    """
    xi = np.asarray(xi, dtype=float)
    b = cantilever_roots(n).reshape((n,) + (1,) * xi.ndim)
    psi, slope = out if out is not None else (np.empty((n, *xi.shape)), np.empty((n, *xi.shape)))
    b, s, c, eb = (v.reshape(-1) for v in _cantilever_constants(b))
    turns = _Rotation(cantilever_roots(n), xi)
    for i in range(n):
        cos, sin = turns.next()
        e_bx = np.exp(-b[i] * xi)
        grow = np.exp(b[i] * (xi - 1.0))
        decay = e_bx * eb[i]
        np.subtract(grow, decay, out=psi[i])
        psi[i] *= c[i]
        psi[i] += e_bx - cos + s[i] * sin
        np.add(grow, decay, out=slope[i])
        slope[i] *= c[i]
        slope[i] += sin + s[i] * cos - e_bx
        slope[i] *= b[i]
    return psi, slope


def trig_table(j_max: int, x) -> np.ndarray:
    """`sin(j pi x)` for `j = 0..j_max`, then `cos(j pi x)` for `j = 0..j_max`.

    Shape `(2 (j_max + 1), *np.shape(x))`: row `j` is the sine, row
    `j_max + 1 + j` the cosine (row `j_max + 1` is the constant 1).
    """
    x = np.asarray(x, dtype=float)
    jx = (np.arange(j_max + 1) * np.pi).reshape((-1,) + (1,) * x.ndim) * x
    return np.concatenate([np.sin(jx), np.cos(jx)])


@dataclasses.dataclass(frozen=True)
class SeparableSum:
    """`n` functions `f_a(xi, eta) = sum_t coef[t, a] T[xi_row[t, a]](xi) T[eta_row[t, a]](eta)`.

    `T` are the rows of `trig_table(j_max, .)`; the three arrays have shape `(2, n)`.
    """

    coef: np.ndarray
    xi_row: np.ndarray
    eta_row: np.ndarray

    def __call__(self, table_xi: np.ndarray, table_eta: np.ndarray) -> np.ndarray:
        """The functions at the points of two `trig_table`s, shape `(n, points)`."""
        return sum(
            self.coef[t][:, None] * table_xi[self.xi_row[t]] * table_eta[self.eta_row[t]]
            for t in range(2)
        )


def triangle_mode_terms(n: int) -> tuple[int, SeparableSum, SeparableSum, SeparableSum]:
    """The first `n` triangle modes and their gradients as sums of separable products.

    Returns `(j_max, phi, dphi/dxi, dphi/deta)`, `j_max` the largest index of a
    mode (the size of the `trig_table` they index). With `S_j = sin(j pi .)`,
    `C_j = cos(j pi .)` and `sigma = (-1)^(m+n)`:

        phi       = 2 S_m(xi) S_n(eta)      - 2 sigma S_n(xi) S_m(eta)
        dphi/dxi  = 2 m pi C_m(xi) S_n(eta) - 2 sigma n pi C_n(xi) S_m(eta)
        dphi/deta = 2 n pi S_m(xi) C_n(eta) - 2 sigma m pi S_n(xi) C_m(eta)
    """
    pairs = np.array(triangle_mode_indices(n))
    m, k = pairs[:, 0], pairs[:, 1]
    j_max = int(m.max())
    cos = j_max + 1  # offset of the cosines in the table
    sign = (-1.0) ** (m + k)
    phi = SeparableSum(np.array([np.full(n, 2.0), -2.0 * sign]), np.array([m, k]), np.array([k, m]))
    phi_xi = SeparableSum(
        np.array([2.0 * (m * np.pi), -2.0 * (sign * (k * np.pi))]),
        np.array([cos + m, cos + k]),
        np.array([k, m]),
    )
    phi_eta = SeparableSum(
        np.array([2.0 * (k * np.pi), -2.0 * (sign * (m * np.pi))]),
        np.array([m, k]),
        np.array([cos + k, cos + m]),
    )
    return j_max, phi, phi_xi, phi_eta


def triangle_modes(n: int, xi, eta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clamped-triangle eigenfunctions and their gradients at points `(xi, eta)`.

    `phi_mn = 2 [sin(m pi xi) sin(n pi eta) - (-1)^(m+n) sin(n pi xi) sin(m pi eta)]`,
    zero on all three edges of `D`, `int_D phi^2 = 1`, Laplacian eigenvalue
    `pi^2 (m^2 + n^2)`. Returns `(phi, dphi/dxi, dphi/deta)`, each of shape
    `(n, len(xi))`. Sines and cosines are evaluated once per distinct `j pi`
    (`triangle_mode_terms`).
    """
    j_max, *functions = triangle_mode_terms(n)
    table_xi, table_eta = trig_table(j_max, xi), trig_table(j_max, eta)
    phi, phi_xi, phi_eta = (f(table_xi, table_eta) for f in functions)
    return phi, phi_xi, phi_eta


def triangle_eigenvalues(n: int) -> np.ndarray:
    """`pi^2 (m^2 + n^2)` of the first `n` triangle modes (Laplacian on D)."""
    pairs = np.array(triangle_mode_indices(n), dtype=float)
    return np.pi**2 * (pairs[:, 0] ** 2 + pairs[:, 1] ** 2)
