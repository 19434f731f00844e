"""What a reader of a saved figure would object to, measured on the drawn figure.

Inside `checking()`, every figure `plots.common.save` writes is drawn once more
and measured (`FigureCheck`): texts and legends outside the figure, texts over
each other or over another panel, lines hidden under another or under the
legend, vertical strokes in a line drawn against x, and what each panel shows.
The tests assert on it; outside `checking()` nothing is measured.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
from pathlib import Path

import numpy as np
from matplotlib.legend import Legend
from matplotlib.text import Text

from sail_ros import outputs


@dataclasses.dataclass(frozen=True)
class Panel:
    """What one panel (axes) of a saved figure shows.

    Attributes:
        xlabel, ylabel: its axis labels.
        ylim: its y-range (bottom, top).
        yticks: the y tick values drawn (inside the range).
        lines: the labels of its visible data lines ("" for an unlabelled one).
        segments: per line, its unbroken runs of points (NaN breaks a line).
    """

    xlabel: str
    ylabel: str
    ylim: tuple[float, float]
    yticks: tuple[float, ...]
    lines: tuple[str, ...]
    segments: tuple[int, ...]


@dataclasses.dataclass(frozen=True)
class FigureCheck:
    """What a reader of a saved figure would object to, measured on the drawn figure.

    Attributes:
        path: the PNG.
        size_px: (width, height) of the PNG [pixels].
        clipped: texts, legends and panels that reach outside the figure.
        overlaps: pairs of texts (titles, labels, tick labels, legends) drawn over
            each other, or a text over another panel's plotting area.
        hidden: pairs of lines of one panel drawn within half a pixel of each other
            everywhere (the first hides the second).
        jumps: lines that join two points of the same x (a vertical stroke: in a
            time history, two samples with one stamp, as at a reset).
        covered: lines with points under their panel's legend.
        panels: per panel (its title, or "panel i"), what it shows.
    """

    path: Path
    size_px: tuple[int, int]
    clipped: tuple[str, ...]
    overlaps: tuple[tuple[str, str], ...]
    hidden: tuple[tuple[str, str], ...]
    jumps: tuple[str, ...]
    covered: tuple[str, ...]
    panels: dict[str, Panel]


_recorders: list[dict[Path, FigureCheck]] = []


@contextlib.contextmanager
def checking():
    """Within the block, every figure saved is measured; yields {path: FigureCheck}, the
    path where the figure ends up (an output built under a temporary name moves)."""
    checks: dict[Path, FigureCheck] = {}

    def follow(built: Path, final: Path) -> None:
        for path in [p for p in checks if p == built or built in p.parents]:
            checks[final / path.relative_to(built)] = checks.pop(path)

    _recorders.append(checks)
    outputs.MOVED.append(follow)
    try:
        yield checks
    finally:
        _recorders.remove(checks)
        outputs.MOVED.remove(follow)


def record(fig, path, dpi: float) -> None:
    """Measure `fig`, about to be saved to `path` at `dpi`, for each `checking()` block."""
    if _recorders:
        check = inspect(fig, path, dpi)
        for checks in _recorders:
            checks[Path(path)] = check


def inspect(fig, path, dpi: float) -> FigureCheck:
    """Draw `fig` and measure it (see `FigureCheck`); `dpi` of the file it is saved to."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    panels = [ax for ax in fig.axes if ax.get_visible()]
    names = {}
    for i, ax in enumerate(panels):
        name = _panel_name(ax, i)
        names[ax] = name if name not in names.values() else f"{name} ({i})"

    clipped = []
    parts = []  # (owner, group, name, bbox) of every drawn text; a group's parts may touch
    for ax in panels:
        for group, name, bbox in _axes_texts(ax, renderer):
            parts.append((ax, group, f"{names[ax]}: {name}", bbox))
        if not _inside(ax.get_tightbbox(renderer), page):
            clipped.append(names[ax])
    for artist in [*fig.texts, *fig.legends]:
        if artist.get_visible() and _has_content(artist):
            name = f"figure {_kind(artist)}"
            parts.append((fig, None, name, artist.get_window_extent(renderer)))
    clipped += [name for _, _, name, bbox in parts if not _inside(bbox, page)]

    overlaps = []
    for (_, group_a, name_a, a), (_, group_b, name_b, b) in itertools.combinations(parts, 2):
        if (group_a is None or group_a != group_b) and _overlap(a, b):
            overlaps.append((name_a, name_b))
    for owner, _, name, bbox in parts:
        for ax in panels:
            if ax is not owner and ax.name != "3d" and _overlap(bbox, ax.bbox):
                overlaps.append((name, f"{names[ax]}: plotting area"))

    hidden, jumps, covered, described = [], [], [], {}
    for ax in panels:
        drawn = [line for line in ax.get_lines() if _is_data_line(line)]
        for first, second in itertools.combinations(drawn, 2):
            if _coincide(first, second):
                hidden.append((f"{names[ax]}: {_label(first)}", f"{names[ax]}: {_label(second)}"))
        jumps += [f"{names[ax]}: {_label(line)}" for line in drawn if _repeats_x(line)]
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            box = legend.get_window_extent(renderer)
            covered += [
                f"{names[ax]}: {_label(line)}" for line in drawn if _points_inside(line, box)
            ]
        low, high = ax.get_ylim()
        described[names[ax]] = Panel(
            ax.get_xlabel(),
            ax.get_ylabel(),
            (float(low), float(high)),
            tuple(float(v) for v in ax.get_yticks() if min(low, high) <= v <= max(low, high)),
            tuple(_label(line) for line in drawn),
            tuple(_segments(line) for line in drawn),
        )
    width, height = (round(v * dpi / fig.dpi) for v in (page.width, page.height))
    return FigureCheck(
        Path(path), (width, height), tuple(dict.fromkeys(clipped)),
        tuple(overlaps), tuple(hidden), tuple(jumps), tuple(covered), described,
    )  # fmt: skip


