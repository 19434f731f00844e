"""When the recorder asks a node for its parameters (`bag.parameter_fetch`), on a clock
the test moves."""

import pytest

from sail_ros.bag.parameter_fetch import ASK, ASK_AGAIN, NOTHING, WARN_ABSENT, ParameterFetch

pytestmark = pytest.mark.model


class Clock:
    """A clock that moves only when the test moves it [s]."""

    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_asks_once_the_node_is_there_again_after_a_restart_and_when_unanswered():
    clock = Clock()
    fetch = ParameterFetch(warn_after_s=5.0, timeout_s=2.0, now=clock)
    assert fetch.poll(False) == NOTHING
    clock.t += 6.0
    assert fetch.poll(False) == WARN_ABSENT
    assert fetch.poll(False) == NOTHING  # warned once
    assert fetch.poll(True) == ASK and fetch.in_flight
    clock.t += 1.0
    assert fetch.poll(True) == NOTHING  # the answer is not overdue yet
    clock.t += 1.5
    assert fetch.poll(True) == ASK_AGAIN and fetch.in_flight
    assert fetch.answered() == 1 and not fetch.in_flight
    assert fetch.poll(True) == NOTHING  # fetched: the events carry the changes
    assert fetch.poll(False) == NOTHING  # gone: no warning once values came
    assert fetch.poll(True) == ASK  # back: it may have restarted with another sail
    assert fetch.answered() == 2


def test_a_node_there_from_the_start_is_never_warned_about():
    clock = Clock()
    fetch = ParameterFetch(warn_after_s=5.0, timeout_s=2.0, now=clock)
    assert fetch.poll(True) == ASK
    assert fetch.answered() == 1
    clock.t += 60.0
    assert fetch.poll(False) == NOTHING
