"""What a reader of a saved figure would object to, measured on the drawn figure.

Inside `checking()`, every figure `plots.common.save` writes is drawn once more
and measured (`FigureCheck`): texts and legends outside the figure, texts over
each other or over another panel, data under a panel's legend or annotations,
lines drawn twice (equal data as two lines) or hidden under a later line (their
legend entry shows nothing), vertical strokes in a line drawn against x, axes
whose tick values have no unit, and what each panel shows. The tests assert on
it; outside `checking()` nothing is measured.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import re
from pathlib import Path

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.legend import Legend
from matplotlib.path import Path as MplPath
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from sail_ros import outputs

# two lines whose data differ by at most this fraction of the larger's largest |value|
# are one curve drawn twice: they belong in one line with one legend entry
EQUAL_DATA = 1e-12
# a line is hidden when a later line covers more than this share of its points
HIDDEN_SHARE = 0.5
# a point of a line is covered when the later line's edge leaves at most this much of it
# showing [pixels]
FRINGE_PX = 1.0
UNIT = re.compile(r"\[[^\]]+\]")  # "[mm]", "[N m]", "[-]"


@dataclasses.dataclass(frozen=True)
class Panel:
    """What one panel (axes) of a saved figure shows.

    Attributes:
        xlabel, ylabel: its axis labels.
        zlabel: a 3-D panel's z label ("" for a flat panel).
        ylim: its y-range (bottom, top).
        yticks: the y tick values drawn (inside the range).
        lines: the labels of its visible data lines ("" for an unlabelled one).
        segments: per line, its unbroken runs of points (NaN breaks a line).
        styles: per line, its line style ("-", "--", ...).
        marks: the tick labels of a secondary x axis along its top (events).
    """

    xlabel: str
    ylabel: str
    zlabel: str
    ylim: tuple[float, float]
    yticks: tuple[float, ...]
    lines: tuple[str, ...]
    segments: tuple[int, ...]
    styles: tuple[str, ...]
    marks: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class FigureCheck:
    """What a reader of a saved figure would object to, measured on the drawn figure.

    Attributes:
        path: the PNG.
        size_px: (width, height) of the PNG [pixels].
        clipped: texts, legends and panels that reach outside the figure.
        overlaps: pairs of texts (titles, labels, tick labels, legends) drawn over
            each other, a text over another panel's plotting area, or a 3-D panel's
            axis label over one of its tick values.
        duplicates: pairs of lines of one panel whose data are equal (within
            `EQUAL_DATA` of the larger's largest value) drawn as two lines: one curve
            with two legend entries, one of which shows nothing.
        hidden: pairs (under, over) of lines of one panel where the later, solid line
            covers more than `HIDDEN_SHARE` of the earlier one's points (leaving at most
            `FRINGE_PX` of it showing): the earlier line's legend entry is not to be
            found in the panel.
        jumps: lines that join two points of the same x (a vertical stroke: in a
            time history, two samples with one stamp, as at a reset).
        covered: lines and filled areas drawn under a text of their panel (its legend,
            an annotation): "panel: line under legend".
        unitless: axes that show tick values but whose label gives no unit in
            brackets ("[mm]", "[-]"): "panel: x axis".
        panels: per panel (its title, or "panel i"), what it shows.
    """

    path: Path
    size_px: tuple[int, int]
    clipped: tuple[str, ...]
    overlaps: tuple[tuple[str, str], ...]
    duplicates: tuple[tuple[str, str], ...]
    hidden: tuple[tuple[str, str], ...]
    jumps: tuple[str, ...]
    covered: tuple[str, ...]
    unitless: tuple[str, ...]
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
    """Lay `fig` out and measure it (see `FigureCheck`); `dpi` of the file it is saved to."""
    fig.draw_without_rendering()  # the layout and the text extents, no pixels
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
    for ax in panels:
        if ax.name == "3d":
            overlaps += [(f"{names[ax]}: {a}", f"{names[ax]}: {b}") for a, b in
                         _labels_over_ticks(ax, renderer)]  # fmt: skip

    duplicates, hidden, jumps, covered, unitless, described = [], [], [], [], [], {}
    for ax in panels:
        drawn = data_lines(ax)
        named = {line: f"{names[ax]}: {_label(line)}" for line in drawn}
        for first, second in itertools.combinations(drawn, 2):
            if _equal_data(first, second):
                duplicates.append((named[first], named[second]))
                continue
            if second.get_zorder() < first.get_zorder():  # drawn first
                first, second = second, first
            if hidden_under(first, second) > HIDDEN_SHARE:
                hidden.append((named[first], named[second]))
        jumps += [named[line] for line in drawn if _repeats_x(line)]
        for text, box in _panel_texts(ax, renderer):
            covered += [f"{named[line]} under {text}" for line in drawn if _crosses(line, box)]
            covered += [
                f"{names[ax]}: {_area_label(area)} under {text}"
                for area in ax.collections
                if isinstance(area, PolyCollection) and _crosses(area, box, filled=True)
            ]
        unitless += [f"{names[ax]}: {letter} axis" for letter in _axes_without_unit(ax)]
        low, high = ax.get_ylim()
        described[names[ax]] = Panel(
            ax.get_xlabel(),
            ax.get_ylabel(),
            ax.get_zlabel() if ax.name == "3d" else "",
            (float(low), float(high)),
            tuple(float(v) for v in ax.get_yticks() if min(low, high) <= v <= max(low, high)),
            tuple(_label(line) for line in drawn),
            tuple(_segments(line) for line in drawn),
            tuple(_style(line) for line in drawn),
            tuple(
                label.get_text()
                for child in ax.child_axes
                for tick in child.xaxis._update_ticks()
                for label in (tick.label1, tick.label2)
                if label.get_visible() and label.get_text()
            ),
        )
    # as savefig sizes the PNG: whole pixels, cut down
    width, height = (int(v * dpi + 1e-6) for v in fig.get_size_inches())
    return FigureCheck(
        Path(path), (width, height), tuple(dict.fromkeys(clipped)), tuple(overlaps),
        tuple(duplicates), tuple(hidden), tuple(jumps), tuple(covered), tuple(unitless),
        described,
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
    for child in ax.child_axes:  # a secondary axis: its tick labels
        for tick in child.xaxis._update_ticks() + child.yaxis._update_ticks():
            for label in (tick.label1, tick.label2):
                texts.append((f"secondary tick label {label.get_text()[:30]!r}", label))
    texts += [(f"text {t.get_text()[:30]!r}", t) for t in ax.texts]
    for name, text in texts:
        if text.get_visible() and text.get_text().strip():
            yield None, name, text.get_window_extent(renderer)
    legend = ax.get_legend()
    if legend is not None and legend.get_visible():
        yield None, "legend", legend.get_window_extent(renderer)


def _labels_over_ticks(ax, renderer):
    """(label, tick label) pairs of a 3-D panel where an axis label, drawn along its
    axis (slanted), lies over a tick value of any of the panel's axes: measured on the
    label's slanted outline, not its upright box, which covers the ticks beside it."""
    axes = [("x", ax.xaxis), ("y", ax.yaxis), ("z", ax.zaxis)]
    ticks = [
        (f"{letter} tick label {label.get_text()!r}", label.get_window_extent(renderer))
        for letter, axis in axes
        if axis.get_visible()
        for tick in axis.majorTicks
        for label in (tick.label1,)
        if label.get_visible() and label.get_text().strip()
    ]
    for letter, axis in axes:
        if not (axis.get_visible() and axis.label.get_visible() and axis.label.get_text()):
            continue
        outline = _outline(axis.label, renderer)
        for name, box in ticks:
            inner = Bbox(box.get_points() + [[1.0, 1.0], [-1.0, -1.0]])  # `_overlap`'s slack
            if outline.intersects_bbox(inner, filled=True):
                yield f"{letter} label", name


