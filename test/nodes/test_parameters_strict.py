"""No parameter goes unnoticed: unknown names stop a node at start, and are refused by name
at run time; accepted changes are logged and reach /parameter_events."""

import subprocess
import sys

import pytest
import yaml
from harness import CONFIG, run_tool, wait_until
from rcl_interfaces.msg import Parameter as ParameterMessage
from rcl_interfaces.msg import ParameterEvent, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter

from sail_ros.nodes import bridge, recorder, replay
from sail_ros.nodes import sim as sim_module
from sail_ros.nodes.bridge import Bridge
from sail_ros.nodes.control import ControlNode
from sail_ros.nodes.recorder import Recorder
from sail_ros.nodes.replay import Replay
from sail_ros.nodes.sim import SimNode
from sail_ros.ros.parameters import ConfigError

pytestmark = pytest.mark.node


@pytest.mark.parametrize(
    ("node_class", "override", "message"),
    [
        (SimNode, Parameter("max_rat", value=2.0), "'max_rat' (did you mean 'max_rate'?)"),
        (SimNode, Parameter("sail.n_boom_mode", value=3), "(did you mean 'sail.n_boom_modes'?)"),
        (Recorder, Parameter("compresion", value="lz4"), "(did you mean 'compression'?)"),
        (Replay, Parameter("rates", value=2.0), "'rates' (did you mean 'rate'?)"),
        (Bridge, Parameter("prot", value=0), "'prot' (did you mean 'port'?)"),
        (ControlNode, Parameter("enable", value=True), "'enable' (did you mean 'enabled'?)"),
    ],
    ids=["sim", "sim-sail", "recorder", "replay", "bridge", "control"],
)
def test_an_unknown_parameter_stops_the_node(ros_context, tmp_path, node_class, override, message):
    """The refused node is destroyed where it is refused (while the error, and with it
    the half-made node, is still held): not left to the garbage collector, which may
    run after rclpy has shut down."""
    witness = Node("refusal_witness", context=ros_context)
    overrides = [override]
    if node_class is Recorder:
        overrides.append(Parameter("output", value=str(tmp_path / "bag")))
    with pytest.raises(ConfigError, match="unknown parameter") as raised:
        node_class(overrides, context=ros_context)
    assert message in str(raised.value)
    assert not (tmp_path / "bag").exists()  # the recorder made nothing
    assert witness.get_node_names() == ["refusal_witness"]
    witness.destroy_node()


def test_a_simulator_that_fails_after_its_commands_node_exists_destroys_both(
    ros_context, monkeypatch
):
    """The simulator takes commands with a second node: a failure after that node is
    made (here, its thread refused) leaves neither node behind."""
    witness = Node("refusal_witness", context=ros_context)

    def refused(*args, **kwargs):
        raise RuntimeError("no thread for the commands")

    monkeypatch.setattr(sim_module, "CommandThread", refused)
    with pytest.raises(RuntimeError, match="no thread for the commands"):
        SimNode(context=ros_context)
    assert witness.get_node_names() == ["refusal_witness"]
    witness.destroy_node()


def set_parameter(client_node, executor, name, value) -> tuple[bool, str]:
    client = client_node.create_client(SetParameters, "/sail_sim/set_parameters")
    wait_until(client.service_is_ready, 10.0, "the parameter service", executor=executor)
    parameter = ParameterMessage(
        name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    )
    future = client.call_async(SetParameters.Request(parameters=[parameter]))
    wait_until(future.done, 10.0, "the answer", executor=executor)
    (result,) = future.result().results
    return result.successful, result.reason


def test_run_time_changes_are_refused_by_name_or_published(ros_context):
    from rclpy.executors import SingleThreadedExecutor

    sim = SimNode(context=ros_context)
    sim.start()
    client = Node("strict_client", context=ros_context)
    events = []
    client.create_subscription(ParameterEvent, "/parameter_events", events.append, 100)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (sim, client):
        executor.add_node(node)
    try:
        ok, reason = set_parameter(client, executor, "max_rat", 2.0)
        assert not ok and reason == "unknown parameter 'max_rat' (did you mean 'max_rate'?)"
        assert not sim.has_parameter("max_rat")
        ok, reason = set_parameter(client, executor, "max_rate", 2.0)
        assert ok, reason
        assert sim.config.policy.max_rate == 2.0
        wait_until(
            lambda: any(
                e.node == "/sail_sim" and [p.name for p in e.changed_parameters] == ["max_rate"]
                for e in events
            ),
            5.0,
            "the parameter event",
            executor=executor,
        )
    finally:
        executor.shutdown()
        sim.destroy_node()
        client.destroy_node()


def test_a_params_file_without_a_section_for_the_node_stops_it(tmp_path, ros_env):
    params = tmp_path / "sim.yaml"
    params.write_text("sail_simm:\n  ros__parameters:\n    max_rate: 2.0\n")
    result = subprocess.run(
        [sys.executable, "-m", "sail_ros.cli", "sim", "--ros-args", "--params-file", str(params)],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert f"--params-file {params} has no section for node 'sail_sim' (it has 'sail_simm'; " \
        "did you mean 'sail_sim' for 'sail_simm'?)" in result.stderr  # fmt: skip
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("node", [bridge, recorder, replay], ids=lambda node: node.NODE_NAME)
def test_a_nodes_params_file_holds_its_defaults(node):
    """config/<node>.yaml says its values are the defaults: they are (an empty list, which
    a params file cannot type, is left out)."""
    name = node.NODE_NAME.removeprefix("sail_")
    document = yaml.safe_load((CONFIG / f"{name}.yaml").read_text())
    values = document[node.NODE_NAME]["ros__parameters"]
    defaults = {spec.name: spec.default for spec in node.SPECS if spec.default != []}
    assert values == defaults


def test_help_gives_the_ranges_the_nodes_enforce():
    """`--help` says what each parameter may be, as the node then enforces it (the
    integers in full)."""
    code, out, _ = run_tool("sim", ["--help"])
    assert code == 0
    assert "sail.n_boom_modes (default 8, read-only; [1, 30]): " in out
    assert "state_rate_hz (default 50.0; [0.01, 1000]): " in out
    assert "initial_lengths (default [10.0]; 1 or 4 values (booms a, b, c, d), each " in out
    assert "initial_hub_velocity (default [0.0, 0.0, 0.0]; 3 values, each [" in out
    code, out, _ = run_tool("recorder", ["--help"])
    out = " ".join(out.split())
    assert code == 0 and "([1024, 1073741824]; default: 1048576)" in out
    assert "([10, 10000000]; default: 10000)" in out
