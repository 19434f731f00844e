"""The simulator's health as a level and a reason: a pure function of what it counted.

`diagnose` decides what /diagnostics says; the node only gathers the counts
of the window since its last status (`Observations`) and publishes the
answer. The worst finding wins: a stopped integration (ERROR), then a motion
leaving the linear model's range, overruns, a real-time factor below the
time scale, dropped or rejected commands (WARN); otherwise OK with the state.
"""

from __future__ import annotations

from typing import NamedTuple

RTF_WARN_FRACTION = 0.9  # WARN when a paced run achieves less than this of time_scale


class Observations(NamedTuple):
    """What the simulator saw over one diagnostics window.

    Attributes:
        state: "running", "paused" or "error".
        error: why the integration stopped ("" while it runs).
        window_s: length of the window [s of wall time].
        overruns: ticks that came late in the window.
        rejected: commands rejected in the window.
        dropped: commands dropped in the window (the command queue was full).
        last_rejection: the reason of the last rejection.
        paced: the run follows the clock (not as fast as possible).
        rtf_measured: a complete real-time factor measurement exists.
        real_time_factor: that measurement [-].
        time_scale: the simulation seconds per wall second asked for [-].
        range_warning: why the motion is leaving the linear model's range ("" if not).
    """

    state: str
    error: str
    window_s: float
    overruns: int
    rejected: int
    dropped: int
    last_rejection: str
    paced: bool
    rtf_measured: bool
    real_time_factor: float
    time_scale: float
    range_warning: str = ""


def diagnose(seen: Observations) -> tuple[str, str]:
    """`(level, message)`: level "OK", "WARN" or "ERROR", and one line saying why."""
    if seen.error:
        return "ERROR", f"integration stopped: {seen.error}; call sail/reset"
    if seen.range_warning:
        return "WARN", f"leaving the linear range: {seen.range_warning}"
    if seen.overruns:
        return "WARN", (
            f"{seen.overruns} overrun(s) in the last {seen.window_s:.3g} s: the integration "
            "is falling behind the clock"
        )
    running = seen.state == "running"
    if (
        seen.paced
        and running
        and seen.rtf_measured
        and seen.real_time_factor < RTF_WARN_FRACTION * seen.time_scale
    ):
        return "WARN", (
            f"real-time factor {seen.real_time_factor:.3g}, below time_scale {seen.time_scale:g}"
        )
    if seen.dropped:
        return "WARN", (
            f"dropped {seen.dropped} command(s): more arrived at once than max_queued_commands"
        )
    if seen.rejected:
        return "WARN", f"rejected {seen.rejected} command(s); last: {seen.last_rejection}"
    if not running:
        return "OK", seen.state
    if seen.rtf_measured:
        return "OK", f"running at {seen.real_time_factor:.3g}x real time"
    return "OK", "running (measuring the real-time factor)"
