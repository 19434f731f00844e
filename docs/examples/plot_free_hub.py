"""
A free hub, open and closed loop
================================

With `free_hub: true` the hub heaves and tilts. `config/scenario_free_hub.yaml` deploys
booms a, b, c from 10 to 16 m in 15 s while boom d stops at 12 m after 6 s, under 1 mPa
on the whole sail: the pressure's centre moves off the hub and tilts it.
`config/scenario_free_hub_control.yaml` is the same deployment with the hub's
controller closing the loop (docs/control.md). 4 boom and 6 membrane modes per
quadrant, so that the site builds quickly.
"""

import tempfile
from pathlib import Path

from sail_ros.tools import deploy

FIGURES = Path(tempfile.mkdtemp())
SMALL = ["--set", "n_boom_modes=4", "--set", "n_membrane_modes=6"]
# sphinx-gallery runs an example in its own folder: the tree is the nearest one up
ROOT = next(
    (
        p
        for p in (Path.cwd(), *Path.cwd().parents)
        if (p / "config" / "scenario_free_hub.yaml").is_file()
    ),
    None,
)
if ROOT is None:
    raise SystemExit(
        "run this example inside the sail_ros tree: it reads config/scenario_free_hub.yaml"
    )

# %%
# The open loop: the hub's heave, tilt and the reactions of its holds. The run warns that
# its error estimate is above twice its tolerance: on a free hub the estimate reads
# many times the error made, about twelve times on the root moments here
# (:doc:`/docs/model`, §11, says why).
deploy.main(["--scenario", str(ROOT / "config" / "scenario_free_hub.yaml"), *SMALL,
             "--every", "5", "--summary", "--figures", str(FIGURES / "open")])  # fmt: skip

# %%
# The closed loop, run beside the open one.
deploy.main(["--scenario", str(ROOT / "config" / "scenario_free_hub_control.yaml"), *SMALL,
             "--every", "5", "--summary", "--figures", str(FIGURES / "closed")])  # fmt: skip
