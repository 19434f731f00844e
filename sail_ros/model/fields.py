"""Configuration tables: every field declared once, with its unit, range and meaning.

A configuration (`SailParameters`, the simulator's policy and settings, the recorder's,
replay's and bridge's parameters) is a frozen dataclass whose fields are declared with
`setting(default, unit, doc, ...)`. A field under its name (a ROS parameter, a `--set`
name) is a `Setting`, the one setting type: it checks a value (`Setting.check`, the same
for the model's constructor, a node's parameters at start and at run time, and the
tools' `--set`), and gives the text of the ROS parameter descriptor
(`ros.parameters.descriptor`), the help lines (`option_help`, `parameter_help`) and the
documentation tables (`markdown_table`). Errors name the field, the value and the
allowed range: `sail_side must be in (0, 10000] m, got 0.0`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence


class ConfigError(ValueError):
    """A parameter or option has a value the program cannot use; the message names it."""


@dataclasses.dataclass(frozen=True)
class Spec:
    """What a field may hold.

    Attributes:
        unit: SI unit of the value ("-" for a pure number, "" for text or a flag).
        doc: what it is, one sentence (the unit is added where shown).
        minimum, maximum: bounds of the value (or of each element of a list).
        above_minimum: the minimum itself is excluded (`> minimum`).
        read_only: for a ROS parameter: fixed once the node has started.
        sizes: the allowed lengths of a list value.
        choices: the allowed values of a text.
        short: a further command-line spelling of a node's option ("-o").
        item_type: the type of each item of a list whose default is empty.
    """

    unit: str
    doc: str
    minimum: float | None = None
    maximum: float | None = None
    above_minimum: bool = False
    read_only: bool = True
    sizes: tuple[int, ...] = ()
    choices: tuple[str, ...] = ()
    short: str | None = None
    item_type: type = float


def setting(default, unit: str, doc: str, **constraints) -> dataclasses.Field:
    """A dataclass field with its `Spec` (a list default is copied per instance)."""
    spec = Spec(unit, doc, **constraints)
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata={"spec": spec})
    return dataclasses.field(default=default, metadata={"spec": spec})


def spec_of(field: dataclasses.Field) -> Spec:
    return field.metadata["spec"]


def default_of(field: dataclasses.Field):
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return field.default


def fields_of(cls_or_instance) -> tuple[dataclasses.Field, ...]:
    """The declared fields (those with a `Spec`)."""
    return tuple(f for f in dataclasses.fields(cls_or_instance) if "spec" in f.metadata)


def kind_of(default) -> type:
    """The type a field holds, from its default: bool, int, float, str, or list."""
    return list if isinstance(default, list | tuple) else type(default)


def range_text(spec: Spec, integer: bool = False) -> str:
    """`(0, 1e+04] m`, `>= 0 1/s`, or "" without bounds; an `integer`'s bounds in full."""
    unit = f" {spec.unit}" if spec.unit not in ("", "-") else ""
    low, high = spec.minimum, spec.maximum
    if low is None and high is None:
        return ""

    def number(value: float) -> str:
        return str(int(value)) if integer else f"{value:g}"

    if high is None:
        return f"{'>' if spec.above_minimum else '>='} {number(low)}{unit}"
    if low is None:
        return f"<= {number(high)}{unit}"
    return f"{'(' if spec.above_minimum else '['}{number(low)}, {number(high)}]{unit}"


def check_value(name: str, value, default, spec: Spec):
    """`value` as the field's type (an integer where a float is declared becomes that
    float, as ROS users type `-p time_scale:=2`; a list becomes a list of floats or
    texts), or ValueError naming `name`, the value and what is allowed."""
    kind = kind_of(default)
    if kind is list:
        return _check_list(name, value, default, spec)
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{name} must be true or false, got {value!r}")
        return value
    if kind is str:
        if not isinstance(value, str):
            raise ValueError(f"{name} must be a text, got {value!r}")
        if spec.choices and value not in spec.choices:
            raise ValueError(f"{name} must be one of {', '.join(spec.choices)}, got {value!r}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(
                f"{name} must be an integer {_range_phrase(spec, integer=True)}, got {value!r}"
            )
        _check_range(name, value, spec, integer=True)
        return value
    return _check_number(name, value, spec)


def _check_number(name: str, value, spec: Spec) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    _check_range(name, value, spec)
    return value


def _check_list(name: str, value, default, spec: Spec) -> list:
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | tuple):
        try:
            value = list(value)  # a numpy array
        except TypeError:
            raise ValueError(
                f"{name} must be a list, like {list(default)!r}; got {value!r}"
            ) from None
    items = list(value)
    if spec.sizes and len(items) not in spec.sizes:
        raise ValueError(
            f"{name} must hold {' or '.join(map(str, spec.sizes))} values, "
            f"got {len(items)}: {items!r}"
        )
    if default and isinstance(default[0], str):
        if not all(isinstance(item, str) for item in items):
            raise ValueError(f"{name} must be a list of texts, got {items!r}")
        return items
    return [_check_number(f"{name}[{i}]", item, spec) for i, item in enumerate(items)]


