"""Bode figure of the linear plant: each tip force to its own tip deflection and root
moment, and with a free hub its force and torques to its heave and tilts.

An undamped plant's response is unbounded at its poles: its lines run off the top of
the magnitude panels there (the grid closes in on each pole, `analysis.plant.bode_grid`)
and break, and the poles are marked along the top; its phase is 0 or -180 deg between
poles and zeros and breaks where it flips, instead of joining the two with a stroke.
"""

from __future__ import annotations

import numpy as np
from matplotlib import transforms

from sail_ros.analysis.plant import (
    bode_band,
    bode_grid,
    bode_pairs,
    frequency_response,
    undamped_shown,
)
from sail_ros.plots.common import BOOM_COLOURS, figure, fit_width, save, styled
from sail_ros.plots.histories import equal_groups

BOOMS = "abcd"
PHASE_TOP = 90.0  # the phase is drawn in (PHASE_TOP - 360, PHASE_TOP] [deg]
FLIP = 90.0  # a phase change this large between neighbouring points is a jump [deg]
NEAR_POLE = 0.02  # points this close to a marked pole (relative) do not set the y-range
HUB_COLOURS = {"x": "tab:purple", "y": "tab:brown"}


def wrapped_phase(frequencies, g, top: float = PHASE_TOP) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and the phase of `g` [deg] wrapped into `(top - 360, top]`, with a
    NaN point where it wraps or jumps by more than `FLIP` between neighbours (an
    undamped response flips between 0 and -180 at its poles and zeros), so that a line
    breaks there instead of crossing the panel.

    Unwrapped, the phase of an undamped plant falls by 180 deg at every pole (python-
    control's bode_plot draws the default sail's tip force a to tip deflection a
    down to -7740 deg). The default window (-270, 90]
    holds the lags of a structure whole: 0 and -180 (a mode's two sides, exactly,
    when undamped) lie inside it, not on its edge where round-off would flip them.
    """
    phase = top - np.mod(top - np.degrees(np.angle(g)), 360.0)
    jumps = np.flatnonzero(np.abs(np.diff(phase)) > FLIP) + 1
    frequencies = np.asarray(frequencies, dtype=float)
    return np.insert(frequencies, jumps, np.nan), np.insert(phase, jumps, np.nan)


def _broken_at(frequencies, values, poles) -> tuple[np.ndarray, np.ndarray]:
    """A NaN point between neighbouring frequencies on either side of each pole [Hz]."""
    frequencies = np.asarray(frequencies, dtype=float)
    where = np.unique(np.searchsorted(frequencies, poles))
    where = where[(where > 0) & (where < frequencies.size)]
    return np.insert(frequencies, where, np.nan), np.insert(values, where, np.nan)


def _panels(plant):
    """(row, column, title, unit, [(label, colour, output, input)]) of each pair of
    magnitude and phase panels."""
    panels = []
    for column, (kind, unit) in enumerate((("tip_deflection", "m/N"), ("root_moment", "N m/N"))):
        label = "tip deflection" if kind == "tip_deflection" else "root moment"
        curves = [(f"boom {b}", BOOM_COLOURS[b], f"{kind}_{b}", f"tip_force_{b}") for b in BOOMS]
        panels.append((0, column, f"tip force -> {label} (same boom)", unit, curves))
    if plant.free_hub:
        heave = [("F_z -> z_h", "k", "hub_heave", "hub_force_z")]
        tilts = [(f"tau_{a} -> theta_{a}", HUB_COLOURS[a], f"hub_tilt_{a}", f"hub_torque_{a}")
                 for a in "xy"]  # fmt: skip
        panels.append((2, 0, "hub force -> hub heave", "m/N", heave))
        panels.append((2, 1, "hub torque -> hub tilt (same axis)", "rad/(N m)", tilts))
    return panels


def _merged_label(curves, group) -> str:
    """One label for curves whose responses are equal: "booms a, c" for booms."""
    labels = [curves[k][0] for k in group]
    if len(group) > 1 and all(label.startswith("boom ") for label in labels):
        return "booms " + ", ".join(label.removeprefix("boom ") for label in labels)
    return ", ".join(labels)


@styled
def bode_figure(omega, response, plant, path, title: str, marked=None):
    """Magnitude and phase (wrapped to (-270, 90] deg) of `tip_force_k ->
    tip_deflection_k` and `-> root_moment_k` for booms a..d (and with a free hub of its
    force to its heave and torques to its tilts); `response` from
    `analysis.plant.frequency_response` at `omega` [rad/s]. Curves whose responses are
    equal (a symmetric sail) share one line, labelled with all of them. `marked`:
    `{(output, input): frequencies [Hz]}` of the undamped poles that show in each
    transfer (`analysis.plant.undamped_shown`): its line breaks there, and a marker
    along the top of its magnitude panel names each."""
    panels = _panels(plant)
    rows = 2 * (1 + plant.free_hub)
    fig, axes = figure(8.0, 2.8 * rows, nrows=rows, ncols=2, sharex=True, squeeze=False)
    hertz = np.asarray(omega) / (2 * np.pi)
    inputs, outputs = list(plant.input_names), list(plant.output_names)
    legends = []
    for row, column, name, unit, curves in panels:
        magnitude, phase = axes[row, column], axes[row + 1, column]
        g = np.column_stack(
            [response[:, outputs.index(out), inputs.index(source)] for _, _, out, source in curves]
        )
        marks = [(marked or {}).get((out, source), []) for _, _, out, source in curves]
        poles = np.unique(np.concatenate([[], *marks]))
        away = np.ones(hertz.size, dtype=bool)
        for pole in poles:
            away &= np.abs(hertz / pole - 1.0) > NEAR_POLE
        groups = equal_groups(g)
        for group in groups:
            style = {"color": curves[group[0]][1], "lw": 1.0}
            values = np.abs(g[:, group[0]])
            magnitude.loglog(*_broken_at(hertz, values, marks[group[0]]),
                             label=_merged_label(curves, group), **style)  # fmt: skip
            phase.semilogx(*wrapped_phase(hertz, g[:, group[0]]), **style)
        if poles.size:
            shown = np.abs(g[away])
            shown = shown[shown > 0]
            if shown.size:  # the lines run off the top at the poles: unbounded
                magnitude.set_ylim(shown.min() / 3.0, shown.max() * 10.0)
            along_top = transforms.blended_transform_factory(
                magnitude.transData, magnitude.transAxes
            )
            magnitude.plot(poles, np.ones(poles.size), ls="", marker="v", ms=3.5,
                           color="0.35", transform=along_top, clip_on=False)  # fmt: skip
        legends.append((magnitude, [_merged_label(curves, group) for group in groups]))
        magnitude.set_title(name)
        magnitude.set_ylabel(f"|G| [{unit}]")
        phase.set_ylabel(f"phase [deg] in ({PHASE_TOP - 360:g}, {PHASE_TOP:g}]")
        phase.set_yticks(np.arange(PHASE_TOP - 360.0, PHASE_TOP + 1.0, 90.0))
        phase.set_ylim(PHASE_TOP - 375.0, PHASE_TOP + 15.0)
    for column in range(2):
        axes[-1, column].set_xlabel("frequency [Hz]")
    for index, (magnitude, labels) in enumerate(legends):
        # the tip panels' legend once when both columns group the booms alike
        if index == 1 and labels == legends[0][1]:
            continue
        magnitude.legend(loc="best", frameon=False)
    axes[0, 0].margins(x=0)
    fit_width(fig.suptitle(title))
    fig.tight_layout()
    return save(fig, path)


def plant_figure(plant, params, listed, path, band=None):
    """The Bode figure of `plant` (built from the sail `params`) in `path`: over `band`
    (F_MIN, F_MAX) [Hz], else `bode_band` of the `listed` poles, on a grid that
    resolves each resonance; the title names the lengths, mode counts and damping, and
    the undamped poles that show. Returns the path."""
    pairs = bode_pairs(plant)
    low, high = band or bode_band(plant, pairs, listed)
    omega = bode_grid(plant, pairs, low, high)
    undamped = undamped_shown(plant, pairs, low, high)
    count = len({f for found in undamped.values() for f in found})
    title = (
        f"lengths {', '.join(f'{v:.4g}' for v in plant.lengths)} m, n_B = "
        f"{params.n_boom_modes}, n_M = {params.membrane_modes}, alpha = "
        f"{params.mass_damping:g} 1/s, beta = {params.stiffness_damping:g} s"
    )
    if count:
        title += (
            f"\nundamped: {count} poles that show here (v, along the top) lie on the "
            "imaginary axis, where |G| is unbounded: the lines are drawn to within 1e-4 of "
            "them and break there"
        )
    response = frequency_response(plant, omega)
    return bode_figure(omega, response, plant, path, title, marked=undamped)
