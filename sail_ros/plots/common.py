"""Saving figures, and the look shared by all of them: the style, long titles
wrapped to the figure, lines broken where time repeats, and no line hidden under
another: a line drawn over most of an earlier one (`figure_check.hidden_under`:
two booms that move alike for a while, not exactly) is drawn dashed when the
figure is saved, its legend entry too, so that both show."""

from __future__ import annotations

import functools
from pathlib import Path
from types import NoneType

import matplotlib

matplotlib.use("Agg")  # files only; never a window

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402

from sail_ros.outputs import staged  # noqa: E402
from sail_ros.plots.figure_check import (  # noqa: E402
    HIDDEN_SHARE,
    data_lines,
    hidden_under,
    record,
)

BOOM_COLOURS = {"a": "tab:blue", "b": "tab:orange", "c": "tab:green", "d": "tab:red"}
QUADRANT_COLOURS = {"ab": "tab:purple", "bc": "tab:brown", "cd": "tab:olive", "da": "tab:cyan"}
DPI = 150
REVEALING = (0, (3.0, 1.5))  # the dashes of a line drawn over most of an earlier one

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
    `fraction` of the figure's width about the text's centre (a panel's title beside a
    legend has less room than the figure's): a long scenario description wraps instead
    of running off the page."""
    fig = text.get_figure(root=True)
    renderer = fig.canvas.get_renderer()
    box = text.get_window_extent(renderer)
    middle = 0.5 * (box.x0 + box.x1)
    limit = fraction * 2.0 * min(middle - fig.bbox.x0, fig.bbox.x1 - middle)

    def width(line: str) -> float:
        text.set_text(line)
        return text.get_window_extent(renderer).width

    lines = []
    for line in text.get_text().split("\n"):
        pieces = _pieces(line, lambda piece: width(piece) > limit)
        current = pieces[0]
        for piece in pieces[1:]:
            joined = current + piece if current.endswith("/") else f"{current} {piece}"
            if width(joined) <= limit:
                current = joined
            else:
                lines.append(current)
                current = piece
        lines.append(current)
    text.set_text("\n".join(lines))


def _pieces(line: str, too_wide) -> list[str]:
    """The words of a line; a word too wide for a line alone (a path) in pieces after
    each "/" (a piece ending in "/" joins the next without a space)."""
    pieces = []
    for word in line.split(" "):
        if "/" in word and too_wide(word):
            parts = word.split("/")
            pieces += [part + "/" for part in parts[:-1]] + ([parts[-1]] if parts[-1] else [])
        else:
            pieces.append(word)
    return pieces


def titled_layout(fig, ax, title: str) -> None:
    """`ax`'s title, wrapped to the room about its centre, and the figure laid out
    (`tight_layout`) around it; wrapped again where the layout moved the panel's centre,
    and laid out again if that changed the lines."""
    ax.set_title(title)
    fit_width(ax.title)
    fig.tight_layout()
    wrapped = ax.title.get_text()
    ax.set_title(title)
    fit_width(ax.title)
    if ax.title.get_text() != wrapped:
        fig.tight_layout()


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


def reveal_hidden(fig) -> None:
    """Draw dashed each line that would cover more than `HIDDEN_SHARE` of an earlier
    line of its panel, and its legend entry, so that the earlier one shows between the
    dashes. Measured on the figure as laid out, without rendering its pixels."""
    if not any(len(data_lines(ax)) > 1 for ax in fig.axes):
        return
    # a layout engine places the panels (`tight_layout` leaves a placeholder, which does
    # not), and a 3-D line is projected, as the figure is drawn
    engine = fig.get_layout_engine()
    if not isinstance(engine, NoneType | PlaceHolderLayoutEngine) or any(
        ax.name == "3d" for ax in fig.axes
    ):
        fig.draw_without_rendering()
    else:  # the data's page positions: the panels' places are set (the figure laid out),
        for ax in fig.axes:  # their limits and aspect settled as drawing settles them
            ax.get_xlim(), ax.get_ylim()
            ax.apply_aspect()
    for ax in fig.axes:
        lines = sorted(data_lines(ax), key=lambda line: line.get_zorder())  # as drawn
        dashed = [
            over
            for k, over in enumerate(lines)
            if any(hidden_under(under, over) > HIDDEN_SHARE for under in lines[:k])
        ]
        for line in dashed:
            line.set_linestyle(REVEALING)
        legend = ax.get_legend()
        if dashed and legend is not None:
            labels = {line.get_label() for line in dashed}
            for handle, text in zip(legend.legend_handles, legend.texts, strict=True):
                if text.get_text() in labels:
                    handle.set_linestyle(REVEALING)


def save(fig, path) -> Path:
    """Write `fig` as PNG to `path` (folders created; whole or not at all:
    `outputs.staged`) and release it; lines that would hide others are dashed first
    (`reveal_hidden`)."""
    path = Path(path)
    try:
        reveal_hidden(fig)
        record(fig, path, DPI)  # measured for the tests when they ask (figure_check.checking)
        with staged(path) as building:
            fig.savefig(building, dpi=DPI, format="png", metadata={"Software": "sail_ros"})
    finally:
        plt.close(fig)
    return path
