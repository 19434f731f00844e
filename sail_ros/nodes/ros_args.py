"""Running a node from a tool `main`: command line, parameters, stop signals, types.

A tool declares its ROS parameters once, as `ParamSpec`s; from them come the
declared parameters (with descriptions, ranges, read-only flags) and
command-line options `--<name-with-dashes>` that override them. ROS
arguments (`--ros-args -p name:=value --params-file f.yaml ...`) work as
usual; an option given on the command line wins over them.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import signal
import threading

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.logging import get_logger
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

_TYPES = {
    bool: Parameter.Type.BOOL,
    int: Parameter.Type.INTEGER,
    float: Parameter.Type.DOUBLE,
    str: Parameter.Type.STRING,
    list: Parameter.Type.STRING_ARRAY,  # the only array kind the tools use
}


class ConfigError(ValueError):
    """A parameter has a value a node cannot use; the message names it."""


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """One ROS parameter of a tool.

    `default` fixes the type (bool, int, float, str, or list of str);
    `minimum`/`maximum` become the descriptor's range; `choices` are checked
    by `declare`. Units belong in `description`.
    """

    name: str
    default: object
    description: str
    read_only: bool = True
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = ()
    short: str | None = None  # e.g. "-o", an extra command-line spelling

    @property
    def options(self) -> list[str]:
        long = "--" + self.name.replace("_", "-")
        return [self.short, long] if self.short else [long]

    def descriptor(self) -> ParameterDescriptor:
        return parameter_descriptor(
            self.name, _TYPES[type(self.default)], self.description, self.read_only,
            self.minimum, self.maximum,
            integer=isinstance(self.default, int) and not isinstance(self.default, bool),
            constraints="one of: " + ", ".join(self.choices) if self.choices else "")


def parameter_descriptor(name: str, kind: Parameter.Type, description: str, read_only: bool,
                         minimum: float | None = None, maximum: float | None = None,
                         integer: bool = False, constraints: str = "") -> ParameterDescriptor:
    """A ParameterDescriptor; a bound given (`minimum`, `maximum`) becomes an integer
    range if `integer`, else a floating-point range (a missing bound: the widest)."""
    descriptor = ParameterDescriptor(name=name, type=kind.value, description=description,
                                     read_only=read_only, additional_constraints=constraints)
    if minimum is not None or maximum is not None:
        if integer:
            descriptor.integer_range = [IntegerRange(
                from_value=int(minimum if minimum is not None else -(2**63)),
                to_value=int(maximum if maximum is not None else 2**63 - 1), step=0)]
        else:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(minimum if minimum is not None else -1e308),
                to_value=float(maximum if maximum is not None else 1e308), step=0.0)]
    return descriptor


def make_parser(prog: str, description: str, specs: list[ParamSpec]) -> argparse.ArgumentParser:
    """An argparse parser with one option per parameter (defaults None: unset)."""
    parser = argparse.ArgumentParser(
        prog=prog, description=description,
        epilog="Every option is also the ROS parameter of the same name with '_' for '-' "
               "(--ros-args -p name:=value, or --ros-args --params-file file.yaml); "
               "an option given here wins.")
    for spec in specs:
        kind = type(spec.default)
        help_text = f"{spec.description} (default: {spec.default!r})"
        if kind is bool:
            parser.add_argument(*spec.options, dest=spec.name, default=None,
                                action=argparse.BooleanOptionalAction, help=help_text)
        elif kind is list:
            parser.add_argument(*spec.options, dest=spec.name, default=None, nargs="+",
                                metavar="NAME", help=help_text)
        else:
            parser.add_argument(*spec.options, dest=spec.name, default=None, type=kind,
                                choices=spec.choices or None, help=help_text)
    return parser


def parse_command_line(parser: argparse.ArgumentParser, prog: str, argv: list[str]):
    """Parse the non-ROS part of `argv`; returns (namespace, args for rclpy.init).

    Raises:
        SystemExit: --help, or a bad option (argparse prints the message).
    """
    ros_argv = [prog, *argv]
    try:
        own_args = remove_ros_args(ros_argv)[1:]
    except _rclpy.RCLInvalidROSArgsError as error:
        parser.error(f"invalid ROS arguments: {error}")
    return parser.parse_args(own_args), ros_argv


def overrides(namespace: argparse.Namespace, specs: list[ParamSpec]) -> list[Parameter]:
    """The parameters set on the command line, as node parameter overrides."""
    chosen = []
    for spec in specs:
        value = getattr(namespace, spec.name, None)
        if value is not None:
            chosen.append(Parameter(spec.name, _TYPES[type(spec.default)], value))
    return chosen


def declare(node, specs: list[ParamSpec]) -> dict[str, object]:
    """Declare `specs` on `node` and return their values.

    Raises:
        ConfigError: a value has the wrong type, is out of range or not a choice.
    """
    values = {}
    for spec in specs:
        # an empty list would be declared as a byte array: declare the type instead
        initial = spec.default if spec.default != [] else Parameter.Type.STRING_ARRAY
        try:
            parameter = node.declare_parameter(spec.name, initial, spec.descriptor())
        except ParameterException as error:
            raise ConfigError(f"parameter {spec.name}: {error}") from None
        value = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else spec.default
        if spec.choices and value not in spec.choices:
            raise ConfigError(f"{spec.name} must be one of {', '.join(spec.choices)}, "
                              f"got {value!r}")
        values[spec.name] = list(value) if isinstance(spec.default, list) else value
    return values


class StopSignals:
    """While active, SIGINT and SIGTERM set `event` instead of raising.

    Use with `rclpy.init(..., signal_handler_options=SignalHandlerOptions.NO)`
    so that the tool, not rclpy, decides how to shut down (drain, close files).
    """

    def __init__(self):
        self.event = threading.Event()
        self.received: str | None = None
        self._previous = {}

    def __enter__(self) -> StopSignals:
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc_info) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _handle(self, signum, frame) -> None:
        self.received = signal.Signals(signum).name
        self.event.set()


def run_node(name: str, parser: argparse.ArgumentParser, argv: list[str], body) -> int:
    """A node tool's `main`: the exit code of `body(namespace, stop)`.

    Parses `argv` (tool options, then `--ros-args ...`; `--help` or a bad option
    ends here), holds SIGINT/SIGTERM in `stop` (a `StopSignals`), starts rclpy
    without its own signal handlers and shuts it down at the end. A
    `ConfigError` (a parameter the node cannot use) is logged and gives exit 2.
    """
    try:
        namespace, ros_argv = parse_command_line(parser, name, argv)
    except SystemExit as exit_:
        return exit_.code if isinstance(exit_.code, int) else 2
    with StopSignals() as stop:
        rclpy.init(args=ros_argv, signal_handler_options=SignalHandlerOptions.NO)
        try:
            return body(namespace, stop)
        except ConfigError as error:
            get_logger(name).error(str(error))
            return 2
        finally:
            rclpy.try_shutdown()


def message_class(type_name: str):
    """The Python class of the message type `pkg/msg/Type`.

    Raises:
        ImportError: the package's Python module is not installed.
        ValueError: `type_name` is not of that form.
    """
    parts = type_name.split("/")
    if len(parts) != 3:
        raise ValueError(f"type name must look like 'pkg/msg/Type', got {type_name!r}")
    package, namespace, name = parts
    try:
        return getattr(importlib.import_module(f"{package}.{namespace}"), name)
    except AttributeError:
        raise ImportError(f"{package}.{namespace} has no {name}") from None
