"""The package's messages as CDR bytes: every message it serialises itself comes from here.

`serialize(message)` is the one serialisation path: the bytes a CDR writer
gives for the message and nothing more. rclpy's `serialize_message` (Fast
CDR under rmw_fastrtps) writes the fields, but returns its buffer padded to
its size estimate (a JointState of four joints 4 to 8 bytes too long): strict
readers (rosbags: "CDR message size mismatch"; Foxglove's
`@foxglove/rosmsg2-serialization`: bytes left over) reject that, and a raw
publisher sends it to every subscriber as it is. The exact size is computed
from the message's own type description (rosidl's `SLOT_TYPES`), the bytes
are cut there and the alignment gaps between fields, which Fast CDR leaves
uninitialised, are zeroed: the same message always gives the same bytes.
Messages published as objects are serialised by the middleware, exactly too.
Between processes DDS adds at most the zeros up to the next 4-byte boundary
(the end alignment of CDR, which every reader skips), whichever way.

Every `/sail/shape` of a simulator has the same layout (the mesh's topology is
fixed), and so has every state message (the names are): only stamps and
numbers change. The message `messages.shape` or `messages.state` builds is serialised
once with recognisable values to find where those lie; each frame then copies the bytes
and writes the new values there (a shape at 20 divisions: ~0.1 ms instead of
~1.4 ms for the objects; a modal state of 160 coordinates: its names are not
converted again). What comes out is, byte for byte, `serialize` of the message
those modules build from the same numbers (tested); the live simulator and the
offline logs (`sail_ros.analysis.log_export`) both write it.
"""

from __future__ import annotations

import struct

import numpy as np
from rclpy.serialization import serialize_message
from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractSequence,
    AbstractString,
    BasicType,
    NamespacedType,
)

from sail_ros import topics
from sail_ros.messages import hub as hub_msg
from sail_ros.messages import shape as shape_msg
from sail_ros.messages import state as state_msg
from sail_ros.model.record import SAMPLE_FIELDS, StateSample

_LITTLE_ENDIAN_CDR = b"\x00\x01"  # encapsulation header rclpy writes on little-endian hosts
_HEADER_SIZE = 4  # encapsulation kind and options; CDR alignment counts from after it
_STAMP = struct.Struct("<iI")  # builtin_interfaces/Time: int32 sec, uint32 nanosec
_TEMPLATE_STAMP_NS = 1_234_567_890_987_654_321  # an unlikely pattern to search for

# CDR size (and alignment) of each rosidl basic type, as Fast CDR writes it for ROS 2
# (classic CDR: an 8-byte value aligned to 8); wchar and long double are left out, no
# ROS message type uses them
_BASIC_SIZES = {
    **dict.fromkeys(("boolean", "octet", "char", "int8", "uint8"), 1),
    **dict.fromkeys(("int16", "uint16", "short", "unsigned short"), 2),
    **dict.fromkeys(("int32", "uint32", "long", "unsigned long", "float"), 4),
    **dict.fromkeys(("int64", "uint64", "long long", "unsigned long long", "double"), 8),
}


def serialize(message) -> bytes:
    """The CDR bytes of a ROS message (an rclpy message object): the 4-byte
    encapsulation header, then the fields, ending with the last one; alignment
    gaps are zero.

    Raises:
        ValueError: a field of a type without a fixed CDR size here (wstring,
            wchar, long double), or bytes that are not little-endian CDR or
            shorter than the fields (another middleware's layout).
    """
    data = bytearray(serialize_message(message))
    if data[:2] != _LITTLE_ENDIAN_CDR:
        raise ValueError(f"{_type_name(message)}: unexpected CDR header {bytes(data[:4])!r}")
    layout = _Layout()
    layout.message(message)
    end = _HEADER_SIZE + layout.offset
    if end > len(data):
        raise ValueError(
            f"{_type_name(message)}: {len(data)} bytes serialised, its fields take {end}"
        )
    for start, size in layout.gaps:
        data[_HEADER_SIZE + start : _HEADER_SIZE + start + size] = bytes(size)
    return bytes(data[:end])


def _type_name(message) -> str:
    package, namespace = type(message).__module__.split(".")[:2]
    return f"{package}/{namespace}/{type(message).__name__}"


class _Layout:
    """Walks a message's fields as CDR lays them out: `offset` is the end of what
    was walked and `gaps` the (offset, size) of the alignment padding, both
    counted from after the encapsulation header."""

    def __init__(self):
        self.offset = 0
        self.gaps: list[tuple[int, int]] = []

    def _align(self, size: int) -> None:
        padding = -self.offset % size
        if padding:
            self.gaps.append((self.offset, padding))
            self.offset += padding

    def _basic(self, typename: str, count: int = 1) -> None:
        try:
            size = _BASIC_SIZES[typename]
        except KeyError:
            raise ValueError(f"no CDR size known here for the type {typename!r}") from None
        if count:  # an empty array is not aligned (Fast CDR, rosbags)
            self._align(size)
            self.offset += size * count

    def message(self, message) -> None:
        fields = message.get_fields_and_field_types()
        if not fields:  # an empty message carries one uint8 (structure_needs_at_least_one_member)
            self._basic("uint8")
        for name, kind in zip(fields, type(message).SLOT_TYPES, strict=True):
            self.value(kind, getattr(message, name))

    def value(self, kind, value) -> None:
        if isinstance(kind, BasicType):
            self._basic(kind.typename)
        elif isinstance(kind, AbstractString):  # uint32 length with the NUL, text, NUL
            self._basic("uint32")
            self.offset += len(value.encode("utf-8")) + 1
        elif isinstance(kind, NamespacedType):
            self.message(value)
        elif isinstance(kind, AbstractNestedType):  # arrays (fixed size) and sequences
            if isinstance(kind, AbstractSequence):
                self._basic("uint32")  # the element count
            if isinstance(kind.value_type, BasicType):
                self._basic(kind.value_type.typename, len(value))
            else:
                for item in value:
                    self.value(kind.value_type, item)
        else:
            raise ValueError(f"no CDR size known here for the type {type(kind).__name__}")


