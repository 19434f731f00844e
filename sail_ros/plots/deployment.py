"""Snapshots of the deflected sail during a deployment (seed Fig. 3).

All panels share the plane's axes (the largest boom length of the run), the
colour scale and the vertical exaggeration, so that growth and vibration
compare across times; the exaggeration is stated in the title.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib import cm

from sail_ros.model.shape import SailSurface
from sail_ros.plots.common import figure, fit_width, save, styled
from sail_ros.plots.sail3d import (
    CMAP,
    draw_sail,
    exaggeration_for,
    symmetric_norm,
    true_box_height,
)


def _lengths_text(lengths) -> str:
    lengths = np.asarray(lengths)
    if np.allclose(lengths, lengths[0]):
        return f"L = {lengths[0]:.2f} m"
    return "L = " + ", ".join(f"{v:.1f}" for v in lengths) + " m"


@styled
def snapshots_figure(
    model, times, lengths, q, path, title: str = "", divisions: int = 14, columns: int = 3
):
    """Write 3-D snapshots of the sail as a PNG.

    Args:
        model: the `SailModel` of the run.
        times: snapshot times [s], (k,).
        lengths: boom lengths [m] at those times, (k, 4).
        q: coordinates at those times, (k, n).
        path: output file.
        title: first line of the figure title (e.g. the scenario).
        divisions: mesh subdivisions of each quadrant edge.
        columns: panels per row.
    """
    surface = SailSurface(model, divisions)
    frames = [
        (surface.vertices(qi, li), surface.boom_lines(qi, li))
        for qi, li in zip(q, lengths, strict=True)
    ]
    peak_m = max(max(np.abs(v[:, 2]).max(), np.abs(b[:, :, 2]).max()) for v, b in frames)
    peak_m = max(peak_m, 1e-6)  # an undeflected run still gets an axis
    extent = 1.03 * float(np.max(lengths))
    exaggeration = exaggeration_for(peak_m, extent, fraction=0.9)
    z_limit_mm = 1.1e3 * peak_m
    box = true_box_height(z_limit_mm / 1e3, extent, exaggeration)
    norm = symmetric_norm(1e3 * peak_m)

    columns = min(columns, len(times))
    rows = math.ceil(len(times) / columns)
    fig, axes = figure(
        2.8 * columns + 0.9,
        2.6 * rows + 0.7,
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
        )
        ax.set_title(f"t = {t:.1f} s\n{_lengths_text(li)}", pad=0)
        ax.set_xlabel("x [m]", labelpad=-6)
        ax.set_ylabel("y [m]", labelpad=-6)
        ax.set_zticks(_z_ticks(z_limit_mm))
        ax.tick_params(axis="z", pad=0)
    for ax in axes.flat[len(times) :]:
        ax.set_visible(False)
    heading = f"{title}\n" if title else ""
    suptitle = fig.suptitle(
        f"{heading}deflection w drawn {exaggeration:g}x true scale "
        "(tick labels true: x, y in m, w in mm); booms black",
        fontsize=10,
    )
    fit_width(suptitle)
    # the panels start below the title however many lines it wrapped to
    title_in = suptitle.get_window_extent(fig.canvas.get_renderer()).height / fig.dpi
    top = 1.0 - (title_in + 0.5) / fig.get_figheight()
    fig.subplots_adjust(left=0.02, right=0.86, bottom=0.03, top=top, wspace=0.22, hspace=0.1)
    bar = fig.colorbar(
        cm.ScalarMappable(norm=norm, cmap=CMAP), ax=axes.ravel().tolist(), shrink=0.7, pad=0.07
    )
    bar.set_label("deflection w [mm]")
    return save(fig, path)


def _z_ticks(limit: float) -> list[float]:
    """-s, 0, s with s a round number (1, 2, 5 x 10^k) within `limit`."""
    decade = 10.0 ** math.floor(math.log10(limit))
    step = max(v * decade for v in (1.0, 2.0, 5.0) if v * decade <= limit)
    return [-step, 0.0, step]
