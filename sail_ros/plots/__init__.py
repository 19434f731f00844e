"""Figures (matplotlib, Agg): one module per kind, each taking computed data.

- `common`: figure saving and shared styling.
- `figure_check`: what a reader of a saved figure would object to, measured
  (clipped or overlapping text, hidden lines); the tests assert on it.
- `sail3d`: the deflected sail as a 3-D surface with its booms.
- `modes`: mode shapes of the whole sail (seed Fig. 2).
- `deployment`: deployment snapshots (seed Fig. 3).
- `histories`: time histories of a run or a log (deploy, report).
- `stability`: largest real part against prestress, eigenvalue loci.
- `plant`: Bode figure of the linear plant.
- `montecarlo`: envelopes, peak histograms and influence of a study.
"""
