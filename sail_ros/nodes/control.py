# ruff: noqa: E402  (the BLAS thread count must be set before numpy is imported)
"""Node `sail_control`: holds a free hub's attitude and heave while the booms deploy.

The loop is `control.DiscreteController` (an LQG designed from the model's plant,
scheduled over boom length; docs/control.md); this node wires it to ROS: it takes
each state sample of the simulator (`sail/hub_state`, `sail/boom_state`, and with a
design model with modes `sail/tip_deflection`), steps the controller once and
publishes the command (`sail/hub_wrench_cmd`, with `tip_forces` also
`sail/tip_force_cmd`), stamped with the time it is to act: the sample's plus
`loop_delay_s` (the simulator holds a hub wrench stamped ahead of its model until
then). Before it commands it asks the simulator for its parameters and refuses (exit
2, one line) a clamped hub, another sail or other mode counts, another state rate, or
limits below its own. When no sample comes for `stale_periods` periods (the simulator
paused or gone) it commands a zero wrench, says so once, and goes on when samples
return. /diagnostics (`sail_control: controller`) reports the loop latency (the
sample's publication to the command's), the delay with which the simulator applied
the commands (from its answers), and the saturations.

SIGINT/SIGTERM: a zero wrench, acknowledged, then exit 0. A bad parameter: exit 2.

    sail-ros control --ros-args --params-file config/closed_loop.yaml
    sail-ros control --ros-args -p sail.free_hub:=true -p weight_tilt:=1e5
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small matrices: one BLAS thread

import argparse
import collections
import gc
import json
import math
import sys
import textwrap
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import GetParameters
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from sail_ros import status as key
from sail_ros import topics
from sail_ros.control.agreement import SIMULATOR_PARAMETERS, disagreement
from sail_ros.control.design import command_limits, require_free_hub
from sail_ros.control.loop import DiscreteController, StaleWatch
from sail_ros.control.schedule import GainSchedule, design_schedule
from sail_ros.control.settings import NODE_SETTINGS, DesignSettings, NodeSettings
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.model.fields import ConfigError, fields_of
from sail_ros.options import PHYSICS_DOC, docstring_examples
from sail_ros.policy import Policy
from sail_ros.ros.commanding import command_publisher
from sail_ros.ros.parameters import declare, destroyed_if_refused, node_options
from sail_ros.ros.program import bounded_teardown, run_node, serve_until_stopped

NODE_NAME = topics.CONTROLLER_NODE
ENABLE_SERVICE = topics.CONTROL_ENABLE_SERVICE
MIN_TICK_S = 0.005  # the simulator ticks at most this often: samples come at least so apart
ACK_TIMEOUT_S = 1.0  # at shutdown, wait this long for the zero wrench to be acknowledged
ASK_AGAIN_S = 2.0  # an unanswered parameter request is sent again after this long
SPECS = NODE_SETTINGS
# newest samples only: a volatile subscription of the state (a late start does not replay
# the simulator's kept history as commands)
SAMPLE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=20,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
ANSWER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=200,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
# status keys (`/diagnostics`)
STATE, ENABLED, SAMPLES, COMMANDS = "state", "enabled", "samples", "commands"
SATURATED, SATURATIONS = "saturated_samples", "saturations"
LATENCY_MEDIAN, LATENCY_MAX = "latency_median_ms", "latency_max_ms"
LATENCY_COUNT = "latency_samples"
DELAY_MEDIAN, DELAY_MAX = "applied_delay_median_s", "applied_delay_max_s"
DELAY_DESIGN = "loop_delay_s"
STALE_SPELLS, LENGTH, DISTURBANCE = "stale_spells", "schedule_length_m", "disturbance"
REJECTED_COMMANDS = "rejected_commands"


def config_from_values(values: dict):
    """`(sail, design, node settings, policy)` from the parameters' values.

    Raises:
        ConfigError: a value the controller cannot use, naming it.
    """

    def table(cls):
        return cls(**{f.name: values[f.name] for f in fields_of(cls) if f.name in values})

    try:
        sail = topics.sail_parameters_from_flat(values)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    try:
        design, settings, policy = table(DesignSettings), table(NodeSettings), table(Policy)
        require_free_hub(sail)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    return sail, design, settings, policy


class ControlNode(Node):
    """The `sail_control` node (module docstring).

    Its arguments are `ros.parameters.node_options`'s and `clock`, the steady clock [s]
    of the watchdog (injected for tests).

    Raises:
        ConfigError: a parameter, or the gains file, the controller cannot use.
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None, clock=time.monotonic):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        self.clock = clock
        with destroyed_if_refused(self):
            self._set_up()

    def _set_up(self) -> None:
        """The gains, the subscriptions, the command publishers and the timers (raises
        ConfigError)."""
        self._values = declare(self, SPECS)
        self.sail, self.design, self.settings, self.policy = config_from_values(self._values)
        self.schedule = self._schedule()
        limits = command_limits(self.policy, self.schedule.inputs)
        self.controller = DiscreteController(self.schedule, limits)
        self.failure = ""  # why the controller cannot go on (exit 2)
        self.enabled = self.settings.enabled
        self._simulator = self.resolve_topic_name(self.settings.simulator_node)
        self._simulator_values: dict | None = None  # its parameters, once checked
        self._asked = -math.inf
        self._parameters_client = self.create_client(
            GetParameters, f"{self.settings.simulator_node}/get_parameters"
        )
        self._period_ns = round(self.design.period * 1e9)
        self._delay_ns = round(self.design.loop_delay_s * 1e9)
        self._watch = StaleWatch(self._stale_limit(1.0))
        self._parts: dict[int, dict] = {}  # stamp -> the sample's messages so far
        self._last_stamp: int | None = None
        self._length = math.nan
        self.commands = 0
        self.rejected = 0
        self._latencies: list[float] = []  # [s] of the current status window
        self._delays: collections.deque = collections.deque(maxlen=1000)  # [s], applied
        self._sent: collections.deque = collections.deque(maxlen=1000)  # (stamp, u) unanswered
        self._epoch_ns: int | None = None  # the simulator's stamp of its time 0
        self._said_zero = False
        wanted = [(topics.HUB_STATE, Odometry), (topics.BOOM_STATE, JointState)]
        if not self.design.rigid:
            wanted.append((topics.TIP_DEFLECTION, JointState))
        self._wanted = [name for name, _ in wanted]
        for name, kind in wanted:
            self.create_subscription(
                kind, name, lambda m, info, name=name: self._on_part(name, m, info), SAMPLE_QOS
            )
        self.create_subscription(
            DiagnosticArray, topics.COMMAND_STATUS, self._on_answers, ANSWER_QOS
        )
        self.create_subscription(
            DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics, topics.DIAGNOSTICS_QOS
        )
        self._wrench = command_publisher(self, topics.HUB_WRENCH_CMD)
        self._forces = (
            command_publisher(self, topics.TIP_FORCE_CMD) if self.design.tip_forces else None
        )
        self._status = self.create_publisher(
            DiagnosticArray, topics.DIAGNOSTICS, topics.DIAGNOSTICS_QOS
        )
        self._hub_topic = self.resolve_topic_name(topics.HUB_WRENCH_CMD)
        self.create_service(SetBool, ENABLE_SERVICE, self._on_enable)
        self._watch_timer = self.create_timer(self._watch.limit_s / 2, self._on_watch)
        self._status_timer = self.create_timer(
            1.0 / self.settings.diagnostics_rate_hz, self.publish_status
        )
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.get_logger().info(
            f"design model {self.design.design_model_text()}, {self.design.state_rate_hz:g} Hz, "
            f"loop delay {self.design.loop_delay_s:g} s, gains at {self.schedule.lengths.size} "
            f"lengths {self.schedule.lengths[0]:.4g}-{self.schedule.lengths[-1]:.4g} m; "
            f"commands {', '.join(self.schedule.inputs)} within {limits.tolist()}; waiting for "
            f"the parameters of '{self._simulator}'"
        )

    def _schedule(self) -> GainSchedule:
        path = self.settings.gains_file
        try:
            if not path:
                return design_schedule(self.sail, self.design)
            schedule = GainSchedule.load(path)
            schedule.check_against(self.design, f"gains_file {path}")
            return schedule
        except ValueError as error:
            raise ConfigError(str(error)) from None

    def _stale_limit(self, time_scale: float) -> float:
        """Wall time [s] without a sample after which the state is stale."""
        period = self.design.period / time_scale if time_scale > 0 else self.design.period
        return self.settings.stale_periods * max(period, MIN_TICK_S)

    # -- the simulator's parameters -----------------------------------------------------------

    def _ask_simulator(self) -> None:
        now = self.clock()
        if now - self._asked < ASK_AGAIN_S or not self._parameters_client.service_is_ready():
            return
        self._asked = now
        request = GetParameters.Request(names=list(SIMULATOR_PARAMETERS))
        self._parameters_client.call_async(request).add_done_callback(self._on_simulator)

    def _on_simulator(self, future) -> None:
        if self._simulator_values is not None or self.failure:
            return
        answer = future.result()
        if len(answer.values) != len(SIMULATOR_PARAMETERS):  # one unknown: none given
            self.failure = (
                f"'{self._simulator}' lacks parameters of a simulator of this package (asked "
                f"for {', '.join(SIMULATOR_PARAMETERS[:3])}, ...): is it sail_sim?"
            )
            return
        values = {
            name: parameter_value_to_python(value)
            for name, value in zip(SIMULATOR_PARAMETERS, answer.values, strict=False)
        }
        values = {name: value for name, value in values.items() if value is not None}
        error, warnings = disagreement(self.sail, self.design, self.policy, values, self._simulator)
        if error:
            self.failure = error
            return
        for warning in warnings:
            self.get_logger().warning(warning)
        self._simulator_values = values
        scale = float(values.get("time_scale", 1.0))
        self._watch = StaleWatch(self._stale_limit(scale))
        self._watch_timer.timer_period_ns = round(self._watch.limit_s / 2 * 1e9)
        self._watch_timer.reset()
        self.get_logger().info(
            f"'{self._simulator}' runs the plant of this design (time scale {scale:g}); "
            f"commanding from its next sample (stale after {1e3 * self._watch.limit_s:.3g} ms "
            "without one)"
        )

    # -- samples ----------------------------------------------------------------------------------

    def _on_part(self, name: str, message, info) -> None:
        stamp = topics.stamp_ns_of(message.header.stamp)
        parts = self._parts.setdefault(stamp, {"source_ns": math.inf})
        parts[name] = message
        parts["source_ns"] = min(parts["source_ns"], info["source_timestamp"])
        if all(topic in parts for topic in self._wanted):
            del self._parts[stamp]
            for older in [s for s in self._parts if s < stamp]:
                del self._parts[older]  # a sample that never completed: passed
            self._on_sample(stamp, parts)
        elif len(self._parts) > 8:
            del self._parts[min(self._parts)]

    def _on_sample(self, stamp: int, parts: dict) -> None:
        if self._watch.seen(self.clock()):
            self.get_logger().info(
                f"state samples again (stamp {stamp} ns): commanding from this one on"
            )
            self._said_zero = False
        if self._simulator_values is None:
            return
        self._follow_time(stamp)
        hub = hub_msg.hub_from_odometry(parts[topics.HUB_STATE])
        y = [hub]
        if not self.design.rigid:
            tips = parts[topics.TIP_DEFLECTION]
            y += [np.asarray(tips.position, dtype=float), np.asarray(tips.velocity, dtype=float)]
        self._length = float(np.mean(parts[topics.BOOM_STATE].position))
        command = self.controller.step(np.concatenate(y), self._length)
        if not self.enabled:
            self.controller.hold(np.zeros_like(command.u))
            return
        self._publish(command.u, stamp)
        self._latencies.append((time.time_ns() - parts["source_ns"]) * 1e-9)

    def _follow_time(self, stamp: int) -> None:
        """Tell the controller what happened since the last sample: a reset (the simulator
        repeats the last stamp) restarts it, samples that never came are skipped."""
        last, self._last_stamp = self._last_stamp, stamp
        if last is None:
            return
        periods = (stamp - last) / self._period_ns
        if stamp <= last or abs(periods - round(periods)) > 1e-3:
            self.controller.restart()
            self.get_logger().info(
                f"state at stamp {stamp} ns after {last} ns: a reset or a jump; the estimate "
                "starts again"
            )
        elif round(periods) > 1:
            self.controller.skip(round(periods) - 1)

    def _publish(self, u, stamp: int | None = None, answers: bool = True) -> None:
        """Publish the command `u` for the sample `stamp` [ns] (default the last one);
        `answers`: the command answers that sample (its applied delay is measured)."""
        stamp = self._last_stamp if stamp is None else stamp
        wrench = hub_msg.hub_wrench_command(*u[:3])  # frame "": the hub's body frame
        if stamp is not None:  # when it acts: the simulator holds it until then
            wrench.header.stamp = topics.stamp(stamp + self._delay_ns)
        self._wrench.publish(wrench)
        self._sent.append((stamp if answers else None, np.array(u[:3], dtype=float)))
        self.commands += 1
        if self._forces is not None:
            forces = commands_msg.load_command(
                topics.TIP_FORCE_CMD, dict(zip(topics.BOOM_JOINTS, map(float, u[3:]), strict=True))
            )
            if stamp is not None:
                forces.header.stamp = topics.stamp(stamp + self._delay_ns)
            self._forces.publish(forces)

    def command_zero(self, why: str) -> None:
        """A zero wrench (and tip forces) now, held by the controller's estimate too."""
        zero = np.zeros(len(self.schedule.inputs))
        self.controller.hold(zero)
        self._publish(zero, answers=False)
        if why:
            self.get_logger().warning(why)

    def _on_watch(self) -> None:
        if self._simulator_values is None and not self.failure:
            self._ask_simulator()
        if self._watch.check(self.clock()) and self._simulator_values is not None:
            limit = 1e3 * self._watch.limit_s
            self.command_zero(
                f"no state sample for {limit:.3g} ms ({self.settings.stale_periods:g} state "
                "periods): the simulator is paused or gone; commanding a zero wrench until "
                "samples come again"
            )

    # -- the simulator's answers ------------------------------------------------------------------

    def _on_diagnostics(self, array: DiagnosticArray) -> None:
        values = diagnostics_msg.diagnostic_values(array, self._simulator)
        if key.SIM_TIME in values:
            stamp = topics.stamp_ns_of(array.header.stamp)
            self._epoch_ns = stamp - round(float(values[key.SIM_TIME]) * 1e9)

    def _on_answers(self, array: DiagnosticArray) -> None:
        for answer in commands_msg.command_answers(array):
            if answer.topic != self._hub_topic:
                continue
            if answer.outcome == commands_msg.REJECTED:
                self.rejected += 1
                if self.rejected == 1:
                    self.get_logger().error(f"a command was rejected: {answer.message}")
                continue
            held = answer.values.get(commands_msg.LOADS_HELD)
            start = answer.values.get("t_start_s")
            if answer.outcome != commands_msg.ACCEPTED or held is None or start is None:
                continue
            values = np.asarray(json.loads(held), dtype=float)
            while self._sent:
                stamp, sent = self._sent.popleft()
                if np.array_equal(sent, values):
                    if stamp is not None and self._epoch_ns is not None:
                        self._delays.append(float(start) - (stamp - self._epoch_ns) * 1e-9)
                    break

    # -- switch, parameters, status ------------------------------------------------------------

    def _on_enable(self, request, response):
        response.message = self.set_enabled(bool(request.data))
        response.success = True
        return response

    def set_enabled(self, enabled: bool) -> str:
        if enabled == self.enabled:
            return f"already {'enabled' if enabled else 'disabled'}"
        self.enabled = enabled
        if not enabled and self._simulator_values is not None:
            self.command_zero("")
        text = "enabled" if enabled else "disabled: a zero wrench is held"
        self.get_logger().info(f"control {text}")
        return text

    def _check_parameters(self, parameters) -> SetParametersResult:
        try:
            for parameter in parameters:
                spec = next(s for s in SPECS if s.name == parameter.name)
                spec.check(parameter.value)
        except (ConfigError, StopIteration) as error:
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        for parameter in parameters:
            self._values[parameter.name] = parameter.value
            if parameter.name == "enabled":
                self.set_enabled(bool(parameter.value))
            elif parameter.name == "diagnostics_rate_hz":
                self._status_timer.timer_period_ns = round(1e9 / parameter.value)
                self._status_timer.reset()

    @property
    def state(self) -> str:
        if self._simulator_values is None:
            return "waiting"
        if self._watch.stale:
            return "stale"
        return "running" if self.enabled else "disabled"

    def status(self) -> tuple[str, str, dict]:
        """`(level, message, values)` of the controller now; a new latency window starts."""
        latencies, self._latencies = np.array(self._latencies), []
        delays = np.array(self._delays)
        controller = self.controller
        values = {
            STATE: self.state,
            ENABLED: self.enabled,
            SAMPLES: controller.samples,
            COMMANDS: self.commands,
            SATURATED: controller.saturated_samples,
            SATURATIONS: dict(
                zip(self.schedule.inputs, controller.saturations.tolist(), strict=True)
            ),  # fmt: skip
            LATENCY_COUNT: latencies.size,
            LATENCY_MEDIAN: round(1e3 * float(np.median(latencies)), 4) if latencies.size else -1.0,
            LATENCY_MAX: round(1e3 * float(latencies.max()), 4) if latencies.size else -1.0,
            DELAY_DESIGN: self.design.loop_delay_s,
            DELAY_MEDIAN: round(float(np.median(delays)), 6) if delays.size else -1.0,
            DELAY_MAX: round(float(delays.max()), 6) if delays.size else -1.0,
            REJECTED_COMMANDS: self.rejected,
            STALE_SPELLS: self._watch.spells,
            LENGTH: round(self._length, 6),
            DISTURBANCE: [round(float(v), 6) for v in controller.disturbance],
        }
        if self.state == "waiting":
            return "WARN", f"waiting for the parameters of '{self._simulator}'", values
        if self.state == "stale":
            return "WARN", "no state samples: a zero wrench is held", values
        slack = self.design.loop_delay_s + 0.5 * self.design.period
        if delays.size and float(np.median(delays)) > slack:
            return (
                "WARN",
                (
                    f"the simulator applies the commands {float(np.median(delays)):.4g} s after "
                    f"their sample, the design assumes {self.design.loop_delay_s:g} s"
                ),
                values,
            )
        return "OK", f"{self.state}: {controller.saturated_samples} saturated samples", values

    def publish_status(self) -> None:
        level, message, values = self.status()
        name = self.get_fully_qualified_name()
        self._status.publish(diagnostics_msg.diagnostics(
            time.time_ns(), level, message, {k: _text(v) for k, v in values.items()}, name,
            topics.controller_status_name(name),
        ))  # fmt: skip

    def close(self) -> None:
        """Leave the hub with a zero wrench, acknowledged (at most ACK_TIMEOUT_S)."""
        if self._simulator_values is not None and self.commands:
            zero = np.zeros(len(self.schedule.inputs))
            self._publish(zero, answers=False)
            self._wrench.wait_for_all_acked(Duration(nanoseconds=int(ACK_TIMEOUT_S * 1e9)))
            self.get_logger().info("stopped: a zero wrench commanded")


