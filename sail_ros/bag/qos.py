"""QoS translation: rclpy's `QoSProfile` to and from rosbag2's QoS entries.

The one place where a live QoS meets its recorded form (`metadata`):

- `entry_of`: what the recorder stores for a publisher the graph reports;
- `recorded_entry`: what that would be for a publisher created with a
  profile (history and depth are not visible in the graph: "unknown", 0);
- `subscription_for`: the request a recorder makes so every offer matches;
- `publisher_for`: the publisher a replay creates from the recorded offers.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from sail_ros.bag.metadata import default_qos_profile


def _rmw_time(duration) -> dict:
    sec, nsec = divmod(duration.nanoseconds, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def entry_of(profile: QoSProfile) -> dict:
    """The rosbag2 (metadata version 9) entry of an offered QoS profile."""
    return {
        "history": profile.history.name.lower(),
        "depth": profile.depth,
        "reliability": profile.reliability.name.lower(),
        "durability": profile.durability.name.lower(),
        "deadline": _rmw_time(profile.deadline),
        "lifespan": _rmw_time(profile.lifespan),
        "liveliness": profile.liveliness.name.lower(),
        "liveliness_lease_duration": _rmw_time(profile.liveliness_lease_duration),
        "avoid_ros_namespace_conventions": bool(profile.avoid_ros_namespace_conventions),
    }


def recorded_entry(profile: QoSProfile) -> dict:
    """The entry the recorder stores for a publisher created with `profile`, as the
    ROS graph reports it: its reliability and durability, history "unknown",
    depth 0, infinite durations."""
    return default_qos_profile(
        reliability=profile.reliability.name.lower(), durability=profile.durability.name.lower()
    )


def subscription_for(offered: list[QoSProfile], depth: int) -> QoSProfile:
    """A request every publisher can serve, as rosbag2 makes it: reliable only if
    all offer reliable, transient local only if all offer it."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def publisher_for(entries: list[dict], default_depth: int) -> QoSProfile:
    """A publisher QoS from the recorded offers (rosbag2 entries): their reliability
    and durability, their depth if they kept a fixed one, else `default_depth`."""
    first = entries[0] if entries else {}
    same = all(
        (p.get("reliability"), p.get("durability"))
        == (first.get("reliability"), first.get("durability"))
        for p in entries
    )
    if not same:
        first = {}  # mixed offers: the ROS default, which every subscriber can match
    depth = first.get("depth") or 0
    if first.get("history") != "keep_last" or depth <= 0:
        depth = default_depth
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=(
            ReliabilityPolicy.BEST_EFFORT
            if first.get("reliability") == "best_effort"
            else ReliabilityPolicy.RELIABLE
        ),
        durability=(
            DurabilityPolicy.TRANSIENT_LOCAL
            if first.get("durability") == "transient_local"
            else DurabilityPolicy.VOLATILE
        ),
    )
