"""External loads on the sail: the inputs of model.md §12 and §13.5 and their checks.

    u = [p_ab, p_bc, p_cd, p_da, F_a, F_b, F_c, F_d]                    (clamped hub)
    u = [p_ab, p_bc, p_cd, p_da, F_a, F_b, F_c, F_d, F_z, tau_x, tau_y]  (free hub)

uniform pressures [Pa] on the quadrants and point forces [N] at the boom
tips, all along +z of the `sail` frame, then the hub wrench: a force [N] along
z and torques [N m] about x and y. `SailModel.input_matrix` turns them into
generalised forces, `Q = B_u(L) u`.
"""

from __future__ import annotations

import bisect

import numpy as np

from sail_ros.model.layout import BOOMS, HUB_COORDINATES, QUADRANT_NAMES, fixed_values, per_boom

INPUT_NAMES = tuple(f"pressure_{q}" for q in QUADRANT_NAMES) + tuple(
    f"tip_force_{b}" for b in BOOMS
)
INPUT_UNITS = ("Pa",) * 4 + ("N",) * 4
OUTPUT_NAMES = tuple(f"tip_deflection_{b}" for b in BOOMS) + tuple(
    f"root_moment_{b}" for b in BOOMS
)
OUTPUT_UNITS = ("m",) * 4 + ("N m",) * 4
N_INPUTS = len(INPUT_NAMES)
# a free hub's inputs and outputs, after the ones above (model.md §13.5)
HUB_INPUT_NAMES = ("hub_force_z", "hub_torque_x", "hub_torque_y")
HUB_INPUT_UNITS = ("N", "N m", "N m")
HUB_OUTPUT_NAMES = HUB_COORDINATES + ("hub_heave_rate", "hub_tilt_rate_x", "hub_tilt_rate_y")
HUB_OUTPUT_UNITS = ("m", "rad", "rad", "m/s", "rad/s", "rad/s")
QUADRANT_ORDER = "quadrants ab, bc, cd, da"  # how the errors name the order of pressures
CLAMPED = "the hub is clamped (free_hub = False)"


def hub_wrench_vector(value, name: str = "hub_wrench", free_hub: bool = True) -> np.ndarray:
    """`(F_z [N], tau_x [N m], tau_y [N m])` as 3 floats (a scalar: that on all three).

    Raises:
        ValueError: a wrong shape or a non-finite value, naming `name`; or, with a
            clamped hub, a non-zero value.
    """
    array = fixed_values(value, name, 3, "F_z, tau_x, tau_y")
    if not free_hub and array.any():
        raise ValueError(f"{name} = {value!r}: {CLAMPED}")
    return array


def inputs(pressures=0.0, tip_forces=0.0, hub_wrench=None, free_hub: bool = False):
    """The input vector `u` from per-quadrant pressures [Pa] (a scalar or 4 values,
    quadrants ab, bc, cd, da), per-boom tip forces [N] (a scalar or 4 values, booms
    a..d) and, for a free hub, the hub wrench `(F_z, tau_x, tau_y)` [N, N m, N m]:
    (8,) with a clamped hub, (11,) with a free one.

    Raises:
        ValueError: a wrong shape or a non-finite value, naming the argument; a
            non-zero hub wrench on a clamped hub.
    """
    if hub_wrench is None and not free_hub:
        u = _four_and_four(pressures, tip_forces)
        if u is not None:
            return u
    parts = [
        per_boom(pressures, "pressures", order=QUADRANT_ORDER),
        per_boom(tip_forces, "tip_forces"),
    ]
    if hub_wrench is not None or free_hub:
        wrench = hub_wrench_vector(0.0 if hub_wrench is None else hub_wrench, free_hub=free_hub)
        if free_hub:
            parts.append(wrench)
    return np.concatenate(parts)


def _four_and_four(pressures, tip_forces) -> np.ndarray | None:
    """The usual clamped hub's `u`, 4 finite values of each checked in one pass; None for
    anything else (`inputs` then says what is wrong)."""
    try:
        p, f = np.asarray(pressures, dtype=float), np.asarray(tip_forces, dtype=float)
    except (TypeError, ValueError):
        return None
    if p.shape != (4,) or f.shape != (4,):
        return None
    u = np.concatenate((p, f))
    return u if np.isfinite(u).all() else None


