"""The simulator's pure parts: command checks and planning, boom motion, the
grid-stepping core, pacing and the parameter table. No ROS runtime."""

import math

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Duration
from harness import ROOT, SMALL_SIM
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.model import (
    CycloidalProfile,
    SailModel,
    SailParameters,
    StaticProfile,
    WaypointProfile,
)
from sail_ros.model.loads import LoadSchedule
from sail_ros.model.profiles import BoomMotion
from sail_ros.policy import TOLERANCE, Policy
from sail_ros.runtime.commands import BoomState, CommandError, Rules, plan_deploy, plan_trajectory
from sail_ros.runtime.config import DEFAULTS, SIM_DEFAULTS, ConfigError, config_from_values
from sail_ros.runtime.intake import CommandQueue
from sail_ros.runtime.pacing import Pacer, RealTimeFactor
from sail_ros.runtime.simulation import ERROR, PAUSED, RUNNING, Simulation

pytestmark = pytest.mark.model

RULES = Rules(
    Policy(min_length=1.0, max_length=70.0, max_rate=1.0, max_acceleration=0.5), SailParameters()
)
REST = BoomState(2.0, np.full(4, 10.0), np.zeros(4), np.zeros(4))


def trajectory(names, *points, **fields):
    """A JointTrajectory; each point is (positions, time_from_start [s])."""
    message = JointTrajectory(joint_names=list(names))
    for positions, seconds in points:
        sec = math.floor(seconds)
        point = JointTrajectoryPoint(
            positions=list(positions),
            time_from_start=Duration(sec=sec, nanosec=round((seconds - sec) * 1e9)),
        )
        for name, value in fields.items():
            setattr(point, name, value)
        message.points.append(point)
    return message


# -- trajectories -------------------------------------------------------------------------------


def test_trajectory_passes_through_points_and_others_are_untouched():
    plan = plan_trajectory(
        trajectory(["boom_c", "boom_a"], ([11.0, 11.5], 6.0), ([12.0, 12.0], 12.0)), REST, RULES
    )
    assert plan.booms == (2, 0)
    assert (plan.t_start, plan.t_end) == (2.0, 14.0)
    for t, (c, a) in [
        (2.0, (10.0, 10.0)),
        (8.0, (11.0, 11.5)),
        (14.0, (12.0, 12.0)),
        (30.0, (12.0, 12.0)),
    ]:
        lengths, rates, _ = plan.profile(t)
        assert (lengths[2], lengths[0]) == pytest.approx((c, a), abs=1e-12)
    assert np.all(plan.profile(14.0)[1] == 0.0)  # at rest at the last point
    assert "boom_c, boom_a: 2 point(s) over 12 s" in plan.summary


def test_trajectory_starts_from_the_current_rates():
    moving = BoomState(
        0.0, np.array([10.0, 11.0, 12.0, 13.0]), np.array([0.3, 0.0, -0.2, 0.0]), np.zeros(4)
    )
    plan = plan_trajectory(trajectory(["boom_a", "boom_c"], ([12.0, 12.0], 10.0)), moving, RULES)
    lengths, rates, _ = plan.profile(0.0)
    assert lengths[[0, 2]] == pytest.approx([10.0, 12.0])
    assert rates[[0, 2]] == pytest.approx([0.3, -0.2])
    # just after the start the rate has not jumped (continuous rate)
    assert plan.profile(1e-6)[1][[0, 2]] == pytest.approx([0.3, -0.2], abs=1e-5)


