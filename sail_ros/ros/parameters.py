"""The ROS parameters of every node: one table entry each, one descriptor, one check.

A node declares the settings of its tables (`model.fields.Setting`: the simulator's
`runtime.config.PARAMETERS`, the controller's, the recorder's, replay's and bridge's
settings). From a setting come the declared parameter (a `ParameterDescriptor` whose
text carries the unit, the range, the array sizes or choices, and `read_only` where
the value fixes the model or the time grid: `descriptor`), the check of a value
(`Setting.check`, the same at start-up, on every change at run time and in the offline
tools), and for the tools the command-line option `--<name-with-dashes>` that
overrides it.

A double parameter takes an integer value as ROS users type it
(`-p time_scale:=2`): at declaration the override is read as a double, and at run
time a pre-set callback turns an integer into a double before rclpy checks the
type.
"""

from __future__ import annotations

import argparse
import contextlib
import textwrap

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from sail_ros.model.fields import ConfigError, Setting
from sail_ros.spelling import did_you_mean

_SCALAR_TYPES = {
    bool: Parameter.Type.BOOL,
    int: Parameter.Type.INTEGER,
    float: Parameter.Type.DOUBLE,
    str: Parameter.Type.STRING,
}
_ARRAY_TYPES = {float: Parameter.Type.DOUBLE_ARRAY, str: Parameter.Type.STRING_ARRAY}


def kind(setting: Setting) -> Parameter.Type:
    """The ROS parameter type of `setting`."""
    if setting.is_list:
        return _ARRAY_TYPES[setting.element_type]
    return _SCALAR_TYPES[type(setting.default)]


def descriptor(setting: Setting) -> ParameterDescriptor:
    """The ROS parameter descriptor of `setting`: its description with the unit, its
    range (of each element of a list), list sizes or choices, and whether it is read-only."""
    spec = setting.spec
    found = ParameterDescriptor(
        name=setting.name,
        type=kind(setting).value,
        description=setting.description,
        read_only=spec.read_only,
        additional_constraints=setting.constraints(),
    )
    if spec.minimum is not None or spec.maximum is not None:  # of each element of a list
        if setting.element_type is int:
            low = int(spec.minimum if spec.minimum is not None else -(2**63))
            high = int(spec.maximum if spec.maximum is not None else 2**63 - 1)
            found.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
        else:
            low = float(spec.minimum if spec.minimum is not None else -1e308)
            high = float(spec.maximum if spec.maximum is not None else 1e308)
            found.floating_point_range = [
                FloatingPointRange(from_value=low, to_value=high, step=0.0)
            ]
    return found


def node_options(parameter_overrides=(), context=None, namespace=None) -> dict:
    """The keyword arguments of rclpy's `Node` for a node of this package: its overrides,
    context and namespace, and undeclared parameters allowed so that `declare` can
    refuse an unknown one by its name.

    Args:
        parameter_overrides: initial parameter values (besides --ros-args).
        context: the rclpy context (default: the global one).
        namespace: the node's namespace (default: from --ros-args, else "/").
    """
    return {
        "context": context,
        "namespace": namespace,
        "parameter_overrides": list(parameter_overrides),
        "allow_undeclared_parameters": True,
    }


@contextlib.contextmanager
def destroyed_if_refused(node: Node):
    """Destroy `node` (as rclpy's `Node`) if the block raises, then let the error go on:
    a node refused while it is set up is destroyed there, not by the garbage collector
    after rclpy has shut down (which can abort the process on its way out)."""
    try:
        yield
    except BaseException:
        Node.destroy_node(node)
        raise


def declare(node, specs: list[Setting]) -> dict[str, object]:
    """Declare the settings `specs` on `node`, check their values and return them (lists as lists);
    from then on the node refuses, by name, any change of a parameter it lacks (create
    it with `allow_undeclared_parameters=True` so that rclpy lets it answer).

    Raises:
        ConfigError: a value has the wrong type, is out of range or not a choice, or
            a parameter was given that the node does not have.
    """
    values = {}
    # rclpy keeps the values given on the command line or to the constructor here, and
    # offers no other way to see them before declaring (tested in test_parameters_strict)
    given = node._parameter_overrides
    for spec in specs:
        # an empty list would be declared as a byte array: declare the type instead
        initial = spec.default if spec.default != [] else kind(spec)
        override = given.get(spec.name)
        ignore_override = False
        if override is not None and _as_double(spec, override) is not None:
            initial, ignore_override = _as_double(spec, override).value, True
        try:
            parameter = node.declare_parameter(
                spec.name, initial, descriptor(spec), ignore_override=ignore_override
            )
        except ParameterException as error:
            raise ConfigError(f"parameter {spec.name}: {error}") from None
        value = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else spec.default
        values[spec.name] = spec.check(list(value) if spec.is_list else value)
    reject_unknown(node)
    refuse_unknown_changes(node)
    by_name = {spec.name: spec for spec in specs}
    node.add_pre_set_parameters_callback(
        lambda parameters: [
            _as_double(by_name.get(p.name), p) or p for p in parameters
        ]  # fmt: skip
    )
    return values


