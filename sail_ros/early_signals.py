"""A SIGINT that comes while a program is still starting, kept instead of lost.

A program started as a background job of a script (`sail-ros sim &`) begins with
SIGINT ignored, so a `kill -INT` during its second of imports would be lost and the
program would run on. And where SIGINT raises KeyboardInterrupt (Python's default), one
raised inside a finalizer or a callback of the imports is printed and dropped. The entry
points (`sail_ros.cli`) call `keep_early_sigint` before they import anything heavy: from
then on a SIGINT is noted in `RECEIVED` (and still raises KeyboardInterrupt where
Python's handler would), and the tools' `StopSignals` (`sail_ros.ros.program`) act on a
noted one once they start. Importing this module changes nothing.
"""

import signal
import threading

RECEIVED: list[str] = []


def _note(signum, frame) -> None:
    RECEIVED.append("SIGINT")


def _note_and_interrupt(signum, frame) -> None:
    RECEIVED.append("SIGINT")
    raise KeyboardInterrupt


def keep_early_sigint() -> None:
    """Note a SIGINT from now on (see the module docstring): only noted if the process
    ignores it, noted and raised if Python's default handler has it; another handler
    is left alone. In the main thread only (where handlers are set)."""
    if threading.current_thread() is not threading.main_thread():
        return
    handler = signal.getsignal(signal.SIGINT)
    if handler is signal.SIG_IGN:
        signal.signal(signal.SIGINT, _note)
    elif handler is signal.default_int_handler:
        signal.signal(signal.SIGINT, _note_and_interrupt)
