"""rosbag2's metadata: the bag description (metadata.yaml, version 9) and QoS text.

What `ros2 bag info` reads: `BagMetadata` as YAML, both as the folder's
`metadata.yaml` and inside each MCAP file (metadata record `rosbag2`,
`serialized_metadata`), and each topic's `offered_qos_profiles`, a YAML block
list of QoS entries (dicts: history, depth, reliability, durability,
deadline, lifespan, liveliness, liveliness_lease_duration,
avoid_ros_namespace_conventions). Plain data: nothing here needs rclpy.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import yaml

METADATA_VERSION = 9  # rosbag2 metadata.yaml version written by Jazzy
RMW_DURATION_INFINITE = {"sec": 9223372036, "nsec": 854775807}

# rosbag2 metadata version <= 8 wrote the QoS policies as rmw enum values
_QOS_ENUMS = {
    "history": ["system_default", "keep_last", "keep_all", "unknown"],
    "reliability": ["system_default", "reliable", "best_effort", "unknown", "best_available"],
    "durability": ["system_default", "transient_local", "volatile", "unknown", "best_available"],
    "liveliness": [
        "system_default",
        "automatic",
        "manual_by_node",
        "manual_by_topic",
        "unknown",
        "best_available",
    ],
}


@dataclasses.dataclass(frozen=True)
class FileSummary:
    """One written MCAP file: message count and log-time span [ns]."""

    path: Path
    message_count: int
    start_time_ns: int
    end_time_ns: int
    topic_counts: dict[str, int]


@dataclasses.dataclass
class TopicMetadata:
    """A recorded topic as rosbag2 describes it."""

    name: str
    type_name: str
    qos_profiles: list[dict]
    type_hash: str


class _Dumper(yaml.SafeDumper):
    """Safe YAML without anchors: rosbag2's yaml-cpp output never has any."""

    def ignore_aliases(self, data) -> bool:
        return True


def dump_yaml(data) -> str:
    """Block-style YAML, keys in insertion order, as rosbag2 writes its metadata."""
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False)


# -- QoS entries and their text ------------------------------------------------------------


def default_qos_profile(**changes) -> dict:
    """A rosbag2 QoS entry; the defaults are what the ROS graph reports for a
    reliable volatile publisher (history unknown, depth 0, infinite durations)."""
    profile = {
        "history": "unknown",
        "depth": 0,
        "reliability": "reliable",
        "durability": "volatile",
        "deadline": dict(RMW_DURATION_INFINITE),
        "lifespan": dict(RMW_DURATION_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(RMW_DURATION_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }
    profile.update(changes)
    return profile


def qos_profiles_yaml(profiles: Sequence[Mapping]) -> str:
    """The `offered_qos_profiles` text rosbag2 stores: a YAML block list."""
    if not profiles:
        return "[]"
    return dump_yaml([dict(p) for p in profiles]).rstrip("\n")


def parse_qos_profiles(text: str) -> list[dict]:
    """Parse an `offered_qos_profiles` text (metadata version 8 or 9) into entries
    whose policies are rosbag2 v9 names ("reliable", "transient_local", ...)."""
    if not text or not text.strip():
        return []
    try:
        profiles = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ValueError(f"offered_qos_profiles is not YAML: {error}") from None
    if not isinstance(profiles, list):
        raise ValueError(f"offered_qos_profiles must be a YAML list, got {text!r}")
    normalised = []
    for profile in profiles:
        profile = dict(profile)
        for policy, names in _QOS_ENUMS.items():
            value = profile.get(policy)
            if isinstance(value, int) and not isinstance(value, bool):
                profile[policy] = names[value] if 0 <= value < len(names) else "unknown"
        normalised.append(profile)
    return normalised


def qos_list(topic: str, profiles: str | Sequence[Mapping] | None) -> list[dict]:
    """QoS entries from their YAML text, a list of mappings, or None (one reliable
    volatile profile); ValueError naming `topic` for anything else."""
    if profiles is None:
        return [default_qos_profile()]
    if isinstance(profiles, str):
        try:
            profiles = yaml.safe_load(profiles) or []
        except yaml.YAMLError as error:
            raise ValueError(f"offered_qos_profiles of {topic} is not YAML: {error}") from None
    if not isinstance(profiles, Sequence) or not all(isinstance(p, Mapping) for p in profiles):
        raise ValueError(
            f"offered_qos_profiles of {topic} must be a list of QoS mappings, got {profiles!r}"
        )
    return [dict(p) for p in profiles]


# -- the bag description -------------------------------------------------------------------


def bag_metadata(
    topics: Sequence[TopicMetadata], files: Sequence[FileSummary], ros_distro: str
) -> dict:
    """rosbag2's BagMetadata (version 9) of `files` holding `topics`."""
    with_messages = [f for f in files if f.message_count]
    start = min((f.start_time_ns for f in with_messages), default=0)
    end = max((f.end_time_ns for f in with_messages), default=0)
    counts = {topic.name: 0 for topic in topics}
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
            for topic in topics
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
        "ros_distro": ros_distro,
    }


def write_metadata_yaml(folder: Path, metadata: dict, fsync: bool = True) -> None:
    """`folder/metadata.yaml`, written under a temporary name and renamed when complete:
    a reader, a crash or a full disk never leaves half of one (with `fsync`, not even a
    power cut: the text is on the disk before the rename, the rename before return)."""
    text = dump_yaml({"rosbag2_bagfile_information": metadata})
    temporary = folder / "metadata.yaml.tmp"
    try:
        with temporary.open("w") as stream:
            stream.write(text)
            stream.flush()
            if fsync:
                os.fsync(stream.fileno())
        temporary.replace(folder / "metadata.yaml")
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    if fsync:
        descriptor = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
