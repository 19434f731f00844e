"""Time histories: boom-tip deflections, boom lengths and rates, energies, real-time factor.

Shared by `sail-ros deploy` (a run in memory) and `sail-ros report` (a log
read back); every function takes arrays and a time axis label. Booms (and
quadrants) whose series are equal share one line and one legend entry
(`equal_groups`); legends stand beside the panels, clear of the data; a run's
load changes (`loads`: `(t, what)` pairs) are dotted lines through the panels,
named along the top, and the loads it starts with are named in the title.
"""

from __future__ import annotations

import numpy as np

from sail_ros.plots.common import (
    BOOM_COLOURS,
    QUADRANT_COLOURS,
    break_lines,
    figure,
    save,
    styled,
    titled_layout,
)

TIME_LABEL = "simulation time t [s]"
BOOMS = tuple(BOOM_COLOURS)


@styled
def tip_deflections_figure(t, tips, path, title: str = "", time_label: str = TIME_LABEL,
                           loads=()):  # fmt: skip
    """Boom-tip deflections [m, drawn in mm] of booms a..d against time [s]; tips (k, 4);
    `loads`: the run's load changes, `(t [s], what)`."""
    fig, ax = figure(6.4, 3.4)
    groups = equal_groups(tips)
    t, tips = break_lines(t, tips)
    for group in groups:
        ax.plot(
            t,
            1e3 * tips[:, group[0]],
            color=BOOM_COLOURS[BOOMS[group[0]]],
            lw=1.2,
            label=_boom_label(group),
        )
    ax.set_xlabel(time_label)
    ax.set_ylabel("tip deflection [mm]")
    ax.margins(x=0)
    _legend_beside(ax)
    _heading(fig, ax, "Boom-tip deflections", _with_loads(title, t, loads, [ax]))
    return save(fig, path)


@styled
def root_moments_figure(t, moments, path, title: str = "", time_label: str = TIME_LABEL,
                        n_boom_modes: int | None = None, loads=()):  # fmt: skip
    """Root bending moments [N m] of booms a..d against time [s]; moments (k, 4). The
    moment series converges slowly with n_B, so the title states it when known;
    `loads`: the run's load changes, `(t [s], what)`."""
    fig, ax = figure(6.4, 3.4)
    groups = equal_groups(moments)
    t, moments = break_lines(t, moments)
    for group in groups:
        colour = BOOM_COLOURS[BOOMS[group[0]]]
        ax.plot(t, moments[:, group[0]], color=colour, lw=1.2, label=_boom_label(group))
    ax.set_xlabel(time_label)
    ax.set_ylabel("root bending moment [N m]")
    ax.margins(x=0)
    modes = f" (n_B = {n_boom_modes})" if n_boom_modes else ""
    _legend_beside(ax)
    _heading(fig, ax, f"Boom root moments{modes}", _with_loads(title, t, loads, [ax]))
    return save(fig, path)


@styled
def boom_lengths_figure(t, lengths, rates, path, title: str = "", time_label: str = TIME_LABEL):
    """Boom lengths [m] and extension rates [m/s] of booms a..d against time [s];
    lengths and rates (k, 4). Booms whose curve is the same share one line in that
    panel (equal rates but different lengths: one rate line, four length lines)."""
    fig, (top, bottom) = figure(6.4, 4.6, nrows=2, sharex=True)
    groups = [equal_groups(lengths), equal_groups(rates)]
    t, lengths, rates = break_lines(t, lengths, rates)
    for ax, values, panel_groups in zip((top, bottom), (lengths, rates), groups, strict=True):
        for group in panel_groups:
            colour = BOOM_COLOURS[BOOMS[group[0]]]
            ax.plot(t, values[:, group[0]], color=colour, lw=1.3, label=_boom_label(group))
    top.set_ylabel("boom length L [m]")
    bottom.set_ylabel("extension rate [m/s]")
    bottom.set_xlabel(time_label)
    for ax in (top, bottom) if groups[0] != groups[1] else (top,):
        _legend_beside(ax, ncols=1)
    top.margins(x=0)
    _heading(fig, top, "Boom lengths and extension rates", title)
    return save(fig, path)


