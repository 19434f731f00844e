"""The checks of model.md §8, against closed-form answers computed here."""

import numpy as np
import pytest
import scipy.linalg
from harness import SMALL
from scipy.optimize import brentq

from sail_ros.model import SailModel, SailParameters, StaticProfile
from sail_ros.model.basis import cantilever_roots
from sail_ros.model.sail_model import cantilever_frequencies, cantilever_frequency

pytestmark = pytest.mark.model

L_FULL = 50.0 * np.sqrt(2.0)


def group_frequencies(omega, rtol=1e-8):
    """Sizes of groups of equal frequencies, in ascending order."""
    sizes = [1]
    for previous, current in zip(omega[:-1], omega[1:], strict=True):
        if abs(current - previous) <= rtol * abs(current):
            sizes[-1] += 1
        else:
            sizes.append(1)
    return sizes


def boom_block(model, lengths):
    M, K = model.mass_and_stiffness(lengths)
    booms = slice(0, 4 * model.n_boom_modes)
    return M[booms, booms], K[booms, booms]


def membrane_block(model, lengths):
    M, K = model.mass_and_stiffness(lengths)
    membranes = slice(4 * model.n_boom_modes, model.n)
    return M[membranes, membranes], K[membranes, membranes]


def test_booms_alone_are_cantilevers():
    """Check 1: rho_M = N0 = P = 0 leaves four bare cantilevers."""
    p = SailParameters(membrane_density=0.0, membrane_prestress=0.0, n_boom_modes=6)
    model = SailModel(p)
    M, K = boom_block(model, L_FULL)
    omega = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
    beta = cantilever_roots(6)
    expected = np.repeat(
        beta**2 * np.sqrt(p.boom_bending_stiffness / (p.boom_linear_density * L_FULL**4)), 4
    )
    np.testing.assert_allclose(omega, expected, rtol=1e-11)
    # the membrane coordinates carry neither mass nor stiffness
    Mm, Km = membrane_block(model, L_FULL)
    assert np.abs(Mm).max() == 0.0 and np.abs(Km).max() == 0.0


def test_membranes_on_rigid_booms():
    """Check 2: with the booms held, each quadrant is a clamped triangle."""
    p = SailParameters(n_membrane_modes=8)
    model = SailModel(p)
    M, K = membrane_block(model, L_FULL)
    omega = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
    wave_speed = np.sqrt(p.membrane_tension / p.membrane_areal_density)
    pairs = [(2, 1), (3, 1), (3, 2), (4, 1), (4, 2), (4, 3), (5, 1), (5, 2)]
    expected = np.repeat([np.pi / L_FULL * wave_speed * np.hypot(m, n) for m, n in pairs], 4)
    np.testing.assert_allclose(omega, expected, rtol=1e-11)

    # and as the booms stiffen, the whole model tends to the same values, like 1/EI
    def deviation(stiffness):
        omega = SailModel(p.replace(boom_bending_stiffness=stiffness)).natural_frequencies(L_FULL)
        return np.max(np.abs(omega[:32] / expected - 1))

    assert deviation(1e8) < 1e-4
    assert deviation(1e9) < 0.15 * deviation(1e8)
    assert deviation(1e10) < 1e-6


def test_cantilever_buckling():
    """Check 3: the lowest frequency goes to zero as P -> pi^2 EI / (4 L^2)."""

    def lowest(load, n_boom_modes=6):
        p = SailParameters(
            membrane_density=0.0,
            membrane_prestress=0.0,
            n_boom_modes=n_boom_modes,
            boom_axial_load=load,
        )
        M, K = boom_block(SailModel(p), L_FULL)
        return scipy.linalg.eigh(K, M, eigvals_only=True)[0]  # omega^2

    euler = np.pi**2 * SailParameters().boom_bending_stiffness / (4 * L_FULL**2)
    unloaded = lowest(0.0)
    ratios = [lowest(f * euler) / unloaded for f in (0.25, 0.5, 0.75, 0.9, 0.99)]
    assert np.all(np.diff(ratios) < 0)
    # omega^2 falls nearly linearly with the load (within 12 % of 1 - P/P_euler)
    for f, ratio in zip((0.25, 0.5, 0.75, 0.9, 0.99), ratios, strict=True):
        assert 1 - f <= ratio <= 1.12 * (1 - f)
    # at the Euler load it reaches zero, up to the Ritz truncation, which more modes shrink
    assert 0 < lowest(euler) / unloaded < 1e-3
    assert lowest(euler, n_boom_modes=10) < 0.5 * lowest(euler)
    assert lowest(1.01 * euler) < 0.0  # beyond it, a divergent mode
    # reported as a negative frequency (no film tension here to hold the booms)
    slack = SailModel(SailParameters(membrane_prestress=0.0, boom_axial_load=1.01 * euler))
    assert slack.natural_frequencies(L_FULL)[0] < 0


