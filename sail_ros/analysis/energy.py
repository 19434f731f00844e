"""Mechanical energy of the sail and of its coordinate groups along a time history.

With `M` and the elastic `K` at the current lengths (rates not included, as
in model.md §7), the energy of coordinate group `g` (boom k's `p_k`, or
quadrant xy's `q_xy`) is its own share

    E_g = 1/2 qd_g^T M_gg qd_g + 1/2 q_g^T K_gg q_g        [J],

which is >= 0 and is the energy the sail would hold if only that group
moved. The total `E = 1/2 qd^T M qd + 1/2 q^T K q` also holds the coupling
between groups (membrane mass and tension riding on the booms), so
`E - sum_g E_g` is reported as the coupling term; it can have either sign.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.model import SailModel
from sail_ros.model.layout import BOOMS, QUADRANTS


@dataclasses.dataclass(frozen=True)
class GroupEnergies:
    """Energies [J] per sample: booms (k, 4) a..d, quadrants (k, 4) ab..da,
    total (k,), coupling (k,) = total - sum of the groups."""

    booms: np.ndarray
    quadrants: np.ndarray
    total: np.ndarray

    @property
    def coupling(self) -> np.ndarray:
        return self.total - self.booms.sum(axis=1) - self.quadrants.sum(axis=1)


def group_energies(model: SailModel, lengths, q, qd) -> GroupEnergies:
    """Energies of each sample.

    Args:
        model: the sail model the coordinates belong to.
        lengths: boom lengths [m], (k, 4).
        q: coordinates [m], (k, n).
        qd: velocities [m/s], (k, n).
    """
    lengths, q, qd = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (lengths, q, qd))
    if (
        not (lengths.shape[0] == q.shape[0] == qd.shape[0])
        or q.shape[1] != model.n
        or qd.shape != q.shape
        or lengths.shape[1] != 4
    ):
        raise ValueError(
            f"need lengths (k, 4) and q, qd (k, {model.n}); got "
            f"{lengths.shape}, {q.shape}, {qd.shape}"
        )
    slices = [model.boom_slice(b) for b in BOOMS] + [
        model.membrane_slice(name) for name, _, _ in QUADRANTS
    ]
    groups = np.empty((q.shape[0], len(slices)))
    total = np.empty(q.shape[0])
    last_key, M, K = None, None, None
    for i in range(q.shape[0]):
        key = lengths[i].tobytes()
        if key != last_key:  # booms at rest: same matrices as the previous sample
            M, K = model.mass_and_stiffness(lengths[i])
            last_key = key
        for j, s in enumerate(slices):
            groups[i, j] = 0.5 * (qd[i, s] @ M[s, s] @ qd[i, s] + q[i, s] @ K[s, s] @ q[i, s])
        total[i] = 0.5 * (qd[i] @ M @ qd[i] + q[i] @ K @ q[i])
    return GroupEnergies(groups[:, :4], groups[:, 4:], total)
