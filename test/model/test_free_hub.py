"""The free hub (docs/model.md §13, checks 14-23), each against an answer computed here:
closed forms, field quadratures of the kinetic energy and the momenta that share
nothing with the matrices, and tight DOP853 integrations of Eq. 2 (rtol 1e-11,
atol 1e-14) on short windows or small mode counts, so that each test takes seconds."""

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from harness import ROOT, SMALL, SMALL_MODES
from scipy.optimize import brentq

from sail_ros import topics
from sail_ros.analysis.modes import modal_analysis
from sail_ros.analysis.plant import frequency_response, linear_plant, poles
from sail_ros.model import (
    BoomMotion,
    CycloidalProfile,
    SailModel,
    SailParameters,
    StaticProfile,
    assembly,
)
from sail_ros.model.assembly import (
    DAMPING,
    GYROSCOPIC,
    GYROSCOPIC_SKEW,
    MASS,
    SPIN_HOLD,
    STIFFNESS,
    STIFFNESS_CANONICAL,
    STIFFNESS_EQ,
)
from sail_ros.model.basis import cantilever_modes, cantilever_roots, triangle_modes
from sail_ros.model.integrals import collapsed_gauss_triangle, gauss_unit_interval
from sail_ros.model.layout import BOOM_DIRECTIONS, BOOMS, QUADRANTS
from sail_ros.model.loads import LoadSchedule

pytestmark = pytest.mark.model

L_FULL = 50.0 * np.sqrt(2.0)
TIGHT = dict(method="DOP853", rtol=1e-11, atol=1e-14)
# check 18: unequal constant lengths, every input (4 pressures [Pa], 4 tip forces [N],
# F_z [N], tau_x, tau_y [N m])
LENGTHS_18 = np.array([14.0, 16.0, 13.0, 15.0])
INPUTS_18 = ([2e-3, -1e-3, 1.5e-3, 0.5e-3], [0.02, -0.01, 0.015, 0.03], [0.3, 0.2, -0.4])
HUB_18 = dict(hub_mass=30.0, hub_inertia_x=25.0, hub_inertia_y=15.0)  # kg, kg m^2


def free(**fields) -> SailParameters:
    return SailParameters(free_hub=True, **{**SMALL_MODES, **fields})


# -- the fields (model.md §13.1-§13.2), independent of the matrices -----------------------------


class Fields:
    """Material points of booms and quadrants on Gauss rules, with the displacement and
    material velocity of Eq. 1 and §3, and the kinetic energy and momenta of §13.2 and
    §13.5 summed over them."""

    def __init__(self, model: SailModel, order: int = 48):
        self.model = model
        nb, nm = model.n_boom_modes, model.n_membrane_modes
        self.s, self.ws = gauss_unit_interval(order)
        self.psi = cantilever_modes(nb, self.s)
        self.dpsi = cantilever_modes(nb, self.s, 1)
        self.xi, self.eta, self.wt = collapsed_gauss_triangle(order)
        phi, phi_xi, phi_eta = triangle_modes(nm, self.xi, self.eta)
        zero = np.zeros((nb, self.xi.size))
        self.S = np.vstack([cantilever_modes(nb, self.xi), cantilever_modes(nb, self.eta), phi])
        self.S_xi = np.vstack([cantilever_modes(nb, self.xi, 1), zero, phi_xi])
        self.S_eta = np.vstack([zero, cantilever_modes(nb, self.eta, 1), phi_eta])

    def points(self, q, qd, lengths, rates):
        """Per component: mass of each point [kg], in-plane position (X, Y) [m] and
        velocity (Xd, Yd) [m/s], deflection w [m] and its material rate Dw/Dt [m/s]."""
        model, p = self.model, self.model.params
        for k, boom in enumerate(BOOMS):
            e, L, Ld = BOOM_DIRECTIONS[k], lengths[k], rates[k]
            p_k, pd_k = q[model.boom_slice(boom)], qd[model.boom_slice(boom)]
            w = p_k @ self.psi
            Dw = pd_k @ self.psi + (Ld / L) * (p_k @ ((1.0 - self.s) * self.dpsi))
            velocity = np.tile(Ld * e, (self.s.size, 1))
            yield p.boom_linear_density * L * self.ws, np.outer(self.s * L, e), velocity, w, Dw
        for quadrant in QUADRANTS:
            a, b = quadrant.first, quadrant.second
            slots = model.layout.quadrant_slots(quadrant)
            e_a, e_b = BOOM_DIRECTIONS[a], BOOM_DIRECTIONS[b]
            position = np.outer(self.xi * lengths[a], e_a) + np.outer(self.eta * lengths[b], e_b)
            w = q[slots] @ self.S
            Dw = (
                qd[slots] @ self.S
                + (rates[a] / lengths[a]) * (q[slots] @ ((1.0 - self.xi) * self.S_xi))
                + (rates[b] / lengths[b]) * (q[slots] @ ((1.0 - self.eta) * self.S_eta))
            )
            velocity = np.tile(rates[a] * e_a + rates[b] * e_b, (self.xi.size, 1))
            mass = p.membrane_areal_density * lengths[a] * lengths[b] * self.wt
            yield mass, position, velocity, w, Dw

    def hub_mass(self, lengths) -> float:
        """m_h(t) [kg]: the hub and, with stowed_mass_on_hub, what is not yet deployed."""
        p = self.model.params
        mass = p.hub_mass
        if p.stowed_mass_on_hub:
            full = p.full_boom_length
            mass += p.boom_linear_density * np.sum(full - lengths)
            mass += (
                0.5
                * p.membrane_areal_density
                * sum(full**2 - lengths[a] * lengths[b] for _, a, b in QUADRANTS)
            )
        return mass

    def _hub(self, q, qd):
        hub = self.model.hub_slice
        return (*q[hub], *qd[hub])

    def kinetic(self, q, qd, lengths, rates) -> float:
        """§13.2's T [J], without the prescribed in-plane 1/2 int (Xd^2 + Yd^2) dm."""
        p = self.model.params
        z, theta_x, theta_y, zd, thd_x, thd_y = self._hub(q, qd)
        T = 0.5 * self.hub_mass(lengths) * zd**2
        T += 0.5 * (p.hub_inertia_x * thd_x**2 + p.hub_inertia_y * thd_y**2)
        for dm, (X, Y), (Xd, Yd), w, Dw in self._points_t(q, qd, lengths, rates):
            U = zd + Y * thd_x - X * thd_y + Dw
            tilt = Yd * theta_x - Xd * theta_y  # c^T theta
            tilt_rate = Yd * thd_x - Xd * thd_y  # c^T thd
            T += np.sum(dm * (0.5 * U**2 + zd * tilt - w * tilt_rate))
        return T

    def kinetic_exact(self, q, qd, lengths, rates) -> float:
        """T with finite rotations, R = R_x(theta_x) R_y(theta_y), body rate
        omega = (thd_x cos theta_y, thd_y, thd_x sin theta_y), less the same in-plane part."""
        p = self.model.params
        z, theta_x, theta_y, zd, thd_x, thd_y = self._hub(q, qd)
        omega = np.array([thd_x * np.cos(theta_y), thd_y, thd_x * np.sin(theta_y)])
        R = _rotation_x(theta_x) @ _rotation_y(theta_y)
        up = R.T @ np.array([0.0, 0.0, 1.0])  # inertial z in the body frame
        T = 0.5 * self.hub_mass(lengths) * zd**2
        T += 0.5 * (p.hub_inertia_x * omega[0] ** 2 + p.hub_inertia_y * omega[1] ** 2)
        for dm, (X, Y), (Xd, Yd), w, Dw in self._points_t(q, qd, lengths, rates):
            rho = np.stack([X, Y, w])
            rho_dot = np.stack([Xd, Yd, Dw])
            turn = np.cross(omega, rho, axis=0)
            relative = turn + rho_dot  # body-frame velocity less the heave
            # |zd e_z + R relative|^2 - (Xd^2 + Yd^2), in-plane speeds O(1) taken out exactly
            square = zd**2 + 2 * zd * (up @ relative) + np.sum(turn**2, axis=0)
            square += 2 * np.sum(turn * rho_dot, axis=0) + Dw**2
            T += 0.5 * np.sum(dm * square)
        return T

    def momenta(self, q, qd, lengths, rates) -> np.ndarray:
        """(p_z, H_x, H_y) of §13.5 from the fields: `V = U + theta_x Yd - theta_y Xd`,
        `W = z_h + Y theta_x - X theta_y + w`."""
        p = self.model.params
        z, theta_x, theta_y, zd, thd_x, thd_y = self._hub(q, qd)
        total = np.array(
            [self.hub_mass(lengths) * zd, p.hub_inertia_x * thd_x, p.hub_inertia_y * thd_y]
        )
        for dm, (X, Y), (Xd, Yd), w, Dw in self._points_t(q, qd, lengths, rates):
            V = zd + Y * thd_x - X * thd_y + Dw + theta_x * Yd - theta_y * Xd
            W = z + Y * theta_x - X * theta_y + w
            total += [np.sum(dm * V), np.sum(dm * (Y * V - W * Yd)), np.sum(dm * (W * Xd - X * V))]
        return total

    def in_plane(self, lengths, rates) -> tuple[np.ndarray, float]:
        """In-plane momentum (P_x, P_y) [kg m/s] and spin momentum H_z [kg m^2/s]."""
        zero = np.zeros(self.model.n)
        P, spin = np.zeros(2), 0.0
        for dm, (X, Y), (Xd, Yd), _, _ in self._points_t(zero, zero, lengths, rates):
            P += [np.sum(dm * Xd), np.sum(dm * Yd)]
            spin += np.sum(dm * (X * Yd - Y * Xd))
        return P, spin

    def _points_t(self, q, qd, lengths, rates):
        for dm, position, velocity, w, Dw in self.points(q, qd, lengths, rates):
            yield dm, position.T, velocity.T, w, Dw


