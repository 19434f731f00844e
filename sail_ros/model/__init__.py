"""The sail's structural model: numpy/scipy only, no ROS.

    from sail_ros.model import SailParameters, SailModel

A one-way chain, each module importing only those above it:

- `layout`: the coordinates as named groups (booms, quadrants, a free hub), their
  slices and names, `per_boom`;
- `basis`, `integrals`: basis functions and the reference integrals (§2, §5);
- `assembly`: the matrices of Eq. 2 as a table of named terms, lifted (§5, §6), with a
  free hub's terms (§13);
- `parameters`, `sail_model`: `SailParameters` and `SailModel`;
- `stepper`, `sampling`, `integrate`: time integration against a narrow
  `LinearSystem` (the matrices at a boom motion), which `SailModel` is; the
  state sampled on a grid between long moving steps; batch runs;
- `profiles`: boom motion (`Profile`, the profiles, `BoomMotion`);
- `shape`: the deflected sail sampled on a mesh.
"""

from sail_ros.model.parameters import SailParameters
from sail_ros.model.profiles import BoomMotion, CycloidalProfile, StaticProfile, WaypointProfile
from sail_ros.model.sail_model import SailModel
from sail_ros.model.stepper import IntegrationError, SailStepper

__all__ = [
    "BoomMotion",
    "CycloidalProfile",
    "IntegrationError",
    "SailModel",
    "SailParameters",
    "SailStepper",
    "StaticProfile",
    "WaypointProfile",
]
