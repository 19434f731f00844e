"""
Stability of a deploying sail
=============================

Seed Eq. 3: the largest real part of the eigenvalues at a frozen length and a constant
rate, over the film prestress. Retraction is unstable at every prestress (the `Md` term
acts as negative damping); deployment is unstable only below a critical prestress that
grows with the rate. `sail-ros stability` runs the sweeps on Dask; the analysis function
it calls takes the Dask client as an argument and runs here, serially, without one. The
figures are the tool's own (`sail_ros.plots.stability`). Small model: 4 boom and 6
membrane modes per quadrant.
"""

import tempfile
from pathlib import Path

import numpy as np

from sail_ros.analysis.stability import stability_sweep
from sail_ros.model import SailParameters
from sail_ros.plots.stability import map_figure, max_real_figure

FIGURES = Path(tempfile.mkdtemp())
params = SailParameters(n_boom_modes=4, n_membrane_modes=6)

# %%
# Three lengths, retraction, rest and two deployment rates, prestress 0.01 Pa to 100 kPa.
sweeps = stability_sweep(params, [20.0, 40.0, 70.71], [-0.1, 0.0, 0.1, 1.0],
                         np.logspace(-2, 5, 29))  # fmt: skip
for sweep in sweeps:
    print(f"L = {sweep.length:6.2f} m, rate {sweep.rate:+.1f} m/s: {sweep.status}, "
          f"critical prestress {sweep.critical_prestress}")  # fmt: skip
max_real_figure(sweeps, FIGURES / "stability.png", params.membrane_prestress)
map_figure(sweeps, FIGURES / "stability_map.png", params.membrane_prestress)
