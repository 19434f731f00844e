"""Exact CDR bytes of a serialised message.

Under rmw_fastrtps, `rclpy.serialization.serialize_message` returns the
payload padded up to its size estimate (a multiple of 8 bytes after the
4-byte encapsulation header). ROS readers ignore the padding, but strict
readers such as `rosbags` reject a message with more than 3 trailing bytes.
Bytes taken from a DDS reader are already exact; messages serialised locally
(offline logs) are trimmed here to the end of their last field.
"""

from __future__ import annotations

import functools


@functools.lru_cache(maxsize=1)
def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def trim_cdr(data: bytes, type_name: str) -> bytes:
    """`data` cut after the last field of its `type_name` message (e.g.
    "sensor_msgs/msg/JointState"); little-endian CDR only, as ROS 2 writes it.

    Raises ValueError if the bytes do not hold such a message.
    """
    if len(data) < 4 or bytes(data[:2]) != b"\x00\x01":
        raise ValueError(f"data must be little-endian CDR, got header {bytes(data[:4])!r}")
    store = _typestore()
    try:
        definition = store.get_msgdef(type_name)
        _, end = definition.deserialize_cdr_le(memoryview(data)[4:], 0, definition.cls, store)
    except Exception as error:  # rosbags raises several kinds for a bad buffer
        raise ValueError(f"data is not a {type_name} message: {error}") from error
    return bytes(data[: 4 + end])