class ShapeSerializer:
    """Serialises `messages.shape.shape(stamp_ns, vertices, triangles, boom_lines, frame_id)`
    for one mesh (`triangles` (T, 3) and `boom_points` points per boom line).

    Raises:
        RuntimeError: if the serialised layout is not the one expected (a changed
            message definition).
        ValueError: bytes `serialize` cannot make exact (another middleware's
            byte order or layout).
    """

    def __init__(self, triangles, boom_points: int, frame_id: str = topics.FRAME_ID):
        self.triangles = np.asarray(triangles)
        self.corners = self.triangles.ravel()
        self.frame_id = frame_id
        rng = np.random.default_rng(0)
        vertices = rng.uniform(-1.0, 1.0, (int(self.corners.max()) + 1, 3))
        boom_lines = rng.uniform(-1.0, 1.0, (4, boom_points, 3))
        template = serialize(
            shape_msg.shape(_TEMPLATE_STAMP_NS, vertices, self.triangles, boom_lines, frame_id)
        )
        self._template = template
        self._stamps = _all_offsets(template, _STAMP.pack(*divmod(_TEMPLATE_STAMP_NS, 10**9)))
        self._points = _offset_of(template, vertices[self.corners])
        self._colours = self._points + 24 * self.corners.size + 4  # after the colours' count
        expected = shape_msg.colour_array(*self._levels(vertices))
        if template[self._colours : self._colours + expected.nbytes] != expected.tobytes():
            raise RuntimeError("/sail/shape: the colours are not where expected")
        self._booms = [_offset_of(template, line) for line in boom_lines]
        if len(self._stamps) != 5:  # the membrane and four booms
            raise RuntimeError(f"/sail/shape: {len(self._stamps)} stamps found, expected 5")

    def _levels(self, vertices):
        heights = vertices[self.corners, 2]
        return heights, max(float(np.max(np.abs(heights), initial=0.0)), shape_msg.MIN_COLOUR_RANGE)

    def serialize(self, stamp_ns: int, vertices, boom_lines) -> bytes:
        """The CDR bytes of the shape at `stamp_ns` [ns]: `vertices` (P, 3) and
        `boom_lines` (4, S, 3) [m], as for `messages.shape.shape`."""
        vertices = np.asarray(vertices, dtype=float)
        buffer = bytearray(self._template)
        stamp = _STAMP.pack(*divmod(int(stamp_ns), 10**9))
        for offset in self._stamps:
            buffer[offset : offset + _STAMP.size] = stamp
        _write(buffer, self._points, vertices[self.corners])
        _write(buffer, self._colours, shape_msg.colour_array(*self._levels(vertices)))
        for offset, line in zip(self._booms, np.asarray(boom_lines, dtype=float), strict=True):
            _write(buffer, offset, line)
        return bytes(buffer)


# the fields of a sample the JointState messages carry, each in exactly one of them
# (`messages.state.JOINT_FIELDS`; a free hub's Odometry is built per sample)
_SAMPLE_ARRAYS = tuple(f for f in SAMPLE_FIELDS if f.name in state_msg.JOINT_FIELDS)


class StateSerializer:
    """Serialises `messages.state.state_messages(stamp_ns, sample, coordinate_names, frame_id,
    with_clock, inertial_frame_id)`: the same `(topic, bytes)` pairs, in the same order.
    A free hub's `/sail/hub_state` (`free_hub`) is built and serialised per sample: its
    orientation is computed, not copied.

    Raises:
        RuntimeError: if the serialised layout is not the one expected.
        ValueError: as for `ShapeSerializer`.
    """

    def __init__(
        self,
        coordinate_names,
        frame_id: str = topics.FRAME_ID,
        with_clock=False,
        free_hub: bool = False,
        inertial_frame_id: str = topics.INERTIAL_FRAME_ID,
    ):
        self._hub_frames = (frame_id, inertial_frame_id) if free_hub else None
        rng = np.random.default_rng(0)
        n = len(coordinate_names)
        sizes = {"boom": 4, "coordinate": n}
        sample = StateSample(
            0.0, **{f.name: rng.uniform(-1.0, 1.0, sizes[f.per]) for f in _SAMPLE_ARRAYS}
        )
        stamp = _STAMP.pack(*divmod(_TEMPLATE_STAMP_NS, 10**9))
        self._layouts = []  # (topic, template, stamp offset, [(array name, offset)])
        placed = []
        for topic, message in state_msg.state_messages(
            _TEMPLATE_STAMP_NS, sample, coordinate_names, frame_id, with_clock
        ):
            template = serialize(message)
            stamps = _all_offsets(template, stamp)
            if len(stamps) != 1:
                raise RuntimeError(f"{topic}: {len(stamps)} stamps found, expected 1")
            arrays = []
            for name in (f.name for f in _SAMPLE_ARRAYS):
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
        if sorted(placed) != sorted(f.name for f in _SAMPLE_ARRAYS):
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
        if self._hub_frames is not None:
            hub = hub_msg.hub_state(stamp_ns, sample.hub, *self._hub_frames)
            messages.append((topics.HUB_STATE, serialize(hub)))
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
