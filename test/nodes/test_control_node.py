"""Node `sail_control` in this process, beside a stand-in simulator in the same private
context: it checks the simulator's parameters before it commands, answers every state
sample with one command stamped with it, holds a zero wrench (said once) while no
samples come, switches off and on by its service, and refuses bad input by name."""

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from harness import Serving
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from sail_ros import topics
from sail_ros.control.schedule import design_schedule
from sail_ros.control.settings import DesignSettings
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.model import SailParameters
from sail_ros.model.fields import ConfigError
from sail_ros.nodes.control import ControlNode
from sail_ros.runtime.config import DEFAULTS

pytestmark = pytest.mark.node

SAIL = {"sail.free_hub": True, "sail.n_boom_modes": 2, "sail.n_membrane_modes": 2}
SIMULATOR = {
    **{name: value for name, value in DEFAULTS.items() if name.startswith("sail.")},
    **SAIL, "state_rate_hz": 100.0, "time_scale": 1.0, "integration_step": 0.01,
    "max_model_step": 0.01, "max_hub_force": 1.0, "max_hub_torque": 1.0, "max_tip_force": 1.0,
    "command_wait_s": 0.0,
}  # fmt: skip
PERIOD_NS = 10_000_000


class StandIn(Node):
    """A node called sail_sim with the simulator's parameters; publishes state samples
    on demand and keeps the wrench commands and the controller's statuses."""

    def __init__(self, context, parameters, namespace=None):
        super().__init__(topics.SIM_NODE, context=context, namespace=namespace)
        for name, value in parameters.items():
            self.declare_parameter(name, value)
        self.hub = self.create_publisher(Odometry, topics.HUB_STATE, topics.STATE_QOS)
        self.booms = self.create_publisher(JointState, topics.BOOM_STATE, topics.STATE_QOS)
        self.wrenches: list[WrenchStamped] = []
        self.statuses: list[dict] = []
        self.create_subscription(
            WrenchStamped, topics.HUB_WRENCH_CMD, self.wrenches.append, topics.COMMAND_QOS
        )
        self.create_subscription(
            DiagnosticArray, topics.DIAGNOSTICS, self._on_status, topics.DIAGNOSTICS_QOS
        )
        self.stamp = 1_700_000_000 * 10**9

    def _on_status(self, array):
        name = topics.controller_status_name(topics.absolute(topics.CONTROLLER_NODE,
                                                             self.get_namespace()))  # fmt: skip
        for status in array.status:
            if status.name == name:
                self.statuses.append({v.key: v.value for v in status.values})

    def sample(self, tilt_x=1e-3):
        self.stamp += PERIOD_NS
        hub = hub_msg.hub_state(self.stamp, [0.0, tilt_x, 0.0, 0.0, 0.0, 0.0])
        booms = JointState(name=list(topics.BOOM_JOINTS), position=[12.0] * 4, velocity=[0.0] * 4)
        booms.header.stamp = topics.stamp(self.stamp)
        self.booms.publish(booms)
        self.hub.publish(hub)


@pytest.fixture
def ros(ros_context):
    """`start(simulator parameters, **controller parameters) -> (controller, stand-in,
    spin_until)` in a private context (`conftest.ros_context`)."""
    context = ros_context
    serving = Serving(context, step=0.002)

    def start(simulator=SIMULATOR, namespace=None, **parameters):
        overrides = [Parameter(n, value=v) for n, v in {**SAIL, **parameters}.items()]
        controller = ControlNode(overrides, context=context, namespace=namespace)
        stand_in = StandIn(context, simulator, namespace)
        serving.add(controller, stand_in)
        return controller, stand_in, serving.spin_until

    yield start
    serving.close()


def commanding(controller, stand_in, spin_until):
    spin_until(lambda: controller.state != "waiting", 10.0, "the simulator's parameters")
    spin_until(lambda: controller._hub_topic and stand_in.booms.get_subscription_count(), 5.0,
               "the controller's subscriptions")  # fmt: skip
    time.sleep(0.2)  # discovery of the wrench publisher by the stand-in


