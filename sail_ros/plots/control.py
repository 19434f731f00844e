"""The closed loop's figures: open against closed loop, and commands against states.

`closed_loop_figure` (`sail-ros deploy` with a controller) sets the free hub's tilt
and heave of the closed loop beside those of the same scenario in open loop, on log
axes (the two differ by orders of magnitude), over the commands and their limits.
`commands_figure` (`sail-ros report` of a log with /sail/hub_wrench_cmd) draws each
hub axis's state and the command on it, one axis a row.
"""

from __future__ import annotations

import numpy as np

from sail_ros.plots.common import break_lines, figure, save, styled
from sail_ros.plots.histories import TIME_LABEL, _heading

COMMAND_COLOURS = ("tab:green", "tab:blue", "tab:orange", "tab:red", "tab:purple",
                   "tab:brown", "tab:olive")  # fmt: skip
# (label, unit, scale) of a command channel by input name
COMMAND_UNITS = {
    "hub_force_z": ("F_z", "N"),
    "hub_torque_x": ("tau_x", "N m"),
    "hub_torque_y": ("tau_y", "N m"),
}


def _positive(values):
    """`values` with zeros (and below) as NaN: a log axis draws no 0."""
    values = np.asarray(values, dtype=float)
    return np.where(values > 0, values, np.nan)


@styled
def closed_loop_figure(open_loop, closed_loop, commands, path, title: str = ""):
    """Open against closed loop and the commands.

    Args:
        open_loop: `(t [s] (k,), hub (k, 6))` of the open loop (`StateSample.hub`).
        closed_loop: the same of the closed loop.
        commands: `(t [s] (k,), u (k, nu), names (nu,), limits (nu,))` of the controller.
        path: output file.
        title: the run, under the figure's title.
    """
    fig, axes = figure(6.4, 7.2, nrows=3, sharex=True)
    for (t, hub), style, which in (
        (open_loop, {"color": "0.45", "ls": "--"}, "open loop"),
        (closed_loop, {"color": "k"}, "closed loop"),
    ):
        axes[0].plot(t, _positive(1e3 * np.hypot(hub[:, 1], hub[:, 2])), lw=1.1, label=which,
                     **style)  # fmt: skip
        axes[1].plot(t, _positive(1e3 * np.abs(hub[:, 0])), lw=1.1, label=which, **style)
    axes[0].set_ylabel("hub tilt |theta| [mrad]")
    axes[1].set_ylabel("hub heave |z_h| [mm]")
    for ax in axes[:2]:
        ax.set_yscale("log")
        ax.legend(ncols=2, loc="lower right", frameon=False)
    t, u, names, limits = commands
    t, u = break_lines(t, u)
    for j, name in enumerate(names):
        label, unit = COMMAND_UNITS.get(name, (name, "N"))
        axes[2].plot(t, u[:, j], color=COMMAND_COLOURS[j], lw=0.9,
                     label=f"{label} [{unit}] (limit {limits[j]:g})")  # fmt: skip
    axes[2].set_ylabel("command [N, N m]")
    largest = float(np.max(limits)) if len(limits) else 1.0
    axes[2].set_ylim(-1.25 * largest, 1.8 * largest)  # the legend above the limit
    axes[2].legend(ncols=3, loc="upper center", frameon=False)
    for ax in axes:
        ax.margins(x=0)
    axes[-1].set_xlabel(TIME_LABEL)
    _heading(fig, axes[0], "Free hub: open and closed loop", title)
    return save(fig, path)


@styled
def commands_figure(t, hub, command_t, wrench, path, title: str = "", time_label=TIME_LABEL):
    """Each hub axis's state and the command on it: heave z_h [m, in mm] with F_z [N],
    theta_x and theta_y [rad, in mrad] with tau_x and tau_y [N m].

    Args:
        t: state times [s] (k,).
        hub: (k, 6) (`StateSample.hub`).
        command_t: command times [s] (m,).
        wrench: (m, 3) F_z, tau_x, tau_y.
        path: output file.
        title: the log, under the figure's title.
        time_label: label of the time axis.
    """
    fig, axes = figure(6.4, 7.2, nrows=3, sharex=True)
    t, hub = break_lines(t, hub)
    order = np.argsort(command_t, kind="stable")
    command_t, wrench = np.asarray(command_t)[order], np.asarray(wrench)[order]
    rows = (
        ("heave z_h [mm]", 1e3, 0, "F_z [N]"),
        ("tilt theta_x [mrad]", 1e3, 1, "tau_x [N m]"),
        ("tilt theta_y [mrad]", 1e3, 2, "tau_y [N m]"),
    )
    for ax, (label, scale, j, command) in zip(axes, rows, strict=True):
        ax.plot(t, scale * hub[:, j], color="k", lw=1.1)
        ax.set_ylabel(label)
        twin = ax.twinx()
        twin.plot(command_t, wrench[:, j], color="tab:red", lw=0.8)
        twin.set_ylabel(command, color="tab:red")
        twin.tick_params(axis="y", colors="tab:red")
        twin.grid(False)
        ax.margins(x=0)
    axes[-1].set_xlabel(time_label)
    _heading(fig, axes[0], "Free hub: states (black) and commands (red)", title)
    return save(fig, path)
