"""Time integration: accuracy on the reference deployment, stability, the stepper API."""

import numpy as np
import pytest
import scipy.linalg
from harness import SMALL

from sail_ros.model import (
    CycloidalProfile,
    IntegrationError,
    SailModel,
    SailParameters,
    StaticProfile,
    WaypointProfile,
)

pytestmark = pytest.mark.model

GAUSS = (0.5 - np.sqrt(3) / 6, 0.5 + np.sqrt(3) / 6)
WEIGHTS = (0.25 + np.sqrt(3) / 6, 0.25 - np.sqrt(3) / 6)


def magnus4_reference(model, profile, x0, t_out, h):
    """Commutator-free 4th-order Magnus with exact matrix exponentials, applied to
    the first-order form of seed Eq. 3 (x = [qd; q]) as published by
    `SailModel.state_matrix`: independent of the stepper's canonical variables
    and rational approximation."""

    def state_matrix(t):
        return model.state_matrix(*profile(t))

    x, t, out = np.array(x0, dtype=float), 0.0, []
    for t_next in t_out:
        steps = int(round((t_next - t) / h))
        for _ in range(steps):
            A1, A2 = state_matrix(t + GAUSS[0] * h), state_matrix(t + GAUSS[1] * h)
            x = scipy.linalg.expm(h * (WEIGHTS[0] * A1 + WEIGHTS[1] * A2)) @ x
            x = scipy.linalg.expm(h * (WEIGHTS[1] * A1 + WEIGHTS[0] * A2)) @ x
            t += h
        out.append(x.copy())
    return np.array(out)


@pytest.fixture(scope="module")
def reference_deployment():
    """model.md §9: 10 m -> 15 m in 15 s, boom a tip at 0.1 m, n_B = n_M = 10."""
    model = SailModel(SailParameters(n_boom_modes=10, n_membrane_modes=10))
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    q0 = model.mode_state("a", 0.1)
    x0 = np.concatenate([np.zeros(model.n), q0])
    t_out = [5.0, 10.0, 15.0]
    fine = magnus4_reference(model, profile, x0, t_out, h=0.05)
    coarse = magnus4_reference(model, profile, x0, t_out, h=0.1)
    return model, profile, q0, t_out, fine, coarse


def test_reference_deployment_tip_deflections_within_0p2_percent(reference_deployment):
    model, profile, q0, t_out, fine, coarse = reference_deployment
    n = model.n
    reference_tips = model.tip_deflections(fine[:, n:])
    # the reference itself is converged far below the tolerance (0.1 m: the initial tip)
    assert np.max(np.abs(model.tip_deflections(coarse[:, n:]) - reference_tips)) < 1e-6
    t, q, qd = model.simulate(profile, 15.0, q0, t_eval=[0.0] + t_out)
    tips = model.tip_deflections(q[1:])
    dense = model.simulate(profile, 15.0, q0, t_eval=np.linspace(0, 15, 301))[1]
    peak = np.max(np.abs(model.tip_deflections(dense)))
    assert peak == pytest.approx(0.1175, rel=0.01)
    error = np.max(np.abs(tips - reference_tips)) / peak
    assert error < 2e-3, f"tip error {error:.2%} of the peak"
    # tip velocities too (the canonical momenta map back to qd)
    reference_rates = model.tip_deflections(fine[:, :n])
    rate_error = np.max(np.abs(model.tip_deflections(qd[1:]) - reference_rates))
    assert rate_error < 5e-3 * np.max(np.abs(reference_rates)), rate_error


def test_stiff_high_modes_stay_bounded_during_deployment():
    model = SailModel(SailParameters(n_boom_modes=12, n_membrane_modes=6))
    rng = np.random.default_rng(3)
    q0 = rng.normal(scale=1e-3, size=model.n)  # every mode, up to ~3000 rad/s, excited
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    t, q, qd = model.simulate(profile, 15.0, q0, t_eval=np.linspace(0, 15, 31))
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(qd))
    energies = [model.energy(qi, qdi, profile(ti)[0]) for ti, qi, qdi in zip(t, q, qd, strict=True)]
    # lengthening lowers every frequency: the vibration energy must not grow
    assert max(energies) <= energies[0] * (1 + 1e-9)


