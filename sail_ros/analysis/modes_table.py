"""What `sail-ros modes` found, as one object (`ModesTable`): the frequencies with their
multiplicities and damping, a free hub's clamped counterparts, the finite-element
cross-check; its text, JSON and CSV are rendered from the same rows, so they agree.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.analysis.json_values import json_number
from sail_ros.analysis.modes import (
    clamped_counterparts,
    group_multiplicities,
    modal_analysis,
)
from sail_ros.model import SailModel

AGREEMENT_PERCENT = 1.0  # the FE cross-check's verdict


@dataclasses.dataclass(frozen=True)
class ModesTable:
    """The modes of one sail at rest, and what was asked of them.

    Attributes:
        params: the sail (its membrane count resolved); described: its parameters in words.
        shown: the boom lengths [m] as given (one or four).
        model: its `SailModel`; modes: `analysis.modes.Modes` at the lengths.
        count: frequencies listed (whole groups).
        zeta: `damping_ratios`, or None for an undamped sail.
        counterparts, clamped: with a free hub, `clamped_counterparts` and the clamped
            sail's `Modes`; else None.
        check: the FE cross-check (`analysis.modes.CrossCheck`), or None.
    """

    params: object
    described: str
    shown: list[float]
    model: SailModel
    modes: object
    count: int
    zeta: np.ndarray | None = None
    counterparts: list | None = None
    clamped: object = None
    check: object = None

    @classmethod
    def of(cls, params, described: str, lengths, count: int) -> ModesTable:
        """The modal analysis of `params` at `lengths` [m] (one or four), with a free
        hub's clamped counterparts."""
        model = SailModel(params)
        modes = modal_analysis(model, lengths[0] if len(lengths) == 1 else lengths)
        zeta = damping_ratios(params, modes.omega)
        counterparts = clamped = None
        if model.free_hub:
            clamped_model = SailModel(params.replace(free_hub=False))
            clamped = modal_analysis(clamped_model, modes.lengths)
            counterparts = clamped_counterparts(model, modes, clamped_model, clamped)
        return cls(params, described, list(lengths), model, modes, count, zeta, counterparts,
                   clamped)  # fmt: skip

    def text(self) -> str:
        """The heading, the parameters and the frequency table (and a free hub's notes)."""
        shown = ", ".join(f"{v:.4g}" for v in self.shown)
        lines = [f"Natural frequencies of the sail, boom lengths {shown} m, at rest",
                 self.described, ""]  # fmt: skip
        omega = self.modes.omega
        if self.counterparts is not None:
            lines.append(
                "  free hub: three rigid-body modes at exactly 0 rad/s (heave, tilts about x "
                "and y); beside each elastic group, the group of the same sail with the hub "
                "clamped (free_hub = false) that holds most of its shape (shape share: 1 = the "
                "same)"
            )
        lines.append(frequency_table(omega, self.count, self.zeta, self.counterparts))
        if self.counterparts is not None:
            note = moved_note(omega, self.count, self.counterparts, self.clamped)
            if note:
                lines.append(note)
        return "\n".join(lines)

    def fem_text(self) -> str:
        """The FE cross-check's heading and tables."""
        return (
            f"\nIndependent finite-element cross-check (seed Tab. 2 layout), L = "
            f"{self.shown[0]:.4g} m, physical parameters above\n" + cross_check_table(self.check)
        )

    def rows(self) -> list[dict]:
        """The listed frequencies, one record each (`frequency_rows`; the CSV's rows)."""
        return frequency_rows(self.modes.omega, self.count, self.zeta, self.counterparts)

    def record(self) -> dict:
        """Parameters, lengths, frequencies and the FE comparison, for JSON."""
        record = {
            "parameters": self.params.to_dict(),
            "lengths_m": list(self.modes.lengths),
            "frequencies": self.rows(),
        }
        if self.check is not None:
            record["fem_cross_check"] = cross_check_record(self.check)
        return record


def damping_ratios(params, omega: np.ndarray) -> np.ndarray | None:
    """Rayleigh damping ratios `alpha / (2 omega) + beta omega / 2` of the modes at
    rest (model.md §12; NaN for a free hub's rigid-body modes, which do not oscillate);
    None for an undamped sail."""
    alpha, beta = params.mass_damping, params.stiffness_damping
    if alpha == 0.0 and beta == 0.0:
        return None
    with np.errstate(divide="ignore"):
        zeta = alpha / (2.0 * np.abs(omega)) + beta * np.abs(omega) / 2.0
    return np.where(omega == 0.0, np.nan, zeta)


