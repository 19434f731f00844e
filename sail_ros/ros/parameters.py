"""The ROS parameters of every node: one table entry each, one descriptor, one check.

A node lists its parameters as `ParamSpec`s, made from the field tables
(`ParamSpec.of`: the simulator's `runtime.config.PARAMETERS`) or written out
(the recorder's and replay's). From a spec come the declared parameter (a
`ParameterDescriptor` whose text carries the unit, the range, the array sizes
or choices, and `read_only` where the value fixes the model or the time grid),
the check of a value (`ParamSpec.check`: `model.fields.check_value`, the same at
start-up, on every change at run time and in the offline tools), and for the
tools the command-line option `--<name-with-dashes>` that overrides it.

A double parameter takes an integer value as ROS users type it
(`-p time_scale:=2`): at declaration the override is read as a double, and at run
time a pre-set callback turns an integer into a double before rclpy checks the
type.
"""

from __future__ import annotations

import argparse
import dataclasses
import textwrap

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.exceptions import ParameterException
from rclpy.parameter import Parameter

from sail_ros.model.fields import ConfigError, Spec, check_value, range_text, spec_of
from sail_ros.ros.cli import suggestion

_SCALAR_TYPES = {
    bool: Parameter.Type.BOOL,
    int: Parameter.Type.INTEGER,
    float: Parameter.Type.DOUBLE,
    str: Parameter.Type.STRING,
}
_ARRAY_TYPES = {float: Parameter.Type.DOUBLE_ARRAY, str: Parameter.Type.STRING_ARRAY}


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """One ROS parameter.

    `default` fixes the type: bool, int, float, str, or a list of float or str
    (`item_type` says which for an empty default). `minimum`/`maximum` bound
    the value (each element of a list of numbers); `sizes` are the allowed
    list lengths; `choices` the allowed strings. Units belong in `description`.
    """

    name: str
    default: object
    description: str
    read_only: bool = True
    minimum: float | None = None
    maximum: float | None = None
    sizes: tuple[int, ...] = ()
    choices: tuple[str, ...] = ()
    short: str | None = None  # e.g. "-o", an extra command-line spelling
    item_type: type = str  # of a list whose default is empty
    above_minimum: bool = False  # the minimum itself excluded

    @classmethod
    def of(cls, name: str, field) -> ParamSpec:
        """The ROS parameter `name` of a table field (`model.fields.setting`)."""
        spec = spec_of(field)
        default = field.default_factory() if callable(field.default_factory) else field.default
        unit = f" [{spec.unit}]" if spec.unit else ""
        return cls(
            name,
            default,
            spec.doc + unit,
            spec.read_only,
            spec.minimum,
            spec.maximum,
            sizes=spec.sizes,
            choices=spec.choices,
            item_type=float,
            above_minimum=spec.above_minimum,
        )

    @property
    def spec(self) -> Spec:
        return Spec(
            "",
            self.description,
            self.minimum,
            self.maximum,
            self.above_minimum,
            self.read_only,
            self.sizes,
            self.choices,
        )

    @property
    def is_list(self) -> bool:
        return isinstance(self.default, list)

    @property
    def element_type(self) -> type:
        """The type of the value, or of each element of a list."""
        if self.is_list:
            return type(self.default[0]) if self.default else self.item_type
        return type(self.default)

    @property
    def kind(self) -> Parameter.Type:
        if self.is_list:
            return _ARRAY_TYPES[self.element_type]
        return _SCALAR_TYPES[type(self.default)]

    @property
    def options(self) -> list[str]:
        long = "--" + self.name.replace("_", "-")
        return [self.short, long] if self.short else [long]

    def constraints(self) -> str:
        """The constraints a range cannot say, as text."""
        if self.sizes:
            limits = range_text(self.spec)
            within = f", each {limits}" if limits else ""
            booms = " (booms a, b, c, d)" if 4 in self.sizes else ""
            return f"{' or '.join(map(str, self.sizes))} values{booms}{within}"
        if self.choices:
            return "one of: " + ", ".join(self.choices)
        return ""

    def descriptor(self) -> ParameterDescriptor:
        descriptor = ParameterDescriptor(
            name=self.name,
            type=self.kind.value,
            description=self.description,
            read_only=self.read_only,
            additional_constraints=self.constraints(),
        )
        if self.minimum is not None or self.maximum is not None:  # of each element of a list
            if self.element_type is int:
                low = int(self.minimum if self.minimum is not None else -(2**63))
                high = int(self.maximum if self.maximum is not None else 2**63 - 1)
                descriptor.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
            else:
                low = float(self.minimum if self.minimum is not None else -1e308)
                high = float(self.maximum if self.maximum is not None else 1e308)
                descriptor.floating_point_range = [
                    FloatingPointRange(from_value=low, to_value=high, step=0.0)
                ]
        return descriptor

    def limits(self) -> str:
        """What the value may be, as text ("" for anything of its type): the range, list
        sizes or choices the node enforces."""
        return self.constraints() or range_text(self.spec, self.element_type is int)

    def help_line(self) -> str:
        """One line for `--help`: name, default, read-only, what it may be, description."""
        flags = ", read-only" if self.read_only else ""
        limits = self.limits()
        limits = f"; {limits}" if limits else ""
        return f"  {self.name} (default {self.default!r}{flags}{limits}): {self.description}"

    def check(self, value):
        """`value` as the parameter's type, or ConfigError naming the parameter, the value
        and what is allowed (`model.fields.check_value`)."""
        default = self.default if self.default != [] else [self.item_type()]
        try:
            return check_value(self.name, value, default, self.spec)
        except ValueError as error:
            raise ConfigError(str(error)) from None


