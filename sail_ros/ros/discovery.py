"""How soon a sail_ros process and the others on its DDS domain find each other.

Fast DDS, ROS 2 Jazzy's default middleware, has a running participant announce
itself every 3 s. A participant that starts later (`sail-ros send`, `watch`, a
recorder) is not always answered at once: measured on one machine, a new process
found a running one at once in about half of the starts and otherwise waited up to
the next announcement, up to 3 s. sail_ros's processes announce themselves every
0.5 s (`fastdds_discovery.xml`), so a command from the terminal reaches the
simulator within half a second; on localhost that costs a few small packets a
second.

Fast DDS's reliable writers ask their readers for acknowledgements every 3 s; a
client tool's (`CLIENT_PROFILE`) every 0.1 s, so that `sail-ros send` can wait,
before it exits, until every reader of its command has it (a recorder's too) at
the cost of a tenth of a second rather than three.

A profile file of the user's (FASTRTPS_DEFAULT_PROFILES_FILE or
FASTDDS_DEFAULT_PROFILES_FILE set) wins: it is left as it is (and `send` may then
wait up to its 2 s bound for acknowledgements). Other middlewares ignore the
setting.
"""

from __future__ import annotations

import os
from pathlib import Path

PROFILE = Path(__file__).with_name("fastdds_discovery.xml")
CLIENT_PROFILE = Path(__file__).with_name("fastdds_client.xml")  # PROFILE, and acks
ANNOUNCEMENT_PERIOD_S = 0.5  # as PROFILE says
PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")


def announce_often(environ=os.environ, profile: Path = PROFILE) -> bool:
    """Have this process's participants (created after this call) use `profile`
    (`PROFILE`, or `CLIENT_PROFILE`), unless the user set a profile file; True if it
    was set here. Inherited by child processes."""
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return False
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(profile)
    return True


def subscriptions_of(node, topic: str, type_name: str) -> int:
    """How many subscriptions of `topic` [a resolved name] with type `type_name` the
    graph of `node` shows: those a publisher of that type can match (a reader of
    another type on the same name never does)."""
    infos = node.get_subscriptions_info_by_topic(topic)
    return sum(1 for info in infos if info.topic_type == type_name)
