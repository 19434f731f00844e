"""Bode figure of the linear plant: each tip force to its own tip deflection and
root moment."""

from __future__ import annotations

import numpy as np

from sail_ros.plots.common import BOOM_COLOURS, figure, save, styled


@styled
def bode_figure(omega, response, plant, path, title: str):
    """Magnitude and phase of `tip_force_k -> tip_deflection_k` and `-> root_moment_k`
    for booms a..d; `response` from `analysis.plant.frequency_response`."""
    fig, axes = figure(8.0, 5.6, nrows=2, ncols=2, sharex=True)
    hertz = np.asarray(omega) / (2 * np.pi)
    inputs, outputs = list(plant.input_names), list(plant.output_names)
    for column, (kind, unit) in enumerate((("tip_deflection", "m/N"), ("root_moment", "N m/N"))):
        for boom in "abcd":
            g = response[:, outputs.index(f"{kind}_{boom}"), inputs.index(f"tip_force_{boom}")]
            # dashed c, d: a symmetric sail puts them on top of a, b
            style = {"color": BOOM_COLOURS[boom], "lw": 1.0, "ls": "--" if boom in "cd" else "-"}
            axes[0, column].loglog(hertz, np.abs(g), label=f"boom {boom}", **style)
            phase = np.degrees(np.unwrap(np.angle(g)))
            axes[1, column].semilogx(hertz, phase, **style)
        label = "tip deflection" if kind == "tip_deflection" else "root moment"
        axes[0, column].set_title(f"tip force -> {label} (same boom)")
        axes[0, column].set_ylabel(f"|G| [{unit}]")
        axes[1, column].set_ylabel("phase [deg]")
        axes[1, column].set_xlabel("frequency [Hz]")
    axes[0, 0].legend(loc="lower left")
    fig.suptitle(title)
    fig.tight_layout()
    return save(fig, path)
