"""Finite-element sail model (`sail_ros.fem`) against closed-form continuum results."""

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq

from sail_ros.fem import SailFEM, fem_convergence
from sail_ros.fem.beam import HermiteBoom
from sail_ros.fem.membrane import QuadrantFE
from sail_ros.model.parameters import SailParameters

pytestmark = pytest.mark.model

DEFAULT = SailParameters()
BOOMS_ONLY = DEFAULT.replace(membrane_density=0.0, membrane_prestress=0.0)


def cantilever_betas(count):
    """Roots of cos b cosh b + 1 = 0, one near each (i + 1/2) pi."""
    f = lambda b: math.cos(b) * math.cosh(b) + 1  # noqa: E731
    return np.array(
        [brentq(f, (i + 0.5) * math.pi - 0.5, (i + 0.5) * math.pi + 0.5) for i in range(count)]
    )


def clamped_triangle_frequencies(params, pairs):
    """(pi/L) sqrt(N0/rho_M) sqrt(m^2 + n^2) for the given (m, n)."""
    L = params.full_boom_length
    c = math.sqrt(params.membrane_tension / params.membrane_areal_density)
    return np.array([math.pi / L * c * math.hypot(m, n) for m, n in pairs])


def hermite_dofs(boom, f, df):
    """Boom DOFs interpolating u = f exactly when f is a cubic."""
    s = boom.element_length * np.arange(1, boom.n_elements + 1)
    return np.column_stack([f(s), df(s)]).ravel()


def relative_spread(values):
    return (values.max() - values.min()) / values.mean()


# integrals the element matrices must reproduce exactly ---------------------


def test_beam_matrices_integrate_cubics_exactly():
    boom = HermiteBoom(7.0, 5)
    p = hermite_dofs(boom, lambda s: s**3, lambda s: 3 * s**2)
    M, K = boom.matrices(linear_density=2.0, bending_stiffness=3.0, axial_load=0.5)
    L = boom.length
    # 2 int s^6 - ; 3 int (6 s)^2 - 0.5 int (3 s^2)^2
    assert p @ M @ p == pytest.approx(2.0 * L**7 / 7, rel=1e-12)
    assert p @ K @ p == pytest.approx(3.0 * 12 * L**3 - 0.5 * 9 * L**5 / 5, rel=1e-12)


def test_quadrant_couples_booms_and_membrane_exactly():
    """Int over the triangle of x^a y^b is a! b! L^(a+b+2) / (a+b+2)!."""
    boom = HermiteBoom(3.0, 2)
    quadrant = QuadrantFE(boom, divisions=6, order=2)  # 3 triangle columns per element
    L, nb = boom.length, boom.n_dofs
    cube = hermite_dofs(boom, lambda s: s**3, lambda s: 3 * s**2)
    zero = np.zeros(nb)
    v = np.zeros(quadrant.n_membrane_dofs)
    along_x = np.concatenate([cube, zero, v])  # w = x^3
    along_y = np.concatenate([zero, cube, v])  # w = y^3
    A, G = quadrant.area_integral, quadrant.gradient_integral

    def simplex(a, b):
        return math.factorial(a) * math.factorial(b) * L ** (a + b + 2) / math.factorial(a + b + 2)

    assert along_x @ A @ along_x == pytest.approx(simplex(6, 0), rel=1e-12)
    assert along_x @ A @ along_y == pytest.approx(simplex(3, 3), rel=1e-12)
    assert along_y @ G @ along_y == pytest.approx(9 * simplex(0, 4), rel=1e-12)
    assert along_x @ G @ along_y == pytest.approx(0.0, abs=1e-12)


def test_membrane_divisions_must_align_with_boom_elements():
    with pytest.raises(ValueError, match="multiple"):
        SailFEM(DEFAULT, boom_elements=4, membrane_divisions=6)
    with pytest.raises(ValueError, match="order"):
        SailFEM(DEFAULT, boom_elements=4, membrane_divisions=8, membrane_order=3)


# 1. booms alone -------------------------------------------------------------


def test_booms_alone_are_four_cantilevers():
    L = BOOMS_ONLY.full_boom_length
    exact = cantilever_betas(3) ** 2 * math.sqrt(
        BOOMS_ONLY.boom_bending_stiffness / (BOOMS_ONLY.boom_linear_density * L**4)
    )
    errors = []
    for elements in (4, 8, 16):
        fem = SailFEM(BOOMS_ONLY, elements, elements, 1)
        assert fem.n_dofs == 4 * 2 * elements
        assert "no membrane" in fem.mesh_description()
        groups = fem.natural_frequencies(12).reshape(3, 4)
        assert all(relative_spread(group) < 1e-9 for group in groups)  # each four times
        errors.append(groups.mean(axis=1) / exact - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)  # Rayleigh-Ritz: from above
    assert np.all(errors[:-1] / errors[1:] > 12)  # O(h^4)
    assert np.all(errors[-1] < 5e-5)


def test_boom_frequencies_scale_with_length():
    fem = SailFEM(BOOMS_ONLY, 8, 8, 1)
    full = fem.natural_frequencies(4)
    half = fem.natural_frequencies(4, length=BOOMS_ONLY.full_boom_length / 2)
    np.testing.assert_allclose(half, 4 * full, rtol=1e-10)


# 2. membranes on rigid booms --------------------------------------------------


