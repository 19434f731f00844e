"""The package's structure: imports flow one way, offline code stays away from nodes."""

import ast
import re
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


# -- the layers, as docs/architecture.md states them ------------------------------------------


def layer_rows() -> list[tuple[tuple[str, ...], str]]:
    """The rows of docs/architecture.md's layer table, top first: (the module prefixes
    the row names, what importing them may load)."""
    rows = []
    text = (ROOT / "docs" / "architecture.md").read_text()
    table = text[text.index("| package | job | imports ROS |") :].split("\n\n")[0]
    for line in table.splitlines()[2:]:
        cells = [cell.strip() for cell in line.strip("|").split(" | ")]
        paths = re.findall(r"`(sail_ros/[\w/]*(?:\.py)?)`", cells[0])
        prefixes = tuple(
            path.removesuffix("/").removesuffix(".py").replace("/", ".") for path in paths
        )
        rows.append((prefixes, cells[-1]))
    return rows


ROWS = layer_rows()


def row_of(module: str) -> int | None:
    for index, (prefixes, _) in enumerate(ROWS):
        if any(module == prefix or module.startswith(prefix + ".") for prefix in prefixes):
            return index
    return None


def test_every_module_has_its_row(graph):
    assert len(ROWS) >= 10, ROWS
    unplaced = sorted(name for name in graph if name != "sail_ros" and row_of(name) is None)
    assert not unplaced, f"not in docs/architecture.md's layer table: {unplaced}"


# the one import down the table that docs/architecture.md names: `SailModel` hands
# itself to `integrate`
REACHES_DOWN = {"sail_ros.model.sail_model": ("sail_ros.integrate",)}


def test_each_row_imports_only_its_own_and_the_rows_above(graph):
    for name, targets in graph.items():
        if name == "sail_ros":
            continue
        allowed = REACHES_DOWN.get(name, ())
        below = {
            t
            for t in targets - {"sail_ros"}
            if row_of(t) > row_of(name) and not t.startswith(allowed)
        }
        assert not below, f"{name} imports {below}, below it in docs/architecture.md"


def test_the_helpers_use_the_standard_library_only():
    for prefix in ROWS[0][0]:
        path = PACKAGE.parent / (prefix.replace(".", "/") + ".py")
        outside = {
            name
            for name in imported_top_levels(path)
            if name not in sys.stdlib_module_names and name != "sail_ros"
        }
        assert not outside, f"{prefix} imports {outside}"


def test_integrate_never_imports_sail_model(graph):
    for name, targets in graph.items():
        if name.startswith("sail_ros.integrate"):
            assert "sail_ros.model.sail_model" not in targets, name


def imported_by(modules: list[str]) -> set[str]:
    """Every module that importing `modules` (together, in a fresh interpreter) loads."""
    code = f"import sys, {', '.join(modules)}\nprint(sorted(sys.modules))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return set(ast.literal_eval(result.stdout.strip()))


def loaded_by(modules: list[str]) -> list[str]:
    """What importing `modules` (together, in a fresh interpreter) loads of ROS: the
    packages rclpy and *_msgs, *_interfaces, and "rclpy.node" if it is among them."""
    names = imported_by(modules)
    packages = {m.split(".")[0] for m in names}
    ros = {p for p in packages if p == "rclpy" or p.endswith(("_msgs", "_interfaces"))}
    return sorted(ros | ({"rclpy.node"} & names))


def modules_of(prefixes) -> list[str]:
    found = []
    for prefix in prefixes:
        path = PACKAGE.parent / prefix.replace(".", "/")
        files = sorted(path.glob("*.py")) if path.is_dir() else [path.with_suffix(".py")]
        found += [module_name(file) for file in files]
    return found


ROS_ROWS = [(prefixes, rule) for prefixes, rule in ROWS if rule != "yes"]


@pytest.mark.parametrize(
    ("prefixes", "rule"), ROS_ROWS, ids=[prefixes[0] for prefixes, _ in ROS_ROWS]
)
def test_what_importing_a_row_loads(prefixes, rule):
    """A row "no" loads neither rclpy nor a message package; "... only" loads no rclpy
    node but in the modules it names (`send`: the tool of cli.TOOLS, `client`:
    tools.client)."""
    from sail_ros.cli import TOOLS

    named = re.findall(r"`(\w+)`", rule.partition("an rclpy node:")[2])
    nodes_allowed = {
        TOOLS[word].split(":")[0] if word in TOOLS else f"sail_ros.tools.{word}" for word in named
    }
    modules = [module for module in modules_of(prefixes) if module not in nodes_allowed]
    ros = loaded_by(modules)
    if rule == "no":
        assert ros == [], f"importing {prefixes} loads {ros}"
    else:
        assert "only" in rule, rule
        assert "rclpy.node" not in ros, f"importing {modules} loads an rclpy node"


def test_messages_are_built_only_in_the_messages_package(graph):
    """`topics` holds names, QoS and the table, and imports no builder; the builders
    (`sail_ros.messages`) build on the model and the topics only, and every other
    module takes them from there."""
    assert not {t for t in graph["sail_ros.topics"] if t.startswith("sail_ros.messages")}
    for name, targets in graph.items():
        if name.startswith("sail_ros.messages"):
            outside = {
                t for t in targets if not t.startswith(("sail_ros.messages", "sail_ros.model"))
            } - {
                "sail_ros",
                "sail_ros.topics",
                "sail_ros.names",
                "sail_ros.bag",
                "sail_ros.bag.recording",
            }
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


def imported_top_levels(path: Path) -> set[str]:
    """The top-level packages `path` imports (`numpy` of `numpy.linalg`)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
    return found


def third_party_imports() -> set[str]:
    found = set().union(*(imported_top_levels(path) for path in PACKAGE.rglob("*.py")))
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


@pytest.mark.parametrize("tool", ["send", "watch", "bag"])
def test_the_terminal_commands_start_without_the_numerical_libraries(tool):
    """`sail-ros send`, `watch` and `bag` are typed at a terminal, again and again: they
    load none of scipy, matplotlib, pyarrow, dask (scipy alone takes about 0.3 s to
    import; a waypoint profile imports scipy.interpolate when it is made)."""
    heavy = {"scipy", "matplotlib", "pyarrow", "dask"}
    loaded = {m.split(".")[0] for m in imported_by([f"sail_ros.tools.{tool}"])} & heavy
    assert loaded == set(), loaded


def test_the_entry_points_module_loads_only_what_keeps_an_early_sigint():
    """Every program starts by importing `sail_ros.cli` (its console scripts' first line),
    before its `main` guards against a Ctrl-C (exit 130, no traceback): that import loads
    nothing but `early_signals`, so the unguarded moment lasts milliseconds, not the tens
    a module such as `options` (argparse, re) would take."""
    bare = imported_by(["sys"])
    loaded = imported_by(["sail_ros.cli"]) - bare
    assert {m for m in loaded if m.startswith("sail_ros")} == {
        "sail_ros",
        "sail_ros.cli",
        "sail_ros.early_signals",
    }
    assert loaded - {"sail_ros", "sail_ros.cli", "sail_ros.early_signals"} <= {
        "signal",
        "threading",
        "_weakrefset",
    }
