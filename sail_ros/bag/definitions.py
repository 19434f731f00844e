"""Message definitions of installed ROS 2 interfaces, in the form rosbag2 stores them.

rosbag2's MCAP storage gives every type a schema whose text is the type's own
`.msg` file followed by the `.msg` file of each type it uses, recursively:
every dependency appears once, depth first, dependencies of one file in
sorted order, each introduced by a line of 80 '=' and a line `MSG: pkg/Type`.
Types that only ship an `.idl` file get the same layout with `IDL:` headers
and schema encoding `ros2idl`.

Interface files are found under `<prefix>/share/<pkg>/<msg|srv|action>/` for
each prefix of the AMENT_PREFIX_PATH environment variable, as ament does, and
then in this Python environment's and this package's own prefixes.
Nothing here needs rclpy.
"""

from __future__ import annotations

import functools
import json
import os
import re
import sys
from pathlib import Path
from typing import NamedTuple

SEPARATOR = "=" * 80

# .msg field types that are not messages (a bounded string `string<=N` is
# reduced to `string` before the lookup)
PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
    }
)

_TYPE_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:(msg|srv|action)/)?([A-Za-z][A-Za-z0-9_]*)$")
_IDL_INCLUDE = re.compile(r'^#include\s+[<"]([A-Za-z0-9_/]+)\.idl[>"]', re.MULTILINE)
_MAX_DEPTH = 50  # nesting deeper than this is a cycle, not a message


class DefinitionNotFoundError(LookupError):
    """No installed interface file defines the requested type."""


class MessageDefinition(NamedTuple):
    """A schema as rosbag2 writes it: `encoding` is "ros2msg" or "ros2idl"."""

    encoding: str
    text: str


def split_type_name(type_name: str) -> tuple[str, str, str]:
    """Split `pkg/msg/Type` (or `pkg/Type`, meaning `msg`) into (pkg, namespace, Type).

    Raises:
        ValueError: the name is not of that form.
    """
    match = _TYPE_NAME.match(type_name)
    if match is None:
        raise ValueError(f"type name must look like 'pkg/msg/Type', got {type_name!r}")
    package, namespace, name = match.groups()
    return package, namespace or "msg", name


def full_type_name(type_name: str) -> str:
    """`std_msgs/Header` -> `std_msgs/msg/Header`; full names are returned unchanged."""
    return "/".join(split_type_name(type_name))


def ament_prefixes() -> tuple[Path, ...]:
    """The install prefixes to search, in order: those of AMENT_PREFIX_PATH, then this
    Python environment's own prefix (where the PyPI ROS packages put share/), then
    the prefix this package is installed in. So definitions are found even when
    AMENT_PREFIX_PATH was not set up."""
    value = os.environ.get("AMENT_PREFIX_PATH", "")
    prefixes = [Path(entry) for entry in value.split(os.pathsep) if entry]
    prefixes += [Path(sys.prefix), _own_prefix()]
    return tuple(dict.fromkeys(prefixes))


def _own_prefix() -> Path:
    """<prefix> of <prefix>/lib/pythonX.Y/site-packages/sail_ros/bag/definitions.py (in
    a source tree, which has no such prefix, the environment's)."""
    parents = Path(__file__).resolve().parents
    return parents[5] if len(parents) > 5 else Path(sys.prefix)


def find_interface_file(type_name: str, extension: str) -> Path:
    """Path of the installed `<Type><extension>` file (extension ".msg", ".idl", ".json").

    Raises:
        DefinitionNotFoundError: no prefix of AMENT_PREFIX_PATH has the file.
    """
    return _find_interface_file(type_name, extension, ament_prefixes())


def message_definition(type_name: str) -> MessageDefinition:
    """The full schema text of `type_name` with all its dependencies, as rosbag2 writes it.

    Raises:
        DefinitionNotFoundError: the type or one of its dependencies is not installed.
        ValueError: `type_name` is malformed or its definitions nest without end.
    """
    return _message_definition(full_type_name(type_name), ament_prefixes())


