"""Latency from the simulator's publish to a Foxglove client of `sail-ros bridge`.

The simulator (default rates: 50 Hz state, 5 Hz shape, 1 Hz diagnostics) and
the bridge run as processes on a DDS domain of their own; Foxglove's WebSocket
client (test/js/bridge_client.mjs: @foxglove/ws-protocol, run with node)
subscribes to every channel and notes when each message arrived (this
machine's wall clock) and its SHA-256. This process holds a raw DDS
subscriber to the same topics that notes each message's DDS source timestamp
(the simulator's wall clock at its publish) and its SHA-256. A message's
latency is its arrival at the client minus its source timestamp, matched by
topic and bytes; also split at the bridge's reception (the log time the
bridge sends). The booms deploy 10 m -> 30 m meanwhile.

    python benchmarks/bridge_latency.py             # 20 s
    python benchmarks/bridge_latency.py --seconds 5

Needs node 20 and test/js's packages (`npm ci` there; scripts/test.sh does it).
Prints the load average before and after: other processes on the machine count.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from results import Results
from std_msgs.msg import Float64

from sail_ros import topics
from sail_ros.nodes.bridge import SERVABLE, SUBSCRIPTION_QOS

JS = Path(__file__).resolve().parents[1] / "test" / "js"
SERVED = re.compile(r"serving on (ws://127\.0\.0\.1:\d+)")
GROUPS = {
    "state (4 topics, 50 Hz)": [topics.absolute(name) for name in topics.STATE_TOPICS],
    "shape (5 Hz)": [topics.absolute(topics.SHAPE)],
    "diagnostics (1 Hz)": [topics.DIAGNOSTICS],
}


class SourceTimes(Node):
    """(topic, SHA-256 of the bytes) -> DDS source timestamp [ns], from raw subscriptions."""

    def __init__(self, context):
        super().__init__("latency_reference", context=context)
        self.sources: dict[tuple[str, str], int] = {}
        for name, (message_type, _) in SERVABLE.items():
            topic = topics.absolute(name)
            self.create_subscription(
                message_type,
                name,
                lambda data, info, topic=topic: self.sources.setdefault(
                    (topic, hashlib.sha256(data).hexdigest()), info["source_timestamp"]
                ),
                SUBSCRIPTION_QOS,
                raw=True,
            )
        self.deploy = self.create_publisher(Float64, topics.DEPLOY_CMD, topics.LATCHED_COMMAND_QOS)
        self.spinner = SingleThreadedExecutor(context=context)
        self.spinner.add_node(self)
        threading.Thread(target=self.spinner.spin, daemon=True).start()


def start(tool: str, args: list[str], env: dict, log: Path) -> subprocess.Popen:
    with open(log, "w") as stream:
        return subprocess.Popen(
            [sys.executable, "-m", "sail_ros.cli", tool, *args],
            env=env,
            stdout=stream,
            stderr=subprocess.STDOUT,
        )


def wait_for_url(log: Path, process: subprocess.Popen, timeout: float = 30.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = SERVED.search(log.read_text())
        if found:
            return found.group(1)
        if process.poll() is not None:
            break
        time.sleep(0.05)
    raise RuntimeError("the bridge did not serve:\n" + log.read_text())


def figures(values_ms: list[float]) -> list:
    """[median, p95, max] [ms] and the count, for the JSON table."""
    if not values_ms:
        return ["-", "-", "-", 0]
    median, p95 = np.percentile(values_ms, [50, 95])
    return [round(median, 2), round(p95, 2), round(max(values_ms), 2), len(values_ms)]


def percentiles(values_ms: list[float]) -> str:
    if not values_ms:
        return "no messages"
    median, p95 = np.percentile(values_ms, [50, 95])
    return (
        f"median {median:6.2f} ms, p95 {p95:6.2f} ms, max {max(values_ms):7.2f} ms "
        f"({len(values_ms)} messages)"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="measured time [s]")
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args(argv)
    results = Results("bridge_latency", sys.argv if argv is None else ["bridge_latency.py", *argv])
    table = []
    domain = 220 - os.getpid() % 10
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        env = dict(
            os.environ,
            ROS_DOMAIN_ID=str(domain),
            ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
            HOME=str(scratch),
            ROS_LOG_DIR=str(scratch / "log"),
        )
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        sim = start("sim", [], env, scratch / "sim.log")
        bridge = start("bridge", ["--port", "0"], env, scratch / "bridge.log")
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        reference = SourceTimes(context)
        try:
            url = wait_for_url(scratch / "bridge.log", bridge)
            deadline = time.monotonic() + 30.0
            while reference.deploy.get_subscription_count() < 1:
                if time.monotonic() > deadline:
                    raise RuntimeError("the simulator did not start")
                time.sleep(0.05)
            plan = scratch / "plan.json"
            plan.write_text(json.dumps({"steps": [{"wait": args.seconds}]}))
            out = scratch / "client.json"
            client = subprocess.Popen(
                ["node", str(JS / "bridge_client.mjs"), url, str(out), str(plan)], cwd=JS
            )
            time.sleep(1.0)  # connected and subscribed
            reference.deploy.publish(Float64(data=30.0))
            if client.wait(args.seconds + 30.0) != 0:
                raise RuntimeError("the client failed")
            time.sleep(0.5)
            result = json.loads(out.read_text())
        finally:
            for process in (bridge, sim):
                process.send_signal(signal.SIGINT)
            for process in (bridge, sim):
                process.wait(20)
            reference.spinner.shutdown()
            reference.destroy_node()
            rclpy.shutdown(context=context)
    print(f"load average after:  {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    total, to_bridge, to_client = {}, {}, {}
    for message in result["messages"]:
        source = reference.sources.get((message["topic"], message["sha256"]))
        if source is None:
            continue  # before this process's subscription matched
        arrival, log_time = int(message["arrival_ns"]), int(message["log_time_ns"])
        for store, value in (
            (total, arrival - source),
            (to_bridge, log_time - source),
            (to_client, arrival - log_time),
        ):
            store.setdefault(message["topic"], []).append(value * 1e-6)
    print(f"\nsimulator publish -> Foxglove client, default rates, {args.seconds:g} s, moving")
    for label, store in (
        ("publish -> client", total),
        ("publish -> bridge (DDS)", to_bridge),
        ("bridge -> client (WebSocket)", to_client),
    ):
        print(f"  {label}")
        for group, names in GROUPS.items():
            values = [v for name in names for v in store.get(name, [])]
            print(f"    {group:<26}{percentiles(values)}")
            table.append([label, group, *figures(values)])
        every = [v for values in store.values() for v in values]
        print(f"    {'all':<26}{percentiles(every)}")
        table.append([label, "all", *figures(every)])
    results.table(
        f"Simulator publish to Foxglove client, default rates, {args.seconds:g} s, booms moving",
        ["path", "topics", "median [ms]", "p95 [ms]", "max [ms]", "messages"],
        table,
    )
    results.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