def _text(value) -> str:
    return json.dumps(value) if isinstance(value, dict | list | bool) else str(value)


def _parser() -> argparse.ArgumentParser:
    lines = [spec.parameter_help() for spec in SPECS]
    return argparse.ArgumentParser(
        prog="sail-ros control",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:3])
        + "\n\n"
        + textwrap.fill(
            "The design model is explicit: design_boom_modes and design_membrane_modes (0 "
            "and 0: the rigid-body model; docs/control.md says why that is the default) and "
            "the gains' schedule_lengths. `sail-ros plant --controller` checks the loop's "
            "poles against the full plant along a deployment.",
            88,
        )
        + "\n\n"
        + PHYSICS_DOC
        + "\n\nROS parameters (--ros-args -p name:=value, or --params-file "
        "config/closed_loop.yaml):\n"
        + "\n".join(lines)
        + "\n\nExamples:\n"
        + "\n".join(f"  {line}" for line in docstring_examples(__doc__)),
    )


def main(argv=None) -> int:
    """`sail-ros control [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    return run_node(NODE_NAME, _parser(), argv, _control)


def _control(_namespace, stop) -> int:
    node = ControlNode()
    # what start-up built (the gains, rclpy's objects) lives as long as the node: out of
    # the collector's way, a collection does not hold a sample's command back
    gc.collect()
    gc.freeze()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    failed = _Failed(node)
    try:
        serve_until_stopped(executor, node, stop, failed)
        if node.failure:
            raise ConfigError(node.failure)
        if stop.received:
            node.get_logger().info(f"{stop.received}: stopping")
        node.close()
    finally:
        executor.remove_node(node)
        with bounded_teardown():
            node.destroy_node()
    return 0


class _Failed:
    """`serve_until_stopped`'s `failed`: set once the node found it cannot go on."""

    def __init__(self, node: ControlNode):
        self._node = node

    def is_set(self) -> bool:
        return bool(self._node.failure)


if __name__ == "__main__":
    sys.exit(main())