def frequency_table(
    omega: np.ndarray, count: int, zeta: np.ndarray | None = None, counterparts=None
) -> str:
    """Rows `mode(s)  omega [rad/s]  f [Hz]  period [s]  multiplicity` (and the damping
    ratio when `zeta` is given) for the first `count` frequencies (whole groups); with
    `counterparts` (a free hub's `clamped_counterparts`) the clamped sail's group of the
    same shape beside each elastic group: its modes, frequency, the change to the free
    hub's and how much of the shape they share."""
    lines = [f"  {'mode':<8}{'omega [rad/s]':>15}{'f [Hz]':>12}{'period [s]':>12}  multiplicity"]
    if zeta is not None:
        lines[0] += f"{'zeta':>10}"
    beside = {}
    if counterparts is not None:
        lines[0] += f"  {'clamped':<8}{'omega [rad/s]':>15}{'change [%]':>12}{'shape share':>13}"
        for pair in counterparts:
            label = _label(pair.clamped_first, pair.clamped_multiplicity)
            change = 100.0 * (omega[pair.free_first] / pair.omega - 1.0)
            beside[pair.free_first] = (
                f"  {label:<8}{pair.omega:15.5f}{change:+12.2f}{pair.share:13.3f}"
            )
    for first, multiplicity in group_multiplicities(omega):
        if first >= count:
            break
        label = _label(first, multiplicity)
        value = omega[first]
        period = f"{2 * np.pi / value:12.2f}" if value > 0 else f"{'divergent':>12}"
        if value == 0.0:  # a free hub's rigid-body modes
            period = f"{'rigid':>12}"
        hertz = value / (2 * np.pi)
        line = f"  {label:<8}{value:15.5f}{hertz:12.6f}{period}  {multiplicity:<12}"
        if zeta is not None:
            line += f"{'-':>10}" if np.isnan(zeta[first]) else f"{zeta[first]:10.4g}"
        line += beside.get(first, "")
        lines.append(line.rstrip())
    return "\n".join(lines)


def frequency_rows(
    omega: np.ndarray, count: int, zeta: np.ndarray | None = None, counterparts=None
) -> list[dict]:
    """One record per frequency (the first `count`, whole groups): mode number,
    omega [rad/s], f [Hz], period [s] (None if divergent or rigid), distinct-frequency
    group and its multiplicity, the damping ratio when `zeta` is given (None for a rigid
    mode), and with `counterparts` the clamped group of the same shape (its first mode,
    omega [rad/s], shape share; None for a rigid mode)."""
    paired = {pair.free_first: pair for pair in counterparts or ()}
    rows = []
    for group, (first, multiplicity) in enumerate(group_multiplicities(omega), start=1):
        if first >= count:
            break
        for index in range(first, first + multiplicity):
            value = float(omega[index])
            rows.append(
                {
                    "mode": index + 1,
                    "omega_rad_s": value,
                    "frequency_hz": value / (2 * np.pi),
                    "period_s": 2 * np.pi / value if value > 0 else None,
                    "group": group,
                    "multiplicity": multiplicity,
                    **({"damping_ratio": json_number(zeta[index])} if zeta is not None else {}),
                }
            )
            if counterparts is not None:
                pair = paired.get(first)
                rows[-1] |= {
                    "clamped_mode": pair.clamped_first + 1 if pair else None,
                    "clamped_omega_rad_s": pair.omega if pair else None,
                    "shape_share": pair.share if pair else None,
                }
    return rows


def _label(first: int, multiplicity: int) -> str:
    return f"{first + 1}" if multiplicity == 1 else f"{first + 1}-{first + multiplicity}"


