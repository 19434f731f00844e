"""The reference deployment (docs/model.md §9) with `sail-ros deploy`'s options changed:
all booms along the cycloidal profile from `start` to `end` metres in `duration`
seconds, boom `boom` bent in its first mode with tip deflection `tip`."""

from __future__ import annotations

import copy

import numpy as np

from sail_ros.analysis.scenario import REFERENCE, Scenario, scenario_from_dict

# the options that build it (the deploy arguments' names), as typed
OPTIONS = {"start": "--from", "end": "--to", "duration": "--duration", "t_end": "--t-end",
           "boom": "--boom", "tip": "--tip"}  # fmt: skip


def reference_scenario(
    start=None, end=None, duration=None, t_end=None, boom=None, tip=None
) -> tuple[Scenario, str]:
    """The scenario and a one-line description of it; None keeps the reference's value
    (`t_end`: the simulated time [s], by default `duration`).

    Raises:
        ValueError: a bad value, named by its option (`OPTIONS`).
    """
    document = copy.deepcopy(REFERENCE)
    body = document["scenario"]
    reference = body["profile"]
    start = reference["start"] if start is None else start
    end = reference["end"] if end is None else end
    given_duration, duration = duration, reference["duration"] if duration is None else duration
    boom = boom or "a"
    tip = body["initial"]["mode_state"]["a"] if tip is None else tip
    body["profile"] = {"type": "cycloidal", "start": start, "end": end, "duration": duration}
    body["duration"] = duration if t_end is None else t_end
    body["initial"] = {"mode_state": {boom: tip}}
    if t_end is not None or given_duration is not None:
        body["snapshots"] = np.linspace(0.0, body["duration"], 6).round(6).tolist()
    text = (
        f"booms {start:g} m -> {end:g} m in {duration:g} s (cycloidal), "
        f"boom {boom} tip {tip:g} m at t = 0"
    )
    body["description"] = text
    labels = {"profile": "--from/--to/--duration", "initial": "--boom/--tip"}
    try:
        return scenario_from_dict(document, labels), text
    except ValueError as error:  # a field of the document is an option here: name it so
        options = {
            "scenario.profile.start": "--from",
            "scenario.profile.end": "--to",
            "scenario.profile.duration": "--duration",
            "scenario.duration": "--duration" if t_end is None else "--t-end",
            f"scenario.initial.mode_state.{boom}": "--tip",
        }
        message = str(error)
        for field, option in options.items():
            if message.startswith(field + " "):
                raise ValueError(option + message[len(field) :]) from None
        raise ValueError(f"the reference deployment of the options: {message}") from None
