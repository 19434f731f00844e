"""Running a ROS program from a tool `main`: command line, stop signals, rclpy's lifetime.

Shared by the nodes and by the tools that talk to them (`send`, `watch`).
ROS arguments (`--ros-args -r __ns:=/sat2 -p name:=value --params-file f.yaml
...`) work as usual; a tool's own options win over them.
"""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import importlib
import re
import select
import signal
import socket
import sys
import threading

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.logging import get_logger
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from sail_ros.early_signals import RECEIVED as EARLY_SIGNALS
from sail_ros.model import yaml_values
from sail_ros.model.fields import ConfigError
from sail_ros.options import parse_arguments
from sail_ros.ros.discovery import announce_often
from sail_ros.spelling import nearest


def read_params_files(ros_argv: list[str]) -> list[tuple[str, list[str]]]:
    """`(path, sections)` of every `--params-file` in `ros_argv`, read and checked: the
    file's node sections, nested namespaces joined as rcl joins them (`/sat2:
    sail_sim: ros__parameters:` is the section `/sat2/sail_sim`).

    Raises:
        ConfigError: a file cannot be read, or is not a params file (one line naming it).
    """
    files = [ros_argv[i + 1] for i, item in enumerate(ros_argv[:-1]) if item == "--params-file"]
    read = []
    for path in files:
        try:
            with open(path) as stream:
                document = yaml_values.load(stream)
        except OSError as error:
            raise ConfigError(f"--params-file {path}: {error.strerror}") from None
        except UnicodeDecodeError as error:
            raise ConfigError(f"--params-file {path}: {yaml_values.not_text(error)}") from None
        except yaml.YAMLError as error:
            raise ConfigError(f"--params-file {path}: {yaml_values.describe(error)}") from None
        try:
            sections = yaml_values.checked_sections(document, f"--params-file {path}")
        except ValueError as error:
            raise ConfigError(str(error)) from None
        if not sections:
            raise ConfigError(
                f"--params-file {path}: expected '<node>: ros__parameters: ...' sections"
            )
        read.append((path, list(sections)))
    return read


def check_params_files(files: list[tuple[str, list[str]]], node_name: str) -> None:
    """Every params file (`read_params_files`) must hold a section for `node_name` (or a
    wildcard): a misspelt section (`sail_simm:`) would otherwise be skipped without a
    word.

    Raises:
        ConfigError: a file has no section for the node (the message names the
            sections and the closest one).
    """
    for path, sections in files:
        if not any(yaml_values.section_applies(section, node_name) for section in sections):
            close = nearest(node_name, sections)
            hint = f"; did you mean {node_name!r} for {close!r}?" if close else ""
            raise ConfigError(
                f"--params-file {path} has no section for node {node_name!r} (it has "
                f"{', '.join(map(repr, sections))}{hint})"
            )


def parse_command_line(
    parser: argparse.ArgumentParser, prog: str, argv: list[str], node_name: str | None = None
):
    """Parse the non-ROS part of `argv`; returns (namespace, args for rclpy.init). The
    `--params-file`s are read first (rcl would say only that it could not parse one)
    and, for a node (`node_name`), must each hold a section for it.

    Raises:
        SystemExit: --help, or a bad option (argparse prints the message).
    """
    ros_argv = [prog, *argv]
    try:
        files = read_params_files(ros_argv)
        if node_name is not None:
            check_params_files(files, node_name)
        own_args = remove_ros_args(ros_argv)[1:]
    except ConfigError as error:
        parser.error(str(error))
    except _rclpy.UnknownROSArgsError as error:  # e.g. a tool option after --ros-args
        parser.error(f"invalid ROS arguments: {error} (options of the tool go before --ros-args)")
    except _rclpy.RCLInvalidROSArgsError as error:
        # rcl's text less the places in its own sources (", at /.../arguments.c:352")
        text = _RCL_SOURCE_PLACE.sub("", str(error)).removeprefix("Failed to parse ROS arguments: ")
        parser.error(f"invalid ROS arguments: {text}")
    return parse_arguments(parser, own_args), ros_argv


_RCL_SOURCE_PLACE = re.compile(r", at /\S+:\d+")


class StopSignals:
    """While active, SIGINT and SIGTERM set `event` instead of raising.

    Use with `rclpy.init(..., signal_handler_options=SignalHandlerOptions.NO)`
    so that the tool, not rclpy, decides how to shut down (drain, close files).
    `wait` sleeps until a signal comes, without polling: the signal's C handler
    writes to a socket the main thread waits on (`signal.set_wakeup_fd`).
    """

    def __init__(self):
        self.event = threading.Event()
        self.received: str | None = None
        self._previous = {}
        self._wakeup: socket.socket | None = None  # read end, while active
        self._writer: socket.socket | None = None

    def __enter__(self) -> StopSignals:
        self._wakeup, writer = socket.socketpair()
        for end in (self._wakeup, writer):
            end.setblocking(False)
        self._writer = writer
        self._previous_wakeup_fd = signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._previous[signum] = signal.signal(signum, self._handle)
        if EARLY_SIGNALS:  # came while the program was starting
            self.received = EARLY_SIGNALS[0]
            self.event.set()
        return self

    def __exit__(self, *exc_info) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        signal.set_wakeup_fd(self._previous_wakeup_fd)
        self._wakeup.close()
        self._writer.close()
        self._wakeup = self._writer = None

    def wait(self, timeout: float) -> bool:
        """Sleep until a stop signal or for `timeout` [s] (main thread); whether one came."""
        if self._wakeup is None:  # not active: only `event` can say stop
            return self.event.wait(timeout)
        if not self.event.is_set():
            ready, _, _ = select.select([self._wakeup], [], [], timeout)
            if ready:
                with contextlib.suppress(BlockingIOError):
                    while self._wakeup.recv(64):
                        pass
        return self.event.is_set()

    def wake(self) -> None:
        """End a `wait` under way at once, without a stop (from any thread)."""
        if self._writer is not None:
            with contextlib.suppress(OSError):
                self._writer.send(b"\0")

    def _handle(self, signum, frame) -> None:
        self.received = signal.Signals(signum).name
        self.event.set()


