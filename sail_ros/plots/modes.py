"""Mode shapes of the whole sail, one panel per distinct frequency (seed Fig. 2).

Two views of the same fields (`SailSurface`: the model's own basis functions
on a triangulation of each quadrant):

- "map": filled contours of the deflection seen from +z, booms as strips
  coloured by their own deflection; sign patterns and nodal lines read
  unambiguously at page size (the default).
- "3d": the deflected surface in perspective, as the seed draws it.

Every shape is normalised to max |w| = 1 over membrane and booms.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib import cm
from matplotlib.collections import LineCollection

from sail_ros.model.shape import SailSurface
from sail_ros.plots.common import figure, fit_width, save, styled
from sail_ros.plots.sail3d import (
    CMAP,
    colour_bar,
    draw_sail,
    label_axes,
    lay_out_panels,
    symmetric_norm,
)

VIEWS = ("map", "3d")
BOX_HEIGHT = 0.4  # 3d view: drawn height of the +-1 range relative to the plane's width
CELL_3D = 3.2  # 3d view: width of a panel's cell [in]
LEVELS = np.linspace(-1.0, 1.0, 21)  # map view: contour levels of w / max|w|


def _title(first: int, multiplicity: int, omega: float) -> str:
    if multiplicity == 1:
        modes = f"mode {first + 1}"
    else:
        kind = {2: " (double)", 3: " (triple)"}.get(multiplicity, "")
        modes = f"modes {first + 1}-{first + multiplicity}{kind}"
    return f"{modes}\n$\\omega$ = {omega:.5f} rad/s"


def _draw_map(ax, vertices, triangles, booms, norm, extent):
    ax.tricontourf(
        vertices[:, 0],
        vertices[:, 1],
        triangles,
        vertices[:, 2],
        levels=LEVELS,
        cmap=CMAP,
        norm=norm,
    )
    for line in booms:
        points = line[:, :2]
        ax.plot(points[:, 0], points[:, 1], color="k", lw=3.2, solid_capstyle="butt")
        strip = LineCollection(
            np.stack([points[:-1], points[1:]], axis=1), cmap=CMAP, norm=norm, linewidths=2.0
        )
        strip.set_array(0.5 * (line[:-1, 2] + line[1:, 2]))
        ax.add_collection(strip)
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_aspect("equal")
    ax.grid(False)


@styled
def mode_shapes_figure(
    model, lengths, shapes, path, view: str = "map", divisions: int = 24, columns: int = 3
):
    """Write the mode shapes as a PNG.

    Args:
        model: the `SailModel` the vectors belong to.
        lengths: boom lengths [m] (4 values).
        shapes: `(number, first_index, multiplicity, omega, vector)` per panel,
            as `analysis.modes.representative_shapes` returns them.
        path: output file.
        view: "map" (filled contours from above) or "3d" (perspective surface).
        divisions: mesh subdivisions of each quadrant edge.
        columns: most panels per row; rows are filled evenly (4 shapes: 2 x 2).
    """
    if view not in VIEWS:
        raise ValueError(f"view must be one of {', '.join(VIEWS)}, got {view!r}")
    surface = SailSurface(model, divisions)
    lengths = np.asarray(lengths, dtype=float)
    extent = 1.03 * float(np.max(lengths))
    rows = math.ceil(len(shapes) / columns)
    columns = math.ceil(len(shapes) / rows)
    options = (
        {"subplot_kw": {"projection": "3d"}} if view == "3d" else {"sharex": True, "sharey": True}
    )
    cell, height = (CELL_3D, 2.9) if view == "3d" else (2.45, 2.45)  # [in]
    fig, axes = figure(
        cell * columns + 1.0, height * rows + 0.7, nrows=rows, ncols=columns, squeeze=False,
        **options,
    )  # fmt: skip
    norm = symmetric_norm(1.0)
    for ax, (_, first, multiplicity, omega, vector) in zip(axes.flat, shapes, strict=False):
        vertices = surface.vertices(vector, lengths)
        booms = surface.boom_lines(vector, lengths)
        peak = max(np.abs(vertices[:, 2]).max(), np.abs(booms[:, :, 2]).max())
        if view == "3d":
            draw_sail(
                ax,
                vertices,
                surface.triangles,
                booms,
                z_factor=1.0 / peak,
                norm=norm,
                extent=extent,
                z_limit=1.0,
                box_height=BOX_HEIGHT,
                zoom=0.85,
            )
            label_axes(ax, "w [-]", [-1, 0, 1])
        else:
            vertices[:, 2] /= peak
            booms[:, :, 2] /= peak
            _draw_map(ax, vertices, surface.triangles, booms, norm, extent)
        ax.set_title(_title(first, multiplicity, omega), pad=2)
    if view == "map":
        for ax in axes[-1]:
            ax.set_xlabel("x [m] (boom a)")
        for ax in axes[:, 0]:
            ax.set_ylabel("y [m] (boom b)")
    for ax in axes.flat[len(shapes) :]:
        ax.set_visible(False)
    equal = np.allclose(lengths, lengths[0])
    shown = (
        f"L = {lengths[0]:.2f} m"
        if equal
        else "L = " + ", ".join(f"{v:.4g}" for v in lengths) + " m (a, b, c, d)"
    )
    what = "booms as strips, seen from +z" if view == "map" else "booms black"
    title = fig.suptitle(
        f"First {len(shapes)} distinct mode shapes, {shown}\n{what}; w normalised to max |w| = 1",
        fontsize=10,
    )
    fit_width(title)
    if view == "3d":
        lay_out_panels(fig, list(axes.flat), columns, cell, title)
        colour_bar(fig, norm, "w / max|w| [-]", columns * cell)
    else:
        fig.subplots_adjust(left=0.1, right=0.86, bottom=0.1, top=0.82, wspace=0.15, hspace=0.3)
        bar = fig.colorbar(
            cm.ScalarMappable(norm=norm, cmap=CMAP), ax=axes.ravel().tolist(), shrink=0.7,
            pad=0.03,
        )  # fmt: skip
        bar.set_label("w / max|w| [-]")
    return save(fig, path)