def test_each_sample_gets_one_command_and_no_samples_a_zero_wrench_once(ros):
    # stale after 20 periods, as config/closed_loop.yaml: one round trip of this test
    # (sample, command, its arrival) on a loaded machine can outlast the default's 3
    controller, stand_in, spin_until = ros(stale_periods=20.0)
    commanding(controller, stand_in, spin_until)
    for _ in range(20):
        stand_in.sample(tilt_x=1e-3)
        spin_until(lambda: len(stand_in.wrenches) and topics.stamp_ns_of(
            stand_in.wrenches[-1].header.stamp) == stand_in.stamp, 2.0, "the command")  # fmt: skip
    answered = [topics.stamp_ns_of(w.header.stamp) for w in stand_in.wrenches]
    assert answered == sorted(set(answered)) and answered[-1] == stand_in.stamp
    assert stand_in.wrenches[-1].wrench.torque.x < 0.0  # against the tilt about x
    assert stand_in.wrenches[-1].header.frame_id == ""  # the hub's body frame
    assert controller.controller.samples == 20 and controller.state == "running"
    sent = len(stand_in.wrenches)
    limit = controller._watch.limit_s
    assert limit == pytest.approx(0.2)  # 20 periods of 10 ms
    deadline = time.monotonic() + 10 * limit
    spin_until(lambda: time.monotonic() > deadline, 10 * limit + 1.0, "time to pass")
    assert controller.state == "stale" and controller._watch.spells == 1
    assert len(stand_in.wrenches) == sent + 1  # one zero wrench, once
    zero = stand_in.wrenches[-1]
    assert (zero.wrench.force.z, zero.wrench.torque.x, zero.wrench.torque.y) == (0.0, 0.0, 0.0)
    assert topics.stamp_ns_of(zero.header.stamp) == stand_in.stamp  # after the last sample
    stand_in.sample()
    spin_until(lambda: len(stand_in.wrenches) == sent + 2, 2.0, "commands again")
    assert controller.state == "running" and stand_in.wrenches[-1].wrench.torque.x < 0.0
    # a status whose window holds that command's latency (none came while stale)
    spin_until(lambda: stand_in.statuses and float(stand_in.statuses[-1]["latency_median_ms"])
               >= 0.0, 3.0, "a status with the command's latency")  # fmt: skip
    assert int(stand_in.statuses[-1]["stale_spells"]) >= 1


def test_a_reset_restarts_the_estimate_and_missed_samples_are_predicted(ros):
    controller, stand_in, spin_until = ros()
    commanding(controller, stand_in, spin_until)
    for _ in range(5):
        stand_in.sample(tilt_x=2e-3)
        spin_until(lambda: topics.stamp_ns_of(stand_in.wrenches[-1].header.stamp)
                   == stand_in.stamp if stand_in.wrenches else False, 2.0, "a command")  # fmt: skip
    before = controller.controller._prior.copy()
    stand_in.stamp += 2 * PERIOD_NS  # two samples lost: predicted with the command held
    stand_in.sample(tilt_x=2e-3)
    spin_until(lambda: controller.controller.samples == 6, 2.0, "the sample after a gap")
    assert not np.allclose(before, controller.controller._prior)
    stand_in.stamp -= PERIOD_NS  # the simulator repeats the last stamp at a reset
    stand_in.sample(tilt_x=0.0)
    spin_until(lambda: controller.controller.samples == 7, 2.0, "the reset's sample")
    assert controller.controller.disturbance == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


def test_the_switch_holds_a_zero_wrench_and_lets_go(ros):
    controller, stand_in, spin_until = ros()
    commanding(controller, stand_in, spin_until)
    client = stand_in.create_client(SetBool, topics.CONTROL_ENABLE_SERVICE)
    spin_until(client.service_is_ready, 5.0, "the enable service")
    future = client.call_async(SetBool.Request(data=False))
    spin_until(future.done, 5.0, "its answer")
    assert future.result().success and "disabled" in future.result().message
    spin_until(lambda: stand_in.wrenches, 2.0, "the zero wrench")
    assert stand_in.wrenches[-1].wrench.torque.x == 0.0
    for _ in range(5):
        stand_in.sample()
    spin_until(lambda: controller.controller.samples == 5, 2.0, "the samples")
    assert len(stand_in.wrenches) == 1 and controller.state == "disabled"
    future = client.call_async(SetBool.Request(data=True))
    spin_until(future.done, 5.0, "its answer")
    stand_in.sample()
    spin_until(lambda: len(stand_in.wrenches) == 2, 2.0, "a command again")


