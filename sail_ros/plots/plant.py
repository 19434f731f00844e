"""Bode figure of the linear plant: each tip force to its own tip deflection and
root moment."""

from __future__ import annotations

import numpy as np

from sail_ros.plots.common import BOOM_COLOURS, figure, fit_width, save, styled
from sail_ros.plots.histories import equal_groups

BOOMS = "abcd"


PHASE_TOP = 90.0  # the phase is drawn in (PHASE_TOP - 360, PHASE_TOP] [deg]


def wrapped_phase(frequencies, g, top: float = PHASE_TOP) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and the phase of `g` [deg] wrapped into `(top - 360, top]`, with a
    NaN point where it wraps, so that a line breaks there instead of crossing the panel.

    Unwrapped, the phase of an undamped plant falls by 180 deg at every pole (python-
    control's bode_plot draws the default sail's tip force a to tip deflection a
    down to -7740 deg). The default window (-270, 90]
    holds the lags of a structure whole: 0 and -180 (a mode's two sides, exactly,
    when undamped) lie inside it, not on its edge where round-off would flip them.
    """
    phase = top - np.mod(top - np.degrees(np.angle(g)), 360.0)
    jumps = np.flatnonzero(np.abs(np.diff(phase)) > 180.0) + 1
    frequencies = np.asarray(frequencies, dtype=float)
    return np.insert(frequencies, jumps, np.nan), np.insert(phase, jumps, np.nan)


@styled
def bode_figure(omega, response, plant, path, title: str):
    """Magnitude and phase (wrapped to (-270, 90] deg) of `tip_force_k ->
    tip_deflection_k` and `-> root_moment_k` for booms a..d; `response` from
    `analysis.plant.frequency_response`. Booms whose responses are equal (a
    symmetric sail) share one line, labelled with all of them."""
    fig, axes = figure(8.0, 5.6, nrows=2, ncols=2, sharex=True)
    hertz = np.asarray(omega) / (2 * np.pi)
    inputs, outputs = list(plant.input_names), list(plant.output_names)
    legends = []
    for column, (kind, unit) in enumerate((("tip_deflection", "m/N"), ("root_moment", "N m/N"))):
        g = np.column_stack(
            [
                response[:, outputs.index(f"{kind}_{boom}"), inputs.index(f"tip_force_{boom}")]
                for boom in BOOMS
            ]
        )
        groups = equal_groups(g)
        for group in groups:
            boom = BOOMS[group[0]]
            names = ", ".join(BOOMS[k] for k in group)
            label = f"boom {names}" if len(group) == 1 else f"booms {names}"
            style = {"color": BOOM_COLOURS[boom], "lw": 1.0}
            axes[0, column].loglog(hertz, np.abs(g[:, group[0]]), label=label, **style)
            axes[1, column].semilogx(*wrapped_phase(hertz, g[:, group[0]]), **style)
        legends.append(groups)
        label = "tip deflection" if kind == "tip_deflection" else "root moment"
        axes[0, column].set_title(f"tip force -> {label} (same boom)")
        axes[0, column].set_ylabel(f"|G| [{unit}]")
        axes[1, column].set_ylabel(f"phase [deg] in ({PHASE_TOP - 360:g}, {PHASE_TOP:g}]")
        axes[1, column].set_xlabel("frequency [Hz]")
        axes[1, column].set_yticks(np.arange(PHASE_TOP - 360.0, PHASE_TOP + 1.0, 90.0))
        axes[1, column].set_ylim(PHASE_TOP - 375.0, PHASE_TOP + 15.0)
    for column in range(2) if legends[0] != legends[1] else range(1):
        axes[0, column].legend(loc="lower left", frameon=False)
    axes[0, 0].margins(x=0)
    fit_width(fig.suptitle(title))
    fig.tight_layout()
    return save(fig, path)