def _outline(text, renderer) -> MplPath:
    """The outline of a rotated text on the page: its upright box turned about the
    centre of its drawn box (the centre of a turned rectangle's bounding box is its own)."""
    drawn = text.get_window_extent(renderer)
    angle = text.get_rotation()
    text.set_rotation(0.0)
    upright = text.get_window_extent(renderer)
    text.set_rotation(angle)
    half_w, half_h = 0.5 * upright.width, 0.5 * upright.height
    corners = np.array([[-half_w, -half_h], [half_w, -half_h], [half_w, half_h],
                        [-half_w, half_h], [-half_w, -half_h]])  # fmt: skip
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    turned = corners @ np.array([[c, s], [-s, c]])
    return MplPath(turned + [0.5 * (drawn.x0 + drawn.x1), 0.5 * (drawn.y0 + drawn.y1)],
                   closed=True)  # fmt: skip


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


def data_lines(ax) -> list:
    """The lines of a panel that draw data: visible, of two points or more, with a
    line style."""
    return [
        line
        for line in ax.get_lines()
        if line.get_visible() and len(line.get_xdata()) > 1 and line.get_linestyle() != "None"
    ]


def _label(line) -> str:
    label = line.get_label()
    return "" if label.startswith("_") else label


def _style(line) -> str:
    """The line style: "-" solid, "--" dashed, ":" dotted, "-." dash-dotted."""
    style = line.get_linestyle()
    return {"solid": "-", "dashed": "--", "dotted": ":", "dashdot": "-."}.get(style, style)


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


