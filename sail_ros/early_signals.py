"""A SIGINT that comes while a program is still starting, kept instead of lost.

A program started as a background job of a script (`sail-ros sim &`) begins with
SIGINT ignored, so a `kill -INT` during its second of imports would be lost and the
program would run on. The entry points (`sail_ros.cli`) call `keep_early_sigint`
before they import anything heavy: in that case (SIGINT ignored, main thread) the
signal is noted in `RECEIVED`, and the tools' `StopSignals` (`sail_ros.ros.program`) act
on it once they start. Importing this module changes nothing.
"""

import signal
import threading

RECEIVED: list[str] = []


def keep_early_sigint() -> None:
    """Note a SIGINT from now on if the process ignores it (see the module docstring)."""
    if (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    ):
        signal.signal(signal.SIGINT, lambda signum, frame: RECEIVED.append("SIGINT"))
