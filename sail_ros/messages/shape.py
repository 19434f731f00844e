"""`/sail/shape`: the deflected sail as RViz/Foxglove markers, coloured by height."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from sail_ros.topics import FRAME_ID, stamp

BOOM_LINE_WIDTH = 0.2  # m, drawn width of a boom in RViz
BOOM_COLOUR = ColorRGBA(r=0.25, g=0.25, b=0.25, a=1.0)
MIN_COLOUR_RANGE = 1e-3  # m: below this the membrane is drawn as flat (white)


COLOUR_LEVELS = 32  # per sign: heights are drawn in 2 * 32 + 1 shades


def _diverging(v: float) -> ColorRGBA:
    return ColorRGBA(r=min(1.0, 1.0 + v), g=1.0 - abs(v), b=min(1.0, 1.0 - v), a=1.0)


# shared, immutable-by-convention colour objects: building 1000s per message is slow
_PALETTE = [_diverging(level / COLOUR_LEVELS) for level in range(-COLOUR_LEVELS, COLOUR_LEVELS + 1)]


# the same shades as float32 RGBA rows, as CDR holds them (`messages.cdr`)
_PALETTE_RGBA = np.array([[c.r, c.g, c.b, c.a] for c in _PALETTE], dtype="<f4")


def _height_levels(heights, scale: float) -> np.ndarray:
    v = np.clip(np.asarray(heights, dtype=float) / scale, -1.0, 1.0)
    return np.rint(v * COLOUR_LEVELS).astype(int) + COLOUR_LEVELS


def height_colours(heights, scale: float) -> list[ColorRGBA]:
    """Diverging colour map of heights [m]: blue at -scale, white at 0, red at
    +scale, in 2 COLOUR_LEVELS + 1 shades."""
    return [_PALETTE[level] for level in _height_levels(heights, scale).tolist()]


def colour_array(heights, scale: float) -> np.ndarray:
    """`height_colours` as an (N, 4) float32 array of r, g, b, a."""
    return _PALETTE_RGBA[_height_levels(heights, scale)]


def shape(stamp_ns_: int, vertices, triangles, boom_lines, frame_id: str = FRAME_ID) -> MarkerArray:
    """`/sail/shape`: the deflected sail for RViz/Foxglove.

    Args:
        stamp_ns_: stamp [ns].
        vertices: membrane mesh points (P, 3) [m] in `frame_id` (`SailSurface.vertices`).
        triangles: vertex indices (T, 3) (`SailSurface.triangles`).
        boom_lines: points along each boom (4, S, 3) [m] (`SailSurface.boom_lines`).
        frame_id: frame of the markers.

    Returns:
        Marker `membrane`/0: TRIANGLE_LIST, one colour per point from its height
        (`height_colours`, scaled to the largest |height| of this frame, at least
        MIN_COLOUR_RANGE); markers `booms`/0..3: LINE_STRIPs of booms a..d.
    """
    header_stamp = stamp(stamp_ns_)
    vertices = np.asarray(vertices, dtype=float)
    corners = np.asarray(triangles).ravel().tolist()
    membrane = _marker(header_stamp, frame_id, "membrane", 0, Marker.TRIANGLE_LIST)
    membrane.scale.x = membrane.scale.y = membrane.scale.z = 1.0
    membrane.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    # one Point and one colour per mesh vertex, shared by the triangles that meet
    # there: a vertex is in about five corners, and building the objects is the cost
    points = [Point(x=x, y=y, z=z) for x, y, z in vertices.tolist()]
    membrane.points = [points[i] for i in corners]
    heights = vertices[:, 2]
    scale = max(float(np.max(np.abs(heights[corners]), initial=0.0)), MIN_COLOUR_RANGE)
    colours = height_colours(heights, scale)
    membrane.colors = [colours[i] for i in corners]
    markers = [membrane]
    for k, line in enumerate(np.asarray(boom_lines, dtype=float)):
        boom = _marker(header_stamp, frame_id, "booms", k, Marker.LINE_STRIP)
        boom.scale.x = BOOM_LINE_WIDTH
        boom.color = BOOM_COLOUR
        boom.points = [Point(x=x, y=y, z=z) for x, y, z in line.tolist()]
        markers.append(boom)
    return MarkerArray(markers=markers)


def _marker(header_stamp: Time, frame_id: str, ns: str, marker_id: int, kind: int) -> Marker:
    marker = Marker(ns=ns, id=marker_id, type=kind, action=Marker.ADD)
    marker.header.stamp = header_stamp
    marker.header.frame_id = frame_id
    marker.pose.orientation.w = 1.0  # identity: points are already in frame_id
    return marker
