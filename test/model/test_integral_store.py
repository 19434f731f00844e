"""The quadrant integrals kept on disk: the values built to the bit, read back by the
next process, rebuilt where a file is damaged or of other code, nothing stored where the
folder cannot be written, and the folder's size bounded."""

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from sail_ros.model import integral_store
from sail_ros.model.integrals import _built, default_quadrature_order, quadrant_integrals

pytestmark = pytest.mark.model

COUNTS = (3, 7)
ORDER = default_quadrature_order(*COUNTS)
NAMES = tuple(field.name for field in dataclasses.fields(_built(*COUNTS, ORDER)))


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    return tmp_path / "sail_ros"


def built_arrays():
    built = _built(*COUNTS, ORDER)
    return {name: getattr(built, name) for name in NAMES}


def counting_build(calls):
    def build():
        calls.append(1)
        return built_arrays()

    return build


def test_a_stored_set_is_read_back_to_the_bit_by_another_process(folder):
    quadrant_integrals.cache_clear()
    ours = quadrant_integrals(*COUNTS, ORDER)
    (stored,) = folder.glob("quadrant_integrals_3_7_*.npz")
    script = (
        "import dataclasses, sys, numpy as np\n"
        "from sail_ros.model import integrals\n"
        "integrals._built = None  # reading it back must not build\n"
        f"q = integrals.quadrant_integrals(3, 7, {ORDER})\n"
        "np.savez(sys.argv[1], **dataclasses.asdict(q))\n"
    )
    out = folder.parent / "other.npz"
    subprocess.run([sys.executable, "-c", script, str(out)], env=os.environ, check=True)
    with np.load(out) as theirs:
        for name in NAMES:
            assert np.array_equal(theirs[name], getattr(ours, name)), name
            assert np.array_equal(theirs[name], built_arrays()[name]), name
    assert not ours.s_s.flags.writeable and stored.is_file()


def test_a_damaged_or_foreign_file_is_built_again(folder):
    calls = []
    first = integral_store.stored_arrays("set", NAMES, counting_build(calls))
    (path,) = folder.glob("set_*.npz")
    path.write_bytes(path.read_bytes()[:1000])  # cut short, as by a full disk
    again = integral_store.stored_arrays("set", NAMES, counting_build(calls))
    assert len(calls) == 2 and all(np.array_equal(first[n], again[n]) for n in NAMES)
    integral_store.stored_arrays("set", NAMES, counting_build(calls))
    assert len(calls) == 2  # the rebuilt file is whole
    # another set of names under the same file name (a file of other code) is not used
    other = integral_store.stored_arrays("set", ("other",), lambda: {"other": np.ones(2)})
    assert list(other) == ["other"] and np.array_equal(other["other"], np.ones(2))


def test_an_unwritable_cache_builds_and_stores_nothing(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    calls = []
    arrays = integral_store.stored_arrays("set", NAMES, counting_build(calls))
    assert len(calls) == 1 and all(np.array_equal(arrays[n], built_arrays()[n]) for n in NAMES)
    assert blocked.read_text() == "not a folder"


def test_the_folder_keeps_the_most_recently_used_sets(folder):
    for index in range(integral_store.KEPT_FILES + 3):
        integral_store.stored_arrays(f"set{index}", ("a",), lambda: {"a": np.zeros(3)})
        os.utime(next(folder.glob(f"set{index}_*.npz")), (index, index))
    kept = sorted(path.name.split("_")[0] for path in folder.glob("*.npz"))
    assert len(kept) == integral_store.KEPT_FILES
    assert "set0" not in kept and f"set{integral_store.KEPT_FILES + 2}" in kept
    assert all(path.suffix == ".npz" for path in folder.iterdir())  # no staging left


def test_without_the_sources_to_fingerprint_nothing_is_stored(folder, monkeypatch):
    """An install that holds only compiled modules cannot tell which code built a file:
    the integrals are built every time, none stored."""
    monkeypatch.setattr(integral_store, "_SOURCES", ("no_such_module.py",))
    calls = []
    integral_store.stored_arrays("set", NAMES, counting_build(calls))
    integral_store.stored_arrays("set", NAMES, counting_build(calls))
    assert len(calls) == 2 and not folder.exists()
