"""ROS 2 bags in MCAP, written and read the way rosbag2's MCAP storage does.

Split as rosbag2 splits it:

- `writer`: `BagWriter`, the sequential writer: a file or a rosbag2 folder
  of files, splitting by size or duration, metadata.yaml;
- `mcap_storage`: `McapFile`, one MCAP file (schemas, channels with QoS
  metadata, chunking, compression, fsync, the `rosbag2` record);
- `metadata`: rosbag2's BagMetadata and the QoS entries as YAML text;
- `qos`: the translation between QoS entries and rclpy's `QoSProfile` (the
  only module here that needs rclpy; import it explicitly);
- `reader`: `BagReader`, messages back as (topic, type_name, data,
  log_time_ns, publish_time_ns), also from files cut short by a crash;
- `definitions`: message definition text and type hashes of installed types.

Messages are stored as given: exact CDR bytes (`sail_ros.messages.cdr.serialize`).
"""

from sail_ros.bag.definitions import (
    DefinitionNotFoundError,
    MessageDefinition,
    message_definition,
    type_hash,
)
from sail_ros.bag.mcap_storage import COMPRESSIONS, BagWriteError
from sail_ros.bag.metadata import (
    FileSummary,
    default_qos_profile,
    parse_qos_profiles,
    qos_profiles_yaml,
)
from sail_ros.bag.reader import BagMessage, BagReader, DamagedBagError, TopicInfo, bag_files
from sail_ros.bag.writer import BagWriter

__all__ = [
    "COMPRESSIONS",
    "BagMessage",
    "BagReader",
    "BagWriteError",
    "BagWriter",
    "DamagedBagError",
    "DefinitionNotFoundError",
    "FileSummary",
    "MessageDefinition",
    "TopicInfo",
    "bag_files",
    "default_qos_profile",
    "message_definition",
    "parse_qos_profiles",
    "qos_profiles_yaml",
    "type_hash",
]
