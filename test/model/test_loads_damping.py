"""Loads, damping and the linear plant (docs/model.md §12, checks 9-13), each against an
answer computed here independently: closed forms, a finite-element Poisson solve,
and a tight-tolerance integration of the same equations."""

import math
import re

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import skfem
from harness import SMALL
from skfem.helpers import dot, grad

from sail_ros.model import CycloidalProfile, SailModel, SailParameters, StaticProfile
from sail_ros.model.basis import cantilever_roots, triangle_modes
from sail_ros.model.linear import modal_eigenvalues
from sail_ros.model.loads import (
    INPUT_NAMES,
    OUTPUT_NAMES,
    LoadSchedule,
    input_function,
    inputs,
)
from sail_ros.model.profiles import BoomMotion

pytestmark = pytest.mark.model

BOOMS_ALONE = {"membrane_density": 0.0, "membrane_prestress": 0.0}


def test_inputs_and_outputs_are_named_in_the_order_of_model_md():
    assert INPUT_NAMES == (
        "pressure_ab", "pressure_bc", "pressure_cd", "pressure_da",
        "tip_force_a", "tip_force_b", "tip_force_c", "tip_force_d",
    )  # fmt: skip
    assert OUTPUT_NAMES[:4] == tuple(f"tip_deflection_{b}" for b in "abcd")
    assert OUTPUT_NAMES[4:] == tuple(f"root_moment_{b}" for b in "abcd")


@pytest.mark.parametrize("n_boom_modes", [2, 4, 8, 16])
def test_check_9_static_tip_force_on_a_cantilever(n_boom_modes):
    """Booms alone, F at the tip of boom b: tip deflection -> F L^3 / (3 EI) (modal
    series 4 sum 1/beta^4 = 1/3, tail below 4 sum_{i>n} 1/beta_i^4) and root
    moment -> F L (alternating, error below the first omitted term 4/beta_{n+1}^2)."""
    params = SailParameters(n_boom_modes=n_boom_modes, n_membrane_modes=1, **BOOMS_ALONE)
    model = SailModel(params)
    L, F, EI = 20.0, 3.0, params.boom_bending_stiffness
    _, K = model.mass_and_stiffness(L)
    slots = model.boom_slice("b")
    Q = model.load_vector(L, tip_forces=[0.0, F, 0.0, 0.0])
    q = np.zeros(model.n)
    q[slots] = np.linalg.solve(K[slots, slots], Q[slots])  # the membranes carry nothing
    beta = cantilever_roots(n_boom_modes + 1)
    # K's boom block is diag(EI beta^4 / L^3) and psi_i(1)^2 = 4: the modal sum exactly
    modal = 4.0 * np.sum(1.0 / beta[:n_boom_modes] ** 4) * F * L**3 / EI
    tip = model.tip_deflections(q)[1]
    assert tip == pytest.approx(modal, rel=1e-9)
    tail = F * L**3 / (3 * EI) - modal  # 4 sum_{i>n} 1/beta_i^4 < 4/(3 pi^4 (n - 1/2)^3)
    assert 0 < tail < 4.0 / (3 * np.pi**4 * (n_boom_modes - 0.5) ** 3) * F * L**3 / EI
    moment = model.root_moments(q, L)[1]
    assert abs(moment - F * L) <= 4.0 / beta[n_boom_modes] ** 2 * F * L
    assert np.all(model.root_moments(q, L)[[0, 2, 3]] == 0.0)


def poisson_mean_deflection(length: float, pressure: float, tension: float) -> float:
    """Mean of w over the triangle {x, y >= 0, x + y <= L} with N0 laplace(w) = -p,
    w = 0 on the edges: P2 finite elements on a fine mesh."""
    mesh = skfem.MeshTri(
        np.array([[0.0, length, 0.0], [0.0, 0.0, length]]), np.array([[0], [1], [2]])
    ).refined(6)
    basis = skfem.Basis(mesh, skfem.ElementTriP2())

    @skfem.BilinearForm
    def stiffness(u, v, _):
        return tension * dot(grad(u), grad(v))

    @skfem.LinearForm
    def load(v, _):
        return pressure * v

    @skfem.Functional
    def integral(w):
        return w.w

    w = skfem.solve(
        *skfem.condense(stiffness.assemble(basis), load.assemble(basis), D=basis.get_dofs())
    )
    return integral.assemble(basis, w=basis.interpolate(w)) / (0.5 * length**2)


