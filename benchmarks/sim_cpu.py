"""CPU use and real-time factor of `sail_sim`, as a separate process over DDS.

For each setting the simulator runs with a subscriber to all its topics in
this process (as a recorder would be), first with the booms at rest, then
while they deploy 10 m -> 60 m (max_rate 0.1 m/s, so that they still move at
the end of the phase even as fast as possible). Reported per phase:

- CPU: the simulator process's CPU time (user + system, all threads) over
  wall time, from /proc/<pid>/stat (100 % = one core);
- RTF: simulation time advanced over wall time (from its diagnostics);
- step: mean wall time of one 0.01 s grid step (from its diagnostics);
- overruns: ticks that found the model more than a step behind the clock
  (from its diagnostics; only meaningful when paced, not as fast as possible).

A setting with `realtime_priority` runs the integration thread first-in first-out
(needs CAP_SYS_NICE or an rtprio limit); where the system refuses, its line says so.

    python benchmarks/sim_cpu.py            # about 90 s
    python benchmarks/sim_cpu.py --quick    # shorter phases
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from results import Results
from std_msgs.msg import Float64

from sail_ros import topics
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.ros.commanding import command_publisher
from sail_ros.topics import TOPICS

SETTINGS = [
    ("default (n_B 8, automatic n_M, 50 Hz state, 5 Hz shape), real time", {}),
    ("default, 2x real time", {"time_scale": 2.0}),
    (
        "n_B = n_M = 10, 100 Hz state, 10 Hz shape, real time",
        {
            "sail.n_boom_modes": 10,
            "sail.n_membrane_modes": 10,
            "state_rate_hz": 100.0,
            "shape_rate_hz": 10.0,
        },
    ),
    (
        "n_B = n_M = 20, 100 Hz state, 10 Hz shape, real time",
        {
            "sail.n_boom_modes": 20,
            "sail.n_membrane_modes": 20,
            "state_rate_hz": 100.0,
            "shape_rate_hz": 10.0,
        },
    ),
    (
        "n_B = n_M = 10, 100 Hz state, 10 Hz shape, 8x real time",
        {
            "sail.n_boom_modes": 10,
            "sail.n_membrane_modes": 10,
            "state_rate_hz": 100.0,
            "shape_rate_hz": 10.0,
            "time_scale": 8.0,
        },
    ),
    (
        "n_B = n_M = 10, 100 Hz state, 10 Hz shape, 8x, SCHED_FIFO 50",
        {
            "sail.n_boom_modes": 10,
            "sail.n_membrane_modes": 10,
            "state_rate_hz": 100.0,
            "shape_rate_hz": 10.0,
            "time_scale": 8.0,
            "realtime_priority": 50,
        },
    ),
    ("default, as fast as possible", {"time_scale": 0.0}),
    (
        "n_B = n_M = 10, 100 Hz state, 10 Hz shape, as fast as possible",
        {
            "sail.n_boom_modes": 10,
            "sail.n_membrane_modes": 10,
            "state_rate_hz": 100.0,
            "shape_rate_hz": 10.0,
            "time_scale": 0.0,
        },
    ),
]
OUTPUTS = {
    topics.BOOM_STATE: "sensor_msgs/msg/JointState",
    topics.MODAL_STATE: "sensor_msgs/msg/JointState",
    topics.TIP_DEFLECTION: "sensor_msgs/msg/JointState",
    topics.SHAPE: "visualization_msgs/msg/MarkerArray",
    topics.CLOCK: "rosgraph_msgs/msg/Clock",
}
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] of process `pid`, all threads."""
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS  # utime, stime


class Observer(Node):
    """Subscribes (raw) to every output and keeps (receipt time, sim time, step ms)."""

    def __init__(self, context):
        super().__init__("sim_cpu_benchmark", context=context)
        self.executor_ = SingleThreadedExecutor(context=context)
        self.executor_.add_node(self)
        self.received = 0
        self.status: list[tuple[float, float, float, int]] = []
        self.realtime_priority = 0
        for name, type_name in OUTPUTS.items():
            package, _, kind = type_name.split("/")
            module = __import__(f"{package}.msg", fromlist=[kind])
            self.create_subscription(
                getattr(module, kind), name, self._count, TOPICS[name].qos, raw=True
            )
        self.create_subscription(
            DiagnosticArray, topics.DIAGNOSTICS, self._on_status, topics.DIAGNOSTICS_QOS
        )
        self.deploy = command_publisher(self, topics.DEPLOY_CMD)

    def _count(self, _data) -> None:
        self.received += 1

    def _on_status(self, message: DiagnosticArray) -> None:
        values = diagnostics_msg.diagnostic_values(message)
        self.realtime_priority = int(values["realtime_priority"])
        self.status.append(
            (
                time.monotonic(),
                float(values["sim_time_s"]),
                float(values["step_time_ms_mean"]),
                int(values["overruns"]),
            )
        )

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor_.spin_once(timeout_sec=0.01)


