"""What the tests share: the test run's DDS domain, paths, a spin loop, tool processes,
the operator node that drives a simulator, in-process tool runs and figure checks.

Importing it (conftest does, first) puts this run on one private DDS domain, on loopback
only, before any rclpy context exists: the variables reach this process and the
processes the tests start, and nothing of the run leaves the machine or meets another
run; its participants announce themselves as often as the tools' do (`ros.discovery`).
A test that needs a second domain leases one (`spare_domain`, the same lease the tools
take, `tools.domains.DomainLease`).
"""

from __future__ import annotations

import contextlib
import fcntl
import importlib
import io
import os
import subprocess
import sys
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from matplotlib.image import imread
from rcl_interfaces.srv import SetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from sail_ros import status as key
from sail_ros import topics
from sail_ros.cli import TOOLS
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.model import SailParameters
from sail_ros.ros.commanding import command_publisher
from sail_ros.ros.discovery import CLIENT_PROFILE, announce_often
from sail_ros.tools.domains import FIRST_DOMAIN, DomainLease, bound_udp_ports, domain_in_use

ROOT = Path(__file__).resolve().parents[1]  # the repository
# Small mode counts for the tests whose subject is not the model's convergence (the
# defaults, several hundred coordinates, are tested where it is: test_continuum.py)
SMALL_MODES = {"n_boom_modes": 4, "n_membrane_modes": 6}
SMALL = SailParameters(**SMALL_MODES)
SMALL_SET = ("--set", "n_boom_modes=4", "--set", "n_membrane_modes=6")  # a tool's options
SMALL_ROS = ("-p", "sail.n_boom_modes:=4", "-p", "sail.n_membrane_modes:=6")  # the simulator's
SMALL_SIM = {f"sail.{name}": value for name, value in SMALL_MODES.items()}  # its parameters
CONFIG = ROOT / "config"
JS = ROOT / "test" / "js"  # Foxglove's JavaScript readers and clients (npm, lockfile)
NODE_MAJOR = 20  # the oldest node they are run with


# The process that chose the session's domain: pytest itself, or one of its xdist workers
# (gw0, gw1, ...), each of which runs its tests on a domain of its own. Processes a test
# starts inherit both variables, so they keep their test's domain.
_RUNNER = os.environ.get("PYTEST_XDIST_WORKER", "main")
_DOMAIN_LOCKS = Path(tempfile.gettempdir()) / "sail_ros_test_domains"


def _session_domain() -> int:
    """One domain for this test run (or xdist worker), below the tools' leases
    (`DomainLease` takes 100 and up), with no participant on this machine and not held by
    another run (a lock file held for the run's life); inherited by processes that import
    this module (helper scripts) through SAIL_ROS_TEST_DOMAIN_ID."""
    chosen = os.environ.get("SAIL_ROS_TEST_DOMAIN_ID")
    if chosen and os.environ.get("SAIL_ROS_TEST_DOMAIN_RUNNER") == _RUNNER:
        return int(chosen)
    _DOMAIN_LOCKS.mkdir(exist_ok=True)
    ports, span = bound_udp_ports(), FIRST_DOMAIN - 1
    for offset in range(span):
        domain = 1 + (os.getpid() + offset) % span
        if domain_in_use(domain, ports):
            continue
        lock = open(_DOMAIN_LOCKS / f"{domain}.lock", "a")  # noqa: SIM115 (held for the run)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        _HELD.append(lock)
        return domain
    raise RuntimeError(f"no free DDS domain in 1..{span} on this machine")


_HELD: list = []  # the lock of this run's domain, released when the process ends
DOMAIN_ID = _session_domain()
os.environ["SAIL_ROS_TEST_DOMAIN_ID"] = str(DOMAIN_ID)
os.environ["SAIL_ROS_TEST_DOMAIN_RUNNER"] = _RUNNER
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN_ID)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
# the test process's own participants (the tools' mains called in it, operators) are
# clients; the processes a test starts choose their own profile (`conftest.ros_env`)
announce_often(profile=CLIENT_PROFILE)
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
_SCRATCH = Path(tempfile.mkdtemp(prefix="sail_ros_test_"))
os.environ.setdefault("HOME", str(_SCRATCH))
os.environ.setdefault("ROS_LOG_DIR", str(_SCRATCH / "ros_log"))


def spare_domain() -> DomainLease:
    """A lease of a second domain, free on this machine, used as a context manager that
    gives the domain's id and holds it until the block ends: keep the block open until
    the processes on that domain have started."""
    return DomainLease()


def wait_until(
    condition, timeout: float, what: str, *, executor=None, step=0.01, between=None, running=()
) -> None:
    """Until `condition()` holds; between two checks spin `executor` for up to `step` [s],
    or call `between()`, or else sleep `step` [s]. Fails naming `what` after `timeout`
    [s], or at once when one of the `running` tools (`Tool`) has exited. The tests' one
    wait."""
    deadline = time.monotonic() + timeout
    while not condition():
        for tool in running:
            if tool.process.poll() is not None:
                pytest.fail(f"{tool.log_path.stem} exited while waiting for {what}:\n{tool.log()}")
        assert time.monotonic() < deadline, f"timed out after {timeout} s waiting for {what}"
        if executor is not None:
            executor.spin_once(timeout_sec=step)
        elif between is not None:
            between()
        else:
            time.sleep(step)


