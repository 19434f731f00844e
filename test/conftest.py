"""Shared fixtures: the ROS environment, a private DDS domain, the operator harness.

Tiers (markers, one per test module; `pytest -m model` runs in seconds):

- `model`: the model, the offline tools and the bag format, against closed
  forms and independent readers; no node;
- `node`: nodes in this process, each test with a private rclpy `Context`;
- `multiprocess`: the tools as separate processes over real DDS;
- `lint`: ruff.

Every test of this process talks on one private DDS domain, on loopback only,
so nothing outside the test run can reach it, and nothing of it leaves the
machine. Set here, before any rclpy context exists, the variables reach both
this process and the processes the tests start.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.srv import SetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory

from sail_ros import topics

TIERS = ("model", "node", "multiprocess", "lint")

# one domain per test run (1..200; Fast DDS supports ids up to 232), inherited by the
# processes it starts, which may import this module too (helper scripts)
DOMAIN_ID = int(os.environ.setdefault("SAIL_ROS_TEST_DOMAIN_ID", str(1 + os.getpid() % 200)))
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN_ID)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
_SCRATCH = Path(tempfile.mkdtemp(prefix="sail_ros_test_"))
os.environ.setdefault("HOME", str(_SCRATCH))
os.environ.setdefault("ROS_LOG_DIR", str(_SCRATCH / "ros_log"))


def pytest_collection_modifyitems(items):
    """Every test belongs to exactly one tier."""
    for item in items:
        tiers = [name for name in TIERS if item.get_closest_marker(name)]
        if len(tiers) != 1:
            raise pytest.UsageError(f"{item.nodeid}: needs exactly one of {TIERS}, has {tiers}")
        item.user_properties.append(("tier", tiers[0]))


_TIER_SECONDS: dict[str, float] = {}
_STARTED = time.monotonic()


def pytest_runtest_logreport(report):
    """Wall time per tier: setup, call and teardown of its tests."""
    tier = dict(report.user_properties).get("tier")
    if tier is not None:
        _TIER_SECONDS[tier] = _TIER_SECONDS.get(tier, 0.0) + report.duration


def pytest_terminal_summary(terminalreporter):
    """The suite's wall time and each tier's, printed by the test command (the README's
    suite budget is 240 s on 2 cores)."""
    tiers = ", ".join(
        f"{tier} {_TIER_SECONDS[tier]:.0f} s" for tier in TIERS if tier in _TIER_SECONDS
    )
    terminalreporter.write_line(
        f"suite wall time {time.monotonic() - _STARTED:.0f} s ({tiers}) on {os.cpu_count()} cores"
    )


@pytest.fixture(scope="session")
def ros_env(tmp_path_factory) -> dict[str, str]:
    """Environment of the processes a test starts: the private domain, localhost, a
    private home and log folder, unbuffered output; a process stopped by SIGABRT prints
    every thread's Python stack (faulthandler), so a hang names where it hangs."""
    home = tmp_path_factory.mktemp("home")
    return dict(
        os.environ,
        HOME=str(home),
        ROS_LOG_DIR=str(home / "log"),
        PYTHONUNBUFFERED="1",
        PYTHONFAULTHANDLER="1",
        RCUTILS_COLORIZED_OUTPUT="0",
    )


@pytest.fixture
def figure_checks():
    """{path: FigureCheck} of every figure saved during the test (`figure_check.checking`)."""
    from sail_ros.plots.figure_check import checking

    with checking() as checks:
        yield checks


@pytest.fixture
def ros_context():
    """A private rclpy context on the test domain, shut down after the test."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    yield context
    rclpy.try_shutdown(context=context)


def spin_until(executor, condition, timeout: float, what: str, step: float = 0.01) -> None:
    """Spin `executor` until `condition()`; fail naming `what` after `timeout` [s]."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out after {timeout} s waiting for {what}"
        executor.spin_once(timeout_sec=step)


# -- the operator harness: tools as processes, and a node that drives them -------------------


class Tool:
    """A `sail-ros <tool>` process whose output goes to a file."""

    def __init__(self, tool, args, env, log_path):
        self.log_path = log_path
        with open(log_path, "w") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "sail_ros.cli", tool, *args],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
            )

    def stop(self, signum, timeout=20.0) -> int:
        self.process.send_signal(signum)
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            pytest.fail(f"{self.log_path.stem} did not exit within {timeout} s:\n{self.log()}")

    def log(self) -> str:
        return self.log_path.read_text()


def ros_value(value) -> str:
    """A parameter value for `-p name:=value`."""
    if isinstance(value, list):
        return "[" + ",".join(map(repr, value)) + "]"
    return repr(value)


