"""The motion of the four booms when each follows the last command that named it.

A boom-length command may name only some booms; the others keep doing what
they were doing (holding, or finishing an earlier command). `BoomMotion` is
a profile (`t -> (lengths, rates, accelerations)`, see
`sail_ros.model.profiles`) that takes boom k's values from the profile
assigned to boom k.
"""

from __future__ import annotations

import numpy as np


class BoomMotion:
    """Booms a..d, each following its own 4-boom profile (only its column is used).

    Args:
        profiles: 4 profiles, one per boom (the same object may serve several).
    """

    def __init__(self, profiles):
        self.profiles = tuple(profiles)
        if len(self.profiles) != 4:
            raise ValueError(f"need one profile per boom (4), got {len(self.profiles)}")
        self._distinct = list({id(p): p for p in self.profiles}.values())

    def replaced(self, profile, booms) -> BoomMotion:
        """This motion with `profile` for the booms at indices `booms` (0 = a)."""
        return BoomMotion(profile if k in booms else p for k, p in enumerate(self.profiles))

    def __call__(self, t):
        if len(self._distinct) == 1:
            return self._distinct[0](t)
        values = {id(p): p(t) for p in self._distinct}
        return tuple(
            np.array([values[id(p)][part][k] for k, p in enumerate(self.profiles)])
            for part in range(3)
        )

    def is_static(self, t0, t1) -> bool:
        return all(p.is_static(t0, t1) for p in self._distinct)

    @property
    def t_end(self) -> float:
        """When the last boom stops [s] (-inf if none was ever commanded)."""
        return max(getattr(p, "t_end", -np.inf) for p in self._distinct)
