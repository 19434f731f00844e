"""Saving figures, and the look shared by all of them: the style, long titles
wrapped to the figure, lines broken where time repeats."""

from __future__ import annotations

import functools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never a window

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sail_ros.outputs import staged  # noqa: E402
from sail_ros.plots.figure_check import record  # noqa: E402

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


def fit_width(text, fraction: float = 0.96) -> None:
    """Break the lines of a text artist (a title) at spaces so that each spans at most
    `fraction` of its figure's width: a long scenario description wraps instead of
    running off the page."""
    fig = text.get_figure(root=True)
    renderer = fig.canvas.get_renderer()
    limit = fraction * fig.bbox.width

    def width(line: str) -> float:
        text.set_text(line)
        return text.get_window_extent(renderer).width

    lines = []
    for line in text.get_text().split("\n"):
        words = line.split(" ")
        current = words[0]
        for word in words[1:]:
            if width(f"{current} {word}") <= limit:
                current = f"{current} {word}"
            else:
                lines.append(current)
                current = word
        lines.append(current)
    text.set_text("\n".join(lines))


def break_lines(t, *columns):
    """`t` and `columns` with a NaN row inserted wherever `t` does not increase, so
    that a line breaks there instead of drawing a vertical jump (a live simulator
    publishes a fresh sample at a reset, with the stamp of the sample before it)."""
    t = np.asarray(t, dtype=float)
    where = np.flatnonzero(np.diff(t) <= 0) + 1
    if not where.size:
        return (t, *(np.asarray(c) for c in columns))
    result = [np.insert(t, where, np.nan)]
    for column in columns:
        column = np.asarray(column, dtype=float)
        result.append(np.insert(column, where, np.nan, axis=0))
    return tuple(result)


def save(fig, path) -> Path:
    """Write `fig` as PNG to `path` (folders created; whole or not at all:
    `outputs.staged`) and release it."""
    path = Path(path)
    try:
        record(fig, path, DPI)  # measured for the tests when they ask (figure_check.checking)
        with staged(path) as building:
            fig.savefig(building, dpi=DPI, format="png", metadata={"Software": "sail_ros"})
    finally:
        plt.close(fig)
    return path
