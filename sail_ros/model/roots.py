"""A bracketed root of a scalar function, by Brent's method (inverse quadratic
extrapolation, secant steps and bisection).

The model solves two frequency equations once per process (`basis`); this keeps
`scipy.optimize`, whose import costs a fifth of a second, out of the tools and nodes
that make no spline (the simulator loads it with scipy.interpolate, for waypoints).
The steps are those of scipy's `brentq` (its C routine, the same floating-point
operations in the same order), so a root is the same to the last bit:
`test/model/test_basis.py` holds it to that.
"""

from __future__ import annotations

from collections.abc import Callable


def bracketed_root(
    f: Callable[[float], float],
    low: float,
    high: float,
    xtol: float,
    rtol: float,
    max_iterations: int = 100,
) -> float:
    """The root of `f` in `[low, high]` (`f(low)` and `f(high)` of opposite signs, or
    one of them 0), to within `xtol + rtol |x|`.

    Raises:
        ValueError: `f` has the same sign at both ends, or the root is not found to
            the tolerance in `max_iterations`.
    """
    previous, current = float(low), float(high)
    f_previous, f_current = float(f(previous)), float(f(current))
    if f_previous * f_current > 0:
        raise ValueError(f"f has the same sign at {low!r} and {high!r}")
    if f_previous == 0:
        return previous
    if f_current == 0:
        return current
    # `current` the best estimate, `previous` the one before it, `block` the point
    # across the root from `current`; `step`, `step_before` the last two steps taken
    block = f_block = step = step_before = 0.0
    for _ in range(max_iterations):
        if f_previous * f_current < 0:  # the root between the last two: they bracket it
            block, f_block = previous, f_previous
            step = step_before = current - previous
        if abs(f_block) < abs(f_current):  # the best estimate is the smaller value
            previous, current, block = current, block, current
            f_previous, f_current, f_block = f_current, f_block, f_current
        delta = (xtol + rtol * abs(current)) / 2
        halfway = (block - current) / 2
        if f_current == 0 or abs(halfway) < delta:
            return current
        if abs(step_before) > delta and abs(f_current) < abs(f_previous):
            if previous == block:  # two points: the secant
                trial = -f_current * (current - previous) / (f_current - f_previous)
            else:  # three: inverse quadratic extrapolation
                slope_previous = (f_previous - f_current) / (previous - current)
                slope_block = (f_block - f_current) / (block - current)
                trial = (
                    -f_current
                    * (f_block * slope_block - f_previous * slope_previous)
                    / (slope_block * slope_previous * (f_block - f_previous))
                )
            if 2 * abs(trial) < min(abs(step_before), 3 * abs(halfway) - delta):
                step_before, step = step, trial  # a short step that converges
            else:
                step_before = step = halfway
        else:
            step_before = step = halfway
        previous, f_previous = current, f_current
        if abs(step) > delta:
            current += step
        else:
            current += delta if halfway > 0 else -delta
        f_current = float(f(current))
    raise ValueError(
        f"no root to {xtol:g} + {rtol:g} |x| in {max_iterations} iterations (at {current!r})"
    )