BAD_TRAJECTORIES = {
    "no names": (trajectory([], ([], 1.0)), "no joint_names"),
    "unknown name": (
        trajectory(["boom_a", "mast"], ([11.0, 11.0], 1.0)),
        "unknown joint name\\(s\\) 'mast'",
    ),
    "repeated name": (
        trajectory(["boom_b", "boom_b"], ([11.0, 11.0], 5.0)),
        "'boom_b' given more than once",
    ),
    "no points": (trajectory(["boom_a"]), "no points"),
    "too few positions": (
        trajectory(["boom_a", "boom_b"], ([11.0], 5.0)),
        "point 0 has 1 positions for 2 joint names",
    ),
    "too many positions": (
        trajectory(["boom_a"], ([11.0], 5.0), ([11.0, 12.0], 9.0)),
        "point 1 has 2 positions for 1 joint names",
    ),
    "velocities": (
        trajectory(["boom_a"], ([11.0], 5.0), velocities=[0.0]),
        "point 0: velocities are not supported",
    ),
    "zero time": (
        trajectory(["boom_a"], ([11.0], 0.0)),
        "point 0: time_from_start 0 s must be > 0",
    ),
    "negative time": (trajectory(["boom_a"], ([11.0], -2.0)), "time_from_start -2 s must be > 0"),
    "times not increasing": (
        trajectory(["boom_a"], ([11.0], 5.0), ([12.0], 5.0)),
        "point 1: time_from_start 5 s must be > that of point 0 \\(5 s\\)",
    ),
    "nan length": (trajectory(["boom_a"], ([math.nan], 5.0)), "point 0: boom_a is nan"),
    "inf length": (trajectory(["boom_a"], ([math.inf], 5.0)), "point 0: boom_a is inf"),
    "too short": (
        trajectory(["boom_d"], ([0.5], 50.0)),
        "boom_d = 0.5 m is outside \\[min_length, max_length\\] = \\[1, 70\\] m",
    ),
    "too long": (trajectory(["boom_d"], ([70.5], 500.0)), "boom_d = 70.5 m is outside"),
    "too fast": (
        trajectory(["boom_a"], ([40.0], 30.0)),
        "boom_a would move at 1.5 m/s, above max_rate 1 m/s",
    ),
    "too abrupt": (
        trajectory(["boom_b"], ([10.4], 1.0)),
        "boom_b would accelerate at 2.4 m/s\\^2, above max_acceleration 0.5",
    ),
}


@pytest.mark.parametrize("case", BAD_TRAJECTORIES, ids=str)
def test_bad_trajectory_is_rejected_with_its_reason(case):
    message, reason = BAD_TRAJECTORIES[case]
    with pytest.raises(CommandError, match=reason):
        plan_trajectory(message, REST, RULES)


def test_spline_overshoot_beyond_the_limits_is_rejected():
    # moving out at 0.5 m/s, 0.4 m below max_length, asked to stop 0.3 m further in 8 s:
    # the spline carries the boom to 70.12 m first
    moving = BoomState(
        0.0, np.array([69.5, 10.0, 10.0, 10.0]), np.array([0.5, 0, 0, 0]), np.zeros(4)
    )
    with pytest.raises(CommandError, match="boom_a would pass through 70.12 m on the way"):
        plan_trajectory(trajectory(["boom_a"], ([69.6], 8.0)), moving, RULES)
    assert plan_trajectory(trajectory(["boom_a"], ([69.6], 4.0)), moving, RULES)


# -- deployment ---------------------------------------------------------------------------------


def test_deploy_from_rest_is_the_fastest_cycloidal_within_limits():
    plan = plan_deploy(15.0, REST, RULES)
    assert isinstance(plan.profile, CycloidalProfile)
    # travel 5 m: rate-limited 2*5/1 = 10 s vs acceleration-limited sqrt(2 pi 5 / 0.5) = 7.9 s
    assert plan.profile.duration == pytest.approx(10.0)
    assert (plan.t_start, plan.t_end, plan.booms) == (2.0, 12.0, (0, 1, 2, 3))


def test_deploy_duration_is_honoured_or_rejected():
    plan = plan_deploy(15.0, REST, RULES, duration=15.0)  # model.md §9 reference
    assert plan.profile.duration == 15.0
    assert plan.profile(9.5)[1] == pytest.approx(np.full(4, 2 * 5 / 15))  # peak rate at T/2
    with pytest.raises(CommandError, match="a 4 s deployment to 15 m needs 2.5 m/s and 1.963"):
        plan_deploy(15.0, REST, RULES, duration=4.0)


