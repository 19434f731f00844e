"""`/diagnostics`: the simulator's integrator status, and its values read back
(keys in `sail_ros.status`)."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from sail_ros.topics import SIM_NODE, integrator_status_name, stamp

LEVELS = {"OK": DiagnosticStatus.OK, "WARN": DiagnosticStatus.WARN, "ERROR": DiagnosticStatus.ERROR}


def diagnostics(
    stamp_ns_: int,
    level: str,
    message: str,
    values: dict,
    node: str = SIM_NODE,
    name: str | None = None,
) -> DiagnosticArray:
    """`/diagnostics`: one status `<node>: integrator` (`integrator_status_name`), or
    `name`.

    Args:
        stamp_ns_: stamp [ns].
        level: "OK", "WARN" or "ERROR".
        message: one line saying why the level is what it is.
        values: key -> value, written with `str` (round floats before).
        node: the publishing node's fully qualified name (also the hardware_id).
        name: the status's name (default the simulator's integrator status).
    """
    status = DiagnosticStatus(
        level=LEVELS[level],
        name=integrator_status_name(node) if name is None else name,
        message=message,
        hardware_id=node.lstrip("/"),
    )
    status.values = [KeyValue(key=key, value=str(value)) for key, value in values.items()]
    array = DiagnosticArray(status=[status])
    array.header.stamp = stamp(stamp_ns_)
    return array


def diagnostic_values(array: DiagnosticArray, node: str = SIM_NODE) -> dict[str, str]:
    """The key/value pairs of the integrator status of simulator `node` (its fully
    qualified name) in `array`; empty if absent."""
    wanted = integrator_status_name(node)
    for status in array.status:
        if status.name == wanted:
            return {pair.key: pair.value for pair in status.values}
    return {}