def test_equal_lengths_show_fourfold_symmetry():
    """Check 4: only single and double frequencies, both present (C4v)."""
    omega = SailModel(SailParameters(n_boom_modes=4, n_membrane_modes=6)).natural_frequencies(
        L_FULL
    )
    sizes = group_frequencies(omega)
    assert set(sizes) == {1, 2}
    assert sizes.count(2) >= 4
    # doubles are exact to round-off, singles are well separated
    doubles = np.isclose(omega[1:], omega[:-1], rtol=1e-8)
    assert np.all(np.abs(np.diff(omega)[doubles]) < 1e-12 * omega[1:][doubles])


def test_symmetric_unequal_lengths_split_doubles():
    """Check 8: L_a = L_c != L_b = L_d keeps only the two mirror symmetries, whose
    irreducible representations are all one-dimensional: no double frequencies.
    Rotating or mirroring the length pattern leaves the spectrum unchanged."""
    model = SailModel(SailParameters(n_boom_modes=4, n_membrane_modes=6))
    omega = model.natural_frequencies([60.0, 50.0, 60.0, 50.0])
    assert set(group_frequencies(omega, rtol=1e-7)) == {1}
    np.testing.assert_allclose(
        model.natural_frequencies([50.0, 60.0, 50.0, 60.0]), omega, rtol=1e-10
    )
    lengths = np.array([40.0, 55.0, 61.0, 47.0])
    reference = model.natural_frequencies(lengths)
    rotated = model.natural_frequencies(np.roll(lengths, 1))
    mirrored = model.natural_frequencies(lengths[[1, 0, 3, 2]])  # reflection about x = y
    np.testing.assert_allclose(rotated, reference, rtol=1e-10)
    np.testing.assert_allclose(mirrored, reference, rtol=1e-10)


@pytest.mark.parametrize("axis", ["boom", "membrane"])
def test_more_modes_never_raise_a_frequency(axis):
    """Check 6 and convergence: Rayleigh-Ritz bounds fall monotonically."""
    previous = None
    for extra in range(0, 5):
        counts = {"boom": (2 + extra, 6), "membrane": (4, 2 + extra)}[axis]
        p = SailParameters(n_boom_modes=counts[0], n_membrane_modes=counts[1])
        omega = SailModel(p).natural_frequencies(L_FULL)[:12]
        if previous is not None:
            assert np.all(omega <= previous * (1 + 1e-12))
            assert np.any(omega < previous * (1 - 1e-10))  # and they do move
        previous = omega


def test_matrix_properties_at_unequal_moving_booms():
    """Check 7: M SPD, K symmetric, G - G^T skew (C minus its symmetric Md part)."""
    model = SailModel(SailParameters(n_boom_modes=5, n_membrane_modes=4))
    lengths, rates, accel = (
        [30.0, 42.0, 35.5, 50.0],
        [0.3, -0.2, 0.05, 0.4],
        [0.01, 0.0, -0.02, 0.03],
    )
    M, C, K_eq = model.matrices(lengths, rates, accel)
    M0, K = model.mass_and_stiffness(lengths)
    np.testing.assert_allclose(M, M.T, atol=1e-14 * np.abs(M).max())
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(K, K.T, atol=1e-14 * np.abs(K).max())
    Md = 0.5 * (C + C.T)
    skew = 0.5 * (C - C.T)
    # Md is the time derivative of M: compare with a central difference along the motion
    h = 1e-6
    dM = (
        model.matrices(np.add(lengths, h * np.array(rates)))[0]
        - model.matrices(np.subtract(lengths, h * np.array(rates)))[0]
    ) / (2 * h)
    np.testing.assert_allclose(Md, dM, atol=1e-7 * np.abs(dM).max())
    assert np.abs(skew).max() > 0
    np.testing.assert_allclose(M0, M)