class Serving:
    """An executor of `context` serving the nodes a test makes (`add`); `close` removes and
    destroys them and shuts it down."""

    def __init__(self, context, step: float = 0.01):
        self.executor = SingleThreadedExecutor(context=context)
        self.step = step  # [s] of spinning between two checks of `spin_until`
        self._nodes = []

    def add(self, *nodes) -> None:
        for node in nodes:
            self.executor.add_node(node)
            self._nodes.append(node)

    def spin_until(self, condition, timeout: float, what: str) -> None:
        wait_until(condition, timeout, what, executor=self.executor, step=self.step)

    def close(self) -> None:
        for node in self._nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()


@contextlib.contextmanager
def private_context(domain_id: int | None = None):
    """A private rclpy context on `domain_id` (the test's domain by default), shut down at
    the end: the one place the tests make a context (the `ros_context` fixture, the
    module-wide listeners, a second participant)."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID if domain_id is None else domain_id)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


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

    def wait_for_lines(self, lines, timeout: float = 20.0) -> None:
        """Until the log holds each of `lines`, and a little more (DDS matches the
        subscriptions a recorder announces within milliseconds)."""
        deadline = time.monotonic() + timeout
        while not all(line in self.log() for line in lines):
            assert self.process.poll() is None and time.monotonic() < deadline, self.log()
            time.sleep(0.05)
        time.sleep(0.2)


def ros_value(value) -> str:
    """A parameter value for `-p name:=value`."""
    if isinstance(value, list):
        return "[" + ",".join(map(repr, value)) + "]"
    return repr(value)


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
        self.deploy = command_publisher(self, topics.DEPLOY_CMD)
        self.trajectory = command_publisher(self, topics.BOOM_LENGTH_CMD)
        self.reset = self.create_client(Trigger, topics.RESET_SERVICE)
        self.pause = self.create_client(SetBool, topics.PAUSE_SERVICE)
        self.set_parameters = self.create_client(SetParameters, "/sail_sim/set_parameters")

    def _on_status(self, message: DiagnosticArray, info) -> None:
        # DDS's source timestamp: when the simulator published, however late this
        # process takes the sample
        self.diagnostics.append(message)
        self.published_ns.append(info["source_timestamp"])

    def spin_until(self, condition, timeout, what):
        wait_until(condition, timeout, what, executor=self.spinner)

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
            **diagnostics_msg.diagnostic_values(array),
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
        return status["stamp_ns"] - round(float(status[key.SIM_TIME]) * 1e9)

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


# -- offline tools in this process, and their figures ------------------------------------


def run_tool(name: str, argv: list[str]) -> tuple[int, str, str]:
    module_name, function_name = TOOLS[name].split(":")
    main = getattr(importlib.import_module(module_name), function_name)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exit_:  # argparse
            code = exit_.code
    return code, out.getvalue(), err.getvalue()


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def assert_png(path, min_width=400, min_height=250, min_drawn=0.03):
    """A real PNG of page-figure size whose pixels are not one flat colour and
    not (almost) all background (at least `min_drawn` of them drawn)."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert len(data) > 10_000, f"{path} is suspiciously small ({len(data)} bytes)"
    pixels = imread(path)[..., :3]
    height, width = pixels.shape[:2]
    assert width >= min_width and height >= min_height, f"{path}: {width}x{height} px"
    assert pixels.std() > 0.05, f"{path} is (nearly) blank"
    drawn = np.mean(np.any(pixels < 0.9, axis=-1))  # not white background
    assert drawn > min_drawn, f"{path}: only {drawn:.1%} of the pixels are drawn"
    return width, height


def assert_figure(path, checks, min_width=400, min_height=250, min_drawn=0.03):
    """`assert_png`, and the figure as drawn (`figure_checks`): no text or panel
    outside it, no text over text or over another panel, no curve drawn twice, no
    line hidden under another, no data under the legend or an annotation, no
    vertical stroke in a line drawn against x, a unit on every axis that shows
    values. Returns its FigureCheck."""
    size = assert_png(Path(path), min_width, min_height, min_drawn)
    check = checks[Path(path)]
    assert check.size_px == size
    assert not check.clipped, f"{path}: outside the figure: {check.clipped}"
    assert not check.overlaps, f"{path}: drawn over each other: {check.overlaps}"
    assert not check.duplicates, f"{path}: one curve drawn as two lines: {check.duplicates}"
    assert not check.hidden, f"{path}: lines hidden under others: {check.hidden}"
    assert not check.jumps, f"{path}: vertical strokes: {check.jumps}"
    assert not check.covered, f"{path}: data under a text: {check.covered}"
    assert not check.unitless, f"{path}: axes without a unit: {check.unitless}"
    return check