@styled
def energies_figure(
    t, booms, quadrants, total, path, title: str = "", time_label: str = TIME_LABEL, loads=()
):
    """Mechanical energy [J] per boom and per quadrant group, and in all, against time [s].

    Args:
        t: times [s], (k,).
        booms: (k, 4) energies of the boom coordinate groups a..d.
        quadrants: (k, 4) energies of the membrane groups ab, bc, cd, da.
        total: (k,) total mechanical energy of the sail.
        path: output file.
        title: figure title.
        time_label: label of the time axis.
        loads: the run's load changes, `(t [s], what)`.
    """
    fig, axes = figure(6.4, 6.0, nrows=3, sharex=True)
    boom_groups, quadrant_groups = equal_groups(booms), equal_groups(quadrants)
    t, booms, quadrants, total = break_lines(t, booms, quadrants, total)
    for group in boom_groups:
        axes[0].plot(
            t,
            booms[:, group[0]],
            color=BOOM_COLOURS[BOOMS[group[0]]],
            lw=1.2,
            label=_boom_label(group) + _zero_note(booms, group),
        )
    names = tuple(QUADRANT_COLOURS)
    for group in quadrant_groups:
        label = ", ".join(names[k] for k in group)
        axes[1].plot(
            t,
            quadrants[:, group[0]],
            color=QUADRANT_COLOURS[names[group[0]]],
            lw=1.2,
            label=f"membrane{'s' if len(group) > 1 else ''} {label}" + _zero_note(quadrants, group),
        )
    axes[2].plot(t, total, color="k", lw=1.3, label="total")
    # from zero: a conserved energy must look flat, not magnify its round-off
    axes[2].set_ylim(0.0, 1.15 * max(float(np.nanmax(total)), 1e-300))
    for ax, values in zip(axes[:2], (booms, quadrants), strict=True):
        if np.any(values > 0):  # all-zero groups (nothing moved) stay on a linear axis
            ax.set_yscale("log")
    for ax in axes:
        ax.set_ylabel("energy [J]")
        ax.margins(x=0)
        _legend_beside(ax, ncols=1, fontsize=7)
    axes[2].set_xlabel(time_label)
    detail = _with_loads(title, t, loads, axes)
    _heading(fig, axes[0], "Mechanical energy by coordinate group (log) and in total (linear)",
             detail)  # fmt: skip
    return save(fig, path)


@styled
def real_time_factor_figure(
    t, factor, path, title: str = "", time_label: str = TIME_LABEL, time_scale=None
):
    """Achieved real-time factor (simulated s per wall s) against time [s], with the
    time scale asked for (`time_scale`: one value or one per sample; <= 0 is as fast
    as possible, drawn as no line). The y-range fits the values, so that a factor
    that stays within a per cent of its time scale shows how it varies."""
    fig, ax = figure(6.4, 3.0)
    scale = np.broadcast_to(np.nan if time_scale is None else time_scale, np.shape(factor))
    t, factor, scale = break_lines(t, factor, scale)
    ax.plot(t, factor, color="k", lw=1.2, marker=".", ms=3, label="achieved")
    shown = [factor]
    if time_scale is not None:
        paced = np.where(scale > 0, scale, np.nan)
        if np.any(np.isfinite(paced)):
            values = np.unique(paced[np.isfinite(paced)])
            what = f"{values[0]:g}" if values.size == 1 else "as set"
            ax.plot(t, paced, color="tab:red", lw=0.9, ls="--", drawstyle="steps-post",
                    label=f"time scale asked for ({what})")  # fmt: skip
            shown.append(paced)
        if np.any(scale <= 0):
            ax.plot([], [], ls="", label="time scale <= 0: as fast as possible")
    ax.set_xlabel(time_label)
    ax.set_ylabel("real-time factor [-]")
    values = np.concatenate([np.ravel(v) for v in shown])
    values = values[np.isfinite(values)]
    if values.size:
        low, high = float(values.min()), float(values.max())
        # at least 2 % of the level: round-off of a steady factor is not magnified
        span = max(high - low, 0.02 * max(abs(high), 1e-3))
        middle = 0.5 * (low + high)
        ax.set_ylim(middle - 0.65 * span, middle + 0.85 * span)  # room for the legend
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.legend(loc="upper right", ncols=2, frameon=False)
    ax.margins(x=0)
    _heading(fig, ax, "Achieved real-time factor (from /diagnostics)", title)
    return save(fig, path)


