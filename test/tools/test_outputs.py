"""Outputs are whole or absent: built under a temporary name and moved into place on
success; a failure half-way (here injected) leaves nothing that looks complete, and an
earlier output of the same name as it was."""

import contextlib
import errno
import os
import re

import pytest
from harness import run_tool

from sail_ros import outputs
from sail_ros.bag import BagWriteError, BagWriter
from sail_ros.outputs import staged
from sail_ros.tools import montecarlo, report

pytestmark = pytest.mark.model


def listing(folder):
    """Every file and folder under `folder`, hidden ones included, with file contents."""
    found = {}
    for root, folders, files in os.walk(folder):
        for name in folders:
            found[os.path.relpath(os.path.join(root, name), folder)] = "/"
        for name in files:
            path = os.path.join(root, name)
            with open(path, "rb") as stream:
                found[os.path.relpath(path, folder)] = stream.read()[:64]
    return found


class InjectedError(Exception):
    """A failure half-way through building an output."""


def build_and_fail(target, write) -> None:
    """Build `target` with `write(path)`, then fail before the end."""
    before = listing(target) if target.is_dir() else target.exists() and target.read_bytes()
    with staged(target) as building:
        write(building)
        now = listing(target) if target.is_dir() else target.exists() and target.read_bytes()
        assert now == before  # nothing new under the real name while building
        raise InjectedError


def test_a_file_appears_whole_or_not_at_all(tmp_path):
    target = tmp_path / "sub" / "table.csv"
    with pytest.raises(InjectedError):
        build_and_fail(target, lambda path: path.write_text("half"))
    assert listing(tmp_path) == {"sub": "/"}  # the folder made, no file, no leftovers
    with staged(target) as building:
        building.write_text("first")
    target.write_text("old")
    with pytest.raises(InjectedError):
        build_and_fail(target, lambda path: path.write_text("new, half"))
    assert target.read_text() == "old" and listing(tmp_path) == {
        "sub": "/",
        "sub/table.csv": b"old",
    }
    with staged(target) as building:
        building.write_text("new")
    assert target.read_text() == "new" and len(listing(tmp_path)) == 2


def test_a_folder_appears_whole_and_merges_into_an_existing_one(tmp_path, monkeypatch):
    target = tmp_path / "report"
    with pytest.raises(InjectedError):
        build_and_fail(target, lambda path: (path.mkdir(), (path / "a.csv").write_text("a")))
    assert listing(tmp_path) == {}
    target.mkdir()
    (target / "mine.txt").write_text("keep")
    (target / "a.csv").write_text("old a")
    with staged(target) as building:
        (building / "worst").mkdir(parents=True)
        (building / "a.csv").write_text("new a")
        (building / "worst" / "w.yaml").write_text("w")
    assert listing(tmp_path) == {
        "report": "/", "report/worst": "/", "report/mine.txt": b"keep",
        "report/a.csv": b"new a", "report/worst/w.yaml": b"w",
    }  # fmt: skip
    monkeypatch.chdir(target)  # `--out .`: the current folder, its other files kept
    with staged(".") as building:
        building.mkdir()
        (building / "b.csv").write_text("b")
    assert (target / "b.csv").read_text() == "b" and (target / "mine.txt").read_text() == "keep"


def test_a_file_where_a_folder_is_needed_is_named(tmp_path):
    (tmp_path / "blocker").write_text("")
    with pytest.raises(ValueError, match="cannot write --npz .*blocker' is a file, not a folder"):
        staged(tmp_path / "blocker" / "p.npz", "--npz").__enter__()


def test_a_folder_that_takes_no_files_is_named_as_given(tmp_path, monkeypatch):
    """Where the staging folder cannot be made, the error names the output the user asked
    for, not the hidden staging folder."""

    def refused(**_):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(outputs.tempfile, "mkdtemp", refused)
    expected = f"cannot write --npz '{tmp_path / 'x.npz'}': Permission denied"
    with (
        pytest.raises(ValueError, match=f"^{re.escape(expected)}$"),
        staged(tmp_path / "x.npz", "--npz"),
    ):
        pass


