"""The package's structure: imports flow one way, offline code stays away from nodes."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest
from harness import ROOT

pytestmark = pytest.mark.model

PACKAGE = ROOT / "sail_ros"


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
    """The structure (`model`) imports nothing else, but `SailModel`'s time integration
    (`stepper`, `simulate`, `simulate_on_grid`) hands the model to `integrate`, which
    imports the structure's modules and never `SailModel` itself."""
    for name, targets in graph.items():
        if name.startswith("sail_ros.model"):
            allowed = ("sail_ros.model", "sail_ros.integrate")
            allowed = allowed if name == "sail_ros.model.sail_model" else allowed[:1]
            outside = {t for t in targets if not t.startswith(allowed)}
            assert not outside, f"{name} imports {outside}"
        if name.startswith("sail_ros.integrate"):
            outside = {
                t for t in targets if not t.startswith(("sail_ros.model", "sail_ros.integrate"))
            }
            assert not outside and "sail_ros.model.sail_model" not in targets, (
                f"{name} imports {targets}"
            )


def test_analysis_tools_and_the_pure_packages_import_no_node_module(graph):
    pure = ("sail_ros.analysis", "sail_ros.tools", "sail_ros.runtime", "sail_ros.bridging",
            "sail_ros.control")  # fmt: skip
    for name, targets in graph.items():
        if name.startswith(pure):
            nodes = {t for t in targets if t.startswith("sail_ros.nodes")}
            assert not nodes, f"{name} imports {nodes}"


def test_messages_are_built_only_in_the_messages_package(graph):
    """`topics` holds names, QoS and the table, and imports no builder; the builders
    (`sail_ros.messages`) build on the model and the topics only, and every other
    module takes them from there."""
    assert not {t for t in graph["sail_ros.topics"] if t.startswith("sail_ros.messages")}
    for name, targets in graph.items():
        if name.startswith("sail_ros.messages"):
            outside = {
                t for t in targets if not t.startswith(("sail_ros.messages", "sail_ros.model"))
            } - {"sail_ros", "sail_ros.topics", "sail_ros.bag", "sail_ros.bag.recording"}
            assert not outside, f"{name} imports {outside}"
    topics = ast.parse((PACKAGE / "topics.py").read_text())
    built = {
        node.name
        for node in topics.body
        if isinstance(node, ast.FunctionDef)
        and node.returns is not None
        and ast.unparse(node.returns) in MESSAGE_TYPES
    }
    assert built == {"stamp"}, f"topics.py builds messages: {built}"


# the message classes the package publishes or writes (what a builder returns)
MESSAGE_TYPES = {
    "JointState",
    "Odometry",
    "WrenchStamped",
    "MarkerArray",
    "Marker",
    "DiagnosticArray",
    "Clock",
    "Time",
}


@pytest.mark.parametrize(
    "module",
    [
        "sail_ros.model",
        "sail_ros.analysis.log_export",
        "sail_ros.analysis.log_series",
        "sail_ros.tools.deploy",
        "sail_ros.tools.report",
        "sail_ros.analysis.closed_loop",
    ],
)
def test_offline_code_does_not_load_rclpy_node(module):
    code = f"import sys, {module}; print('rclpy.node' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


@pytest.mark.parametrize(
    "module",
    ["sail_ros.model", "sail_ros.control.check", "sail_ros.control.loop",
     "sail_ros.control.agreement"],
)  # fmt: skip
def test_the_model_and_the_controller_do_not_load_ros(module):
    code = f"import sys, {module}; print(sorted(m for m in sys.modules if 'rclpy' in m))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "[]", result.stdout + result.stderr


# import name -> its rosdep key in package.xml; imports without a key are listed in its
# pip-only comment
ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "tqdm": "python3-tqdm",
    "rosbags": "python3-rosbags-pip",
}
PIP_ONLY = {
    "mcap": "mcap",
    "skfem": "scikit-fem",
    "dask": "dask",
    "distributed": "distributed",
    "pyarrow": "pyarrow",
    "bokeh": "bokeh",
    "foxglove": "foxglove-sdk",
}


def third_party_imports() -> set[str]:
    found = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                found.add(node.module.split(".")[0])
    return {name for name in found if name not in sys.stdlib_module_names and name != "sail_ros"}


def test_package_xml_declares_every_import():
    import xml.etree.ElementTree as ElementTree

    text = (PACKAGE.parent / "package.xml").read_text()
    root = ElementTree.fromstring(text)
    runtime = {element.text for element in root.iter("exec_depend")}
    for name in sorted(third_party_imports()):
        if name in PIP_ONLY:
            assert PIP_ONLY[name] in text, f"{name}: not named as a pip-only dependency"
        elif name in ROSDEP_KEYS:
            assert ROSDEP_KEYS[name] in runtime, f"{name}: no <exec_depend>{ROSDEP_KEYS[name]}"
        else:  # a ROS package: its own name is the key
            assert name in runtime, f"{name}: no <exec_depend>{name}"
