"""sail_ros: deployment dynamics and vibration of a four-quadrant solar sail."""

import signal as _signal
import threading as _threading

# A program started as a background job of a script (`sail-ros sim &`) begins with
# SIGINT ignored, so a `kill -INT` while it is still importing would be lost and the
# program would run on. In that case the signal is noted instead, and the tools'
# StopSignals (sail_ros.ros_cli) act on it once they start. Anywhere else (SIGINT not
# ignored, not the main thread) nothing changes.
EARLY_SIGNALS: list[str] = []
if (
    _threading.current_thread() is _threading.main_thread()
    and _signal.getsignal(_signal.SIGINT) is _signal.SIG_IGN
):
    _signal.signal(_signal.SIGINT, lambda signum, frame: EARLY_SIGNALS.append("SIGINT"))
