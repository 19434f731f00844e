"""Basis functions against their defining equations (model.md §2), and the quadrant
integrals against a plain sum over the quadrature points."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from sail_ros.model import basis
from sail_ros.model.basis import (
    cantilever_modes,
    cantilever_roots,
    pinned_free_root,
    triangle_eigenvalues,
    triangle_mode_indices,
    triangle_modes,
)
from sail_ros.model.integrals import (
    _built,
    collapsed_gauss_triangle,
    default_quadrature_order,
    gauss_unit_interval,
)
from sail_ros.model.roots import bracketed_root

pytestmark = pytest.mark.model

N_MODES = 30


def test_cantilever_roots_solve_frequency_equation():
    roots = cantilever_roots(N_MODES)
    # independent root-finding of the textbook equation for the first few
    for i in range(6):
        expected = brentq(
            lambda b: np.cos(b) * np.cosh(b) + 1.0, i * np.pi + 0.5, (i + 1) * np.pi + 0.5
        )
        assert roots[i] == pytest.approx(expected, rel=1e-13)
    # large roots approach (i - 1/2) pi from either side, exponentially fast
    i = np.arange(1, N_MODES + 1)
    assert np.all(np.abs(roots[8:] - (i[8:] - 0.5) * np.pi) < 1e-6)
    assert np.all(np.diff(roots) > 2.8)


def test_cantilever_modes_solve_beam_equation_to_30_modes():
    """Psi'''' = beta^4 psi, clamped at 0, free at 1: holds without cancellation."""
    beta = cantilever_roots(N_MODES)[:, None]
    x = np.linspace(0.0, 1.0, 101)
    psi = cantilever_modes(N_MODES, x)
    fourth = cantilever_modes(N_MODES, x, derivative=4)
    assert np.max(np.abs(fourth / beta**4 - psi)) < 1e-12
    ends = [
        cantilever_modes(N_MODES, [0.0], 0),
        cantilever_modes(N_MODES, [0.0], 1) / beta,
        cantilever_modes(N_MODES, [1.0], 2) / beta**2,
        cantilever_modes(N_MODES, [1.0], 3) / beta**3,
    ]
    for value in ends:
        assert np.max(np.abs(value)) < 1e-12


def test_cantilever_modes_are_orthonormal_with_tip_two():
    x, w = gauss_unit_interval(300)
    psi = cantilever_modes(N_MODES, x)
    curvature = cantilever_modes(N_MODES, x, derivative=2)
    beta = cantilever_roots(N_MODES)
    np.testing.assert_allclose((psi * w) @ psi.T, np.eye(N_MODES), atol=1e-12)
    np.testing.assert_allclose(
        (curvature * w) @ curvature.T / np.outer(beta**2, beta**2), np.eye(N_MODES), atol=1e-12
    )
    tip = cantilever_modes(N_MODES, [1.0])[:, 0]
    np.testing.assert_allclose(np.abs(tip), 2.0, rtol=1e-12)


def test_cantilever_derivatives_match_finite_differences():
    x = np.array([0.13, 0.5, 0.91])
    h = 1e-6
    for k in range(3):
        numeric = (cantilever_modes(8, x + h, k) - cantilever_modes(8, x - h, k)) / (2 * h)
        exact = cantilever_modes(8, x, k + 1)
        np.testing.assert_allclose(numeric, exact, rtol=1e-6, atol=1e-6 * np.abs(exact).max())


def test_triangle_mode_order():
    pairs = triangle_mode_indices(10)
    assert pairs[:7] == ((2, 1), (3, 1), (3, 2), (4, 1), (4, 2), (4, 3), (5, 1))
    keys = [(m * m + n * n, m) for m, n in triangle_mode_indices(40)]
    assert keys == sorted(keys)
    assert all(m > n >= 1 for m, n in triangle_mode_indices(40))


def test_triangle_modes_orthonormal_clamped_and_eigen():
    n = 20
    xi, eta, w = collapsed_gauss_triangle(80)
    phi, phi_xi, phi_eta = triangle_modes(n, xi, eta)
    np.testing.assert_allclose((phi * w) @ phi.T, np.eye(n), atol=1e-12)
    dirichlet = (phi_xi * w) @ phi_xi.T + (phi_eta * w) @ phi_eta.T
    np.testing.assert_allclose(dirichlet, np.diag(triangle_eigenvalues(n)), atol=1e-9)
    s = np.linspace(0.0, 1.0, 37)
    for edge_xi, edge_eta in ((s, 0 * s), (0 * s, s), (s, 1.0 - s)):
        assert np.max(np.abs(triangle_modes(n, edge_xi, edge_eta)[0])) < 1e-12


def test_triangle_gradients_match_finite_differences():
    xi, eta, h = np.array([0.2, 0.4]), np.array([0.3, 0.1]), 1e-6
    phi, phi_xi, phi_eta = triangle_modes(6, xi, eta)
    np.testing.assert_allclose(
        (triangle_modes(6, xi + h, eta)[0] - triangle_modes(6, xi - h, eta)[0]) / (2 * h),
        phi_xi,
        atol=1e-6,
    )
    np.testing.assert_allclose(
        (triangle_modes(6, xi, eta + h)[0] - triangle_modes(6, xi, eta - h)[0]) / (2 * h),
        phi_eta,
        atol=1e-6,
    )


@pytest.mark.parametrize(("n_boom_modes", "n_membrane_modes"), [(1, 1), (3, 7), (7, 2), (12, 12)])
def test_quadrant_integrals_equal_sums_over_every_point_of_the_rule(n_boom_modes, n_membrane_modes):
    """The row-by-row, block-by-block build against the plain sum over all points:
    `<f g^T> = sum_q w_q f(x_q) g(x_q)^T` with every vector function evaluated in full."""
    order = default_quadrature_order(n_boom_modes, n_membrane_modes)
    xi, eta, w = collapsed_gauss_triangle(order)
    zero = np.zeros((n_boom_modes, xi.size))
    phi, phi_xi, phi_eta = triangle_modes(n_membrane_modes, xi, eta)
    s = np.vstack([cantilever_modes(n_boom_modes, xi), cantilever_modes(n_boom_modes, eta), phi])
    s_xi = np.vstack([cantilever_modes(n_boom_modes, xi, 1), zero, phi_xi])
    s_eta = np.vstack([zero, cantilever_modes(n_boom_modes, eta, 1), phi_eta])
    ra, rb = (1.0 - xi) * s_xi, (1.0 - eta) * s_eta

    def gram(f, g):
        return (f * w) @ g.T

    expected = {
        "s_s": gram(s, s),
        "s_ra": gram(s, ra),
        "s_rb": gram(s, rb),
        "ra_ra": gram(ra, ra),
        "ra_rb": gram(ra, rb) + gram(rb, ra),
        "rb_rb": gram(rb, rb),
        "sxi_sxi": gram(s_xi, s_xi),
        "seta_seta": gram(s_eta, s_eta),
        "s_mean": s @ w,
        "xi_s": s @ (xi * w),
        "eta_s": s @ (eta * w),
        "ra_mean": ra @ w,
        "xi_ra": ra @ (xi * w),
        "eta_ra": ra @ (eta * w),
        "rb_mean": rb @ w,
        "xi_rb": rb @ (xi * w),
        "eta_rb": rb @ (eta * w),
    }
    built = _built(n_boom_modes, n_membrane_modes, order)  # the build, not the integral store
    for name, value in expected.items():
        assert np.allclose(getattr(built, name), value, rtol=0, atol=1e-12 * np.abs(value).max()), (
            name
        )


@pytest.mark.parametrize("n", [3, 12, 40, 400])
def test_rotated_cosines_equal_the_direct_ones_to_round_off(n):
    """`cos(b_i x)`, `sin(b_i x)` from rotating mode i - 1 by `b_i - b_(i-1)` equal a
    direct evaluation in long double to what the direct float64 evaluation itself
    reaches (its argument `b_i x` rounded: ~ulp(b_n))."""
    x = np.concatenate([np.linspace(0.0, 1.0, 1001), np.random.default_rng(3).random(999)])
    b = basis.cantilever_roots(n).reshape(n, 1)
    cos, sin = basis._cos_sin(b, x)
    exact_cos = np.cos(b.astype(np.longdouble) * x.astype(np.longdouble))
    exact_sin = np.sin(b.astype(np.longdouble) * x.astype(np.longdouble))
    bound = 4 * np.spacing(b[-1, 0]) + 1e-15
    assert np.abs(cos - exact_cos).max() < bound and np.abs(sin - exact_sin).max() < bound


def test_the_bracketed_root_is_scipys_brentq_to_the_last_bit():
    """The model's root finder takes brentq's steps: the same root, bit for bit, on the
    model's two frequency equations (400 cantilever roots, the pinned-free one) and on
    functions with a multiple root, a pole-like slope and a root at a bracket's end."""
    eps4 = 4 * np.finfo(float).eps
    with np.errstate(over="ignore"):
        for i in range(400):
            centre = (i + 0.5) * np.pi
            f = lambda b: np.cos(b) + 1.0 / np.cosh(b)  # noqa: E731
            ends = (centre - 0.5 * np.pi + 1e-9, centre + 0.5 * np.pi - 1e-9)
            ours = bracketed_root(f, *ends, xtol=1e-15, rtol=eps4)
            assert ours == brentq(f, *ends, xtol=1e-15, rtol=eps4), i
    assert pinned_free_root() == brentq(
        lambda b: np.sin(b) - np.cos(b) * np.tanh(b), np.pi + 1e-3, 1.5 * np.pi,
        xtol=1e-15, rtol=eps4,
    )  # fmt: skip
    cases = [
        (lambda x: (x - 1.3) ** 3, 0.0, 4.0),
        (lambda x: np.tan(x) - 1e3, 0.0, 1.5707),
        (lambda x: x * x - 2.0, 0.0, 2.0),
        (lambda x: math.exp(x) - 5.0, -10.0, 10.0),
        (lambda x: x - 0.25, 0.25, 3.0),
    ]
    for f, low, high in cases:
        for xtol, rtol in ((1e-15, eps4), (1e-6, 1e-8), (2e-12, eps4)):
            try:
                expected = brentq(f, low, high, xtol=xtol, rtol=rtol)
            except RuntimeError:  # not converged in 100 iterations: neither is ours
                with pytest.raises(ValueError, match="no root"):
                    bracketed_root(f, low, high, xtol, rtol)
            else:
                assert bracketed_root(f, low, high, xtol, rtol) == expected
    with pytest.raises(ValueError, match="same sign"):
        bracketed_root(lambda x: x * x + 1.0, -1.0, 1.0, 1e-12, eps4)
    with pytest.raises(ValueError, match="no root"):
        bracketed_root(lambda x: math.exp(x) - 2.0, 0.0, 1.0, 1e-300, 0.0, max_iterations=3)
