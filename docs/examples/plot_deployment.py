"""
A deployment and its report
===========================

`sail-ros deploy` runs a deployment offline (seed Fig. 3): here the reference
deployment (model.md §9: all booms 10 m -> 15 m in 15 s, boom a bent to a 0.1 m tip),
with 4 boom and 6 membrane modes per quadrant so that the site builds quickly. It
prints the tip deflections and their true peaks, and draws snapshots of the sail, the
tip deflections and the boom lengths. Its `--mcap` log is the live format, which
`sail-ros report` reads as it reads a recorder's.
"""

import tempfile
from pathlib import Path

from sail_ros.tools import deploy, report

FIGURES = Path(tempfile.mkdtemp())
SMALL = ["--set", "n_boom_modes=4", "--set", "n_membrane_modes=6"]
LOG = FIGURES.parent / f"{FIGURES.name}.mcap"

# %%
# The deployment, its table and figures.
deploy.main([*SMALL, "--every", "3", "--summary", "--figures", str(FIGURES / "deploy"),
             "--mcap", str(LOG)])  # fmt: skip

# %%
# The report of its log: tip deflections, root moments, boom lengths and modal energies
# (a live log adds the real-time factor).
report.main([str(LOG), "--out", str(FIGURES / "report"), "--no-convergence"])