def type_hash(type_name: str) -> str:
    """The `RIHS01_<sha256>` type hash from the installed `<Type>.json`, or "" if none."""
    return _type_hash(full_type_name(type_name), ament_prefixes())


@functools.lru_cache(maxsize=512)
def _find_interface_file(type_name: str, extension: str, prefixes: tuple[Path, ...]) -> Path:
    package, namespace, name = split_type_name(type_name)
    for prefix in prefixes:
        candidate = prefix / "share" / package / namespace / f"{name}{extension}"
        if candidate.is_file():
            return candidate
    searched = os.pathsep.join(str(prefix) for prefix in prefixes)
    raise DefinitionNotFoundError(
        f"no {package}/{namespace}/{name}{extension} under share/ of any prefix "
        f"(AMENT_PREFIX_PATH, this environment, this package): {searched}"
    )


@functools.lru_cache(maxsize=256)
def _message_definition(type_name: str, prefixes: tuple[Path, ...]) -> MessageDefinition:
    try:
        _find_interface_file(type_name, ".msg", prefixes)
    except DefinitionNotFoundError:
        _find_interface_file(type_name, ".idl", prefixes)  # raises when neither exists
        root = f"{SEPARATOR}\nIDL: {type_name}\n"
        return MessageDefinition("ros2idl", root + _append_idl(type_name, prefixes, set(), 0))
    package, namespace, name = split_type_name(type_name)
    # the root is named as in its own file; dependencies as written in .msg fields
    return MessageDefinition(
        "ros2msg", _append_msg(f"{package}/{name}", namespace, prefixes, set(), 0)
    )


def _append_msg(name: str, namespace: str, prefixes, seen: set[str], depth: int) -> str:
    if depth > _MAX_DEPTH:
        raise ValueError(f"message definitions nest deeper than {_MAX_DEPTH} at {name}")
    package, _, type_ = name.partition("/")
    text = _find_interface_file(f"{package}/{namespace}/{type_}", ".msg", prefixes).read_text()
    for dependency in sorted(_msg_dependencies(text, package)):
        if dependency not in seen:
            seen.add(dependency)
            text += f"\n{SEPARATOR}\nMSG: {dependency}\n"
            text += _append_msg(dependency, "msg", prefixes, seen, depth + 1)
    return text


def _msg_dependencies(text: str, package: str) -> set[str]:
    """Message types used by the fields of a .msg file, as `pkg/Type`."""
    dependencies = set()
    for line in text.splitlines():
        tokens = line.split("#", 1)[0].split()
        if len(tokens) < 2:
            continue
        field_type = re.split(r"[\[<]", tokens[0], maxsplit=1)[0]
        if field_type in PRIMITIVE_TYPES:
            continue
        dependencies.add(field_type if "/" in field_type else f"{package}/{field_type}")
    return dependencies


def _append_idl(type_name: str, prefixes, seen: set[str], depth: int) -> str:
    if depth > _MAX_DEPTH:
        raise ValueError(f"message definitions nest deeper than {_MAX_DEPTH} at {type_name}")
    text = _find_interface_file(type_name, ".idl", prefixes).read_text()
    for dependency in sorted(set(_IDL_INCLUDE.findall(text))):
        if dependency not in seen:
            seen.add(dependency)
            text += f"\n{SEPARATOR}\nIDL: {dependency}\n"
            text += _append_idl(dependency, prefixes, seen, depth + 1)
    return text


@functools.lru_cache(maxsize=256)
def _type_hash(type_name: str, prefixes: tuple[Path, ...]) -> str:
    try:
        path = _find_interface_file(type_name, ".json", prefixes)
    except DefinitionNotFoundError:
        return ""
    for entry in json.loads(path.read_text()).get("type_hashes", []):
        if entry.get("type_name") == type_name:
            return entry.get("hash_string", "")
    return ""
