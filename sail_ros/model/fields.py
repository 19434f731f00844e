"""Configuration tables: every field declared once, with its unit, range and meaning.

A configuration (`SailParameters`, the simulator's policy and settings) is a frozen
dataclass whose fields are declared with `setting(default, unit, doc, ...)`. That one
declaration gives the check of a value (`check_value`, the same for the model's
constructor, the simulator's ROS parameters and the tools' `--set`), the text of the
ROS parameter descriptor, the `--set` help and the documentation tables
(`help_line`, `markdown_table`). Errors name the field, the value and the allowed
range: `sail_side must be in (0, 10000] m, got 0.0`.
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
    """

    unit: str
    doc: str
    minimum: float | None = None
    maximum: float | None = None
    above_minimum: bool = False
    read_only: bool = True
    sizes: tuple[int, ...] = ()
    choices: tuple[str, ...] = ()


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


def help_line(name: str, field: dataclasses.Field) -> str:
    """`name [unit] (default 0.1, range [0, 1]): doc` for --help texts."""
    spec = spec_of(field)
    unit = f" [{spec.unit}]" if spec.unit else ""
    limits = range_text(spec)
    within = f", {limits}" if limits else ""
    choices = f", one of {', '.join(spec.choices)}" if spec.choices else ""
    return f"{name}{unit} (default {default_of(field)!r}{within}{choices}): {spec.doc}"


def table_cell(text: str) -> str:
    """`text` for a cell of a Markdown table: its `|` escaped."""
    return text.replace("|", "\\|")


def markdown_table(named_fields, writable: bool = False) -> str:
    """Fields as a Markdown table: name, default, unit, range, (writable,) meaning.

    Args:
        named_fields: `(name, field)` pairs, e.g. `((f.name, f) for f in fields_of(cls))`.
        writable: add a column saying whether a ROS parameter may change at run time.
    """
    header = ["name", "default", "unit", "range", *(["writable"] if writable else []), "meaning"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, field in named_fields:
        spec = spec_of(field)
        limits = table_cell(range_text(spec))
        if spec.sizes:
            each = f", each {limits}" if limits else ""
            limits = f"{' or '.join(map(str, spec.sizes))} values{each}"
        cells = [f"`{name}`", f"{default_of(field)!r}", spec.unit or "–", limits or "–"]
        if writable:
            cells.append("no" if spec.read_only else "yes")
        cells.append(table_cell(spec.doc))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
