"""`BagWriter`: the sequential writer of a recording, as rosbag2's SequentialWriter.

Given a folder, the writer behaves like `ros2 bag record`: files
`<folder>/<folder name>_<index>.mcap`, a new one when the current one reaches
`max_file_size_bytes` or spans `max_file_duration_s` of log time, and a
rosbag2 `metadata.yaml` (version 9, `metadata`) once closed. As in rosbag2's
SequentialWriter::write, `write` splits when a split is due (`split_due`,
`split`); a caller that adds to each new file (e.g. a metadata record) does
both itself and writes with `split=False`. Given a path
ending in `.mcap`, it writes that one file. Each file is an `McapFile`
(`mcap_storage`: schemas, channels, chunks, fsync, the rosbag2 record).

Example (`cdr` from `sail_ros.messages.cdr.serialize`)::

    with BagWriter("run1", compression="zstd") as bag:
        bag.add_topic("/sail/boom_state", "sensor_msgs/msg/JointState")
        bag.write("/sail/boom_state", cdr, log_time_ns=t_ns)
        bag.add_metadata("sail_sim_parameters", {"sail_side": "100.0"})

A `BagWriter` is not thread-safe: use it from one thread.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from sail_ros.bag.definitions import MessageDefinition, message_definition, type_hash
from sail_ros.bag.mcap_storage import COMPRESSIONS, BagWriteError, McapFile, guarded
from sail_ros.bag.metadata import (
    FileSummary,
    TopicMetadata,
    bag_metadata,
    qos_list,
    write_metadata_yaml,
)

MIN_FILE_SIZE_BYTES = 1024  # rosbag2's MCAP storage refuses smaller splits


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
            raise ValueError(
                f"max_file_size_bytes must be 0 (no split) or >= "
                f"{MIN_FILE_SIZE_BYTES}, got {max_file_size_bytes!r}"
            )
        _check_number("max_file_duration_s", max_file_duration_s, minimum=0.0)
        if self._single_file and (max_file_size_bytes or max_file_duration_s):
            raise ValueError(
                f"splitting files needs a folder as output, got the file path {str(self._path)!r}"
            )
        self._compression = compression
        self._chunk_size = chunk_size
        self._max_chunk_duration_s = max_chunk_duration_s
        self._max_file_size = max_file_size_bytes
        self._max_file_duration_ns = round(max_file_duration_s * 1e9)
        self._fsync = fsync
        self._ros_distro = ros_distro
        self._overwrite = overwrite

        self._topics: dict[str, TopicMetadata] = {}
        self._schemas: dict[str, tuple[str, str]] = {}  # type name -> (encoding, text)
        self._files: list[FileSummary] = []
        self._file: McapFile | None = None
        self._error: BagWriteError | None = None
        self._closed = False

        if not self._single_file:
            self._attempt(guarded, self._path, self._make_folder)
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
        definition: MessageDefinition | None = None,
    ) -> None:
        """Declare a topic before writing to it; again for a known topic is a no-op.

        Args:
            topic: absolute topic name, e.g. "/sail/boom_state".
            type_name: "pkg/msg/Type".
            offered_qos_profiles: the publishers' QoS, as rosbag2 QoS entries
                (dicts, see `metadata.default_qos_profile`) or their YAML text;
                None means one reliable volatile profile.
            topic_type_hash: `"RIHS01_..."`; None reads it from the installed .json.
            definition: the type's schema (e.g. as another log recorded it); None
                reads it from the installed .msg files.

        Raises:
            DefinitionNotFoundError: no definition given and none installed.
        """
        self._check_usable()
        if topic in self._topics:
            return
        if not topic.startswith("/"):
            raise ValueError(f"topic must be an absolute name starting with '/', got {topic!r}")
        if type_name not in self._schemas:
            if definition is None or not definition.text:
                # no empty schema: no reader can decode a channel without its definition
                definition = message_definition(type_name)  # DefinitionNotFoundError names it
            self._schemas[type_name] = (definition.encoding, definition.text)
        self._topics[topic] = TopicMetadata(
            name=topic,
            type_name=type_name,
            qos_profiles=qos_list(topic, offered_qos_profiles),
            type_hash=type_hash(type_name) if topic_type_hash is None else topic_type_hash,
        )
        self._attempt(self._file.register, self._topics[topic], *self._schemas[type_name])
        self._attempt(self._file.push)  # a file cut before its first chunk still has the topic

    def write(
        self,
        topic: str,
        data: bytes,
        log_time_ns: int,
        publish_time_ns: int | None = None,
        sequence: int = 0,
        *,
        split: bool = True,
    ) -> None:
        """Append one message, after a split if one is due and `split`.

        Strict readers reject bytes past the message's last field (rosbags:
        "CDR message size mismatch"), which `rclpy.serialization.serialize_message`
        leaves under rmw_fastrtps: give `sail_ros.messages.cdr.serialize`'s
        bytes, or a raw subscription's (exact).

        Args:
            topic: a topic declared with `add_topic`.
            data: the CDR-serialised message, stored as given.
            log_time_ns: receive time [ns since the Unix epoch].
            publish_time_ns: send time [ns]; None means `log_time_ns`.
            sequence: publisher sequence number (0 if unknown).
            split: False: into the current file, whatever its size and span (the
                caller decides splits with `split_due` and `split`).
        """
        self._check_usable()
        if topic not in self._topics:
            raise ValueError(f"topic {topic!r} was not declared; call add_topic first")
        if split and self.split_due(log_time_ns):
            self.split()
        publish_time_ns = log_time_ns if publish_time_ns is None else publish_time_ns
        self._attempt(self._file.write, topic, data, log_time_ns, publish_time_ns, sequence)

    def split_due(self, log_time_ns: int) -> bool:
        """Whether a message logged at `log_time_ns` [ns] should start a new file: the
        current one holds messages and reached `max_file_size_bytes` or would span
        `max_file_duration_s` (rosbag2's should_split_bagfile)."""
        self._check_usable()
        file = self._file
        if file.message_count == 0:
            return False
        if self._max_file_duration_ns and (
            log_time_ns - file.start_time_ns >= self._max_file_duration_ns
        ):
            return True
        return bool(self._max_file_size) and self._attempt(file.size) >= self._max_file_size

    def split(self) -> Path:
        """Finish the current file and start the next, with every topic declared in it
        (rosbag2's split_bagfile); returns the new file's path."""
        self._check_usable()
        if self._single_file:
            raise ValueError(f"splitting files needs a folder as output, got {str(self._path)!r}")
        self._finish_file()
        self._open_file()
        return self._file.path

    def tick(self) -> None:
        """Close the chunk in progress if it is `max_chunk_duration_s` old.

        `write` does this itself; call `tick` periodically when messages may
        stop arriving, so the last ones still reach the disk in time.
        """
        if self._file is None:
            return
        self._check_usable()
        self._attempt(self._file.tick)

    def seconds_to_next_tick(self) -> float:
        """Time until the chunk in progress is due [s]; `max_chunk_duration_s` if none is."""
        if self._file is None:
            return self._max_chunk_duration_s
        return self._file.seconds_to_next_tick()

    def flush(self) -> None:
        """Close the chunk in progress now and push it to the disk."""
        self._check_usable()
        self._attempt(self._file.flush)

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Write an MCAP metadata record (a string -> string map) into the current file."""
        self._check_usable()
        bad = [
            key
            for key, value in data.items()
            if not isinstance(key, str) or not isinstance(value, str)
        ]
        if bad:
            raise TypeError(
                f"metadata {name!r} must map strings to strings; entry {bad[0]!r} does not"
            )
        self._attempt(self._file.add_metadata, name, data)

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
            if self._file is not None:
                self._files.append(self._file.abandon())
                self._file = None
            raise self._error
        self._finish_file()
        if not self._single_file:
            metadata = bag_metadata(list(self._topics.values()), self._files, self._ros_distro)
            self._attempt(
                guarded,
                self._path / "metadata.yaml",
                write_metadata_yaml,
                self._path,
                metadata,
                self._fsync,
            )
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
        self._file = self._attempt(
            McapFile,
            self._next_path(),
            compression=self._compression,
            chunk_size=self._chunk_size,
            max_chunk_duration_s=self._max_chunk_duration_s,
            fsync=self._fsync,
            overwrite=self._overwrite,
        )
        for topic in self._topics.values():
            self._attempt(self._file.register, topic, *self._schemas[topic.type_name])
        self._attempt(self._file.flush)

    def _finish_file(self) -> None:
        file = self._file
        metadata = bag_metadata(list(self._topics.values()), [file.summary()], self._ros_distro)
        self._files.append(self._attempt(file.finish, metadata, self._ros_distro))
        self._file = None

    def _all_file_summaries(self) -> list[FileSummary]:
        current = [self._file.summary()] if self._file else []
        return self._files + current

    # -- errors -----------------------------------------------------------------------------

    def _check_usable(self) -> None:
        if self._error is not None:
            raise self._error
        if self._closed:
            raise ValueError(f"bag '{self._path}' is closed")

    def _attempt(self, function, *args, **kwargs):
        """Call `function`; a BagWriteError marks the writer failed for good."""
        try:
            return function(*args, **kwargs)
        except BagWriteError as error:
            self._error = error
            raise


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
