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
    except OSError as error:
        raise ValueError(f"cannot read {what} {str(path)!r}: {error.strerror}") from None


def describe(error: yaml.YAMLError) -> str:
    """A YAML error in one line: what, and where (line and column, from 1)."""
    mark = getattr(error, "problem_mark", None)
    what = getattr(error, "problem", None) or str(error).splitlines()[0]
    if mark is None:
        return what
    return f"{what} (line {mark.line + 1}, column {mark.column + 1})"
