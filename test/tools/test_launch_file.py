"""launch/sail.launch.py, checked without ROS 2's launch (not installed here): it runs
against stand-ins of the launch API that take exactly the real keyword arguments, and
what it asks for must exist: executables among setup.py's entry points, node names
whose params files hold their section, and parameters the nodes declare."""

import importlib.util
import sys
import types
from pathlib import Path

import pytest
import yaml
from harness import ROOT

from sail_ros.cli import TOOLS
from sail_ros.nodes import bridge, recorder
from sail_ros.runtime.config import PARAMETERS

pytestmark = pytest.mark.model

LAUNCH = ROOT / "launch" / "sail.launch.py"
# node name -> the parameters it declares
DECLARED = {
    "sail_sim": set(PARAMETERS),
    "sail_recorder": {spec.name for spec in recorder.SPECS},
    "sail_bridge": {spec.name for spec in bridge.SPECS},
}


class Stand:
    """A launch object: keeps its arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


# the classes the launch file may use, with the keyword arguments the real ones take
# (launch 3.4 / launch_ros 0.26, ROS 2 Jazzy)
API = {
    "launch": {"LaunchDescription": ("initial_entities",)},
    "launch.actions": {
        "DeclareLaunchArgument": ("name", "default_value", "description", "choices")
    },
    "launch.conditions": {"IfCondition": ("predicate_expression",)},
    "launch.substitutions": {
        "LaunchConfiguration": ("variable_name", "default"),
        "PathJoinSubstitution": ("substitutions",),
    },
    "launch_ros.actions": {
        "Node": (
            "executable",
            "package",
            "name",
            "namespace",
            "exec_name",
            "parameters",
            "remappings",
            "ros_arguments",
            "arguments",
            "output",
            "condition",
            "respawn",
        )
    },
    "launch_ros.substitutions": {"FindPackageShare": ("package",)},
}


def stand_in(name: str, keywords: tuple[str, ...]) -> type:
    def init(self, *args, **kwargs):
        unknown = set(kwargs) - set(keywords)
        assert not unknown, f"{name} takes no {sorted(unknown)}"
        assert len(args) <= len(keywords), f"{name}: too many positional arguments"
        Stand.__init__(self, *args, **kwargs)

    return type(name, (Stand,), {"__init__": init})


@pytest.fixture
def description(monkeypatch):
    for module_name, classes in API.items():
        module = types.ModuleType(module_name)
        for name, keywords in classes.items():
            setattr(module, name, stand_in(name, keywords))
        monkeypatch.setitem(sys.modules, module_name, module)
    spec = importlib.util.spec_from_file_location("sail_launch", LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # only the names of API import
    return module.generate_launch_description()


def entities(description, kind: str) -> list[Stand]:
    return [e for e in description.args[0] if type(e).__name__ == kind]


def default_file(description, argument) -> Path:
    """The file the launch argument named by LaunchConfiguration `argument` defaults to,
    as the package's share/ folder (installed from this tree) holds it."""
    (declared,) = [
        d for d in entities(description, "DeclareLaunchArgument") if d.args[0] == argument.args[0]
    ]
    find, *parts = declared.kwargs["default_value"].args[0]
    assert type(find).__name__ == "FindPackageShare" and find.args == ("sail_ros",)
    return ROOT.joinpath(*parts)


def flat(values: dict, prefix: str = "") -> set[str]:
    names = set()
    for key, value in values.items():
        if isinstance(value, dict):
            names |= flat(value, f"{prefix}{key}.")
        else:
            names.add(prefix + key)
    return names


def test_nodes_are_the_packages_executables_with_their_own_names(description):
    nodes = entities(description, "Node")
    assert [n.kwargs["executable"] for n in nodes] == ["sim", "recorder", "bridge"]
    for node in nodes:
        assert node.kwargs["package"] == "sail_ros"
        assert node.kwargs["executable"] in TOOLS
        module = TOOLS[node.kwargs["executable"]].split(":")[0]
        assert node.kwargs["name"] == importlib.import_module(module).NODE_NAME


def test_params_files_hold_declared_parameters_of_their_node(description):
    for node in entities(description, "Node"):
        (argument,) = node.kwargs["parameters"]
        path = default_file(description, argument)
        document = yaml.safe_load(path.read_text())
        name = node.kwargs["name"]
        assert list(document) == [name], path
        given = flat(document[name]["ros__parameters"])
        assert given == DECLARED[name], (path, given ^ DECLARED[name])


def test_the_bridge_starts_only_when_asked(description):
    (bridge_node,) = [
        n for n in entities(description, "Node") if n.kwargs["executable"] == "bridge"
    ]
    condition = bridge_node.kwargs["condition"]
    assert type(condition).__name__ == "IfCondition"
    (flag,) = [d for d in entities(description, "DeclareLaunchArgument") if d.args[0] == "bridge"]
    assert condition.args[0].args[0] == "bridge" and flag.kwargs["default_value"] == "false"
    others = [n for n in entities(description, "Node") if n is not bridge_node]
    assert all(n.kwargs["condition"] is None for n in others)


def test_setup_installs_the_launch_file_and_the_layout():
    text = (ROOT / "setup.py").read_text()
    assert '"/launch", glob("launch/*.launch.py")' in text
    assert 'glob("config/*.json")' in text
