"""The hub's controller without ROS (docs/control.md): sampling with the loop delay against
closed forms, the LQR against the continuous one, the schedule, the gains file, the loop's
saturation and anti-windup, the watchdog, and the stability check against the full plant
(the reference free-hub scenario, at explicit mode counts)."""

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg
from harness import CONFIG

from sail_ros.analysis.scenario import load_scenario
from sail_ros.control import agreement
from sail_ros.control.check import NEUTRAL, check_deployment, loop_matrix, plant_outputs
from sail_ros.control.design import (
    HUB_WRENCH,
    design_model,
    design_point,
    design_sail,
    sampled,
)
from sail_ros.control.loop import DiscreteController, StaleWatch
from sail_ros.control.schedule import GainSchedule, design_schedule
from sail_ros.control.settings import DesignSettings
from sail_ros.model import SailModel, SailParameters
from sail_ros.policy import Policy

pytestmark = pytest.mark.model

FREE = SailParameters(free_hub=True, n_boom_modes=4, n_membrane_modes=6)
DOUBLE_INTEGRATOR = (np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]))


@pytest.mark.parametrize("delay_periods", [0.0, 0.3, 1.0, 1.7, 3.0])
def test_sampling_with_delay_is_the_exact_response_of_a_double_integrator(delay_periods):
    """`x = (theta, omega)` under a unit-inertia torque held over each period and acting
    `delay` later: the sampled system's response to a command sequence equals the
    continuous solution, piecewise quadratic, computed here."""
    A, B = DOUBLE_INTEGRATOR
    period = 0.1
    delay = delay_periods * period
    s = sampled(A, B, np.zeros((2, 0)), period, delay)
    commands = np.array([0.3, -1.0, 0.5, 2.0, 0.0, -0.7, 1.1, 0.4])
    xi = np.zeros(s.F.shape[0])
    for u in commands:
        xi = s.F @ xi + s.G @ [u]

    def torque(t):  # u_k acts over [k T + delay, (k + 1) T + delay)
        k = math.floor((t - delay) / period + 1e-12)
        return commands[k] if 0 <= k < commands.size else 0.0

    # exact: integrate the piecewise-constant torque, breaking at every switch
    t_end = commands.size * period
    switches = sorted({0.0, t_end, *(k * period + delay for k in range(commands.size))})
    theta = omega = 0.0
    for a, b in zip(switches, switches[1:], strict=False):
        if b > t_end:
            b = t_end
        if b <= a:
            continue
        u, h = torque(0.5 * (a + b)), b - a
        theta, omega = theta + omega * h + 0.5 * u * h * h, omega + u * h
    assert xi[:2] == pytest.approx([theta, omega], rel=1e-12, abs=1e-14)


def test_the_lqr_of_the_rigid_hub_tends_to_the_continuous_one():
    """At a short period the rigid design's gains on a tilt are those of the continuous
    LQR of `J theta'' = tau`: `k_p = sqrt(q / r)`, `k_d = sqrt(q_v / r + 2 J k_p)`."""
    settings = DesignSettings(state_rate_hz=1000.0)
    model = SailModel(design_sail(FREE, settings))
    point = design_point(model, settings, 12.0)
    M, _ = model.mass_and_stiffness(12.0)
    J = M[model.hub_slice, model.hub_slice][1, 1]
    k_p = math.sqrt(settings.weight_tilt / settings.weight_torque)
    k_d = math.sqrt(settings.weight_tilt_rate / settings.weight_torque + 2 * J * k_p)
    # rows: F_z, tau_x, tau_y; columns: z, theta_x, theta_y, zd, thd_x, thd_y, then d
    assert point.K[1, 1] == pytest.approx(k_p, rel=2e-3)
    assert point.K[1, 4] == pytest.approx(k_d, rel=2e-3)
    assert point.K[1, 6:] == pytest.approx([0.0, 1.0, 0.0])  # -d^ on its own channel


