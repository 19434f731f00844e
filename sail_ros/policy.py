"""The limits and alarms of the sail's operation: one policy for the simulator and every tool.

What a boom may do (lengths, rates, accelerations), what loads it may take, how
short a boom the integration can afford, how many points a trajectory and how
many samples an offline output may hold, and when the linear model leaves its
range (a tip deflection past a fraction of its boom's length). The simulator
takes its policy from its ROS parameters of the same names; the offline tools
from the same defaults, changed with `--set name=value`. So a command the
simulator refuses is refused by `sail-ros deploy`, `modes`, `plant` and
`stability` alike, with the same words: the field, the value and the range.

A run that leaves the model's range stops with `OutOfRangeError`, whose text is
the simulator's alarm.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_ros.model import SailParameters
from sail_ros.model.fields import check_fields, setting
from sail_ros.model.layout import per_boom

TOLERANCE = 1e-9  # relative slack on the limits, for round-off in the profiles
BOOMS = "abcd"
# offline outputs (time histories held in memory) are refused beyond this, with the estimate
MAX_OUTPUT_BYTES = 1 << 30


class OutOfRangeError(RuntimeError):
    """A run left the linear model's range or became non-finite; the text says where."""


@dataclasses.dataclass(frozen=True)
class Policy:
    """The limits a motion, a load or an output must respect, and the alarms of a run."""

    min_length: float = setting(
        5.0, "m", "shortest boom length a command may ask for or pass through (the simulator "
        "refuses one its model cannot step in real time on the machine)",
        minimum=1e-3, maximum=1e4, read_only=False,
    )  # fmt: skip
    max_length: float = setting(
        0.0, "m", "longest boom length a command may ask for or pass through; 0: the "
        "fully deployed length a/sqrt(2) of the sail", minimum=0.0, maximum=1e4,
        read_only=False,
    )  # fmt: skip
    max_rate: float = setting(
        1.0, "m/s", "largest |extension rate| of a commanded motion", minimum=1e-6,
        maximum=100.0, read_only=False,
    )  # fmt: skip
    max_acceleration: float = setting(
        0.5, "m/s^2", "largest |extension acceleration| of a commanded motion",
        minimum=1e-6, maximum=100.0, read_only=False,
    )  # fmt: skip
    max_trajectory_points: int = setting(
        1000, "-", "most points a boom-length trajectory (a command, or a scenario's "
        "waypoint profile offline) may hold (planning checks the whole spline)", minimum=1,
        maximum=100000, read_only=False,
    )  # fmt: skip
    max_pressure: float = setting(
        0.01, "Pa", "largest |pressure| on a quadrant (solar radiation pressure at 1 AU "
        "is at most 9.1e-6 Pa)", minimum=0.0, maximum=1e3, read_only=False,
    )  # fmt: skip
    max_tip_force: float = setting(
        1.0, "N", "largest |force| at a boom tip", minimum=0.0, maximum=1e4, read_only=False
    )
    max_substep_rate: float = setting(
        3200.0, "1/s", "most sub-steps per second of simulation the shortest allowed boom "
        "may need: its first bending frequency, which the sub-steps resolve, grows like "
        "1/L^2, so this bounds min_length from below", minimum=1.0, maximum=1e7,
        read_only=False,
    )  # fmt: skip
    max_hub_force: float = setting(
        1.0, "N", "largest |force| along z a hub wrench command may set (free hub)",
        minimum=0.0, maximum=1e6, read_only=False,
    )  # fmt: skip
    max_hub_torque: float = setting(
        1.0, "N m", "largest |torque| about x or y a hub wrench command may set (free hub)",
        minimum=0.0, maximum=1e6, read_only=False,
    )  # fmt: skip
    tilt_warn_rad: float = setting(
        0.1, "rad", "a hub tilt beyond this is a warning (free hub): the small-angle model "
        "is leaving its range", minimum=1e-6, maximum=3.0, read_only=False,
    )  # fmt: skip
    tilt_error_rad: float = setting(
        0.3, "rad", "a hub tilt beyond this stops the run (free hub); above tilt_warn_rad",
        minimum=1e-6, maximum=3.0, read_only=False,
    )  # fmt: skip
    tip_warn_fraction: float = setting(
        0.1, "-", "a boom-tip deflection beyond this fraction of its boom's length is a "
        "warning: the linear (small-deflection) model is leaving its range", minimum=1e-6,
        maximum=10.0, read_only=False,
    )  # fmt: skip
    tip_error_fraction: float = setting(
        0.3, "-", "a boom-tip deflection beyond this fraction of its boom's length stops "
        "the run (the results mean nothing beyond); above tip_warn_fraction", minimum=1e-6,
        maximum=10.0, read_only=False,
    )  # fmt: skip

    def __post_init__(self):
        check_fields(self)
        if not self.tilt_warn_rad < self.tilt_error_rad:
            raise ValueError(
                f"tilt_warn_rad ({self.tilt_warn_rad:g}) must be below tilt_error_rad "
                f"({self.tilt_error_rad:g})"
            )
        if not self.tip_warn_fraction < self.tip_error_fraction:
            raise ValueError(
                f"tip_warn_fraction ({self.tip_warn_fraction:g}) must be below "
                f"tip_error_fraction ({self.tip_error_fraction:g})"
            )
        if self.max_length and not self.min_length < self.max_length:
            raise ValueError(
                f"min_length ({self.min_length:g} m) must be below max_length "
                f"({self.max_length:g} m)"
            )

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    def replace(self, **changes) -> Policy:
        return dataclasses.replace(self, **changes)

    # -- lengths and motion ----------------------------------------------------------------

    def length_range(self, sail: SailParameters) -> tuple[float, float]:
        """`[min_length, max_length]` [m] for `sail` (max_length 0: its full length)."""
        return self.min_length, self.max_length or sail.full_boom_length

    def for_sail(self, sail: SailParameters) -> Policy:
        """These limits with max_length 0 resolved: `sail`'s full length [m]."""
        return self.replace(max_length=self.length_range(sail)[1])

    def check_sail(self, sail: SailParameters) -> None:
        """The range of lengths must be one the sail and the integration can have: below
        the longest, and not so short that its booms' sub-steps cost more than
        `max_substep_rate`."""
        low, high = self.length_range(sail)
        if not low < high:
            raise ValueError(
                f"min_length ({low:g} m) must be below max_length ({high:g} m, the fully "
                f"deployed length of a {sail.sail_side:g} m sail when max_length is 0)"
            )
        # here, not at the top: `send` and `watch` use the policy, and start without the
        # model's solvers
        from sail_ros.integrate.control import PHASE_PER_STEP
        from sail_ros.model.sail_model import boom_frequency_bound

        needed = boom_frequency_bound(sail, low) / PHASE_PER_STEP
        if needed > self.max_substep_rate:
            shortest = low * math.sqrt(needed / self.max_substep_rate)  # rate ~ 1/L^2
            raise ValueError(
                f"min_length = {low:g} m would need {needed:.4g} sub-steps per second "
                f"of simulation, more than max_substep_rate = {self.max_substep_rate:g}: the "
                f"shortest affordable min_length here is {math.ceil(shortest * 1e3) / 1e3:g} m"
            )

    def check_length(self, value: float, what: str, sail: SailParameters) -> float:
        """`value` [m] if a boom may have that length, else ValueError naming `what`."""
        low, high = self.length_range(sail)
        if not math.isfinite(value):
            raise ValueError(f"{what} is {value!r}, not a finite length")
        if not low <= value <= high:
            raise ValueError(
                f"{what} = {value:g} m is outside [min_length, max_length] = [{low:g}, {high:g}] m"
            )
        return float(value)

    def check_lengths(self, values, what: str, sail: SailParameters) -> np.ndarray:
        """Per-boom lengths [m] (4), each checked (`what` names them: "lengths")."""
        values = np.asarray(values, dtype=float)
        for boom, value in zip(BOOMS, values, strict=True):
            self.check_length(float(value), f"{what} of boom {boom}", sail)
        return values

    def check_rates(self, rates, what: str = "rates") -> np.ndarray:
        """Per-boom constant extension rates [m/s] (4), each within max_rate."""
        rates = np.asarray(rates, dtype=float)
        for boom, rate in zip(BOOMS, rates, strict=True):
            self.check_rate(float(rate), f"{what} of boom {boom}")
        return rates

    def check_rate(self, rate: float, what: str) -> float:
        """A constant extension rate [m/s] within [-max_rate, max_rate]."""
        if self.motion_excess(None, None, abs(rate), 0.0, None)[2]:
            raise ValueError(
                f"{what} = {rate:g} m/s is outside [-max_rate, max_rate] = "
                f"[{-self.max_rate:g}, {self.max_rate:g}] m/s"
            )
        return float(rate)

    def check_points(self, count: int, what: str = "") -> None:
        """A trajectory of `count` points (waypoints) within max_trajectory_points: refused
        before its spline is built."""
        if count > self.max_trajectory_points:
            prefix = f"{what}: " if what else ""
            raise ValueError(
                f"{prefix}{count} points, more than max_trajectory_points = "
                f"{self.max_trajectory_points}"
            )

    def motion_excess(self, low, high, rate, acceleration, sail: SailParameters | None):
        """Where a motion leaves the limits, from its extremes (arrays of one shape, or
        numbers): `(below min_length, above max_length, above max_rate, above
        max_acceleration)`, each True where it does (a NaN counts as outside). The one
        comparison of a motion with the limits, with the one slack TOLERANCE for round-off
        in the profiles; `sail` None leaves the lengths unchecked (False)."""
        slack = 1.0 + TOLERANCE
        if sail is None:
            short = long = False
        else:
            shortest, longest = self.length_range(sail)
            short = np.logical_not(np.asarray(low) >= shortest / slack)
            long = np.logical_not(np.asarray(high) <= longest * slack)
        fast = np.logical_not(np.asarray(rate) <= self.max_rate * slack)
        sharp = np.logical_not(np.asarray(acceleration) <= self.max_acceleration * slack)
        as_python = (lambda v: bool(v)) if np.ndim(fast) == 0 else (lambda v: v)
        return tuple(as_python(v) for v in (short, long, fast, sharp))

    def motion_fits(self, low, high, rate, acceleration, sail: SailParameters | None):
        """Whether a motion of these extremes keeps within the limits (`motion_excess`),
        element by element."""
        short, long, fast, sharp = self.motion_excess(low, high, rate, acceleration, sail)
        return ~(np.asarray(short) | long | fast | sharp)

    def check_motion(self, profile, sail: SailParameters, booms=range(4), what: str = "") -> None:
        """A motion (a profile with `extremes()`) of the booms at indices `booms`: its
        lengths, |rates| and |accelerations| everywhere within the limits."""
        low, high, rate, acceleration = profile.extremes()
        short, long, fast, sharp = self.motion_excess(low, high, rate, acceleration, sail)
        shortest, longest = self.length_range(sail)
        prefix = f"{what}: " if what else ""
        for k in booms:
            name = f"boom_{BOOMS[k]}"
            if short[k] or long[k]:
                reached = low[k] if short[k] else high[k]
                raise ValueError(
                    f"{prefix}{name} would pass through {reached:.4g} m on the way, outside "
                    f"[min_length, max_length] = [{shortest:g}, {longest:g}] m"
                )
            if fast[k]:
                raise ValueError(
                    f"{prefix}{name} would move at {rate[k]:.4g} m/s, above max_rate "
                    f"{self.max_rate:g} m/s"
                )
            if sharp[k]:
                raise ValueError(
                    f"{prefix}{name} would accelerate at {acceleration[k]:.4g} m/s^2, above "
                    f"max_acceleration {self.max_acceleration:g} m/s^2"
                )

    def fastest_cycloid(self, start, end, t0: float = 0.0):
        """The fastest cycloidal move [m] from `start` to `end` (4 each, or one number)
        from `t0` [s] whose rate and acceleration stay within max_rate and
        max_acceleration (`CycloidalProfile.shortest_duration`)."""
        from sail_ros.model.profiles import CycloidalProfile  # as in check_sail

        travel = float(np.max(np.abs(per_boom(end, "end") - per_boom(start, "start"))))
        duration = CycloidalProfile.shortest_duration(travel, self.max_rate, self.max_acceleration)
        return CycloidalProfile(start, end, duration, t0)

    # -- loads -----------------------------------------------------------------------------

    def check_load(self, name: str, value: float, pressure: bool) -> float:
        """A pressure [Pa] (`pressure`) or tip force [N] named `name`, within its limit."""
        unit, limit_name = ("Pa", "max_pressure") if pressure else ("N", "max_tip_force")
        limit = self.max_pressure if pressure else self.max_tip_force
        value = self.finite_load(name, value, pressure)
        if abs(value) > limit:
            raise ValueError(
                f"|{name}| = {abs(value):g} {unit} exceeds {limit_name} = {limit:g} {unit}"
            )
        return value

    @staticmethod
    def finite_load(name: str, value: float, pressure: bool) -> float:
        """A pressure [Pa] (`pressure`) or tip force [N] named `name`, if finite (what a
        client can check without knowing the simulator's limits)."""
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{name} = {value} {'Pa' if pressure else 'N'} is not finite")
        return value

    # -- alarms of a run -------------------------------------------------------------------

    def check_initial_tips(self, tips, lengths, what: str = "initial tip deflection") -> None:
        """Tip deflections [m] a run may start from: within tip_error_fraction of each
        boom's length [m] (a start beyond would stop the run at once)."""
        for boom, tip, length in zip(BOOMS, np.asarray(tips, float), np.asarray(lengths, float),
                                     strict=True):  # fmt: skip
            if not math.isfinite(tip) or abs(tip) > self.tip_error_fraction * length:
                raise ValueError(
                    f"{what} of boom {boom} = {tip:g} m is outside +-tip_error_fraction x length "
                    f"= +-{self.tip_error_fraction * length:.4g} m (boom length {length:g} m)"
                )

    def range_state(self, tips, lengths, hub=None) -> tuple[str, str]:
        """`(warning, error)` texts of tip deflections [m] at lengths [m] (4 each) and, with
        a free hub, of its state `hub` (z_h, theta_x, theta_y, ...: the tilt
        `|theta|` [rad]): "" while within the warning and error limits."""
        fractions = np.abs(tips) / lengths
        k = int(np.argmax(fractions))
        tilt = float(np.hypot(hub[1], hub[2])) if hub is not None else 0.0
        warn, stop = self.tip_warn_fraction, self.tip_error_fraction
        quiet = not (fractions[k] > warn or fractions[k] > stop)  # every step: no text
        if quiet and not tilt > self.tilt_warn_rad:
            if np.isfinite(fractions[k]) and np.isfinite(tilt):
                return "", ""
            return "", f"state became non-finite (tip deflection of boom {BOOMS[k]})"
        warning, error = "", ""
        if not quiet:
            reason = (
                f"tip deflection of boom {BOOMS[k]} is {fractions[k]:.3g} of its length "
                f"({fractions[k] * lengths[k]:.4g} m of {lengths[k]:.4g} m)"
            )
            if fractions[k] > stop:
                error = f"{reason}, beyond tip_error_fraction {stop:g}: out of the linear range"
            else:
                warning = f"{reason}, beyond tip_warn_fraction {warn:g}"
        if tilt > self.tilt_warn_rad and not error:
            reason = f"hub tilt is {tilt:.3g} rad"
            if tilt > self.tilt_error_rad:
                error = f"{reason}, beyond tilt_error_rad {self.tilt_error_rad:g}: out of the "
                error += "small-angle range"
            elif not warning:
                warning = f"{reason}, beyond tilt_warn_rad {self.tilt_warn_rad:g}"
        return ("", error) if error else (warning, "")

    def check_hub_wrench(self, force_z: float, torque_x: float, torque_y: float) -> None:
        """A hub wrench [N, N m, N m] within max_hub_force and max_hub_torque."""
        for name, value, limit, limit_name, unit in (
            ("force.z", force_z, self.max_hub_force, "max_hub_force", "N"),
            ("torque.x", torque_x, self.max_hub_torque, "max_hub_torque", "N m"),
            ("torque.y", torque_y, self.max_hub_torque, "max_hub_torque", "N m"),
        ):
            if not np.isfinite(value):
                raise ValueError(f"{name} = {value} {unit} is not finite")
            if abs(value) > limit:
                raise ValueError(
                    f"|{name}| = {abs(value):g} {unit} exceeds {limit_name} = {limit:g} {unit}"
                )

    # -- offline outputs -------------------------------------------------------------------

    @staticmethod
    def check_output(
        samples: int,
        bytes_per_sample: int,
        what: str,
        fewer: str = "a shorter duration or a lower output rate",
    ) -> None:
        """An offline output of `samples` samples must fit in MAX_OUTPUT_BYTES; refused
        with the estimate before anything is allocated (`fewer`: how to ask for less)."""
        size = float(samples) * bytes_per_sample
        if size > MAX_OUTPUT_BYTES:
            raise ValueError(
                f"{what}: {samples:.4g} samples would take {size / 2**30:.3g} GiB, more than "
                f"the {MAX_OUTPUT_BYTES / 2**30:g} GiB an offline output may hold (fewer "
                f"samples: {fewer})"
            )