def _panel_texts(ax, renderer):
    """(name, bbox) of the texts drawn inside a flat panel's plotting area: its legend
    and its annotations."""
    if ax.name == "3d":
        return
    legend = ax.get_legend()
    if legend is not None and legend.get_visible():
        yield "legend", legend.get_window_extent(renderer)
    for text in ax.texts:
        if text.get_visible() and text.get_text().strip():
            yield f"text {text.get_text()[:30]!r}", text.get_window_extent(renderer)


def _crosses(artist, box, filled: bool = False) -> bool:
    """Whether a line (or, `filled`, an area) is drawn through `box` (display
    coordinates); NaN points break a line."""
    if filled:
        paths = [artist.get_transform().transform_path(p) for p in artist.get_paths()]
    else:
        paths = [artist.get_transform().transform_path(artist.get_path())]
    return any(path.intersects_bbox(box, filled=filled) for path in paths)


def _area_label(area) -> str:
    label = area.get_label()
    return "area" if label.startswith("_") else label


def _axes_without_unit(ax):
    """The letters of a panel's axes that draw tick values but whose label gives no
    unit in brackets."""
    axes = [("x", ax.xaxis), ("y", ax.yaxis)] + ([("z", ax.zaxis)] if ax.name == "3d" else [])
    for letter, axis in axes:
        if not axis.get_visible():
            continue
        values = [
            label.get_text()
            for tick in axis._update_ticks()  # those drawn (see _axes_texts)
            for label in (tick.label1, tick.label2)
            if label.get_visible()
        ]
        if any(text.strip() for text in values) and not UNIT.search(axis.get_label_text()):
            yield letter


def _equal_data(first, second) -> bool:
    """Whether two lines hold the same points, to `EQUAL_DATA` of their largest value."""
    a = np.asarray(first.get_xydata(), dtype=float)
    b = np.asarray(second.get_xydata(), dtype=float)
    if a.shape != b.shape or np.any(np.isfinite(a) != np.isfinite(b)):
        return False
    finite = np.isfinite(a)
    if not finite.any():
        return False
    scale = np.max(np.abs(np.where(finite, np.maximum(np.abs(a), np.abs(b)), 0.0)), axis=0)
    return bool(np.all(np.abs(np.where(finite, a - b, 0.0)) <= EQUAL_DATA * scale))


def hidden_under(under, over) -> float:
    """The share of `under`'s finite points that `over` (drawn after it) covers on the
    page: drawn at the same x, leaving at most `FRINGE_PX` of `under` showing beside it;
    0 when `over` is not solid (`under` shows between its dashes). A line drawn on other
    x than `over`'s is compared with `over`'s interpolant when that runs forward in x."""
    if over.get_linestyle() not in ("-", "solid"):
        return 0.0
    a = under.get_transform().transform(np.asarray(under.get_xydata(), dtype=float))
    b = over.get_transform().transform(np.asarray(over.get_xydata(), dtype=float))
    finite_a = np.all(np.isfinite(a), axis=1)
    if not finite_a.any():
        return 0.0
    if a.shape == b.shape and np.allclose(a[:, 0], b[:, 0], equal_nan=True, atol=0.5, rtol=0):
        other = b[:, 1]
    else:
        finite_b = np.all(np.isfinite(b), axis=1)
        x, y = b[finite_b, 0], b[finite_b, 1]
        if x.size < 2 or np.any(np.diff(x) <= 0):
            return 0.0
        other = np.interp(a[:, 0], x, y, left=np.nan, right=np.nan)
    pixels = under.get_figure(root=True).dpi / 72.0
    allowed = FRINGE_PX + 0.5 * pixels * (over.get_linewidth() - under.get_linewidth())
    with np.errstate(invalid="ignore"):
        covered = np.abs(a[:, 1] - other) <= max(allowed, 0.0)
    return float(np.sum(covered & finite_a) / np.sum(finite_a))
