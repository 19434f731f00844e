"""The quadrant integrals kept on disk between processes.

Building the integrals of the default mode counts takes about a second of CPU, and every
simulator, tool and worker that starts builds them again; a file holds them for the next
process. A stored set is used only if it was built by the same code (a digest of the
modules they are computed from and numpy's version names the file) and reads back whole;
anything else, or a cache folder that cannot be written, builds them afresh. The
values are the built ones to the bit (`.npy` keeps every float as it is).

Where: `$XDG_CACHE_HOME/sail_ros` or `~/.cache/sail_ros`; at most `KEPT_FILES` sets stay
(the least recently used go).
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sail_ros.outputs import staged

# the sets kept (one of the default counts is 2.5 MB)
KEPT_FILES = 8
# the modules the integrals are computed from: the quadrature and blocks, the basis
# functions, the cantilever roots, the membrane modes' indices
_SOURCES = ("integrals.py", "basis.py", "roots.py", "layout.py")


def cache_folder() -> Path | None:
    """`$XDG_CACHE_HOME/sail_ros`, else `~/.cache/sail_ros`; None without a home."""
    base = os.environ.get("XDG_CACHE_HOME") or (
        str(Path.home() / ".cache") if os.environ.get("HOME") else ""
    )
    return Path(base) / "sail_ros" if base else None


def _code_fingerprint() -> str | None:
    """What the stored values depend on besides the counts: the sources that compute them
    and numpy's version; None where the sources cannot be read (nothing is stored then)."""
    digest = hashlib.sha256(np.__version__.encode())
    here = Path(__file__).parent
    try:
        for name in _SOURCES:
            digest.update((here / name).read_bytes())
    except OSError:
        return None
    return digest.hexdigest()[:16]


def stored_arrays(
    key: str, names: tuple[str, ...], build: Callable[[], dict[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """The arrays `names` that `build()` makes for `key` (a file-name-safe label of its
    arguments): read from the cache folder where a set of this code is there, else built
    and stored."""
    folder, fingerprint = cache_folder(), _code_fingerprint()
    path = None if folder is None or fingerprint is None else folder / f"{key}_{fingerprint}.npz"
    if path is not None:
        found = _read(path, names)
        if found is not None:
            return found
    arrays = build()
    if path is not None:
        _write(path, arrays)
    return arrays


def _read(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray] | None:
    try:
        with np.load(path, allow_pickle=False) as stored:
            if sorted(stored.files) != sorted(names):
                return None
            arrays = {name: stored[name] for name in names}
        os.utime(path)  # recently used: kept longest
        return arrays
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):  # absent, cut short
        return None


def _write(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Store whole or not at all (`outputs.staged`: a reader sees the whole file or
    none), then keep the `KEPT_FILES` most recently used sets; a folder that cannot be
    written stores nothing."""
    try:
        with staged(path) as building:
            np.savez(building, **arrays)
        sets = sorted(path.parent.glob("*.npz"), key=lambda p: p.stat().st_mtime, reverse=True)
        for old in sets[KEPT_FILES:]:
            old.unlink(missing_ok=True)
    except (OSError, ValueError):  # ValueError: `staged`'s, a file where the folder goes
        pass
