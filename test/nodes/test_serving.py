"""`serve_until_stopped`: the executor on a thread of its own, the main thread asleep
until a stop signal; a signal ends it at once, an error in a callback is raised."""

import os
import signal
import time

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from sail_ros.ros import program as ros_program
from sail_ros.ros.program import StopSignals, serve_until_stopped

pytestmark = pytest.mark.node


@pytest.fixture
def served(ros_context, monkeypatch):
    """A node on an executor; the serving threads' longest wait is far beyond the
    test's margins, so only a wake-up can end a wait in time."""
    monkeypatch.setattr(ros_program, "SERVE_WAIT_S", 60.0)
    node = Node("serving_test", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    yield node, executor
    executor.remove_node(node)
    node.destroy_node()
    executor.shutdown()


def test_a_stop_signal_ends_serving_at_once_and_callbacks_run_meanwhile(served):
    node, executor = served
    calls = []

    def callback():
        calls.append(time.monotonic())
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)  # to the process, as a terminal sends it

    node.create_timer(0.05, callback)
    with StopSignals() as stop:
        started = time.monotonic()
        serve_until_stopped(executor, node, stop)
        ended = time.monotonic()
    assert stop.received == "SIGINT" and len(calls) == 3
    assert ended - calls[-1] < 10.0 and ended - started < 20.0  # not the 60 s wait


def test_an_error_in_a_callback_is_raised_by_the_serving_call(served):
    node, executor = served

    def fail():
        raise RuntimeError("broken callback")

    node.create_timer(0.05, fail)
    started = time.monotonic()
    with StopSignals() as stop, pytest.raises(RuntimeError, match="broken callback"):
        serve_until_stopped(executor, node, stop)
    assert time.monotonic() - started < 20.0 and not stop.received
