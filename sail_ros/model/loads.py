"""External loads on the sail: the eight inputs of model.md §12 and their checks.

    u = [p_ab, p_bc, p_cd, p_da, F_a, F_b, F_c, F_d]

uniform pressures [Pa] on the quadrants and point forces [N] at the boom
tips, all along +z of the `sail` frame. `SailModel.input_matrix` turns them
into generalised forces, `Q = B_u(L) u`.
"""

from __future__ import annotations

import numpy as np

from sail_ros.model.layout import BOOMS, QUADRANT_NAMES

INPUT_NAMES = tuple(f"pressure_{q}" for q in QUADRANT_NAMES) + tuple(
    f"tip_force_{b}" for b in BOOMS
)
INPUT_UNITS = ("Pa",) * 4 + ("N",) * 4
OUTPUT_NAMES = tuple(f"tip_deflection_{b}" for b in BOOMS) + tuple(
    f"root_moment_{b}" for b in BOOMS
)
OUTPUT_UNITS = ("m",) * 4 + ("N m",) * 4
N_INPUTS = len(INPUT_NAMES)


def inputs(pressures=0.0, tip_forces=0.0) -> np.ndarray:
    """The input vector `u` (8,) from per-quadrant pressures [Pa] (a scalar or 4
    values, quadrants ab, bc, cd, da) and per-boom tip forces [N] (a scalar or 4
    values, booms a..d).

    Raises:
        ValueError: a wrong shape or a non-finite value, naming the argument.
    """
    return np.concatenate(
        [
            _four(pressures, "pressures", "quadrants ab, bc, cd, da"),
            _four(tip_forces, "tip_forces", "booms a, b, c, d"),
        ]
    )


def _four(value, name: str, order: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is not None and array.ndim == 0:
        array = np.full(4, float(array))
    if array is None or array.shape != (4,):
        raise ValueError(f"{name} must be a scalar or 4 values ({order}), got {value!r}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return array


def input_function(loads):
    """`loads` as a callable `t -> u` (8,), or None for no loads.

    Args:
        loads: None; a constant pair `(pressures, tip_forces)`; or a callable
            `t -> (pressures, tip_forces)`.
    """
    if loads is None:
        return None
    if callable(loads):
        return lambda t: inputs(*loads(t))
    try:
        pressures, tip_forces = loads
    except (TypeError, ValueError):
        raise ValueError(
            f"loads must be None, a pair (pressures, tip_forces) or a callable "
            f"t -> (pressures, tip_forces), got {loads!r}"
        ) from None
    constant = inputs(pressures, tip_forces)
    return lambda t: constant
