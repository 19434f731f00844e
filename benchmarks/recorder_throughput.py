"""Highest publish rate at which `sail_recorder` loses nothing.

For each rate, a publisher process sends `--seconds` worth of simulator-like
steps (per step: /sail/boom_state with 4 booms, /sail/modal_state with 40
modes, /sail/shape with a membrane of --points points), a recorder process
records them (default parameters: zstd, reliable), and the messages in the
finished bag are counted. The publisher sends pre-serialised CDR bytes, so
that it is not the first to saturate. Prints one line per rate and the
highest rate without loss, and the recorder's CPU time per recorded message
(user + system, all threads, from /proc). Not a test: the figures depend on
the machine.

    python benchmarks/recorder_throughput.py
    python benchmarks/recorder_throughput.py --rates 100 1000 3000 --points 1000
"""

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results import Results
from sim_cpu import cpu_seconds  # a sibling script: benchmarks/ is on sys.path when run

TOPICS = ["/sail/boom_state", "/sail/modal_state", "/sail/shape"]


def sail_step(i: int, points: int):
    """The messages of simulation step i."""
    from geometry_msgs.msg import Point
    from sensor_msgs.msg import JointState
    from visualization_msgs.msg import Marker, MarkerArray

    booms = JointState(
        name=[f"boom_{k}" for k in range(4)], position=[0.1 * i] * 4, velocity=[0.01] * 4
    )
    modes = JointState(
        name=[f"mode_{k}" for k in range(40)], position=[1e-3 * i] * 40, velocity=[1e-4] * 40
    )
    membrane = Marker(
        ns="membrane",
        id=0,
        type=Marker.TRIANGLE_LIST,
        points=[Point(x=float(k), y=0.5 * k, z=1e-3 * i) for k in range(points)],
    )
    for message in (booms, modes, membrane):
        message.header.stamp.sec = i
    return dict(zip(TOPICS, (booms, modes, MarkerArray(markers=[membrane])), strict=True))


def publish(rate: float, steps: int, points: int) -> None:
    """Publisher process: wait for the recorder, publish, print the achieved rate [Hz]."""
    import rclpy
    from rclpy.node import Node

    rclpy.init()
    node = Node("throughput_publisher")
    step = sail_step(0, points)
    publishers = {t: node.create_publisher(type(m), t, 10) for t, m in step.items()}
    while min(p.get_subscription_count() for p in publishers.values()) < 1:
        rclpy.spin_once(node, timeout_sec=0.01)
    from sail_ros.messages.cdr import serialize

    # serialised ahead, so that the rate measures the recorder, not building messages
    messages = [
        {topic: serialize(message) for topic, message in sail_step(i, points).items()}
        for i in range(min(steps, 50))
    ]
    start = due = time.monotonic()
    for i in range(steps):
        for topic, message in messages[i % len(messages)].items():
            publishers[topic].publish(message)
        due += 1.0 / rate
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    print(f"{steps / (time.monotonic() - start):.1f}", flush=True)
    rclpy.shutdown()


def measure(rate: float, seconds: float, points: int, env: dict, folder: Path) -> tuple:
    """(achieved publish rate [Hz], messages published, messages in the bag, recorder CPU
    seconds while the publisher ran)."""
    steps = max(50, round(rate * seconds))
    recorder = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sail_ros.cli",
            "recorder",
            "-o",
            str(folder),
            "--topics",
            *TOPICS,
            "--parameter-node",
            "",
        ],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(1.0)  # past the recorder's start-up, which is not what is measured
    cpu_before = cpu_seconds(recorder.pid)
    publisher = subprocess.run(
        [sys.executable, __file__, "--publish", str(rate), str(steps), str(points)],
        env=env,
        capture_output=True,
        text=True,
        timeout=seconds * 20 + 60,
        check=True,
    )
    cpu = cpu_seconds(recorder.pid) - cpu_before
    recorder.send_signal(signal.SIGINT)
    _, err = recorder.communicate(timeout=60)
    if recorder.returncode != 0:
        raise RuntimeError(f"recorder failed:\n{err}")
    from sail_ros.bag import BagReader

    recorded = sum(info.message_count for info in BagReader(folder).topics().values())
    return float(publisher.stdout.strip()), steps * len(TOPICS), recorded, cpu


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--rates",
        type=float,
        nargs="+",
        default=[100, 200, 500, 1000, 2000, 4000, 8000],
        help="steps/s to try",
    )
    parser.add_argument("--seconds", type=float, default=2.0, help="publishing time per rate [s]")
    parser.add_argument("--points", type=int, default=400, help="membrane points per shape")
    parser.add_argument("--publish", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args()
    if args.publish:
        publish(float(args.publish[0]), int(args.publish[1]), int(args.publish[2]))
        return 0

    env = dict(
        os.environ,
        ROS_DOMAIN_ID=str(101 + os.getpid() % 100),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
    )
    shape_bytes = len(sail_step(0, args.points)["/sail/shape"].markers[0].points) * 24
    print(
        f"per step: {len(TOPICS)} messages, shape ~{shape_bytes / 1024:.1f} KiB; "
        f"{args.seconds} s per rate"
    )
    print(
        f"{'target Hz':>10} {'achieved Hz':>12} {'published':>10} {'recorded':>9} "
        f"{'lost':>6} {'MiB/s':>7} {'CPU/message':>12}"
    )
    best = None
    results = Results("recorder_throughput", sys.argv)
    table = []
    with tempfile.TemporaryDirectory() as tmp:
        for index, rate in enumerate(args.rates):
            folder = Path(tmp) / f"rate_{index}"
            achieved, published, recorded, cpu = measure(
                rate, args.seconds, args.points, env, folder
            )
            size = sum(f.stat().st_size for f in folder.glob("*.mcap"))
            raw_rate = achieved * (shape_bytes + 800) / 2**20  # uncompressed, roughly
            cpu_us = 1e6 * cpu / max(recorded, 1)
            print(
                f"{rate:>10.0f} {achieved:>12.1f} {published:>10} {recorded:>9} "
                f"{published - recorded:>6} {raw_rate:>7.2f} {cpu_us:>9.0f} us "
                f"  (bag {size / 2**20:.2f} MiB)"
            )
            table.append([round(rate), round(achieved, 1), published, recorded,
                          published - recorded, round(raw_rate, 2), round(cpu_us)])  # fmt: skip
            if recorded == published:
                best = achieved
            else:
                break
    results.table(
        f"Recorder throughput: {len(TOPICS)} messages a step, {args.seconds:g} s per rate",
        ["target [steps/s]", "achieved [steps/s]", "published", "recorded", "lost",
         "MiB/s (raw)", "CPU per message [us]"],
        table,
    )  # fmt: skip
    if best is None:
        print("the recorder lost messages at every rate tried")
        results.write(args.json)
        return 1
    print(f"highest lossless rate: {best:.0f} steps/s ({best * len(TOPICS):.0f} messages/s)")
    results.note(f"highest lossless rate: {best:.0f} steps/s ({best * len(TOPICS):.0f} messages/s)")
    results.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
