"""A flood of commands at a simulator process: valid deploy commands, then malformed
ones (to NaN), then bytes that are no Float64 at all, at 1000 a second (the first two as
benchmarks/command_flood.py). Every command ends counted:
accepted, superseded or rejected, adding up to what was sent; the simulator never
stalls (no state later than five state periods after the one before, where the flood
once stalled it for seconds).

Whether it keeps real time is the full-size trial's question, 10 s per phase, in
scripts/stress.sh (`--slow`; SAIL_ROS_FLOOD_RATE and SAIL_ROS_FLOOD_SECONDS size it): at
most one late state (more than two state periods after the one before) and at most one
overrun more than in as long a quiet phase just before, which counts what the machine's
other load costs. The suite floods 1.5 s per phase, where one tick delayed by the
machine is already one overrun too many to tell from the flood's cost."""

import math
import os
import time

import pytest
from harness import SMALL_SIM
from std_msgs.msg import Float64

from sail_ros import status as key
from sail_ros import topics

pytestmark = [pytest.mark.multiprocess, pytest.mark.timing]

STATE_PERIOD_S = 0.02  # the default 50 Hz
SIZES = {  # commands per second, seconds per phase
    "suite": (1000.0, 1.5),
    "stress": (
        float(os.environ.get("SAIL_ROS_FLOOD_RATE", "1000")),
        float(os.environ.get("SAIL_ROS_FLOOD_SECONDS", "10")),
    ),
}
KINDS = {  # the i-th command of each phase
    "valid": lambda i: Float64(data=10.2 + 0.2 * (i % 5)),
    "malformed": lambda i: Float64(data=math.nan),
    "undecodable": lambda i: b"\x00\x01\x00\x00\x00",  # a CDR header and one byte
}
OUTCOMES = (key.ACCEPTED, key.SUPERSEDED, key.REJECTED)


def late_states(stamps: list[int]) -> list[float]:
    """The gaps [s] between consecutive states' source stamps [ns] over 2 state periods."""
    gaps = [(b - a) / 1e9 for a, b in zip(stamps[:-1], stamps[1:], strict=True)]
    return [gap for gap in gaps if gap > 2 * STATE_PERIOD_S]


def flood(operator, targets, rate: float, seconds: float) -> int:
    """Publish deploy commands `targets(i)` at `rate` for `seconds`; how many were sent."""
    sent, start = 0, time.monotonic()
    while (now := time.monotonic()) < start + seconds:
        while sent < int((now - start) * rate):
            operator.deploy.publish(targets(sent))
            sent += 1
        operator.spinner.spin_once(timeout_sec=0.0005)
    return sent


@pytest.mark.parametrize("size", ["suite", pytest.param("stress", marks=pytest.mark.slow)])
def test_a_flood_of_commands_is_held_in_real_time_and_counted(processes, operator, size):
    rate, seconds = SIZES[size]
    states = []
    operator.create_subscription(
        topics.TOPICS[topics.BOOM_STATE].message_type,
        topics.BOOM_STATE,
        lambda message, info: states.append(info["source_timestamp"]),
        topics.STATE_QOS,
    )
    processes("sim", parameters={**SMALL_SIM, "diagnostics_rate_hz": 4.0})
    operator.wait_for_simulator()
    quiet = operator.wait_for_status(lambda s: True, 5.0, "a status before the quiet phase")
    quiet_first = len(states)
    if size == "stress":
        flood(operator, KINDS["valid"], 0.0, seconds)
    quiet_late = late_states(states[quiet_first:])
    before = operator.wait_for_status(lambda s: True, 5.0, "a status after the quiet phase")
    quiet_overruns = int(before[key.OVERRUNS]) - int(quiet[key.OVERRUNS])
    for kind, targets in KINDS.items():
        first = len(states)
        sent = flood(operator, targets, rate, seconds)
        counted = sum(int(before[name]) for name in OUTCOMES) + sent
        after = operator.wait_for_status(
            lambda s, counted=counted: sum(int(s[name]) for name in OUTCOMES) >= counted,
            10.0,
            f"every {kind} command counted",
        )
        outcomes = {name: int(after[name]) - int(before[name]) for name in OUTCOMES}
        assert sum(outcomes.values()) == sent, (kind, outcomes)
        if kind == "valid":
            assert outcomes[key.REJECTED] == 0 and outcomes[key.ACCEPTED] >= 1, outcomes
        else:
            assert outcomes[key.REJECTED] == sent, outcomes
        published = states[first:]
        assert len(published) > 0.8 * seconds / STATE_PERIOD_S, kind
        late = late_states(published)
        assert max(late, default=0.0) <= 5 * STATE_PERIOD_S, f"{kind}: {max(late) * 1e3:.1f} ms"
        if size == "stress":
            overruns = int(after[key.OVERRUNS]) - int(before[key.OVERRUNS])
            assert overruns <= quiet_overruns + 1, (kind, overruns, quiet_overruns)
            assert len(late) <= len(quiet_late) + 1, f"{kind}: late {late}, quiet {quiet_late}"
        before = after
