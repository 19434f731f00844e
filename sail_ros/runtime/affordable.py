"""How short a boom the simulator can afford, from what the model costs on this machine.

A moving grid step is split into equal sub-steps where the shortest boom's first
bending frequency needs it (`Simulation.substeps`), and their number grows like
1/L^2 as a boom shortens: at 0.37 m a grid step of the default sail takes 21 of
them, at 7 mm some 60 000. The policy's `max_substep_rate` bounds that count
whatever the machine; the simulator must also finish each grid step in the time
it stands for. `StepCost` measures the CPU time of one sub-step of its model
(the least of a few moving grid steps), and `StepCost.check` refuses a
`min_length` whose moving grid steps, at that length, would take

- more than `REALTIME_SHARE` of the wall time they stand for, at the time scale
  asked for or at real time, whichever is slower (faster time scales are kept
  as far as the model allows, and the lag is counted as overruns), or
- more than `GRID_STEP_LIMIT_S` each, at any time scale, as fast as possible too:
  a tick holds the run's lock for its steps, so services, commands and a stop
  would wait that long.

The node checks at start and on every change of a parameter (`min_length` and
`max_substep_rate` are writable), so no command can take the booms where a grid
step stalls the simulator.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from sail_ros.model import SailModel
from sail_ros.model.fields import ConfigError
from sail_ros.runtime.commands import Rules, plan_deploy
from sail_ros.runtime.config import SimConfig
from sail_ros.runtime.simulation import Simulation

# of the wall time a moving grid step at min_length stands for, what its sub-steps may
# take: the rest is the tick's publishing, the commands and a machine that is not idle
REALTIME_SHARE = 0.5
GRID_STEP_LIMIT_S = 0.25  # the longest a grid step may take at any time scale [s]
MEASURED_SUBSTEPS = 4  # a measured grid step has about this many sub-steps
MEASURED_STEPS = 5  # grid steps timed; the least is taken (the machine's other load aside)
MEASURE_BUDGET_S = 1.0  # [s] CPU time after which the timing stops at the steps taken


def substeps_at(model: SailModel, config: SimConfig, length: float) -> int:
    """The equal sub-steps a moving grid step needs with the shortest boom at `length`
    [m] (`Simulation.substeps`, at the stepper's step bound)."""
    return Simulation(model, _at(config, length)).substeps()


def _at(config: SimConfig, length: float) -> SimConfig:
    """`config` with every boom starting at `length` [m], undeflected and at rest, and
    commands allowed down to it."""
    policy = config.policy
    if length < policy.min_length:
        policy = policy.replace(min_length=length)
    return dataclasses.replace(
        config,
        policy=policy,
        initial_lengths=np.full(4, float(length)),
        initial_tip_deflection=np.zeros(4),
        initial_hub_velocity=np.zeros(3),
    )


@dataclasses.dataclass(frozen=True)
class StepCost:
    """The CPU time of one moving sub-step of a model on this machine.

    Attributes:
        substep_s: CPU time of one sub-step [s].
    """

    substep_s: float

    @classmethod
    def measure(cls, model: SailModel, config: SimConfig) -> StepCost:
        """Time `MEASURED_STEPS` moving grid steps of `model` (at `config`'s grid, step
        and tolerance) with booms short enough for about `MEASURED_SUBSTEPS` sub-steps
        each, deploying; the least per sub-step. The time is the thread's CPU time: what
        the model costs, not how long the machine's other work kept it from a core
        (which the margin of `REALTIME_SHARE` is for)."""
        # a length of MEASURED_SUBSTEPS to twice as many (sub-steps grow like 1/L^2); with
        # fewer than 2 a moving step spans a grid step or more, and the timed grid steps
        # would be samples taken from it
        length = config.policy.min_length
        for _ in range(40):
            found = substeps_at(model, config, length)
            if MEASURED_SUBSTEPS <= found <= 2 * MEASURED_SUBSTEPS:
                break
            length *= math.sqrt(found / MEASURED_SUBSTEPS) if found > 1 else 0.5
        sim = Simulation(model, _at(config, length))
        plan = plan_deploy(1.5 * length, sim.boom_state(), Rules(sim.policy, model.params))
        sim.apply_motion(plan)
        least, spent = math.inf, 0.0
        for _ in range(MEASURED_STEPS):
            count = sim.substeps()
            started = time.thread_time()
            sim.step()
            took = time.thread_time() - started
            least, spent = min(least, took / count), spent + took
            if spent > MEASURE_BUDGET_S:  # a model this slow is refused on any count
                break
        return cls(least)

    def check(self, model: SailModel, config: SimConfig) -> None:
        """Refuse `config` if its booms at `min_length` cost more than the module's
        docstring allows.

        Raises:
            ConfigError: naming min_length, its value, what a grid step would cost and
                the shortest min_length affordable.
        """
        length = config.policy.min_length
        step = config.integration_step
        count = substeps_at(model, config, length)
        if count < 2:  # a moving step spans a grid step or more: no sub-steps to refuse
            return
        seconds = count * self.substep_s
        limit = GRID_STEP_LIMIT_S
        why = f"the {_time(limit)} a grid step may take (services and a stop wait for it)"
        if not config.as_fast_as_possible:
            scale = min(config.time_scale, 1.0)
            if REALTIME_SHARE * step / scale < limit:
                limit = REALTIME_SHARE * step / scale
                why = (
                    f"{REALTIME_SHARE:g} of the {_time(step / scale)} of wall time the step "
                    f"stands for at time scale {scale:g}"
                )
        if seconds <= limit:
            return
        most = max(1, math.floor(limit / self.substep_s))
        longest = config.policy.length_range(config.sail)[1]
        shortest = length * math.sqrt(count / most)  # sub-steps grow like 1/L^2
        while shortest < longest and substeps_at(model, config, shortest) > most:
            shortest *= 1.01  # the count rounds up
        raise ConfigError(
            f"min_length = {length:g} m would need {count} sub-steps per grid step of "
            f"{step:g} s, {_time(seconds)} of computation at {_time(self.substep_s)} each "
            f"({model.n} coordinates, as measured at start), more than {why}: the shortest "
            f"affordable min_length here is {math.ceil(shortest * 1e3) / 1e3:g} m"
        )


def _time(seconds: float) -> str:
    """A wall time for a message: in ms below a second."""
    return f"{seconds:.3g} s" if seconds >= 1.0 else f"{1e3 * seconds:.3g} ms"
