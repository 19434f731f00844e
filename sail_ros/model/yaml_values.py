"""YAML read as people write numbers: `3e-6` is a float, as in YAML 1.2.

PyYAML follows YAML 1.1, whose float pattern needs a dot (`3.0e-6`) and reads
`3e-6` as the string "3e-6". `SafeLoader` here adds the YAML 1.2 forms; the
rest is PyYAML's safe loader.
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml


class SafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader, with YAML 1.2 floats (`1e3`, `3E-6`, `-2.5e+4`, `-.5`)."""


SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    # an exponent, or a dot with digits on one side; never a plain integer
    re.compile(r"^[-+]?(?:(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+|\.\d+|\d+\.\d*)$"),
    list("-+0123456789."),
)


def load(text_or_stream):
    """`yaml.safe_load` with YAML 1.2 floats."""
    return yaml.load(text_or_stream, Loader=SafeLoader)  # noqa: S506 (a SafeLoader)


def load_file(path, what: str):
    """The YAML document in `path`; ValueError naming the file (`what`: e.g. "scenario")
    when it cannot be read or is not YAML."""
    try:
        return load(Path(path).read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"{path}: not valid YAML: {describe(error)}") from None
    except UnicodeDecodeError as error:
        raise ValueError(f"cannot read {what} {str(path)!r}: {not_text(error)}") from None
    except OSError as error:
        raise ValueError(f"cannot read {what} {str(path)!r}: {error.strerror}") from None


def not_text(error: UnicodeDecodeError) -> str:
    """Why a file is no YAML at all, in a few words: its first byte that is not UTF-8."""
    return f"not UTF-8 text (byte {error.object[error.start]:#04x} at offset {error.start})"


def describe(error: yaml.YAMLError) -> str:
    """A YAML error in one line: what, and where (line and column, from 1)."""
    mark = getattr(error, "problem_mark", None)
    what = getattr(error, "problem", None) or str(error).splitlines()[0]
    if mark is None:
        return what
    return f"{what} (line {mark.line + 1}, column {mark.column + 1})"


def node_sections(document, prefix: str = "") -> dict | None:
    """The node sections of a ROS 2 params file's `document` (`<node>: ros__parameters:
    ...`), each name's `ros__parameters` value, names joined through nested namespaces
    as rcl joins them (`/sat2: sail_sim: ros__parameters:` is `/sat2/sail_sim`); None
    when `document` is not a params file (a branch that does not end in
    `ros__parameters`, or nothing)."""
    if not isinstance(document, dict) or not document:
        return None
    sections = {}
    for name, body in document.items():
        if not isinstance(body, dict):
            return None
        joined = f"{prefix}/{name}" if prefix else str(name)
        if "ros__parameters" in body:
            sections[joined] = body["ros__parameters"]
            continue
        nested = node_sections(body, joined)
        if nested is None:
            return None
        sections.update(nested)
    return sections


def section_applies(section: str, node_name: str) -> bool:
    """Whether a params file's section (`node_sections`) is read by the node `node_name`
    in any namespace: its last name is the node's or a wildcard (`/**`, `*`)."""
    return section.rstrip("/").rsplit("/", 1)[-1] in (node_name, "**", "*")


def checked_sections(document, where) -> dict | None:
    """`node_sections` of `document`, each a mapping as rcl requires.

    Raises:
        ValueError: (naming `where`, the file) a section's `ros__parameters` is not a
            mapping (empty, a list, a value), which rcl refuses without naming it.
    """
    sections = node_sections(document)
    for name, body in (sections or {}).items():
        if not isinstance(body, dict):
            raise ValueError(f"{where}: ros__parameters of {name} must be a mapping, got {body!r}")
    return sections


def node_parameters(document, node: str, where) -> dict | None:
    """The parameters a ROS 2 params file's `document` gives the node `node` (its
    sections that apply, `section_applies`, in the file's order, the last value of a
    name kept, as rcl does), by their ROS names (`flattened`); None when `document` is
    not a params file.

    Raises:
        ValueError: (naming `where`, the file) a section's `ros__parameters` is not a
            mapping (rcl refuses the file), or no section applies to `node`.
    """
    sections = checked_sections(document, where)
    if sections is None:
        return None
    applying = [body for name, body in sections.items() if section_applies(name, node)]
    if not applying:
        raise ValueError(
            f"{where}: no parameters for {node} (sections: {', '.join(sections)}); "
            f"{node} would take none of them"
        )
    given = {}
    for body in applying:
        given.update(flattened(body))
    return given


def flattened(mapping: dict, prefix: str = "") -> dict:
    """A section's parameters as ROS names them: `{"sail": {"n_boom_modes": 4}}` is
    `{"sail.n_boom_modes": 4}`."""
    flat = {}
    for key, value in mapping.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flattened(value, name + "."))
        else:
            flat[name] = value
    return flat