def test_every_motion_check_draws_the_line_at_the_one_slack():
    """The policy's rate and motion checks and the deploy planners compare with the limits
    in one place (`Policy.motion_excess`): within its slack a motion passes, beyond it
    every one of them refuses."""
    policy, sail = RULES.policy, RULES.sail
    within, beyond = 1.0 + TOLERANCE / 2, 1.0 + 4 * TOLERANCE
    rate, acceleration = policy.max_rate, policy.max_acceleration
    assert not any(policy.motion_excess(10.0, 10.0, rate * within, acceleration * within, sail))
    assert policy.motion_excess(10.0, 10.0, rate * beyond, 0.0, sail) == (
        False, False, True, False
    )  # fmt: skip
    assert policy.motion_excess(10.0, 10.0, 0.0, math.nan, sail)[3]
    policy.check_rate(rate * within, "rate")
    with pytest.raises(ValueError, match="max_rate"):
        policy.check_rate(rate * beyond, "rate")
    fastest = policy.fastest_cycloid(10.0, 15.0).duration
    plan = plan_deploy(15.0, REST, RULES, duration=fastest)
    policy.check_motion(plan.profile, sail)
    with pytest.raises(CommandError, match="needs"):
        plan_deploy(15.0, REST, RULES, duration=fastest / beyond)
    with pytest.raises(ValueError, match="above max_"):
        policy.check_motion(CycloidalProfile(10.0, 15.0, fastest / beyond), sail)


@pytest.mark.parametrize(
    ("target", "reason"),
    [
        (math.nan, "target is nan, not a finite length"),
        (-math.inf, "target is -inf"),
        (0.9, "target = 0.9 m is outside"),
        (80.0, "target = 80 m is outside"),
    ],
    ids=str,
)
def test_bad_deploy_target_is_rejected(target, reason):
    with pytest.raises(CommandError, match=reason):
        plan_deploy(target, REST, RULES)


def test_deploy_while_moving_continues_smoothly_within_limits():
    now = BoomState(
        3.0,
        np.array([12.0, 12.0, 11.0, 11.0]),
        np.array([0.8, 0.8, -0.5, 0.0]),
        np.array([0.1, 0.1, 0.0, 0.0]),
    )
    plan = plan_deploy(11.5, now, RULES)
    assert isinstance(plan.profile, WaypointProfile)
    lengths, rates, _ = plan.profile(now.t)
    assert lengths == pytest.approx(now.lengths) and rates == pytest.approx(now.rates)
    lengths, rates, accelerations = plan.profile(plan.t_end)
    assert lengths == pytest.approx(np.full(4, 11.5)) and not np.any(rates)
    low, high, rate, acceleration = plan.profile.extremes()
    assert np.all(rate <= RULES.policy.max_rate) and np.all(
        acceleration <= RULES.policy.max_acceleration
    )
    # the quickest such move: 10 % shorter breaks a limit
    shorter = WaypointProfile(
        [now.t, now.t + (plan.t_end - now.t) / 1.1],
        [now.lengths, np.full(4, 11.5)],
        start_rates=now.rates,
    )
    _, _, rate, acceleration = shorter.extremes()
    assert np.any(rate > RULES.policy.max_rate) or np.any(
        acceleration > RULES.policy.max_acceleration
    )


# -- boom motion --------------------------------------------------------------------------------


def test_boom_motion_takes_each_boom_from_its_own_profile():
    hold = StaticProfile([10.0, 11.0, 12.0, 13.0])
    deploy = CycloidalProfile(10.0, 20.0, 10.0, t0=1.0)
    motion = BoomMotion([hold] * 4).replaced(deploy, (1, 3))
    lengths, rates, _ = motion(6.0)
    assert lengths == pytest.approx([10.0, 15.0, 12.0, 15.0])
    assert rates == pytest.approx([0.0, 2.0, 0.0, 2.0])
    assert motion.is_static(0.0, 0.5) and not motion.is_static(5.0, 6.0)
    assert motion.t_end == 11.0 and BoomMotion([hold] * 4).t_end == -math.inf


