"""A deployment run written as an MCAP log with the live simulator's topics.

Every reader of recorder logs (`sail-ros report`, `sail-ros replay`,
`ros2 bag`, Foxglove) reads these too:

- topics, types, QoS (as the recorder stores the simulator's publishers')
  from `sail_ros.topics`, message contents from `sail_ros.messages`:
  `/clock`, `/sail/boom_state`, `/sail/modal_state`, `/sail/tip_deflection`,
  `/sail/root_moment` (and a free hub's `/sail/hub_state`) at every output time,
  `/sail/shape` at the shape rate; no `/diagnostics`
  (an offline run has no real-time pacing to report);
- time: header stamps, log time and publish time are all simulation time in
  ns since LOG_EPOCH_NS = 0, the Unix epoch, so t = 0 s is
  1970-01-01T00:00:00Z and a stamp divided by 1e9 is the simulation time [s];
- metadata `sail_sim_parameters`: the simulator's parameter names
  (`sail.<field>`, the policy's limits, `initial_lengths`, ...) with values as
  one-line YAML, as the recorder stores them;
- metadata `sail_deploy_scenario`: the scenario as YAML and the epoch;
- a closed loop's commands (`commands`): /sail/hub_wrench_cmd (and /sail/tip_force_cmd)
  at every state sample, stamped and logged with the time they act (the sample's plus
  the loop delay), as `sail_control` stamps its own.

The messages are the bytes the live simulator publishes, made by the same
serialisers (`sail_ros.messages.cdr`: exact CDR, nothing after the last
field). A chunk is closed after every simulated
second (CHUNK_SECONDS), as the recorder closes one per wall-clock second of a
real-time run, so a file cut short keeps everything before its last chunk.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import yaml

from sail_ros import topics
from sail_ros.analysis.deployment import DeploymentRun
from sail_ros.bag import BagWriter
from sail_ros.bag.qos import recorded_entry
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.messages.cdr import ShapeSerializer, StateSerializer, serialize
from sail_ros.model import SailModel
from sail_ros.model.shape import SailSurface
from sail_ros.outputs import staged
from sail_ros.policy import Policy

LOG_EPOCH_NS = 0
CHUNK_SECONDS = 1.0  # simulated time per MCAP chunk [s]
# the topics of an offline run: every state sample with its /clock, and the shape (and a
# free hub's state)
LOGGED_TOPICS = (topics.CLOCK, *topics.STATE_TOPICS, topics.SHAPE)


def recorded_parameters(
    model: SailModel,
    run: DeploymentRun,
    *,
    state_rate_hz: float,
    shape_rate_hz: float,
    max_step: float,
    shape_divisions: int,
    policy: Policy | None = None,
    frame_id: str = topics.FRAME_ID,
) -> dict[str, str]:
    """The run's settings under the simulator's parameter names, values as YAML text.

    `initial_lengths` and `initial_tip_deflection` are the lengths [m] and
    tip deflections [m] at t = 0. `integration_step` is the simulator's grid
    step [s]: the state sample interval; `max_model_step` and `model_rtol` are the
    run's longest step [s] and tolerance (the run's accuracy; its steps, chosen by the
    tolerance, are its own, not the grid's). `time_scale` 0.0 means "as fast as
    possible", which an offline run is. The policy's limits are
    those the run kept (default: the simulator's defaults).
    """
    values = topics.flat_sail_parameters(model.params)
    values.update(dataclasses.asdict(Policy() if policy is None else policy))
    values.update(
        {
            "initial_lengths": [float(v) for v in run.lengths[0]],
            "initial_tip_deflection": [float(v) for v in run.tips[0]],
            "state_rate_hz": float(state_rate_hz),
            "shape_rate_hz": float(shape_rate_hz),
            "integration_step": 1.0 / state_rate_hz,
            "max_model_step": float(max_step),
            "model_rtol": run.accuracy.rtol or 0.0,  # 0: fixed steps
            "time_scale": 0.0,
            "frame_id": frame_id,
            "shape_divisions": int(shape_divisions),
        }
    )
    return {name: topics.yaml_value(value) for name, value in values.items()}


def write_deployment_log(
    path,
    model: SailModel,
    run: DeploymentRun,
    *,
    parameters: dict[str, str],
    scenario_document: dict,
    shape_every: int,
    shape_divisions: int,
    frame_id: str = topics.FRAME_ID,
    progress: Callable[[float], None] | None = None,
    commands=None,
) -> list:
    """Write `run` to `path` (a `.mcap` file, replaced if present, or a bag folder).

    Args:
        path: output file or folder.
        model: the model of the run (coordinate names, shape basis).
        run: the states to write.
        parameters: the `sail_sim_parameters` record (`recorded_parameters`).
        scenario_document: the scenario as plain data.
        shape_every: write `/sail/shape` at every `shape_every`-th output time
            (0: never).
        shape_divisions: mesh subdivisions of each quadrant edge in the shape.
        frame_id: frame of every message.
        progress: optional callable `progress(t)` after each output time.
        commands: a closed loop's `(t [s] (k,), u (k, nu), delay [s], input names)`: the
            command of each sample time (the hub wrench first, then tip forces).

    Returns:
        the `BagWriter` file summaries.
    """
    states = StateSerializer(
        model.coordinate_names, frame_id, with_clock=True, free_hub=model.free_hub
    )
    surface = SailSurface(model, shape_divisions) if shape_every else None
    shapes = (
        ShapeSerializer(surface.triangles, surface.boom_stations.size, frame_id)
        if surface
        else None
    )
    with BagWriter(path, overwrite=True, fsync=False) as bag:  # regenerable: no fsync cost
        bag.add_metadata(topics.PARAMETERS_METADATA, parameters)
        bag.add_metadata(
            topics.SCENARIO_METADATA,
            {
                "scenario": yaml.safe_dump(scenario_document, sort_keys=False),
                "epoch_ns": str(LOG_EPOCH_NS),
            },
        )
        logged = (*LOGGED_TOPICS, topics.HUB_STATE) if model.free_hub else LOGGED_TOPICS
        command_messages = _commands(commands, frame_id)
        logged = (*logged, *sorted({topic for _, _, topic, _ in command_messages}))
        for name in logged:
            if name != topics.SHAPE or shape_every:
                topic = topics.TOPICS[name]
                bag.add_topic(topics.absolute(name), topic.type_name, [recorded_entry(topic.qos)])
        chunk_end = CHUNK_SECONDS
        for i, t in enumerate(run.t):
            if t >= chunk_end:
                bag.flush()
                chunk_end = (t // CHUNK_SECONDS + 1) * CHUNK_SECONDS
            stamp = topics.stamp_ns(LOG_EPOCH_NS, float(t))
            messages = states.serialize(stamp, run.sample(i))
            if shape_every and i % shape_every == 0:
                vertices = surface.vertices(run.q[i], run.lengths[i])
                booms = surface.boom_lines(run.q[i], run.lengths[i])
                messages.append((topics.SHAPE, shapes.serialize(stamp, vertices, booms)))
            for topic, data in messages:
                bag.write(topics.absolute(topic), data, log_time_ns=stamp, publish_time_ns=stamp)
            while command_messages and command_messages[0][0] <= t + 1e-9:
                _, at_ns, topic, data = command_messages.pop(0)
                bag.write(topics.absolute(topic), data, log_time_ns=at_ns, publish_time_ns=at_ns)
            if progress is not None:
                progress(float(t))
    return bag.close()


def _commands(commands, frame_id: str) -> list:
    """`(t [s], log time [ns], topic, CDR bytes)` of a closed loop's commands, in time
    order (`write_deployment_log`)."""
    if commands is None:
        return []
    times, values, delay, names = commands
    found = []
    for t, u in zip(times, values, strict=True):
        acts = topics.stamp_ns(LOG_EPOCH_NS, float(t) + delay)
        wrench = hub_msg.hub_wrench_command(*u[:3], frame_id=frame_id)
        wrench.header.stamp = topics.stamp(acts)
        found.append((float(t), acts, topics.HUB_WRENCH_CMD, serialize(wrench)))
        if len(names) > 3:
            forces = dict(zip(topics.BOOM_JOINTS, map(float, u[3:]), strict=True))
            message = commands_msg.load_command(topics.TIP_FORCE_CMD, forces)
            message.header.stamp = topics.stamp(acts)
            found.append((float(t), acts, topics.TIP_FORCE_CMD, serialize(message)))
    return found


def write_study_log(found, scenario, policy: Policy, request, progress):
    """A deploy study's run (`analysis.deploy_study.DeployStudy`) at its grid's times as
    the log `request.mcap` asks for (whole or not at all, `outputs.staged`, named --mcap
    in errors), a closed loop's commands with it; `progress(what, total)` as
    `deploy_study.study`'s. Returns the path written."""
    result, closed, rate_hz = found.result, found.closed, request.rate
    logged = result.subset(np.isin(result.t, found.grid))
    shape_every = round(rate_hz / request.shape_rate) if request.shape_rate > 0 else 0
    parameters = recorded_parameters(
        found.model, logged, state_rate_hz=rate_hz,
        shape_rate_hz=rate_hz / shape_every if shape_every else 0.0,
        max_step=request.max_step, shape_divisions=request.shape_divisions, policy=policy,
    )  # fmt: skip
    commands = None
    if closed is not None:
        commands = (result.t, closed.commands, closed.schedule.delay, closed.inputs)
    with staged(request.mcap, "--mcap") as building, progress("mcap", logged.t[-1]) as reached:
        write_deployment_log(
            building, found.model, logged, parameters=parameters,
            scenario_document=scenario.document, shape_every=shape_every,
            shape_divisions=request.shape_divisions, progress=reached, commands=commands,
        )  # fmt: skip
    return request.mcap
