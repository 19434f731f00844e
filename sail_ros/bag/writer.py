"""`BagWriter`: CDR messages into MCAP files laid out as rosbag2's MCAP storage writes them.

What a file holds, so that `ros2 bag info/play`, Foxglove and rosbags read it:

- profile `ros2`; one schema per type, encoding `ros2msg` with the full
  definition text of the installed `.msg` files (see `definitions`);
- one channel per topic, message encoding `cdr`, channel metadata
  `offered_qos_profiles` (the publishers' QoS as a rosbag2 YAML list) and
  `topic_type_hash` (RIHS01_...);
- messages as the CDR bytes given, log time and publish time in ns;
- zstd/lz4/uncompressed chunks, closed when they reach `chunk_size` bytes or
  are `max_chunk_duration_s` old, then flushed (and fsync'ed) so that a killed
  process or a power cut loses at most the chunk in progress;
- at close, a `rosbag2` metadata record (`serialized_metadata`,
  `ROS_DISTRO`) and the summary section.

Given a folder, the writer behaves like `ros2 bag record`: files
`<folder>/<folder name>_<index>.mcap`, a new one when the current one reaches
`max_file_size_bytes` or spans `max_file_duration_s` of log time, and a
rosbag2 `metadata.yaml` (version 9) once closed. Given a path ending in
`.mcap`, it writes that one file.

Example (`cdr` from `rclpy.serialization.serialize_message`)::

    with BagWriter("run1", compression="zstd") as bag:
        bag.add_topic("/sail/boom_state", "sensor_msgs/msg/JointState")
        bag.write("/sail/boom_state", cdr, log_time_ns=t_ns)
        bag.add_metadata("sail_sim_parameters", {"sail_side": "100.0"})

A `BagWriter` is not thread-safe: use it from one thread.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Callable, Mapping, Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer

from sail_ros.bag.definitions import DefinitionNotFoundError, message_definition, type_hash

COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}
METADATA_VERSION = 9  # rosbag2 metadata.yaml version written by Jazzy
MIN_FILE_SIZE_BYTES = 1024  # rosbag2's MCAP storage refuses smaller splits
_MESSAGE_RECORD_OVERHEAD = 31  # bytes: opcode, length, channel, sequence, two times
_INFINITE = {"sec": 9223372036, "nsec": 854775807}  # RMW_DURATION_INFINITE


class BagWriteError(RuntimeError):
    """Writing a bag file failed; `path` is the file, `error` the OSError."""

    def __init__(self, path: Path, error: OSError):
        super().__init__(f"cannot write '{path}': {error.strerror or error}"
                         + (f" [errno {error.errno}]" if error.errno else ""))
        self.path = path
        self.error = error


@dataclasses.dataclass(frozen=True)
class FileSummary:
    """One written MCAP file: message count and log-time span [ns]."""

    path: Path
    message_count: int
    start_time_ns: int
    end_time_ns: int
    topic_counts: dict[str, int]


@dataclasses.dataclass
class _Topic:
    name: str
    type_name: str
    qos_profiles: list[dict]
    type_hash: str
    schema_encoding: str
    schema_text: str


@dataclasses.dataclass
class _OpenFile:
    path: Path
    stream: object
    mcap: Writer
    channel_ids: dict[str, int]
    schema_ids: dict[str, int]
    topic_counts: dict[str, int]
    message_count: int = 0
    start_time_ns: int = 0
    end_time_ns: int = 0


def default_qos_profile(**changes) -> dict:
    """A rosbag2 QoS entry; the defaults are what the ROS graph reports for a
    reliable volatile publisher (history unknown, depth 0, infinite durations)."""
    profile = {
        "history": "unknown",
        "depth": 0,
        "reliability": "reliable",
        "durability": "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }
    profile.update(changes)
    return profile


class _Dumper(yaml.SafeDumper):
    """Safe YAML without anchors: rosbag2's yaml-cpp output never has any."""

    def ignore_aliases(self, data) -> bool:
        return True


def dump_yaml(data) -> str:
    """Block-style YAML, keys in insertion order, as rosbag2 writes its metadata."""
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False)