def _rotation_x(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rotation_y(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def motion(profile, t):
    return tuple(np.broadcast_to(np.asarray(v, dtype=float), (4,)).copy() for v in profile(t))


def at_rest(model, lengths, q0, qd0, inputs, times, h=0.05):
    """The stepper at rest, loaded by `inputs` (11,), in steps of exactly `h` [s] (one
    cached propagator), sampled at `times` (multiples of `h`): `(q, qd)`."""
    stepper = model.stepper(StaticProfile(lengths), q0=q0, qd0=qd0, inputs=lambda t: inputs)
    q, qd = [], []
    for count in np.round(np.diff(np.concatenate([[0.0], times])) / h).astype(int):
        for _ in range(count):
            stepper.step(h)
        q.append(stepper.q)
        qd.append(stepper.qd)
    return np.array(q), np.array(qd)


def equation_2(model, profile, inputs=None, extra=None):
    """`xd` of Eq. 2 as first-order `x = [q; qd]` (independent of the stepper): the model's
    `M`, `C`, `K_eq` and `B_u` at each time, solved densely; `extra(t, q, qd, motion)`
    appends the rates of quadratures carried along."""
    n = model.n

    def rhs(t, x):
        lengths, rates, accelerations = motion(profile, t)
        M, C, K = model.assemble(("M", "C", "K_eq"), lengths, rates, accelerations)
        q, qd = x[:n], x[n : 2 * n]
        force = -C @ qd - K @ q
        if inputs is not None:
            force += model.assemble_inputs(lengths) @ inputs
        parts = [qd, np.linalg.solve(M, force)]
        if extra is not None:
            parts.append(extra(t, q, qd, (lengths, rates, accelerations)))
        return np.concatenate(parts)

    return rhs


# -- parameters, layout, interface ----------------------------------------------------------------


def test_free_hub_parameters_default_to_the_clamped_sail_and_are_checked():
    p = SailParameters()
    assert p.free_hub is False and p.stowed_mass_on_hub is True
    assert (p.hub_mass, p.hub_inertia_x, p.hub_inertia_y) == (100.0, 100.0, 100.0)
    # with the stowed material on the hub the heave's mass M[z, z] is the whole sail's:
    # m_h + 4 rho_B L_f + 2 rho_M L_f^2 (model.md §13.8)
    model = SailModel(free())
    z = model.hub_slice.start
    assert model.mass_and_stiffness(7.0)[0][z, z] == pytest.approx(164.03, abs=5e-3)
    for field in ("free_hub", "stowed_mass_on_hub"):
        with pytest.raises(ValueError, match=f"{field} must be true or false, got 1"):
            SailParameters(**{field: 1})
    with pytest.raises(ValueError, match=r"hub_mass must be in \[0, 1e\+12\] kg, got -1.0"):
        free(hub_mass=-1.0)
    with pytest.raises(ValueError, match="hub_inertia_y must be finite, got nan"):
        free(hub_inertia_y=float("nan"))
    assert SailParameters.from_dict(free(hub_mass=3.0).to_dict()).hub_mass == 3.0


def test_the_simulators_parameters_carry_the_hub_only_when_it_is_free():
    assert not any("hub" in name for name in topics.flat_sail_parameters(SailParameters()))
    sail = free(hub_mass=12.5, stowed_mass_on_hub=False)
    flat = topics.flat_sail_parameters(sail)
    assert flat["sail.free_hub"] is True and flat["sail.hub_mass"] == 12.5
    assert topics.sail_parameters_from_flat(flat) == sail
    recorded = {name: topics.yaml_value(value) for name, value in flat.items()}
    assert topics.sail_parameters_from_record(recorded) == sail


def test_lengths_beyond_the_stowed_material_are_refused_naming_the_boom():
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=1))
    over = [70.0, 70.0, 72.0, 70.0]
    with pytest.raises(ValueError, match=r"lengths: boom c is 72\.0 m, longer than .* 70\.7107 m"):
        model.matrices(over)
    with pytest.raises(ValueError, match="boom c is 72.0 m"):
        model.simulate(StaticProfile(over), 0.1)
    model.matrices(L_FULL)  # the full length itself is allowed
    SailModel(free(n_boom_modes=2, n_membrane_modes=1, stowed_mass_on_hub=False)).matrices(over)


