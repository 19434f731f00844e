"""The modal model at its default mode counts against the continuum: a finite-element
transient of the same sail (`sail_ros.fem.free_vibration`), and the FE transient itself
against closed forms."""

import math

import numpy as np
import pytest

from sail_ros.fem import SailFEM, free_vibration
from sail_ros.model import SailModel, SailParameters, StaticProfile
from sail_ros.model.basis import cantilever_roots
from sail_ros.model.layout import triangle_mode_indices
from sail_ros.model.parameters import DEFAULT_RESOLVED_LENGTH, LIVE_DEFAULTS

pytestmark = pytest.mark.model

# The bar of docs/model.md ("Mode counts"): every tip and root moment within 2 % of the
# largest peak of its kind over the whole history
BAR = 0.02
LENGTH, DURATION, SPACING = 15.0, 10.0, 0.01
BENT = [0.1, 0.0, 0.0, 0.0]  # boom a bent 0.1 m in its first mode


def history_errors(t, tips, moments, reference) -> dict:
    """Largest |difference| of each output kind over the history, relative to the
    reference's largest peak of that kind, and per boom relative to its own peak."""
    errors = {}
    for kind, values, ref in (
        ("tips", tips, reference.tips),
        ("moments", moments, reference.root_moments),
    ):
        ref = np.array([np.interp(t, reference.t, ref[:, k]) for k in range(4)]).T
        difference = np.abs(values - ref).max(axis=0)
        peaks = np.abs(ref).max(axis=0)
        errors[kind] = (difference.max() / peaks.max(), difference / peaks)
    return errors


def modal_history(params):
    model = SailModel(params)
    t = np.arange(0.0, DURATION + SPACING / 2, SPACING)
    _, q, _ = model.simulate(
        StaticProfile(LENGTH), DURATION, q0=model.initial_coordinates(BENT), t_eval=t
    )
    return model, t, model.tip_deflections(q), model.root_moments(q, LENGTH)


@pytest.fixture(scope="module")
def fe_transient():
    return free_vibration(SailParameters(), LENGTH, BENT, DURATION, output_spacing=SPACING)


@pytest.mark.parametrize(
    "changes",
    [{}, {"resolved_length": LENGTH}, LIVE_DEFAULTS],  # the last resolved at 10 m, as live
    ids=["defaults", "resolved-at-the-run's-length", "the-simulator's-defaults"],
)
def test_default_mode_counts_follow_the_fe_transient(fe_transient, changes):
    """Boom a bent at a fixed 15 m: its energy flows into the film, whose dense spectrum
    the automatic membrane count resolves; every tip and root moment of the modal model
    stays within 2 % of the largest peak of its kind of the FE transient."""
    params = SailParameters(**changes)
    model, t, tips, moments = modal_history(params)
    assert model.n_membrane_modes == params.membrane_modes
    errors = history_errors(t, tips, moments, fe_transient)
    for kind, (largest, per_boom) in errors.items():
        assert largest <= BAR, f"{kind}: {100 * largest:.2f} % of peak (per boom {per_boom})"


def test_too_few_membrane_modes_miss_the_bar(fe_transient):
    """The check can fail: the former default (4, 6) leaves boom a ringing with its
    energy still in it (its tip 4x the FE's at 10 s)."""
    _, t, tips, moments = modal_history(SailParameters(n_boom_modes=4, n_membrane_modes=6))
    largest, _ = history_errors(t, tips, moments, fe_transient)["tips"]
    assert largest > 10 * BAR


def test_automatic_count_keeps_every_mode_in_the_band():
    """The automatic count is every clamped-triangle mode up to `membrane_band` times the
    first cantilever frequency at `resolved_length`: the next mode lies above it."""
    for changes in (
        {},
        {"resolved_length": 15.0},
        {"membrane_band": 2.5},
        {"membrane_prestress": 5000.0},
    ):
        params = SailParameters(**changes)
        L = params.resolved_length or DEFAULT_RESOLVED_LENGTH
        c = math.sqrt(params.membrane_tension / params.membrane_areal_density)
        boom = (
            cantilever_roots(1)[0] ** 2
            * math.sqrt(params.boom_bending_stiffness / params.boom_linear_density)
            / L**2
        )
        m, n = np.array(triangle_mode_indices(params.membrane_modes + 1)).T
        frequency = math.pi / L * c * np.hypot(m, n)
        band = params.membrane_band * boom
        assert (frequency[:-1] <= band).all() and frequency[-1] > band
    assert SailParameters(membrane_prestress=0.0).membrane_modes == 6
    assert SailParameters(n_membrane_modes=12).membrane_modes == 12


def test_fe_transient_of_a_bare_boom_is_its_first_mode():
    """Booms alone: boom a bent in its first mode swings in it, `0.1 cos(omega_1 t)`, with
    the discrete frequency of the Hermite mesh turned by the trapezoidal rule:
    `tan(Omega h / 2) = omega h / 2`."""
    bare = SailParameters(membrane_density=0.0, membrane_prestress=0.0)
    h = 0.01
    result = free_vibration(
        bare,
        12.0,
        BENT,
        5.0,
        time_step=h,
        output_spacing=0.05,
        boom_elements=8,
        membrane_divisions=8,
    )
    (omega,) = SailFEM(bare, 8, 8).natural_frequencies(1, 12.0)
    continuum = cantilever_roots(1)[0] ** 2 * math.sqrt(6000.0 / 0.1) / 12.0**2
    assert omega == pytest.approx(continuum, rel=1e-5)
    newmark = 2 / h * math.atan(omega * h / 2)
    expected = 0.1 * np.cos(newmark * result.t)
    assert np.abs(result.tips[:, 0] - expected).max() < 1e-6
    assert np.abs(result.tips[:, 1:]).max() == 0.0
    # the root moment of the first mode: EI psi''(0) / L^2 with psi''(0) = 2 beta^2, tip 2
    moment = 6000.0 * 2 * cantilever_roots(1)[0] ** 2 / 12.0**2 * 0.05
    assert (
        np.abs(result.root_moments[:, 0] - moment * np.cos(newmark * result.t)).max()
        < 1e-3 * moment
    )


def test_fe_transient_rejects_bad_input():
    params = SailParameters()
    with pytest.raises(ValueError, match="length must be finite and > 0 m, got -1"):
        free_vibration(params, -1.0, BENT, 1.0)
    with pytest.raises(ValueError, match="output_spacing must be a multiple of time_step"):
        free_vibration(params, 10.0, BENT, 1.0, time_step=0.004, output_spacing=0.01)


@pytest.mark.slow
def test_default_mode_counts_follow_the_fine_fe_transient():
    """The full-size check: the FE film at 48 divisions a leg (within 0.3 % of its
    peaks' limit), 2 ms steps."""
    fine = free_vibration(SailParameters(), LENGTH, BENT, DURATION, time_step=0.002,
                          output_spacing=SPACING, membrane_divisions=48)  # fmt: skip
    for changes in ({}, {"resolved_length": LENGTH}):
        _, t, tips, moments = modal_history(SailParameters(**changes))
        for kind, (largest, per_boom) in history_errors(t, tips, moments, fine).items():
            assert largest <= BAR, f"{kind}: {100 * largest:.2f} % of peak (per boom {per_boom})"
