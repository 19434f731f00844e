"""Where every boom, quadrant and generalised coordinate sits (model.md §1, §6, §13).

The bottom of the model: names and index arithmetic only, no physics. The
system coordinates are a list of named groups, in this order:

    q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da]            (clamped hub)
    q = [p_a, p_b, p_c, p_d, q_ab, q_bc, q_cd, q_da, z_h, theta_x, theta_y]   (free hub)

with `n_B` cantilever coordinates per boom, `n_M` triangle coordinates per
quadrant (quadrant `xy` spans the booms `x` (first) and `y` (second)) and the
hub's heave and two tilts. A new kind of coordinate is one more group.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

BOOMS = ("a", "b", "c", "d")
# in-plane unit vector e_k of each boom in the `sail` frame (model.md §1)
BOOM_DIRECTIONS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
# the hub's coordinates (model.md §13): heave z_h [m], tilts theta_x, theta_y [rad]
HUB_COORDINATES = ("hub_heave", "hub_tilt_x", "hub_tilt_y")


class Quadrant(NamedTuple):
    """A membrane quadrant: its name and the indices (0 = a) of its two booms."""

    name: str
    first: int
    second: int


# model.md §1 and Tab. 1: the first boom of a quadrant is the one named first
QUADRANTS = (Quadrant("ab", 0, 1), Quadrant("bc", 1, 2), Quadrant("cd", 2, 3), Quadrant("da", 3, 0))
QUADRANT_NAMES = tuple(quadrant.name for quadrant in QUADRANTS)
# (2, 4): each quadrant's first boom, then each one's second (indices into a per-boom array)
QUADRANT_BOOMS = np.array([[q.first for q in QUADRANTS], [q.second for q in QUADRANTS]])


def per_boom(
    value, name: str, positive: bool = False, order: str = "booms a, b, c, d"
) -> np.ndarray:
    """A scalar (all four) or 4 values (in `order`: booms, or quadrants for their
    loads) as a float array of 4 (`fixed_values`)."""
    return fixed_values(value, name, 4, order, positive)


def fixed_values(value, name: str, count: int, order: str, positive: bool = False) -> np.ndarray:
    """A scalar (all of them) or `count` values (in `order`) as a float array.

    Raises:
        ValueError: naming `name` and the value, when it is not numbers, the shape
            is wrong, a value is not finite, or (with `positive`) a value is <= 0.
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is not None and array.ndim == 0:
        array = np.full(count, float(array))
    if array is None or array.shape != (count,):
        raise ValueError(f"{name} must be a scalar or {count} values ({order}), got {value!r}")
    if not np.isfinite(array).all():
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


def hub_tilt_axis(k: int) -> tuple[int, float]:
    """`(axis, sign)` with `d_k^T theta = sign * theta[axis]` (axis 0: theta_x, 1:
    theta_y), `d_k = (e_k,y, -e_k,x)`: how a tilt of the hub lifts boom k's points,
    `W = s d_k^T theta` at distance `s` along it (model.md §13.1)."""
    d = np.array([BOOM_DIRECTIONS[k, 1], -BOOM_DIRECTIONS[k, 0]])
    axis = int(np.argmax(np.abs(d)))
    return axis, float(d[axis])


class Group(NamedTuple):
    """A group of generalised coordinates: its name (`boom_a`, `membrane_ab`, `hub`)
    and the names of its coordinates, in order."""

    name: str
    coordinates: tuple[str, ...]


class Layout:
    """Slices and names of the generalised coordinates for `(n_B, n_M)`, and the hub.

    Args:
        n_boom_modes: cantilever modes per boom `n_B` (>= 1).
        n_membrane_modes: triangle modes per quadrant `n_M` (>= 1).
        free_hub: append the hub's three coordinates (model.md §13).
    """

    def __init__(self, n_boom_modes: int, n_membrane_modes: int, free_hub: bool = False):
        self.n_boom_modes = nb = int(n_boom_modes)
        self.n_membrane_modes = nm = int(n_membrane_modes)
        pairs = triangle_mode_indices(nm)
        groups = [
            Group(f"boom_{b}", tuple(f"boom_{b}_mode_{i + 1}" for i in range(nb))) for b in BOOMS
        ]
        groups += [
            Group(f"membrane_{q}", tuple(f"membrane_{q}_mode_{m}_{k}" for m, k in pairs))
            for q in QUADRANT_NAMES
        ]
        if free_hub:
            groups.append(Group("hub", HUB_COORDINATES))
        self.groups = tuple(groups)
        self._slices = {}
        start = 0
        for group in self.groups:
            self._slices[group.name] = slice(start, start + len(group.coordinates))
            start += len(group.coordinates)
        self.n = start
        self.n_elastic = 4 * nb + 4 * nm  # booms and membranes: the hub comes last

    def group_slice(self, name: str) -> slice:
        """Coordinates of the group `name` (`boom_a`, `membrane_ab`, `hub`, ...)."""
        try:
            return self._slices[name]
        except KeyError:
            raise ValueError(
                f"no coordinate group {name!r}; the groups are {', '.join(self._slices)}"
            ) from None

    @property
    def hub_slice(self) -> slice | None:
        """`z_h, theta_x, theta_y` in the system vector; None with a clamped hub."""
        return self._slices.get("hub")

    def boom_slice(self, boom: str) -> slice:
        """Coordinates `p_k` of boom `k` ("a" ... "d") in the system vector."""
        boom_index(boom)
        return self._slices[f"boom_{boom}"]

    def membrane_slice(self, quadrant: str) -> slice:
        """Coordinates `q_xy` of quadrant `xy` ("ab" ... "da") in the system vector."""
        quadrant_index(quadrant)
        return self._slices[f"membrane_{quadrant}"]

    def boom_slots(self, k: int) -> np.ndarray:
        """System indices of boom `k`'s coordinates (k = 0 for boom a)."""
        span = self._slices[f"boom_{BOOMS[k]}"]
        return np.arange(span.start, span.stop)

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
        `membrane_ab_mode_2_1` ... (triangle mode (m, n) of quadrant ab), then, with a
        free hub, `hub_heave`, `hub_tilt_x`, `hub_tilt_y`.
        """
        return [name for group in self.groups for name in group.coordinates]
