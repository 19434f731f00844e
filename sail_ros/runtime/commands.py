"""Commands checked against the policy and turned into boom motion or loads, without ROS.

Two motion commands (msg_docs/boom_length_cmd.md, msg_docs/deploy_cmd.md):

* a trajectory (`trajectory_msgs/JointTrajectory`-like: `joint_names`,
  `points[i].positions`, `points[i].time_from_start`): the named booms
  follow a cubic spline from their current length and rate through the
  points, and stop at the last one (`WaypointProfile`); the other booms
  carry on as before;
* a deployment target (m) for all four booms: from rest the cycloidal
  profile of model.md §9, the fastest within the rate and acceleration
  limits (or of a fixed duration); while the booms move, a cubic from their
  current length and rate to rest at the target, again the fastest within
  the limits.

and two load commands (msg_docs/pressure_cmd.md, msg_docs/tip_force_cmd.md):
`sensor_msgs/JointState`-like messages naming what they load (`quadrant_ab`
... / `boom_a` ...) with the value in `effort` (Pa / N, +z of the sail frame);
named values change, the others are held.

Every limit is the policy's (`sail_ros.policy.Policy`, the same for the offline
tools). A command is accepted whole or rejected whole: `CommandError` says why,
and nothing of it is used.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

# loaded with the simulator: a first waypoint command would otherwise wait, inside a
# real-time step, for the import of scipy.interpolate (and scipy.optimize) that
# `WaypointProfile` leaves to where it is first used (~0.3 s)
import scipy.interpolate  # noqa: F401

from sail_ros.model import CycloidalProfile, SailParameters, WaypointProfile
from sail_ros.names import BOOM_JOINTS, LOAD_NAMES, PRESSURE_CMD
from sail_ros.policy import Policy

# Candidate durations of a deployment that starts while the booms move:
# T_rest * GROWTH**k, k = -DURATION_STEPS_DOWN .. DURATION_STEPS_UP.
GROWTH = 1.1
DURATION_STEPS_DOWN, DURATION_STEPS_UP = 20, 60


class CommandError(ValueError):
    """A command that cannot be followed; the message is the reason."""


class BoomState(NamedTuple):
    """Where the booms are at time `t` [s]: lengths [m], rates [m/s],
    accelerations [m/s^2], 4 values each (booms a..d)."""

    t: float
    lengths: np.ndarray
    rates: np.ndarray
    accelerations: np.ndarray


@dataclasses.dataclass(frozen=True)
class Rules:
    """What a command must respect: the policy, for this sail (its full boom length
    bounds `max_length` 0)."""

    policy: Policy
    sail: SailParameters

    def check(self, check, *args, **kwargs):
        """`check(*args, **kwargs)` (a `Policy` method), its ValueError a CommandError."""
        try:
            return check(*args, **kwargs)
        except ValueError as error:
            raise CommandError(str(error)) from None


@dataclasses.dataclass(frozen=True)
class Plan:
    """An accepted command.

    Attributes:
        profile: the motion of the booms in `booms` (a 4-boom profile).
        booms: indices (0 = a) of the booms that follow `profile`.
        t_start, t_end: when the motion starts and ends [s].
        summary: one line for the log.
    """

    profile: object
    booms: tuple[int, ...]
    t_start: float
    t_end: float
    summary: str


def plan_trajectory(trajectory, now: BoomState, rules: Rules) -> Plan:
    """Check a JointTrajectory-like command and make its motion.

    The trajectory starts at `now.t` whatever its header stamp; point times
    are `time_from_start` after that.

    Raises:
        CommandError: unknown or repeated joint names, no points, a point
            whose positions do not match the names, velocities/accelerations/
            effort given (the spline sets them), times not > 0 and strictly
            increasing, a non-finite length, a length outside the limits, or
            a motion (spline overshoot included) beyond the limits.
    """
    names = list(trajectory.joint_names)
    if not names:
        raise CommandError("no joint_names: name at least one of " + ", ".join(BOOM_JOINTS))
    unknown = [name for name in names if name not in BOOM_JOINTS]
    if unknown:
        raise CommandError(
            f"unknown joint name(s) {', '.join(map(repr, unknown))}; "
            f"known: {', '.join(BOOM_JOINTS)}"
        )
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise CommandError(f"joint name(s) {', '.join(map(repr, repeated))} given more than once")
    rules.check(rules.policy.check_points, len(trajectory.points))
    points = list(trajectory.points)
    if not points:
        raise CommandError("no points")
    booms = tuple(BOOM_JOINTS.index(name) for name in names)
    times, rows = [now.t], [np.array(now.lengths, dtype=float)]
    previous = 0.0  # time_from_start of the point before [s]
    for i, point in enumerate(points):
        positions = list(point.positions)
        if len(positions) != len(names):
            raise CommandError(
                f"point {i} has {len(positions)} positions for {len(names)} joint names"
            )
        for field in ("velocities", "accelerations", "effort"):
            if len(getattr(point, field)):
                raise CommandError(
                    f"point {i}: {field} are not supported (leave them "
                    "empty; the booms follow a spline through the positions)"
                )
        offset = point.time_from_start.sec + point.time_from_start.nanosec * 1e-9
        if offset <= previous:
            raise CommandError(
                f"point {i}: time_from_start {offset:g} s must be > "
                + ("0" if i == 0 else f"that of point {i - 1} ({previous:g} s)")
            )
        previous = offset
        for name, value in zip(names, positions, strict=True):
            rules.check(rules.policy.check_length, value, f"point {i}: {name}", rules.sail)
        row = rows[0].copy()
        row[list(booms)] = positions
        times.append(now.t + offset)
        rows.append(row)
    start_rates = np.zeros(4)
    start_rates[list(booms)] = np.asarray(now.rates)[list(booms)]
    profile = WaypointProfile(times, np.array(rows), start_rates=start_rates)
    rules.check(rules.policy.check_motion, profile, rules.sail, booms)
    return Plan(
        profile,
        booms,
        now.t,
        times[-1],
        f"trajectory for {', '.join(names)}: {len(points)} point(s) over {times[-1] - now.t:g} s",
    )


def plan_deploy(target: float, now: BoomState, rules: Rules, duration: float = 0.0) -> Plan:
    """Check a deployment target [m] for all four booms and make its motion.

    Args:
        target: final length of every boom [m].
        now: the booms' state when the command arrives.
        rules: what the motion must respect.
        duration: the deployment's duration [s]; 0 for the fastest within the limits.

    Raises:
        CommandError: `target` not finite or outside the limits, or no
            motion of the given duration (or of any duration tried) within
            the limits.
    """
    rules.check(rules.policy.check_length, target, "target", rules.sail)
    policy = rules.policy
    lengths = np.asarray(now.lengths, dtype=float)
    at_rest = not (np.any(now.rates) or np.any(now.accelerations))
    fixed = duration > 0.0
    if at_rest:
        if fixed:
            profile = CycloidalProfile(lengths, target, duration, t0=now.t)
            _, _, rates, accelerations = profile.extremes()
            peak_rate, peak_acceleration = float(np.max(rates)), float(np.max(accelerations))
            if not policy.motion_fits(None, None, peak_rate, peak_acceleration, None):
                raise CommandError(
                    f"a {duration:g} s deployment to {target:g} m needs {peak_rate:.4g} m/s and "
                    f"{peak_acceleration:.4g} m/s^2; limits {policy.max_rate:g} m/s, "
                    f"{policy.max_acceleration:g} m/s^2 (raise deploy_duration, or set it "
                    "to 0 for the fastest allowed)"
                )
        else:
            profile = policy.fastest_cycloid(lengths, target, t0=now.t)
        kind = "cycloidal"
    else:
        profile = _moving_deploy(target, now, rules, duration if fixed else None)
        kind = "cubic from the current rates"
    return Plan(
        profile,
        (0, 1, 2, 3),
        now.t,
        profile.t_end,
        f"deploy to {target:g} m: {kind} over {profile.t_end - now.t:.4g} s",
    )


def _moving_deploy(target: float, now: BoomState, rules: Rules, duration: float | None):
    """The quickest cubic from the current lengths and rates to rest at `target`
    that keeps within `limits` (or the one of the given `duration`)."""
    if duration is not None:
        candidates = [duration]
    else:
        # the time to go there from rest, or to stop the fastest boom, sets the scale
        policy = rules.policy
        base = max(
            policy.fastest_cycloid(now.lengths, target).duration,
            2.0 * float(np.max(np.abs(now.rates))) / policy.max_acceleration,
        )
        candidates = [base * GROWTH**k for k in range(-DURATION_STEPS_DOWN, DURATION_STEPS_UP)]
    lengths, rates = np.asarray(now.lengths, dtype=float), np.asarray(now.rates, dtype=float)
    fits = _cubic_fits(lengths, rates, target, np.asarray(candidates), rules)
    # the quickest that fits (checked once more as every motion is), or the longest, whose
    # check says why none fits
    length = candidates[int(np.argmax(fits))] if fits.any() else candidates[-1]
    profile = WaypointProfile(
        [now.t, now.t + length], [lengths, np.full(4, target)], start_rates=rates
    )
    try:
        rules.check(rules.policy.check_motion, profile, rules.sail)
    except CommandError as error:
        tried = (
            f"{duration:g} s"
            if duration is not None
            else f"{candidates[0]:.3g} to {candidates[-1]:.3g} s"
        )
        raise CommandError(
            f"no deployment to {target:g} m from the current motion within the "
            f"limits (durations {tried}; e.g. {error})"
        ) from None
    return profile


def _cubic_fits(lengths, rates, target: float, durations, rules: Rules) -> np.ndarray:
    """For each duration T [s] (d,), whether the cubic from `lengths` [m] and `rates`
    [m/s] (4,) to rest at `target` [m] in T keeps every boom within the limits, from its
    exact extremes: with s = (t - t0) / T, L = a0 + a1 s + a2 s^2 + a3 s^3 (a1 = v0 T),
    the rate `L'(s) / T` is largest at an end or at its vertex, the acceleration
    `L''(s) / T^2` at an end, and the lengths at the ends or where the rate is 0."""
    T = durations[:, None]  # (d, 1) against the 4 booms
    a0, a1 = lengths[None, :], rates[None, :] * T
    a2 = 3.0 * (target - a0) - 2.0 * a1
    a3 = 2.0 * (a0 - target) + a1
    acceleration = np.maximum(np.abs(2 * a2), np.abs(2 * a2 + 6 * a3)) / T**2
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(a3 != 0, -a2 / (3 * a3), -1.0)
        inside = (vertex > 0) & (vertex < 1)
        peak_rate = np.where(inside, np.abs(a1 + a2 * vertex), 0.0) / T
        rate = np.maximum(np.abs(rates)[None, :], peak_rate)
        # where the rate is 0: a1 + 2 a2 s + 3 a3 s^2 = 0
        root = np.sqrt(np.maximum(a2 * a2 - 3 * a1 * a3, 0.0))
        stationary = [(-a2 + sign * root) / (3 * a3) for sign in (1.0, -1.0)]
    low = np.minimum(a0, target)
    high = np.maximum(a0, target)
    for s in stationary:
        ok = np.isfinite(s) & (s > 0) & (s < 1)
        s = np.where(ok, s, 0.0)
        value = a0 + a1 * s + a2 * s**2 + a3 * s**3
        low, high = (
            np.where(ok, np.minimum(low, value), low),
            np.where(ok, np.maximum(high, value), high),
        )
    return rules.policy.motion_fits(low, high, rate, acceleration, rules.sail).all(axis=1)


class LoadChange(NamedTuple):
    """An accepted load command: the new values (4,) of the loaded kind, a summary, and
    when they act [s of simulation time] (None: from the model's time on)."""

    values: np.ndarray
    summary: str
    t_start: float | None = None


# the furthest ahead of the model a hub wrench's header stamp may ask it to act: further,
# the stamp is of another clock than the simulator's, and the command is refused
MAX_COMMAND_LEAD_S = 1.0


def plan_load(topic: str, message, current: np.ndarray, rules: Rules) -> LoadChange:
    """The loads after `message` on `topic` (PRESSURE_CMD or TIP_FORCE_CMD).

    Args:
        topic: which load command.
        message: a JointState-like object with `name` and `effort`.
        current: the values held now (4,), [Pa] or [N].
        rules: the limits (`max_pressure` [Pa] / `max_tip_force` [N]).

    Raises:
        CommandError: why the command is refused; nothing changes.
    """
    known = LOAD_NAMES[topic]
    pressure = topic == PRESSURE_CMD
    unit = "Pa" if pressure else "N"
    names, values = list(message.name), list(message.effort)
    if not names:
        raise CommandError(f"names nothing to load; names are {', '.join(known)}")
    if len(values) != len(names):
        raise CommandError(
            f"has {len(names)} name(s) but {len(values)} effort value(s): one value per name"
        )
    unknown = [name for name in names if name not in known]
    if unknown:
        raise CommandError(
            f"unknown name(s) {', '.join(map(repr, unknown))}; names are {', '.join(known)}"
        )
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise CommandError(f"names {', '.join(repeated)} more than once")
    new = np.array(current, dtype=float)
    for name, value in zip(names, values, strict=True):
        new[known.index(name)] = rules.check(rules.policy.check_load, name, value, pressure)
    summary = ", ".join(f"{name} = {new[known.index(name)]:g} {unit}" for name in names)
    return LoadChange(new, summary + " (others held)" if len(names) < 4 else summary)


def plan_hub_wrench(
    message,
    rules: Rules,
    frame_id: str,
    free_hub: bool,
    now: float = 0.0,
    at: float | None = None,
) -> LoadChange:
    """The hub wrench `(F_z [N], tau_x, tau_y [N m])` of a `sail/hub_wrench_cmd`
    (`geometry_msgs/WrenchStamped`-like) in frame `frame_id` (or no frame), acting from
    `at` [s of simulation time, its header stamp's] when that is later than the model's
    time `now` [s] (a controller's command for a loop delay), else from `now`.

    Raises:
        CommandError: the hub is clamped; a held axis (force.x, force.y, torque.z) is not
            zero (the holds would absorb it without a word); another frame; a value not
            finite or beyond max_hub_force / max_hub_torque; a stamp more than
            MAX_COMMAND_LEAD_S ahead of the model.
    """
    if not free_hub:
        raise CommandError("the hub is clamped (sail.free_hub = false): no hub wrench")
    frame = message.header.frame_id
    if frame not in ("", frame_id):
        raise CommandError(f"header.frame_id is {frame!r}: give the wrench in {frame_id!r}")
    force, torque = message.wrench.force, message.wrench.torque
    held = {"force.x": force.x, "force.y": force.y, "torque.z": torque.z}
    for name, value in held.items():
        if value != 0.0:
            raise CommandError(
                f"{name} = {value:g}: the hub is held in the sail plane and about z (model.md "
                "§13.1); only force.z, torque.x and torque.y act"
            )
    values = np.array([force.z, torque.x, torque.y], dtype=float)
    rules.check(rules.policy.check_hub_wrench, *values)
    summary = f"hub force_z = {values[0]:g} N, torque_x = {values[1]:g} N m, torque_y = "
    summary += f"{values[2]:g} N m"
    if at is None or at <= now + 1e-9:
        return LoadChange(values, summary)
    if at > now + MAX_COMMAND_LEAD_S:
        raise CommandError(
            f"header.stamp is {at - now:.6g} s ahead of the simulation (more than "
            f"{MAX_COMMAND_LEAD_S:g} s): a stamp of another clock? Leave it 0 to act at once"
        )
    return LoadChange(values, f"{summary} from t = {at:.6f} s", at)
