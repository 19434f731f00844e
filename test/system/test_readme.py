"""The README and the user's guide run as written: every command block, in order (the
README's, then each guide page's in `PAGES`), in a fresh copy of the tree.

Blocks tagged `bash` (or `bash long`) run in one bash session (so `source scripts/env.sh`
and background jobs carry over from block to block), `python` blocks with the
environment's python at their place in the order. Not run: `bash ros` (needs
a ROS installation with the `ros2` command), `bash suite` (the test suite
itself), untagged, `text` or `console` blocks (output), and `{include}` directives (the
guide showing a README block, which runs from the README). The copy holds exactly
what a clone would (git's tracked and unignored files), shares the set-up
`.venv`, and must be as clean afterwards: whatever the examples write is
ignored by git.

The suite runs them CI-sized: every block that works offline, not the main job (its
`sail-ros demo` runs in test_sim_multiprocess.py), the live walk-throughs (blocks that
start processes in the background, driven in test_drive.py) nor the Monte Carlo study
(run in test_studies_dask.py), nor `bash long` blocks, which take more than about ten
seconds at the default mode counts and whose options run CI-sized in test/tools
(`deploy --convergence`: test_tool_deploy.py's convergence tests; the free-hub scenario:
its free-hub tests). Everything runs with `--slow` (scripts/stress.sh).
"""

import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from harness import ROOT

pytestmark = pytest.mark.multiprocess

