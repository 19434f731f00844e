"""The simulator's messages as CDR bytes, filled with numpy instead of built from objects.

Every `/sail/shape` of a simulator has the same layout (the mesh's topology is
fixed), and so has every state message (the names are): only stamps and
numbers change. The message `topics` builds is serialised once with
recognisable values to find where those lie; each frame then copies the bytes
and writes the new values there (a shape at 20 divisions: ~0.1 ms instead of
~1.4 ms for the objects; a modal state of 160 coordinates: its names are not
converted again). What comes out decodes to the message `topics` builds from
the same numbers (tested with rclpy's deserialiser).
"""

from __future__ import annotations

import struct

import numpy as np
from rclpy.serialization import serialize_message

from sail_ros import topics
from sail_ros.model.sail_model import StateSample

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


# the arrays of a sample the state messages carry, each in exactly one of them
_SAMPLE_ARRAYS = ("lengths", "rates", "q", "qd", "tips", "tip_rates", "root_moments")


class StateSerializer:
    """Serialises `topics.state_messages(stamp_ns, sample, coordinate_names, frame_id,
    with_clock)`: the same `(topic, bytes)` pairs, in the same order.

    Raises:
        RuntimeError: if the serialised layout is not the one expected.
    """

    def __init__(self, coordinate_names, frame_id: str = topics.FRAME_ID, with_clock=False):
        rng = np.random.default_rng(0)
        n = len(coordinate_names)
        sample = StateSample(0.0, *(rng.uniform(-1.0, 1.0, size) for size in (4, 4, n, n, 4, 4, 4)))
        stamp = _STAMP.pack(*divmod(_TEMPLATE_STAMP_NS, 10**9))
        self._layouts = []  # (topic, template, stamp offset, [(array name, offset)])
        placed = []
        for topic, message in topics.state_messages(
            _TEMPLATE_STAMP_NS, sample, coordinate_names, frame_id, with_clock
        ):
            template = serialize_message(message)
            if template[:2] != _LITTLE_ENDIAN_CDR:
                raise RuntimeError(f"{topic}: unexpected CDR header {template[:4]!r}")
            stamps = _all_offsets(template, stamp)
            if len(stamps) != 1:
                raise RuntimeError(f"{topic}: {len(stamps)} stamps found, expected 1")
            arrays = []
            for name in _SAMPLE_ARRAYS:
                pattern = np.ascontiguousarray(getattr(sample, name), dtype="<f8").tobytes()
                offsets = _all_offsets(template, pattern)
                if len(offsets) == 1:
                    arrays.append((name, offsets[0]))
            placed += [name for name, _ in arrays]
            # one buffer per topic, written in place through views made once: a message
            # is its copy (up to 800 samples a second, so views per sample would count)
            buffer = bytearray(template)
            views = [
                (name, np.frombuffer(buffer, "<f8", len(getattr(sample, name)), offset))
                for name, offset in arrays
            ]
            self._layouts.append((topic, buffer, stamps[0], views))
        if sorted(placed) != sorted(_SAMPLE_ARRAYS):
            raise RuntimeError(f"state messages: arrays found {placed}, expected each once")

    def serialize(self, stamp_ns: int, sample: StateSample) -> list[tuple[str, bytes]]:
        """The `(topic, CDR bytes)` of every state message of `sample` at `stamp_ns` [ns].
        Not for two threads at once (the buffers are shared)."""
        stamp = _STAMP.pack(*divmod(int(stamp_ns), 10**9))
        messages = []
        for topic, buffer, stamp_offset, views in self._layouts:
            buffer[stamp_offset : stamp_offset + _STAMP.size] = stamp
            for name, view in views:
                view[:] = getattr(sample, name)
            messages.append((topic, bytes(buffer)))
        return messages


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