# -- the simulation core ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def config():
    return config_from_values(
        {
            **SMALL_SIM,
            "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0],
            "max_rate": 1.0,
            "max_acceleration": 0.5,
        }
    )


@pytest.fixture(scope="module")
def model(config):
    return SailModel(config.sail)


def test_simulation_steps_on_the_grid_and_matches_simulate(model, config):
    sim = Simulation(model, config)
    for _ in range(100):
        assert sim.step()
    sim.apply_motion(sim.plan_deploy(12.0))
    while sim.steps < 600:
        assert sim.step()
    assert sim.t == pytest.approx(6.0, abs=1e-12)
    assert sim.accepted == 1 and sim.last_command_start == pytest.approx(1.0)
    # the same motion offline, sampled as the simulator does: agreement to round-off
    profile = Policy(max_rate=1.0, max_acceleration=0.5).fastest_cycloid(
        10.0, 12.0, t0=sim.last_command_start
    )
    run = model.simulate_on_grid(
        profile, 6.0, 0.01, model.initial_coordinates([0.1, 0, 0, 0]),
        max_step=config.max_model_step, rtol=config.model_rtol,
    )  # fmt: skip
    t, q, qd = run
    assert t[-1] == pytest.approx(6.0, abs=1e-12)
    assert sim.q == pytest.approx(q[-1], abs=1e-12) and sim.qd == pytest.approx(qd[-1], abs=1e-12)
    # ... in the same steps: one exact step per grid step at rest, and while the booms
    # moved steps of many grid steps, as the tolerance chose them
    moving = np.count_nonzero(t[:-1] >= profile.t0)
    assert sim.stepper.steps_taken == run.steps
    assert run.steps < 100 + moving / 5
    assert sim.sample().lengths == pytest.approx(profile(6.0)[0])


def test_loads_are_held_from_the_next_step_and_match_simulate(model, config):
    """A tip force and pressures commanded at t = 1 s, the solar pressure on top: the
    offline model with the same loads switched at 1 s agrees to round-off; a reset
    zeroes the commanded loads."""
    solar = config_from_values({**SMALL_SIM, "initial_tip_deflection": [0.1, 0, 0, 0],
                                "solar_pressure": 9.08e-6})  # fmt: skip
    sim = Simulation(model, solar)
    for _ in range(100):
        assert sim.step()
    force = commands_msg.load_command(topics.TIP_FORCE_CMD, {"boom_b": 0.05})
    change = sim.load(topics.TIP_FORCE_CMD, force)
    assert change.summary == "boom_b = 0.05 N (others held)"
    pressure = commands_msg.load_command(
        topics.PRESSURE_CMD, {"quadrant_ab": 2e-3, "quadrant_cd": 1e-3}
    )
    sim.load(topics.PRESSURE_CMD, pressure)
    assert sim.inputs() == pytest.approx(
        [2e-3 + 9.08e-6, 9.08e-6, 1e-3 + 9.08e-6, 9.08e-6, 0, 0.05, 0, 0]
    )
    while sim.steps < 400:
        assert sim.step()
    schedule = LoadSchedule([(0.0, 9.08e-6, 0.0), (1.0, np.array([2e-3, 0, 1e-3, 0]) + 9.08e-6,
                                                   [0, 0.05, 0, 0])])  # fmt: skip
    _, q, _ = model.simulate(
        StaticProfile(10.0),
        4.0,
        model.initial_coordinates([0.1, 0, 0, 0]),
        t_eval=[1.0, 4.0],
        loads=schedule,
        max_step=0.01,
    )
    assert sim.q == pytest.approx(q[-1], abs=1e-12)
    assert sim.sample().root_moments == pytest.approx(model.root_moments(q[-1], 10.0))
    energy, load_power, dissipation = sim.balance()
    assert energy == pytest.approx(model.energy(sim.q, sim.qd, 10.0), rel=1e-12)
    assert dissipation == 0.0 and load_power != 0.0  # undamped, loaded
    sim.reset(solar)
    assert sim.inputs() == pytest.approx([9.08e-6] * 4 + [0.0] * 4)