def test_check_10_uniform_pressure_on_membranes_over_rigid_booms():
    """Rigid booms (their coordinates removed), a pressure on Q_ab: the membrane's
    mean deflection converges to the finite-element Poisson solution."""
    L, p = 12.0, 2.0e-3
    reference = poisson_mean_deflection(L, p, SailParameters().membrane_tension)
    errors = []
    for n_membrane_modes in (3, 10, 30, 60):
        model = SailModel(SailParameters(n_boom_modes=1, n_membrane_modes=n_membrane_modes))
        _, K = model.mass_and_stiffness(L)
        slots = model.membrane_slice("ab")
        Q = model.load_vector(L, pressures=[p, 0.0, 0.0, 0.0])
        coefficients = np.linalg.solve(K[slots, slots], Q[slots])
        # mean of w = sum_j c_j <phi_j> / |D| with the rule of the model's own modes
        xi, eta, weight = _fine_triangle_rule()
        phi, _, _ = triangle_modes(n_membrane_modes, xi, eta)
        mean = coefficients @ (phi @ weight) / 0.5
        errors.append(abs(mean - reference) / reference)
    assert errors == sorted(errors, reverse=True)
    assert errors[-1] < 2e-3


def _fine_triangle_rule():
    from sail_ros.model.integrals import collapsed_gauss_triangle

    return collapsed_gauss_triangle(200)


DAMPED = SailParameters(
    n_boom_modes=4,
    n_membrane_modes=6,
    mass_damping=0.02,
    stiffness_damping=2e-4,
    boom_bending_stiffness=4500.0,
    membrane_prestress=9000.0,
)


def test_check_11_energy_changes_by_the_work_of_loads_and_damping():
    """Constant unequal lengths, damping, a pressure and a tip force: E(t) - E(0) equals
    the integral of qd^T Q - qd^T C_d qd (Simpson's rule on a fine grid)."""
    model = SailModel(DAMPED)
    lengths = np.array([12.0, 13.0, 12.5, 14.0])
    loads = ([1e-3, 0.0, 2e-3, 0.0], [0.0, 0.02, 0.0, -0.01])
    t = np.linspace(0.0, 4.0, 4001)
    q0 = model.initial_coordinates([0.05, 0.0, -0.02, 0.0])
    _, q, qd = model.simulate(StaticProfile(lengths), 4.0, q0=q0, t_eval=t, loads=loads)
    M, K = model.mass_and_stiffness(lengths)
    C_d = model.structural_damping(lengths)
    Q = model.load_vector(lengths, *loads)
    energy = 0.5 * np.einsum("ti,ij,tj->t", qd, M, qd) + 0.5 * np.einsum("ti,ij,tj->t", q, K, q)
    power = qd @ Q - np.einsum("ti,ij,tj->t", qd, C_d, qd)
    work = scipy.integrate.simpson(power, x=t)
    assert abs(work) > 1e-3 * energy[0]  # the check sees the loads and the damping
    assert energy[-1] - energy[0] == pytest.approx(work, rel=1e-6, abs=1e-9 * energy[0])


def test_check_12_rayleigh_damped_eigenvalues():
    model = SailModel(DAMPED)
    lengths = [15.0, 16.0, 15.0, 17.0]
    omega = model.natural_frequencies(lengths)
    alpha, beta = DAMPED.mass_damping, DAMPED.stiffness_damping
    zeta = alpha / (2 * omega) + beta * omega / 2
    assert np.all(zeta < 1)  # underdamped: conjugate pairs
    expected = np.concatenate(
        [
            -zeta * omega + 1j * omega * np.sqrt(1 - zeta**2),
            -zeta * omega - 1j * omega * np.sqrt(1 - zeta**2),
        ]
    )
    eigenvalues = model.eigenvalues(lengths)
    expected = expected[np.lexsort((expected.real, expected.imag))]
    assert np.allclose(eigenvalues, expected, rtol=1e-9, atol=1e-9 * omega.max())