def _check_range(name: str, value, spec: Spec, integer: bool = False) -> None:
    low, high = spec.minimum, spec.maximum
    below = low is not None and (value <= low if spec.above_minimum else value < low)
    above = high is not None and value > high
    if below or above:
        what = "an integer " if integer else ""
        raise ValueError(f"{name} must be {what}{_range_phrase(spec, integer)}, got {value!r}")


def _range_phrase(spec: Spec, integer: bool = False) -> str:
    text = range_text(spec, integer)
    return text if text[:1] in "<>" else f"in {text}" if text else "of any value"


def check_fields(instance, prefix: str = "") -> None:
    """Check every declared field of a frozen dataclass instance and store its value as
    the field's type (call from `__post_init__`)."""
    for field in fields_of(instance):
        value = check_value(
            prefix + field.name, getattr(instance, field.name), default_of(field), spec_of(field)
        )
        object.__setattr__(instance, field.name, value)


@dataclasses.dataclass(frozen=True)
class Setting:
    """A table's field under its name: a ROS parameter of a node, a `--set` name of a tool
    (`sail.<field>` for the sail's fields in the simulator)."""

    name: str
    default: object
    spec: Spec

    @classmethod
    def of(cls, name: str, field: dataclasses.Field) -> Setting:
        return cls(name, default_of(field), spec_of(field))

    @property
    def description(self) -> str:
        """The meaning, with the unit in brackets: a ROS descriptor's description."""
        return self.spec.doc + (f" [{self.spec.unit}]" if self.spec.unit else "")

    @property
    def is_list(self) -> bool:
        return isinstance(self.default, list)

    @property
    def element_type(self) -> type:
        """The type of the value, or of each element of a list."""
        if self.is_list:
            return type(self.default[0]) if self.default else self.spec.item_type
        return type(self.default)

    @property
    def options(self) -> list[str]:
        """A node's command-line spellings: `--<name-with-dashes>` (and `short`)."""
        long = "--" + self.name.replace("_", "-")
        return [self.spec.short, long] if self.spec.short else [long]

    def constraints(self) -> str:
        """The constraints a range cannot say, as text: list sizes, choices."""
        if self.spec.sizes:
            limits = range_text(dataclasses.replace(self.spec, unit=""))
            within = f", each {limits}" if limits else ""
            booms = " (booms a, b, c, d)" if 4 in self.spec.sizes else ""
            return f"{' or '.join(map(str, self.spec.sizes))} values{booms}{within}"
        if self.spec.choices:
            return "one of: " + ", ".join(self.spec.choices)
        return ""

    def limits(self) -> str:
        """What the value may be, as text ("" for anything of its type)."""
        plain = dataclasses.replace(self.spec, unit="")
        return self.constraints() or range_text(plain, self.element_type is int)

    def check(self, value):
        """`value` as the setting's type, or ConfigError naming it, the value and what is
        allowed (`check_value`)."""
        default = self.default if self.default != [] else [self.spec.item_type()]
        try:
            return check_value(self.name, value, default, self.spec)
        except ValueError as error:
            raise ConfigError(str(error)) from None

    def option_help(self) -> str:
        """`name [unit] (default 0.1, range [0, 1]): doc`, a tool's `--set` help."""
        spec = self.spec
        unit = f" [{spec.unit}]" if spec.unit else ""
        limits = range_text(spec)
        within = f", {limits}" if limits else ""
        choices = f", one of {', '.join(spec.choices)}" if spec.choices else ""
        return f"{self.name}{unit} (default {self.default!r}{within}{choices}): {spec.doc}"

    def parameter_help(self) -> str:
        """`  name (default 0.1, read-only; limits): description`, a node's `--help`."""
        flags = ", read-only" if self.spec.read_only else ""
        limits = self.limits()
        limits = f"; {limits}" if limits else ""
        return f"  {self.name} (default {self.default!r}{flags}{limits}): {self.description}"


def settings_of(table, prefix: str = "") -> list[Setting]:
    """The settings of a table (its fields, each named `prefix` + its name)."""
    return [Setting.of(prefix + field.name, field) for field in fields_of(table)]


def table_cell(text: str) -> str:
    """`text` for a cell of a Markdown table: its `|` escaped."""
    return text.replace("|", "\\|")


def markdown_table(settings, writable: bool = False) -> str:
    """Settings as a Markdown table: name, default, unit, range, (writable,) meaning.

    Args:
        settings: `Setting`s, e.g. `settings_of(SailParameters)`.
        writable: add a column saying whether a ROS parameter may change at run time.
    """
    header = ["name", "default", "unit", "range", *(["writable"] if writable else []), "meaning"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for setting_ in settings:
        name, spec = setting_.name, setting_.spec
        limits = table_cell(range_text(spec))
        if spec.sizes:
            each = f", each {limits}" if limits else ""
            limits = f"{' or '.join(map(str, spec.sizes))} values{each}"
        cells = [f"`{name}`", f"{setting_.default!r}", spec.unit or "–", limits or "–"]
        if writable:
            cells.append("no" if spec.read_only else "yes")
        cells.append(table_cell(spec.doc))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