def test_the_hub_is_one_more_group_of_coordinates():
    clamped = SailModel(SailParameters(n_boom_modes=2, n_membrane_modes=3))
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=3))
    assert (model.n, model.n_elastic, model.hub_slice) == (23, 20, slice(20, 23))
    assert (clamped.n, clamped.n_elastic, clamped.hub_slice) == (20, 20, None)
    assert model.coordinate_names == [
        *clamped.coordinate_names,
        "hub_heave",
        "hub_tilt_x",
        "hub_tilt_y",
    ]
    assert model.layout.group_slice("hub") == model.hub_slice
    assert [g.name for g in model.layout.groups][-2:] == ["membrane_da", "hub"]
    assert model.input_names[8:] == ("hub_force_z", "hub_torque_x", "hub_torque_y")
    assert model.output_names[8:] == (
        "hub_heave", "hub_tilt_x", "hub_tilt_y",
        "hub_heave_rate", "hub_tilt_rate_x", "hub_tilt_rate_y",
    )  # fmt: skip
    assert len(clamped.input_names) == 8 and len(clamped.output_names) == 8
    A, B, C, D = model.state_space(12.0)
    assert (A.shape, B.shape, C.shape, D.shape) == ((46, 46), (46, 11), (14, 46), (14, 11))
    assert model.input_matrix(12.0).shape == (23, 11)


def test_a_clamped_hub_refuses_a_hub_wrench_and_rigid_motion():
    model = SailModel(SailParameters(n_boom_modes=2, n_membrane_modes=1))
    clamped = r"the hub is clamped \(free_hub = False\)"
    with pytest.raises(ValueError, match=clamped):
        model.rigid_body_acceleration(10.0)
    with pytest.raises(ValueError, match=clamped):
        model.momenta(np.zeros(model.n), np.zeros(model.n), 10.0)
    with pytest.raises(ValueError, match=r"hub_wrench = \[0, 0.1, 0\]: " + clamped):
        model.static_deflection(10.0, hub_wrench=[0, 0.1, 0])
    with pytest.raises(ValueError, match=clamped):
        model.simulate(StaticProfile(10.0), 0.1, loads=(0.0, 0.0, [1.0, 0.0, 0.0]))
    # a zero hub wrench is no wrench
    np.testing.assert_array_equal(
        model.load_vector(10.0, 1e-3, 0.0, [0.0, 0.0, 0.0]), model.load_vector(10.0, 1e-3)
    )
    zero = np.zeros(model.n)
    assert model.sample(0.0, np.full(4, 10.0), np.zeros(4), zero, zero).hub is None


def test_hub_wrench_reaches_the_hub_through_loads_and_the_schedule():
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=2, hub_mass=5.0))
    profile = StaticProfile(12.0)
    schedule = LoadSchedule([(0.0, 1e-3, 0.0), (0.5, None, None, [2.0, 0.0, 0.0])])
    assert len(schedule(0.2)) == 3 and not schedule(0.2)[2].any()
    np.testing.assert_array_equal(schedule(0.7)[2], [2.0, 0.0, 0.0])
    assert len(LoadSchedule([(0.0, 1e-3, 0.0)])(1.0)) == 2  # without a wrench: as before
    t = np.array([0.0, 0.5, 1.0])
    runs = [
        model.simulate(profile, 1.0, t_eval=t, loads=schedule)[1],
        model.simulate(profile, 1.0, t_eval=t, loads=lambda s: schedule(s))[1],
    ]
    # a plain callable's jump is located (to SWITCH_RESOLUTION): the same run to round-off
    np.testing.assert_allclose(runs[0], runs[1], rtol=0, atol=1e-12 * np.abs(runs[0]).max())
    # constant triple: the heave follows F t^2 / (2 M_zz) once the elastic part is at rest
    q = model.simulate(profile, 1.0, t_eval=t, loads=(0.0, 0.0, [2.0, 0.0, 0.0]))[1]
    M, _ = model.mass_and_stiffness(12.0)
    h = model.hub_slice
    a = model.rigid_body_acceleration(12.0, hub_wrench=[2.0, 0.0, 0.0])
    np.testing.assert_allclose(a, np.linalg.solve(M[h, h], [2.0, 0.0, 0.0]), rtol=1e-12)
    assert q[-1, h.start] == pytest.approx(0.5 * a[0], rel=0.05)
    sample = model.sample(1.0, np.full(4, 12.0), np.zeros(4), q[-1], 2 * q[-1])
    np.testing.assert_array_equal(sample.hub, np.concatenate([q[-1, h], 2 * q[-1, h]]))


def test_modal_analysis_and_plant_carry_the_hub():
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=2, mass_damping=0.01))
    modes = modal_analysis(model, 12.0)
    assert np.array_equal(modes.omega[:3], np.zeros(3)) and modes.groups[0] == (0, 3)
    np.testing.assert_allclose(modes.omega, model.natural_frequencies(12.0), rtol=1e-12)
    plant = linear_plant(model, 12.0)
    assert plant.input_names == model.input_names and len(plant.input_units) == 11
    assert plant.output_names == model.output_names and len(plant.output_units) == 14
    assert plant.input_units[8:] == ("N", "N m", "N m")
    assert plant.output_units[8:] == ("m", "rad", "rad", "m/s", "rad/s", "rad/s")
    assert plant.state_names[model.n - 3] == "hub_heave"
    assert [p.omega for p in poles(plant)[:6]] == [0.0] * 6
    # a torque tau_x: the tilt theta_x(s) = tau_x / (s^2 J_x,eff) at low frequency
    w = 1e-3
    response = frequency_response(plant, [w])[0]
    tilt = response[model.output_names.index("hub_tilt_x"), model.input_names.index("hub_torque_x")]
    M, _ = model.mass_and_stiffness(12.0)
    J = 1.0 / np.linalg.inv(M[model.hub_slice, model.hub_slice])[1, 1]
    assert (-(w**2) * tilt).real == pytest.approx(1.0 / J, rel=1e-3)


