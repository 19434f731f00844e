# ruff: noqa: E402  (the BLAS thread count must be set before numpy is imported)
"""Node `sail_sim`: the solar sail's deployment dynamics and vibration in real time.

The run itself is `runtime.realtime.RealTimeRun` (pacing, stepping, commands,
status); this node wires it to ROS: parameters (`runtime.config`), command
subscriptions, the reset and pause services, the publishers of its outputs
(msg_docs/README.md), and a `Ticker` thread that calls its `tick`. The
executor's thread serves the parameters and services, and what they change is
done on the ticks' thread (`RealTimeRun.later`): however long the model's work,
the executor never waits for it. The commands have a thread of their own.

Stamps are simulation time: the wall-clock (ROS system) time when the node
started plus the simulation time, so with time_scale 1 they follow the
ROS clock (trailing it by any time spent paused); with any other time
scale /clock carries the same times for nodes with use_sim_time.

SIGINT/SIGTERM: stop, let subscribers acknowledge what was published, exit 0.
A bad parameter: exit 2.

    sail-ros sim --ros-args --params-file config/sim.yaml
    sail-ros sim --ros-args -p time_scale:=5.0 -p initial_tip_deflection:=[0.1,0.0,0.0,0.0]
    sail-ros sim --ros-args -p time_scale:=8.0 -p realtime_priority:=50
"""

import os

# The model's matrices are small: one BLAS thread is fastest, and OpenBLAS
# reads this only when numpy loads it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import gc
import sys
import threading
import time
import traceback

from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import SetBool, Trigger

from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.messages import state as state_msg
from sail_ros.messages.cdr import ShapeSerializer, StateSerializer
from sail_ros.model import SailModel
from sail_ros.model.shape import SailSurface
from sail_ros.options import PHYSICS_DOC, docstring_examples
from sail_ros.ros.commanding import decode
from sail_ros.ros.discovery import subscriptions_of
from sail_ros.ros.parameters import ConfigError, declare, destroyed_if_refused, node_options
from sail_ros.ros.program import bounded_teardown, run_node, serve_until_stopped
from sail_ros.ros.taking import take_waiting
from sail_ros.runtime.affordable import StepCost
from sail_ros.runtime.config import SETTINGS, config_from_values
from sail_ros.runtime.intake import Undecodable
from sail_ros.runtime.realtime import RealTimeRun
from sail_ros.runtime.ticker import Ticker

NODE_NAME = "sail_sim"
ACK_TIMEOUT_S = 1.0  # at shutdown, wait this long for subscribers to acknowledge
TICK_STOP_S = 0.5  # ... and this long for a tick under way to end
SWITCH_INTERVAL_S = 0.0005  # the interpreter's switch interval in the simulator's process
# Commands act at the next tick (ticks are at least 5 ms apart): taking bursts more often
# buys nothing, and each wake-up of the commands' executor costs ~0.4 ms of the
# interpreter that a tick would wait for. After a wake-up everything waiting is taken.
INTAKE_PAUSE_S = 0.005
# ... but after a wake-up that found one command alone, a stream (a controller's, one
# command a state sample) rather than a burst, a rest of INTAKE_PAUSE_S would have the
# next command of a stream at the tick rate miss its tick about every other time: the
# rest is this long then
STREAM_PAUSE_S = 0.001
# A burst that fills the queue waits this long at most for a tick to take it (the ticks
# are at most MAX_TICK_PERIOD_S apart, and one is called at once); what still finds the
# queue full is rejected.
QUEUE_WAIT_S = 0.1
SPECS = SETTINGS


