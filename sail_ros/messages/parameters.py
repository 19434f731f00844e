"""A node's parameters as the logs keep them: each value as one line of YAML text.

From `rcl_interfaces` messages: the values a fetch answers (`yaml_texts`) and a
`ParameterEvent` (`parameter_update`), which the recorder stores and `report`
reads back from logs that have only `/parameter_events`.
"""

from __future__ import annotations

from rcl_interfaces.msg import ParameterEvent
from rclpy.parameter import parameter_value_to_python

from sail_ros.bag.recording import ParameterUpdate
from sail_ros.topics import stamp_ns_of, yaml_value


def yaml_texts(names, values) -> dict[str, str]:
    """Each parameter (`names`) as YAML text of its `rcl_interfaces/msg/ParameterValue`;
    unset ones left out."""
    texts = {}
    for name, value in zip(names, values, strict=True):
        python_value = parameter_value_to_python(value)
        if python_value is not None:  # NOT_SET
            texts[name] = yaml_value(python_value)
    return texts


def parameter_update(event: ParameterEvent, log_time_ns: int) -> ParameterUpdate:
    """The event's declared, changed and deleted parameters in plain values."""

    def texts(parameters):
        return yaml_texts([p.name for p in parameters], [p.value for p in parameters])

    return ParameterUpdate(
        time_ns=stamp_ns_of(event.stamp),
        log_time_ns=log_time_ns,
        declared=texts(event.new_parameters),
        changed=texts(event.changed_parameters),
        deleted=tuple(p.name for p in event.deleted_parameters),
    )
