"""Does the simulator run the plant the controller was designed for?

The node asks the simulator for its parameters (`SIMULATOR_PARAMETERS`) before it
commands, and `disagreement` compares them with its own: a clamped hub, other mode
counts or another sail, another state rate, or limits below the controller's
saturation (its commands would be refused) are errors, each one line naming the
parameter and both values; a model that may run ahead of the published samples (a
`max_model_step` above the `integration_step`), a tick that carries more than one
sample or ends between samples are warnings: commands then act later than the
design's loop delay.
"""

from __future__ import annotations

import math

from sail_ros.control.settings import DesignSettings
from sail_ros.model import SailParameters
from sail_ros.model.parameters import sail_fields
from sail_ros.policy import Policy

LIMITS = (("max_hub_force", "N"), ("max_hub_torque", "N m"), ("max_tip_force", "N"))
TICK_S = 0.005  # the simulator's shortest tick [s of wall time] (runtime.pacing)
SIMULATOR_PARAMETERS = (
    *(f"sail.{name}" for name in SailParameters.field_names()),
    "state_rate_hz",
    "time_scale",
    "integration_step",
    "max_model_step",
    "command_wait_s",
    *(name for name, _ in LIMITS),
)


def disagreement(
    params: SailParameters, design: DesignSettings, policy: Policy, simulator: dict, node: str
) -> tuple[str, list[str]]:
    """`(error, warnings)`: the first thing in `simulator` (parameter name -> value, as
    the simulator `node` has them) that the controller cannot work with ("" if none), and
    what it can but should be told about."""
    sail = sail_fields(simulator)
    if sail.get("free_hub") is False:
        return (
            f"the simulator {node} has a clamped hub (sail.free_hub = false): nothing to "
            "control; run it with -p sail.free_hub:=true",
            [],
        )
    for name in ("n_boom_modes", "n_membrane_modes"):
        if name in sail and sail[name] != getattr(params, name):
            return (
                f"sail.{name} = {getattr(params, name)} here, {sail[name]} in {node}: the "
                "controller's plant has other mode counts than the simulator's (give both the "
                "same sail)",
                [],
            )
    for name in SailParameters.field_names():
        mine, theirs = getattr(params, name), sail.get(name)
        if theirs is None or mine == theirs:
            continue
        if isinstance(mine, float) and math.isclose(mine, float(theirs), rel_tol=1e-12):
            continue
        return (f"sail.{name} = {mine!r} here, {theirs!r} in {node}: another sail", [])
    rate = simulator.get("state_rate_hz")
    if rate is not None and not math.isclose(rate, design.state_rate_hz, rel_tol=1e-9):
        return (
            f"state_rate_hz = {design.state_rate_hz:g} Hz here, {rate:g} Hz in {node}: the "
            "loop is designed for one sample period",
            [],
        )
    for name, unit in LIMITS:
        mine, theirs = getattr(policy, name), simulator.get(name)
        if theirs is not None and mine > theirs * (1 + 1e-12):
            return (
                f"{name} = {mine:g} {unit} here, {theirs:g} {unit} in {node}: commands up to "
                "the controller's limit would be refused",
                [],
            )
    warnings = []
    step, longest = simulator.get("integration_step"), simulator.get("max_model_step")
    scale = simulator.get("time_scale")
    span = TICK_S * scale if scale is not None and scale > 0 else 0.0  # [s] of a tick
    if span > design.period + design.loop_delay_s + 1e-9:
        warnings.append(
            f"at time_scale {scale:g} a tick of {node} (at least {1e3 * TICK_S:g} ms) carries "
            f"{span / design.period:.3g} state samples: the commands of all but its last act "
            f"late; state_rate_hz <= {1 / span:g} Hz keeps one sample a tick"
        )
    elif (
        span >= design.period * (1 - 1e-9)
        and design.loop_delay_s < design.period
        and not simulator.get("command_wait_s")
    ):
        warnings.append(
            f"at time_scale {scale:g} a tick of {node} is as short as it gets ({1e3 * TICK_S:g} "
            f"ms): a command acts from its sample only if it comes before the next tick, and "
            f"else a tick late; -p command_wait_s:=1.0 of the simulator has each step wait for "
            "its command"
        )
    if step is not None and not math.isclose(
        design.period / step, round(design.period / step), rel_tol=1e-9
    ):
        warnings.append(f"{node}'s samples do not fall on its integration_step = {step:g} s")
    elif step is not None and scale is not None and scale > 0 and step < design.period * (1 - 1e-9):
        warnings.append(
            f"{node}'s integration_step = {step:g} s is shorter than the sample period "
            f"{design.period:g} s: a tick may end between two samples, and a command then "
            f"acts that much later (run it with -p integration_step:={design.period:g})"
        )
    if step is not None and longest is not None and longest > step * (1 + 1e-9):
        warnings.append(
            f"{node}'s max_model_step = {longest:g} s is above its integration_step = "
            f"{step:g} s: its model may run ahead of the published samples, and a command "
            f"then acts up to {longest - step:g} s later than loop_delay_s = "
            f"{design.loop_delay_s:g} s (run it with -p max_model_step:={step:g})"
        )
    return "", warnings
