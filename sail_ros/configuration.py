"""The sail and the limits a program runs with: one merge of its layers, one precedence.

Every program takes the same order, lowest first: the defaults, then a params or
scenario file, then the command line (the tools' `--set`; the nodes' `-p`, which rcl
lays over their params file before `runtime.config.config_from_values` checks the
whole set). `merge` takes the layers in that order and checks each value where it is
given, so a bad one is named with its source (a file, a scenario's sail section; a
name typed on the command line names itself). A file is read as the simulator would
read it (`file_layer`): a sail parameters file gives the sail, the simulator's params
file its sail (what it leaves out, the simulator's defaults) and its limits, by the
names the node declares (`sail.<field>`, converted by `model.parameters.sail_fields`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

from sail_ros.model import SailParameters, yaml_values
from sail_ros.model.fields import Setting, fields_of
from sail_ros.model.parameters import SIMULATOR_NODE, sail_fields, sail_section
from sail_ros.policy import Policy
from sail_ros.runtime.config import PARAMETERS, SIM_DEFAULTS
from sail_ros.spelling import did_you_mean

# parameters every rclpy node has besides its own
NODE_BUILT_INS = ("use_sim_time", "start_type_description_service")
LIMITS = {field.name: Setting.of(field.name, field) for field in fields_of(Policy)}


@dataclasses.dataclass(frozen=True)
class Layer:
    """What one source gives.

    Attributes:
        source: its name in errors ("" for the command line, whose names say it).
        sail: fields of `SailParameters` -> value.
        policy: fields of `Policy` (the limits) -> value.
    """

    source: str
    sail: Mapping = dataclasses.field(default_factory=dict)
    policy: Mapping = dataclasses.field(default_factory=dict)


def merge(layers: Sequence[Layer]) -> tuple[SailParameters, Policy]:
    """The sail and the limits of `layers`, lowest precedence first (a later layer's value
    replaces an earlier one's).

    Raises:
        ValueError: a bad name or value, named with its layer's source (even where a
            later layer replaces it: the source holds a mistake); limits that disagree
            with each other (`Policy`), as the whole merge.
    """
    sail, policy = {}, {}
    for layer in layers:
        try:
            SailParameters.from_dict(layer.sail)
            for name, value in layer.policy.items():
                if name not in LIMITS:
                    raise ValueError(f"unknown limit {name!r}{did_you_mean(name, LIMITS)}")
                LIMITS[name].check(value)
        except ValueError as error:
            raise ValueError(f"{layer.source}: {error}" if layer.source else str(error)) from None
        sail.update(layer.sail)
        policy.update(layer.policy)
    return SailParameters.from_dict(sail), Policy(**policy)


def file_layer(path) -> Layer:
    """The layer of a parameters file: a sail parameters file (the fields of
    `SailParameters`, at top level or under `sail:`) or the simulator's params file (what
    the simulator would take of it: its sail and its limits).

    Raises:
        ValueError: the file cannot be read, is no YAML, or names what the simulator
            does not have (`simulator_parameters`), naming it.
    """
    document = yaml_values.load_file(path, "config")
    given = simulator_parameters(document, path)
    if given is None:  # a sail parameters file
        return Layer(str(path), sail_section(document or {}, Path(path)))
    limits = {name: value for name, value in given.items() if name in LIMITS}
    # what the file leaves out, the simulator's default (its live sail differs from the table's)
    return Layer(str(path), sail_fields({**SIM_DEFAULTS, **given}), limits)


def simulator_parameters(document, path) -> dict | None:
    """The parameters a ROS 2 params file (`<node>: ros__parameters: ...`; its YAML
    `document`, read from `path`, which errors name) gives the simulator (its sections
    for `sail_sim`, in any namespace, and for every node, `/**`), by the names the node
    declares (`sail.n_boom_modes`), nested mappings flattened as ROS does; None for a
    document that is not a params file.

    Raises:
        ValueError: the file names a parameter the simulator does not have (which the
            simulator refuses, `ros.parameters.reject_unknown`), or holds no section it
            would read, naming them.
    """
    given = yaml_values.node_parameters(document, SIMULATOR_NODE, path)
    if given is None:
        return None
    known = set(PARAMETERS) | set(NODE_BUILT_INS)
    unknown = [f"{name!r}{did_you_mean(name, known)}" for name in sorted(set(given) - known)]
    if unknown:
        raise ValueError(f"{path}: unknown parameter(s) of {SIMULATOR_NODE}: {', '.join(unknown)}")
    return given
