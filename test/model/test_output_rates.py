"""The velocities at output times inside moving steps: exact (`M^-1 (p - G q)` at each
time) or the step's extension (`SailStepper.states_at(times, rates)`); the coordinates
and the peaks are the same either way, so a caller that reads positions only (a Monte
Carlo row) takes the cheaper one."""

import numpy as np
import pytest

from sail_ros.integrate.system import SAMPLES_AT_ONCE
from sail_ros.model import CycloidalProfile, SailModel, SailParameters

pytestmark = pytest.mark.model


def test_extension_rates_leave_the_coordinates_and_differ_from_exact_rates_by_little():
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    q0 = np.zeros(model.n)
    q0[0] = 0.02
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 6.0), q0=q0)
    compared = 0
    scale = 0.0
    worst = 0.0
    while stepper.t < 6.0 - 1e-9:
        t0 = stepper.t
        stepper.advance_step(6.0)
        times = t0 + (stepper.t - t0) * np.array([0.2, 0.5, 0.9])
        q_exact, qd_exact = stepper.states_at(times)
        q_ext, qd_ext = stepper.states_at(times, rates="extension")
        assert np.array_equal(q_exact, q_ext)  # the same positions, to the bit
        tips_exact, tips_ext = model.tip_deflections(qd_exact), model.tip_deflections(qd_ext)
        scale = max(scale, np.abs(tips_exact).max())
        worst = max(worst, np.abs(tips_exact - tips_ext).max())
        compared += 1
    assert compared > 5
    # the extension's rates are of the midpoint rule's order: off by below 1 % of peak
    assert 0.0 < worst < 1e-2 * scale


def test_unknown_rates_are_refused_by_name():
    model = SailModel(SailParameters(n_boom_modes=2, n_membrane_modes=2))
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 6.0))
    stepper.advance_step(6.0)
    with pytest.raises(ValueError, match="rates must be 'exact' or 'extension', got 'slope'"):
        stepper.states_at([0.5 * stepper.t], rates="slope")


def test_without_rates_the_positions_are_the_same_and_the_step_end_is_the_state():
    """With rates None (a Monte Carlo row: positions at the output times, the state at
    the end) the coordinates are the same to the bit, no velocities inside the step, the
    state at its end."""
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    q0 = np.zeros(model.n)
    q0[0] = 0.02
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 6.0), q0=q0)
    stepper.advance_step(6.0)
    t0 = stepper.t
    stepper.advance_step(6.0)  # a step whose followed modes are turned in its samples
    times = t0 + (stepper.t - t0) * np.array([0.2, 0.5, 0.9, 1.0])
    q_exact, qd_exact = stepper.states_at(times)
    q, qd = stepper.states_at(times, rates=None)
    assert np.array_equal(q, q_exact)
    assert np.isnan(qd[:3]).all() and np.array_equal(qd[3], stepper.qd)


def test_simulate_without_rates_gives_the_same_coordinates():
    """`SailModel.simulate(..., rates=None)` (a log's rerun reads the tips alone): the
    coordinates at every output time the same to the bit, velocities only at the steps'
    ends."""
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    q0 = model.mode_state(boom="a", tip_deflection=0.05)
    profile, t_eval = CycloidalProfile(10.0, 15.0, 6.0), np.linspace(0.0, 6.0, 25)
    t, q, qd = model.simulate(profile, 6.0, q0, t_eval=t_eval)
    t_none, q_none, qd_none = model.simulate(profile, 6.0, q0, t_eval=t_eval, rates=None)
    assert np.array_equal(t, t_none) and np.array_equal(q, q_none)
    inside = np.isnan(qd_none).any(axis=1)
    assert 0 < inside.sum() < t.size - 1  # most outputs fall inside steps
    assert np.array_equal(qd_none[~inside], qd[~inside])


class _Cycloid:
    """A plain profile object: the reference deployment's motion, one time at a time (no
    `over`, no `is_static`)."""

    def __init__(self):
        self._profile = CycloidalProfile(10.0, 15.0, 6.0)

    def __call__(self, t):
        return self._profile(t)


def test_exact_rates_at_many_samples_and_from_a_plain_profile():
    """Exact rates at more samples of a step than one pass takes (`SAMPLES_AT_ONCE`) are
    those of the samples asked a few at a time; a profile without `over` (its motion one
    time at a time) gives the rates that `CycloidalProfile` does in one pass, to
    round-off."""
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    q0 = model.mode_state("a", 0.02)
    states = {}
    for name, profile in (("cycloid", CycloidalProfile(10.0, 15.0, 6.0)), ("plain", _Cycloid())):
        stepper = model.stepper(profile, q0=q0)
        stepper.advance_step(6.0)
        t0 = stepper.t
        stepper.advance_step(6.0)
        times = t0 + (stepper.t - t0) * np.linspace(0.01, 0.99, 3 * SAMPLES_AT_ONCE + 5)
        q, qd = stepper.states_at(times)
        for part in np.array_split(np.arange(times.size), 7):
            q_part, qd_part = stepper.states_at(times[part])
            assert np.array_equal(q_part, q[part])
            np.testing.assert_allclose(qd_part, qd[part], rtol=0, atol=1e-12 * np.abs(qd).max())
        states[name] = q, qd
    (q, qd), (q_plain, qd_plain) = states["cycloid"], states["plain"]
    np.testing.assert_allclose(q_plain, q, rtol=0, atol=1e-12 * np.abs(q).max())
    np.testing.assert_allclose(qd_plain, qd, rtol=0, atol=1e-12 * np.abs(qd).max())