@styled
def hub_attitude_figure(t, hub, holds, path, title: str = "", time_label: str = TIME_LABEL):
    """A free hub against time [s]: its tilts theta_x, theta_y [rad, drawn in mrad as the
    tools print them], its heave z_h [m, drawn in mm] and what its in-plane and spin
    holds supply.

    Args:
        t: times [s], (k,).
        hub: (k, 6) z_h [m], theta_x, theta_y [rad] and their rates (`StateSample.hub`).
        holds: (k, 3) F_x, F_y [N] and tau_z [N m] (`deployment.hold_reactions`), or None.
        path: output file.
        title: the run, under the figure's title.
        time_label: label of the time axis.
    """
    rows = 3 if holds is not None else 2
    fig, axes = figure(6.4, 2.0 + 1.6 * rows, nrows=rows, sharex=True)
    t, hub, *rest = break_lines(t, hub, *(() if holds is None else (holds,)))
    tilts = 1e3 * hub[:, 1:3]
    axes[0].plot(t, tilts[:, 0], color="tab:blue", lw=1.2, label="theta_x (about boom a)")
    axes[0].plot(t, tilts[:, 1], color="tab:orange", lw=1.2, label="theta_y (about boom b)")
    tilt = np.hypot(tilts[:, 0], tilts[:, 1])
    axes[0].plot(t, tilt, color="k", lw=0.9, ls="--", label="tilt |theta|")
    axes[0].set_ylabel("hub tilt [mrad]")
    axes[1].plot(t, 1e3 * hub[:, 0], color="k", lw=1.2, label="heave z_h")
    axes[1].set_ylabel("hub heave [mm]")
    if holds is not None:
        force = axes[2]
        force.plot(t, rest[0][:, 0], color="tab:green", lw=1.2, label="F_x")
        force.plot(t, rest[0][:, 1], color="tab:purple", lw=1.2, label="F_y")
        force.set_ylabel("hold force [N]")
        lines = force.get_lines()
        if np.any(np.nan_to_num(rest[0][:, 2]) != 0):
            torque = force.twinx()
            torque.plot(t, rest[0][:, 2], color="tab:red", lw=1.0, ls="--", label="tau_z")
            torque.set_ylabel("spin hold torque [N m]", color="tab:red")
            lines += torque.get_lines()
        else:
            lines.append(force.plot([], [], ls="", label="tau_z = 0 throughout")[0])
        force.legend(lines, [line.get_label() for line in lines], ncols=3, loc="best",
                     frameon=False)  # fmt: skip
    for ax in axes[:2]:
        ax.legend(ncols=3, loc="best", frameon=False)
    for ax in axes:
        ax.margins(x=0)
    axes[-1].set_xlabel(time_label)
    _heading(fig, axes[0], "Free hub: attitude, heave and hold reactions", title)
    return save(fig, path)


def _zero_note(values, group) -> str:
    """A legend note for a group whose energy is 0 throughout while another's is not:
    the log axis cannot draw it."""
    drawn = np.nan_to_num(values)
    if np.any(drawn[:, group[0]] != 0) or not np.any(drawn > 0):
        return ""
    return " (0 J throughout)"


def _heading(fig, ax, what: str, detail: str) -> None:
    """`what`, and `detail` (the run) on the next line, over `ax`, wrapped to the room
    about the panel's centre, and the figure laid out."""
    titled_layout(fig, ax, f"{what}\n{detail}" if detail else what)


def _legend_beside(ax, ncols: int = 1, **options) -> None:
    """The panel's legend to the right of its plotting area, clear of every curve and
    mark (`fig.tight_layout` makes room for it)."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, ncols=ncols,
              frameon=False, **options)  # fmt: skip


def _with_loads(title: str, t, loads, axes) -> str:
    """Mark a run's load changes (`(t [s], what)`) after its first time as dotted lines
    through `axes`, named along the top of the first; the title with the loads the run
    starts with."""
    finite = np.asarray(t, dtype=float)
    finite = finite[np.isfinite(finite)]
    start = float(finite[0]) if finite.size else 0.0
    first = [what for when, what in loads if when <= start]
    later = [(when, what) for when, what in loads if when > start]
    for ax in axes:
        for when, _ in later:
            ax.axvline(when, color="0.4", lw=0.8, ls=":", zorder=1)
    if later:
        top = axes[0].secondary_xaxis("top")
        top.set_xticks([when for when, _ in later], [what for _, what in later], fontsize=7)
        top.tick_params(length=2, pad=1)
    if first:
        title = f"{title}; " if title else ""
        title += "loads from the start: " + ", ".join(first)
    return title


def equal_groups(columns) -> list[list[int]]:
    """Column indices grouped by equal series (relative 1e-9 of the largest value),
    so that booms moving alike get one line instead of hidden overlapping ones."""
    columns = np.asarray(columns)
    tolerance = 1e-9 * max(float(np.abs(columns).max(initial=0.0)), 1e-300)
    groups: list[list[int]] = []
    for k in range(columns.shape[1]):
        for group in groups:
            if np.all(np.abs(columns[:, k] - columns[:, group[0]]) <= tolerance):
                group.append(k)
                break
        else:
            groups.append([k])
    return groups


def _boom_label(group) -> str:
    names = ", ".join(BOOMS[k] for k in group)
    return f"boom {names}" if len(group) == 1 else f"booms {names}"
