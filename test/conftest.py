"""Shared fixtures and the suite's rules: tiers by folder, the slow trials, wall times.

The tests live by tier, one folder each, every module marked with its tier:

- `test/model/` (`model`): the model alone, against closed forms (seconds);
- `test/runtime/` (`model`): the simulator without ROS: command planning, the stepping
  core, pacing, the real-time run on an injected clock;
- `test/bag/` (`model`): the message builders, their CDR bytes and the recording, read
  back by independent readers;
- `test/tools/` (`model`, and `lint`): the offline tools, the bag format, the docs,
  the layout and the launch file, in this process;
- `test/nodes/` (`node`): nodes in this process, each test with a private rclpy context;
- `test/system/` (`multiprocess`): the tools as separate processes over real DDS.

`pytest -m model` runs the first four in about a minute. A test marked `slow` is the full
size of a trial the suite runs CI-sized: it runs only with `--slow` (scripts/stress.sh).
The test command runs three tests at a time (pytest-xdist, `-n 3`, a module on one worker
when its tests share a module fixture, any other test wherever a worker is free); a
test marked `timing` asserts wall-clock behaviour (real-time factor, overruns), so it
runs while no other test that keeps pace with the wall clock does (a node or
multi-process test): it holds a lock exclusively that those hold shared, from before
their fixtures are set up until they are torn down. The in-process tiers' tests (work
alone, no wall-clock pace) take no lock and run beside it at the lowest CPU priority.
What the tests share besides fixtures is in `harness.py` (imported first: it puts the
run on its private DDS domain).
"""

from __future__ import annotations

import collections
import contextlib
import fcntl
import hashlib
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest
from harness import JS, NODE_MAJOR, Operator, Tool, private_context, ros_value

from sail_ros.ros.discovery import CLIENT_PROFILE, PROFILE

TIERS = ("model", "node", "multiprocess", "lint")
IN_PROCESS_TIERS = ("model", "lint")  # work alone: no process keeps pace with the wall clock
FOLDER_TIERS = {
    "model": ("model",),
    "runtime": ("model",),
    "bag": ("model",),
    "tools": ("model", "lint"),
    "nodes": ("node",),
    "system": ("multiprocess",),
}


def pytest_addoption(parser):
    parser.addoption(
        "--slow", action="store_true", help="run the full-size trials too (scripts/stress.sh)"
    )


def _module_fixture_user(item) -> bool:
    """True if the test uses a fixture of module scope (made once per module and worker)."""
    definitions = item._fixtureinfo.name2fixturedefs  # pytest's record of the test's fixtures
    return any(d.scope == "module" for name in item.fixturenames for d in definitions.get(name, ()))


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups (--dist loadgroup)
def pytest_collection_modifyitems(config, items):
    """Every test belongs to exactly one tier, the one of its folder; `slow` trials are
    deselected unless --slow. With xdist, a module whose tests share a module fixture runs
    on one worker (an xdist group), any other test wherever a worker is free."""
    kept, slow = [], []
    for item in items:
        if item.get_closest_marker("timing") is not None:
            item.add_marker(pytest.mark.xdist_group("timing"))
        elif _module_fixture_user(item):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))
        tiers = [name for name in TIERS if item.get_closest_marker(name)]
        if len(tiers) != 1:
            raise pytest.UsageError(f"{item.nodeid}: needs exactly one of {TIERS}, has {tiers}")
        folder = Path(item.fspath).parent.name
        if tiers[0] not in FOLDER_TIERS.get(folder, ()):
            raise pytest.UsageError(
                f"{item.nodeid}: tier {tiers[0]} in test/{folder}/ (tiers by folder: "
                f"{FOLDER_TIERS})"
            )
        item.user_properties.append(("tier", tiers[0]))
        is_slow = item.get_closest_marker("slow") is not None
        (slow if is_slow and not config.getoption("--slow") else kept).append(item)
    if slow:
        config.hook.pytest_deselected(items=slow)
    sizes = collections.Counter(_group(item) for item in kept)
    kept.sort(key=lambda item: _scheduling_order(item, sizes))
    items[:] = kept


def _group(item) -> str | None:
    marker = item.get_closest_marker("xdist_group")
    return None if marker is None else marker.args[0]


