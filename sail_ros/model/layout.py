"""Where every boom, quadrant and generalised coordinate sits (model.md §1, §6).

The bottom of the model: names and index arithmetic only, no physics. The
system coordinates are ordered

    q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]

with `n_B` cantilever coordinates per boom and `n_M` triangle coordinates per
quadrant; quadrant `xy` spans the booms `x` (first) and `y` (second).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

BOOMS = ("a", "b", "c", "d")


class Quadrant(NamedTuple):
    """A membrane quadrant: its name and the indices (0 = a) of its two booms."""

    name: str
    first: int
    second: int


# model.md §1 and Tab. 1: the first boom of a quadrant is the one named first
QUADRANTS = (Quadrant("ab", 0, 1), Quadrant("bc", 1, 2), Quadrant("cd", 2, 3), Quadrant("da", 3, 0))
QUADRANT_NAMES = tuple(quadrant.name for quadrant in QUADRANTS)


def per_boom(
    value, name: str, positive: bool = False, order: str = "booms a, b, c, d"
) -> np.ndarray:
    """A scalar (all four) or 4 values (in `order`: booms, or quadrants for their
    loads) as a float array of 4.

    Raises:
        ValueError: naming `name` and the value, when it is not numbers, the shape
            is wrong, a value is not finite, or (with `positive`) a value is <= 0.
    """
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
    if positive and np.any(array <= 0.0):
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return array


def boom_index(boom: str) -> int:
    """0 for boom "a" ... 3 for "d" (ValueError for any other name)."""
    if boom not in BOOMS:
        raise ValueError(f"boom must be one of a, b, c, d, got {boom!r}")
    return BOOMS.index(boom)


def quadrant_index(quadrant: str) -> int:
    """0 for quadrant "ab" ... 3 for "da" (ValueError for any other name)."""
    if quadrant not in QUADRANT_NAMES:
        raise ValueError(f"quadrant must be one of {', '.join(QUADRANT_NAMES)}, got {quadrant!r}")
    return QUADRANT_NAMES.index(quadrant)


@functools.cache
def triangle_mode_indices(n: int) -> tuple[tuple[int, int], ...]:
    """Index pairs `(m, n)`, `m > n >= 1`, of the first `n` clamped-triangle modes.

    Ordered by `(m^2 + n^2, m)` ascending: (2,1), (3,1), (3,2), (4,1), ...
    (the order of the membrane coordinates and of `basis.triangle_modes`).
    """
    pairs = []
    m_max = 2
    while True:
        pairs = sorted(
            ((m, k) for m in range(2, m_max + 1) for k in range(1, m)),
            key=lambda mk: (mk[0] ** 2 + mk[1] ** 2, mk[0]),
        )
        # every pair with m > m_max has m^2 + n^2 > m_max^2: the first n are final
        if len(pairs) >= n and pairs[n - 1][0] ** 2 + pairs[n - 1][1] ** 2 <= m_max**2:
            return tuple(pairs[:n])
        m_max += 1


class Layout:
    """Slices and names of the generalised coordinates for `(n_B, n_M)`.

    Args:
        n_boom_modes: cantilever modes per boom `n_B` (>= 1).
        n_membrane_modes: triangle modes per quadrant `n_M` (>= 1).
    """

    def __init__(self, n_boom_modes: int, n_membrane_modes: int):
        self.n_boom_modes = nb = int(n_boom_modes)
        self.n_membrane_modes = nm = int(n_membrane_modes)
        self.n = 4 * nb + 4 * nm

    def boom_slice(self, boom: str) -> slice:
        """Coordinates `p_k` of boom `k` ("a" ... "d") in the system vector."""
        k = boom_index(boom)
        return slice(k * self.n_boom_modes, (k + 1) * self.n_boom_modes)

    def membrane_slice(self, quadrant: str) -> slice:
        """Coordinates `q_xy` of quadrant `xy` ("ab" ... "da") in the system vector."""
        start = 4 * self.n_boom_modes + quadrant_index(quadrant) * self.n_membrane_modes
        return slice(start, start + self.n_membrane_modes)

    def boom_slots(self, k: int) -> np.ndarray:
        """System indices of boom `k`'s coordinates (k = 0 for boom a)."""
        return np.arange(k * self.n_boom_modes, (k + 1) * self.n_boom_modes)

    def quadrant_slots(self, quadrant: Quadrant) -> np.ndarray:
        """System indices of the quadrant vector `q~ = [p_first, p_second, q_quadrant]`
        (size `2 n_B + n_M`): where each row of a quadrant matrix lands (Tab. 1)."""
        membrane = self.membrane_slice(quadrant.name)
        return np.concatenate(
            [
                self.boom_slots(quadrant.first),
                self.boom_slots(quadrant.second),
                np.arange(membrane.start, membrane.stop),
            ]
        )

    @property
    def coordinate_names(self) -> list[str]:
        """One self-describing name per generalised coordinate, in system order.

        `boom_a_mode_1` ... (cantilever mode i of boom a), then
        `membrane_ab_mode_2_1` ... (triangle mode (m, n) of quadrant ab).
        """
        names = [f"boom_{b}_mode_{i + 1}" for b in BOOMS for i in range(self.n_boom_modes)]
        pairs = triangle_mode_indices(self.n_membrane_modes)
        names += [f"membrane_{q}_mode_{m}_{k}" for q in QUADRANT_NAMES for m, k in pairs]
        return names
