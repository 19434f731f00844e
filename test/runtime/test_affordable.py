"""`runtime.affordable`: the shortest boom the simulator can afford for what its model
costs. The cost of a sub-step is given here (the machine's is measured at start), so
the refusals are the same on any machine."""

import pytest

from sail_ros.model import SailModel
from sail_ros.model.fields import ConfigError
from sail_ros.runtime import affordable
from sail_ros.runtime.affordable import (
    GRID_STEP_LIMIT_S,
    MEASURED_SUBSTEPS,
    REALTIME_SHARE,
    StepCost,
    substeps_at,
)
from sail_ros.runtime.config import config_from_values

pytestmark = pytest.mark.model

SMALL = {"sail.n_boom_modes": 4, "sail.n_membrane_modes": 6}
COST = StepCost(0.7e-3)  # s a sub-step: the default sail's here


@pytest.fixture(scope="module")
def model():
    return SailModel(config_from_values(SMALL).sail)


def config(**values):
    return config_from_values({**SMALL, **values})


def refusal(model, **values) -> str:
    """The check's refusal of `values` (which the policy lets through)."""
    checked = config(**{"max_substep_rate": 1e7, **values})
    with pytest.raises(ConfigError) as refused:
        COST.check(model, checked)
    return str(refused.value)


def shortest_in(text: str) -> float:
    return float(text.rsplit("min_length here is ", 1)[1].removesuffix(" m"))


def test_sub_steps_grow_like_one_over_the_length_squared(model):
    base = config()
    counts = [substeps_at(model, base, length) for length in (0.4, 0.2, 0.1)]
    assert counts[1] == pytest.approx(4 * counts[0], abs=4)  # each rounded up
    assert counts[2] == pytest.approx(4 * counts[1], abs=4)


def test_the_stall_of_allowed_values_is_refused_naming_what_is_affordable(model):
    """max_substep_rate 1e7 lets min_length 7 mm through the policy, whose moving grid
    step would take tens of seconds: refused in one line, naming the length, the cost and
    the shortest affordable length, which is itself affordable and a few mm less not."""
    values = {"max_substep_rate": 1e7, "min_length": 0.007, "initial_lengths": [0.007]}
    config(**values)  # the policy lets it through
    count = substeps_at(model, config(**values), 0.007)
    text = refusal(model, **values)
    seconds = count * COST.substep_s
    assert text.startswith(
        f"min_length = 0.007 m would need {count} sub-steps per grid step of 0.01 s, "
        f"{seconds:.3g} s of computation at 0.7 ms each (40 coordinates, as measured at "
        f"start), more than {REALTIME_SHARE:g} of the 10 ms of wall time the step stands for "
        "at time scale 1: the shortest affordable min_length here is "
    ), text
    shortest = shortest_in(text)
    COST.check(model, config(min_length=shortest))
    refusal(model, min_length=shortest - 0.01)


def test_the_default_rate_at_a_short_length_is_refused_and_the_defaults_pass(model):
    """0.37 m is within the default max_substep_rate but needs about three times the
    wall time real time allows (a real-time factor of 0.66 when the booms got there)."""
    text = refusal(model, min_length=0.37, max_substep_rate=3200.0)  # the default rate
    assert "min_length = 0.37 m would need 21 sub-steps per grid step" in text
    COST.check(model, config())


def test_what_is_affordable_follows_the_clock_and_bounds_every_grid_step(model):
    """Slower than real time affords shorter booms; faster is kept as far as the model
    allows (checked at real time); as fast as possible, a grid step may take at most
    GRID_STEP_LIMIT_S, so that services and a stop wait no longer."""
    paced = shortest_in(refusal(model, min_length=0.2))
    assert shortest_in(refusal(model, min_length=0.2, time_scale=8.0)) == paced
    slow = shortest_in(refusal(model, min_length=0.05, time_scale=0.1))
    assert slow < paced
    fast = refusal(model, min_length=0.007, max_substep_rate=1e7, time_scale=0.0)
    assert f"more than the {1e3 * GRID_STEP_LIMIT_S:g} ms a grid step may take" in fast
    assert shortest_in(fast) < slow
    COST.check(model, config(min_length=0.2, max_substep_rate=1e7, time_scale=0.0))


def test_the_cost_is_measured_on_grid_steps_of_a_few_sub_steps(model, monkeypatch):
    """However short min_length (7 mm: some 60 000 sub-steps a grid step), the measured
    grid steps have MEASURED_SUBSTEPS to twice as many sub-steps: the measurement takes
    milliseconds, and never times a grid step taken from a longer step."""
    counts = []

    class Counted(affordable.Simulation):
        def step(self):
            counts.append(self.substeps())
            return super().step()

    monkeypatch.setattr(affordable, "Simulation", Counted)
    for length in (0.007, 1.0, 30.0):
        counts.clear()
        values = {"max_substep_rate": 1e7, "min_length": length, "initial_lengths": [30.0]}
        cost = StepCost.measure(model, config(**values))
        assert 0.0 < cost.substep_s < 1.0
        assert counts and all(
            MEASURED_SUBSTEPS <= count <= 2 * MEASURED_SUBSTEPS for count in counts
        ), (length, counts)