def test_the_rigid_design_model_is_the_hub_block_of_the_sail():
    settings = DesignSettings()
    model = SailModel(FREE)
    plant = design_model(SailModel(design_sail(FREE, settings)), settings, [14.0, 13, 15, 12])
    M, _ = model.mass_and_stiffness([14.0, 13, 15, 12])
    h = model.hub_slice
    expected = np.linalg.solve(M[h, h], model.input_matrix([14.0, 13, 15, 12])[h][:, HUB_WRENCH])
    assert plant.B[3:] == pytest.approx(expected, rel=1e-12)
    assert plant.B_d[3:] == pytest.approx(np.linalg.inv(M[h, h]), rel=1e-12)


def test_the_schedule_blends_its_design_points_and_holds_its_ends():
    settings = DesignSettings(schedule_lengths=[10.0, 12.0, 16.0])
    schedule = design_schedule(FREE, settings)
    model = SailModel(design_sail(FREE, settings))
    exact = design_point(model, settings, 12.0)
    for name in ("F", "G", "C", "M", "K"):
        assert getattr(schedule.at(12.0), name) == pytest.approx(getattr(exact, name))
        middle = 0.5 * (getattr(schedule, name)[1] + getattr(schedule, name)[2])
        assert getattr(schedule.at(14.0), name) == pytest.approx(middle)
        assert getattr(schedule.at(30.0), name) == pytest.approx(getattr(schedule, name)[2])
        assert getattr(schedule.at(1.0), name) == pytest.approx(getattr(schedule, name)[0])


def test_a_gains_file_round_trips_and_a_bad_one_is_named(tmp_path):
    schedule = design_schedule(FREE, DesignSettings(schedule_lengths=[10.0, 16.0]))
    path = tmp_path / "gains.npz"
    schedule.save(path)
    read = GainSchedule.load(path)
    assert read.inputs == schedule.inputs and read.settings == schedule.settings
    assert np.array_equal(read.K, schedule.K) and read.period == schedule.period
    read.check_against(schedule.settings, "here")
    with pytest.raises(ValueError, match=r"designed at 100 Hz, state_rate_hz is 50 Hz"):
        read.check_against(schedule.settings.replace(state_rate_hz=50.0), "here")
    arrays = dict(np.load(path))
    for change, message in (
        (lambda a: a.__setitem__("K", a["K"][:, :, :-1]), r"K has shape \(2, 3, 8\), expected"),
        (lambda a: a["M"].__setitem__((0, 0, 0), np.nan), "M holds a value that is not finite"),
        (lambda a: a.pop("C"), "no C"),
        (lambda a: a.__setitem__("format", np.array("other")), "not a gain schedule"),
    ):
        broken = {k: v.copy() for k, v in arrays.items()}
        change(broken)
        np.savez(tmp_path / "broken.npz", **broken)
        with pytest.raises(ValueError, match=message):
            GainSchedule.load(tmp_path / "broken.npz")


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"weight_tilt": math.nan}, "weight_tilt must be finite, got nan"),
        ({"weight_torque": 0.0}, r"weight_torque must be in \(0, 1e\+15\]"),
        ({"design_boom_modes": 2}, "both 0 .* or both at least 1"),
        ({"tip_forces": True}, "tip_forces = true needs a design model with modes"),
        ({"schedule_lengths": [12.0, 10.0]}, "schedule_lengths must be empty or at least 2"),
        ({"loop_delay_s": 1.0}, "more than 50 sample periods"),
    ],
    ids=["nan", "zero-r", "modes", "tip-forces", "lengths", "delay"],
)
def test_bad_settings_are_named(changes, message):
    with pytest.raises(ValueError, match=message):
        DesignSettings(**changes)


def rigid_hub(settings, length, disturbance):
    """The rigid design's own sampled plant with a constant disturbance wrench."""
    model = SailModel(design_sail(FREE, settings))
    plant = design_model(model, settings, length)
    return sampled(plant.A, plant.B, plant.B_d, settings.period, 0.0), disturbance


class Windup(DiscreteController):
    """The same loop whose prediction takes the demand, not the command applied."""

    def step(self, y, length):
        command = super().step(y, length)
        self._predict(command.demand)
        self.u = command.u
        return command


