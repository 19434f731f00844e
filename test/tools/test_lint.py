"""ruff over the whole tree: the lint rules and the one formatter (settings in pyproject.toml)."""

import subprocess
import sys

import pytest
from harness import ROOT

pytestmark = pytest.mark.lint


@pytest.mark.parametrize(
    "command",
    [["check", "--no-cache"], ["format", "--check", "--no-cache"]],
    ids=["lint", "format"],
)
def test_ruff_passes(command):
    result = subprocess.run(
        [sys.executable, "-m", "ruff", *command, str(ROOT)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stdout + result.stderr