def test_the_balance_of_a_damped_ringing_sail_is_its_energy_and_dissipation():
    """With Rayleigh damping the dissipation `qd^T C_d qd` is positive and the energy
    that of the model, both from the one assembly `balance` makes."""
    damping = {"sail.mass_damping": 0.01, "sail.stiffness_damping": 1e-3}
    damped = config_from_values({**SMALL_SIM, "initial_tip_deflection": [0.1, 0, 0, 0], **damping})
    model = SailModel(damped.sail)
    sim = Simulation(model, damped)
    for _ in range(30):
        assert sim.step()
    energy, load_power, dissipation = sim.balance()
    qd, lengths = sim.qd, sim.lengths
    assert dissipation > 0.0 and load_power == 0.0
    assert dissipation == pytest.approx(qd @ model.structural_damping(lengths) @ qd, rel=1e-12)
    assert energy == pytest.approx(model.energy(sim.q, qd, lengths), rel=1e-12)


@pytest.mark.parametrize(
    ("topic", "values", "reason"),
    [
        (topics.TIP_FORCE_CMD, {"boom_e": 0.1}, r"unknown name\(s\) 'boom_e'; names are boom_a"),
        (topics.PRESSURE_CMD, {"boom_a": 0.1}, r"unknown name\(s\) 'boom_a'; names are quadr"),
        (topics.TIP_FORCE_CMD, {"boom_a": math.nan}, "boom_a = nan N is not finite"),
        (topics.TIP_FORCE_CMD, {"boom_a": -2.0}, r"\|boom_a\| = 2 N exceeds max_tip_force = 1 N"),
        (topics.PRESSURE_CMD, {"quadrant_ab": 0.5}, "exceeds max_pressure = 0.01 Pa"),
        (topics.PRESSURE_CMD, {}, "names nothing to load"),
    ],
    ids=str,
)
def test_bad_load_commands_are_rejected_whole(model, config, topic, values, reason):
    sim = Simulation(model, config)
    message = commands_msg.load_command(topic, {"quadrant_ab": 1e-3} if topic == topics.PRESSURE_CMD
                                  else {"boom_b": 0.5})  # fmt: skip
    sim.load(topic, message)
    before = sim.inputs()
    bad = commands_msg.load_command(topic, {**values})
    if topic == topics.TIP_FORCE_CMD and values:
        bad.name.insert(0, "boom_c")  # a good value first: nothing of the command applies
        bad.effort = [0.3, *bad.effort]
    with pytest.raises(CommandError, match=reason):
        sim.load(topic, bad)
    assert np.array_equal(sim.inputs(), before) and sim.rejected == 1


def test_short_booms_get_sub_steps(model, config):
    short = config_from_values({**SMALL_SIM, "min_length": 1.0, "initial_lengths": [1.0]})
    sim = Simulation(model, short)
    # omega_1 = 1.8751^2 sqrt(6000 / 0.1) / 1.0^2 = 861 rad/s; a step of the tolerance's
    # stepper is two rational steps of at most 2 rad: 4 / 861 = 4.6 ms, so 0.01 s needs 3
    assert sim.substeps() == 3
    assert Simulation(model, config).substeps() == 1
    assert sim.step() and sim.stepper.steps_taken == 1  # at rest: one exact step
    sim.apply_motion(sim.plan_deploy(2.0))
    assert sim.step() and sim.stepper.steps_taken == 4 and sim.t == pytest.approx(0.02)


def test_rejected_command_leaves_the_state_alone(model, config):
    reference, sim = Simulation(model, config), Simulation(model, config)
    for _ in range(50):
        reference.step()
        sim.step()
    with pytest.raises(CommandError, match="above max_rate"):
        sim.apply_motion(sim.plan_trajectory(trajectory(["boom_a"], ([20.0], 5.0))))
    assert sim.accepted == 0
    for _ in range(50):
        reference.step()
        sim.step()
    assert np.array_equal(sim.q, reference.q)


