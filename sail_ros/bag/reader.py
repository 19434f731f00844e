"""Read ROS 2 MCAP bags: messages as CDR bytes with their topic, type and times.

Reads what `BagWriter` writes and what `ros2 bag record -s mcap` writes: a
single `.mcap` file or a bag folder of them (read in index order). A file
with a summary section is read through its indexes, in log-time order. A
file without one (the recorder was killed, the disk filled up, the power
went) is read front to back up to its last complete record, in file order;
a chunk that was being written when the file was cut is dropped, as is
anything after a record that fails to decode.

Example::

    bag = BagReader("run1")
    for message in bag.messages(topics=["/sail/boom_state"]):
        ...  # message.topic, .type_name, .data (CDR), .log_time_ns, .publish_time_ns
"""

from __future__ import annotations

import io
import logging
import re
import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import NamedTuple

from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from sail_ros.bag.definitions import MessageDefinition
from sail_ros.bag.metadata import parse_qos_profiles

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")  # opcode, length

_log = logging.getLogger(__name__)


class DamagedBagError(ValueError):
    """A file's content does not decode (a bad CRC, a garbled chunk); the message names it."""


class BagMessage(NamedTuple):
    """One recorded message; times in ns since the Unix epoch."""

    topic: str
    type_name: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int


class TopicInfo(NamedTuple):
    """A recorded topic: type, encoding, the publishers' QoS (rosbag2 entries:
    dicts with history, depth, reliability, durability, ...), message count, and
    the type's schema as recorded (None if the file has none)."""

    topic: str
    type_name: str
    message_encoding: str
    offered_qos_profiles: list[dict]
    type_hash: str
    message_count: int
    definition: MessageDefinition | None = None


def _bag_message(channel: Channel, schema: Schema | None, message: Message) -> BagMessage:
    return BagMessage(
        channel.topic,
        schema.name if schema else "",
        message.data,
        message.log_time,
        message.publish_time,
    )


def bag_files(path: str | Path) -> list[Path]:
    """The MCAP files of a bag: `path` itself, or a folder's `*.mcap` in index order.

    Raises:
        FileNotFoundError: `path` does not exist or the folder has no .mcap file.
    """
    path = Path(path)
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise FileNotFoundError(f"'{path}' does not exist")
    files = sorted(path.glob("*.mcap"), key=_index_order)
    if not files:
        raise FileNotFoundError(f"folder '{path}' has no .mcap file")
    return files


