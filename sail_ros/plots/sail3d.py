"""The deflected sail as a 3-D surface: membrane triangles coloured by deflection, booms as lines.

Heights come from the model's own fields on a triangulation of each quadrant
(`SailSurface`), not from interpolation. The vertical scale is set through
the axes' box aspect, so tick labels keep true values while the shape is
drawn a chosen number of times taller than it is (stated by the caller).
"""

from __future__ import annotations

import numpy as np
from matplotlib import cm
from matplotlib.colors import Normalize

CMAP = "RdBu_r"  # diverging: up red, down blue, flat white


def symmetric_norm(limit: float) -> Normalize:
    """Colour scale `[-limit, limit]`, flat sail white; a zero limit gives [-1, 1]."""
    limit = float(limit) if limit > 0 else 1.0
    return Normalize(-limit, limit)


def draw_sail(
    ax,
    vertices,
    triangles,
    boom_lines,
    *,
    z_factor: float,
    norm: Normalize,
    extent: float,
    z_limit: float,
    box_height: float,
    zoom: float = 1.05,
) -> None:
    """Draw one sail state on a 3-D axes.

    Args:
        ax: a `projection="3d"` axes.
        vertices: membrane mesh vertices (P, 3) [m] (`SailSurface.vertices`).
        triangles: triangle indices (T, 3) (`SailSurface.triangles`).
        boom_lines: (4, stations, 3) [m] (`SailSurface.boom_lines`).
        z_factor: multiplies heights for the z axis (1e3 plots mm, or
            1 / max|w| plots a normalised shape); x and y stay in m.
        norm: colour scale for heights in z-axis units.
        extent: half-width of the x and y axes [m] (same for all panels).
        z_limit: half-height of the z axis, in z-axis units.
        box_height: drawn height of the z range relative to the plane's width;
            for true proportions times an exaggeration `e` that is
            `e * (2 z_limit / z_factor) / (2 extent)` (`true_box_height`).
        zoom: how much of its panel the box fills (`set_box_aspect`).
    """
    z = vertices[:, 2] * z_factor
    divisions = np.sqrt(len(triangles) / 4)  # of a quadrant's edge
    ax.computed_zorder = False
    ax.plot_trisurf(
        vertices[:, 0],
        vertices[:, 1],
        z,
        triangles=triangles,
        cmap=CMAP,
        norm=norm,
        linewidth=0.2 * min(1.0, 16.0 / divisions),  # a fine mesh is not drawn darker
        edgecolor=(0.4, 0.4, 0.4, 0.25),
        antialiased=True,
        shade=False,
    )  # faint mesh edges show where a flat (white) membrane is
    for line in boom_lines:  # drawn last and on top: mplot3d's depth sort would hide them
        ax.plot(line[:, 0], line[:, 1], line[:, 2] * z_factor, color="k", lw=1.4, zorder=10)
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_zlim(-z_limit, z_limit)
    ax.set_box_aspect((1.0, 1.0, box_height), zoom=zoom)
    ticks = _round_ticks(extent)
    ax.set_xticks(ticks)
    ax.set_yticks(ticks)
    ax.tick_params(pad=-2)
    ax.view_init(elev=28, azim=-55)


def label_axes(ax, z_label: str, z_ticks) -> None:
    """Axis labels of a sail panel drawn by `draw_sail`: x and y [m], and `z_label` at
    `z_ticks`; the labels as close to the box as keeps them clear of the tick values
    (nearer, the slanted x label lies over the middle tick "0")."""
    ax.set_xlabel("x [m]", labelpad=0)
    ax.set_ylabel("y [m]", labelpad=0)
    ax.set_zlabel(z_label, labelpad=-5)
    ax.set_zticks(z_ticks)
    ax.tick_params(axis="z", pad=-1)


def resolving_divisions(model, least: int = 12) -> int:
    """Mesh subdivisions of a quadrant edge that sample the model's highest membrane
    mode `sin(m pi xi)` at four points or more per wave (`least` at the fewest)."""
    from sail_ros.model.layout import triangle_mode_indices

    pairs = triangle_mode_indices(model.n_membrane_modes) if model.n_membrane_modes else ()
    highest = max((m for m, _ in pairs), default=0)
    return max(least, 2 * highest)