def test_deploy_log_cut_by_a_full_disk_leaves_the_old_log(tmp_path, monkeypatch):
    """The disk fills after 40 messages: exit 1, one line naming --mcap, the earlier
    log of that name untouched, no partial file."""
    log = tmp_path / "run.mcap"
    log.write_bytes(b"an earlier log")
    write = BagWriter.write
    count = [0]

    def filling(self, *args, **kwargs):
        count[0] += 1
        if count[0] > 40:
            raise BagWriteError(self.path, OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))
        return write(self, *args, **kwargs)

    monkeypatch.setattr(BagWriter, "write", filling)
    code, out, err = run_tool("deploy", ["--t-end", "3", "--rate", "10", "--mcap", str(log)])
    assert code == 1 and count[0] > 40
    assert err == f"error: --mcap {log}: cannot write: No space left on device; nothing written\n"
    assert "wrote" not in out
    assert listing(tmp_path) == {"run.mcap": b"an earlier log"}


def test_a_report_that_fails_half_way_writes_nothing(tmp_path, monkeypatch):
    log = tmp_path / "run.mcap"
    assert run_tool("deploy", ["--t-end", "2", "--rate", "10", "--mcap", str(log)])[0] == 0

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), "root_moments.png")

    monkeypatch.setattr(report, "root_moments_figure", no_space)  # after the first figure
    out = tmp_path / "report"
    code, _, err = run_tool("report", [str(log), "--out", str(out), "--no-convergence"])
    assert code == 2
    assert err == "error: cannot use 'root_moments.png': No space left on device\n"
    assert sorted(listing(tmp_path)) == ["run.mcap"]  # no report, no partial folder
    out.mkdir()
    (out / "states.csv").write_text("the earlier report's")
    assert run_tool("report", [str(log), "--out", str(out), "--no-convergence"])[0] == 2
    assert listing(out) == {"states.csv": b"the earlier report's"}


def test_a_study_that_fails_half_way_writes_nothing(tmp_path, monkeypatch):
    """In this process (no cluster); the figures fail after the tables were built."""
    monkeypatch.setattr(montecarlo, "dask_client", lambda *_: contextlib.nullcontext())

    def broken(*args):
        raise OSError(errno.EIO, os.strerror(errno.EIO), "envelopes.png")

    monkeypatch.setattr(montecarlo, "_figures", broken)
    study = tmp_path / "study.yaml"
    study.write_text(
        "study:\n  samples: 2\n  scenario:\n    scenario: {duration: 1.0, profile: {type: "
        "static, lengths: 10.0}, initial: {mode_state: {a: 0.1}}}\n    sail: "
        "{n_boom_modes: 1, n_membrane_modes: 1}\n"
    )
    out = tmp_path / "results"
    code, _, err = run_tool("montecarlo", [str(study), "--out", str(out)])
    assert code == 2 and "Input/output error" in err
    assert sorted(listing(tmp_path)) == ["study.yaml"]
    monkeypatch.undo()
    monkeypatch.setattr(montecarlo, "dask_client", lambda *_: contextlib.nullcontext())
    code, stdout, err = run_tool("montecarlo", [str(study), "--out", str(out)])
    assert code == 0, err
    written = {line.removeprefix("wrote ") for line in stdout.splitlines() if "wrote" in line}
    assert written == {str(out / name) for name in listing(out) if listing(out)[name] != "/"}
    assert {"samples.csv", "summary.txt", "summary.json", "envelopes.png"} <= set(listing(out))


def test_moved_outputs_are_followed_by_the_figure_checks(tmp_path):
    """A figure built inside a staged folder is measured where it ends up."""
    from sail_ros.plots.figure_check import checking
    from sail_ros.plots.histories import tip_deflections_figure

    with checking() as checks, staged(tmp_path / "out") as building:
        tip_deflections_figure([0.0, 1.0], [[0.0] * 4, [1e-3] * 4], building / "t.png", "t")
    assert list(checks) == [tmp_path / "out" / "t.png"]
    assert not outputs.MOVED  # the listener left with the block


def test_the_line_naming_a_file_says_which_folders_were_made_for_it(tmp_path, capsys):
    """`modes --csv a/b/x.csv` makes a/b; the line that names the file says so (once),
    the files written into a folder that was there do not."""
    from sail_ros.tools import modes

    small = ["--set", "n_boom_modes=2", "--set", "n_membrane_modes=2"]
    target = tmp_path / "new" / "deeper" / "x.csv"
    assert (
        modes.main([*small, "--csv", str(target), "--json", str(target.with_suffix(".json"))]) == 0
    )
    written = [line for line in capsys.readouterr().out.splitlines() if line.startswith("wrote")]
    assert written == [f"wrote {target} (made the folder {tmp_path / 'new'})",
                       f"wrote {target.with_suffix('.json')}"]  # fmt: skip
    assert modes.main([*small, "--csv", str(target)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {target}"
