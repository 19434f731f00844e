"""The diagnostics policy: which level and message each situation gets."""

import pytest

from sail_ros.runtime.diagnosis import RTF_WARN_FRACTION, Observations, diagnose

pytestmark = pytest.mark.model

CALM = Observations(
    state="running",
    error="",
    window_s=1.0,
    overruns=0,
    rejected=0,
    dropped=0,
    last_rejection="",
    paced=True,
    rtf_measured=True,
    real_time_factor=1.0,
    time_scale=1.0,
)


@pytest.mark.parametrize(
    ("changes", "level", "message"),
    [
        ({}, "OK", "running at 1x real time"),
        ({"rtf_measured": False}, "OK", "running (measuring the real-time factor)"),
        ({"state": "paused"}, "OK", "paused"),
        ({"overruns": 3, "window_s": 2.0}, "WARN", "3 overrun(s) in the last 2 s"),
        ({"real_time_factor": 0.5}, "WARN", "real-time factor 0.5, below time_scale 1"),
        ({"rejected": 2, "last_rejection": "fast"}, "WARN", "rejected 2 command(s); last: fast"),
        ({"dropped": 4, "rejected": 1}, "WARN", "dropped 4 command(s)"),
        ({"state": "error", "error": "nan", "overruns": 1}, "ERROR", "integration stopped: nan"),
    ],
    ids=["ok", "measuring", "paused", "overruns", "slow", "rejected", "dropped", "error-wins"],
)
def test_level_and_message(changes, level, message):
    got_level, got_message = diagnose(CALM._replace(**changes))
    assert got_level == level
    assert got_message.startswith(message)


def test_slow_run_warns_only_when_paced_running_and_measured():
    slow = RTF_WARN_FRACTION * 2.0 * 0.99
    assert diagnose(CALM._replace(time_scale=2.0, real_time_factor=slow))[0] == "WARN"
    assert diagnose(CALM._replace(time_scale=2.0, real_time_factor=1.81))[0] == "OK"
    for changes in ({"paced": False}, {"state": "paused"}, {"rtf_measured": False}):
        seen = CALM._replace(time_scale=2.0, real_time_factor=slow, **changes)
        assert diagnose(seen)[0] == "OK", changes


def test_overruns_outrank_a_slow_run_and_rejections():
    seen = CALM._replace(overruns=1, real_time_factor=0.1, rejected=5)
    assert diagnose(seen)[1].startswith("1 overrun(s)")