class SimNode(Node):
    """The `sail_sim` node: `run` (a `RealTimeRun`) wired to topics, services,
    parameters and a ticker thread from `start` on. With `realtime_priority` the ticks'
    thread alone is scheduled first-in first-out.

    Its arguments are `ros.parameters.node_options`'s.

    Raises:
        ConfigError: a parameter has a value the simulator cannot use.
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        with destroyed_if_refused(self):
            self._set_up()

    def _set_up(self) -> None:
        """The model, its publishers, the ticks and the commands' node (raises ConfigError)."""
        self._values = declare(self, SPECS)
        self.config = config = config_from_values(self._values)
        sail = config.resolved_sail
        try:
            model = SailModel(sail)
        except ValueError as error:  # mode counts whose integrals would not fit
            raise ConfigError(f"sail.n_boom_modes, sail.n_membrane_modes: {error}") from None
        # what a sub-step of this model costs here: how short a min_length it affords
        self._cost = StepCost.measure(model, config)
        self._cost.check(model, config)
        self.surface = SailSurface(model, config.shape_divisions)
        self._shape = ShapeSerializer(
            self.surface.triangles, self.surface.boom_stations.size, config.frame_id
        )
        published = [*topics.STATE_TOPICS, topics.SHAPE, topics.DIAGNOSTICS, topics.COMMAND_STATUS]
        commands = list(topics.COMMAND_TOPICS)
        if model.free_hub:  # its state and wrench exist only then (msg_docs/hub_state.md)
            published.append(topics.HUB_STATE)
            commands.append(topics.HUB_WRENCH_CMD)
        if config.time_scale != 1.0:
            published.append(topics.CLOCK)
        self._states = StateSerializer(
            model.coordinate_names,
            config.frame_id,
            with_clock=topics.CLOCK in published,
            free_hub=model.free_hub,
            inertial_frame_id=config.inertial_frame_id,
        )
        self._outputs = {
            name: self.create_publisher(
                topics.TOPICS[name].message_type, name, topics.TOPICS[name].qos
            )
            for name in published
        }
        self._ticker = None
        self._clock_ns = -1  # the last /clock published [ns]
        self.run = RealTimeRun(
            model,
            config,
            self,
            time.time_ns(),
            on_schedule=self._on_schedule,
            resolve=self.resolve_topic_name,
        )
        self._ticker = Ticker(
            self.run.tick, self.run.lock, "sail_sim ticks", on_failure=self._on_failure
        )
        self.failed = threading.Event()  # the integration thread raised: the node must end
        self.run.realtime_priority = self._schedule_ticks()
        # Commands are taken by a lean node of their own on a thread of its own: rclpy
        # rebuilds its wait set of every entity of an executor for each message taken,
        # and at 1000 commands a second this node's (parameter services, publishers'
        # event handlers) cost more than a core; once woken, it takes every command
        # waiting (`_receive`) and then pauses (`INTAKE_PAUSE_S`). No event handlers: each
        # command topic is taken twice (topics.COMMAND_QOS), and a transient-local
        # subscription that does not match a volatile publisher is as meant, not news.
        self._commands = Node(
            topics.SIM_COMMANDS_NODE,
            context=self.context,
            namespace=self.get_namespace(),
            start_parameter_services=False,
        )
        # should what follows fail, this node is destroyed here (the simulator's by `__init__`)
        with destroyed_if_refused(self._commands):
            self._subscribe_commands(commands)
            self.create_service(Trigger, topics.RESET_SERVICE, self._on_reset)
            self.create_service(SetBool, topics.PAUSE_SERVICE, self._on_pause)
            self.add_on_set_parameters_callback(self._check_parameters)
            self.add_post_set_parameters_callback(self._apply_parameters)

    def _subscribe_commands(self, commands) -> None:
        """The command topics `commands` on the commands' node, and the thread that serves it."""
        quiet = SubscriptionEventCallbacks(use_default_callbacks=False)
        # command topic (resolved) -> its type, and the subscriptions of both the graph
        # shows: all of them, and those of the type (`SUBSCRIBERS` of each answer)
        self._command_types = {
            self._commands.resolve_topic_name(name): topics.TOPICS[name].type_name
            for name in commands
        }
        self._subscriptions_seen: dict[str, int] = {}
        self._listeners: dict[str, int] = {}
        self._command_subscriptions = [
            (
                name,
                self._commands.create_subscription(
                    topics.TOPICS[name].message_type,
                    name,
                    lambda data, info, name=name: self._receive(name, data, info),
                    qos,
                    event_callbacks=quiet,
                    raw=True,  # read here: bytes that are no command are answered too
                ),
            )
            for name in commands
            for qos in topics.COMMAND_INTAKE_QOS
        ]
        self._burst = True  # the last wake-up of the commands' node took more than one
        self._intake = CommandThread(
            self._commands, lambda: INTAKE_PAUSE_S if self._burst else STREAM_PAUSE_S
        )

    @property
    def sim(self):
        """The simulation (state, counts) of the run."""
        return self.run.sim

    def start(self) -> None:
        """Start the clock and the ticks, and publish the initial state.

        Apart from construction so that whoever runs the node can finish its own set-up
        first (`_simulate` moves start-up's objects out of the collector's way, which
        would otherwise delay the first ticks)."""
        # before the clock starts: a process's first log line takes rclpy ~70 ms (it
        # looks up the caller's module among all loaded), the interpreter's lock held
        epoch_ns = time.time_ns()
        self._log_start(epoch_ns)
        self.run.start(epoch_ns)

    def _log_start(self, epoch_ns: int) -> None:
        config, model = self.config, self.sim.model
        speed = (
            "as fast as possible"
            if config.as_fast_as_possible
            else f"time scale {config.time_scale:g}"
        )
        if self.run.realtime_priority:
            speed += f", integration thread at real-time priority {self.run.realtime_priority}"
        self.get_logger().info(
            f"{model.n} coordinates (n_B = {model.n_boom_modes}, n_M = "
            f"{model.n_membrane_modes}), step {config.integration_step:g} s, {speed}; "
            f"booms at {config.initial_lengths.tolist()} m; stamps = {epoch_ns} ns + "
            "simulation time"
        )
        note = config.live_counts_note()
        if note:
            self.get_logger().info(note)

    def _schedule_ticks(self) -> int:
        """Put the ticks' thread on real-time scheduling if `realtime_priority` asks for it
        and the run is paced; returns the priority it runs at (0: normal scheduling)."""
        priority = self.config.realtime_priority
        if not priority:
            return 0
        if self.config.as_fast_as_possible:
            self.get_logger().warning(
                f"realtime_priority {priority} ignored: as fast as possible, the integration "
                "thread never waits and would take a core from everything else"
            )
            return 0
        try:
            self._ticker.make_realtime(priority)
        except OSError as error:
            self.get_logger().warning(
                f"realtime_priority {priority} refused ({error.strerror or error}): the "
                "integration thread keeps normal scheduling; real-time priorities need "
                f"CAP_SYS_NICE or an rtprio limit (ulimit -r) of at least {priority}"
            )
            return 0
        return priority

    def _on_failure(self, error: BaseException) -> None:
        self.failed.set()
        self.get_logger().error(
            "the integration thread failed:\n" + "".join(traceback.format_exception(error)).rstrip()
        )

    def _on_schedule(self, period: float) -> None:
        if self._ticker is not None:
            self._ticker.set(period, True)

    # -- parameters, services, commands: the executor's thread -----------------------------------

    def _check_parameters(self, parameters) -> SetParametersResult:
        """On-set: accept a change only if the whole configuration stays valid, and its
        booms at min_length affordable (`StepCost.check`)."""
        try:
            config = config_from_values({**self._values, **{p.name: p.value for p in parameters}})
            self._cost.check(self.sim.model, config)
        except ConfigError as error:
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        """Post-set: use the new values, and say so (the recorder keeps the change too)."""
        self._values.update({p.name: p.value for p in parameters})
        self.config = config = config_from_values(self._values)
        self._on_ticks(lambda: self.run.configure(config))  # this thread waits for no step
        for parameter in parameters:
            self.get_logger().info(
                f"parameter {parameter.name} set to {parameter.value!r} at t = {self.sim.t:.6f} s"
            )

    def _receive(self, name: str, data: bytes, info: dict) -> None:
        """A command's CDR bytes from the commands' executor, then every other one already
        waiting, each read as its topic's type and submitted in the order they arrived
        (DDS's reception times). Bytes that are no such message are submitted as
        `Undecodable`, to be answered and counted as rejected: a typed subscription
        would drop them without a word."""
        # With the run's lock held, as a tick: the two then never take turns at the
        # interpreter (every switch interval), which under a flood doubled a tick's wall
        # time; a tick waits for at most one burst, and a burst for at most one tick.
        self._count_listeners()  # before: the graph's lock is not the run's to wait on
        with self.run.lock:
            taken = [(name, data, info)]
            for other, subscription in self._command_subscriptions:
                taken.extend(
                    (other, *pair)
                    for pair in take_waiting(subscription, topics.COMMAND_INTAKE_DEPTH)
                )
            taken.sort(key=lambda command: command[2].get("received_timestamp") or 0)
            self._burst = len(taken) > 1
            taken = [(topic, _read(topic, data), info) for topic, data, info in taken]
            wake, rest = self._submit_while_room(taken)
        while rest:
            # The queue is full (a burst larger than it, or the sender stalled and then
            # caught up): a tick takes it as one batch now, and the rest waits for that,
            # at most QUEUE_WAIT_S, rather than being rejected; then what still finds it
            # full is rejected and counted.
            self._ticker.poke()
            room = self.run.queue.wait_for_room(QUEUE_WAIT_S)
            with self.run.lock:
                woken, rest = self._submit_while_room(rest, force=not room)
            wake = wake or woken
        if wake:
            self._ticker.poke()  # paused: no tick would come before the next status

    def _count_listeners(self) -> None:
        """Refresh how many subscriptions of its type each command topic has (a sender
        waits for as many): the count by type reads every subscription's details (~80
        us), so only when the topic's total changed (~5 us to ask)."""
        for topic, type_name in self._command_types.items():
            total = self._commands.count_subscribers(topic)
            if self._subscriptions_seen.get(topic) != total:
                self._subscriptions_seen[topic] = total
                self._listeners[topic] = subscriptions_of(self._commands, topic, type_name)

    def _submit_while_room(self, commands: list, force: bool = False) -> tuple[bool, list]:
        """Submit `commands` in order while the queue has room (all of them if `force`);
        whether the run should be woken, and the commands left."""
        wake = False
        for index, command in enumerate(commands):
            if self.run.queue.full() and not force:
                return wake, commands[index:]
            wake = self.run.submit(*command) or wake
        return wake, []

    async def _on_reset(self, request, response):
        response.message = await self._on_ticks(self.run.reset)
        response.success = True
        return response

    async def _on_pause(self, request, response):
        response.message = await self._on_ticks(lambda: self.run.pause(request.data))
        response.success = True
        return response

    def _on_ticks(self, action) -> Future:
        """`action()` on the ticks' thread, woken for it at once (`RealTimeRun.later`); its
        result as a future of this node's executor, which meanwhile serves everything
        else: however long a grid step takes, the executor never waits for it (a service
        callback awaits the future and answers once it is done)."""
        future = Future(executor=self.executor)
        future.add_done_callback(lambda _: None)  # its scheduling wakes the executor

        def act():
            try:
                future.set_result(action())
            except Exception as error:  # the service's caller learns of it, as rclpy's would
                future.set_exception(error)
                raise

        self.run.later(act)
        self._ticker.poke()
        return future

    # -- outputs of the run (`runtime.realtime.Outputs`) ---------------------------------------

    def state(self, stamp_ns: int, sample) -> None:
        for name, data in self._states.serialize(stamp_ns, sample):
            if name == topics.CLOCK and not self._clock_moved(stamp_ns):
                continue
            self._outputs[name].publish(data)  # CDR bytes of `messages.state.state_messages`

    def _clock_moved(self, stamp_ns: int) -> bool:
        """Whether /clock may go out at `stamp_ns` [ns]: only forward, never the same
        time twice (a reset's own sample repeats the stamp of the state it leaves, and a
        status repeats the latest sample's), so a `use_sim_time` node never sees its
        clock stand still on a message; noted as published if so."""
        if stamp_ns <= self._clock_ns:
            return False
        self._clock_ns = stamp_ns
        return True

    def shape(self, stamp_ns: int, q, lengths) -> None:
        self._outputs[topics.SHAPE].publish(  # CDR bytes of `messages.shape.shape`
            self._shape.serialize(
                stamp_ns, self.surface.vertices(q, lengths), self.surface.boom_lines(q, lengths)
            )
        )

    def status(self, stamp_ns: int, level: str, message: str, values: dict) -> None:
        self._outputs[topics.DIAGNOSTICS].publish(
            diagnostics_msg.diagnostics(
                stamp_ns, level, message, values, self.get_fully_qualified_name()
            )
        )
        # the time reached since the last state sample (fewer samples than grid steps)
        if topics.CLOCK in self._outputs and self._clock_moved(stamp_ns):
            self._outputs[topics.CLOCK].publish(state_msg.clock(stamp_ns))

    def answers(self, answers: list[commands_msg.CommandAnswer]) -> None:
        # who listens on each command topic, counted as the commands came (`_receive`, not
        # on this thread): a sender waits for as many
        counted = [
            a._replace(
                values={**a.values, commands_msg.SUBSCRIBERS: str(self._listeners.get(a.topic, 0))}
            )
            for a in answers
        ]
        self._outputs[topics.COMMAND_STATUS].publish(
            commands_msg.command_status(self.run.stamp_ns(), counted)
        )

    def log(self, severity: str, text: str) -> None:
        # one call site per severity: rclpy's logger refuses a site that changes it
        logger = self.get_logger()
        if severity == "error":
            logger.error(text)
        elif severity == "warning":
            logger.warning(text)
        else:
            logger.info(text)

    # -- shutdown --------------------------------------------------------------------------------

    def close(self) -> None:
        """Stop integrating and give subscribers time to acknowledge what was published.
        A grid step still under way after TICK_STOP_S is not waited for."""
        self._intake.stop()
        if self._ticker.stop(TICK_STOP_S):
            self.run.finish()
        else:
            self.get_logger().warning(
                f"the integration thread is still in a step after {TICK_STOP_S:g} s: stopping "
                "without it"
            )
        deadline = time.monotonic() + ACK_TIMEOUT_S
        for publisher in self._outputs.values():
            remaining = max(0.0, deadline - time.monotonic())
            publisher.wait_for_all_acked(Duration(nanoseconds=int(remaining * 1e9)))

    def destroy_node(self) -> None:
        self._intake.stop()
        self._ticker.stop(TICK_STOP_S)
        self._commands.destroy_node()
        super().destroy_node()


