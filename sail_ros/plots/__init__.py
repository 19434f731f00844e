"""Figures (matplotlib, Agg): one module per kind, each taking computed data.

- `common`: figure saving and shared styling.
- `sail3d`: the deflected sail as a 3-D surface with its booms.
- `modes`: mode shapes of the whole sail (seed Fig. 2).
- `deployment`: deployment snapshots (seed Fig. 3) and time histories.
- `stability`: largest real part against prestress, eigenvalue loci.
- `report`: time histories read back from a log.
"""