def test_hold_loads_are_the_rates_of_the_in_plane_and_spin_momenta():
    """§13.3: (F_x, F_y) = dP/dt and tau_z = dH_z/dt, against central differences of the
    field sums along the motion; zero when the motion is point-symmetric."""
    model = SailModel(free(n_boom_modes=1, n_membrane_modes=1))
    fields = Fields(model, order=24)
    L, Ld, Ldd = (
        np.array([10.0, 12.0, 9.0, 13.0]),
        np.array([0.3, -0.2, 0.5, 0.1]),
        np.array([0.02, 0.01, -0.03, 0.04]),
    )
    h = 1e-4

    def at(t):
        return fields.in_plane(L + Ld * t + 0.5 * Ldd * t**2, Ld + Ldd * t)

    (P1, H1), (P0, H0) = at(h), at(-h)
    expected = np.array([*(P1 - P0), H1 - H0]) / (2 * h)
    loads = model.hold_loads(L, Ld, Ldd)
    np.testing.assert_allclose(loads, expected, rtol=1e-7, atol=1e-12 * np.abs(expected).max())
    symmetric = model.hold_loads([10.0, 12.0, 10.0, 12.0], [0.3, 0.1, 0.3, 0.1], [0.02, 0, 0.02, 0])
    assert np.abs(symmetric).max() < 1e-15


# -- checks 14-16: frequencies ---------------------------------------------------------------------


def test_check_14_a_heavy_hub_tends_to_the_clamped_sail_like_one_over_j():
    clamped = SailModel(SMALL).natural_frequencies(L_FULL)

    def deviation(heavy):
        hub = dict(hub_mass=heavy, hub_inertia_x=heavy, hub_inertia_y=heavy)
        omega = SailModel(free(stowed_mass_on_hub=False, **hub)).natural_frequencies(L_FULL)
        assert np.array_equal(omega[:3], np.zeros(3))
        return np.max(np.abs(omega[3:] / clamped - 1.0))

    d8, d12 = deviation(1e8), deviation(1e12)
    assert d8 < 1e-3  # model.md: 2.6e-4
    assert 0.5e-4 < d12 / d8 < 2e-4  # 1/J: 2.6e-8


def test_check_15_three_rigid_modes_and_interlacing_elastic_ones():
    model = SailModel(free())
    omega = model.natural_frequencies(L_FULL)
    clamped = SailModel(SMALL).natural_frequencies(L_FULL)
    assert np.array_equal(omega[:3], np.zeros(3))
    elastic = omega[3:]
    # the full problem K v = omega^2 M v has them too (and three near-zero values)
    M, K = model.mass_and_stiffness(L_FULL)
    full = scipy.linalg.eigh(K, M, eigvals_only=True)
    assert np.abs(full[:3]).max() < 1e-10 * elastic[0] ** 2
    np.testing.assert_allclose(np.sqrt(full[3:]), elastic, rtol=1e-10)
    # M_r,qq <= M_qq, rank 3: omega_c,i <= omega_f,i <= omega_c,i+3
    assert np.all(clamped <= elastic * (1 + 1e-12))
    assert np.all(elastic[:-3] <= clamped[3:] * (1 + 1e-12))
    np.testing.assert_array_equal(
        np.round(elastic[:6], 5), [0.13891, 0.14391, 0.21807, 0.23386, 0.23386, 0.24813]
    )
    np.testing.assert_array_equal(
        np.round(clamped[:7], 5), [0.11628, 0.12742, 0.12742, 0.14391, 0.21807, 0.23478, 0.23478]
    )
    # the modes that put no net force or moment on the hub do not move
    np.testing.assert_allclose(elastic[[1, 2]], clamped[[3, 4]], rtol=1e-10)
    # the lifted modes are M-orthonormal, the rigid ones included
    lam, V = model.normal_modes(L_FULL)
    np.testing.assert_allclose(V.T @ M @ V, np.eye(model.n), atol=1e-10)
    np.testing.assert_allclose(K @ V, M @ V * lam, atol=1e-10 * np.abs(K).max())


@pytest.mark.parametrize("n_boom_modes", [4, 8])
def test_check_16_booms_on_a_massless_hub_are_clamped_guided_and_pinned(n_boom_modes):
    """Booms alone on a massless hub: each cantilever index splits into clamped-free (x1),
    guided-free (hub heaves: tan b + tanh b = 0, x1) and pinned-free (hub tilts:
    tan b = tanh b, x2), in units sqrt(EI / rho_B) / L^2, approached from above."""
    params = free(n_boom_modes=n_boom_modes, n_membrane_modes=1, membrane_density=0.0,
                  membrane_prestress=0.0, hub_mass=0.0, hub_inertia_x=0.0, hub_inertia_y=0.0,
                  stowed_mass_on_hub=False)  # fmt: skip
    model = SailModel(params)
    L = 10.0
    M, K = model.mass_and_stiffness(L)
    # the membranes carry neither mass nor stiffness: the booms and the hub only (§13.6)
    keep = np.r_[0 : 4 * n_boom_modes, model.hub_slice]
    M, K = M[np.ix_(keep, keep)], K[np.ix_(keep, keep)]
    e, h = slice(0, 4 * n_boom_modes), slice(4 * n_boom_modes, None)
    reduced = M[e, e] - M[e, h] @ np.linalg.solve(M[h, h], M[h, e])
    unit = np.sqrt(params.boom_bending_stiffness / params.boom_linear_density) / L**2
    omega = np.sqrt(scipy.linalg.eigh(K[e, e], reduced, eigvals_only=True)) / unit
    clamped_free = cantilever_roots(1)[0] ** 2
    guided_free = brentq(lambda b: np.sin(b) + np.cos(b) * np.tanh(b), 2.0, 3.0) ** 2
    pinned_free = brentq(lambda b: np.sin(b) - np.cos(b) * np.tanh(b), 3.5, 4.5) ** 2
    assert guided_free == pytest.approx(5.59332, abs=5e-6)
    assert pinned_free == pytest.approx(15.41821, abs=5e-6)
    assert omega[0] == pytest.approx(clamped_free, rel=1e-10)  # the hub does not move
    errors = np.array([omega[1] / guided_free, omega[2] / pinned_free, omega[3] / pinned_free]) - 1
    assert np.all(errors > 0)  # Rayleigh-Ritz: from above
    bound = {4: (3e-5, 2e-5), 8: (1e-6, 3e-7)}[n_boom_modes]  # model.md: 2e-5, 1e-5; 6e-7, 1e-7
    assert errors[0] < bound[0] and errors[1:].max() < bound[1]
    assert errors[2] == pytest.approx(errors[1], rel=1e-6)  # a double pair (x2)


