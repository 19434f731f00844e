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
  state sampled on a grid between long moving steps; batch runs; the steps
  themselves: `rational` (moving), `exact_step` (at rest), `fast_modes` (the
  followed high modes), `blocks` (a large system's solves);
- `profiles`: boom motion (`Profile`, the profiles, `BoomMotion`);
- `record`: the state sample, `peaks`: true peaks inside the steps;
- `shape`: the deflected sail sampled on a mesh.

The names below are imported when first used (PEP 562): a tool that needs only the
parameters (`send`, `watch`) does not pay for scipy's solvers and splines at start.
"""

import importlib

_WHERE = {
    "BoomMotion": "profiles",
    "CycloidalProfile": "profiles",
    "IntegrationError": "stepper",
    "SailModel": "sail_model",
    "SailParameters": "parameters",
    "SailStepper": "stepper",
    "StaticProfile": "profiles",
    "WaypointProfile": "profiles",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})