TEARDOWN_LIMIT_S = 10.0  # a node's DDS teardown takes milliseconds; this long, it is stuck


@contextlib.contextmanager
def bounded_teardown(limit_s: float | None = None):
    """Within: destroying nodes and contexts, after the program's work is done. If
    that takes longer than `limit_s` [s], the process ends (exit code 1, with every
    thread's stack on standard error).

    Fast DDS 2.14 can deadlock while it removes a process's participant if other
    participants leave at the same moment (its discovery callbacks wait on a lock,
    the removal waits for them, spinning): the process would spin at 100 % of a
    core for ever, and it holds the interpreter's lock, so the watchdog is
    faulthandler's, which runs without it. It writes to the process's standard error
    where `sys.stderr` is not a file (a tool's `main` called with its output captured)."""
    arm_teardown_limit(limit_s)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def arm_teardown_limit(limit_s: float | None = None) -> None:
    """From now on, end the process (exit code 1, every thread's stack on standard error)
    unless `faulthandler.cancel_dump_traceback_later` comes within `limit_s` [s] (default
    `TEARDOWN_LIMIT_S`): `bounded_teardown` where the teardown has no block of its own."""
    limit_s = TEARDOWN_LIMIT_S if limit_s is None else limit_s
    try:
        sys.stderr.fileno()
        stream = sys.stderr
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is an OSError
        stream = sys.__stderr__
    faulthandler.dump_traceback_later(limit_s, exit=True, file=stream)


SERVE_WAIT_S = 1.0  # the longest wait of `serve_until_stopped`'s two threads [s]


def serve_until_stopped(executor, node, stop: StopSignals, failed=None) -> None:
    """Run `executor`'s callbacks (it serves `node`) on a thread of its own until a stop
    signal, until rclpy is shut down, or until the event `failed` is set (another of the
    program's threads cannot go on; it should `stop.wake()` or wait up to SERVE_WAIT_S);
    an error in a callback is raised here.

    The main thread sleeps meanwhile (`StopSignals.wait`): spinning there with a short
    timeout, only to notice a signal, would wake the process ten times a second and
    compete with the node's own threads for the interpreter."""
    failures = []
    stopping = threading.Event()
    finished = threading.Event()  # set before the wake-up, so the main thread sees it
    # ends the thread's wait at once (`executor.wake` would not end a `spin_once`)
    wake = node.create_guard_condition(lambda: None)

    def serve() -> None:
        try:
            while not stopping.is_set():
                executor.spin_once(timeout_sec=SERVE_WAIT_S)
        except ExternalShutdownException:
            pass
        except BaseException as error:  # handed to the main thread
            failures.append(error)
        finally:
            finished.set()
            stop.wake()

    thread = threading.Thread(target=serve, name="executor", daemon=True)
    thread.start()
    try:
        while (
            not finished.is_set()
            and not stop.wait(SERVE_WAIT_S)
            and not (failed is not None and failed.is_set())
        ):
            pass
    finally:
        stopping.set()
        wake.trigger()
        thread.join()
        node.destroy_guard_condition(wake)
    if failures:
        raise failures[0]


def run_node(name: str, parser: argparse.ArgumentParser, argv: list[str], body) -> int:
    """A node tool's `main`: the exit code of `body(namespace, stop)`.

    Parses `argv` (tool options, then `--ros-args ...`; `--help` or a bad option
    ends here), holds SIGINT/SIGTERM in `stop` (a `StopSignals`), starts rclpy
    without its own signal handlers and shuts it down at the end. A
    `ConfigError` (a parameter the node cannot use) is logged and gives exit 2.
    """
    try:
        namespace, ros_argv = parse_command_line(parser, name, argv, node_name=name)
    except SystemExit as exit_:
        return exit_.code if isinstance(exit_.code, int) else 2
    with StopSignals() as stop:
        announce_often()
        rclpy.init(args=ros_argv, signal_handler_options=SignalHandlerOptions.NO)
        try:
            return body(namespace, stop)
        except ConfigError as error:
            get_logger(name).error(str(error))
            # the node `body` was building goes with this traceback as the block ends:
            # its participant's teardown (Fast DDS can deadlock there) is bounded too
            arm_teardown_limit()
            return 2
        finally:
            with bounded_teardown():
                rclpy.try_shutdown()


def message_class(type_name: str):
    """The Python class of the message type `pkg/msg/Type`.

    Raises:
        ImportError: the package's Python module is not installed.
        ValueError: `type_name` is not of that form.
    """
    parts = type_name.split("/")
    if len(parts) != 3:
        raise ValueError(f"type name must look like 'pkg/msg/Type', got {type_name!r}")
    package, namespace, name = parts
    try:
        return getattr(importlib.import_module(f"{package}.{namespace}"), name)
    except AttributeError:
        raise ImportError(f"{package}.{namespace} has no {name}") from None
