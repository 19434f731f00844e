"""Memory of the recorder when the disk is slower than the traffic.

A `sail_recorder` node runs in this process on a private DDS domain; its bag
writer is slowed to `--write-ms` per message (a slow disk), while a publisher
sends `--rate` JointState messages per second (80 values each) for
`--seconds`. Prints the process's resident memory every few seconds, and
what was written and dropped: with the bounded queue (`queue_messages`) the
memory levels off once the queue is full, and the excess is counted.

    python benchmarks/recorder_slow_disk.py [--rate 2000] [--write-ms 2] [--seconds 30]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=2000.0, help="messages per second")
    parser.add_argument("--write-ms", type=float, default=2.0, help="disk time per message")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--queue", type=int, default=10000, help="queue_messages")
    args = parser.parse_args()

    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from sail_ros.bag import BagReader, BagWriter
    from sail_ros.nodes.recorder import Recorder

    original = BagWriter.write

    def slow_write(self, topic, *rest, **kwargs):
        time.sleep(args.write_ms / 1000.0)
        return original(self, topic, *rest, **kwargs)

    BagWriter.write = slow_write
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=200 + os.getpid() % 30)
    folder = Path(tempfile.mkdtemp()) / "bag"
    topic = "/sail/boom_state"
    recorder = Recorder(
        [
            Parameter("output", value=str(folder)),
            Parameter("topics", value=[topic]),
            Parameter("parameter_node", value=""),
            Parameter("queue_messages", value=args.queue),
            Parameter("qos_depth", value=1000),
        ],
        context=context,
    )

    class Stop:
        event = threading.Event()
        received = "benchmark"

    runner = threading.Thread(target=lambda: recorder.run(Stop))
    runner.start()
    node = Node("slow_disk_publisher", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    publisher = node.create_publisher(JointState, topic, QoSProfile(depth=1000))
    while publisher.get_subscription_count() < 1 or recorder.count_publishers(topic) < 1:
        executor.spin_once(timeout_sec=0.05)
    message = JointState(name=[f"j{i}" for i in range(20)], position=[0.1] * 80)
    print(f"{'t [s]':>6}{'sent':>9}{'RSS [MB]':>10}")
    start = time.monotonic()
    sent, next_report = 0, 0.0
    print(f"{0.0:6.1f}{0:9d}{rss_mb():10.1f}", flush=True)
    while (now := time.monotonic() - start) < args.seconds:
        while sent < now * args.rate:
            message.header.stamp.sec = sent
            publisher.publish(message)
            sent += 1
        if now >= next_report + 3.0:
            next_report = now
            print(f"{now:6.1f}{sent:9d}{rss_mb():10.1f}", flush=True)
        executor.spin_once(timeout_sec=0.001)
    Stop.event.set()
    runner.join()
    written = sum(1 for _ in BagReader(folder).messages())
    dropped = sum(recorder.bag.dropped.values())
    print(
        f"sent {sent}, written {written}, dropped (counted) {dropped}, disk "
        f"{1000.0 / args.write_ms:.0f} messages/s; RSS {rss_mb():.1f} MB at the end"
    )


if __name__ == "__main__":
    main()