SETUP_INPUTS = ("requirements.txt", "constraints.txt", "setup.py")  # as scripts/setup_env.sh
TIMEOUT_S = 900  # all blocks take ~2 min on an idle 2-core machine
LIVE = re.compile(r"&\s*$", re.MULTILINE)  # a process left running in the background
STUDY = "sail-ros montecarlo"
MAIN_JOB = "scripts/main.sh"
FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```", re.MULTILINE | re.DOTALL)
# the pages whose blocks run, in this order (a page's blocks may use what an earlier wrote)
PAGES = (
    "README.md",
    "docs/guide/start.md",
    "docs/guide/simulator.md",
    "docs/guide/foxglove.md",
    "docs/guide/logs.md",
    "docs/guide/studies.md",
    "docs/guide/free_hub.md",
    "docs/guide/closed_loop.md",
    "docs/guide/python.md",
    "docs/scenarios.md",
)
KINDS = {
    "bash",
    "python",
    "bash long",
    "bash ros",
    "bash suite",
    "console",
    "text",
    "",
    "{include}",
}


def blocks(text: str) -> list[tuple[str, str]]:
    """(info string, body) of every fenced block."""
    return [(info.strip(), body) for info, body in FENCE.findall(text)]


def fresh_copy(destination: Path) -> Path:
    """The tree as a fresh clone of it would be, as a git repository of one commit."""
    listed = subprocess.run(
        ["git", "ls-files", "-co", "--exclude-standard", "-z"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout.split(b"\0")
    for name in filter(None, (item.decode() for item in listed)):
        source = ROOT / name
        if source.is_file() and not source.is_symlink():
            target = destination / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    (destination / ".venv").symlink_to(Path(sys.prefix))
    git = ["git", "-c", "user.name=readme", "-c", "user.email=readme@localhost"]
    for command in (["init", "-q"], ["add", "-A"], ["commit", "-q", "-m", "copy"]):
        subprocess.run([*git, *command], cwd=destination, check=True, capture_output=True)
    return destination


def page_blocks(tree: Path) -> list[tuple[str, str]]:
    """(info string, body) of every fenced block of the pages, in order."""
    return [block for page in PAGES for block in blocks((tree / page).read_text())]


def test_readme_blocks_are_recognised():
    kinds = [info for info, _ in blocks((ROOT / "README.md").read_text())]
    assert "bash" in kinds and "python" in kinds and "bash ros" in kinds
    every = [info.split(" ")[0] if info.startswith("{") else info for info, _ in page_blocks(ROOT)]
    assert set(every) <= KINDS, set(every) - KINDS


def test_every_guide_page_with_commands_is_run():
    """A guide page that holds a command block is one of `PAGES`."""
    listed = {ROOT / page for page in PAGES}
    for page in sorted((ROOT / "docs").rglob("*.md")):
        if "_build" in page.parts or "_generated" in page.parts:
            continue
        kinds = {info for info, _ in blocks(page.read_text())}
        if kinds & {"bash", "bash long", "python"}:
            assert page in listed, f"{page.relative_to(ROOT)} has command blocks that no test runs"


def environment_is_current(tree: Path) -> bool:
    """True if the shared .venv was set up from these files (scripts/setup_env.sh's stamp),
    so the README's set-up step in the copy installs nothing into it."""
    text = b"".join((tree / name).read_bytes() for name in SETUP_INPUTS)
    stamp = Path(sys.prefix) / ".installed"
    return stamp.is_file() and stamp.read_text().strip() == hashlib.sha256(text).hexdigest()


def offline(info: str, body: str) -> bool:
    """A block that starts nothing in the background and runs no study, no long command
    nor the main job."""
    return (
        info != "bash long" and not LIVE.search(body) and STUDY not in body and MAIN_JOB not in body
    )


@pytest.mark.slow
def test_readme_runs_top_to_bottom(tmp_path, ros_env):
    output, tree = run_readme(tmp_path, ros_env, lambda info, body: True)
    assert "accepted: deploy to 12 m" in output
    assert "rejected, as it should be" in output
    assert "40 samples ran, 0 failed" in output
    assert "simulator and recorder stopped cleanly" in output  # scripts/main.sh
    stored = re.search(r"simulator parameters stored: \d+ \(.*\)", output)  # as quoted
    assert stored and stored.group(0) in (tree / "README.md").read_text(), stored
    assert (tree / "out" / "run1" / "metadata.yaml").is_file()
    assert (tree / "out" / "run1_report").is_dir()
    check_offline_output(output, tree)


def test_readme_offline_blocks_run(tmp_path, ros_env):
    output, tree = run_readme(tmp_path, ros_env, offline)
    assert "accepted: deploy to 12 m" not in output  # the live walk-through did not run
    check_offline_output(output, tree)


def check_offline_output(output: str, tree: Path) -> None:
    """What the offline blocks print and leave behind."""
    assert "lowest frequencies at full deployment" in output  # the Python example printed
    assert (tree / "out" / "loaded_report").is_dir()
    assert (tree / "out" / "plant.mat").is_file()
    status = subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=all"],
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert status == "", f"the examples left files git does not ignore:\n{status}"
    assert os.path.islink(tree / ".venv")


def run_readme(tmp_path: Path, ros_env: dict, chosen) -> tuple[str, Path]:
    """Run the pages' `bash` and `python` blocks that `chosen(info, body)` keeps, in order,
    in one bash session in a fresh copy; (everything printed, the copy)."""
    tree = fresh_copy(tmp_path / "sail_ros")
    assert environment_is_current(tree), "the environment is out of date: run scripts/test.sh"
    script, ran = ["set -euo pipefail"], set()
    for index, (info, body) in enumerate(page_blocks(tree)):
        if info not in ("bash", "bash long", "python") or not chosen(info, body):
            continue
        lines = {line.split("#")[0].strip() for line in body.splitlines()} - {""}
        if info != "python" and lines <= ran:  # a guide page shows commands run already
            continue
        ran |= lines
        script.append(f'echo "--- block {index} at ${{SECONDS}} s"')
        if info != "python":
            script.append(body)
        else:
            path = tmp_path / f"block_{index}.py"
            path.write_text(body)
            script.append(f"{sys.executable} {path}")
    env = dict(ros_env, PYTHONPATH=str(tree))  # the copy's code, not the developer's
    env.pop("AMENT_PREFIX_PATH", None)  # scripts/env.sh sets it
    log = tmp_path / "readme.log"
    # in a process group of its own, so that a timeout ends its jobs too; not in a session
    # of its own, which Linux would schedule as a group of its own (autogroup), taking
    # its share of the cores beside the whole suite's (conftest.py: CPU priorities)
    with log.open("w") as out:
        session = subprocess.Popen(
            ["bash", "-c", "\n".join(script)],
            cwd=tree,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            process_group=0,
        )
        try:
            session.wait(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(session.pid, signal.SIGKILL)
            session.wait()
            raise AssertionError(
                f"over {TIMEOUT_S} s; so far:\n{log.read_text()[-6000:]}"
            ) from None
    output = log.read_text()
    assert session.returncode == 0, output[-6000:]
    return output, tree