def test_gyroscopic_derivative_matches_definition():
    """Gd in K_eq is the total time derivative of G (model.md §5)."""
    from sail_ros.model.assembly import GYROSCOPIC, STIFFNESS_CANONICAL

    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    L0, v0, a0 = (
        np.array([30.0, 42.0, 35.5, 50.0]),
        np.array([0.3, -0.2, 0.05, 0.4]),
        np.array([0.02, 0.01, -0.02, 0.03]),
    )

    def gyro(t):
        return model.evaluate((GYROSCOPIC,), L0 + v0 * t + 0.5 * a0 * t**2, v0 + a0 * t, a0)[0]

    h = 1e-5
    Gd = (gyro(h) - gyro(-h)) / (2 * h)
    _, _, K_eq = model.matrices(L0, v0, a0)
    K_canonical = model.evaluate((STIFFNESS_CANONICAL,), L0, v0, a0)[0]
    np.testing.assert_allclose(K_eq - K_canonical, Gd, atol=1e-8 * np.abs(Gd).max())


def test_quadrature_is_converged_to_nine_digits():
    p = SailParameters(n_boom_modes=10, n_membrane_modes=10)
    base = SailModel(p).natural_frequencies([45.0, 60.0, 52.0, 70.0])
    from sail_ros.model.integrals import default_quadrature_order

    refined = SailModel(p, quadrature_order=default_quadrature_order(10, 10) + 60)
    np.testing.assert_allclose(
        refined.natural_frequencies([45.0, 60.0, 52.0, 70.0]), base, rtol=1e-10
    )


@pytest.mark.parametrize("path", ["exact", "rational"])
def test_energy_conserved_at_constant_length(path):
    """Check 5: no energy added (or lost) by the integrator while lengths are fixed."""
    model = SailModel(SailParameters(n_boom_modes=6, n_membrane_modes=6))
    rng = np.random.default_rng(7)
    q0 = rng.normal(scale=0.02, size=model.n)  # excites the stiff high boom modes too
    static = StaticProfile(20.0)
    # a plain callable is never known to be static, so it takes the rational (moving) path
    profile = static if path == "exact" else (lambda t: static(t))
    stepper = model.stepper(profile, q0=q0, max_step=0.05)
    e0 = stepper.energy()
    for t in np.linspace(5.0, 60.0, 12):
        stepper.advance(t)
        assert stepper.energy() == pytest.approx(e0, rel=1e-9)
    assert np.all(np.isfinite(stepper.q))


def test_tip_deflection_and_mode_state():
    model = SailModel(SMALL)
    q = model.mode_state(boom="c", tip_deflection=0.25)
    np.testing.assert_allclose(model.tip_deflections(q), [0.0, 0.0, 0.25, 0.0], atol=1e-15)
    assert np.count_nonzero(q) == 1
    series = np.stack([q, 2 * q])
    np.testing.assert_allclose(model.tip_deflections(series)[:, 2], [0.25, 0.5])


def test_coordinate_names_follow_system_order():
    model = SailModel(SailParameters(n_boom_modes=2, n_membrane_modes=3))
    names = model.coordinate_names
    assert len(names) == model.n == 20
    assert names[:3] == ["boom_a_mode_1", "boom_a_mode_2", "boom_b_mode_1"]
    assert names[8:11] == ["membrane_ab_mode_2_1", "membrane_ab_mode_3_1", "membrane_ab_mode_3_2"]
    assert names[-1] == "membrane_da_mode_3_2"


def test_boom_mode_shares_sum_to_the_tips_and_root_moments_at_their_frequencies():
    """Each boom mode's share of the outputs (what a log's report asks of the model for
    the modes its sampling cannot follow) adds up to the outputs, and the boom modes'
    bare-cantilever frequencies are `beta_j^2 sqrt(EI / rho_B) / L^2`."""
    model = SailModel(SMALL)
    rng = np.random.default_rng(3)
    q = rng.normal(size=(5, model.n))
    lengths = rng.uniform(5.0, 12.0, size=(5, 4))
    tips, moments = model.boom_mode_shares(q, lengths)
    assert tips.shape == moments.shape == (5, 4, model.n_boom_modes)
    np.testing.assert_allclose(tips.sum(axis=2), model.tip_deflections(q), rtol=1e-12)
    np.testing.assert_allclose(moments.sum(axis=2), model.root_moments(q, lengths), rtol=1e-12)
    params = model.params
    omega = cantilever_frequencies(params, lengths, model.n_boom_modes)
    beta = brentq(lambda b: np.cos(b) * np.cosh(b) + 1.0, 1.0, 3.0)
    expected = beta**2 * np.sqrt(params.boom_bending_stiffness / params.boom_linear_density)
    np.testing.assert_allclose(omega[..., 0], expected / lengths**2, rtol=1e-10)
    assert cantilever_frequency(params, 7.0) == pytest.approx(expected / 49.0, rel=1e-10)
