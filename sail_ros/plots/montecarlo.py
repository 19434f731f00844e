"""Figures of a Monte Carlo study: tip envelopes, peak histograms, the most
influential input against the peak."""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import MaxNLocator

from sail_ros.plots.common import BOOM_COLOURS, figure, fit_width, save, styled

BOOMS = "abcd"


@styled
def envelopes_figure(t, tips, path, title: str = ""):
    """Median and 5-95 % band of each boom's tip deflection [mm] against time [s];
    `tips` (samples, k, 4) on the common times `t`, the study's output samples: the
    figure says how far apart they are (motion faster than they follow is not in the
    envelopes; the peaks figure has the true peaks)."""
    fig, axes = figure(8.0, 5.4, nrows=2, ncols=2, sharex=True, layout="constrained")
    tips = 1e3 * np.asarray(tips)
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for k, (ax, boom) in enumerate(zip(axes.ravel(), BOOMS, strict=True)):
        low, middle, high = np.percentile(tips[:, :, k], [5, 50, 95], axis=0)
        colour = BOOM_COLOURS[boom]
        ax.fill_between(t, low, high, color=colour, alpha=0.25, lw=0, label="5-95 %")
        ax.plot(t, middle, color=colour, lw=1.0, marker=".", ms=2.5, label="median")
        ax.set_title(f"boom {boom}")
        ax.set_ylabel("tip deflection [mm]")
        ax.margins(x=0)
    for ax in axes[1]:
        ax.set_xlabel("simulation time t [s]")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncols=2,
               frameon=False)  # fmt: skip
    fit_width(
        fig.suptitle(
            f"Tip-deflection envelopes over {tips.shape[0]} samples"
            + (f"\n{title}" if title else "")
            + f"\nof the runs' states every {spacing:.3g} s (the study's output_rate_hz; dots): "
            "faster motion is not in them; the peak histograms give the true peaks"
        )
    )
    return save(fig, path)


@styled
def peaks_figure(peaks, path, title: str = ""):
    """Histograms of each boom's peak |tip deflection| [mm]; `peaks` (samples, 4)."""
    fig, axes = figure(8.0, 4.6, nrows=2, ncols=2)
    peaks = 1e3 * np.asarray(peaks)
    for k, (ax, boom) in enumerate(zip(axes.ravel(), BOOMS, strict=True)):
        ax.hist(peaks[:, k], bins=30, color=BOOM_COLOURS[boom], alpha=0.8)
        ax.set_title(f"boom {boom}")
        ax.set_xlabel("peak |tip deflection| [mm]")
        ax.set_ylabel("samples [-]")
        ax.yaxis.set_major_locator(MaxNLocator(nbins="auto", integer=True))  # whole counts
    fit_width(fig.suptitle("Peak tip deflections" + (f"\n{title}" if title else "")))
    fig.tight_layout()
    return save(fig, path)


@styled
def influence_figure(values, peaks, name: str, rho: float, path, unit: str | None = None):
    """The most influential input (in `unit`; a length in m drawn in mm, as the peak is)
    against the peak |tip deflection| [mm]."""
    fig, ax = figure(6.0, 4.0)
    values = np.asarray(values, dtype=float)
    if unit == "m":
        values, unit = 1e3 * values, "mm"
    ax.scatter(values, 1e3 * np.asarray(peaks), s=8, alpha=0.6, color="tab:blue")
    ax.set_xlabel(f"{name} [{unit or '-'}]")
    ax.set_ylabel("peak |tip deflection|, all booms [mm]")
    ax.set_title(f"Most influential input: {name} (Spearman rho = {rho:+.3f})")
    fit_width(ax.title)
    fig.tight_layout()
    return save(fig, path)
