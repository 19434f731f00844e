"""External loads on the sail: the eight inputs of model.md §12 and their checks.

    u = [p_ab, p_bc, p_cd, p_da, F_a, F_b, F_c, F_d]

uniform pressures [Pa] on the quadrants and point forces [N] at the boom
tips, all along +z of the `sail` frame. `SailModel.input_matrix` turns them
into generalised forces, `Q = B_u(L) u`.
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.layout import BOOMS, QUADRANT_NAMES, per_boom

INPUT_NAMES = tuple(f"pressure_{q}" for q in QUADRANT_NAMES) + tuple(
    f"tip_force_{b}" for b in BOOMS
)
INPUT_UNITS = ("Pa",) * 4 + ("N",) * 4
OUTPUT_NAMES = tuple(f"tip_deflection_{b}" for b in BOOMS) + tuple(
    f"root_moment_{b}" for b in BOOMS
)
OUTPUT_UNITS = ("m",) * 4 + ("N m",) * 4
N_INPUTS = len(INPUT_NAMES)
QUADRANT_ORDER = "quadrants ab, bc, cd, da"  # how the errors name the order of pressures


def inputs(pressures=0.0, tip_forces=0.0) -> np.ndarray:
    """The input vector `u` (8,) from per-quadrant pressures [Pa] (a scalar or 4
    values, quadrants ab, bc, cd, da) and per-boom tip forces [N] (a scalar or 4
    values, booms a..d).

    Raises:
        ValueError: a wrong shape or a non-finite value, naming the argument.
    """
    return np.concatenate(
        [
            per_boom(pressures, "pressures", order=QUADRANT_ORDER),
            per_boom(tip_forces, "tip_forces"),
        ]
    )


def input_function(loads):
    """`loads` as a callable `t -> u` (8,), or None for no loads.

    Args:
        loads: None; a constant pair `(pressures, tip_forces)`; or a callable
            `t -> (pressures, tip_forces)`, such as a `LoadSchedule`.

    The result has `switch_times` when they are known (none for constant loads, a
    `LoadSchedule`'s own); a plain callable has none, so a batch run ends its steps
    at the output times, where its switches are to be put.
    """
    if loads is None:
        return None
    if callable(loads):
        return _Inputs(loads) if hasattr(loads, "switch_times") else lambda t: inputs(*loads(t))
    try:
        pressures, tip_forces = loads
    except (TypeError, ValueError):
        raise ValueError(
            f"loads must be None, a pair (pressures, tip_forces) or a callable "
            f"t -> (pressures, tip_forces), got {loads!r}"
        ) from None
    constant = inputs(pressures, tip_forces)
    return _Inputs(lambda t: (constant[:4], constant[4:]), switch_times=())


class _Inputs:
    """Loads `t -> (pressures, tip_forces)` whose switch times are known (`switch_times`,
    where the stepper ends its steps), as `t -> u`."""

    def __init__(self, loads, switch_times=None):
        self._loads = loads
        self.switch_times = tuple(loads.switch_times if switch_times is None else switch_times)

    def __call__(self, t: float) -> np.ndarray:
        return inputs(*self._loads(t))


class LoadSchedule:
    """Piecewise-constant loads: each step sets pressures and/or tip forces from its
    time on, the others held; zero before the first.

    Args:
        steps: `(t, pressures, tip_forces)` with `t` [s] increasing; `pressures`
            or `tip_forces` None keeps the previous values.

    Called with `t` it returns `(pressures, tip_forces)` (4 values each), so it is
    a `loads` of `SailModel.simulate`; `switch_times` are where the loads change
    (the stepper ends steps there).
    """

    def __init__(self, steps):
        self.switch_times: list[float] = []
        self._values: list[tuple[np.ndarray, np.ndarray]] = []
        pressures, forces = np.zeros(4), np.zeros(4)
        for i, (t, new_pressures, new_forces) in enumerate(steps):
            if not np.isfinite(t) or (self.switch_times and t <= self.switch_times[-1]):
                raise ValueError(f"load step {i}: times must be finite and increasing, got {t!r}")
            if new_pressures is not None:
                pressures = per_boom(
                    new_pressures, f"load step {i}: pressures", order="ab, bc, cd, da"
                )
            if new_forces is not None:
                forces = per_boom(new_forces, f"load step {i}: tip_forces")
            self.switch_times.append(float(t))
            self._values.append((pressures, forces))

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        index = int(np.searchsorted(self.switch_times, t, side="right")) - 1
        return self._values[index] if index >= 0 else (np.zeros(4), np.zeros(4))
