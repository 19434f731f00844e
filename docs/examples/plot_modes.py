"""
Natural frequencies and mode shapes
===================================

`sail-ros modes` lists the natural frequencies of the sail at given boom lengths, with
their multiplicities, and draws the first distinct mode shapes (seed Tab. 2, Fig. 2).
This example uses 4 boom and 6 membrane modes per quadrant so that the site builds
quickly; the tool's default is the converged set (:doc:`/docs/model`, mode counts).
"""

import tempfile
from pathlib import Path

from sail_ros.tools import modes

FIGURES = Path(tempfile.mkdtemp())
SMALL = ["--set", "n_boom_modes=4", "--set", "n_membrane_modes=6"]

# %%
# The default sail fully deployed (70.71 m booms): the frequencies and the first six
# distinct mode shapes, drawn by the tool itself (`--figures`).
modes.main([*SMALL, "--lengths", "70.71", "--count", "8", "--figures", str(FIGURES)])