def test_check_13_constant_loads_settle_to_the_static_deflection_and_the_dc_gain():
    model = SailModel(DAMPED.replace(mass_damping=0.5))
    lengths = np.array([10.0, 11.0, 10.5, 12.0])
    pressures, forces = [1e-3, 5e-4, 0.0, 2e-3], [0.01, 0.0, -0.02, 0.0]
    static = model.static_deflection(lengths, pressures, forces)
    M, K = model.mass_and_stiffness(lengths)
    assert np.allclose(K @ static, model.load_vector(lengths, pressures, forces), rtol=1e-10)
    omega = model.natural_frequencies(lengths)
    settle = 40.0 / (0.5 * model.params.mass_damping)  # e^-20 of the slowest mode
    _, q, _ = model.simulate(
        StaticProfile(lengths), settle, t_eval=[settle], loads=(pressures, forces)
    )
    assert np.allclose(q[-1], static, rtol=1e-6, atol=1e-8 * np.abs(static).max())
    assert omega.min() > 0
    A, B, C, D = model.state_space(lengths)
    u = np.concatenate([pressures, forces])
    dc_gain = -C @ np.linalg.solve(A, B)
    expected = np.concatenate([model.tip_deflections(static), model.root_moments(static, lengths)])
    assert np.allclose(dc_gain @ u, expected, rtol=1e-8)
    assert np.all(D == 0) and A.shape == (2 * model.n, 2 * model.n) and B.shape == (2 * model.n, 8)


def test_state_space_matches_eigenvalues_and_matrices():
    model = SailModel(DAMPED)
    A, _, _, _ = model.state_space(14.0, rates=0.2)
    plant = np.linalg.eigvals(A)
    plant = plant[np.lexsort((plant.real, plant.imag))]
    assert np.allclose(plant, model.eigenvalues(14.0, rates=0.2), atol=1e-8)


def test_with_zero_loads_and_damping_the_model_is_the_seeds():
    seed, zero = SailModel(SMALL), SailModel(SMALL.replace(mass_damping=0.0))
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    q0 = seed.mode_state("a", 0.1)
    _, q_seed, _ = seed.simulate(profile, 15.0, q0=q0)
    _, q_zero, _ = zero.simulate(profile, 15.0, q0=q0, loads=(0.0, 0.0))
    assert np.array_equal(q_seed, q_zero)
    M, C, K = seed.matrices(12.0, 0.3, 0.01)
    assert np.all(seed.structural_damping(12.0) == 0.0)
    assert np.array_equal(C, zero.matrices(12.0, 0.3, 0.01)[1])


def deployment_reference(model, profile, loads_at, t_points, switch_times, q0):
    """The same equations, M qdd + C qd + K_eq q = B_u u, by DOP853 at rtol 1e-11,
    restarted at every load switch (the loads are constant between)."""
    n = model.n

    def rhs(t, x, u):
        lengths, rates, accelerations = profile(t)
        M, C, K = model.matrices(lengths, rates, accelerations)
        force = model.input_matrix(lengths) @ u
        q, qd = x[:n], x[n:]
        return np.concatenate([qd, np.linalg.solve(M, force - C @ qd - K @ q)])

    edges = [0.0, *switch_times, t_points[-1]]
    x = np.concatenate([q0, np.zeros(n)])
    out = []
    for start, end in zip(edges[:-1], edges[1:], strict=True):
        inside = sorted({t for t in t_points if start < t <= end} | {end})
        segment = scipy.integrate.solve_ivp(
            rhs,
            (start, end),
            x,
            method="DOP853",
            rtol=1e-11,
            atol=1e-14,
            t_eval=inside,
            args=(loads_at(0.5 * (start + end)),),  # constant inside the segment
        )
        out.extend(y for t, y in zip(segment.t, segment.y.T, strict=True) if t in t_points)
        x = segment.y[:, -1]
    return np.array(out)


