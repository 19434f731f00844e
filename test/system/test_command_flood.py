"""A flood of commands at a simulator process: valid deploy commands, then malformed ones,
1000 a second, 10 s each (as benchmarks/command_flood.py), a trial of scripts/stress.sh
(`--slow`; SAIL_ROS_FLOOD_RATE and SAIL_ROS_FLOOD_SECONDS size it). The
simulator keeps real time (at most one late state, one more than two state periods after
the one before, and at most one overrun more than in as long a quiet phase just before,
which counts what the machine's other load costs; no state later than five periods,
where the flood once stalled the simulator for seconds) and every command ends counted:
accepted, superseded or rejected, adding up to what was sent."""

import math
import os
import time

import pytest
from std_msgs.msg import Float64

from sail_ros import topics
from sail_ros.messages import status as key

pytestmark = [pytest.mark.multiprocess, pytest.mark.timing, pytest.mark.slow]

RATE = float(os.environ.get("SAIL_ROS_FLOOD_RATE", "1000"))  # commands per second
PHASE_S = float(os.environ.get("SAIL_ROS_FLOOD_SECONDS", "10"))
STATE_PERIOD_S = 0.02  # the default 50 Hz


def late_states(stamps: list[int]) -> list[float]:
    """The gaps [s] between consecutive states' source stamps [ns] over 2 state periods."""
    gaps = [(b - a) / 1e9 for a, b in zip(stamps[:-1], stamps[1:], strict=True)]
    return [gap for gap in gaps if gap > 2 * STATE_PERIOD_S]


def flood(operator, targets, rate: float = RATE) -> int:
    """Publish deploy commands to `targets(i)` at `rate` for PHASE_S; how many were sent."""
    sent, start = 0, time.monotonic()
    while (now := time.monotonic()) < start + PHASE_S:
        while sent < int((now - start) * rate):
            operator.deploy.publish(Float64(data=targets(sent)))
            sent += 1
        operator.spinner.spin_once(timeout_sec=0.0005)
    return sent


@pytest.mark.parametrize(
    ("kind", "targets"),
    [("valid", lambda i: 10.2 + 0.2 * (i % 5)), ("malformed", lambda i: math.nan)],
)
def test_a_flood_of_commands_is_held_in_real_time_and_counted(processes, operator, kind, targets):
    states = []
    operator.create_subscription(
        topics.TOPICS[topics.BOOM_STATE].message_type,
        topics.BOOM_STATE,
        lambda message, info: states.append(info["source_timestamp"]),
        topics.STATE_QOS,
    )
    processes("sim", parameters={"diagnostics_rate_hz": 4.0})
    operator.wait_for_simulator()
    quiet = operator.wait_for_status(lambda s: True, 5.0, "a status before the quiet phase")
    quiet_first = len(states)
    flood(operator, targets, rate=0.0)
    quiet_late = late_states(states[quiet_first:])
    before = operator.wait_for_status(lambda s: True, 5.0, "a status before the flood")
    quiet_overruns = int(before[key.OVERRUNS]) - int(quiet[key.OVERRUNS])
    first = len(states)
    sent = flood(operator, targets)
    after = operator.wait_for_status(
        lambda s: (
            sum(int(s[name]) for name in (key.ACCEPTED, key.SUPERSEDED, key.REJECTED)) >= sent
        ),
        10.0,
        "every command counted",
    )
    outcomes = {
        name: int(after[name]) - int(before[name])
        for name in (key.ACCEPTED, key.SUPERSEDED, key.REJECTED)
    }
    assert sum(outcomes.values()) == sent, outcomes
    if kind == "valid":
        assert outcomes[key.REJECTED] == 0 and outcomes[key.ACCEPTED] >= 1, outcomes
    else:
        assert outcomes[key.REJECTED] == sent, outcomes
    assert int(after[key.OVERRUNS]) - int(before[key.OVERRUNS]) <= quiet_overruns + 1
    published = states[first:]
    assert len(published) > 0.8 * PHASE_S / STATE_PERIOD_S
    late = late_states(published)
    assert len(late) <= len(quiet_late) + 1, f"late states: {late}, quiet phase: {quiet_late}"
    assert max(late, default=0.0) <= 5 * STATE_PERIOD_S, f"a {max(late) * 1e3:.1f} ms gap"
