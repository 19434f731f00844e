"""A flood of commands at the simulator: does it keep real time, and does every command
end counted?

Starts `sail_sim` as a process (default settings, real time) and, from a node in
this process, publishes commands at a fixed rate for a phase each:

- `quiet`: none, for what the machine's other load costs the simulator;
- `valid`: deploy commands to alternating targets (10.2 m, 10.4 m, ...), each valid;
- `malformed`: deploy commands to NaN, each rejected.

Per phase it prints: commands sent; their outcomes as the simulator's /diagnostics
count them (accepted, superseded, rejected) and whether they add up to what was
sent; overruns; late states, gaps between two /sail/boom_state samples as the
simulator published them (DDS source timestamps) over the bound of two
state periods (40 ms at 50 Hz), in brackets those while the bystander was late too;
the largest gap; and the simulator process's CPU (a share of one core). Then what
the machine did meanwhile: a bystander, a process of its own that sleeps 2 ms at a
time, counts its wake-ups later than one integration step (10 ms) and its largest
delay; and the CPU time the hypervisor took from the machine's cores (steal,
/proc/stat; in 10 ms units). A late state while the bystander was late too is the
machine's, not the simulator's.

    python benchmarks/command_flood.py                       # 1000/s, 10 s per phase
    python benchmarks/command_flood.py --rate 500 --seconds 3
    python benchmarks/command_flood.py -- -p realtime_priority:=50
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from machine import stolen_seconds
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from sail_ros import status as key
from sail_ros import topics
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.ros.commanding import command_publisher

COUNTS = (key.ACCEPTED, key.SUPERSEDED, key.REJECTED, key.IGNORED)


class Observer(Node):
    """Publishes the commands; keeps the statuses and when each state was published."""

    def __init__(self, context):
        super().__init__("flood_observer", context=context)
        self.deploy = command_publisher(self, topics.DEPLOY_CMD)
        self.published_ns: list[int] = []
        self.statuses: list[dict] = []
        self.create_subscription(
            JointState,
            topics.BOOM_STATE,
            lambda message, info: self.published_ns.append(info["source_timestamp"]),
            topics.STATE_QOS,
        )
        self.create_subscription(
            DiagnosticArray,
            topics.DIAGNOSTICS,
            lambda message: self.statuses.append(diagnostics_msg.diagnostic_values(message)),
            topics.DIAGNOSTICS_QOS,
        )


# sleeps 2 ms at a time for argv[1] seconds; prints the largest delay [ms], then each
# wake-up more than 10 ms late as the span it slept [ns, system clock]
BYSTANDER = """
import sys, time
end, largest = time.monotonic() + float(sys.argv[1]), 0.0
while (asked := time.monotonic()) < end:
    asked_ns = time.time_ns()
    time.sleep(0.002)
    delay = time.monotonic() - asked - 0.002
    largest = max(largest, delay)
    if delay > 0.010:
        print(asked_ns, time.time_ns())
