"""Parameters (validation, YAML) and boom-motion profiles."""

import math
import re

import numpy as np
import pytest
import yaml

from sail_ros.model import (
    CycloidalProfile,
    SailModel,
    SailParameters,
    StaticProfile,
    WaypointProfile,
)
from sail_ros.model.profiles import SampledProfile
from sail_ros.policy import Policy

pytestmark = pytest.mark.model

CONFIG = "config/sail.yaml"


def test_defaults_match_model_md():
    p = SailParameters()
    assert p.full_boom_length == pytest.approx(70.7107, abs=1e-4)
    assert p.membrane_areal_density == pytest.approx(3.575e-3)
    assert p.membrane_tension == pytest.approx(0.017225)
    assert (p.n_boom_modes, p.n_membrane_modes, p.boom_axial_load) == (8, 0, 0.0)
    assert (p.membrane_band, p.resolved_length, p.membrane_modes) == (1.8, 0.0, 181)
    assert SailParameters.from_yaml(CONFIG) == p


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("sail_side", 0.0, "sail_side must be in (0, 10000] m, got 0.0"),
        (
            "boom_bending_stiffness",
            -1.0,
            "boom_bending_stiffness must be in (0, 1e+12] N m^2, got -1.0",
        ),
        ("boom_linear_density", math.nan, "boom_linear_density must be finite, got nan"),
        ("membrane_thickness", -2e-6, "membrane_thickness must be in [0, 0.01] m, got -2e-06"),
        ("membrane_prestress", math.inf, "membrane_prestress must be finite, got inf"),
        ("boom_axial_load", -0.5, "boom_axial_load must be in [0, 1e+12] N, got -0.5"),
        ("membrane_density", "heavy", "membrane_density must be a number, got 'heavy'"),
        ("n_boom_modes", 0, "n_boom_modes must be an integer in [1, 30], got 0"),
        ("n_membrane_modes", 2.5, "n_membrane_modes must be an integer in [0, 400], got 2.5"),
    ],
    ids=lambda v: str(v)[:24],
)
def test_bad_parameters_name_field_and_value(field, value, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        SailParameters(**{field: value})


def test_yaml_round_trip_and_unknown_keys(tmp_path):
    p = SailParameters(sail_side=40.0, n_boom_modes=7, boom_axial_load=0.3)
    path = tmp_path / "sail.yaml"
    path.write_text(yaml.safe_dump({"sail": p.to_dict()}, sort_keys=False))
    assert SailParameters.from_yaml(path) == p
    path.write_text(yaml.safe_dump({"sail": {"sail_side": 40.0, "boom_stiffness": 1.0}}))
    with pytest.raises(ValueError, match="unknown sail parameter\\(s\\) 'boom_stiffness'"):
        SailParameters.from_yaml(path)
    # a ROS 2 params file works as well
    path.write_text(
        yaml.safe_dump({"sail_sim": {"ros__parameters": {"sail": {"n_membrane_modes": 3}}}})
    )
    assert SailParameters.from_yaml(path).n_membrane_modes == 3
    # by parameter name, in a namespace, or none at all (the simulator's limits alone)
    path.write_text("/sat2:\n  sail_sim:\n    ros__parameters:\n      sail.n_boom_modes: 6\n")
    assert SailParameters.from_yaml(path).n_boom_modes == 6
    path.write_text("sail_sim:\n  ros__parameters:\n    max_rate: 2.0\n")
    assert SailParameters.from_yaml(path) == SailParameters()
    # the simulator's sections alone, as the simulator and the tools read the file
    path.write_text(
        "sail_recorder:\n  ros__parameters:\n    sail.n_boom_modes: 9\n"
        "sail_sim:\n  ros__parameters:\n    max_rate: 2.0\n"
    )
    assert SailParameters.from_yaml(path).n_boom_modes == 8
    path.write_text("sail_sim:\n  ros__parameters:\n    sail: 4\n")
    with pytest.raises(ValueError, match="sail of sail_sim must be a mapping, got 4"):
        SailParameters.from_yaml(path)


def test_run_time_arguments_are_checked():
    model = SailModel()
    with pytest.raises(ValueError, match=r"lengths must be > 0, got \[10, 0, 10, 10\]"):
        model.matrices([10, 0, 10, 10])
    with pytest.raises(ValueError, match="rates must be a scalar or 4 values"):
        model.matrices(10.0, rates=[1.0, 2.0])
    with pytest.raises(ValueError, match="accelerations must be finite"):
        model.matrices(10.0, accelerations=math.nan)
    with pytest.raises(ValueError, match="boom must be one of a, b, c, d, got 'e'"):
        model.mode_state(boom="e")


def test_cycloidal_profile_closed_form():
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    for t in (0.0, 15.0, 20.0):
        _, rate, accel = profile(t)
        assert np.all(rate == 0) and np.all(accel == 0)
    L, rate, accel = profile(7.5)
    np.testing.assert_allclose(L, 12.5)
    np.testing.assert_allclose(rate, 2 * 5.0 / 15.0)  # peak rate 2 dL / T
    np.testing.assert_allclose(profile(3.75)[2], 2 * math.pi * 5.0 / 15.0**2)  # peak acceleration
    # derivatives are consistent
    h = 1e-6
    np.testing.assert_allclose(
        (profile(4.0 + h)[0] - profile(4.0 - h)[0]) / (2 * h), profile(4.0)[1], rtol=1e-7
    )
    np.testing.assert_allclose(
        (profile(4.0 + h)[1] - profile(4.0 - h)[1]) / (2 * h), profile(4.0)[2], rtol=1e-6
    )
    assert profile.is_static(15.0, 16.0) and not profile.is_static(14.0, 15.5)


def test_cycloidal_within_limits():
    profile = Policy(max_rate=0.5, max_acceleration=0.02).fastest_cycloid(
        10.0, [20.0, 15.0, 10.0, 12.0]
    )
    t = np.linspace(0, profile.duration, 2001)
    rates = np.array([profile(ti)[1] for ti in t])
    accels = np.array([profile(ti)[2] for ti in t])
    assert np.abs(rates).max() <= 0.5 + 1e-12 and np.abs(accels).max() <= 0.02 + 1e-12
    assert max(np.abs(rates).max() / 0.5, np.abs(accels).max() / 0.02) == pytest.approx(
        1.0, rel=1e-4
    )


def test_waypoint_profile_passes_waypoints_with_continuous_rate():
    times = [1.0, 3.0, 4.0, 8.0]
    lengths = np.array(
        [[10, 10, 10, 10], [12, 11, 10, 13], [13, 11, 9, 13], [15, 15, 15, 15]], dtype=float
    )
    profile = WaypointProfile(times, lengths, start_rates=[0.1, 0, 0, 0])
    for t, L in zip(times, lengths, strict=True):
        np.testing.assert_allclose(profile(t)[0], L)
    np.testing.assert_allclose(profile(1.0)[1], [0.1, 0, 0, 0])
    for t in times[1:-1]:
        np.testing.assert_allclose(profile(t - 1e-9)[1], profile(t + 1e-9)[1], atol=1e-6)
    assert profile.is_static(8.0, 9.0) and not profile.is_static(0.5, 1.5)
    low, high, rate, accel = profile.extremes()
    assert np.all(low <= lengths.min(axis=0) + 1e-12) and np.all(
        high >= lengths.max(axis=0) - 1e-12
    )


@pytest.mark.parametrize("kind", ["waypoints", "samples"])
def test_a_profile_from_its_first_time_on_is_its_own_motion(kind):
    """At its first time, and a switch's resolution (1 ns) before it, where a stepper
    enters it as a new piece, a profile gives its own motion (the right-hand limit, the
    spline's or the Hermite's acceleration), not the hold before it: a command's motion
    replayed from its time logged to the nanosecond, on either side of the simulator's
    step end, starts with the acceleration the simulator used."""
    times = [2.0, 3.0, 5.0]
    lengths = np.array([[10.0] * 4, [10.6, 10.4, 10.7, 10.3], [11.5] * 4])
    if kind == "waypoints":
        profile = WaypointProfile(times, lengths, start_rates=0.5)
    else:
        profile = SampledProfile(times, lengths, np.full((3, 4), 0.5))
    just_after = profile(2.0 + 1e-6)
    for t in (2.0, 2.0 - 4e-10):
        lengths_t, rates, accelerations = profile(t)
        np.testing.assert_allclose(lengths_t, lengths[0], atol=1e-9)
        np.testing.assert_allclose(rates, 0.5, atol=1e-8)
        np.testing.assert_allclose(accelerations, just_after[2], rtol=1e-4)
        assert np.abs(accelerations).min() > 0.1
    assert not profile(2.0 - 2e-9)[2].any()  # before it: the hold


@pytest.mark.parametrize(
    ("times", "lengths", "message"),
    [
        ([0.0], [10.0], "times must hold at least 2 values"),
        ([0.0, 0.0], [10.0, 11.0], "times must be finite and strictly increasing"),
        ([0.0, 1.0], [10.0, -1.0], "lengths must be finite and > 0"),
        ([0.0, 1.0], [[10.0, 11.0]], "lengths must have shape"),
    ],
)
def test_waypoint_profile_errors(times, lengths, message):
    with pytest.raises(ValueError, match=message):
        WaypointProfile(times, lengths)


def test_static_profile():
    lengths, rates, accelerations = StaticProfile([10, 11, 12, 13])(5.0)
    np.testing.assert_array_equal(lengths, [10, 11, 12, 13])
    assert not rates.any() and not accelerations.any()


def test_a_motion_over_many_times_is_the_profile_at_each():
    """`profiles.motion_over`: a cycloidal profile, booms of several profiles, and a
    profile without `over` (one call per time) give what the profile gives at each time,
    to the bit, before, during and after the motion."""
    from sail_ros.model.profiles import BoomMotion, motion_over

    times = np.concatenate([np.linspace(-1.0, 17.0, 181), [1.0, 6.0, 16.0]])
    cycloidal = CycloidalProfile([10.0, 11.0, 12.0, 13.0], 15.0, 5.0, t0=1.0)
    slower = CycloidalProfile(10.0, 14.0, 15.0, t0=1.0)
    profiles = [cycloidal, BoomMotion([cycloidal, slower, cycloidal, slower]),
                BoomMotion([cycloidal, StaticProfile(12.0), slower, slower])]  # fmt: skip
    assert hasattr(profiles[2], "over") and profiles[2].over(times) is None  # a static boom
    for profile in profiles:
        found = motion_over(profile, times)
        for part, values in enumerate(found):
            expected = np.array([profile(float(t))[part] for t in times])
            assert values.shape == (times.size, 4) and np.array_equal(values, expected)
