"""Saving figures, and the look shared by all of them."""

from __future__ import annotations

import functools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window

import matplotlib.pyplot as plt  # noqa: E402

BOOM_COLOURS = {"a": "tab:blue", "b": "tab:orange", "c": "tab:green", "d": "tab:red"}
QUADRANT_COLOURS = {"ab": "tab:purple", "bc": "tab:brown", "cd": "tab:olive", "da": "tab:cyan"}
DPI = 150

STYLE = {
    "font.size": 9,
    "axes.titlesize": 9,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
}


def styled(plot):
    """Run a plotting function (which ends in `save`) under the shared style.

    Font sizes are read when artists are drawn, so the whole function, saving
    included, runs inside the style context.
    """

    @functools.wraps(plot)
    def wrapper(*args, **kwargs):
        with plt.rc_context(STYLE):
            return plot(*args, **kwargs)

    return wrapper


def figure(width_in: float, height_in: float, **subplots):
    """A new figure [inches] and its axes (`plt.subplots` keyword arguments)."""
    return plt.subplots(figsize=(width_in, height_in), **subplots)


def save(fig, path) -> Path:
    """Write `fig` as PNG to `path` (folders created) and release it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, metadata={"Software": "sail_ros"})
    plt.close(fig)
    return path