print(largest * 1e3)
"""
STATE_PERIOD_NS = 20_000_000  # 50 Hz


def cpu_seconds(pid: int) -> float:
    """CPU time [s] process `pid` has used (user + system)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def phase(observer, sim_pid: int, kind: str, rate: float, seconds: float) -> dict:
    """Publish `kind` commands at `rate` per second for `seconds`; what the simulator did,
    and what a bystander process saw meanwhile."""
    time.sleep(1.2)  # a status from before the phase
    before = dict(observer.statuses[-1])
    first_state = len(observer.published_ns)
    cpu_before, stolen_before = cpu_seconds(sim_pid), stolen_seconds()
    bystander = subprocess.Popen(
        [sys.executable, "-c", BYSTANDER, str(seconds)], stdout=subprocess.PIPE, text=True
    )
    sent, start = 0, time.monotonic()
    while (now := time.monotonic()) < start + seconds:
        due = int((now - start) * rate)
        if kind == "quiet":
            time.sleep(start + seconds - now)
            continue
        while sent < due:
            target = math.nan if kind == "malformed" else 10.2 + 0.2 * (sent % 5)
            observer.deploy.publish(Float64(data=target))
            sent += 1
        # the next command's time: sleeping, not spinning, leaves the machine's cores
        # to the simulator (the observer's callbacks run on their own thread)
        time.sleep(max(0.0, start + (sent + 1) / rate - time.monotonic()))
    cpu = (cpu_seconds(sim_pid) - cpu_before) / (time.monotonic() - start)
    stolen = stolen_seconds() - stolen_before
    *stalls, bystander_largest_ms = bystander.communicate()[0].splitlines()
    stalls = [tuple(map(int, line.split())) for line in stalls]
    time.sleep(2.5)  # the last commands answered, a status after them
    after = observer.statuses[-1]
    outcomes = {name: int(after[name]) - int(before[name]) for name in COUNTS}
    stamps = observer.published_ns[first_state:]
    gaps = list(zip(stamps[:-1], stamps[1:], strict=True))
    late = [(a, b) for a, b in gaps if b - a > 2 * STATE_PERIOD_NS]
    return {
        "sent": sent,
        "outcomes": outcomes,
        "overruns": int(after[key.OVERRUNS]) - int(before[key.OVERRUNS]),
        "largest_gap_ms": max((b - a) / 1e6 for a, b in gaps),
        "late_states": len(late),
        # late states while the bystander was late too: the machine's, not the simulator's
        "late_with_bystander": sum(any(s0 < b and a < s1 for s0, s1 in stalls) for a, b in late),
        "cpu": cpu,
        "stolen_ms": 1e3 * stolen,
        "bystander_late": len(stalls),
        "bystander_largest_ms": float(bystander_largest_ms),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rate", type=float, default=1000.0, help="commands per second (1000)")
    parser.add_argument("--seconds", type=float, default=10.0, help="length of a phase [s]")
    parser.add_argument(
        "sim_args", nargs="*", help="more ROS arguments of the simulator (-p name:=value)"
    )
    args = parser.parse_args()
    domain = 100 + os.getpid() % 100
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    log_path = Path(tempfile.gettempdir()) / f"command_flood_{os.getpid()}.log"
    with log_path.open("w") as log:
        return _run(args, domain, env, log)


def _run(args, domain: int, env: dict, log) -> int:
    sim = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sail_ros.cli",
            "sim",
            "--ros-args",
            "-p",
            "shape_rate_hz:=5.0",
            *args.sim_args,
        ],
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    observer = Observer(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(observer)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    try:
        deadline = time.monotonic() + 30.0
        while not (observer.statuses and observer.deploy.get_subscription_count() >= 1):
            if time.monotonic() > deadline:
                raise SystemExit(f"the simulator did not come up; see {log.name}")
            executor.spin_once(timeout_sec=0.1)
        spinning.start()
        print(
            f"{args.rate:g} commands/s for {args.seconds:g} s per phase (simulator log: {log.name})"
        )
        print(f"  {'phase':<10}{'sent':>6}{'accepted':>9}{'superseded':>11}{'rejected':>9}"
              f"{'add up':>7}{'overruns':>9}{'late states':>12}{'largest gap':>12}{'CPU':>5}"
              f"{'bystander late':>15}{'largest':>8}{'stolen':>10}")  # fmt: skip
        for kind in ("quiet", "valid", "malformed"):
            found = phase(observer, sim.pid, kind, args.rate, args.seconds)
            outcomes = found["outcomes"]
            adds_up = sum(outcomes.values()) == found["sent"]
            late = f"{found['late_states']} ({found['late_with_bystander']})"
            print(
                f"  {kind:<10}{found['sent']:>6}{outcomes[key.ACCEPTED]:>9}"
                f"{outcomes[key.SUPERSEDED]:>11}{outcomes[key.REJECTED]:>9}"
                f"{'yes' if adds_up else 'NO':>7}{found['overruns']:>9}{late:>12}"
                f"{found['largest_gap_ms']:>9.1f} ms{found['cpu']:>5.0%}"
                f"{found['bystander_late']:>15}{found['bystander_largest_ms']:>5.1f} ms"
                f"{found['stolen_ms']:>7.0f} ms"
            )
    finally:
        executor.shutdown()
        if spinning.is_alive():
            spinning.join()
        executor.remove_node(observer)
        observer.destroy_node()
        rclpy.try_shutdown(context=context)
        sim.send_signal(signal.SIGINT)
        sim.wait(20)
    return 0


if __name__ == "__main__":
    sys.exit(main())