def test_loaded_damped_deployment_matches_a_tight_reference():
    """Unequal booms deploying, damping, a constant pressure on two quadrants and a
    tip force switched on and off mid-run: tips and root moments at five times within
    0.2 % of their peak of the reference."""
    params = DAMPED.replace(stiffness_damping=5e-4)
    model = SailModel(params)
    profile = BoomMotion(
        [
            CycloidalProfile(10.0, 14.0, 12.0),
            CycloidalProfile(11.0, 15.0, 12.0),
            CycloidalProfile(10.0, 13.0, 12.0),
            CycloidalProfile(12.0, 14.0, 12.0),
        ]
    )
    on, off = 3.0, 7.0

    def loads(t):
        force = 0.05 if on <= t < off else 0.0
        return [2e-3, 0.0, 1e-3, 0.0], [0.0, force, 0.0, 0.0]

    def loads_at(t):
        pressures, forces = loads(t)
        return np.concatenate([pressures, forces])

    q0 = model.mode_state("a", 0.1)
    t_check = np.array([1.5, 4.0, 6.5, 9.0, 12.0])
    t_eval = np.sort(np.concatenate([t_check, [on, off]]))
    t, q, _ = model.simulate(profile, 12.0, q0=q0, t_eval=t_eval, loads=loads)
    reference = deployment_reference(model, profile, loads_at, t_eval, [on, off], q0)
    n = model.n
    keep = np.isin(t, t_check)
    lengths = np.array([profile(ti)[0] for ti in t])
    for name, series, expected in (
        ("tips", model.tip_deflections(q), model.tip_deflections(reference[:, :n])),
        ("moments", model.root_moments(q, lengths), model.root_moments(reference[:, :n], lengths)),
    ):
        assert np.abs(expected).max() > 0
        error = np.abs(series - expected)[keep].max() / np.abs(expected).max()
        assert error < 2e-3, (name, error)


def test_strongly_damped_followed_modes_leave_every_state_finite():
    """At (20, 20) with stiffness damping the highest boom modes decay by e^-700 and more
    within a step; between steps they are the end's vibration turned back, whose growth
    (`fast_modes.TURN_BACK_EXPONENT`) must keep their underflowed 0 a 0: every output
    state and every sample the peaks are searched on finite (18 of 200 states were nan)."""
    from sail_ros.integrate.peaks import OutputPeaks

    params = SailParameters(
        n_boom_modes=20, n_membrane_modes=20, mass_damping=0.02, stiffness_damping=2e-4
    )
    model = SailModel(params)
    finite = []

    def check(sampled):
        finite.extend(np.isfinite(sampled.values).all(axis=1))

    peaks = OutputPeaks(model, check=check)

    t_out = np.arange(0.0, 2.0, 0.01)
    run = model.simulate(
        CycloidalProfile(10.0, 15.0, 8.0), 2.0, model.mode_state("a", 0.1), t_eval=t_out,
        observer=peaks,
    )  # fmt: skip
    found = peaks.peaks  # the steps left sampled
    assert np.isfinite(run[1]).all() and np.isfinite(run[2]).all()
    assert finite and all(finite)
    assert np.isfinite(found.tip_deflection.value).all()
    assert np.isfinite(found.root_moment.value).all()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda m: m.load_vector(10.0, pressures=[1.0, 2.0]), "pressures must be a scalar or 4"),
        (lambda m: m.load_vector(10.0, tip_forces=math.nan), "tip_forces must be finite"),
        (lambda m: m.load_vector(10.0, tip_forces="x"), "tip_forces must be a scalar or 4"),
        (lambda m: m.root_moments(np.zeros(3), 10.0), "q must have 40 values"),
        (lambda m: m.input_matrix(-1.0), "lengths must be > 0"),
        (
            lambda m: m.simulate(StaticProfile(10.0), 1.0, loads=(1.0, 2.0, 3.0, 4.0)),
            "loads must be None, a pair",
        ),
        (  # a triple carries a hub wrench (docs/model.md §13.8), which a clamped hub refuses
            lambda m: m.simulate(StaticProfile(10.0), 1.0, loads=(1.0, 2.0, 3.0)),
            "hub_wrench = 3.0: the hub is clamped (free_hub = False)",
        ),
        (
            lambda m: m.simulate(StaticProfile(10.0), 1.0, loads=lambda t: (math.inf, 0.0)),
            "pressures must be finite",
        ),
        (
            lambda m: SailParameters(mass_damping=-1.0),
            "mass_damping must be in [0, 1e+06] 1/s, got -1",
        ),
        (
            lambda m: SailParameters(stiffness_damping=math.nan),
            "stiffness_damping must be finite",
        ),
    ],
    ids=lambda value: value if isinstance(value, str) else "call",
)
def test_load_and_damping_errors_name_the_argument(call, message):
    model = SailModel(SMALL)
    with pytest.raises(ValueError, match=re.escape(message)):
        call(model)