def settle(controller, s, disturbance, steps=3000):
    """Tilt theta_x over `steps` samples from 20 mrad off under `disturbance`, and which
    samples saturated."""
    x = np.array([0.0, 0.02, 0.0, 0.0, 0.0, 0.0])
    tilts, saturated = [], []
    for _ in range(steps):
        command = controller.step(x, 10.0)
        assert np.all(np.abs(command.u) <= controller.limits)
        saturated.append(command.saturated.any())
        x = s.F @ x + s.G @ command.u + s.G_d @ disturbance
        tilts.append(x[1])
    return np.array(tilts), np.array(saturated)


def test_the_estimate_takes_the_applied_command_so_nothing_winds_up():
    """20 mrad off under a constant torque of 0.6 N m with 0.8 N m to hold it: the torque
    saturates for seconds. Predicting with the command applied, the loop leaves
    saturation without overshoot (under 1 % of the start) and settles; predicting with
    the demand, the disturbance estimate winds up and the tilt overshoots by 60 % and
    settles three times later. The saturated samples are counted, per channel."""
    settings = DesignSettings(schedule_lengths=[10.0, 16.0])
    schedule = design_schedule(FREE, settings)
    s, d = rigid_hub(settings, 10.0, np.array([0.0, 0.6, 0.0]))
    controller = DiscreteController(schedule, [1.0, 0.8, 0.8])
    tilts, saturated = settle(controller, s, d)
    assert saturated.sum() > 100 and controller.saturated_samples == saturated.sum()
    assert controller.saturations.tolist() == [0, saturated.sum(), 0]
    wound_tilts, _ = settle(Windup(schedule, [1.0, 0.8, 0.8]), s, d)
    assert -tilts.min() < 0.01 * 0.02 and -wound_tilts.min() > 0.5 * 0.02
    settled = np.flatnonzero(np.abs(tilts) > 1e-4).max()
    assert np.flatnonzero(np.abs(wound_tilts) > 1e-4).max() > 2 * settled
    assert controller.disturbance == pytest.approx([0.0, 0.6, 0.0], abs=1e-4)
    assert abs(tilts[-1]) < 1e-6


def test_hold_and_skip_keep_the_prediction_that_of_the_plant():
    settings = DesignSettings(schedule_lengths=[10.0, 16.0])
    schedule = design_schedule(FREE, settings)
    s, _ = rigid_hub(settings, 10.0, 0.0)
    twin = DiscreteController(schedule, [1.0, 1.0, 1.0])
    controller = DiscreteController(schedule, [1.0, 1.0, 1.0])
    x = np.array([0.0, 1e-3, -2e-3, 0.0, 0.0, 0.0])
    controller.step(x, 10.0)
    controller.hold(np.zeros(3))  # the plant got a zero wrench instead
    x1 = s.F @ x
    controller.skip(2)  # and two samples did not come
    x3 = s.F @ s.F @ x1
    twin.step(x, 10.0)
    # the prediction now is the plant's state (to the estimate's own error)
    assert controller._prior[:6] == pytest.approx(x3, abs=2e-5)
    assert not np.allclose(twin._prior[:6], controller._prior[:6])


def test_the_watchdog_says_stale_once_and_ends_it_with_a_sample():
    watch = StaleWatch(0.03)
    assert not watch.check(10.0)  # nothing seen yet: nothing stale
    watch.seen(10.0)
    assert not watch.check(10.03)
    assert watch.check(10.031) and watch.stale
    assert not watch.check(11.0)  # said once
    assert watch.seen(11.5) and not watch.stale and watch.spells == 1
    assert not watch.seen(11.51)


def test_the_check_is_the_loop_the_controller_runs():
    """A few steps of the sampled full plant with the `DiscreteController` in the loop
    (limits far off) equal the powers of the check's loop matrix on the same start."""
    settings = DesignSettings(schedule_lengths=[10.0, 16.0])
    schedule = design_schedule(FREE, settings)
    model = SailModel(FREE)
    lengths, rates = [14.0, 14.0, 14.0, 12.0], [0.3, 0.3, 0.3, 0.0]
    A, B, C, _ = model.state_space(lengths, rates)
    plant = sampled(A, B[:, HUB_WRENCH], np.zeros((A.shape[0], 0)), schedule.period, 0.0)
    outputs = plant_outputs(model, C, schedule.measurements)
    controller = DiscreteController(schedule, [1e9] * 3)
    x = np.zeros(A.shape[0])
    x[0], x[model.n + model.n - 2] = 0.02, 1e-3  # boom a bent, the hub turning
    loop = loop_matrix(model, schedule, lengths, rates)
    first = schedule.at(float(np.mean(lengths))).C  # the controller starts from pinv(C) y
    state = np.concatenate([x, np.linalg.pinv(first) @ outputs @ x])
    for _ in range(5):
        controller.step(outputs @ x, float(np.mean(lengths)))
        x = plant.F @ x + plant.G @ controller.u
        state = loop @ state
    assert state[: x.size] == pytest.approx(x, rel=1e-9, abs=1e-15)