def moved_note(omega, count: int, counterparts, clamped) -> str:
    """One line naming the clamped groups within the listed frequencies that no listed
    free-hub group is beside, and where the free hub moved each (or "")."""
    listed = [first for first, _ in group_multiplicities(omega) if first < count]
    highest = omega[listed[-1]]
    beside = {p.clamped_first for p in counterparts if p.free_first in listed}
    moved = []
    for first, multiplicity in clamped.groups:
        if clamped.omega[first] > highest:
            break
        if first in beside:
            continue
        text = f"{_label(first, multiplicity)} ({clamped.omega[first]:.5f} rad/s)"
        found = [p for p in counterparts if p.clamped_first == first]
        if found:
            free_first = found[0].free_first
            free_count = dict(group_multiplicities(omega))[free_first]
            text += (
                f" is free-hub mode {_label(free_first, free_count)} "
                f"({omega[free_first]:.5f} rad/s)"
            )
        moved.append(text)
    if not moved:
        return ""
    return (
        "  clamped modes the free hub moved beyond the listed ones (the hub moves with "
        f"them): {'; '.join(moved)}"
    )


def cross_check_table(check) -> str:
    """The FE comparison in the seed's Tab. 2 layout, then both refinement tables."""
    k = check.count
    fem_settings = check.fem_levels[-1][0]
    n_boom, n_membrane = check.modal_levels[-1][:2]
    header = "  " + f"{'Modal frequency':<22}" + "".join(f"{f'w{i + 1}':>10}" for i in range(k))
    lines = [
        f"  FE:    {fem_settings['description']}",
        f"  modal: n_B = {n_boom}, n_M = {n_membrane} ({4 * n_boom + 4 * n_membrane} coordinates)",
        "",
        header,
        "  " + f"{'FE (rad/s)':<22}" + "".join(f"{v:10.5f}" for v in check.fem),
        "  " + f"{'Modal (rad/s)':<22}" + "".join(f"{v:10.5f}" for v in check.modal),
        # + 0.0 turns a rounded -0.000 into +0.000
        "  "
        + f"{'Difference (%)':<22}"
        + "".join(f"{round(v, 3) + 0.0:+10.3f}" for v in check.difference_percent),
        "",
        f"  FE mesh refinement: lowest {k} frequencies [rad/s]",
        f"  {'NB':>4}{'ND':>5}{'order':>6}{'DOFs':>8}{'time [s]':>10}  "
        + "".join(f"{f'w{i + 1}':>11}" for i in range(k)),
    ]
    for settings, omega in check.fem_levels:
        lines.append(
            f"  {settings['boom_elements']:>4}{settings['membrane_divisions']:>5}"
            f"{settings['membrane_order']:>6}{settings['n_dofs']:>8}"
            f"{settings['seconds']:>10.2f}  " + "".join(f"{v:11.7f}" for v in omega)
        )
    lines += [
        "",
        f"  Modal refinement: lowest {k} frequencies [rad/s]",
        f"  {'n_B':>4}{'n_M':>5}{'coords':>8}{'time [s]':>10}       "
        + "".join(f"{f'w{i + 1}':>11}" for i in range(k)),
    ]
    for n_boom, n_membrane, seconds, omega in check.modal_levels:
        lines.append(
            f"  {n_boom:>4}{n_membrane:>5}{4 * n_boom + 4 * n_membrane:>8}"
            f"{seconds:>10.2f}       " + "".join(f"{v:11.7f}" for v in omega)
        )
    worst = float(np.max(np.abs(check.difference_percent)))
    verdict = "agree" if worst <= AGREEMENT_PERCENT else "DISAGREE"
    lines += [
        "",
        f"  largest |difference| over the first {k}: {worst:.3f} % "
        f"({verdict} within {AGREEMENT_PERCENT:g} %)",
    ]
    return "\n".join(lines)


def cross_check_record(check) -> dict:
    """The FE comparison as plain data for JSON."""
    return {
        "compared": check.count,
        "fem": [float(v) for v in check.fem],
        "modal": [float(v) for v in check.modal],
        "difference_percent": [float(v) for v in check.difference_percent],
        "fem_levels": [
            {**settings, "omega_rad_s": [float(v) for v in omega]}
            for settings, omega in check.fem_levels
        ],
        "modal_levels": [
            {
                "n_boom_modes": nb,
                "n_membrane_modes": nm,
                "seconds": seconds,
                "omega_rad_s": [float(v) for v in omega],
            }
            for nb, nm, seconds, omega in check.modal_levels
        ],
    }


def fem_csv_rows(check) -> list[dict]:
    return [
        {
            "mode": i + 1,
            "fem_rad_s": float(f),
            "modal_rad_s": float(m),
            "difference_percent": float(d),
        }
        for i, (f, m, d) in enumerate(
            zip(check.fem, check.modal, check.difference_percent, strict=True)
        )
    ]