def qos_profiles_yaml(profiles: Sequence[Mapping]) -> str:
    """The `offered_qos_profiles` text rosbag2 stores: a YAML block list."""
    if not profiles:
        return "[]"
    return dump_yaml([dict(p) for p in profiles]).rstrip("\n")


class BagWriter:
    """Writes CDR messages to an MCAP file or a rosbag2 folder of MCAP files.

    Args:
        path: a folder (created if absent; must be empty) or a file ending in
            `.mcap` (must not exist unless `overwrite`).
        compression: chunk compression, "zstd", "lz4" or "none".
        chunk_size: close a chunk once its messages reach this size [bytes].
        max_chunk_duration_s: close a chunk this long after its first message
            [s, wall clock]; a chunk's messages are only safe on disk once it is closed.
        max_file_size_bytes: start a new file once the current one reaches
            this size [bytes] (0: never); it may overshoot by one chunk.
        max_file_duration_s: start a new file once the log times in the current
            one span this long [s] (0: never).
        fsync: fsync each closed chunk so a power cut loses at most one chunk.
        on_new_file: called with the path of each file after the first, right
            after it is opened (a split); e.g. to write metadata into it.
        ros_distro: recorded in the rosbag2 metadata.
        overwrite: replace an existing `.mcap` file (folder mode never overwrites).

    Raises:
        ValueError: an argument is out of range (the message names it).
        BagWriteError: the output cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        compression: str = "zstd",
        chunk_size: int = 1 << 20,
        max_chunk_duration_s: float = 1.0,
        max_file_size_bytes: int = 0,
        max_file_duration_s: float = 0.0,
        fsync: bool = True,
        on_new_file: Callable[[Path], None] | None = None,
        ros_distro: str = "jazzy",
        overwrite: bool = False,
    ):
        self._path = Path(path)
        self._single_file = self._path.suffix == ".mcap"
        _check_choice("compression", compression, COMPRESSIONS)
        _check_number("chunk_size", chunk_size, minimum=1, integer=True)
        _check_number("max_chunk_duration_s", max_chunk_duration_s, minimum=0.0, exclusive=True)
        _check_number("max_file_size_bytes", max_file_size_bytes, minimum=0, integer=True)
        if 0 < max_file_size_bytes < MIN_FILE_SIZE_BYTES:
            raise ValueError(f"max_file_size_bytes must be 0 (no split) or >= "
                             f"{MIN_FILE_SIZE_BYTES}, got {max_file_size_bytes!r}")
        _check_number("max_file_duration_s", max_file_duration_s, minimum=0.0)
        if self._single_file and (max_file_size_bytes or max_file_duration_s):
            raise ValueError(f"splitting files needs a folder as output, got the file "
                             f"path {str(self._path)!r}")
        self._compression = compression
        self._chunk_size = chunk_size
        self._max_chunk_duration_s = max_chunk_duration_s
        self._max_file_size = max_file_size_bytes
        self._max_file_duration_ns = round(max_file_duration_s * 1e9)
        self._fsync = fsync
        self._on_new_file = on_new_file
        self._ros_distro = ros_distro
        self._overwrite = overwrite
        self._library = _library_name()

        self._topics: dict[str, _Topic] = {}
        self._files: list[FileSummary] = []
        self._file: _OpenFile | None = None
        self._chunk_bytes = 0
        self._chunk_opened_at: float | None = None  # time.monotonic() of its first message
        self._error: BagWriteError | None = None
        self._closed = False

        if not self._single_file:
            self._guarded(self._path, self._make_folder)
        self._open_file()

    # -- public API -------------------------------------------------------------------------

    @property
    def path(self) -> Path:
        """The folder or file given to the constructor."""
        return self._path

    @property
    def files(self) -> list[Path]:
        """Every MCAP file written so far, the current one included."""
        current = [self._file.path] if self._file else []
        return [f.path for f in self._files] + current

    @property
    def topic_counts(self) -> dict[str, int]:
        """Messages written per topic, over all files (topics with none included)."""
        counts = dict.fromkeys(self._topics, 0)
        for summary in self._all_file_summaries():
            for topic, count in summary.topic_counts.items():
                counts[topic] += count
        return counts

    def add_topic(
        self,
        topic: str,
        type_name: str,
        offered_qos_profiles: str | Sequence[Mapping] | None = None,
        topic_type_hash: str | None = None,
    ) -> None:
        """Declare a topic before writing to it; again for a known topic is a no-op.

        Args:
            topic: absolute topic name, e.g. "/sail/boom_state".
            type_name: "pkg/msg/Type"; its definition is read from the installed
                .msg files (a type without any gets an empty schema).
            offered_qos_profiles: the publishers' QoS, as rosbag2 QoS entries
                (dicts, see `default_qos_profile`) or their YAML text; None means
                one reliable volatile profile.
            topic_type_hash: "RIHS01_..."; None reads it from the installed .json.
        """
        self._check_usable()
        if topic in self._topics:
            return
        if not topic.startswith("/"):
            raise ValueError(f"topic must be an absolute name starting with '/', got {topic!r}")
        try:
            definition = message_definition(type_name)
            encoding, text = definition.encoding, definition.text
        except DefinitionNotFoundError:
            encoding, text = "", ""  # MCAP's "no schema available"
        self._topics[topic] = _Topic(
            name=topic,
            type_name=type_name,
            qos_profiles=_qos_list(topic, offered_qos_profiles),
            type_hash=type_hash(type_name) if topic_type_hash is None else topic_type_hash,
            schema_encoding=encoding,
            schema_text=text,
        )
        self._guarded(self._file.path, self._register, self._file, self._topics[topic])

    def write(
        self,
        topic: str,
        data: bytes,
        log_time_ns: int,
        publish_time_ns: int | None = None,
        sequence: int = 0,
    ) -> None:
        """Append one message.

        Under rmw_fastrtps, `rclpy.serialization.serialize_message` returns
        its size estimate: the CDR bytes plus unused trailing bytes. ROS,
        rosbag2 and mcap_ros2 ignore them; rosbags rejects such a message
        ("CDR message size mismatch"). Bytes from a raw subscription are exact.

        Args:
            topic: a topic declared with `add_topic`.
            data: the CDR-serialised message, stored as given.
            log_time_ns: receive time [ns since the Unix epoch].
            publish_time_ns: send time [ns]; None means `log_time_ns`.
            sequence: publisher sequence number (0 if unknown).
        """
        self._check_usable()
        if topic not in self._topics:
            raise ValueError(f"topic {topic!r} was not declared; call add_topic first")
        self._maybe_split(log_time_ns)
        file = self._file
        publish_time_ns = log_time_ns if publish_time_ns is None else publish_time_ns
        self._guarded(file.path, file.mcap.add_message, file.channel_ids[topic], log_time_ns,
                      data, publish_time_ns, sequence)
        if file.message_count == 0:
            file.start_time_ns = file.end_time_ns = log_time_ns
        file.start_time_ns = min(file.start_time_ns, log_time_ns)
        file.end_time_ns = max(file.end_time_ns, log_time_ns)
        file.message_count += 1
        file.topic_counts[topic] += 1
        self._chunk_bytes += len(data) + _MESSAGE_RECORD_OVERHEAD
        if self._chunk_opened_at is None:
            self._chunk_opened_at = time.monotonic()
        if self._chunk_bytes >= self._chunk_size:
            self.flush()
        else:
            self.tick()

    def tick(self) -> None:
        """Close the chunk in progress if it is `max_chunk_duration_s` old.

        `write` does this itself; call `tick` periodically when messages may
        stop arriving, so the last ones still reach the disk in time.
        """
        opened = self._chunk_opened_at
        if opened is not None and time.monotonic() - opened >= self._max_chunk_duration_s:
            self.flush()

    def seconds_to_next_tick(self) -> float:
        """Time until the chunk in progress is due [s]; `max_chunk_duration_s` if none is."""
        if self._chunk_opened_at is None:
            return self._max_chunk_duration_s
        due = self._chunk_opened_at + self._max_chunk_duration_s
        return max(0.0, due - time.monotonic())

    def flush(self) -> None:
        """Close the chunk in progress now and push it to the disk."""
        self._check_usable()
        self._guarded(self._file.path, self._flush_file, self._file)

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Write an MCAP metadata record (a string -> string map) into the current file."""
        self._check_usable()
        bad = [key for key, value in data.items()
               if not isinstance(key, str) or not isinstance(value, str)]
        if bad:
            raise TypeError(f"metadata {name!r} must map strings to strings; "
                            f"entry {bad[0]!r} does not")
        file = self._file
        # the chunk in progress goes first, so the file stays in receive order
        self._guarded(file.path, self._flush_file, file)
        self._guarded(file.path, file.mcap.add_metadata, name, dict(data))
        self._guarded(file.path, self._flush_file, file)

    def close(self) -> list[FileSummary]:
        """Finish the current file (summary, rosbag2 metadata) and, for a folder,
        write metadata.yaml. Safe to call twice. After a write error it only
        releases the file: what reached the disk stays readable.

        Returns:
            one summary per file written.

        Raises:
            BagWriteError: finishing the file failed.
        """
        if self._closed:
            return list(self._files)
        self._closed = True
        if self._error is not None:
            self._abandon()
            raise self._error
        self._finish_file()
        if not self._single_file:
            self._guarded(self._path / "metadata.yaml", self._write_metadata_yaml)
        return list(self._files)

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
            return
        with contextlib.suppress(BagWriteError):  # the exception in flight says more
            self.close()

    # -- files ------------------------------------------------------------------------------

    def _make_folder(self) -> None:
        self._path.mkdir(parents=True, exist_ok=True)
        if any(self._path.iterdir()):
            raise FileExistsError(17, "folder exists and is not empty", str(self._path))

    def _next_path(self) -> Path:
        if self._single_file:
            return self._path
        return self._path / f"{self._path.name}_{len(self._files)}.mcap"

    def _open_file(self) -> None:
        path = self._next_path()
        stream = self._guarded(path, open, path, "wb" if self._overwrite else "xb")
        mcap = Writer(
            stream,
            chunk_size=1 << 62,  # chunks are closed here, by size and by age
            compression=COMPRESSIONS[self._compression],
        )
        file = _OpenFile(path=path, stream=stream, mcap=mcap, channel_ids={}, schema_ids={},
                         topic_counts=dict.fromkeys(self._topics, 0))
        self._file = file
        self._guarded(path, mcap.start, "ros2", self._library)
        for topic in self._topics.values():
            self._guarded(path, self._register, file, topic)
        self._guarded(path, self._flush_file, file)

    def _register(self, file: _OpenFile, topic: _Topic) -> None:
        schema_id = file.schema_ids.get(topic.type_name)
        if schema_id is None:
            schema_id = file.mcap.register_schema(topic.type_name, topic.schema_encoding,
                                                  topic.schema_text.encode())
            file.schema_ids[topic.type_name] = schema_id
        file.channel_ids[topic.name] = file.mcap.register_channel(
            topic.name,
            "cdr",
            schema_id,
            {"offered_qos_profiles": qos_profiles_yaml(topic.qos_profiles),
             "topic_type_hash": topic.type_hash},
        )
        file.topic_counts.setdefault(topic.name, 0)

    def _flush_file(self, file: _OpenFile) -> None:
        file.mcap.flush()
        if self._fsync:
            os.fsync(file.stream.fileno())
        self._chunk_bytes = 0
        self._chunk_opened_at = None

    def _maybe_split(self, log_time_ns: int) -> None:
        file = self._file
        if file.message_count == 0:
            return
        too_long = (self._max_file_duration_ns
                    and log_time_ns - file.start_time_ns >= self._max_file_duration_ns)
        too_big = (self._max_file_size
                   and self._guarded(file.path, file.stream.tell) >= self._max_file_size)
        if too_long or too_big:
            self._finish_file()
            self._open_file()
            if self._on_new_file is not None:
                self._on_new_file(self._file.path)

    def _finish_file(self) -> None:
        file = self._file
        summary = self._summary_of(file)
        self._guarded(file.path, self._flush_file, file)
        self._guarded(file.path, file.mcap.add_metadata, "rosbag2", {
            "serialized_metadata": dump_yaml(self._bag_metadata([summary])),
            "ROS_DISTRO": self._ros_distro,
        })
        self._guarded(file.path, file.mcap.finish)
        self._guarded(file.path, self._flush_and_close, file)
        self._files.append(summary)
        self._file = None

    def _flush_and_close(self, file: _OpenFile) -> None:
        file.stream.flush()
        if self._fsync:
            os.fsync(file.stream.fileno())
        file.stream.close()

    def _abandon(self) -> None:
        if self._file is None:
            return
        # the buffered tail cannot be written either; the error is already reported
        with contextlib.suppress(OSError):
            self._file.stream.close()
        self._files.append(self._summary_of(self._file))
        self._file = None

    def _write_metadata_yaml(self) -> None:
        text = dump_yaml({"rosbag2_bagfile_information": self._bag_metadata(self._files)})
        temporary = self._path / "metadata.yaml.tmp"
        temporary.write_text(text)
        temporary.replace(self._path / "metadata.yaml")

    # -- metadata ---------------------------------------------------------------------------

    def _summary_of(self, file: _OpenFile) -> FileSummary:
        return FileSummary(path=file.path, message_count=file.message_count,
                           start_time_ns=file.start_time_ns, end_time_ns=file.end_time_ns,
                           topic_counts=dict(file.topic_counts))

    def _all_file_summaries(self) -> list[FileSummary]:
        current = [self._summary_of(self._file)] if self._file else []
        return self._files + current

    def _bag_metadata(self, files: list[FileSummary]) -> dict:
        """rosbag2's BagMetadata (version 9) for `files`."""
        with_messages = [f for f in files if f.message_count]
        start = min((f.start_time_ns for f in with_messages), default=0)
        end = max((f.end_time_ns for f in with_messages), default=0)
        counts = dict.fromkeys(self._topics, 0)
        for f in files:
            for topic, count in f.topic_counts.items():
                counts[topic] += count
        return {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": end - start},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": sum(counts.values()),
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": topic.name,
                        "type": topic.type_name,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": topic.qos_profiles,
                        "type_description_hash": topic.type_hash,
                    },
                    "message_count": counts[topic.name],
                }
                for topic in self._topics.values()
            ],
            # chunk compression belongs to the storage; rosbag2 leaves these empty for it
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.path.name for f in files],
            "files": [
                {
                    "path": f.path.name,
                    "starting_time": {"nanoseconds_since_epoch": f.start_time_ns},
                    "duration": {"nanoseconds": f.end_time_ns - f.start_time_ns},
                    "message_count": f.message_count,
                }
                for f in files
            ],
            "custom_data": None,
            "ros_distro": self._ros_distro,
        }

    # -- errors -----------------------------------------------------------------------------

    def _check_usable(self) -> None:
        if self._error is not None:
            raise self._error
        if self._closed:
            raise ValueError(f"bag '{self._path}' is closed")

    def _guarded(self, path: Path, function, *args):
        """Call `function`; an OSError marks the writer failed and becomes a BagWriteError."""
        try:
            return function(*args)
        except OSError as error:
            self._error = BagWriteError(path, error)
            raise self._error from error


def _qos_list(topic: str, profiles: str | Sequence[Mapping] | None) -> list[dict]:
    if profiles is None:
        return [default_qos_profile()]
    if isinstance(profiles, str):
        try:
            profiles = yaml.safe_load(profiles) or []
        except yaml.YAMLError as error:
            raise ValueError(f"offered_qos_profiles of {topic} is not YAML: {error}") from None
    if not isinstance(profiles, Sequence) or not all(isinstance(p, Mapping) for p in profiles):
        raise ValueError(f"offered_qos_profiles of {topic} must be a list of QoS mappings, "
                         f"got {profiles!r}")
    return [dict(p) for p in profiles]


def _check_choice(name: str, value, choices) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got {value!r}")


def _check_number(name: str, value, *, minimum, integer=False, exclusive=False) -> None:
    kinds = (int,) if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, kinds) or value != value:
        kind = "an integer" if integer else "a number"
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    if value < minimum or (exclusive and value == minimum):
        relation = ">" if exclusive else ">="
        raise ValueError(f"{name} must be {relation} {minimum}, got {value!r}")


def _library_name() -> str:
    try:
        own = version("sail_ros")
    except PackageNotFoundError:
        own = "source"
    return f"sail_ros {own}; mcap-python {version('mcap')}"
