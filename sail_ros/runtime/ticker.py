"""A periodic call on a thread of its own, paced by the steady clock.

The simulator's ticks (up to 200 per second) and its diagnostics run here rather
than as rclpy timers: each wake-up of rclpy's executor rebuilds a wait set of
the node's timers, services and publisher event handlers, about 1 ms of a core,
10 % at 100 Hz. A thread waiting on a lock wakes for less: ~100 us on a virtual
machine whose idle cores are halted (an `Event`, a condition with locks of its
own, costs twice that). The executor runs the rest (commands, services,
parameters), so both threads take the same lock around the simulation.

How late a call comes is up to the operating system: on a busy machine a
normally scheduled thread that wakes may wait milliseconds for a core.
`make_realtime` puts the thread on first-in first-out real-time scheduling,
so that it runs as soon as it wakes, ahead of every normally scheduled thread.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time

AFAP_PAUSE_S = 1e-4  # between back-to-back ticks: lets the executor's callbacks have the lock


class Ticker:
    """Calls `work()` with `lock` held every `period` [s] of the steady clock while
    active (back to back for period 0), like an rclpy timer: the first call one period
    after it becomes active; a late call is made at once, calls missed before it are
    skipped, not bunched.

    A call that raises ends the calls: the error is kept in `failure` and handed to
    `on_failure` (a program that cannot go on should say so and end, not carry on
    without its periodic work).

    Args:
        work: the callable.
        lock: held around each call (an `RLock`, so that `work` may take it too).
        name: the thread's name.
        on_failure: called with the exception if `work` raises (from the thread).
    """

    def __init__(self, work, lock, name: str, on_failure=None):
        self._work = work
        self._lock = lock
        self._on_failure = on_failure
        self.failure: BaseException | None = None
        self._period = 0.0
        self._active = False
        self._stopping = False
        self._restart = False  # set by `set`, read by the thread: before it starts
        self._poked = False  # set by `poke`: one call at once, the schedule unchanged
        # a change wakes the thread by releasing this lock, which the thread takes
        self._changed = threading.Lock()
        self._changed.acquire()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def set(self, period: float, active: bool) -> None:
        """Tick every `period` [s] (>= 0) from now on if `active`, else not at all; a
        change of activity restarts the period."""
        restart = active != self._active
        self._period, self._active = float(period), bool(active)
        if restart or active:
            self._restart = restart
            self._wake()

    def poke(self) -> None:
        """One call as soon as possible, active or not, without changing the schedule
        (e.g. a command arrived while the periodic calls are far apart)."""
        self._poked = True
        self._wake()

    def make_realtime(self, priority: int) -> None:
        """Schedule the thread first-in first-out at `priority` (1-99; Linux's
        SCHED_FIFO, as ros2_control's controller manager schedules its loop). Such a
        thread yields its core only by waiting, so a period shorter than the calls take
        would starve every normally scheduled thread on that core.

        Raises:
            OSError: the system refuses (PermissionError without CAP_SYS_NICE or an
                rtprio limit, `ulimit -r`, of at least `priority`); the scheduling is
                unchanged.
        """
        if not hasattr(os, "SCHED_FIFO"):
            raise OSError("this system has no SCHED_FIFO scheduling")
        os.sched_setscheduler(self._thread.native_id, os.SCHED_FIFO, os.sched_param(priority))

    def stop(self, timeout: float | None = None) -> bool:
        """No more calls once this returns (a call under way finishes first, waited for
        at most `timeout` [s]; None: as long as it takes); whether the thread ended. A
        call still under way then ends the calls, and what it raises is let go."""
        self._stopping = True
        self._wake()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout)
        return not self._thread.is_alive()

    def _run(self) -> None:
        try:
            self._loop()
        except BaseException as error:  # handed on: the owner decides what follows
            if self._stopping:  # a call the owner stopped waiting for, ended with what it used
                return
            self.failure = error
            if self._on_failure is not None:
                self._on_failure(error)

    def _loop(self) -> None:
        next_call = None
        while not self._stopping:
            if self._poked:
                self._poked = False
                with self._lock:
                    if not self._stopping:
                        self._work()
                continue
            if not self._active:
                self._changed.acquire()
                next_call = None
                continue
            now = time.monotonic()
            if next_call is None or self._restart:
                self._restart = False
                next_call = now + self._period
            if now < next_call:
                if self._changed.acquire(timeout=next_call - now):
                    next_call = min(next_call, time.monotonic() + self._period)
                continue
            with self._lock:
                if self._active and not self._stopping:
                    self._work()
            now = time.monotonic()
            if self._period <= 0.0:
                next_call = now
                time.sleep(AFAP_PAUSE_S)
            else:
                next_call = following_call(next_call, now, self._period)

    def _wake(self) -> None:
        # released already and not yet taken: the thread wakes anyway
        with contextlib.suppress(RuntimeError):
            self._changed.release()


def following_call(last_due: float, now: float, period: float) -> float:
    """When the call after the one due at `last_due` [s] is due, at `now`, for
    `period` > 0 [s]: one period later; if that has passed, at once (the latest
    missed time in phase), the calls missed before it skipped."""
    due = last_due + period
    if due <= now - period:
        due += period * math.floor((now - due) / period)
    return due
