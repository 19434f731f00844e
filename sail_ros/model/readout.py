"""The model's coordinates and what they read as: names, slices, the inputs and outputs
(model.md §6, §7, §12), tip deflections, root moments, bent starting states and the state
record. `SailModel` is one."""

from __future__ import annotations

import numpy as np

from sail_ros.model.layout import BOOMS, Layout, per_boom
from sail_ros.model.loads import (
    CLAMPED,
    HUB_INPUT_NAMES,
    HUB_INPUT_UNITS,
    HUB_OUTPUT_NAMES,
    HUB_OUTPUT_UNITS,
    INPUT_NAMES,
    INPUT_UNITS,
    OUTPUT_NAMES,
    OUTPUT_UNITS,
)
from sail_ros.model.record import StateSample


class Readout:
    """The coordinates of `layout` (a `Layout`) read as the sail's outputs, with the boom
    integrals' tip values and root curvatures and `bending_stiffness` EI [N m^2]."""

    def __init__(self, layout: Layout, boom_integrals, bending_stiffness: float):
        self.layout = layout
        self.n = layout.n
        self.n_elastic = layout.n_elastic
        self.hub_slice = layout.hub_slice
        self.free_hub = layout.hub_slice is not None
        self.boom_integrals = boom_integrals
        self._tip_rows = self._boom_rows(boom_integrals.tip)
        self._curvature_rows = self._boom_rows(boom_integrals.root_curvature)
        self._bending_stiffness = bending_stiffness
        # (8, n): tip deflections, then root moments times L_k^2: the output rows free of
        # the lengths (`output_rows` divides the moments by L_k^2)
        self.length_free_rows = np.vstack(
            [self._tip_rows, bending_stiffness * self._curvature_rows]
        )

    def boom_slice(self, boom: str) -> slice:
        """Coordinates `p_k` of boom `k` in the system vector."""
        return self.layout.boom_slice(boom)

    def membrane_slice(self, quadrant: str) -> slice:
        """Coordinates `q_xy` of quadrant `xy` in the system vector."""
        return self.layout.membrane_slice(quadrant)

    @property
    def coordinate_names(self) -> list[str]:
        """One self-describing name per generalised coordinate (`Layout.coordinate_names`)."""
        return self.layout.coordinate_names

    @property
    def input_names(self) -> tuple[str, ...]:
        """The inputs `u` in order: 4 pressures, 4 tip forces (`loads.INPUT_NAMES`),
        then, with a free hub, `hub_force_z`, `hub_torque_x`, `hub_torque_y`."""
        return INPUT_NAMES + (HUB_INPUT_NAMES if self.free_hub else ())

    @property
    def input_units(self) -> tuple[str, ...]:
        return INPUT_UNITS + (HUB_INPUT_UNITS if self.free_hub else ())

    @property
    def output_names(self) -> tuple[str, ...]:
        """The plant's outputs: 4 tip deflections, 4 root moments (`loads.OUTPUT_NAMES`),
        then, with a free hub, `hub_heave`, `hub_tilt_x`, `hub_tilt_y` and their rates."""
        return OUTPUT_NAMES + (HUB_OUTPUT_NAMES if self.free_hub else ())

    @property
    def output_units(self) -> tuple[str, ...]:
        return OUTPUT_UNITS + (HUB_OUTPUT_UNITS if self.free_hub else ())

    def _require_free_hub(self) -> None:
        if not self.free_hub:
            raise ValueError(CLAMPED)

    def root_moments(self, q, lengths) -> np.ndarray:
        """Root bending moments `EI u_k''(0) = (EI / L_k^2) psi''(0)^T p_k` [N m] of
        booms a..d: (4,) for one state, (k, 4) for a series (`lengths` then 4 values
        or (k, 4)). Converges more slowly with n_B than the tip deflection."""
        q = np.asarray(q, dtype=float)
        lengths = np.asarray(lengths, dtype=float)
        if lengths.ndim <= 1:
            lengths = per_boom(lengths, "lengths", positive=True)
        elif lengths.shape != q.shape[:-1] + (4,):
            raise ValueError(
                f"lengths must be a scalar, 4 values or one row of 4 per state, "
                f"got shape {lengths.shape}"
            )
        if q.shape[-1] != self.n:
            raise ValueError(f"q must have {self.n} values per state, got shape {q.shape}")
        return self._bending_stiffness * (q @ self._curvature_rows.T) / lengths**2

    def boom_mode_shares(self, q, lengths) -> tuple[np.ndarray, np.ndarray]:
        """Each boom mode's share of the tip deflections [m] and of the root moments
        [N m] of states `q` (k, n) at `lengths` (k, 4): two (k, 4, n_B) arrays whose sums
        over the last axis are `tip_deflections` and `root_moments`."""
        p = np.stack([np.asarray(q)[:, self.layout.boom_slots(k)] for k in range(4)], axis=1)
        curvature = self._bending_stiffness * self.boom_integrals.root_curvature
        lengths = np.asarray(lengths, dtype=float)[:, :, None]
        return p * self.boom_integrals.tip, p * curvature / lengths**2

    def output_rows(self, lengths) -> np.ndarray:
        """(8, n): tip deflections [m] and root moments [N m] per unit coordinate at 4
        checked `lengths` (`loads.OUTPUT_NAMES`; `integrate.system.LinearSystem`)."""
        rows = self.length_free_rows.copy()
        rows[4:] /= np.asarray(lengths, dtype=float)[:, None] ** 2
        return rows

    def _boom_rows(self, values) -> np.ndarray:
        """(4, n): row k holds `values` (one per mode) at boom k's coordinates."""
        rows = np.zeros((4, self.n))
        for k in range(4):
            rows[k, self.layout.boom_slots(k)] = values
        return rows

    def tip_deflections(self, q) -> np.ndarray:
        """Boom-tip deflections `u_k(L_k) = psi(1)^T p_k` [m] (4 values, a..d).

        `q` may be one state (n,) or a series (..., n); works for velocities too.
        """
        return np.asarray(q) @ self._tip_rows.T

    def sample(self, t, lengths, rates, q, qd) -> StateSample:
        """The state at `t` [s] with its tip deflections, their rates, the root moments
        and a free hub's state `(z_h, theta_x, theta_y, zd_h, thd_x, thd_y)`; for a series
        (`t` (k,), the others with the times first) the record of arrays."""
        q, qd = np.asarray(q), np.asarray(qd)
        hub = None
        if self.free_hub:
            hub = np.concatenate([q[..., self.hub_slice], qd[..., self.hub_slice]], axis=-1)
        return StateSample(
            t=t,
            lengths=lengths,
            rates=rates,
            q=q,
            qd=qd,
            tips=self.tip_deflections(q),
            tip_rates=self.tip_deflections(qd),
            root_moments=self.root_moments(q, lengths),
            hub=hub,
        )

    def mode_state(self, boom: str = "a", tip_deflection: float = 0.1) -> np.ndarray:
        """Coordinates with boom `boom` bent in its first cantilever mode, all else 0.

        Args:
            boom: "a", "b", "c" or "d".
            tip_deflection: the tip deflection of that boom [m].
        """
        if not np.isfinite(tip_deflection):
            raise ValueError(f"tip_deflection must be finite, got {tip_deflection!r}")
        q = np.zeros(self.n)
        q[self.boom_slice(boom).start] = tip_deflection / self.boom_integrals.tip[0]
        return q

    def initial_coordinates(self, tip_deflections) -> np.ndarray:
        """Coordinates with each boom bent in its first cantilever mode to the given
        tip deflection [m] (a scalar or 4 values, booms a..d), membranes flat."""
        tips = per_boom(tip_deflections, "tip_deflections")
        return sum(self.mode_state(boom, float(tip)) for boom, tip in zip(BOOMS, tips, strict=True))