# -- check 17: momenta during deployment ----------------------------------------------------------


@pytest.mark.parametrize("stowed", [True, False], ids=["stowed", "not stowed"])
def test_check_17_momenta_are_conserved_during_deployment(stowed):
    """Seed deployment (cycloid 10 -> 15 m in 15 s, to 18 s), booms a and b bent (0.1,
    -0.05 m), a film mode at 0.02 m, hub 20 kg and 10 kg m^2, (2, 3) modes: p_z, H_x, H_y
    from the fields stay constant to 1e-9 of the hub's momenta, along the stepper's run and
    along a DOP853 integration of Eq. 2 (its Md, Gd, S_h) over 2.75-4.75 s (the largest
    accelerations); the stepper follows DOP853 within 2e-3 of each output's peak."""
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=3, hub_mass=20.0, hub_inertia_x=10.0,
                           hub_inertia_y=10.0, stowed_mass_on_hub=stowed))  # fmt: skip
    fields = Fields(model, order=32)
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    q0 = model.initial_coordinates([0.1, -0.05, 0.0, 0.0])
    q0[model.membrane_slice("ab").start] = 0.02
    times = np.linspace(0.0, 18.0, 73)  # every 0.25 s
    t, q, qd = model.simulate(profile, 18.0, q0=q0, t_eval=times)
    h = model.hub_slice
    p = model.params

    def momenta(q, qd, t):
        lengths, rates, _ = motion(profile, t)
        return fields.momenta(q, qd, lengths, rates)

    hub_mass = np.array([fields.hub_mass(motion(profile, s)[0]) for s in t])
    scale = max(
        np.abs(hub_mass * qd[:, h.start]).max(),
        p.hub_inertia_x * np.abs(qd[:, h.start + 1]).max(),
        p.hub_inertia_y * np.abs(qd[:, h.start + 2]).max(),
    )
    assert scale > 0.1  # kg m/s: the hub does move
    along_stepper = np.array([momenta(*state) for state in zip(q, qd, t, strict=True)])
    assert np.abs(along_stepper - along_stepper[0]).max() < 1e-9 * scale

    # Eq. 2 itself, from the stepper's state at 2.75 s
    start, window = 11, slice(11, 20)  # t = 2.75 ... 4.75 s
    n = model.n
    solution = scipy.integrate.solve_ivp(
        equation_2(model, profile),
        (t[start], t[window][-1]),
        np.concatenate([q[start], qd[start]]),
        t_eval=t[window],
        **TIGHT,
    )
    assert solution.success
    exact_q, exact_qd = solution.y[:n].T, solution.y[n:].T
    along_exact = np.array([momenta(*s) for s in zip(exact_q, exact_qd, t[window], strict=True)])
    assert np.abs(along_exact - along_stepper[0]).max() < 1e-9 * scale
    # matrix form = field form
    for i in (0, 4, 8):
        lengths, rates, _ = motion(profile, t[window][i])
        np.testing.assert_allclose(
            model.momenta(exact_q[i], exact_qd[i], lengths, rates),
            along_exact[i],
            rtol=0,
            atol=1e-12 * scale,
        )
    outputs = np.hstack([model.tip_deflections(exact_q), exact_q[:, h]])
    stepped = np.hstack([model.tip_deflections(q[window]), q[window][:, h]])
    peaks = np.abs(np.hstack([model.tip_deflections(q), q[:, h]])).max(axis=0)
    assert np.all(np.abs(stepped - outputs).max(axis=0) <= 2e-3 * peaks)


def test_samples_between_moving_steps_follow_the_hub():
    """The simulator's sampling (0.05 s moving steps, samples every 0.01 s from each step's
    continuous extension) on a free hub against DOP853 on Eq. 2: tips and the hub's heave
    and tilts within 2e-3 of their peaks (measured 2.4e-4); their rates within 1e-2
    (measured 5.2e-3 for thd_y, 2.4e-3 for tip rates: the extension's velocity, as for
    the clamped sail's tip rates in docs/model.md §11)."""
    model = SailModel(free(n_boom_modes=2, n_membrane_modes=2, hub_mass=20.0, hub_inertia_x=10.0))
    profile = CycloidalProfile([10.0, 11.0, 10.0, 12.0], [13.0, 12.0, 14.0, 13.0], 4.0)
    q0 = model.initial_coordinates([0.1, -0.05, 0.0, 0.02])
    n, h = model.n, model.hub_slice
    t, q, qd = model.simulate_on_grid(profile, 4.0, 0.01, q0=q0)
    solution = scipy.integrate.solve_ivp(
        equation_2(model, profile), (0.0, 4.0), np.concatenate([q0, np.zeros(n)]), t_eval=t, **TIGHT
    )
    exact_q, exact_qd = solution.y[:n].T, solution.y[n:].T
    for sampled, exact, bound in ((q, exact_q, 2e-3), (qd, exact_qd, 1e-2)):
        reference = np.hstack([model.tip_deflections(exact), exact[:, h]])
        outputs = np.hstack([model.tip_deflections(sampled), sampled[:, h]])
        peaks = np.abs(reference).max(axis=0)
        assert np.all(peaks > 0)
        assert np.all(np.abs(outputs - reference).max(axis=0) <= bound * peaks)


# -- checks 18-21: loads, holds, inertia relief, damping -------------------------------------------