def test_a_schedules_input_vectors_are_its_values_made_once():
    """A `LoadSchedule`'s inputs (`input_function`) are the vectors of its values, made
    when the run starts and shared by every call (read-only); before, at and after each
    switch, those `inputs` makes of what the schedule gives. A subclass with its own
    `__call__` is asked as a plain callable is."""
    schedule = LoadSchedule(
        [(1.0, 2e-5, 0.0), (2.0, None, [0.0, 1e-3, 0.0, 0.0]), (3.0, 0.0, None)]
    )
    for free_hub in (False, True):
        u = input_function(schedule, free_hub)
        assert u.switch_times == (1.0, 2.0, 3.0)
        for t in (0.0, 0.5, 1.0, 1.5, 2.0, 2.9999, 3.0, 7.0):
            expected = inputs(*schedule(t), free_hub=free_hub)
            assert np.array_equal(u(t), expected) and not u(t).flags.writeable, t
        assert u(1.5) is u(1.7)

    class Doubled(LoadSchedule):
        def __call__(self, t):
            pressures, forces = super().__call__(t)
            return 2.0 * pressures, 2.0 * forces

    doubled = input_function(Doubled([(0.0, 1e-5, 0.0)]))
    assert np.array_equal(doubled(1.0), inputs(2e-5, 0.0))


@pytest.mark.parametrize(
    ("change", "why"),
    [
        ({"boom_axial_load": 100.0}, "an axial load at or above buckling"),  # pi^2 EI/(4 L^2)
        ({"membrane_prestress": 0.0}, "membrane_prestress = 0 Pa: the film has no out-of-plane"),
    ],
    ids=["buckled", "slack film"],
)
def test_static_deflection_refuses_a_sail_without_stiffness_and_says_why(change, why):
    with pytest.raises(
        ValueError, match=re.escape(f"not positive definite at these lengths ({why}")
    ):
        SailModel(SailParameters(**change)).static_deflection(20.0, tip_forces=1.0)


@pytest.mark.parametrize("params", [SailParameters(), DAMPED])
def test_at_rest_the_modal_eigenvalues_are_the_general_eigensolvers(params):
    model = SailModel(params)
    lengths = [10.0, 12.5, 15.0, 11.0]
    general = np.linalg.eigvals(model.state_matrix(lengths))
    general = general[np.lexsort((general.real, general.imag))]
    eigenvalues = model.eigenvalues(lengths)
    assert np.allclose(eigenvalues, general, rtol=1e-12, atol=1e-12 * np.abs(general).max())
    if params.mass_damping == params.stiffness_damping == 0.0:
        assert np.all(eigenvalues.real == 0.0)  # undamped: on the imaginary axis exactly


def test_modes_that_the_damping_couples_go_to_the_general_eigensolver():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((6, 6))
    M, K = X @ X.T + 6 * np.eye(6), np.diag(np.arange(1.0, 7.0))
    C = 0.1 * M + 0.01 * K
    proportional = modal_eigenvalues(M, C, K)
    general = np.linalg.eigvals(np.block([[-np.linalg.solve(M, C), -np.linalg.solve(M, K)],
                                          [np.eye(6), np.zeros((6, 6))]]))  # fmt: skip
    assert np.allclose(np.sort_complex(proportional), np.sort_complex(general), rtol=1e-12)
    C[0, 1] = C[1, 0] = 0.05  # no longer diagonal in the modes
    assert modal_eigenvalues(M, C, K) is None
    K[0, 1] = 1e-3  # not symmetric
    assert modal_eigenvalues(M, 0.1 * M, K) is None
