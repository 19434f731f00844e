"""Outputs that are whole or absent: built under a temporary name, moved into place.

`staged(path)` gives the path to build a file or a folder at: the same name in a
hidden folder `.NAME.partial-*` beside it. When the block ends without an
exception the result moves to `path` (`os.replace`, atomic for a file or a new
folder); on an exception (a failure, Ctrl-C) it is deleted. So a tool that stops
half-way leaves no half-written file or folder that looks complete: an earlier
output of the same name stays as it was, and a kill leaves at most the hidden
`.partial-` folder.

A folder built over an existing folder is merged into it file by file, each
replacing its namesake at the end (`--out .` never deletes anything else).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

# called with (built path, final path) for every file moved into place (the tests'
# figure checks follow their figures there)
MOVED: list[Callable[[Path, Path], None]] = []
# the outermost folder each `make_folder` created (absolute), until `made_for` names it
# beside the output written into it
CREATED: list[Path] = []


def make_folder(folder: Path, what: str = "") -> None:
    """Create `folder` and its parents (the outermost of those created is kept in
    `CREATED`); ValueError naming the file that stands in the way."""
    folder = Path(folder)
    for place in (folder, *folder.parents):
        if place.exists() and not place.is_dir():
            prefix = f"{what} " if what else ""
            raise ValueError(f"cannot write {prefix}'{folder}': '{place}' is a file, not a folder")
    missing = [place for place in (folder, *folder.parents) if not place.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    if missing:
        CREATED.append(Path(os.path.abspath(missing[-1])))


def made_for(path) -> Path | None:
    """The folder made for the output `path` (one of `CREATED` that holds it), taken off
    the list so that it is named once; None when its folder was there."""
    path = Path(os.path.abspath(path))
    for folder in CREATED:
        if folder in path.parents:
            CREATED.remove(folder)
            return folder
    return None


@contextlib.contextmanager
def staged(path, what: str = ""):
    """Yield the path to build `path` (a file or a folder) at; see the module docstring.
    `what` names the output in errors (an option, e.g. "--mcap")."""
    path = Path(os.path.abspath(path))  # "." has a name and a parent
    make_folder(path.parent, what)
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-", dir=path.parent))
    except OSError as error:  # named as the user gave it, not as the staging folder
        prefix = f"{what} " if what else ""
        raise ValueError(f"cannot write {prefix}'{path}': {error.strerror or error}") from None
    try:
        yield staging / path.name
        built = staging / path.name
        if built.exists():
            _move(built, path)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _move(built: Path, final: Path) -> None:
    if built.is_dir() and final.is_dir():
        for child in sorted(built.iterdir()):
            _move(child, final / child.name)
        return
    if built.is_dir() and final.exists():
        raise ValueError(f"cannot write the folder '{final}': a file of that name is in the way")
    if not built.is_dir() and final.is_dir():
        raise ValueError(f"cannot write '{final}': a folder of that name is in the way")
    os.replace(built, final)
    for listener in MOVED:
        listener(built, final)
