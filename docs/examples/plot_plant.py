"""
The linear plant and its Bode figure
====================================

`sail-ros plant` gives the linear plant at frozen lengths and rates (`x = [q; qd]`;
inputs: 4 pressures, 4 tip forces; outputs: 4 tip deflections, 4 root moments): its
poles with frequency and damping ratio, the matrices as `.npz` and MATLAB `.mat`, and a
Bode figure. Unequal booms (a, c at 20 m, b, d at 22 m), Rayleigh damping, 4 boom and 6
membrane modes per quadrant.
"""

import tempfile
from pathlib import Path

from sail_ros.tools import plant

FIGURES = Path(tempfile.mkdtemp())

# %%
plant.main(["--lengths", "20", "22", "20", "22", "--set", "mass_damping=0.02",
            "--set", "stiffness_damping=1e-3", "--set", "n_boom_modes=4",
            "--set", "n_membrane_modes=6", "--npz", str(FIGURES / "plant.npz"),
            "--figure", str(FIGURES / "plant_bode.png")])  # fmt: skip
