"""The keys of the scenario and study files: declared once, checked and documented from there.

A section of a file (`scenario:`, a profile, a load step, `study:`, ...) is a
`Section`: its keys, each with its kind, unit, default, range and meaning. The
readers (`scenario`, `montecarlo`) check a mapping against its section (unknown
keys with the nearest known one, missing required keys, each number by its
range) and name every value by its path in the file, down to the element:
`scenario.loads[2].tip_forces.b must be a number, got 'x'`. docs/scenarios.md
holds the same sections as tables (`markdown`), checked against them by a test.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.model.fields import Spec, check_value, range_text, table_cell
from sail_ros.model.layout import BOOMS
from sail_ros.spelling import did_you_mean

REQUIRED = "required"

# kind -> how the documentation names it
KINDS = {
    "text": "text",
    "number": "number",
    "integer": "integer",
    "booms": "number or 4 (booms a, b, c, d)",
    "quadrants": "number or 4 (quadrants ab, bc, cd, da)",
    "times": "list of numbers",
    "waypoint lengths": "list: per time a number, or 4 (booms a..d)",
    "mapping": "mapping",
    "coordinates": "mapping of coordinate names, or a list of all n",
    "list": "list of mappings",
    "file or mapping": "file name or mapping",
    "distribution": "mapping (a distribution)",
}


@dataclasses.dataclass(frozen=True)
class Key:
    """One key of a section: `kind` (one of KINDS), `spec` (unit, meaning, range of a
    number or of each element), `default` (REQUIRED, or the value its absence means;
    `absent` says it in words where no value does)."""

    name: str
    kind: str
    spec: Spec
    default: object = REQUIRED
    absent: str = ""


def key(name, kind, unit, doc, default=REQUIRED, absent="", **constraints) -> Key:
    if kind not in KINDS:
        raise ValueError(f"key {name}: kind must be one of {', '.join(KINDS)}, got {kind!r}")
    return Key(name, kind, Spec(unit, doc, **constraints), default, absent)


@dataclasses.dataclass(frozen=True)
class Section:
    """The keys a mapping of a file may hold, and where it is (`path`, for the docs)."""

    path: str
    doc: str
    keys: tuple[Key, ...]

    def __getitem__(self, name: str) -> Key:
        return next(k for k in self.keys if k.name == name)

    def check_keys(self, mapping, where: str) -> dict:
        """`mapping` if it is a mapping of known keys holding every required one;
        ValueError naming `where` and the key otherwise."""
        if not isinstance(mapping, dict):
            raise ValueError(f"{where} must be a mapping, got {mapping!r}")
        known = [k.name for k in self.keys]
        unknown = [name for name in mapping if name not in known]
        if unknown:
            hint = did_you_mean(str(unknown[0]), known)
            raise ValueError(
                f"{where}: unknown key(s) {', '.join(map(repr, unknown))}{hint}; "
                f"known: {', '.join(known)}"
            )
        missing = [k.name for k in self.keys if k.default == REQUIRED and k.name not in mapping]
        if missing:
            raise ValueError(f"{where} needs {', '.join(missing)}")
        return mapping

    def number(self, mapping: dict, name: str, where: str):
        """The number at `mapping[name]` (or its default), checked by its key's range."""
        entry = self[name]
        value = mapping.get(name, entry.default)
        return check_number(value, f"{where}.{name}", entry.spec, entry.kind == "integer")

    def markdown(self) -> str:
        """The section as a Markdown table: key, kind, unit, default, range, meaning."""
        lines = [
            "| key | kind | unit | default | range | meaning |",
            "|---|---|---|---|---|---|",
        ]
        for entry in self.keys:
            limits = table_cell(range_text(entry.spec))
            lines.append(
                f"| `{entry.name}` | {KINDS[entry.kind]} | {entry.spec.unit or '–'} | "
                f"{_default_text(entry)} | {limits or '–'} | "
                f"{table_cell(entry.spec.doc)} |"
            )
        return "\n".join(lines)


def _default_text(entry: Key) -> str:
    if entry.absent:
        return entry.absent
    return "**required**" if entry.default == REQUIRED else f"`{entry.default!r}`"


def check_number(value, where: str, spec: Spec, integer: bool = False):
    """`value` as a float (or int), finite and within `spec`'s range; ValueError naming
    `where`: `scenario.duration must be > 0 s, got -1.0`."""
    return check_value(where, value, 0 if integer else 0.0, spec)


def check_each(value, where: str, names: tuple[str, ...], spec: Spec) -> np.ndarray:
    """One number for all or one per name (4: booms a..d or quadrants ab..da) as an
    array of 4, each checked and named by its element: `...tip_forces.b`."""
    if isinstance(value, list | tuple):
        if len(value) != len(names):
            order = "booms" if names == BOOMS else "quadrants"
            raise ValueError(
                f"{where} must be a scalar or {len(names)} values ({order} "
                f"{', '.join(names)}), got {len(value)}: {value!r}"
            )
        return np.array(
            [check_number(v, f"{where}.{n}", spec) for v, n in zip(value, names, strict=True)]
        )
    return np.full(len(names), check_number(value, where, spec))


def check_times(value, where: str, spec: Spec, at_least: int = 1) -> list[float]:
    """A list of at least `at_least` numbers, each checked and named `where[i]`."""
    if not isinstance(value, list | tuple) or len(value) < at_least:
        raise ValueError(f"{where} must be a list of at least {at_least} number(s), got {value!r}")
    return [check_number(v, f"{where}[{i}]", spec) for i, v in enumerate(value)]
