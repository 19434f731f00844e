"""Stability checked, not hoped for: the discrete loop against the full plant.

At frozen boom lengths and rates the full model (`SailModel.state_space`, every mode
of the plant's mode counts, the free hub's rigid-body modes, the rates' gyroscopic
terms) is sampled with the controller's period and loop delay (`design.sampled`); the
controller is the schedule's design point at the mean length. With the plant's state
`x` (and the commands still to act) and the controller's prediction `e`,

    u     = -K (S e + M C_p x),        S = I - M C
    x_next = (F_p - G_p K M C_p) x - G_p K S e
    e_next = (F - G K) (M C_p x + S e)

and the loop's poles are the eigenvalues `z` of that matrix, `s = ln(z) / T` [1/s]
(poles at `z = 0`, from the delay line, are left out). The loop is stable when no pole
has `Re s > NEUTRAL`; a pole within `NEUTRAL` of the imaginary axis is a mode the loop
does not reach (it neither loads the hub nor shows in the measurements: with an
undamped sail it keeps its open-loop pole on the axis). Flexible modes the design model
leaves out are all in the plant, so spillover shows as a positive real part.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_ros.control.design import HUB_WRENCH, TIP_FORCES, DesignPoint, sampled
from sail_ros.control.schedule import GainSchedule
from sail_ros.model import SailModel
from sail_ros.model.layout import per_boom
from sail_ros.model.linear import without_rigid

NEUTRAL = 1e-9  # 1/s: |Re s| within this is on the imaginary axis (|z| - 1 ~ 1e-11)


@dataclasses.dataclass(frozen=True)
class LoopPoles:
    """The closed loop at one time of a deployment.

    Attributes:
        t: time [s]; lengths, rates: the booms' [m], [m/s] (4,).
        largest_real: the largest Re s of the loop's poles [1/s].
        largest_pole: that pole.
        reached_real: the largest Re s of the poles the loop moves off the axis
            (-inf if none).
        neutral: poles within NEUTRAL of the imaginary axis.
        open_loop_real: the plant's largest elastic Re s without the controller (its
            rigid-body poles left out).
        above_nyquist: the plant's elastic poles above the Nyquist frequency pi / T.
    """

    t: float
    lengths: np.ndarray
    rates: np.ndarray
    largest_real: float
    largest_pole: complex
    reached_real: float
    neutral: int
    open_loop_real: float
    above_nyquist: int

    @property
    def stable(self) -> bool:
        return self.largest_real <= NEUTRAL


def plant_outputs(model: SailModel, C: np.ndarray, measurements) -> np.ndarray:
    """The rows of the measured outputs (`design.measurement_names`) over the plant's
    `x = [q; qd]`, from `state_space`'s `C`: the hub's six, then tips and tip rates."""
    n = model.n
    rows = [C[8:14]]
    if len(measurements) > 6:
        tip_rates = np.zeros((4, 2 * n))
        tip_rates[:, n:] = C[:4, :n]
        rows += [C[:4], tip_rates]
    return np.vstack(rows)


def loop_matrix(
    model: SailModel, schedule: GainSchedule, lengths, rates, point: DesignPoint | None = None
) -> np.ndarray:
    """The closed loop's transition matrix at frozen `lengths` [m] and `rates` [m/s]
    (module docstring); `point` the controller (default the schedule's at the mean
    length)."""
    lengths, rates = per_boom(lengths, "lengths", positive=True), per_boom(rates, "rates")
    A, B, C, _ = model.state_space(lengths, rates)
    columns = HUB_WRENCH + (TIP_FORCES if len(schedule.inputs) > 3 else [])
    plant = sampled(A, B[:, columns], np.zeros((A.shape[0], 0)), schedule.period, schedule.delay)
    C_p = np.zeros((len(schedule.measurements), plant.F.shape[0]))
    C_p[:, : plant.n_x] = plant_outputs(model, C, schedule.measurements)
    point = schedule.at(float(np.mean(lengths))) if point is None else point
    F_p, G_p = plant.F, plant.G
    S = np.eye(point.F.shape[0]) - point.M @ point.C
    closed = point.F - point.G @ point.K
    KM = point.K @ point.M @ C_p
    return np.block(
        [
            [F_p - G_p @ KM, -G_p @ point.K @ S],
            [closed @ point.M @ C_p, closed @ S],
        ]
    )


def loop_poles(model: SailModel, schedule: GainSchedule, t: float, lengths, rates) -> LoopPoles:
    """The closed loop's poles at frozen `lengths` and `rates` (`LoopPoles`)."""
    lengths, rates = per_boom(lengths, "lengths", positive=True), per_boom(rates, "rates")
    z = np.linalg.eigvals(loop_matrix(model, schedule, lengths, rates))
    z = z[np.abs(z) > 1e-12]
    s = np.log(z.astype(complex)) / schedule.period
    i = int(np.argmax(s.real))
    reached = s.real[np.abs(s.real) > NEUTRAL]
    open_loop = without_rigid(model.eigenvalues(lengths, rates), model.free_hub)
    return LoopPoles(
        t=float(t),
        lengths=lengths,
        rates=rates,
        largest_real=float(s.real[i]),
        largest_pole=complex(s[i]),
        reached_real=float(reached.max()) if reached.size else -math.inf,
        neutral=int(np.sum(np.abs(s.real) <= NEUTRAL)),
        open_loop_real=float(open_loop.real.max()),
        above_nyquist=int(np.sum(open_loop.imag > math.pi / schedule.period)),
    )


def check_deployment(model: SailModel, schedule: GainSchedule, profile, times, progress=None):
    """`LoopPoles` at each of `times` [s] of the boom motion `profile` (lengths and
    rates frozen there); `progress(t)` after each."""
    rows = []
    for t in times:
        lengths, rates, _ = profile(float(t))
        rows.append(loop_poles(model, schedule, float(t), lengths, rates))
        if progress is not None:
            progress(float(t))
    return rows