def _read(topic: str, data: bytes):
    """The command of `topic` that CDR bytes `data` hold, or `Undecodable` saying why not."""
    kind = topics.TOPICS[topic]
    try:
        return decode(data, kind.message_type)
    except ValueError as error:
        return Undecodable(len(data), kind.type_name, str(error))


class CommandThread:
    """Serves `node` (the command subscriptions) with an executor on a thread of its own
    until `stop`, resting `rest()` [s] after each wake-up."""

    def __init__(self, node: Node, rest):
        self._node = node
        self._rest = rest
        self._executor = SingleThreadedExecutor(context=node.context)
        self._executor.add_node(node)
        self._stopping = threading.Event()
        self._wake = node.create_guard_condition(lambda: None)  # ends a wait at once
        self._thread = threading.Thread(target=self._serve, name="sail_sim commands", daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        try:
            while not self._stopping.is_set() and self._node.context.ok():
                self._executor.spin_once(timeout_sec=1.0)
                self._stopping.wait(self._rest())
        except ExternalShutdownException:
            pass

    def stop(self) -> None:
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._wake.trigger()
        self._thread.join()
        self._executor.remove_node(self._node)
        self._executor.shutdown()


def _parser() -> argparse.ArgumentParser:
    lines = ["  " + spec.parameter_help() for spec in SPECS]
    return argparse.ArgumentParser(
        prog="sail-ros sim",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=PHYSICS_DOC
        + "\n\nROS parameters (--ros-args -p name:=value, or --params-file config/sim.yaml):\n"
        + "\n".join(lines)
        + "\n\nExamples:\n"
        + "\n".join(f"  {line}" for line in docstring_examples(__doc__)),
    )


def main(argv=None) -> int:
    """`sail-ros sim [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    return run_node(NODE_NAME, _parser(), argv, _simulate)


def _simulate(_namespace, stop) -> int:
    # The ticks' thread must not wait Python's default 5 ms for the interpreter while the
    # executor's thread takes a burst of commands (1000 a second: overruns at 5 ms).
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    node = SimNode()
    # What start-up built (the model's integrals, rclpy's objects) lives as long as
    # the node: out of the collector's way, a collection no longer pauses a tick
    # for tens of milliseconds.
    gc.collect()
    gc.freeze()
    node.start()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        serve_until_stopped(executor, node, stop, node.failed)
        if stop.received:
            node.get_logger().info(f"{stop.received}: stopping at t = {node.sim.t:.6f} s")
    finally:
        node.close()
        executor.remove_node(node)
        with bounded_teardown():
            node.destroy_node()
    return 1 if node.failed.is_set() else 0


if __name__ == "__main__":
    sys.exit(main())