def _panel_name(ax, index: int) -> str:
    return ax.get_title().replace("\n", " ").strip() or f"panel {index}"


def _kind(artist) -> str:
    return "legend" if isinstance(artist, Legend) else artist.get_text()[:40]


def _has_content(artist) -> bool:
    return not isinstance(artist, Text) or bool(artist.get_text().strip())


def _axes_texts(ax, renderer):
    """(group, name, bbox) of each text a panel draws: titles, axis labels, tick
    labels, legend, annotations. A 3-D panel's axes come whole (their labels are
    placed in projection), in one group: they meet at the box's corners."""
    texts = [("title", ax.title)]
    if ax.name == "3d":
        for letter, axis in (("x", ax.xaxis), ("y", ax.yaxis), ("z", ax.zaxis)):
            if axis.get_visible():
                yield ax, f"{letter} axis", axis.get_tightbbox(renderer)
    else:
        for letter, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            if not axis.get_visible():
                continue
            texts.append((f"{letter} label", axis.label))
            # the ticks drawn, those inside the view (as Axis.get_tightbbox takes them);
            # the others keep stale positions
            for tick in axis._update_ticks():
                for label in (tick.label1, tick.label2):
                    texts.append((f"{letter} tick label {label.get_text()!r}", label))
    texts += [(f"text {t.get_text()[:30]!r}", t) for t in ax.texts]
    for name, text in texts:
        if text.get_visible() and text.get_text().strip():
            yield None, name, text.get_window_extent(renderer)
    legend = ax.get_legend()
    if legend is not None and legend.get_visible():
        yield None, "legend", legend.get_window_extent(renderer)


def _inside(bbox, page, slack: float = 0.5) -> bool:
    return (
        bbox.x0 >= page.x0 - slack
        and bbox.y0 >= page.y0 - slack
        and bbox.x1 <= page.x1 + slack
        and bbox.y1 <= page.y1 + slack
    )


def _overlap(a, b, slack: float = 1.0) -> bool:
    """True when two boxes share more than `slack` pixels in both directions."""
    width = min(a.x1, b.x1) - max(a.x0, b.x0)
    height = min(a.y1, b.y1) - max(a.y0, b.y0)
    return width > slack and height > slack


def _is_data_line(line) -> bool:
    return line.get_visible() and len(line.get_xdata()) > 1 and line.get_linestyle() != "None"


def _label(line) -> str:
    label = line.get_label()
    return "" if label.startswith("_") else label


def _finite_points(line) -> np.ndarray:
    xy = np.asarray(line.get_xydata(), dtype=float)
    return np.all(np.isfinite(xy), axis=1)


def _segments(line) -> int:
    """Unbroken runs of finite points of a line."""
    finite = _finite_points(line)
    return int(finite[0]) + int(np.sum(finite[1:] & ~finite[:-1]))


def _repeats_x(line) -> bool:
    """Whether a line drawn as a function of x (x never decreasing) joins two
    consecutive points of equal x and different y: a vertical stroke."""
    xy = np.asarray(line.get_xydata(), dtype=float)
    finite = _finite_points(line)
    joined = finite[1:] & finite[:-1]  # NaN breaks the line: no stroke across it
    step, rise = np.diff(xy[:, 0])[joined], np.diff(xy[:, 1])[joined]
    if np.any(step < 0) or not np.any(step > 0):
        return False
    return bool(np.any((step == 0) & (rise != 0)))


def _points_inside(line, box) -> bool:
    """Whether any point of a line is drawn inside `box` (display coordinates)."""
    xy = line.get_transform().transform(np.asarray(line.get_xydata(), dtype=float))
    x, y = xy[:, 0], xy[:, 1]
    return bool(np.any((x > box.x0) & (x < box.x1) & (y > box.y0) & (y < box.y1)))


def _coincide(first, second) -> bool:
    """Whether two lines are drawn within half a pixel of each other at every point."""
    a = first.get_transform().transform(first.get_xydata())
    b = second.get_transform().transform(second.get_xydata())
    if a.shape != b.shape:
        return False
    finite = np.isfinite(a) & np.isfinite(b)
    if not finite.any() or np.any(np.isfinite(a) != np.isfinite(b)):
        return False
    return bool(np.all(np.abs(a[finite] - b[finite]) <= 0.5))