def test_check_18_work_and_momentum_balance_at_constant_lengths():
    """Unequal constant lengths, hub 30 kg, 25 and 15 kg m^2, all 11 inputs, alpha 0.02
    1/s, beta 0.01 s, 20 s: E(t) - E(0) = int (qd^T B_u u - qd^T C_d qd) dt to 1e-9 of the
    work, and p_z, H change by (B_u u)_h t to 1e-9, along DOP853 and along the stepper
    (the exact step: rigid modes accelerate, the others about their equilibrium)."""
    params = free(
        n_boom_modes=3, n_membrane_modes=4, mass_damping=0.02, stiffness_damping=0.01, **HUB_18
    )
    model = SailModel(params)
    n, L = model.n, LENGTHS_18
    u = np.concatenate([np.asarray(v, dtype=float) for v in INPUTS_18])
    C_d = model.structural_damping(L)
    Q = model.input_matrix(L) @ u
    q0 = model.initial_coordinates([0.1, -0.05, 0.02, 0.0])

    A, B, _, _ = model.state_space(L)
    force = B @ u

    def rhs(t, x):  # Eq. 2 at constant lengths, with the work done carried along
        qd = x[n : 2 * n]
        return np.concatenate([A @ x[:-1] + force, [qd @ Q - qd @ C_d @ qd]])

    times = np.linspace(0.0, 20.0, 21)
    solution = scipy.integrate.solve_ivp(
        rhs, (0.0, 20.0), np.concatenate([q0, np.zeros(n), [0.0]]), t_eval=times, **TIGHT
    )
    q, qd, done = solution.y[:n].T, solution.y[n : 2 * n].T, solution.y[-1]
    energy = np.array([model.energy(a, b, L) for a, b in zip(q, qd, strict=True)])
    assert np.abs(done).max() > 0.1  # J
    assert np.abs(energy - energy[0] - done).max() < 1e-9 * np.abs(done).max()
    expected = Q[model.hub_slice][None, :] * times[:, None]
    stepped = at_rest(model, L, q0, np.zeros(n), u, times)
    for run_q, run_qd in ((q, qd), stepped):
        momenta = np.array([model.momenta(a, b, L) for a, b in zip(run_q, run_qd, strict=True)])
        assert np.abs(momenta - momenta[0] - expected).max() < 1e-9 * np.abs(expected).max()
    # the stepper's exact step and DOP853 agree
    assert np.abs(stepped[0] - q).max() <= 1e-9 * np.abs(q).max()


def test_check_19_hold_moments_balance_the_angular_momentum(monkeypatch):
    """Unequal deployment (cycloids 10, 12, 9, 13 -> 16, 15, 17, 14 m in 12 s), hub 25
    kg, 12 and 18 kg m^2, initial tilt rates 0.01, -0.005 rad/s, (1, 3) modes, DOP853 on
    Eq. 2: p_z constant and H(t) - H(0) equal to the integral of the hold moments
    (-z_h Pd_y + theta_y Hd_z, z_h Pd_x - theta_x Hd_z) to 1e-9 of max |H| (measured
    3e-15); without the spin hold's S_h the balance fails (by 1.3e-4 of max |H|)."""
    hub = dict(hub_mass=25.0, hub_inertia_x=12.0, hub_inertia_y=18.0)
    model = SailModel(free(n_boom_modes=1, n_membrane_modes=3, **hub))
    fields = Fields(model, order=24)
    n, h = model.n, model.hub_slice
    profile = CycloidalProfile([10.0, 12.0, 9.0, 13.0], [16.0, 15.0, 17.0, 14.0], 12.0)
    qd0 = np.zeros(n)
    qd0[h.start + 1 : h.stop] = [0.01, -0.005]

    def hold_moments(t, q, qd, state):
        force_x, force_y, torque = model.hold_loads(*state)
        z, theta_x, theta_y = q[h]
        return np.array([-z * force_y + theta_y * torque, z * force_x - theta_x * torque])

    times = np.linspace(0.0, 12.0, 25)

    def balance(model):
        """(momenta from the fields (k, 3), the hold moments' integral (k, 2), q, qd)."""
        solution = scipy.integrate.solve_ivp(
            equation_2(model, profile, extra=hold_moments),
            (0.0, 12.0),
            np.concatenate([np.zeros(n), qd0, [0.0, 0.0]]),
            t_eval=times,
            **TIGHT,
        )
        q, qd, moments = solution.y[:n].T, solution.y[n : 2 * n].T, solution.y[2 * n :].T
        momenta = np.array(
            [
                fields.momenta(a, b, *motion(profile, t)[:2])
                for a, b, t in zip(q, qd, times, strict=True)
            ]
        )
        return momenta, moments, q, qd

    momenta, moments, q, qd = balance(model)
    scale = np.abs(momenta[:, 1:]).max()
    assert np.abs(moments).max() > 1e-4 * scale  # the holds do act
    assert np.abs(momenta[:, 0] - momenta[0, 0]).max() < 1e-9 * scale
    assert np.abs(momenta[:, 1:] - momenta[0, 1:] - moments).max() < 1e-9 * scale
    for i in (5, 12, 20):  # matrix form = field form
        lengths, rates, _ = motion(profile, times[i])
        np.testing.assert_allclose(
            model.momenta(q[i], qd[i], lengths, rates), momenta[i], rtol=0, atol=1e-12 * scale
        )
    spin_hold = [t for t in assembly.QUADRANT_HUB_TERMS if t.integral == "spin"]
    assert len(spin_hold) == 1
    monkeypatch.setattr(
        assembly,
        "QUADRANT_HUB_TERMS",
        tuple(t for t in assembly.QUADRANT_HUB_TERMS if t.integral != "spin"),
    )
    momenta, moments, _, _ = balance(SailModel(free(n_boom_modes=1, n_membrane_modes=3, **hub)))
    assert np.abs(momenta[:, 1:] - momenta[0, 1:] - moments).max() > 1e-5 * scale


def test_check_20_inertia_relief_is_where_damped_motion_settles():
    """Constant loads (as in check 18), alpha 0.3 1/s, beta 0.05 s: after 200 s the
    deflection is q_s and the hub accelerates at a (to 1e-9); the plant's elastic outputs
    at s = i 1e-5 rad/s equal q_s's tips and root moments (to 1e-9; their imaginary part
    is O(s))."""
    model = SailModel(
        free(n_boom_modes=3, n_membrane_modes=4, mass_damping=0.3, stiffness_damping=0.05, **HUB_18)
    )
    L, h, e = LENGTHS_18, model.hub_slice, slice(0, model.n_elastic)
    q_s = model.static_deflection(L, *INPUTS_18)
    a = model.rigid_body_acceleration(L, *INPUTS_18)
    assert np.array_equal(q_s[h], np.zeros(3))
    u = np.concatenate([np.asarray(v, float) for v in INPUTS_18])
    q0 = model.initial_coordinates(0.05)
    q, qd = at_rest(model, L, q0, np.zeros(model.n), u, np.array([199.0, 200.0]))
    np.testing.assert_allclose(q[1, e], q_s[e], rtol=0, atol=1e-9 * np.abs(q_s).max())
    # (an acceleration from the residual of Eq. 2 would carry the round-off of qd = M^-1 p
    # with |p| ~ 50 kg m/s by then: 1e-8 of a)
    np.testing.assert_allclose(qd[1, h] - qd[0, h], a, rtol=0, atol=1e-9 * np.abs(a).max())
    # and the plant's low-frequency response
    A, B, C_out, _ = model.state_space(L)
    s = 1e-5j
    response = C_out @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B @ u)
    static = np.concatenate([model.tip_deflections(q_s), model.root_moments(q_s, L)])
    np.testing.assert_allclose(response[:8].real, static, rtol=0, atol=1e-9 * np.abs(static).max())
    # the hub outputs hold double integrators: s^2 z_h(s) -> a
    np.testing.assert_allclose((s**2 * response[8:11]).real, a, rtol=1e-6)