def _scheduling_order(item, sizes: dict) -> tuple[bool, bool, int]:
    """The order xdist hands the tests out in (`pytest_configure`): the timing tests first,
    so that the worker that runs them does so before any other test lowers its priority
    (`pytest_runtest_setup`); then the in-process tiers' groups (a docs build, a module
    of model runs), which the other workers run beside the timing tests; then the rest,
    the groups with the most tests first (xdist's own order)."""
    group = _group(item)
    beside_timing = group is not None and _tier(item) in IN_PROCESS_TIERS
    size = 1 if group is None else sizes[group]
    return group != "timing", not beside_timing, -size


def pytest_configure(config):
    """The tests go out to the xdist workers in their collection order
    (`_scheduling_order`): xdist's own reordering of the groups by size would put the
    timing tests after the bigger groups."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_finish(session):
    """On an xdist worker with --dist loadgroup: every grouped test carries its group in
    its node id, which is how xdist tells its scheduler (pytest 9.2 ignores that, and the
    groups silently fall apart: pytest-xdist#1386; constraints.txt pins 9.1)."""
    if not (os.environ.get("PYTEST_XDIST_WORKER") and session.config.getvalue("loadgroup")):
        return
    lost = [
        item.nodeid
        for item in session.items
        if item.get_closest_marker("xdist_group") is not None and "@" not in item.nodeid
    ]
    if lost:
        raise pytest.UsageError(f"xdist ignores the test groups, e.g. {lost[0]}")


_TIER_SECONDS: dict[str, float] = {}
_STARTED = time.monotonic()


def pytest_runtest_logreport(report):
    """Wall time per tier: setup, call and teardown of its tests."""
    tier = dict(report.user_properties).get("tier")
    if tier is not None:
        _TIER_SECONDS[tier] = _TIER_SECONDS.get(tier, 0.0) + report.duration


def pytest_terminal_summary(terminalreporter, config):
    """The suite's wall time, and the time of each tier's tests (summed over the tests
    run at once), printed by the test command (the README's suite budget is 240 s on 2
    cores)."""
    tiers = ", ".join(
        f"{tier} {_TIER_SECONDS[tier]:.0f} s" for tier in TIERS if tier in _TIER_SECONDS
    )
    workers = getattr(config.option, "numprocesses", None) or 1
    terminalreporter.write_line(
        f"suite wall time {time.monotonic() - _STARTED:.0f} s on {os.cpu_count()} cores, "
        f"{workers} test(s) at a time (test time by tier: {tiers})"
    )


class _TimingLock:
    """Between xdist workers, a lock file of this run's temporary root: every node and
    multi-process test holds it shared while it runs, `timing` tests exclusively; one
    worker runs those one after another (an xdist group, first in the order) and keeps the
    lock from the first to its next other test. A worker takes the lock through a gate (a
    second file, held exclusively while it waits): flock favours neither mode, and
    without the gate the other workers' tests, each taking the lock shared as the last
    lets go, could keep a timing test waiting for the whole run."""

    def __init__(self):
        self._file = self._gate = None
        self._mode = None

    def hold(self, path: Path, mode: int) -> None:
        if self._mode == mode:
            return
        if self._file is None:
            self._file = path.open("a")  # noqa: SIM115 (held across tests)
            self._gate = path.with_suffix(".gate").open("a")  # noqa: SIM115
        fcntl.flock(self._file, fcntl.LOCK_UN)  # never held while waiting at the gate
        fcntl.flock(self._gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(self._file, mode)
        finally:
            fcntl.flock(self._gate, fcntl.LOCK_UN)
        self._mode = mode

    def unlock(self) -> None:
        if self._file is not None:
            fcntl.flock(self._file, fcntl.LOCK_UN)
            self._mode = None

    def release(self) -> None:
        if self._file is not None:
            fcntl.flock(self._file, fcntl.LOCK_UN)
            self._file.close()
            self._gate.close()
            self._file = self._gate = self._mode = None


_TIMING_LOCK = _TimingLock()


class _Priority:
    """This worker's CPU priority: every thread of the process (and so every thread and
    process it starts from then on) at the lowest, `nice` 19. Linux gives each thread
    its own nice value, so each is set (`setpriority` of the process sets only the
    calling thread's); a priority once lowered cannot be raised without privileges. A
    process a test starts stays in the suite's session: Linux schedules a new session as a
    group of its own (autogroup), beside the suite's whatever its priority."""

    LOWEST = 19

    def __init__(self):
        self.lowered = False

    def lower(self) -> None:
        if self.lowered:
            return
        for thread in os.listdir("/proc/self/task"):
            with contextlib.suppress(ProcessLookupError):  # a thread that has just ended
                os.setpriority(os.PRIO_PROCESS, int(thread), self.LOWEST)
        self.lowered = True


_PRIORITY = _Priority()


def _tier(item) -> str | None:
    return dict(item.user_properties).get("tier")


def _timing(item) -> bool | None:
    """Whether `item` is a `timing` test; None outside an xdist worker (no lock)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return None
    return item.get_closest_marker("timing") is not None


def _lock_mode(item) -> int | None:
    """How `item` holds the lock (`_TimingLock`): exclusively (a timing test), shared (a
    node or multi-process test), or not at all (an in-process test; outside xdist)."""
    timing = _timing(item)
    if timing is None or (not timing and _tier(item) in IN_PROCESS_TIERS):
        return None
    return fcntl.LOCK_EX if timing else fcntl.LOCK_SH


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_setup(item):
    """A `timing` test runs at its worker's own CPU priority, while no node or
    multi-process test runs on another worker (see _TimingLock): the lock is taken before
    the test's fixtures are set up, a module's too (they are set up with its first test:
    a recorded log would otherwise be made beside a timing test). Every other test first
    lowers its worker's priority: an in-process one (the `model` tier: a docs build, model
    runs) then runs beside the timing tests without the lock, on the cores they leave."""
    timing = _timing(item)
    if timing:
        if _PRIORITY.lowered:
            pytest.fail(
                f"{item.nodeid}: a timing test after another test on this worker, whose "
                "CPU priority is lowered (the timing tests come first on one worker with "
                "--dist loadgroup, as scripts/test.sh runs them)",
                pytrace=False,
            )
    elif timing is not None:
        _PRIORITY.lower()
    mode = _lock_mode(item)
    if mode is not None:
        # one per run: xdist gives each worker a temporary folder in the run's own
        path = Path(item.config.option.basetemp).parent / "timing.lock"
        _TIMING_LOCK.hold(path, mode)
    return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """The lock is let go once the test's fixtures are torn down, a module's too (with its
    last test), so a timing test of another worker can come in between two others."""
    try:
        return (yield)
    finally:
        if _lock_mode(item) == fcntl.LOCK_SH:
            _TIMING_LOCK.unlock()


def pytest_sessionfinish(session):
    _TIMING_LOCK.release()


@pytest.fixture(scope="session")
def ros_env(tmp_path_factory) -> dict[str, str]:
    """Environment of the processes a test starts: the private domain, localhost, a
    private home and log folder, unbuffered output; a process stopped by SIGABRT prints
    every thread's Python stack (faulthandler), so a hang names where it hangs."""
    home = tmp_path_factory.mktemp("home")
    environ = dict(os.environ)
    # each process picks its own Fast DDS profile, as it does outside the tests (a
    # profile file of the user's stays)
    if environ.get("FASTRTPS_DEFAULT_PROFILES_FILE") in (str(PROFILE), str(CLIENT_PROFILE)):
        del environ["FASTRTPS_DEFAULT_PROFILES_FILE"]
    return dict(
        environ,
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
    with private_context() as context:
        yield context


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


@pytest.fixture
def operator(ros_context):
    """An `Operator` node on the test domain, in a private context."""
    node = Operator(ros_context)
    yield node
    node.spinner.shutdown()
    node.destroy_node()


@pytest.fixture(scope="module")
def js_readers() -> Path:
    """The node command (version 20 or newer), with the JavaScript readers installed
    from the lockfile; a failure, not a skip, without them."""
    node = shutil.which("node")
    if node is None:
        pytest.fail(
            f"node is not installed: this test decodes the logs with Foxglove's JavaScript "
            f"readers; install Node.js {NODE_MAJOR} (or newer) and npm, then run scripts/test.sh"
        )
    version = subprocess.run([node, "--version"], capture_output=True, text=True).stdout.strip()
    major = int(version.lstrip("v").split(".")[0]) if version.startswith("v") else 0
    if major < NODE_MAJOR:
        pytest.fail(f"node {version or '(no version)'} is too old: install Node.js {NODE_MAJOR}")
    lock = hashlib.sha256((JS / "package-lock.json").read_bytes()).hexdigest()
    stamp = JS / "node_modules" / ".installed"
    if not stamp.is_file() or stamp.read_text().strip() != lock:
        pytest.fail(
            f"{JS / 'node_modules'} is missing or not installed from package-lock.json: run "
            "scripts/test.sh (it runs `npm ci` there; needs npm)"
        )
    return Path(node)