def _as_double(spec: Setting | None, parameter: Parameter) -> Parameter | None:
    """An integer (or integer array) given to a double parameter, as doubles; else None."""
    if spec is None or spec.element_type is not float:
        return None
    if parameter.type_ == Parameter.Type.INTEGER:
        return Parameter(parameter.name, Parameter.Type.DOUBLE, float(parameter.value))
    if parameter.type_ == Parameter.Type.INTEGER_ARRAY:
        values = [float(v) for v in parameter.value]
        return Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY, values)
    return None


def make_parser(
    prog: str, description: str, specs: list[Setting], examples=()
) -> argparse.ArgumentParser:
    """An argparse parser with one option per parameter (defaults None: unset); its
    `--help` ends with the `examples` (commands, one a line)."""
    epilog = textwrap.fill(
        "Every option is also the ROS parameter of the same name with '_' for '-' "
        "(--ros-args -p name:=value, or --ros-args --params-file file.yaml); "
        "an option given here wins.",
        88,
    )
    if examples:
        epilog += "\n\nExamples:\n" + "\n".join(f"  {line}" for line in examples)
    parser = argparse.ArgumentParser(
        prog=prog,
        description=description,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=epilog,
    )
    for spec in specs:
        limits = spec.limits()
        limits = f"{limits}; " if limits and not spec.spec.choices else ""
        help_text = f"{spec.description} ({limits}default: {spec.default!r})"
        if spec.element_type is bool:
            parser.add_argument(
                *spec.options,
                dest=spec.name,
                default=None,
                action=argparse.BooleanOptionalAction,
                help=help_text,
            )
        elif spec.is_list:
            parser.add_argument(
                *spec.options,
                dest=spec.name,
                default=None,
                nargs="+",
                type=spec.element_type,
                metavar="VALUE" if spec.element_type is float else "NAME",
                help=help_text,
            )
        else:
            parser.add_argument(
                *spec.options,
                dest=spec.name,
                default=None,
                type=spec.element_type,
                choices=spec.spec.choices or None,
                help=help_text,
            )
    return parser


def overrides(namespace: argparse.Namespace, specs: list[Setting]) -> list[Parameter]:
    """The parameters set on the command line, as node parameter overrides."""
    chosen = []
    for spec in specs:
        value = getattr(namespace, spec.name, None)
        if value is not None:
            chosen.append(Parameter(spec.name, kind(spec), value))
    return chosen


# -- strictness: no parameter goes unnoticed ------------------------------------------------


def reject_unknown(node) -> None:
    """Stop a node given a parameter it does not have (from `-p`, a params file or
    the constructor): a misspelt name would otherwise be ignored without a word.

    Call after every parameter is declared. Raises ConfigError naming each unknown
    parameter, with the closest known name.
    """
    given = node._parameter_overrides  # rclpy keeps what it was given here
    unknown = sorted(name for name in given if not node.has_parameter(name))
    if unknown:
        known = list(node._parameters)
        raise ConfigError(
            f"unknown parameter(s) of {node.get_name()}: "
            + ", ".join(f"{name!r}{did_you_mean(name, known)}" for name in unknown)
        )


def refuse_unknown_changes(node) -> None:
    """Refuse, naming it, a run-time change of a parameter the node does not have (the
    node must allow undeclared parameters, or rclpy refuses without the name)."""

    def check(parameters) -> SetParametersResult:
        for parameter in parameters:
            if not node.has_parameter(parameter.name):
                reason = f"unknown parameter {parameter.name!r}" + did_you_mean(
                    parameter.name, list(node._parameters)
                )
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(check)
