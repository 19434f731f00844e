"""Snapshots of the deflected sail during a deployment (seed Fig. 3).

All panels share the plane's axes (the largest boom length of the run), the
colour scale and the vertical exaggeration, so that growth and vibration
compare across times; the exaggeration is the same for every run
(`EXAGGERATION`, or the caller's), stated in the title, so that runs compare
too. The mesh resolves the highest membrane mode of the model
(`sail3d.resolving_divisions`).
"""

from __future__ import annotations

import math

import numpy as np

from sail_ros.model.shape import SailSurface
from sail_ros.plots.common import figure, fit_width, save, styled
from sail_ros.plots.sail3d import (
    colour_bar,
    draw_sail,
    exaggeration_for,
    label_axes,
    lay_out_panels,
    resolving_divisions,
    symmetric_norm,
    true_box_height,
)

EXAGGERATION = 20.0  # heights drawn this many times true scale, in every run
TALLEST = 0.5  # the drawn range +-max|w| at most this fraction of the plane's width
ZOOM = 1.1  # of a panel's box in its cell
LOWEST_BOX = 0.25  # the z range drawn at least this fraction of the plane's width tall


def _lengths_text(lengths) -> str:
    lengths = np.asarray(lengths)
    if np.allclose(lengths, lengths[0]):
        return f"L = {lengths[0]:.2f} m"
    return "L = " + ", ".join(f"{v:.1f}" for v in lengths) + " m"


def shown_exaggeration(peak_m: float, extent: float, wanted: float) -> float:
    """`wanted`, or, when it would draw the range of heights +-`peak_m` [m] taller than
    `TALLEST` of the plane's width 2 `extent` [m], the largest round exaggeration that
    does not."""
    if wanted * 2.0 * peak_m <= TALLEST * 2.0 * extent:
        return wanted
    return exaggeration_for(peak_m, extent, fraction=TALLEST)


@styled
def snapshots_figure(
    model, times, lengths, q, path, title: str = "", exaggeration: float = EXAGGERATION,
    divisions: int | None = None, columns: int = 3,
):  # fmt: skip
    """Write 3-D snapshots of the sail as a PNG.

    Args:
        model: the `SailModel` of the run.
        times: snapshot times [s], (k,).
        lengths: boom lengths [m] at those times, (k, 4).
        q: coordinates at those times, (k, n).
        path: output file.
        title: first line of the figure title (e.g. the scenario).
        exaggeration: heights drawn this many times true scale (lowered, and the title
            says so, where +-max|w| would be drawn over half the sail's width tall).
        divisions: mesh subdivisions of each quadrant edge (default: enough for the
            model's highest membrane mode).
        columns: panels per row.
    """
    surface = SailSurface(model, divisions or resolving_divisions(model))
    frames = [
        (surface.vertices(qi, li), surface.boom_lines(qi, li))
        for qi, li in zip(q, lengths, strict=True)
    ]
    peak_m = max(max(np.abs(v[:, 2]).max(), np.abs(b[:, :, 2]).max()) for v, b in frames)
    peak_m = max(peak_m, 1e-6)  # an undeflected run still gets an axis
    extent = 1.03 * float(np.max(lengths))
    drawn = shown_exaggeration(peak_m, extent, exaggeration)
    # a small deflection keeps the exaggeration, in a box tall enough for its z ticks
    z_limit_mm = 1e3 * max(1.1 * peak_m, LOWEST_BOX * extent / drawn)
    box = true_box_height(z_limit_mm / 1e3, extent, drawn)
    norm = symmetric_norm(1e3 * peak_m)

    columns = min(columns, len(times))
    rows = math.ceil(len(times) / columns)
    # [in]; a taller box (a larger deflection) gets a taller cell
    cell_w, cell_h, bar_w = 3.6, 1.9 + 1.6 * box, 1.1
    fig, axes = figure(
        cell_w * columns + bar_w,
        cell_h * rows + 0.9,
        nrows=rows,
        ncols=columns,
        squeeze=False,
        subplot_kw={"projection": "3d"},
    )
    for ax, t, li, (vertices, booms) in zip(axes.flat, times, lengths, frames, strict=False):
        draw_sail(
            ax,
            vertices,
            surface.triangles,
            booms,
            z_factor=1e3,
            norm=norm,
            extent=extent,
            z_limit=z_limit_mm,
            box_height=box,
            zoom=ZOOM,
        )
        ax.set_title(f"t = {t:.1f} s, {_lengths_text(li)}", pad=0)
        label_axes(ax, "w [mm]", _z_ticks(z_limit_mm))
    for ax in axes.flat[len(times) :]:
        ax.set_visible(False)
    heading = f"{title}\n" if title else ""
    scale = f"heights w drawn {drawn:g}x true scale"
    if drawn != exaggeration:
        scale += f" ({exaggeration:g}x would draw them over half the sail's width tall)"
    suptitle = fig.suptitle(
        f"{heading}{scale}; the axes give true values (x, y in m, w in mm); booms black",
        fontsize=10,
    )
    fit_width(suptitle)
    lay_out_panels(fig, list(axes.flat), columns, cell_w, suptitle, (1.0, 1.0, box), ZOOM)
    colour_bar(fig, norm, "deflection w [mm]", columns * cell_w)
    return save(fig, path)


def _z_ticks(limit: float) -> list[float]:
    """-s, 0, s with s a round number (1, 2, 5 x 10^k) within `limit`."""
    decade = 10.0 ** math.floor(math.log10(limit))
    step = max(v * decade for v in (1.0, 2.0, 5.0) if v * decade <= limit)
    return [-step, 0.0, step]