class BagReader:
    """A bag (MCAP file or folder) opened for reading.

    Raises:
        FileNotFoundError: see `bag_files`.
        ValueError: a file is not MCAP or not a ROS 2 (profile "ros2") recording.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._files = [_McapFile(file) for file in bag_files(path)]

    @property
    def files(self) -> list[Path]:
        """The MCAP files, in reading order."""
        return [file.path for file in self._files]

    @property
    def incomplete_files(self) -> list[Path]:
        """Files without a summary section: read up to their last complete record."""
        return [file.path for file in self._files if file.summary is None]

    def topics(self) -> dict[str, TopicInfo]:
        """Every recorded topic (the first file's type and QoS win), counts summed."""
        topics: dict[str, TopicInfo] = {}
        for file in self._files:
            for info in file.topics():
                known = topics.get(info.topic)
                if known is None:
                    topics[info.topic] = info
                else:
                    count = known.message_count + info.message_count
                    topics[info.topic] = known._replace(message_count=count)
        return topics

    def metadata(self) -> list[tuple[str, dict[str, str]]]:
        """The MCAP metadata records (name, string map), file by file."""
        return [entry for file in self._files for entry in file.metadata()]

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
        """Messages of `topics` (None: all), file by file, each file in log-time
        order (file order for an incomplete file)."""
        wanted = None if topics is None else set(topics)
        for file in self._files:
            yield from file.messages(wanted)


class _McapFile:
    """One MCAP file; `summary` is None when the file has no (readable) summary."""

    def __init__(self, path: Path):
        self.path = path
        with path.open("rb") as stream:
            if stream.read(len(MAGIC)) != MAGIC:
                raise ValueError(f"'{path}' is not an MCAP file")
            profile = _header_profile(stream, path)
            if profile != "ros2":
                raise ValueError(
                    f"'{path}' is not a ROS 2 recording: MCAP profile {profile!r}, expected 'ros2'"
                )
            self.summary = _summary_or_none(stream)
        self._scan: tuple[list[TopicInfo], list[tuple[str, dict]]] | None = None
        self._warned = False  # about an incomplete file, once

    def topics(self) -> list[TopicInfo]:
        if self.summary is None:
            return self._scanned()[0]
        statistics = self.summary.statistics
        counts = statistics.channel_message_counts if statistics else {}
        return [
            _topic_info(
                channel, self.summary.schemas.get(channel.schema_id), counts.get(channel.id, 0)
            )
            for channel in self.summary.channels.values()
        ]

    def metadata(self) -> list[tuple[str, dict[str, str]]]:
        if self.summary is None:
            return self._scanned()[1]
        with self.path.open("rb") as stream:
            return [
                (record.name, dict(record.metadata))
                for record in SeekingReader(stream).iter_metadata()
            ]

    def messages(self, wanted: set[str] | None) -> Iterator[BagMessage]:
        if self.summary is None:
            yield from self._recovered_messages(wanted)
            return
        with self.path.open("rb") as stream:
            records = SeekingReader(stream, validate_crcs=True).iter_messages(
                topics=wanted, log_time_order=True
            )
            while True:
                try:
                    schema, channel, message = next(records)
                except StopIteration:
                    return
                # a garbled chunk fails in the CRC check or in any decompressor
                except Exception as error:
                    raise DamagedBagError(
                        f"'{self.path}' is damaged: {type(error).__name__}: {error}"
                    ) from None
                yield _bag_message(channel, schema, message)

    def _scanned(self) -> tuple[list[TopicInfo], list[tuple[str, dict]]]:
        """Topics (with counts) and metadata of an incomplete file, from one pass."""
        if self._scan is None:
            schemas: dict[int, Schema] = {}
            channels: dict[int, Channel] = {}
            counts: dict[int, int] = {}
            metadata = []
            for record in self._records():
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels.setdefault(record.id, record)
                elif isinstance(record, Message):
                    counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                elif isinstance(record, Metadata):
                    metadata.append((record.name, dict(record.metadata)))
            topics = [
                _topic_info(channel, schemas.get(channel.schema_id), counts.get(cid, 0))
                for cid, channel in channels.items()
            ]
            self._scan = (topics, metadata)
        return self._scan

    def _recovered_messages(self, wanted: set[str] | None) -> Iterator[BagMessage]:
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        for record in self._records():
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                channel = channels.get(record.channel_id)
                if channel is None or (wanted is not None and channel.topic not in wanted):
                    continue
                yield _bag_message(channel, schemas.get(channel.schema_id), record)

    def _records(self) -> Iterator:
        """The records of an incomplete file up to its last complete one, chunks opened."""
        with self.path.open("rb") as stream:
            size = stream.seek(0, io.SEEK_END)
            end = _complete_prefix_end(stream, size)
            stream.seek(0)
            reader = StreamReader(io.BufferedReader(_Prefix(stream, end)), validate_crcs=True)
            records = reader.records
            while True:
                try:
                    record = next(records)
                except (StopIteration, EndOfFile):
                    break
                # a cut or garbled chunk can fail in any decompressor; what precedes it stands
                except Exception as error:
                    _log.warning("'%s': stopped reading at a damaged record: %s", self.path, error)
                    break
                yield record
            if end < size and not self._warned:
                self._warned = True
                _log.warning(
                    "'%s' is incomplete: read %d of %d bytes (up to its last complete record)",
                    self.path,
                    end,
                    size,
                )


class _Prefix(io.RawIOBase):
    """The first `limit` bytes of a binary stream."""

    def __init__(self, stream, limit: int):
        self._stream = stream
        self._left = limit

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        count = min(len(buffer), self._left)
        data = self._stream.read(count)
        buffer[: len(data)] = data
        self._left -= len(data)
        return len(data)


def _complete_prefix_end(stream, size: int) -> int:
    """Offset just past the last record that lies wholly inside the file."""
    offset = len(MAGIC)
    while offset + _RECORD_HEAD.size <= size:
        stream.seek(offset)
        opcode, length = _RECORD_HEAD.unpack(stream.read(_RECORD_HEAD.size))
        end = offset + _RECORD_HEAD.size + length
        if end > size:
            break
        offset = end
        if opcode == Opcode.FOOTER:
            return min(size, offset + len(MAGIC))
    return offset


def _header_profile(stream, path: Path) -> str:
    head = stream.read(_RECORD_HEAD.size + 4)
    if len(head) < _RECORD_HEAD.size + 4 or head[0] != Opcode.HEADER:
        raise ValueError(f"'{path}' is not an MCAP file: no header record")
    (length,) = struct.unpack_from("<I", head, _RECORD_HEAD.size)
    return stream.read(length).decode(errors="replace")


def _summary_or_none(stream):
    """The summary through the footer, or None if there is none or it is unreadable."""
    try:
        stream.seek(0)
        return SeekingReader(stream).get_summary()
    except (McapError, struct.error, ValueError, OSError):
        return None


def _topic_info(channel: Channel, schema: Schema | None, count: int) -> TopicInfo:
    metadata = channel.metadata or {}
    return TopicInfo(
        topic=channel.topic,
        type_name=schema.name if schema else "",
        message_encoding=channel.message_encoding,
        offered_qos_profiles=parse_qos_profiles(metadata.get("offered_qos_profiles", "")),
        type_hash=metadata.get("topic_type_hash", ""),
        message_count=count,
        definition=(
            MessageDefinition(schema.encoding, schema.data.decode(errors="replace"))
            if schema is not None and schema.data
            else None
        ),
    )


def _index_order(path: Path) -> tuple:
    """`name_10.mcap` after `name_9.mcap`."""
    match = re.search(r"_(\d+)$", path.stem)
    return (
        path.stem[: match.start()] if match else path.stem,
        int(match.group(1)) if match else -1,
        path.name,
    )