def measure(observer: Observer, pid: int, seconds: float) -> tuple[float, float, float, int]:
    """(CPU fraction, real-time factor, mean step ms, overruns) over the next `seconds`."""
    first = len(observer.status)
    cpu0, wall0 = cpu_seconds(pid), time.monotonic()
    observer.spin_for(seconds)
    cpu = (cpu_seconds(pid) - cpu0) / (time.monotonic() - wall0)
    window = observer.status[first:]
    (w0, t0, _, overruns0), (w1, t1, _, overruns1) = window[0], window[-1]
    steps = [step for _, _, step, _ in window[1:]]
    return cpu, (t1 - t0) / (w1 - w0), sum(steps) / len(steps), overruns1 - overruns0


def run(parameters: dict, rest_s: float, moving_s: float, env: dict, domain: int):
    ros_args = [
        item
        for name, value in {"diagnostics_rate_hz": 10.0, "max_rate": 0.1, **parameters}.items()
        for item in ("-p", f"{name}:={value}")
    ]
    sim = subprocess.Popen(
        [sys.executable, "-m", "sail_ros.cli", "sim", "--ros-args", *ros_args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    observer = Observer(context)
    try:
        deadline = time.monotonic() + 30.0
        while len(observer.status) < 3 or observer.deploy.get_subscription_count() < 1:
            if sim.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the simulator did not start:\n" + sim.stderr.read().decode())
            observer.spin_for(0.05)
        observer.spin_for(1.0)  # past the start-up
        rest = measure(observer, sim.pid, rest_s)
        observer.deploy.publish(Float64(data=60.0))  # 1000 s of simulation at 0.1 m/s
        observer.spin_for(0.2)
        moving = measure(observer, sim.pid, moving_s)
        priority = observer.realtime_priority
    finally:
        sim.send_signal(signal.SIGINT)
        code = sim.wait(20)
        observer.destroy_node()
        rclpy.shutdown(context=context)
    if code != 0:
        raise RuntimeError(f"the simulator exited with {code}")
    return rest, moving, priority


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 s phases instead of 8 s")
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args(argv)
    results = Results("sim_cpu", sys.argv if argv is None else ["sim_cpu.py", *argv])
    table = []
    phase = 3.0 if args.quick else 8.0
    domain = 230 - os.getpid() % 10
    with tempfile.TemporaryDirectory() as home:
        env = dict(
            os.environ,
            ROS_DOMAIN_ID=str(domain),
            ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
            HOME=home,
            ROS_LOG_DIR=os.path.join(home, "log"),
        )
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        print(
            f"sail_sim CPU use and real-time factor ({os.cpu_count()} cores; CPU 100 % = "
            f"one core; {phase:g} s per phase)\n"
        )
        print(f"  {'setting':<72}{'phase':>9}{'CPU':>8}{'RTF':>9}{'step':>10}{'overruns':>10}")
        for name, parameters in SETTINGS:
            *phases, priority = run(parameters, phase, phase, env, domain)
            if priority != parameters.get("realtime_priority", 0):
                name += " (refused)"
            for label, (cpu, rtf, step, overruns) in zip(
                ("at rest", "moving"), phases, strict=True
            ):
                print(
                    f"  {name:<72}{label:>9}{100 * cpu:7.1f}%{rtf:9.2f}{step:8.3f}ms{overruns:>10}",
                    flush=True,
                )
                table.append([name, label, round(100 * cpu, 1), round(rtf, 2), round(step, 3),
                              overruns])  # fmt: skip
                name = ""
    results.table(
        f"The simulator process, {phase:g} s per phase (CPU 100 % = one core; overruns: ticks "
        "that found the model more than one integration step behind the clock)",
        ["setting", "phase", "CPU [%]", "real-time factor", "step [ms]", "overruns"],
        table,
    )
    results.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
