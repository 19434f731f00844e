"""The integration thread's pacing (`nodes/ticker.py`), on the real steady clock, with
margins wide enough for a busy machine."""

import os
import threading
import time

import pytest
from harness import wait_until

from sail_ros.runtime.ticker import Ticker, following_call

pytestmark = pytest.mark.node


def test_calls_come_every_period_while_active_and_never_after_stop():
    calls, lock = [], threading.RLock()
    ticker = Ticker(lambda: calls.append(time.monotonic()), lock, "test ticker")
    time.sleep(0.05)
    assert not calls  # inactive until set
    started = time.monotonic()
    ticker.set(0.01, True)
    wait_until(lambda: len(calls) >= 10, 5.0, "ten calls", step=0.001)
    ticker.set(0.01, False)
    count = len(calls)
    assert count <= (time.monotonic() - started) / 0.01 + 1  # none faster than the period
    time.sleep(0.05)
    assert len(calls) == count  # inactive: no call
    with lock:  # a call holds the lock: none runs while it is held here
        ticker.set(0.0, True)  # back to back
        held = len(calls)
        time.sleep(0.05)
        assert len(calls) == held
    wait_until(lambda: len(calls) > held, 5.0, "a call once the lock is free", step=0.001)
    ticker.stop()
    stopped = len(calls)
    time.sleep(0.05)
    assert len(calls) == stopped


def test_a_late_call_is_made_at_once_and_the_missed_ones_skipped():
    assert following_call(1.00, 1.003, 0.01) == pytest.approx(1.01)  # on time: one period on
    assert following_call(1.00, 1.012, 0.01) == pytest.approx(1.01)  # late: due, at once
    # 5.5 periods late: the latest missed time in phase, at once; the four before it skipped
    assert following_call(1.00, 1.055, 0.01) == pytest.approx(1.05)
    assert following_call(1.05, 1.0551, 0.01) == pytest.approx(1.06)  # then in phase again


def _policy(name: str) -> tuple[int, int]:
    """(scheduling policy, priority) of the one live thread called `name`."""
    (thread,) = [t for t in threading.enumerate() if t.name == name]
    return os.sched_getscheduler(thread.native_id), os.sched_getparam(thread.native_id)[0]


def test_make_realtime_schedules_the_thread_first_in_first_out_or_leaves_it_as_it_was():
    calls, lock = [], threading.RLock()
    ticker = Ticker(lambda: calls.append(time.monotonic()), lock, "test realtime ticker")
    try:
        assert _policy("test realtime ticker") == (os.SCHED_OTHER, 0)
        try:
            ticker.make_realtime(10)
        except PermissionError:  # no CAP_SYS_NICE, no rtprio limit: nothing changed
            assert _policy("test realtime ticker") == (os.SCHED_OTHER, 0)
        else:
            assert _policy("test realtime ticker") == (os.SCHED_FIFO, 10)
            assert os.sched_getscheduler(0) == os.SCHED_OTHER  # this thread is not
        ticker.set(0.01, True)
        time.sleep(0.2)
        assert len(calls) >= 5
    finally:
        ticker.stop()
