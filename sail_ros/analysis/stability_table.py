"""What `sail-ros stability` found, as one object (`StabilityTable`): its rows (the
critical prestress per length and rate, with the growth at the sail's own
prestress) give the text, the CSV and the grid's CSV alike."""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.analysis.stability import INSTABILITY_RTOL, STABLE, UNSTABLE, growth

FIGURES = ("stability.png", "stability_map.png", "eigenvalue_loci.png")  # in --figures DIR


def _describe(sweep) -> str:
    if sweep.status == STABLE:
        return "stable at every prestress"
    if sweep.status == UNSTABLE:
        return "unstable at every prestress"
    text = f"{sweep.critical_prestress:.4g}"
    return text if sweep.monotone else text + " (stability windows below)"


def critical_rows(sweeps, params) -> list[dict]:
    """One record per sweep: length [m], rate [m/s], status, critical prestress [Pa]
    and tension [N/m] (None without one), whether stable and unstable alternate at most
    once, and the largest real part and magnitude of the eigenvalues [1/s] at the
    sail's own prestress."""
    rows = []
    for sweep in sweeps:
        max_real, max_abs = growth(params, sweep.length, sweep.rate, params.membrane_prestress)
        rows.append(
            {
                "length_m": sweep.length,
                "rate_m_s": sweep.rate,
                "status": sweep.status,
                "critical_prestress_pa": sweep.critical_prestress,
                "critical_tension_n_m": (
                    None
                    if sweep.critical_prestress is None
                    else sweep.critical_prestress * params.membrane_thickness
                ),
                "monotone": sweep.monotone,
                "max_real_at_sail_prestress_1_s": max_real,
                "max_abs_at_sail_prestress_1_s": max_abs,
            }
        )
    return rows


@dataclasses.dataclass(frozen=True)
class StabilityTable:
    """A stability sweep and its grid.

    Attributes:
        params: the sail; described: its parameters in words.
        lengths: boom lengths [m]; rates: extension rates [m/s]; prestresses: the grid [Pa].
        sweeps: one `analysis.stability.PrestressSweep` per length and rate.
        rows: `critical_rows` of the sweeps.
    """

    params: object
    described: str
    lengths: list[float]
    rates: list[float]
    prestresses: np.ndarray
    sweeps: list
    rows: list[dict]

    @classmethod
    def of(cls, params, described, lengths, rates, prestresses, sweeps) -> StabilityTable:
        rows = critical_rows(sweeps, params)
        return cls(params, described, list(lengths), list(rates), prestresses, sweeps, rows)

    def text(self) -> str:
        low, high, points = self.prestresses[0], self.prestresses[-1], len(self.prestresses)
        total = len(self.lengths) * len(self.rates) * points
        sail = f"sigma = {self.params.membrane_prestress:g} Pa"
        lines = [
            "Frozen-length stability (seed Eq. 3): constant rate, all booms alike; "
            "the prestress is varied",
            self.described,
            f"  grid: {points} prestresses {low:g}..{high:g} Pa (log-spaced) x "
            f"{len(self.rates)} rates x {len(self.lengths)} length(s) = {total} points",
            f"  unstable when max Re(lambda) > {INSTABILITY_RTOL:g} max |lambda|",
            "",
            f"  {'L [m]':>7}{'rate [m/s]':>12}  {'critical prestress [Pa]':<32}max Re at {sail} "
            "[1/s]",
        ]
        for row, sweep in zip(self.rows, self.sweeps, strict=True):
            rate = f"{row['rate_m_s']:+.3g}" if row["rate_m_s"] else "0"
            lines.append(
                f"  {row['length_m']:7.4g}{rate:>12}  {_describe(sweep):<32}"
                f"{row['max_real_at_sail_prestress_1_s']:+.3e}"
            )
        lines += [
            "",
            "  critical prestress: the frozen system is unstable below it and stable above it;",
            "  retraction (rate < 0) turns the Md term into negative damping: unstable at any "
            "prestress.",
        ]
        return "\n".join(lines)

    def grid_rows(self) -> list[dict]:
        """Every grid point: length, rate, prestress, max Re, max |lambda|, unstable."""
        return [
            {
                "length_m": s.length,
                "rate_m_s": s.rate,
                "prestress_pa": float(p),
                "max_real_1_s": float(r),
                "max_abs_1_s": float(a),
                "unstable": bool(u),
            }
            for s in self.sweeps
            for p, r, a, u in zip(s.prestress, s.max_real, s.max_abs, s.unstable, strict=True)
        ]