def test_check_21_damped_eigenvalues_are_six_zeros_and_the_elastic_pairs():
    model = SailModel(free(mass_damping=0.02, stiffness_damping=0.005))
    L = LENGTHS_18
    omega = model.natural_frequencies(L)[3:]
    zeta = 0.02 / (2 * omega) + 0.005 * omega / 2
    assert zeta.max() < 1.0
    root = omega * np.sqrt(1 - zeta**2)
    expected = np.concatenate([-zeta * omega + 1j * root, -zeta * omega - 1j * root])
    A = model.state_space(L)[0]
    for eigenvalues in (model.eigenvalues(L), np.linalg.eigvals(A)):
        order = np.argsort(np.abs(eigenvalues))
        assert np.array_equal(eigenvalues[order[:6]], np.zeros(6))
        rest = eigenvalues[order[6:]]
        for value in expected:
            assert np.abs(rest - value).min() <= 1e-9 * abs(value)


# -- check 22: structure ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def moving():
    params = free(n_boom_modes=3, n_membrane_modes=4, boom_axial_load=0.2, **HUB_18)
    model = SailModel(params)
    L = np.array([31.0, 44.0, 37.5, 52.0])
    Ld = np.array([0.7, -0.4, 0.15, 0.9])
    Ldd = np.array([0.02, 0.01, -0.02, 0.03])
    return model, L, Ld, Ldd


def test_stability_leaves_out_the_six_rigid_eigenvalues_while_booms_move():
    """Default sail and hub at 15 m (model.md §13.6, §13.10): deploying at 0.5 m/s the
    elastic modes' max Re is +0.0146 1/s (clamped -0.0175), the rigid ones are the six
    smallest in modulus and at most 0; retracting at 0.1 m/s the rigid pair grows at
    +0.0159 1/s (the hub's mass shrinks), above every elastic mode (+0.0067): the
    stability studies judge the elastic ones. At rest they are stable."""
    from sail_ros.analysis.stability import growth
    from sail_ros.model.linear import without_rigid

    params = SailParameters(free_hub=True, **SMALL_MODES)
    model = SailModel(params)
    prestress = params.membrane_prestress
    deploying = model.eigenvalues(15.0, 0.5)
    rigid = deploying[np.argsort(np.abs(deploying))[:6]]
    assert (
        np.abs(rigid).max()
        < 0.1
        < np.abs(np.delete(deploying, np.argsort(np.abs(deploying))[:6])).min()
    )
    assert growth(params, 15.0, 0.5, prestress)[0] == pytest.approx(0.01459, abs=5e-5)
    assert growth(params.replace(free_hub=False), 15.0, 0.5, prestress)[0] == pytest.approx(
        -0.01748, abs=5e-5
    )
    retracting = model.eigenvalues(15.0, -0.1)
    assert retracting.real.max() == pytest.approx(0.01585, abs=5e-5)  # a rigid pair
    elastic = model.elastic_eigenvalues(15.0, -0.1)
    assert elastic.size == retracting.size - 6
    assert elastic.real.max() == pytest.approx(0.00667, abs=5e-5)
    assert growth(params, 15.0, -0.1, prestress)[0] == pytest.approx(elastic.real.max(), rel=1e-6)
    max_real, max_abs = growth(params, 15.0, 0.0, prestress)
    assert max_real < 1e-9 * max_abs
    clamped = SailModel(params.replace(free_hub=False)).eigenvalues(15.0, 0.5)
    assert np.array_equal(without_rigid(clamped, False), clamped)


def test_check_22_structure_of_the_matrices(moving):
    model, L, Ld, Ldd = moving
    h = model.hub_slice
    M, C, K_eq = model.matrices(L, Ld, Ldd)
    K, G, skew, spin, K_canonical = model.evaluate(
        (STIFFNESS, GYROSCOPIC, GYROSCOPIC_SKEW, SPIN_HOLD, STIFFNESS_CANONICAL), L, Ld, Ldd
    )
    np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-14 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-14 * np.abs(K).max())
    assert not K[h].any() and not K[:, h].any()  # exact zeros, not cancellations
    np.testing.assert_array_equal(skew, -skew.T)
    np.testing.assert_array_equal(spin, -spin.T)
    _, spin_momentum = Fields(model, order=24).in_plane(L, Ld)
    expected = np.zeros_like(spin)
    expected[h.start + 1, h.start + 2], expected[h.start + 2, h.start + 1] = (
        spin_momentum,
        -spin_momentum,
    )
    np.testing.assert_allclose(spin, expected, rtol=0, atol=1e-12 * abs(spin_momentum))
    # Md and Gd are the time derivatives of M and G along the motion
    step = 1e-5

    def along(t):
        return L + Ld * t + 0.5 * Ldd * t**2, Ld + Ldd * t, Ldd

    M1, G1 = model.evaluate((MASS, GYROSCOPIC), *along(step))
    M0, G0 = model.evaluate((MASS, GYROSCOPIC), *along(-step))
    Md = C - skew - spin  # no damping here
    np.testing.assert_allclose(Md, (M1 - M0) / (2 * step), rtol=0, atol=1e-8 * np.abs(Md).max())
    Gd = K_eq - K_canonical
    np.testing.assert_allclose(Gd, (G1 - G0) / (2 * step), rtol=0, atol=1e-8 * np.abs(Gd).max())
    np.testing.assert_allclose(model.evaluate((DAMPING,), L, Ld, Ldd)[0], C, atol=1e-15)
    np.testing.assert_allclose(model.evaluate((STIFFNESS_EQ,), L, Ld, Ldd)[0], K_eq, atol=1e-15)


def test_check_22_kinetic_energy_from_fields_and_against_finite_rotations(moving):
    """`1/2 qd^T M qd + qd^T G q + 1/2 q^T N q` = §13.2's T from the fields (1e-12); against
    exact finite-rotation kinematics T differs by H_z thd_x theta_y, up to third order."""
    model, L, Ld, _ = moving
    fields = Fields(model)
    rng = np.random.default_rng(5)
    q, qd = rng.normal(size=model.n), rng.normal(size=model.n)
    q[model.hub_slice] *= 0.05
    qd[model.hub_slice] *= 0.05
    M, G, K, K_canonical = model.evaluate(
        (MASS, GYROSCOPIC, STIFFNESS, STIFFNESS_CANONICAL), L, Ld, 0.0
    )
    N = K - K_canonical

    def quadratic(q, qd):
        return 0.5 * qd @ M @ qd + qd @ G @ q + 0.5 * q @ N @ q

    T = quadratic(q, qd)
    assert fields.kinetic(q, qd, L, Ld) == pytest.approx(T, rel=1e-12)
    _, spin = fields.in_plane(L, Ld)
    theta_y, thd_x = q[model.hub_slice][2], qd[model.hub_slice][1]
    held = spin * thd_x * theta_y
    assert abs(held) > 1e-4 * abs(T)  # the held spin's term is there to see
    residual = []
    for scale in (1e-2, 1e-3):  # every small quantity times `scale`, in-plane speeds O(1)
        exact = fields.kinetic_exact(scale * q, scale * qd, L, Ld)
        residual.append(abs(exact / scale**2 - (T + held)))
    assert residual[1] < 1e-8 * abs(T)  # measured 3e-9
    assert residual[1] < 0.1 * residual[0]  # of higher order: it falls with the amplitude