def node_options(parameter_overrides=(), context=None, namespace=None) -> dict:
    """The keyword arguments of rclpy's `Node` for a node of this package: its overrides,
    context and namespace, and undeclared parameters allowed so that `declare` can
    refuse an unknown one by its name."""
    return {
        "context": context,
        "namespace": namespace,
        "parameter_overrides": list(parameter_overrides),
        "allow_undeclared_parameters": True,
    }


def declare(node, specs: list[ParamSpec]) -> dict[str, object]:
    """Declare `specs` on `node`, check their values and return them (lists as lists);
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
        initial = spec.default if spec.default != [] else spec.kind
        override = given.get(spec.name)
        ignore_override = False
        if override is not None and _as_double(spec, override) is not None:
            initial, ignore_override = _as_double(spec, override).value, True
        try:
            parameter = node.declare_parameter(
                spec.name, initial, spec.descriptor(), ignore_override=ignore_override
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


def _as_double(spec: ParamSpec | None, parameter: Parameter) -> Parameter | None:
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
    prog: str, description: str, specs: list[ParamSpec], examples=()
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
        limits = f"{limits}; " if limits and not spec.choices else ""
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
                choices=spec.choices or None,
                help=help_text,
            )
    return parser


def overrides(namespace: argparse.Namespace, specs: list[ParamSpec]) -> list[Parameter]:
    """The parameters set on the command line, as node parameter overrides."""
    chosen = []
    for spec in specs:
        value = getattr(namespace, spec.name, None)
        if value is not None:
            chosen.append(Parameter(spec.name, spec.kind, value))
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
            + ", ".join(f"{name!r}{suggestion(name, known)}" for name in unknown)
        )


def refuse_unknown_changes(node) -> None:
    """Refuse, naming it, a run-time change of a parameter the node does not have (the
    node must allow undeclared parameters, or rclpy refuses without the name)."""

    def check(parameters) -> SetParametersResult:
        for parameter in parameters:
            if not node.has_parameter(parameter.name):
                reason = f"unknown parameter {parameter.name!r}" + suggestion(
                    parameter.name, list(node._parameters)
                )
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(check)