@pytest.fixture(scope="module")
def reference():
    scenario = load_scenario(CONFIG / "scenario_free_hub_control.yaml")
    return scenario, SailModel(FREE.replace(**scenario.sail))


def test_the_loop_is_stable_along_the_reference_free_hub_deployment(reference):
    """Every 0.25 s of config/scenario_free_hub_control.yaml (booms
    deploying unequally, frozen at each time's lengths and rates: the open plant is
    unstable there), the discrete loop against the plant with all of its modes at (4, 6)
    has no pole in the right half-plane; the poles the loop moves are all in the open
    left half-plane, the others are modes of the undamped sail it does not reach."""
    scenario, model = reference
    schedule = design_schedule(model.params, scenario.controller)
    rows = check_deployment(model, schedule, scenario.profile, np.arange(0.0, 20.01, 0.25))
    assert max(row.open_loop_real for row in rows) > 0.01  # the open plant is unstable
    assert all(row.stable for row in rows), [
        (row.t, row.largest_real) for row in rows if not row.stable
    ]
    assert max(row.reached_real for row in rows) < 0.0
    assert all(row.above_nyquist == 0 for row in rows)


def test_the_check_finds_spillover_where_there_is_some(reference):
    """The same loop at 50 Hz: the plant's highest boom modes lie above the Nyquist
    frequency, and the sampled loop pushes undamped ones into the right half-plane."""
    scenario, model = reference
    settings = scenario.controller.replace(state_rate_hz=50.0)
    schedule = design_schedule(model.params, settings)
    rows = check_deployment(model, schedule, scenario.profile, [0.0, 20.0])
    assert all(row.above_nyquist > 0 for row in rows)
    assert any(not row.stable and row.largest_real > 100 * NEUTRAL for row in rows)


def test_a_simulator_that_runs_another_plant_is_named():
    design, policy = DesignSettings(), Policy()
    node = "/sail_sim"

    def said(**changes):
        values = {"sail.free_hub": True, "sail.n_boom_modes": 4, "sail.n_membrane_modes": 6,
                  "state_rate_hz": 100.0, "max_hub_torque": 1.0, "integration_step": 0.01,
                  "max_model_step": 0.01, "time_scale": 1.0, **changes}  # fmt: skip
        return agreement.disagreement(FREE, design, policy, values, node)

    assert said() == ("", [])
    assert "clamped hub" in said(**{"sail.free_hub": False})[0]
    assert said(**{"sail.n_boom_modes": 8})[0].startswith("sail.n_boom_modes = 4 here, 8 in")
    assert said(**{"sail.hub_mass": 50.0})[0].startswith("sail.hub_mass = 100.0 here, 50.0")
    assert said(state_rate_hz=50.0)[0].startswith("state_rate_hz = 100 Hz here, 50 Hz")
    assert said(max_hub_torque=0.5)[0].startswith("max_hub_torque = 1 N m here, 0.5 N m")
    assert "run ahead" in said(max_model_step=0.5)[1][0]
    assert "carries 2 state samples" in said(time_scale=4.0)[1][0]


def test_a_design_without_a_stabilising_riccati_solution_is_refused():
    settings = DesignSettings(design_boom_modes=1, design_membrane_modes=1)
    undamped = dataclasses.replace(settings)
    object.__setattr__(undamped, "design_damping_ratio", 0.0)  # below its range
    model = SailModel(design_sail(FREE, undamped))
    with pytest.raises(ValueError, match="no stabilising solution of the Riccati equation"):
        design_point(model, undamped, 10.0)
    assert scipy.linalg  # the solver the message is about
