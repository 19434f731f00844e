"""config/foxglove_layout.json, checked without Foxglove: every topic it names is one the
bridge serves and the recorder logs under the same name, and every message path exists in
the topic's type, with the boom the plot says."""

import json
import re
import subprocess

import pytest
from harness import ROOT

from sail_ros import topics
from sail_ros.model import SailParameters
from sail_ros.nodes import bridge
from sail_ros.policy import Policy
from sail_ros.ros.program import message_class

pytestmark = pytest.mark.model

LAYOUT = ROOT / "config" / "foxglove_layout.json"
# /topic.field[index].field ... (the message paths the layout uses: no filters, no slices)
PATH = re.compile(r"^(/[A-Za-z0-9_/]+?)((?:\.[A-Za-z_][A-Za-z0-9_]*(?:\[\d+\])?)*)$")
SERVED = {topics.absolute(name): spec for name, (spec, _) in bridge.SERVABLE.items()}
TYPE_NAMES = {topics.absolute(name): type_name for name, (_, type_name) in bridge.SERVABLE.items()}
# the joint order of each JointState topic the plots index, and the field of its value
# (messages.state.boom_state, tip_deflection, root_moment)
JOINTS = {
    "/sail/boom_state": (topics.BOOM_JOINTS, "position"),
    "/sail/tip_deflection": (topics.TIP_JOINTS, "position"),
    "/sail/root_moment": (topics.ROOT_JOINTS, "effort"),
}


@pytest.fixture(scope="module")
def layout() -> dict:
    return json.loads(LAYOUT.read_text())


def panels_in(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    return panels_in(node["first"]) + panels_in(node["second"])


def resolve(path: str):
    """(topic, the value's type or Python type at the end of `path`, last index or None)."""
    match = PATH.match(path)
    assert match, f"{path!r} is not a message path of the form /topic.field[i]..."
    topic, rest = match.groups()
    assert topic in SERVED, f"{path}: {topic} is not served by the bridge"
    kind: object = SERVED[topic]
    index = None
    for part in re.findall(r"\.([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?", rest):
        field, index_text = part
        fields = kind.get_fields_and_field_types()
        assert field in fields, f"{path}: {kind.__name__} has no field {field!r}"
        field_type = fields[field]
        index = int(index_text) if index_text else None
        sequence = field_type.startswith("sequence<") or field_type.endswith("]")
        assert sequence == (index is not None), f"{path}: {field} is {field_type}"
        element = re.sub(r"^sequence<(.*?)(, \d+)?>$|\[\d*\]$", r"\1", field_type)
        kind = message_class(element.replace("/", "/msg/")) if "/" in element else element
    return topic, kind, index


def test_every_panel_is_placed_and_every_placed_panel_configured(layout):
    assert sorted(panels_in(layout["layout"])) == sorted(layout["configById"])


def test_topics_are_the_simulators_under_the_logs_names(layout):
    configs = layout["configById"]
    named = set(configs["3D!sail"]["topics"])
    named |= {configs[p]["topicToRender"] for p in configs if "topicToRender" in configs[p]}
    named |= {configs[p]["topicName"] for p in configs if p.startswith("Publish!")}
    named |= {resolve(configs[p]["topicPath"])[0] for p in configs if p.startswith("RawMessages!")}
    named |= {
        resolve(path["value"])[0]
        for p in configs
        if p.startswith("Plot!")
        for path in configs[p]["paths"]
    }
    logged = {topics.absolute(name) for name in topics.RECORDED_TOPICS}
    assert named and named <= logged and named <= set(SERVED)
    assert configs["3D!sail"]["followTf"] == topics.FRAME_ID


def test_plots_are_numbers_of_the_boom_they_name(layout):
    plots = [c for p, c in layout["configById"].items() if p.startswith("Plot!")]
    assert len(plots) == 3
    for plot in plots:
        booms = []
        for path in plot["paths"]:
            topic, kind, index = resolve(path["value"])
            joints, field = JOINTS[topic]
            assert kind == "double" and f".{field}[" in path["value"], path
            joint = joints[index]
            assert path["label"] == f"boom {joint.split('_')[1]}", path
            booms.append(joint.split("_")[1])
        assert booms == ["a", "b", "c", "d"], plot["title"]


def test_the_publish_panel_sends_a_deployment_the_simulator_accepts(layout):
    panel = layout["configById"]["Publish!deploy"]
    assert panel["topicName"] == topics.absolute(topics.DEPLOY_CMD)
    assert panel["datatype"] == TYPE_NAMES[panel["topicName"]]
    message = SERVED[panel["topicName"]]()
    for field, value in json.loads(panel["value"]).items():
        assert field in message.get_fields_and_field_types(), field
        setattr(message, field, value)  # the message checks the value's type
    Policy().check_length(message.data, "the layout's deployment", SailParameters())


def test_the_status_panel_shows_the_simulators_integrator(layout):
    panel = layout["configById"]["DiagnosticStatusPanel!integrator"]
    assert panel["selectedName"] == topics.integrator_status_name()
    assert panel["selectedHardwareId"] == topics.SIM_NODE
    resolve(layout["configById"]["RawMessages!answers"]["topicPath"])


def test_the_guides_copy_for_another_namespace_moves_every_topic_and_status(tmp_path):
    """docs/guide/foxglove.md's command writes the layout for /sat2: every topic the layout
    names moves under /sat2 (but the global /diagnostics), and the status panel follows
    the simulator's name there."""
    page = (ROOT / "docs" / "guide" / "foxglove.md").read_text()
    (command,) = [b for b in re.findall(r"```bash\n(.*?)```", page, re.S) if "sed " in b]
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "foxglove_layout.json").write_text(LAYOUT.read_text())
    subprocess.run(["bash", "-ec", command], cwd=tmp_path, check=True)
    text = (tmp_path / "out" / "foxglove_layout_sat2.json").read_text()
    topics_named = re.findall(r'"(/[A-Za-z0-9_]+/[^"]*)"', text)
    assert topics_named and all(name.startswith("/sat2/sail/") for name in topics_named)
    assert len(topics_named) == len(re.findall(r'"/sail/', LAYOUT.read_text()))
    status = json.loads(text)["configById"]["DiagnosticStatusPanel!integrator"]
    assert status["topicToRender"] == "/diagnostics"
    assert status["selectedName"] == topics.integrator_status_name("/sat2/sail_sim")
    assert status["selectedHardwareId"] == "sat2/sail_sim"