# -- the time step: exact at rest with the rigid modes ----------------------------------------


def test_exact_step_at_rest_carries_rigid_modes_under_a_load():
    """At rest the step is exact with the rigid modes too: from a bent state with a
    constant load and damping, after 7 s, the state equals the matrix exponential of
    the first-order system (with the load as an extra state) to 1e-9."""
    model = SailModel(
        free(n_boom_modes=3, n_membrane_modes=3, mass_damping=0.05, stiffness_damping=0.002)
    )
    n, L = model.n, LENGTHS_18
    q0 = model.initial_coordinates([0.1, 0.0, -0.03, 0.02])
    qd0 = np.zeros(n)
    qd0[model.hub_slice] = [0.01, -0.002, 0.003]
    u = np.concatenate([np.asarray(v, float) for v in INPUTS_18])
    (q,), (qd,) = at_rest(model, L, q0, qd0, u, np.array([7.0]))
    A, B, _, _ = model.state_space(L)
    augmented = np.zeros((2 * n + 1, 2 * n + 1))
    augmented[: 2 * n, : 2 * n] = A
    augmented[: 2 * n, -1] = B @ u
    x = scipy.linalg.expm(7.0 * augmented) @ np.concatenate([q0, qd0, [1.0]])
    scale = np.abs(x[:n]).max()
    np.testing.assert_allclose(q, x[:n], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(qd, x[n : 2 * n], rtol=0, atol=1e-9 * np.abs(x[n:-1]).max())


# -- check 23: the clamped hub is the code before the free hub, bit for bit ------------------------


BEFORE_FREE_HUB = "821e2348e9"  # main before the free hub merged (assembly as now)


def test_check_23_the_clamped_hub_is_bit_for_bit_the_code_before(tmp_path):
    """Every matrix, frequency, plant, time history (moving, at rest, on the grid, by
    blocks; in the fixed steps that code took) of the clamped sail, from
    `test/model/clamped_reference.py` run on the code before the free hub (`git archive`
    BEFORE_FREE_HUB) and on this tree, each in its own process with one BLAS thread:
    equal to the last bit."""
    if shutil.which("git") is None:
        pytest.skip("git is needed to take the code before the free hub")
    before = tmp_path / "before"
    before.mkdir()
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", BEFORE_FREE_HUB, "sail_ros"],
        capture_output=True,
        check=False,
    )
    if archive.returncode != 0:
        pytest.skip(f"commit {BEFORE_FREE_HUB} not in this clone: {archive.stderr.decode()}")
    subprocess.run(["tar", "-x", "-C", str(before)], input=archive.stdout, check=True)
    results = {}
    for name, tree in (("before", before), ("now", ROOT)):
        out = tmp_path / f"{name}.npz"
        env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
        subprocess.run(
            [sys.executable, str(ROOT / "test" / "model" / "clamped_reference.py"), str(out)],
            env=env,
            cwd=tmp_path,
            check=True,
        )
        results[name] = np.load(out)
    old, new = results["before"], results["now"]
    assert str(old["source"]).startswith(str(before)) and str(new["source"]).startswith(str(ROOT))
    assert sorted(old.files) == sorted(new.files) and len(old.files) > 70
    differing = [
        key
        for key in old.files
        if key != "source"
        and not (old[key].shape == new[key].shape and np.array_equal(old[key], new[key]))
    ]
    assert differing == []


def point_symmetric_run(params, duration=6.0):
    """A free sail without loads or damping, booms a and c deploying alike and b and d
    alike, later and slower; booms a and b bent, the hub moving: `(model, run, profile)`."""
    model = SailModel(params)
    profile = BoomMotion([
        CycloidalProfile(10.0, 12.0, 6.0), CycloidalProfile(10.0, 11.5, 4.0, t0=1.0),
        CycloidalProfile(10.0, 12.0, 6.0), CycloidalProfile(10.0, 11.5, 4.0, t0=1.0),
    ])  # fmt: skip
    q0 = model.initial_coordinates([0.1, -0.05, 0.0, 0.0])
    qd0 = np.zeros(model.n)
    qd0[model.hub_slice] = [0.001, 0.002, -0.001]
    t = np.linspace(0.0, duration, 61)
    return model, model.simulate(profile, duration, q0=q0, qd0=qd0, t_eval=t), profile


def momenta_drift(model, run, profile) -> np.ndarray:
    """The largest change of `(p_z, H_x, H_y)` over the run's outputs, over its peak."""
    t, q, qd = run
    momenta = np.array([model.momenta(q[i], qd[i], *profile(t[i])[:2]) for i in range(t.size)])
    return np.abs(momenta - momenta[0]).max(axis=0) / np.abs(momenta).max(axis=0)


def test_the_momenta_hold_at_the_default_tolerance_inside_and_between_steps():
    """At the default tolerance the high modes are followed in their frozen modes, which
    know nothing of the gyroscopic coupling that carries momentum to the hub while the
    booms move: the hub's canonical momenta are kept as the rational step leaves them
    (`moving._replaced`), at the steps' ends and at the outputs inside them, so `p_z`,
    `H_x`, `H_y` stay constant to 1e-9 of their peak."""
    model, run, profile = point_symmetric_run(free(hub_mass=20.0, hub_inertia_x=10.0,
                                                   hub_inertia_y=10.0))  # fmt: skip
    assert run.steps < 0.5 * run[0].size * 10  # steps of several outputs
    assert (momenta_drift(model, run, profile) < 1e-9).all(), momenta_drift(model, run, profile)


@pytest.mark.slow
def test_the_momenta_hold_at_the_default_mode_counts():
    """The same at the default (converged) mode counts."""
    params = SailParameters(free_hub=True, hub_mass=20.0, hub_inertia_x=10.0, hub_inertia_y=10.0)
    model, run, profile = point_symmetric_run(params, duration=14.0)
    assert (momenta_drift(model, run, profile) < 1e-9).all(), momenta_drift(model, run, profile)
