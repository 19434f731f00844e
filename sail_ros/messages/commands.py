"""The boom and load commands (`sail/boom_length_cmd`, `sail/pressure_cmd`,
`sail/tip_force_cmd`) and the simulator's answer to every command
(`sail/command_status`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from sail_ros.names import (  # noqa: F401  the answers' vocabulary, re-exported
    ACCEPTED,
    IGNORED,
    LOADS_HELD,
    REJECTED,
    SIM_NODE,
    SUBSCRIBERS,
    SUPERSEDED,
    CommandAnswer,
)
from sail_ros.topics import stamp


def load_command(topic: str, values: Mapping[str, float]) -> JointState:
    """A `sail/pressure_cmd` (quadrant -> Pa) or `sail/tip_force_cmd` (boom -> N)."""
    message = JointState(name=list(values))
    message.effort = [float(v) for v in values.values()]
    return message


def boom_length_command(booms: Sequence[str], points: Sequence[Sequence[float]]) -> JointTrajectory:
    """A `sail/boom_length_cmd` taking `booms` ("a" ...) through `points`, each a time
    from now [s] followed by one length [m] per boom."""
    message = JointTrajectory(joint_names=[f"boom_{boom}" for boom in booms])
    for seconds, *lengths in points:
        whole = math.floor(seconds)
        message.points.append(
            JointTrajectoryPoint(
                positions=lengths,
                time_from_start=Duration(sec=whole, nanosec=round((seconds - whole) * 1e9)),
            )
        )
    return message


_OUTCOME_LEVELS = {
    ACCEPTED: DiagnosticStatus.OK,
    REJECTED: DiagnosticStatus.ERROR,
    IGNORED: DiagnosticStatus.WARN,
    SUPERSEDED: DiagnosticStatus.WARN,
}


def command_status(stamp_ns_: int, answers: Sequence[CommandAnswer]) -> DiagnosticArray:
    """`sail/command_status`: the answers to the commands a tick handled, one status
    per command in the order handled; level OK (accepted), ERROR (rejected) or WARN
    (superseded, ignored), name `sail_sim: <topic>`, the answer's fields as values."""
    array = DiagnosticArray(status=[_status(answer) for answer in answers])
    array.header.stamp = stamp(stamp_ns_)
    return array


def _status(answer: CommandAnswer) -> DiagnosticStatus:
    status = DiagnosticStatus(
        level=_OUTCOME_LEVELS[answer.outcome],
        name=f"{SIM_NODE}: {answer.topic}",
        message=answer.message,
        hardware_id=SIM_NODE,
    )
    pairs = {
        "topic": answer.topic,
        "outcome": answer.outcome,
        "source_timestamp_ns": str(answer.source_timestamp_ns),
        "publication_sequence_number": str(answer.sequence),
        **answer.values,
    }
    status.values = [KeyValue(key=key, value=str(value)) for key, value in pairs.items()]
    return status


def command_answers(array: DiagnosticArray) -> list[CommandAnswer]:
    """The answers in a `sail/command_status` message, in the order handled."""
    answers = []
    for status in array.status:
        pairs = {pair.key: pair.value for pair in status.values}
        if "outcome" in pairs and "topic" in pairs:
            answers.append(
                CommandAnswer(
                    topic=pairs.pop("topic"),
                    outcome=pairs.pop("outcome"),
                    message=status.message,
                    source_timestamp_ns=int(pairs.pop("source_timestamp_ns")),
                    sequence=int(pairs.pop("publication_sequence_number")),
                    values=pairs,
                )
            )
    return answers