def input_function(loads, free_hub: bool = False):
    """`loads` as a callable `t -> u` ((8,) clamped, (11,) free hub), or None for no
    loads.

    Args:
        loads: None; a constant pair `(pressures, tip_forces)` or triple
            `(pressures, tip_forces, hub_wrench)`; or a callable `t ->` either, such as a
            `LoadSchedule`.
        free_hub: whether the hub is free (else a non-zero hub wrench is refused).

    The result's values are checked (`checked`: 1-D, finite). It has `switch_times` when
    they are known (none for constant loads, a `LoadSchedule`'s own); a plain callable
    has none, and the stepper finds its jumps (`StepControl.locate_jump`).
    """
    if loads is None:
        return None
    if isinstance(loads, LoadSchedule) and type(loads).__call__ is LoadSchedule.__call__:
        return loads.input_function(free_hub)  # its values were checked when it was made
    if callable(loads):

        def u(t):
            return inputs(*_unpack(loads(t)), free_hub=free_hub)

        u.checked = True
        switches = getattr(loads, "switch_times", None)
        return u if switches is None else _Inputs(u, switches)
    constant = inputs(*_unpack(loads), free_hub=free_hub)
    return _Inputs(lambda t: constant, ())


class _Inputs:
    """Inputs `t -> u` whose switch times [s] are known (`switch_times`, where the
    stepper ends its steps)."""

    checked = True  # each `u` a 1-D array of finite values (`SailStepper` asks)

    def __init__(self, u, switch_times):
        self._u = u
        self.switch_times = tuple(switch_times)

    def __call__(self, t: float) -> np.ndarray:
        return self._u(t)


def _unpack(loads) -> tuple:
    """`(pressures, tip_forces, hub_wrench or None)` of a pair or a triple."""
    try:
        items = tuple(loads)
    except TypeError:
        items = ()
    if len(items) not in (2, 3):
        raise ValueError(
            f"loads must be None, a pair (pressures, tip_forces), a triple (pressures, "
            f"tip_forces, hub_wrench) or a callable t -> either, got {loads!r}"
        )
    return items if len(items) == 3 else (*items, None)


class LoadSchedule:
    """Piecewise-constant loads: each step sets pressures, tip forces and/or the hub
    wrench from its time on, the others held; zero before the first.

    Args:
        steps: `(t, pressures, tip_forces)` or `(t, pressures, tip_forces,
            hub_wrench)` with `t` [s] increasing; a value None keeps the previous
            one. `hub_wrench` is `(F_z [N], tau_x [N m], tau_y [N m])`.

    Called with `t` it returns `(pressures, tip_forces)` (4 values each), or, when a
    step has a hub wrench, `(pressures, tip_forces, hub_wrench)`, so it is a `loads`
    of `SailModel.simulate`; `switch_times` are where the loads change (the stepper
    ends steps there).
    """

    def __init__(self, steps):
        self.switch_times: list[float] = []
        pressures, forces, wrench = np.zeros(4), np.zeros(4), np.zeros(3)
        # the values from each switch time on, after those before the first (zero)
        self._values: list[tuple[np.ndarray, ...]] = [(pressures, forces, wrench)]
        self._with_hub = False
        for i, step in enumerate(steps):
            if len(step) not in (3, 4):
                raise ValueError(
                    f"load step {i}: expected (t, pressures, tip_forces[, hub_wrench]), "
                    f"got {step!r}"
                )
            t, new_pressures, new_forces, *new_wrench = step
            if not np.isfinite(t) or (self.switch_times and t <= self.switch_times[-1]):
                raise ValueError(f"load step {i}: times must be finite and increasing, got {t!r}")
            if new_pressures is not None:
                pressures = per_boom(
                    new_pressures, f"load step {i}: pressures", order="ab, bc, cd, da"
                )
            if new_forces is not None:
                forces = per_boom(new_forces, f"load step {i}: tip_forces")
            if new_wrench and new_wrench[0] is not None:
                wrench = hub_wrench_vector(new_wrench[0], f"load step {i}: hub_wrench")
                self._with_hub = True
            self.switch_times.append(float(t))
            self._values.append((pressures, forces, wrench))

    def __call__(self, t: float) -> tuple[np.ndarray, ...]:
        values = self._values[bisect.bisect_right(self.switch_times, t)]
        return values if self._with_hub else values[:2]

    def input_function(self, free_hub: bool = False) -> _Inputs:
        """`input_function` of this schedule: each step's input vector made once (a
        stepper asks for the inputs several times a step)."""
        vectors = [inputs(*values, free_hub=free_hub) for values in self._values]
        for vector in vectors:  # shared by every call: no caller may change them
            vector.flags.writeable = False
        times = self.switch_times

        def u(t):
            return vectors[bisect.bisect_right(times, t)]

        return _Inputs(u, times)