def true_box_height(z_limit_m: float, extent: float, exaggeration: float) -> float:
    """Box height (relative to the plane's width 2 `extent` [m]) that draws
    heights up to `z_limit_m` [m] `exaggeration` times taller than true."""
    return exaggeration * z_limit_m / extent


def exaggeration_for(max_height_m: float, extent: float, fraction: float = 0.35) -> float:
    """A round vertical exaggeration (1, 2, 5 x 10^k) that draws the largest
    height [m] at about `fraction` of the plane's width 2 `extent` [m]."""
    if not max_height_m > 0:
        return 1.0
    wanted = fraction * 2.0 * extent / (2.0 * max_height_m)
    decade = 10.0 ** np.floor(np.log10(wanted))
    for step in (5.0, 2.0, 1.0):
        if step * decade <= wanted:
            return float(step * decade)
    return float(decade)


def _round_ticks(extent: float) -> list[float]:
    """-s, 0, s with s a round number just below `extent` [m]."""
    room = extent * 0.95
    decade = 10.0 ** np.floor(np.log10(room))  # of the room, so that 1 x decade fits it
    step = max(v * decade for v in (1.0, 2.0, 5.0) if v * decade <= room)
    step = float(np.floor(room / step) * step)
    return [-step, 0.0, step]


def lay_out_panels(fig, axes, columns: int, cell_width_in: float, title, aspect=None,
                   zoom: float = 1.0) -> None:  # fmt: skip
    """Place 3-D panels in cells `cell_width_in` wide, row by row from under the figure's
    `title` (however many lines it wrapped to) to its foot, their backgrounds clear so
    that a panel's margin never hides its neighbour's axis labels (mplot3d draws them
    outside the box). With `aspect` (the panels' box aspect, drawn at `zoom`), a panel
    whose box and labels would spill out of its cell (a tall box) is drawn smaller."""
    renderer = fig.canvas.get_renderer()
    title_in = title.get_window_extent(renderer).height / fig.dpi
    width_in, height_in = fig.get_figwidth(), fig.get_figheight()
    top_in = height_in - title_in - 0.2
    rows = -(-len(axes) // columns)
    row_in = top_in / rows
    # each panel's title in a band at the top of its row, the box below it
    band_in = max(ax.title.get_window_extent(renderer).height for ax in axes) / fig.dpi + 0.1
    for index, ax in enumerate(axes):
        row, column = divmod(index, columns)
        bottom_in = top_in - (row + 1) * row_in
        ax.set_position([column * cell_width_in / width_in, bottom_in / height_in,
                         cell_width_in / width_in, (row_in - band_in) / height_in])  # fmt: skip
        ax.patch.set_alpha(0.0)
    if aspect is None:
        return
    shown = {ax: zoom for ax in axes if ax.get_visible()}
    for _ in range(4):  # the labels do not shrink with the box: measured again
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        spilling = False
        for ax in shown:
            ax.title.set_visible(False)  # above the cell by design: the box and its labels
            drawn = ax.get_tightbbox(renderer)
            ax.title.set_visible(True)
            # the cell given, not the square mplot3d draws the box in
            cell = ax.get_position(original=True).transformed(fig.transFigure)
            fits = min(cell.width / drawn.width, cell.height / drawn.height)
            if fits < 1.0:
                shown[ax] *= 0.97 * fits
                ax.set_box_aspect(aspect, zoom=shown[ax])
                spilling = True
        if not spilling:
            return


def colour_bar(fig, norm: Normalize, label: str, left_in: float):
    """A vertical colour bar of `CMAP` over `norm`, `left_in` from the figure's left edge."""
    bar = fig.add_axes([(left_in + 0.15) / fig.get_figwidth(), 0.15, 0.15 / fig.get_figwidth(),
                        0.6])  # fmt: skip
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap=CMAP), cax=bar)
    bar.set_ylabel(label)
    return bar
