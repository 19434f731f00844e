"""Stability figures: max Re(lambda) against prestress per rate, the stability map, and
eigenvalue loci; `stability_figures` draws the three of a `sail-ros stability` run."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
from matplotlib import cm
from matplotlib.colors import LogNorm
from matplotlib.lines import Line2D

from sail_ros.analysis.stability import CRITICAL, INSTABILITY_RTOL, eigenvalue_loci
from sail_ros.analysis.stability_table import FIGURES
from sail_ros.plots.common import figure, fit_width, save, styled

RATE_CMAP = "viridis"
LOCI_CMAP = "plasma"


def _linthresh(values, round_off=1e-12) -> float:
    """Linear range of a symlog axis: a decade below the smallest |value| that is not
    round-off (above `round_off`, a number or one per value)."""
    values = np.abs(np.asarray(values, dtype=float))
    values = values[values > round_off]
    return 10.0 ** math.floor(math.log10(values.min())) if values.size else 1e-6


def _rate_colours(rates) -> dict[float, tuple]:
    """A colour per |rate| (log-spaced along the colour map), zero excluded."""
    speeds = sorted({abs(r) for r in rates if r != 0})
    cmap = matplotlib.colormaps[RATE_CMAP]
    if len(speeds) == 1:
        return {speeds[0]: cmap(0.4)}
    norm = LogNorm(speeds[0], speeds[-1])
    return {s: cmap(0.85 * float(norm(s))) for s in speeds}


@styled
def max_real_figure(sweeps, path, sail_prestress: float | None = None):
    """Max Re(lambda) [1/s] against membrane prestress [Pa], one panel per length.

    Deployment (rate > 0) solid, retraction dashed, zero rate black dotted;
    colour by |rate|; a dot marks each critical prestress; a grey line the
    sail's own prestress.
    """
    lengths = sorted({s.length for s in sweeps})
    columns = min(len(lengths), 3)
    rows = math.ceil(len(lengths) / columns)
    fig, axes = figure(
        3.6 * columns + 2.0, 3.4 * rows + 0.6, nrows=rows, ncols=columns, squeeze=False, sharey=True
    )
    colours = _rate_colours([s.rate for s in sweeps])
    # a real part within the instability criterion's tolerance of 0 is round-off: drawn
    # in the linear range about 0, not given decades of its own
    threshold = _linthresh(
        np.concatenate([s.max_real for s in sweeps]),
        np.concatenate([INSTABILITY_RTOL * s.max_abs for s in sweeps]),
    )
    for ax, length in zip(axes.flat, lengths, strict=False):
        for sweep in (s for s in sweeps if s.length == length):
            if sweep.rate == 0:
                style = {"color": "k", "ls": ":"}
            else:
                style = {"color": colours[abs(sweep.rate)], "ls": "-" if sweep.rate > 0 else "--"}
            ax.plot(sweep.prestress, sweep.max_real, lw=1.4, **style)
            if sweep.critical_prestress is not None:
                ax.plot(
                    [sweep.critical_prestress],
                    [0.0],
                    "o",
                    ms=4.5,
                    mfc=style["color"],
                    mec="k",
                    mew=0.6,
                    zorder=5,
                )
        if sail_prestress is not None:
            ax.axvline(sail_prestress, color="0.5", lw=1.0)
            ax.annotate(
                "sail",
                (sail_prestress, 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(3, -10),
                textcoords="offset points",
                color="0.4",
                fontsize=8,
            )
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xscale("log")
        # linscale 1: +-threshold sit a decade's height from 0, as far apart as the
        # other labels (closer, they run into each other on a short panel)
        ax.set_yscale("symlog", linthresh=threshold, linscale=1.0)
        ax.set_title(f"L = {length:.4g} m")
        ax.set_xlabel("membrane prestress $\\sigma$ [Pa]")
    for ax in axes[:, 0]:
        ax.set_ylabel(f"max Re($\\lambda$) [1/s]  (symlog, linear within $\\pm${threshold:g})")
    for ax in axes.flat[len(lengths) :]:
        ax.set_visible(False)
    handles = [
        Line2D([], [], color=colours[s], lw=1.4, label=f"|rate| {s:g} m/s") for s in sorted(colours)
    ]
    handles += [
        Line2D([], [], color="0.3", ls="-", label="deployment"),
        Line2D([], [], color="0.3", ls="--", label="retraction"),
    ]
    if any(s.rate == 0 for s in sweeps):
        handles.append(Line2D([], [], color="k", ls=":", label="rate 0"))
    handles.append(Line2D([], [], ls="", marker="o", mfc="w", mec="k", label="critical prestress"))
    fig.legend(handles=handles, loc="center right", frameon=False)
    fit_width(
        fig.suptitle(
            "Frozen-length stability (seed Eq. 3)\nlargest real part of the eigenvalues; "
            "> 0 is unstable",
            fontsize=10,
        )
    )
    right = 1.0 - 1.9 / fig.get_figwidth()  # room for the legend
    fig.subplots_adjust(
        left=0.75 / fig.get_figwidth(), right=right, bottom=0.13, top=0.84, wspace=0.08, hspace=0.4
    )
    return save(fig, path)


def _rate_edges(ax, rates) -> np.ndarray:
    """Edges of the rates' cells on `ax`'s (symlog) x axis: halfway between neighbours
    in the drawn coordinate, the outer ones as far out as the inner gaps."""
    scale = ax.xaxis.get_transform()
    drawn = scale.transform(np.asarray(rates, dtype=float))
    gaps = np.diff(drawn) if drawn.size > 1 else np.array([2.0])
    inner = 0.5 * (drawn[1:] + drawn[:-1])
    edges = np.concatenate([[drawn[0] - 0.5 * gaps[0]], inner, [drawn[-1] + 0.5 * gaps[-1]]])
    return scale.inverted().transform(edges)


@styled
def map_figure(sweeps, path, sail_prestress: float | None = None):
    """Stable and unstable regions over rate x prestress, one panel per length, with
    the critical prestress curve (deployment) and the sail's prestress. The rate axis is
    symmetric-logarithmic (linear within the smallest |rate| given, logarithmic beyond),
    a cell per rate of the grid centred on it."""
    from sail_ros.analysis.stability import critical_curves

    lengths = sorted({s.length for s in sweeps})
    rates = sorted({s.rate for s in sweeps})
    speeds = [abs(r) for r in rates if r != 0]
    linear = min(speeds, default=1.0)
    columns = min(len(lengths), 3)
    rows = math.ceil(len(lengths) / columns)
    fig, axes = figure(
        3.4 * columns + 0.8, 3.2 * rows + 0.8, nrows=rows, ncols=columns, squeeze=False,
        sharey=True, layout="constrained",
    )  # fmt: skip
    curves = critical_curves(sweeps)
    for ax, length in zip(axes.flat, lengths, strict=False):
        ax.set_xscale("symlog", linthresh=linear, linscale=1.0)
        here = {s.rate: s for s in sweeps if s.length == length}
        prestress = next(iter(here.values())).prestress
        unstable = np.array([here[r].unstable for r in rates], dtype=float).T
        ax.pcolormesh(
            _rate_edges(ax, rates),
            np.concatenate(
                [prestress[:1] / 1.2, np.sqrt(prestress[1:] * prestress[:-1]), prestress[-1:] * 1.2]
            ),  # fmt: skip
            unstable,
            cmap=matplotlib.colors.ListedColormap(["#cfe8cf", "#f3c2c2"]),
            vmin=0,
            vmax=1,
            shading="flat",
        )
        points = curves.get(length, [])
        if points:
            ax.plot([r for r, _ in points], [c for _, c in points], "k-o", ms=3, lw=1.2,
                    label="critical prestress")  # fmt: skip
        if sail_prestress is not None:
            ax.axhline(sail_prestress, color="0.3", lw=1.0, ls="--", label="sail")
        ax.set_yscale("log")
        ax.set_xticks(rates, [f"{r:g}" for r in rates], rotation=60)
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_title(f"L = {length:.4g} m")
        ax.set_xlabel(f"extension rate [m/s] (symlog, linear within $\\pm${linear:g})")
    for ax in axes[:, 0]:
        ax.set_ylabel("membrane prestress $\\sigma$ [Pa]")
    for ax in axes.flat[len(lengths) :]:
        ax.set_visible(False)
    handles = [
        matplotlib.patches.Patch(color="#cfe8cf", label="stable"),
        matplotlib.patches.Patch(color="#f3c2c2", label="unstable"),
        Line2D([], [], color="k", marker="o", ms=3, label="critical prestress"),
        Line2D([], [], color="0.3", ls="--", label="sail's prestress"),
    ]
    # below the panels, in as many rows as the figure's width needs
    columns_legend = 4 if columns > 1 else 2
    fig.legend(handles=handles, loc="outside lower center", ncols=columns_legend, frameon=False)
    title = fig.suptitle("Stability map (seed Eq. 3, frozen length, constant rate)", fontsize=10)
    fit_width(title)
    return save(fig, path)


@styled
def loci_figure(
    prestresses, eigenvalues, length: float, rate: float, path, critical: float | None = None
):
    """Eigenvalues in the complex plane (Im >= 0) as the prestress [Pa] varies.

    Args:
        prestresses: prestress per eigenvalue set [Pa].
        eigenvalues: one array of eigenvalues [1/s] per prestress.
        length: boom length [m] (title only).
        rate: extension rate [m/s] (title only).
        path: output file.
        critical: critical prestress [Pa] to state in the title, if any.
    """
    fig, ax = figure(6.2, 4.4)
    norm = LogNorm(min(prestresses), max(prestresses))
    cmap = LOCI_CMAP
    real = np.concatenate([e.real for e in eigenvalues])
    for s, values in zip(prestresses, eigenvalues, strict=True):
        upper = values[values.imag >= 0]
        ax.scatter(
            upper.real,
            upper.imag,
            s=5,
            c=np.full(upper.size, s),
            cmap=cmap,
            norm=norm,
            linewidths=0,
        )
    ax.axvline(0.0, color="k", lw=0.6)
    size = np.concatenate([np.abs(e) for e in eigenvalues])
    ax.set_xscale("symlog", linthresh=_linthresh(real, INSTABILITY_RTOL * size), linscale=0.5)
    ax.set_yscale("symlog", linthresh=0.01, linscale=0.5)
    top = max(float(np.max([e.imag.max() for e in eigenvalues])), 0.01)
    ax.set_ylim(0.0, 1.5 * top)
    ax.set_xlabel("Re($\\lambda$) [1/s]  (symlog; > 0 unstable)")
    ax.set_ylabel("Im($\\lambda$) [rad/s]  (symlog)")
    kind = "deployment" if rate > 0 else "retraction" if rate < 0 else "at rest"
    title = f"Eigenvalue loci, L = {length:.4g} m, rate {rate:+g} m/s ({kind})"
    if critical is not None:
        title += f"\ncritical prestress {critical:.4g} Pa"
    ax.set_title(title)
    fit_width(ax.title)
    bar = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, pad=0.02)
    bar.set_label("membrane prestress $\\sigma$ [Pa]")
    fig.tight_layout()
    return save(fig, path)


def stability_figures(table, folder, loci_rate: float | None = None) -> list:
    """The three figures of a `StabilityTable` in `folder` (`FIGURES`); the loci at the
    first length and `loci_rate` [m/s] (default: the fastest deployment rate, else the
    rate of largest magnitude). Returns their paths."""
    params, sweeps, rates = table.params, table.sweeps, table.rates
    real_path, map_path, loci_path = (folder / name for name in FIGURES)
    written = [
        max_real_figure(sweeps, real_path, params.membrane_prestress),
        map_figure(sweeps, map_path, params.membrane_prestress),
    ]
    deploying = [r for r in rates if r > 0]
    rate = (
        loci_rate
        if loci_rate is not None
        else (max(deploying) if deploying else max(rates, key=abs))
    )
    length = float(table.lengths[0])
    critical = next(
        (
            s.critical_prestress
            for s in sweeps
            if s.length == length and s.rate == rate and s.status == CRITICAL
        ),
        None,
    )
    loci = eigenvalue_loci(params, length, rate, table.prestresses)
    written.append(loci_figure(table.prestresses, loci, length, rate, loci_path, critical))
    return written