@pytest.fixture
def processes(tmp_path, ros_env):
    """`start(tool, *args, parameters={...})`; every process still running at the end
    is killed."""
    started = []

    def start(tool, *args, parameters=None):
        ros_args = []
        if parameters:
            ros_args = ["--ros-args"] + [
                item
                for name, value in parameters.items()
                for item in ("-p", f"{name}:={ros_value(value)}")
            ]
        log = tmp_path / f"{tool}_{len(started)}.log"
        tool_process = Tool(tool, [*args, *ros_args], ros_env, log)
        started.append(tool_process)
        return tool_process

    yield start
    for tool_process in started:
        if tool_process.process.poll() is None:
            tool_process.process.kill()
            tool_process.process.wait()


class Operator(Node):
    """Publishes commands, calls services, and keeps everything the simulator publishes."""

    def __init__(self, context):
        super().__init__("sim_operator", context=context)
        self.spinner = SingleThreadedExecutor(context=context)
        self.spinner.add_node(self)
        self.states = {name: [] for name in topics.STATE_TOPICS}
        for name, kept in self.states.items():
            self.create_subscription(JointState, name, kept.append, topics.STATE_QOS)
        self.diagnostics: list[DiagnosticArray] = []
        self.published_ns: list[int] = []  # wall clock each diagnostics left the simulator
        self.create_subscription(
            DiagnosticArray, topics.DIAGNOSTICS, self._on_status, topics.DIAGNOSTICS_QOS
        )
        self.deploy = self.create_publisher(Float64, topics.DEPLOY_CMD, topics.COMMAND_QOS)
        self.trajectory = self.create_publisher(
            JointTrajectory, topics.BOOM_LENGTH_CMD, topics.COMMAND_QOS
        )
        self.reset = self.create_client(Trigger, topics.RESET_SERVICE)
        self.pause = self.create_client(SetBool, topics.PAUSE_SERVICE)
        self.set_parameters = self.create_client(SetParameters, "/sail_sim/set_parameters")

    def _on_status(self, message: DiagnosticArray, info) -> None:
        # DDS's source timestamp: when the simulator published, however late this
        # process takes the sample
        self.diagnostics.append(message)
        self.published_ns.append(info["source_timestamp"])

    def spin_until(self, condition, timeout, what):
        spin_until(self.spinner, condition, timeout, what)

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        self.spin_until(lambda: time.monotonic() > deadline, seconds + 1.0, "time to pass")

    def spin_until_quiet(self, quiet=0.3, timeout=10.0):
        """Take what is in flight: until nothing arrived for `quiet` [s]."""

        def arrived():
            return len(self.diagnostics) + sum(len(kept) for kept in self.states.values())

        seen, calm_from = arrived(), time.monotonic()

        def calm():
            nonlocal seen, calm_from
            if arrived() != seen:
                seen, calm_from = arrived(), time.monotonic()
            return time.monotonic() - calm_from > quiet

        self.spin_until(calm, timeout, f"{quiet} s without a message")

    def status(self, index=-1) -> dict:
        """An integrator status (default the latest): its values, plus level,
        message and stamp_ns."""
        array = self.diagnostics[index]
        status, stamp = array.status[0], array.header.stamp
        return {
            **topics.diagnostic_values(array),
            "level": status.level,
            "message": status.message,
            "stamp_ns": stamp.sec * 10**9 + stamp.nanosec,
        }

    def wait_for_status(self, condition, timeout, what) -> dict:
        """The first status published from now on that satisfies `condition`."""
        seen = len(self.diagnostics)
        found = []

        def check():
            nonlocal seen
            while seen < len(self.diagnostics) and not found:
                if condition(self.status(seen)):
                    found.append(self.status(seen))
                seen += 1
            return found

        self.spin_until(check, timeout, what)
        return found[0]

    def epoch_ns(self) -> int:
        """The stamp of simulation time 0: every stamp is epoch + simulation time."""
        status = self.status()
        return status["stamp_ns"] - round(float(status["sim_time_s"]) * 1e9)

    def call(self, client, request, timeout=10.0):
        self.spin_until(client.service_is_ready, timeout, f"service {client.srv_name}")
        future = client.call_async(request)
        self.spin_until(future.done, timeout, f"an answer from {client.srv_name}")
        return future.result()

    def wait_for_simulator(self, subscribers=1):
        """Until the simulator publishes and each command publisher has `subscribers`."""
        self.spin_until(
            lambda: self.diagnostics and self.states[topics.BOOM_STATE], 30.0, "the simulator"
        )
        self.spin_until(
            lambda: (
                min(self.deploy.get_subscription_count(), self.trajectory.get_subscription_count())
                >= subscribers
            ),
            10.0,
            f"{subscribers} subscriber(s) of the command topics",
        )


@pytest.fixture
def operator(ros_context):
    """An `Operator` node on the test domain, in a private context."""
    node = Operator(ros_context)
    yield node
    node.spinner.shutdown()
    node.destroy_node()