@pytest.mark.parametrize(
    ("simulator", "message"),
    [
        ({**SIMULATOR, "sail.free_hub": False}, "the simulator /sail_sim has a clamped hub"),
        ({**SIMULATOR, "sail.n_boom_modes": 4}, "sail.n_boom_modes = 2 here, 4 in /sail_sim"),
        ({**SIMULATOR, "state_rate_hz": 50.0}, "state_rate_hz = 100 Hz here, 50 Hz in"),
        ({**SIMULATOR, "max_hub_torque": 0.5}, "max_hub_torque = 1 N m here, 0.5 N m in"),
        ({"state_rate_hz": 100.0}, "'/sail_sim' lacks parameters of a simulator"),
    ],
    ids=["clamped", "mode-counts", "rate", "limits", "not-a-simulator"],
)
def test_a_simulator_of_another_plant_stops_the_controller_before_it_commands(
    ros, simulator, message
):
    controller, stand_in, spin_until = ros(simulator)
    spin_until(lambda: controller.failure, 10.0, "the refusal")
    assert message in controller.failure
    stand_in.sample()
    deadline = time.monotonic() + 0.2
    spin_until(lambda: time.monotonic() > deadline, 1.0, "time to pass")
    assert not stand_in.wrenches and controller.commands == 0


def test_bad_parameters_and_gains_files_are_named(ros, tmp_path):
    with pytest.raises(
        ConfigError, match=r"parameter weight_tilt: Invalid parameter value \(nan\)"
    ):
        ros(weight_tilt=math.nan)
    with pytest.raises(ConfigError, match="sail.free_hub is false"):
        ros(**{"sail.free_hub": False})
    settings = DesignSettings(schedule_lengths=[10.0, 12.0])
    schedule = design_schedule(SailParameters(free_hub=True, n_boom_modes=2,
                                              n_membrane_modes=2), settings)  # fmt: skip
    path = tmp_path / "gains.npz"
    schedule.save(path)
    controller, _, _ = ros(gains_file=str(path))
    assert controller.schedule.lengths.tolist() == [10.0, 12.0]
    arrays = dict(np.load(path))
    arrays["G"] = arrays["G"][:, :, :2]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ConfigError, match=r"gains file .*bad.npz: G has shape \(2, 9, 2\)"):
        ros(gains_file=str(tmp_path / "bad.npz"))
    with pytest.raises(ConfigError, match="designed at 100 Hz, state_rate_hz is 50 Hz"):
        ros(gains_file=str(path), state_rate_hz=50.0)


def test_the_status_names_the_controller():
    array = diagnostics_msg.diagnostics(
        0,
        "OK",
        "running",
        {},
        "/sat2/sail_control",
        topics.controller_status_name("/sat2/sail_control"),
    )
    assert array.status[0].name == "sat2/sail_control: controller"


def test_in_a_namespace_it_controls_the_simulator_of_its_namespace(ros):
    controller, stand_in, spin_until = ros(namespace="/sat2")
    commanding(controller, stand_in, spin_until)
    assert controller._simulator == "/sat2/sail_sim"
    stand_in.sample()
    spin_until(lambda: stand_in.wrenches, 2.0, "a command in /sat2")
    assert controller._hub_topic == "/sat2/sail/hub_wrench_cmd"
    spin_until(lambda: stand_in.statuses, 3.0, "the status sat2/sail_control: controller")


def test_the_controllers_sail_defaults_are_the_simulators():
    """A controller and a simulator started with their defaults design for and run one
    sail (the simulator's own defaults, `LIVE_DEFAULTS`, included)."""
    from sail_ros.control.settings import NODE_SETTINGS

    sail = {s.name: s.default for s in NODE_SETTINGS if s.name.startswith("sail.")}
    assert sail == {name: value for name, value in DEFAULTS.items() if name.startswith("sail.")}
    assert sail["sail.membrane_band"] != SailParameters().membrane_band  # the live one
