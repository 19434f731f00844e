"""One MCAP file laid out as rosbag2's MCAP storage writes it (`McapFile`).

What a file holds, so that `ros2 bag info/play`, Foxglove and rosbags read it:

- profile `ros2`; one schema per type, encoding `ros2msg` with the full
  definition text of the installed `.msg` files (see `definitions`);
- one channel per topic, message encoding `cdr`, channel metadata
  `offered_qos_profiles` (the publishers' QoS as a rosbag2 YAML list) and
  `topic_type_hash` (`RIHS01_...`);
- messages as the CDR bytes given, log time and publish time in ns;
- the header at once, and each schema and channel as soon as its topic is
  registered, outside any chunk, flushed (and fsync'ed): a file cut before its
  first chunk still names its topics (each is repeated in the first chunk that
  uses it, as the mcap writer does; MCAP allows identical repeats);
- zstd/lz4/uncompressed chunks, closed when they reach `chunk_size` bytes or
  are `max_chunk_duration_s` old, then flushed (and fsync'ed) so that a killed
  process or a power cut loses at most the chunk in progress; a file's first
  chunks are shorter: the first closes `FIRST_CHUNK_S` after its first message,
  each next one may last twice as long as the one before, up to
  `max_chunk_duration_s` (0.1, 0.2, 0.4, 0.8, 1 s), so that a process killed
  early in a file, with little on disk yet, loses at most about the second
  half of what it received;
- at `finish`, a `rosbag2` metadata record (`serialized_metadata`,
  `ROS_DISTRO`) and the summary section.

Every OSError becomes a `BagWriteError` naming the file.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Schema
from mcap.writer import CompressionType, Writer

from sail_ros.bag.metadata import FileSummary, TopicMetadata, dump_yaml, qos_profiles_yaml

COMPRESSIONS = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
_MESSAGE_RECORD_OVERHEAD = 31  # bytes: opcode, length, channel, sequence, two times
FIRST_CHUNK_S = 0.1  # a file's first chunk closes this long after its first message [s]


class BagWriteError(RuntimeError):
    """Writing a bag file failed; `path` is the file, `error` the OSError."""

    def __init__(self, path: Path, error: OSError):
        super().__init__(
            f"cannot write '{path}': {error.strerror or error}"
            + (f" [errno {error.errno}]" if error.errno else "")
        )
        self.path = path
        self.error = error


def guarded(path: Path, function, *args):
    """`function(*args)`; an OSError becomes a BagWriteError naming `path`."""
    try:
        return function(*args)
    except OSError as error:
        raise BagWriteError(path, error) from error


class McapFile:
    """One open MCAP file of a recording.

    Args:
        path: the file; created (it must not exist unless `overwrite`).
        compression: "zstd", "lz4" or "none".
        chunk_size: close a chunk once its messages reach this size [bytes].
        max_chunk_duration_s: close a chunk this long after its first message [s].
        fsync: fsync each closed chunk.
        overwrite: replace an existing file.

    Raises:
        BagWriteError: the file cannot be created.
    """

    def __init__(
        self,
        path: Path,
        *,
        compression: str,
        chunk_size: int,
        max_chunk_duration_s: float,
        fsync: bool,
        overwrite: bool,
    ):
        self.path = path
        self._chunk_size = chunk_size
        self._max_chunk_duration_s = max_chunk_duration_s
        self._fsync = fsync
        self._stream = guarded(path, open, path, "wb" if overwrite else "xb")
        self._mcap = Writer(
            self._stream,
            chunk_size=1 << 62,  # chunks are closed here, by size and by age
            compression=COMPRESSIONS[compression],
        )
        self._channel_ids: dict[str, int] = {}
        self._schema_ids: dict[str, int] = {}
        self.topic_counts: dict[str, int] = {}
        self.message_count = 0
        self.start_time_ns = 0
        self.end_time_ns = 0
        self._chunk_bytes = 0
        self._chunk_opened_at: float | None = None  # time.monotonic() of its first message
        self._chunk_duration_s = min(FIRST_CHUNK_S, max_chunk_duration_s)  # the next's
        guarded(path, self._mcap.start, "ros2", _library_name())

    def summary(self) -> FileSummary:
        return FileSummary(
            path=self.path,
            message_count=self.message_count,
            start_time_ns=self.start_time_ns,
            end_time_ns=self.end_time_ns,
            topic_counts=dict(self.topic_counts),
        )

    def size(self) -> int:
        """Bytes written to the file so far."""
        return guarded(self.path, self._stream.tell)

    def register(self, topic: TopicMetadata, schema_encoding: str, schema_text: str) -> None:
        """A channel for `topic` (and a schema for its type, once per type), written at
        once outside the chunk in progress; `push` sends them to the disk."""
        guarded(self.path, self._register, topic, schema_encoding, schema_text)

    def push(self) -> None:
        """What was written so far to the disk, without closing the chunk in progress."""
        guarded(self.path, self._push)

    def _push(self) -> None:
        self._stream.flush()
        if self._fsync:
            os.fsync(self._stream.fileno())

    def _register(self, topic: TopicMetadata, schema_encoding: str, schema_text: str) -> None:
        # the mcap writer puts schemas and channels into the chunk in progress only; the
        # same records are also written here, between chunks, and pushed to the disk
        records = RecordBuilder()
        schema_id = self._schema_ids.get(topic.type_name)
        if schema_id is None:
            data = schema_text.encode()
            schema_id = self._mcap.register_schema(topic.type_name, schema_encoding, data)
            self._schema_ids[topic.type_name] = schema_id
            Schema(id=schema_id, name=topic.type_name, encoding=schema_encoding, data=data).write(
                records
            )
        metadata = {
            "offered_qos_profiles": qos_profiles_yaml(topic.qos_profiles),
            "topic_type_hash": topic.type_hash,
        }
        channel_id = self._mcap.register_channel(topic.name, "cdr", schema_id, metadata)
        self._channel_ids[topic.name] = channel_id
        Channel(
            id=channel_id,
            topic=topic.name,
            message_encoding="cdr",
            schema_id=schema_id,
            metadata=metadata,
        ).write(records)
        self.topic_counts.setdefault(topic.name, 0)
        # the writer keeps nothing of its own unwritten between calls (its records go
        # out at once, the chunk in progress stays in memory) and computes no CRC over
        # the data section, so records written to its stream here keep the file valid
        self._stream.write(records.end())

    def write(
        self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int, sequence: int
    ) -> None:
        """Append one message to the chunk in progress; close it if it is full or old."""
        guarded(
            self.path,
            self._mcap.add_message,
            self._channel_ids[topic],
            log_time_ns,
            data,
            publish_time_ns,
            sequence,
        )
        if self.message_count == 0:
            self.start_time_ns = self.end_time_ns = log_time_ns
        self.start_time_ns = min(self.start_time_ns, log_time_ns)
        self.end_time_ns = max(self.end_time_ns, log_time_ns)
        self.message_count += 1
        self.topic_counts[topic] += 1
        self._chunk_bytes += len(data) + _MESSAGE_RECORD_OVERHEAD
        if self._chunk_opened_at is None:
            self._chunk_opened_at = time.monotonic()
        if self._chunk_bytes >= self._chunk_size:
            self.flush()
        else:
            self.tick()

    def tick(self) -> None:
        """Close the chunk in progress if it is due (`max_chunk_duration_s` old; a
        file's first ones sooner)."""
        opened = self._chunk_opened_at
        if opened is not None and time.monotonic() - opened >= self._chunk_duration_s:
            self.flush()

    def seconds_to_next_tick(self) -> float:
        """Time until the chunk in progress is due [s]; `max_chunk_duration_s` if none is."""
        if self._chunk_opened_at is None:
            return self._max_chunk_duration_s
        due = self._chunk_opened_at + self._chunk_duration_s
        return max(0.0, due - time.monotonic())

    def flush(self) -> None:
        """Close the chunk in progress now and push it to the disk."""
        guarded(self.path, self._flush)

    def _flush(self) -> None:
        self._mcap.flush()
        self._push()
        if self._chunk_opened_at is not None:  # a chunk was written: the next may last longer
            self._chunk_duration_s = min(2 * self._chunk_duration_s, self._max_chunk_duration_s)
        self._chunk_bytes = 0
        self._chunk_opened_at = None

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """An MCAP metadata record, after the chunk in progress (the file stays in
        receive order), pushed to the disk at once."""
        self.flush()
        guarded(self.path, self._mcap.add_metadata, name, dict(data))
        self.flush()

    def finish(self, serialized_metadata: dict, ros_distro: str) -> FileSummary:
        """The `rosbag2` record, the summary section, and the file closed."""
        summary = self.summary()
        self.flush()
        record = {"serialized_metadata": dump_yaml(serialized_metadata), "ROS_DISTRO": ros_distro}
        guarded(self.path, self._mcap.add_metadata, "rosbag2", record)
        guarded(self.path, self._mcap.finish)
        guarded(self.path, self._close)
        return summary

    def _close(self) -> None:
        self._push()
        self._stream.close()

    def abandon(self) -> FileSummary:
        """Release the file after a write error: the buffered tail cannot be written
        either; what reached the disk stays readable."""
        with contextlib.suppress(OSError):
            self._stream.close()
        return self.summary()


def _library_name() -> str:
    try:
        own = version("sail_ros")
    except PackageNotFoundError:
        own = "source"
    return f"sail_ros {own}; mcap-python {version('mcap')}"
