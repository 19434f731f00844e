"""`/sail/shape` as CDR bytes, filled with numpy instead of built from Point objects.

The mesh's topology is fixed for a simulator's life, so every shape message has
the same layout: only the stamps, the points and the colours change. The
message `topics.shape` builds is serialised once, with recognisable values, to
find where those fields lie; each frame then copies the bytes and writes the new
values there (at 20 divisions, ~0.1 ms instead of ~1.4 ms for the objects). What
comes out decodes to the message `topics.shape` builds from the same numbers
(tested with rclpy's deserialiser).
"""

from __future__ import annotations

import struct

import numpy as np
from rclpy.serialization import serialize_message

from sail_ros import topics

_LITTLE_ENDIAN_CDR = b"\x00\x01"  # encapsulation header rclpy writes on little-endian hosts
_STAMP = struct.Struct("<iI")  # builtin_interfaces/Time: int32 sec, uint32 nanosec
_TEMPLATE_STAMP_NS = 1_234_567_890_987_654_321  # an unlikely pattern to search for


class ShapeSerializer:
    """Serialises `topics.shape(stamp_ns, vertices, triangles, boom_lines, frame_id)`
    for one mesh (`triangles` (T, 3) and `boom_points` points per boom line).

    Raises:
        RuntimeError: if the serialised layout is not the one expected (another
            middleware's byte order, or a changed message definition).
    """

    def __init__(self, triangles, boom_points: int, frame_id: str = topics.FRAME_ID):
        self.triangles = np.asarray(triangles)
        self.corners = self.triangles.ravel()
        self.frame_id = frame_id
        rng = np.random.default_rng(0)
        vertices = rng.uniform(-1.0, 1.0, (int(self.corners.max()) + 1, 3))
        boom_lines = rng.uniform(-1.0, 1.0, (4, boom_points, 3))
        template = serialize_message(
            topics.shape(_TEMPLATE_STAMP_NS, vertices, self.triangles, boom_lines, frame_id)
        )
        if template[:2] != _LITTLE_ENDIAN_CDR:
            raise RuntimeError(f"/sail/shape: unexpected CDR header {template[:4]!r}")
        self._template = template
        self._stamps = _all_offsets(template, _STAMP.pack(*divmod(_TEMPLATE_STAMP_NS, 10**9)))
        self._points = _offset_of(template, vertices[self.corners])
        self._colours = self._points + 24 * self.corners.size + 4  # after the colours' count
        expected = topics.colour_array(*self._levels(vertices))
        if template[self._colours : self._colours + expected.nbytes] != expected.tobytes():
            raise RuntimeError("/sail/shape: the colours are not where expected")
        self._booms = [_offset_of(template, line) for line in boom_lines]
        if len(self._stamps) != 5:  # the membrane and four booms
            raise RuntimeError(f"/sail/shape: {len(self._stamps)} stamps found, expected 5")

    def _levels(self, vertices):
        heights = vertices[self.corners, 2]
        return heights, max(float(np.max(np.abs(heights), initial=0.0)), topics.MIN_COLOUR_RANGE)

    def serialize(self, stamp_ns: int, vertices, boom_lines) -> bytes:
        """The CDR bytes of the shape at `stamp_ns` [ns]: `vertices` (P, 3) and
        `boom_lines` (4, S, 3) [m], as for `topics.shape`."""
        vertices = np.asarray(vertices, dtype=float)
        buffer = bytearray(self._template)
        stamp = _STAMP.pack(*divmod(int(stamp_ns), 10**9))
        for offset in self._stamps:
            buffer[offset : offset + _STAMP.size] = stamp
        _write(buffer, self._points, vertices[self.corners])
        _write(buffer, self._colours, topics.colour_array(*self._levels(vertices)))
        for offset, line in zip(self._booms, np.asarray(boom_lines, dtype=float), strict=True):
            _write(buffer, offset, line)
        return bytes(buffer)


def _write(buffer: bytearray, offset: int, values: np.ndarray) -> None:
    """`values` into `buffer` at `offset`, little-endian, through a view (one copy)."""
    dtype = values.dtype.newbyteorder("<")
    np.frombuffer(buffer, dtype=dtype, count=values.size, offset=offset)[:] = values.ravel()


def _offset_of(data: bytes, values: np.ndarray) -> int:
    """Where the little-endian float64 bytes of `values` lie in `data`, found once."""
    pattern = np.ascontiguousarray(values, dtype="<f8").tobytes()
    offsets = _all_offsets(data, pattern)
    if len(offsets) != 1:
        raise RuntimeError(f"/sail/shape: a point array found {len(offsets)} times")
    return offsets[0]


def _all_offsets(data: bytes, pattern: bytes) -> list[int]:
    offsets, start = [], data.find(pattern)
    while start >= 0:
        offsets.append(start)
        start = data.find(pattern, start + 1)
    return offsets