def test_leaving_the_linear_range_warns_then_stops_before_anything_is_non_finite(config):
    # twice the Euler load pi^2 EI / (4 L^2) = 148 N of the 10 m booms: they buckle slowly
    buckling = config_from_values(
        {**SMALL_SIM, "sail.boom_axial_load": 300.0, "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0]}
    )
    sim = Simulation(SailModel(buckling.sail), buckling)
    warned_at = None
    while sim.step():
        assert sim.steps < 1000, "the buckled booms should diverge within 10 s"
        if sim.range_warning and warned_at is None:
            warned_at = sim.steps
            assert "tip deflection of boom a is " in sim.range_warning
            assert sim.range_warning.endswith("beyond tip_warn_fraction 0.1")
    assert warned_at is not None and warned_at < sim.steps  # WARN came first
    assert sim.state == ERROR and "beyond tip_error_fraction 0.3: out of the linear range" in (
        sim.error
    )
    tips = sim.model.tip_deflections(sim.q)
    assert np.all(np.isfinite(sim.q)) and abs(tips[0]) / 10.0 < 1.0  # 0.3 < ... < 1


class NoRangeCheck:
    """A policy without the tip-deflection alarms."""

    def range_state(self, tips, lengths, hub=None):
        return "", ""


def test_non_finite_state_stops_until_reset(config):
    buckling = config_from_values(
        {
            **SMALL_SIM,
            "sail.boom_axial_load": 1e6,
            "initial_tip_deflection": [0.1, 0.0, 0.0, 0.0],
        }
    )
    sim = Simulation(SailModel(buckling.sail), buckling)
    sim.policy = NoRangeCheck()  # let it blow up
    while sim.step():
        assert sim.steps < 1000, "the buckled booms should diverge within 10 s"
    assert sim.state == ERROR and "non-finite" in sim.error
    assert np.all(np.isfinite(sim.q))  # the last finite state is kept
    t = sim.t
    assert not sim.step() and sim.t == t
    with pytest.raises(CommandError, match="call sail/reset first"):
        sim.apply_motion(sim.plan_deploy(12.0))
    sim.paused = True
    sim.reset(config_from_values({**SMALL_SIM, "sail.boom_axial_load": 1e6}))  # no tip: stays 0
    assert sim.state == PAUSED and sim.t == t and not np.any(sim.q)
    sim.paused = False
    assert sim.state == RUNNING and all(sim.step() for _ in range(100))


# -- pacing -------------------------------------------------------------------------------------


class FakeClock:
    """A monotonic clock the test moves by hand [s]."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_pacer_follows_the_steady_clock_without_drift():
    clock = FakeClock()
    pacer = Pacer(2.0, 0.01, tick_steps=2, now=clock)
    assert pacer.tick_period == pytest.approx(0.01)  # 2 steps of 0.01 s at 2x
    pacer.tick_steps = 1
    assert pacer.tick_period == 0.005  # the floor
    pacer.tick_steps = 1000  # a state sample every 10 s of simulation
    assert pacer.tick_period == 0.05  # the ceiling: the integration is never starved
    pacer.tick_steps = 2
    pacer.run_from(0.0)
    clock.now += 1.25
    assert pacer.due() == pytest.approx(2.5)
    pacer.hold(2.5)
    clock.now += 10.0  # paused time does not count
    assert pacer.due() == 2.5
    pacer.run_from(2.5)
    clock.now += 0.5
    assert pacer.due() == pytest.approx(3.5)
    unpaced = Pacer(0.0, 0.01, 2, now=clock)
    unpaced.run_from(0.0)
    assert unpaced.tick_period == 0.0 and unpaced.due() == math.inf


def test_overrun_is_a_tick_more_than_one_step_late_or_left_behind():
    clock = FakeClock()
    pacer = Pacer(1.0, 0.01, now=clock)
    pacer.run_from(0.0)
    t, overruns = 0.0, []
    for delay in [0.01, 0.0105, 0.0095, 0.0199, 0.0201, 0.01]:  # wall time between ticks
        clock.now += delay
        due, deadline, overrun = pacer.tick(t)
        assert deadline == pytest.approx(clock.now + pacer.budget)
        overruns.append(overrun)
        t = math.floor(due / 0.01 + 1e-9) * 0.01  # the tick caught up
    assert overruns == [False, False, False, False, True, False]
    clock.now += 0.01
    due, _, _ = pacer.tick(t)
    clock.now += 0.01  # this tick could not catch up (out of budget)
    assert pacer.tick(t)[2] is True


def test_real_time_factor_is_measured_over_long_uninterrupted_running_windows():
    clock = FakeClock()
    clock.now = 0.0
    rtf = RealTimeFactor(0.5, now=clock)
    rtf.restart(0.0, running=True)

    def update(wall, t):
        clock.now = wall
        return rtf.update(t)

    assert not update(0.3, 0.6)  # too short: nothing measured yet
    assert (rtf.value, rtf.window, rtf.current) == (0.0, 0.0, False)
    assert update(0.6, 1.2)
    assert (rtf.value, rtf.window, rtf.current) == (pytest.approx(2.0), pytest.approx(0.6), True)
    # diagnostics sent 5 ms later (a state change publishes at once) after a catch-up
    # tick: the window goes on instead of giving (1.24 - 1.2) / 0.005 = 8x
    assert not update(0.605, 1.24)
    assert rtf.value == pytest.approx(2.0)
    assert update(1.2, 2.3)
    assert (rtf.value, rtf.window) == (pytest.approx(1.1 / 0.6), pytest.approx(0.6))
    clock.now = 1.75  # a pause after 0.55 s of running: that window counts
    rtf.restart(3.4, running=False)
    assert (rtf.value, rtf.window, rtf.current) == (pytest.approx(2.0), pytest.approx(0.55), False)
    assert not update(5.0, 3.4)  # paused: nothing measured, the last value stays
    clock.now = 5.0
    rtf.restart(3.4, running=True)  # resumed...
    clock.now = 5.1
    rtf.restart(3.6, running=True)  # ...and reset 0.1 s later: too short, dropped
    assert rtf.value == pytest.approx(2.0) and not rtf.current
    assert not update(5.5, 4.4)
    assert update(5.7, 4.8) and rtf.value == pytest.approx(2.0) and rtf.current


# -- parameters ---------------------------------------------------------------------------------


def test_config_file_holds_the_defaults():
    document = yaml.safe_load((ROOT / "config/sim.yaml").read_text())
    values = document["sail_sim"]["ros__parameters"]
    flat = {f"sail.{key}": value for key, value in values.pop("sail").items()} | values
    assert flat == DEFAULTS
    # config/sail.yaml holds the sail's defaults, the offline tools'; the simulator's
    # differ where SIM_DEFAULTS says (and its start-up line says so)
    sail = yaml.safe_load((ROOT / "config/sail.yaml").read_text())["sail"]
    assert sail == SailParameters().to_dict()
    simulator = {name: value for name, value in DEFAULTS.items() if name.startswith("sail.")}
    differing = {name for name, value in simulator.items() if value != sail[name[5:]]}
    assert differing == set(SIM_DEFAULTS) == {"sail.membrane_band"}
    assert (
        config_from_values({})
        .live_counts_note()
        .startswith(
            "membrane_band 1.4 keeps 106 membrane modes per quadrant where the offline tools' 1.8 "
            "keeps 181"
        )
    )


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        (
            {"min_length": 20.0, "max_length": 15.0},
            "min_length \\(20 m\\) must be below max_length",
        ),
        (
            {"initial_lengths": [10.0, 10.0, 80.0, 10.0]},
            "initial_lengths of boom c = 80 m is outside \\[min_length, max_length\\] = "
            "\\[5, 70.7107\\] m",
        ),
        (
            {"initial_lengths": [10.0, 10.0]},
            "initial_lengths must hold 1 or 4 values, got 2: \\[10.0, 10.0\\]",
        ),
        ({"max_rate": -1.0}, "max_rate must be in \\[1e-06, 100\\] m/s, got -1.0"),
        ({"max_rate": True}, "max_rate must be a number, got True"),
        ({"initial_tip_deflection": [math.nan]}, "initial_tip_deflection\\[0\\] must be finite"),
        (
            {"initial_tip_deflection": [4.0, 0.0, 0.0, 0.0]},
            "initial_tip_deflection of boom a = 4 m is outside \\+-tip_error_fraction",
        ),
        ({"state_rate_hz": 200.0}, "state_rate_hz = 200 Hz is faster than the integration step"),
        ({"sail.sail_side": 0.0}, "sail.sail_side must be in \\(0, 10000\\] m, got 0.0"),
        ({"sail.n_boom_modes": 31}, "sail.n_boom_modes must be an integer in \\[1, 30\\], got 31"),
        ({"frame_id": 3}, "frame_id must be a text, got 3"),
    ],
    ids=str,
)
def test_bad_configuration_names_the_parameter(change, reason):
    with pytest.raises(ConfigError, match=reason):
        config_from_values(change)


def test_integers_are_taken_for_doubles_as_ros_users_type_them():
    config = config_from_values({"max_rate": 2, "time_scale": 3, "initial_lengths": [12]})
    assert config.policy.max_rate == 2.0 and isinstance(config.policy.max_rate, float)
    assert config.time_scale == 3.0 and config.initial_lengths.tolist() == [12.0] * 4


def test_a_min_length_whose_booms_would_need_too_many_substeps_is_refused():
    """omega_1 = beta_1^2 sqrt(EI / rho_B) / L^2 (beta_1 = 1.8751), one sub-step per
    2 rad: 5 mm would need 1.7e7 sub-steps per simulated second; the refusal
    names the shortest length within max_substep_rate, whatever the step."""
    omega_1m = 1.875104068711961**2 * math.sqrt(6000.0 / 0.1)  # [rad/s at 1 m]
    needed = omega_1m / 0.005**2 / 2.0
    shortest = math.ceil(math.sqrt(omega_1m / (2.0 * 3200.0)) * 1e3) / 1e3
    for step in (0.01, 0.1):
        with pytest.raises(ConfigError) as refused:
            config_from_values(
                {"min_length": 0.005, "initial_lengths": [1.0], "integration_step": step}
            )
        assert str(refused.value) == (
            f"min_length = 0.005 m would need {needed:.4g} sub-steps per second of "
            f"simulation, more than max_substep_rate = 3200: the shortest affordable "
            f"min_length here is {shortest:g} m"
        )
    config_from_values({"min_length": shortest})
    config_from_values({"min_length": 0.05, "max_substep_rate": needed / 99.0})


def test_the_command_queue_is_bounded_and_counts_what_it_refuses():
    queue = CommandQueue(capacity=3)
    assert [queue.offer(k) for k in range(5)] == [True, True, True, False, False]
    assert queue.overflowed == 2 and queue.take() == [0, 1, 2] and queue.take() == []
    assert queue.offer(5) and queue.take() == [5] and queue.overflowed == 2


def test_publication_intervals_round_to_whole_steps():
    config = config_from_values({"state_rate_hz": 30.0, "shape_rate_hz": 0.0})
    assert config.steps_between(config.state_rate_hz) == 3  # 1 / (30 * 0.01) = 3.33
    assert config.steps_between(config.shape_rate_hz) == 0  # off


def test_a_trajectory_longer_than_max_trajectory_points_is_rejected_whole(config):
    sim = Simulation(SailModel(config.sail), config)
    sim.policy = sim.policy.replace(max_trajectory_points=3)
    command = JointTrajectory(joint_names=["boom_a"])
    for i in range(4):
        point = JointTrajectoryPoint(positions=[10.0 + 0.01 * (i + 1)])
        point.time_from_start.sec = i + 1
        command.points.append(point)
    with pytest.raises(CommandError, match="4 points, more than max_trajectory_points = 3"):
        sim.apply_motion(sim.plan_trajectory(command))
    command.points.pop()
    assert sim.apply_motion(sim.plan_trajectory(command)).booms == (0,)