def test_non_finite_state_raises_and_reset_recovers():
    euler = np.pi**2 * 6000.0 / (4 * 20.0**2)
    model = SailModel(SailParameters(membrane_prestress=0.0, boom_axial_load=400 * euler))
    stepper = model.stepper(StaticProfile(20.0), q0=model.mode_state("a", 0.1))
    with pytest.raises(IntegrationError, match="non-finite"):
        stepper.advance(1e4)
    stepper.reset(model.mode_state("b", 0.05))
    assert stepper.t == 0.0
    np.testing.assert_allclose(model.tip_deflections(stepper.q), [0, 0.05, 0, 0])


def test_profile_swap_keeps_velocity_continuous():
    model = SailModel(SMALL)
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 15.0), q0=model.mode_state("a", 0.1))
    stepper.advance(4.0)
    q, qd = stepper.q, stepper.qd
    lengths, rates, _ = stepper.boom_motion()
    stepper.profile = WaypointProfile([4.0, 9.0], [lengths, np.full(4, 12.0)], start_rates=rates)
    np.testing.assert_allclose(stepper.qd, qd, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(stepper.q, q)
    stepper.advance(9.0)
    np.testing.assert_allclose(stepper.boom_motion()[0], 12.0)


def test_advance_by_less_than_round_off_of_a_step():
    model = SailModel(SMALL)
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 15.0), q0=model.mode_state("a", 0.1))
    stepper.advance(1.0)
    stepper.advance(1.0 + 1e-10)  # one tiny step, not a division by zero
    assert stepper.t == pytest.approx(1.0 + 1e-10, abs=1e-15)
    t, q, _ = model.simulate(StaticProfile(20.0), 2.0, t_eval=[0.0, 1.0, 1.0 + 1e-11, 2.0])
    np.testing.assert_array_equal(t, [0.0, 1.0, 1.0 + 1e-11, 2.0])


def test_simulate_arguments_are_checked():
    model = SailModel(SMALL)
    profile = StaticProfile(30.0)
    with pytest.raises(ValueError, match="t_end must be finite and > 0, got -1"):
        model.simulate(profile, -1.0)
    with pytest.raises(ValueError, match="t_eval must increase"):
        model.simulate(profile, 2.0, t_eval=[0.0, 1.5, 1.0])
    with pytest.raises(ValueError, match="q0 must have 40 values"):
        model.simulate(profile, 1.0, q0=np.zeros(3))
    with pytest.raises(ValueError, match="lengths at t = 0 s must be > 0"):
        model.simulate(lambda t: (0.0, 0.0, 0.0), 1.0)
    t, q, qd = model.simulate(profile, 1.0)
    assert t[0] == 0.0 and t[-1] == 1.0 and q.shape == (t.size, 40) == qd.shape


def test_simulate_at_rest_stays_at_rest():
    model = SailModel(SMALL)
    t, q, qd = model.simulate(CycloidalProfile(10.0, 40.0, 20.0), 25.0)
    assert np.all(q == 0.0) and np.all(qd == 0.0)


def test_free_vibration_matches_modal_solution():
    """At fixed length the answer is the modal superposition; the stepper must
    reproduce it (exact propagator path) over many periods."""
    model = SailModel(SMALL)
    M, K = model.mass_and_stiffness(30.0)
    lam, V = scipy.linalg.eigh(K, M)
    q0 = model.mode_state("d", 0.2)
    eta0 = V.T @ M @ q0
    t = 137.3
    expected = V @ (eta0 * np.cos(np.sqrt(lam) * t))
    stepper = model.stepper(StaticProfile(30.0), q0=q0, max_step=0.1)
    stepper.advance(t)
    np.testing.assert_allclose(stepper.q, expected, atol=1e-10 * np.abs(q0).max())
