"""ROS 2 bags in MCAP, written and read the way rosbag2's MCAP storage does.

- `BagWriter`: CDR messages into an MCAP file or a rosbag2 folder of them
  (schemas from the installed .msg files, channel QoS metadata, chunking,
  compression, splitting, metadata.yaml).
- `BagReader`: messages back as (topic, type_name, data, log_time_ns,
  publish_time_ns), also from files cut short by a crash.
- `definitions`: message definition text and type hashes of installed types.
- `trim_cdr`: exact CDR bytes of a locally serialised message.

Nothing in this package needs rclpy.
"""

from sail_ros.bag.cdr import trim_cdr
from sail_ros.bag.definitions import (
    DefinitionNotFoundError,
    MessageDefinition,
    message_definition,
    type_hash,
)
from sail_ros.bag.reader import BagMessage, BagReader, TopicInfo, bag_files, parse_qos_profiles
from sail_ros.bag.writer import (
    COMPRESSIONS,
    BagWriteError,
    BagWriter,
    FileSummary,
    default_qos_profile,
    qos_profiles_yaml,
)

__all__ = [
    "COMPRESSIONS",
    "BagMessage",
    "BagReader",
    "BagWriteError",
    "BagWriter",
    "DefinitionNotFoundError",
    "FileSummary",
    "MessageDefinition",
    "TopicInfo",
    "bag_files",
    "default_qos_profile",
    "message_definition",
    "parse_qos_profiles",
    "qos_profiles_yaml",
    "trim_cdr",
    "type_hash",
]