def test_membranes_on_rigid_booms_are_clamped_triangles():
    rigid = DEFAULT.replace(boom_bending_stiffness=1e12)
    exact = clamped_triangle_frequencies(rigid, [(2, 1), (3, 1), (3, 2), (4, 1)])
    errors = []
    for divisions in (8, 16):
        groups = SailFEM(rigid, divisions, divisions, 2).natural_frequencies(16).reshape(4, 4)
        assert all(relative_spread(group) < 1e-8 for group in groups)
        errors.append(groups.mean(axis=1) / exact - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)
    assert np.all(errors[0] / errors[1] > 10)  # P2: O(h^4)
    assert np.all(errors[1] < 5e-4)


# 3. cantilever buckling -------------------------------------------------------


def test_lowest_frequency_vanishes_at_the_euler_load():
    L = BOOMS_ONLY.full_boom_length
    euler = math.pi**2 * BOOMS_ONLY.boom_bending_stiffness / (4 * L**2)
    unloaded = SailFEM(BOOMS_ONLY, 8, 8, 1).natural_frequencies(1)[0]

    def lowest(load):
        params = BOOMS_ONLY.replace(boom_axial_load=load * euler)
        return SailFEM(params, 8, 8, 1).natural_frequencies(4)

    near = lowest(0.999)
    assert np.all(near > 0)
    # omega^2 falls about linearly in P: omega ~ sqrt(1 - P/P_E) omega_0
    assert near[0] / unloaded == pytest.approx(math.sqrt(0.001), rel=0.1)
    assert np.all(lowest(1.001) < 0)  # buckled: divergence, reported negative


# 4. the default sail --------------------------------------------------------


def test_default_sail_has_the_four_fold_symmetry_pattern():
    """w1 single, w2 = w3, w4 single, w5 single, w6 = w7, w8 single.

    w5 is the clamped (2,1) membrane mode, equal in all quadrants and of
    alternating sign from quadrant to quadrant: the pulls of the two
    quadrants on every boom cancel, the booms stay at rest, and the
    frequency is exactly that of the clamped triangle.
    """
    w = SailFEM(DEFAULT, 16, 16, 2).natural_frequencies(8)
    double = [(1, 2), (5, 6)]
    for i, j in double:
        assert w[j] / w[i] - 1 < 1e-9
    distinct = [w[0], w[1], w[3], w[4], w[5], w[7]]
    assert np.all(np.diff(distinct) / distinct[1:] > 1e-3)
    exact = clamped_triangle_frequencies(DEFAULT, [(2, 1)])[0]
    assert 0 < w[4] / exact - 1 < 1e-4


def test_refinement_lowers_every_frequency():
    levels = [(n, n, 2) for n in (2, 4, 8, 16, 32)]
    results = fem_convergence(DEFAULT, levels, k=6)
    table = np.array([frequencies for _, frequencies in results])
    steps = -np.diff(table, axis=0)
    assert np.all(steps > 0)  # nested meshes: monotone from above
    assert np.all(steps[1:] < steps[:-1] / 4)  # and converging
    settings = results[-1][0]
    assert settings["n_dofs"] == 4 * (2 * 32 + 63 * 62 // 2)
    assert "4 x 1024 P2 triangles" in settings["description"]
    assert settings["seconds"] > 0


def test_p1_converges_to_the_p2_frequencies():
    p2 = SailFEM(DEFAULT, 16, 16, 2).natural_frequencies(6)
    p1 = [SailFEM(DEFAULT, 16, n, 1).natural_frequencies(6) for n in (16, 32)]
    errors = np.array(p1) / p2 - 1
    assert np.all(errors[0] > 0)  # P1 is a subspace of P2 on the same mesh
    assert np.all(errors[1] > 0)  # and less accurate on the twice finer one
    assert np.all(errors[1] < errors[0] / 3)  # P1: O(h^2)
    assert np.all(errors[1] < 3e-3)


# solver and special membranes -------------------------------------------------


def test_lanczos_matches_dense_solution():
    fem = SailFEM(DEFAULT, 4, 8, 2)
    M, K = fem.matrices()
    np.testing.assert_allclose(M.toarray(), M.toarray().T, atol=1e-15)
    np.testing.assert_allclose(K.toarray(), K.toarray().T, atol=1e-12)
    dense = scipy.linalg.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    assert dense[0] > 0 and np.linalg.eigvalsh(M.toarray())[0] > 0
    np.testing.assert_allclose(fem.eigenvalues(10), dense[:10], rtol=1e-9)


def test_massless_membrane_is_condensed_and_stiffens_the_booms():
    massless = SailFEM(DEFAULT.replace(membrane_density=0.0), 8, 8, 2).natural_frequencies(6)
    feather = DEFAULT.replace(membrane_density=1e-6)  # rho_M = 2.5e-12 kg/m^2
    np.testing.assert_allclose(
        massless, SailFEM(feather, 8, 8, 2).natural_frequencies(6), rtol=1e-8
    )
    bare = SailFEM(BOOMS_ONLY, 8, 8, 2).natural_frequencies(6)
    assert np.all(massless > bare)


def test_slack_membrane_with_mass_is_rejected():
    with pytest.raises(ValueError, match="prestress"):
        SailFEM(DEFAULT.replace(membrane_prestress=0.0))
