"""The text blocks several tools print: a sail's parameters with their units, each
boom's true peaks with their times (and their convergence), a free hub's peaks (in
text and in JSON)."""

from __future__ import annotations

import numpy as np

from sail_ros.analysis.json_values import json_number
from sail_ros.model import SailParameters
from sail_ros.model.parameters import DEFAULT_RESOLVED_LENGTH


def _automatic(params) -> str:
    """How an automatic membrane count was chosen ("" for a count given)."""
    if params.n_membrane_modes:
        return ""
    length = params.resolved_length or DEFAULT_RESOLVED_LENGTH
    capped = ""
    if params.membrane_mode_need > params.membrane_modes:
        capped = f", capped from {params.membrane_mode_need}"
    return (
        f"; n_M automatic: the membrane modes up to {params.membrane_band:g} x the first "
        f"cantilever frequency at L = {length:g} m{capped}"
    )


def describe_parameters(params: SailParameters) -> str:
    """The parameters in one block, with units, for printing next to results (a free
    hub's in one more line)."""
    hub = []
    if params.free_hub:
        stowed = "on the hub" if params.stowed_mass_on_hub else "not counted"
        hub.append(
            f"  free hub                m_h = {params.hub_mass:g} kg, J_x = "
            f"{params.hub_inertia_x:g} kg m^2, J_y = {params.hub_inertia_y:g} kg m^2, "
            f"stowed material {stowed}"
        )
    return "\n".join(
        [
            f"  sail side a             {params.sail_side:g} m (full boom length "
            f"{params.full_boom_length:.4g} m)",
            f"  boom EI                 {params.boom_bending_stiffness:g} N m^2",
            f"  boom rho_B              {params.boom_linear_density:g} kg/m",
            f"  film h, rho             {params.membrane_thickness:g} m, "
            f"{params.membrane_density:g} kg/m^3 "
            f"(rho_M = {params.membrane_areal_density:.4g} kg/m^2)",
            f"  film prestress          {params.membrane_prestress:g} Pa "
            f"(N0 = {params.membrane_tension:.4g} N/m)",
            f"  boom axial load P       {params.boom_axial_load:g} N",
            f"  modes n_B, n_M          {params.n_boom_modes}, {params.membrane_modes} "
            f"({4 * params.n_boom_modes + 4 * params.membrane_modes}"
            f"{' + 3 hub' if params.free_hub else ''} coordinates){_automatic(params)}",
            f"  Rayleigh damping        alpha = {params.mass_damping:g} 1/s, "
            f"beta = {params.stiffness_damping:g} s",
            *hub,
        ]
    )


def print_peak_table(peaks, convergence=None, indent: str = "  ") -> None:
    """Each boom's peak |tip deflection| [mm] and |root moment| [N m] with its time, and
    with a `Convergence` (`analysis.convergence`) each one's change [%] against its
    finest rerun: over the largest peak of its kind, and over the boom's own."""
    tips = [
        ("|tip deflection| [mm]", 1e3 * peaks.tip_deflection.value, "12.4f"),
        ("  at t [s]", peaks.tip_deflection.time_s, "12.3f"),
    ]
    moments = [
        ("|root moment| [N m]", peaks.root_moment.value, "12.5g"),
        ("  at t [s]", peaks.root_moment.time_s, "12.3f"),
    ]
    if convergence is not None:
        finest, change = convergence.finest, convergence.change
        against = f"against ({finest.n_boom_modes}, {finest.n_membrane_modes}) modes"
        for rows, largest, own in ((tips, change.tips, change.tips_own),
                                   (moments, change.moments, change.moments_own)):  # fmt: skip
            rows.append((f"  change {against}, % of the largest", 100 * largest, "+12.3f"))
            rows.append((f"  change {against}, % of its own peak", 100 * own, "+12.3f"))
    lines = tips + moments  # a peak of 0 (the output never moved) has no time: a dash
    width = max(len(label) for label, _, _ in lines) + 2
    print(f"{indent}{'':{width}}" + "".join(f"{'boom ' + b:>12}" for b in "abcd"))
    for label, values, spec in lines:
        print(f"{indent}{label:<{width}}" + "".join(_cell(v, spec) for v in values))


def _cell(value: float, spec: str) -> str:
    """`value` as `spec`, or a dash in its place when it is not a number (the time of a
    peak that is 0)."""
    width = int(spec.lstrip("+").split(".")[0])
    return f"{value:>{spec}}" if np.isfinite(value) else f"{'-':>{width}}"


def print_hub_peak_table(hub, indent: str = "  ") -> None:
    """A free hub's peak |z_h| [mm], |theta_x|, |theta_y| and tilt |theta| [mrad] with their
    times (`Peaks.hub`)."""
    labels = ("|z_h| [mm]", "|theta_x| [mrad]", "|theta_y| [mrad]", "|theta| [mrad]")
    print(f"{indent}{'':12}" + "".join(f"{label:>18}" for label in labels))
    print(f"{indent}{'peak':<12}" + "".join(f"{1e3 * v:18.4f}" for v in hub.value))
    print(f"{indent}{'  at t [s]':<12}" + "".join(_cell(v, "18.3f") for v in hub.time_s))


# a free hub's peaks (`Peaks.hub`) as --json names them: `peak_<name>`, and
# `peak_<name less its unit>_time_s`
HUB_NAMES = ("heave_m", "tilt_x_rad", "tilt_y_rad", "tilt_rad")


def hub_peaks_json(hub, holds) -> dict:
    """A free hub's true peaks and its holds' peak reactions, for --json."""
    report = {f"peak_{name}": float(v) for name, v in zip(HUB_NAMES, hub.value, strict=True)}
    report |= {
        f"peak_{name.rsplit('_', 1)[0]}_time_s": json_number(v)
        for name, v in zip(HUB_NAMES, hub.time_s, strict=True)
    }
    report |= {
        "peak_hold_force_N": holds.force,
        "peak_hold_force_time_s": holds.force_time_s,
        "peak_hold_torque_N_m": holds.torque,
        "peak_hold_torque_time_s": holds.torque_time_s,
        "hold_spacing_s": holds.spacing_s,
    }
    return report
