"""The sail's structural model: numpy/scipy only, no ROS.

    from sail_ros.model import SailParameters, SailModel

A one-way chain, each module importing only those above it:

- `layout`: the coordinates as named groups (booms, quadrants, a free hub), their
  slices and names, `per_boom`; `roots`: a bracketed root by Brent's method; `lapack`:
  the raw LAPACK routines; `fields`, `yaml_values`: configuration tables declared once,
  and YAML read as people write numbers;
- `integral_store`: the quadrant integrals kept on disk between processes;
- `basis`, `integrals`: basis functions and the reference integrals (§2, §5);
- `blocks`: the matrices as component blocks (a large system's solves);
- `assembly`: the matrices of Eq. 2 as a table of named terms, lifted (§5, §6), with a
  free hub's terms (§13);
- `loads`, `record`, `readout`: the inputs and their checks (§12), the state sample,
  what the coordinates read as (tips, root moments, the outputs);
- `linear`: the linear analysis at frozen lengths (§7, §12); `profiles`: boom motion
  (`Profile`, the profiles, `BoomMotion`);
- `parameters`, `hub`, `sail_model`: `SailParameters`, a free hub's momenta and holds,
  and `SailModel`;
- `shape`: the deflected sail sampled on a mesh.

The names below are imported when first used (PEP 562): a tool that needs only the
parameters (`send`, `watch`) does not pay for scipy's solvers and splines at start.
"""

import importlib

_WHERE = {
    "BoomMotion": "sail_ros.model.profiles",
    "CycloidalProfile": "sail_ros.model.profiles",
    "IntegrationError": "sail_ros.integrate.errors",
    "SailModel": "sail_ros.model.sail_model",
    "SailParameters": "sail_ros.model.parameters",
    "SailStepper": "sail_ros.integrate.stepper",
    "StaticProfile": "sail_ros.model.profiles",
    "WaypointProfile": "sail_ros.model.profiles",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})
