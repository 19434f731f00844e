"""Time histories: boom-tip deflections, boom lengths and rates, energies, real-time factor.

Shared by `sail-ros deploy` (a run in memory) and `sail-ros report` (a log
read back); every function takes arrays and a time axis label.
"""

from __future__ import annotations

import numpy as np

from sail_ros.plots.common import BOOM_COLOURS, QUADRANT_COLOURS, figure, save, styled

TIME_LABEL = "simulation time t [s]"
BOOMS = tuple(BOOM_COLOURS)


@styled
def tip_deflections_figure(t, tips, path, title: str = "", time_label: str = TIME_LABEL):
    """Boom-tip deflections [m, drawn in mm] of booms a..d against time [s]; tips (k, 4)."""
    fig, ax = figure(6.4, 3.4)
    tips = np.asarray(tips)
    for group in equal_groups(tips):
        ax.plot(
            t,
            1e3 * tips[:, group[0]],
            color=BOOM_COLOURS[BOOMS[group[0]]],
            lw=1.2,
            label=_boom_label(group),
        )
    ax.set_xlabel(time_label)
    ax.set_ylabel("tip deflection [mm]")
    ax.set_title(_title("Boom-tip deflections", title))
    ax.legend(ncols=4, loc="upper right", frameon=False)
    ax.margins(x=0)
    _headroom(ax)
    fig.tight_layout()
    return save(fig, path)


@styled
def root_moments_figure(t, moments, path, title: str = "", time_label: str = TIME_LABEL,
                        n_boom_modes: int | None = None):  # fmt: skip
    """Root bending moments [N m] of booms a..d against time [s]; moments (k, 4). The
    moment series converges slowly with n_B, so the title states it when known."""
    fig, ax = figure(6.4, 3.4)
    moments = np.asarray(moments)
    for group in equal_groups(moments):
        colour = BOOM_COLOURS[BOOMS[group[0]]]
        ax.plot(t, moments[:, group[0]], color=colour, lw=1.2, label=_boom_label(group))
    ax.set_xlabel(time_label)
    ax.set_ylabel("root bending moment [N m]")
    modes = f" (n_B = {n_boom_modes})" if n_boom_modes else ""
    ax.set_title(_title(f"Boom root moments{modes}", title))
    ax.legend(ncols=4, loc="upper right", frameon=False)
    ax.margins(x=0)
    _headroom(ax)
    fig.tight_layout()
    return save(fig, path)


@styled
def boom_lengths_figure(t, lengths, rates, path, title: str = "", time_label: str = TIME_LABEL):
    """Boom lengths [m] and extension rates [m/s] of booms a..d against time [s];
    lengths and rates (k, 4). Booms that move alike share one line."""
    fig, (top, bottom) = figure(6.4, 4.6, nrows=2, sharex=True)
    lengths, rates = np.asarray(lengths), np.asarray(rates)
    for group in equal_groups(np.concatenate([lengths, rates])):
        style = {"color": BOOM_COLOURS[BOOMS[group[0]]], "lw": 1.3}
        top.plot(t, lengths[:, group[0]], label=_boom_label(group), **style)
        bottom.plot(t, rates[:, group[0]], **style)
    top.set_ylabel("boom length L [m]")
    bottom.set_ylabel("extension rate [m/s]")
    bottom.set_xlabel(time_label)
    top.set_title(_title("Boom lengths and extension rates", title))
    top.legend(ncols=2, loc="best", frameon=False)
    top.margins(x=0)
    fig.tight_layout()
    return save(fig, path)


@styled
def energies_figure(
    t, booms, quadrants, total, path, title: str = "", time_label: str = TIME_LABEL
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
    """
    fig, axes = figure(6.4, 6.0, nrows=3, sharex=True)
    booms, quadrants = np.asarray(booms), np.asarray(quadrants)
    for group in equal_groups(booms):
        axes[0].plot(
            t,
            booms[:, group[0]],
            color=BOOM_COLOURS[BOOMS[group[0]]],
            lw=1.2,
            label=_boom_label(group),
        )
    names = tuple(QUADRANT_COLOURS)
    for group in equal_groups(quadrants):
        label = ", ".join(names[k] for k in group)
        axes[1].plot(
            t,
            quadrants[:, group[0]],
            color=QUADRANT_COLOURS[names[group[0]]],
            lw=1.2,
            label=f"membrane{'s' if len(group) > 1 else ''} {label}",
        )
    axes[2].plot(t, total, color="k", lw=1.3, label="total")
    # from zero: a conserved energy must look flat, not magnify its round-off
    axes[2].set_ylim(0.0, 1.15 * max(float(np.max(total)), 1e-300))
    for ax, values in zip(axes[:2], (booms, quadrants), strict=True):
        if np.any(values > 0):  # all-zero groups (nothing moved) stay on a linear axis
            ax.set_yscale("log")
    for ax in axes:
        ax.set_ylabel("energy [J]")
        ax.legend(ncols=4, loc="best", frameon=False, fontsize=7)
        ax.margins(x=0)
    axes[2].set_xlabel(time_label)
    axes[0].set_title(
        _title("Mechanical energy by coordinate group (log) and in total (linear)", title)
    )
    fig.tight_layout()
    return save(fig, path)


@styled
def real_time_factor_figure(t, factor, path, title: str = "", time_label: str = TIME_LABEL):
    """Achieved real-time factor (simulated s per wall s) against time [s]."""
    fig, ax = figure(6.4, 3.0)
    ax.plot(t, factor, color="k", lw=1.2, marker=".", ms=3)
    ax.axhline(1.0, color="tab:red", lw=0.8, ls="--", label="real time")
    ax.set_xlabel(time_label)
    ax.set_ylabel("real-time factor [-]")
    ax.set_title(_title("Achieved real-time factor (from /diagnostics)", title))
    ax.legend(loc="lower right", frameon=False)
    ax.set_ylim(bottom=0.0)
    ax.margins(x=0)
    fig.tight_layout()
    return save(fig, path)


def _title(what: str, detail: str) -> str:
    return f"{what}\n{detail}" if detail else what


def _headroom(ax, fraction: float = 0.2) -> None:
    """Extra space above the data for a legend inside the axes."""
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + fraction * (high - low))


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
