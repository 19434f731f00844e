"""The package's structure: imports flow one way, offline code stays away from nodes."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.model

PACKAGE = Path(__file__).resolve().parents[1] / "sail_ros"


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every sail_ros module `path` imports, at any depth of the file."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return {name for name in found if name.startswith("sail_ros")}


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    modules = {module_name(path): path for path in PACKAGE.rglob("*.py")}
    return {name: imports_of(path) & set(modules) - {name} for name, path in modules.items()}


def test_no_import_cycle(graph):
    state: dict[str, str] = {}

    def visit(name, trail):
        state[name] = "open"
        for target in sorted(graph[name]):
            if state.get(target) == "open":
                cycle = trail[trail.index(target) :] + [target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target, [*trail, target])
        state[name] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


def test_model_imports_only_the_model(graph):
    for name, targets in graph.items():
        if name.startswith("sail_ros.model"):
            outside = {t for t in targets if not t.startswith("sail_ros.model")}
            assert not outside, f"{name} imports {outside}"


def test_analysis_and_tools_import_no_node_module(graph):
    for name, targets in graph.items():
        if name.startswith(("sail_ros.analysis", "sail_ros.tools")):
            nodes = {t for t in targets if t.startswith("sail_ros.nodes")}
            assert not nodes, f"{name} imports {nodes}"


@pytest.mark.parametrize(
    "module",
    [
        "sail_ros.model",
        "sail_ros.analysis.log_export",
        "sail_ros.analysis.log_series",
        "sail_ros.tools.deploy",
        "sail_ros.tools.report",
    ],
)
def test_offline_code_does_not_load_rclpy_node(module):
    code = f"import sys, {module}; print('rclpy.node' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


def test_model_does_not_load_ros():
    code = "import sys, sail_ros.model; print(sorted(m for m in sys.modules if 'rclpy' in m))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "[]", result.stdout + result.stderr
