# ruff: noqa: E402  (the BLAS thread count must be set before numpy is imported)
"""Node `sail_sim`: the solar sail's deployment dynamics and vibration in real time.

Integrates the sail model (`sail_ros.model`, model.md) and samples it on a
fixed grid of `integration_step` seconds (`Simulation`), paced by the steady clock (`time_scale`
simulation seconds per wall second), and publishes the boom state, the
modal state, the boom-tip deflections, the sail's shape and diagnostics
(msg_docs/README.md). Booms move on `sail/boom_length_cmd` and
`sail/deploy_cmd`; `sail/reset` and `sail/pause` control the run.

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
import functools
import gc
import math
import sys
import threading
import time

from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import SetBool, Trigger

from sail_ros import topics
from sail_ros.cli import PHYSICS_DOC
from sail_ros.message_bytes import ShapeSerializer, StateSerializer
from sail_ros.model import SailModel
from sail_ros.model.shape import SailSurface
from sail_ros.nodes.commands import CommandError
from sail_ros.nodes.diagnosis import Observations, diagnose
from sail_ros.nodes.intake import DUPLICATE, STALE, CommandIntake, CommandQueue
from sail_ros.nodes.pacing import Pacer, RealTimeFactor
from sail_ros.nodes.parameters import ConfigError, declare, node_options
from sail_ros.nodes.sim_params import SPECS, config_from_values
from sail_ros.nodes.simulation import RUNNING, Simulation
from sail_ros.nodes.ticker import Ticker, following_call
from sail_ros.ros_cli import bounded_teardown, run_node, serve_until_stopped

NODE_NAME = "sail_sim"
ACK_TIMEOUT_S = 1.0  # at shutdown, wait this long for subscribers to acknowledge
RECEPTION_WAIT_S = 1.0  # the reception thread's longest wait (a stop wakes it at once)
RTF_MIN_WINDOW_S = 0.5  # the real-time factor is measured over running windows this long
OVERRUN_LOG_INTERVAL_S = 5.0  # overruns are counted in /diagnostics, logged this seldom


def _locked(method):
    """The method with the node's `lock` held (callbacks of the executor's thread)."""

    @functools.wraps(method)
    def locked(self, *args):
        with self.lock:
            return method(self, *args)

    return locked


class SimNode(Node):
    """The `sail_sim` node. The integration and the diagnostics run on a thread of
    their own (`Ticker`) from `start` on, commands are taken from DDS on another
    (`_reception`); services, parameters and commands run in the executor's callbacks.
    `lock` is held around anything that reads or changes the simulation. With
    `realtime_priority` the ticks' thread alone is scheduled first-in first-out.

    Args:
        parameter_overrides: initial parameter values (besides --ros-args).
        context: the rclpy context (default: the global one).
        namespace: the node's namespace (default: from --ros-args, else "/").

    Raises:
        ConfigError: a parameter has a value the simulator cannot use.
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        self._values = declare(self, SPECS)
        self.config = config = config_from_values(self._values)
        try:
            model = SailModel(config.sail)
        except ValueError as error:  # mode counts whose integrals would not fit
            raise ConfigError(f"sail.n_boom_modes, sail.n_membrane_modes: {error}") from None
        self.sim = Simulation(model, config)
        self.surface = SailSurface(model, config.shape_divisions)
        self._shape = ShapeSerializer(
            self.surface.triangles, self.surface.boom_stations.size, config.frame_id
        )
        self.pacer = Pacer(
            config.time_scale, config.integration_step, config.steps_between(config.state_rate_hz)
        )
        self.overruns = 0
        self._overrun_logged = -math.inf  # steady clock [s] of the last overrun line

        published = [*topics.STATE_TOPICS, topics.SHAPE, topics.DIAGNOSTICS, topics.COMMAND_STATUS]
        if config.time_scale != 1.0:
            published.append(topics.CLOCK)
        self._states = StateSerializer(
            model.coordinate_names, config.frame_id, with_clock=topics.CLOCK in published
        )
        self._outputs = {
            name: self.create_publisher(
                topics.TOPICS[name].message_type, name, topics.TOPICS[name].qos
            )
            for name in published
        }
        # Commands are taken from DDS by a node of their own on its own thread, so a
        # long tick cannot let DDS overwrite them, into a bounded, counted queue that
        # this node's thread empties (`_run_commands`).
        self.intake = CommandIntake(time.time_ns())
        self.queue = CommandQueue(config.max_queued_commands)
        self._commands_waiting = self.create_guard_condition(self._run_commands)
        self._reception = Node(
            f"{NODE_NAME}_commands", context=self.context, namespace=self.get_namespace()
        )
        for name in topics.COMMAND_TOPICS:
            for qos in topics.COMMAND_INTAKE_QOS:
                self._reception.create_subscription(
                    topics.TOPICS[name].message_type,
                    name,
                    lambda message, info, name=name: self._receive(name, message, info),
                    qos,
                )
        self._reception_stop = threading.Event()
        # wakes the reception thread's wait at once when it is to stop
        self._reception_wake = self._reception.create_guard_condition(lambda: None)
        self._reception_thread = threading.Thread(
            target=self._spin_reception, name="sail_sim commands", daemon=True
        )
        self._reception_thread.start()
        self.create_service(Trigger, topics.RESET_SERVICE, self._on_reset)
        self.create_service(SetBool, topics.PAUSE_SERVICE, self._on_pause)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.lock = threading.RLock()
        # the node's periodic work (integration and diagnostics) runs on this thread;
        # the executor only serves commands, services and parameters
        self._ticker = Ticker(self._tick, self.lock, "sail_sim ticks")
        self.realtime_priority = self._schedule_ticks()  # 0: normal scheduling
        self._diagnostics_period = 1.0 / config.diagnostics_rate_hz  # s
        self._diagnostics_due = math.inf  # steady clock [s]; set by `start`
        self._started = False
        self.epoch_ns = time.time_ns()  # the stamp of simulation time 0 (again at `start`)
        self.real_time_factor = RealTimeFactor(RTF_MIN_WINDOW_S)
        self._window = self._window_start()
        self._use_config()

    def start(self) -> None:
        """Start the clock, the ticks and the diagnostics, and publish the initial state.

        Apart from construction so that whoever runs the node can finish its own set-up
        first (`_simulate` moves start-up's objects out of the collector's way, which
        would otherwise delay the first ticks)."""
        with self.lock:
            if self._started:
                return
            self._started = True
            self.epoch_ns = time.time_ns()
            # before the clock starts: a process's first log line takes rclpy ~70 ms
            # (it looks up the caller's module among all loaded), the interpreter's lock
            # held, which would hold up the first ticks
            self._log_start()
            self.pacer.run_from(self.sim.t)
            self.real_time_factor.restart(self.sim.t, self.sim.state == RUNNING)
            self._window = self._window_start()
            self._diagnostics_due = time.monotonic() + self._diagnostics_period
            self._set_ticks()
            self._start_sampling()

    def _log_start(self) -> None:
        config, model = self.config, self.sim.model
        speed = (
            "as fast as possible"
            if config.as_fast_as_possible
            else f"time scale {config.time_scale:g}"
        )
        if self.realtime_priority:
            speed += f", integration thread at real-time priority {self.realtime_priority}"
        self.get_logger().info(
            f"{model.n} coordinates (n_B = {model.n_boom_modes}, n_M = "
            f"{model.n_membrane_modes}), step {config.integration_step:g} s, {speed}; "
            f"booms at {config.initial_lengths.tolist()} m; stamps = {self.epoch_ns} ns + "
            "simulation time"
        )

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

    # -- parameters -------------------------------------------------------------------------

    def _check_parameters(self, parameters) -> SetParametersResult:
        """On-set: accept a change only if the whole configuration stays valid."""
        try:
            config_from_values({**self._values, **{p.name: p.value for p in parameters}})
        except ConfigError as error:
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    @_locked
    def _apply_parameters(self, parameters) -> None:
        """Post-set: use the new values, and say so (the recorder keeps the change too,
        from /parameter_events)."""
        self._values.update({p.name: p.value for p in parameters})
        self.config = config_from_values(self._values)
        self._use_config()
        for parameter in parameters:
            self.get_logger().info(
                f"parameter {parameter.name} set to {parameter.value!r} at t = {self.sim.t:.6f} s"
            )

    def _use_config(self) -> None:
        """Publication intervals, range limits, loads and the ticks' period from
        `self.config`."""
        config = self.config
        self.sim.range_limits = (config.tip_warn_fraction, config.tip_error_fraction)
        if config.solar_pressure != self.sim.solar_pressure:
            self.sim.set_solar_pressure(config.solar_pressure)
        self._every_state = config.steps_between(config.state_rate_hz)
        self._every_shape = config.steps_between(config.shape_rate_hz)
        self.pacer.tick_steps = self._every_state
        period = 1.0 / config.diagnostics_rate_hz
        if period != self._diagnostics_period:
            self._diagnostics_period = period
            self._diagnostics_due = min(self._diagnostics_due, time.monotonic() + period)
        self._set_ticks()

    def _set_ticks(self) -> None:
        """Tick at the pacing's period while running (at least as often as diagnostics
        are due), else at the diagnostics' period (nothing before `start`)."""
        if not self._started:
            return
        period = self._diagnostics_period
        if self.sim.state == RUNNING:
            period = min(period, self.pacer.tick_period)
        self._ticker.set(period, True)

    # -- integration ------------------------------------------------------------------------

    def _tick(self) -> None:
        """One wake-up of the ticks' thread: integrate while running, and publish the
        diagnostics when they are due."""
        if self.sim.state == RUNNING:
            self._integrate()
        now = time.monotonic()
        if now >= self._diagnostics_due:
            self._publish_diagnostics()
            self._diagnostics_due = following_call(
                self._diagnostics_due, now, self._diagnostics_period
            )

    def _integrate(self) -> None:
        """Integrate whole grid steps up to the time due (never beyond), publishing
        the samples that fall on them, within the tick's wall-time budget."""
        sim = self.sim
        due, deadline, overrun = self.pacer.tick(sim.t)
        if overrun:
            self.overruns += 1
            # throttled here: rclpy's throttle costs ~0.6 ms a call even when it drops
            # the line (it inspects the caller first), and a late tick has none to spare
            now = time.monotonic()
            if now >= self._overrun_logged + OVERRUN_LOG_INTERVAL_S:
                self._overrun_logged = now
                self.get_logger().warning(
                    f"overrun at t = {sim.t:.3f} s: the model is {due - sim.t:.3g} s behind "
                    f"the clock (at most one such line every {OVERRUN_LOG_INTERVAL_S:g} s)"
                )
        limit = due + 1e-9 * sim.step_size  # round-off must not cost a step
        while sim.t + sim.step_size <= limit and time.monotonic() < deadline:
            warned = sim.range_warning
            if not sim.step():
                self._stop_on_error()
                return
            if sim.range_warning and not warned:  # say it now, not at the next status
                self.get_logger().warning(f"leaving the linear range: {sim.range_warning}")
                self._publish_diagnostics()
            steps = sim.steps - self._sampled_from
            if steps % self._every_state == 0:
                self._publish_state()
            if self._every_shape and steps % self._every_shape == 0:
                self._publish_shape()

    def _set_running(self) -> None:
        """Integrate while the simulation runs; hold the clock otherwise."""
        running = self.sim.state == RUNNING
        if running:
            self.pacer.run_from(self.sim.t)
        else:
            self.pacer.hold(self.sim.t)
        self._set_ticks()
        self.real_time_factor.restart(self.sim.t, self.sim.state == RUNNING)

    def _stop_on_error(self) -> None:
        self._set_running()
        self.get_logger().error(
            f"integration stopped: {self.sim.error}; call {topics.RESET_SERVICE} to start again"
        )
        self._publish_diagnostics()

    # -- commands and services ----------------------------------------------------------------

    def _spin_reception(self) -> None:
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self._reception)
        try:
            while not self._reception_stop.is_set() and self.context.ok():
                executor.spin_once(timeout_sec=RECEPTION_WAIT_S)
        except ExternalShutdownException:
            pass
        finally:
            executor.remove_node(self._reception)
            executor.shutdown()

    def _receive(self, name: str, message, info: dict) -> None:
        """Reception thread: queue a command once; answer at once if it cannot wait."""
        why_not = self.intake.admit(name, info)
        if why_not == DUPLICATE:
            return
        if self.queue.offer((name, message, info, why_not)):
            self._commands_waiting.trigger()
            return
        text = (
            f"dropped: {self.queue.capacity} commands were already waiting "
            "(max_queued_commands); not run"
        )
        self.get_logger().warning(f"{self.resolve_topic_name(name)} {text}")
        self._answer(name, info, topics.IGNORED, text, {})

    @_locked
    def _run_commands(self) -> None:
        """Simulator thread: act on the waiting commands in their order of arrival."""
        for name, message, info, why_not in self.queue.take():
            self._command(name, message, info, why_not)

    def _command(self, name: str, message, info: dict, why_not: str | None) -> None:
        """Act on a command, and answer on sail/command_status."""
        topic = self.resolve_topic_name(name)
        values = {}
        if why_not == STALE:
            outcome = topics.IGNORED
            text = "published before this simulator started; not run"
            self.get_logger().warning(f"ignored {topic}: {text}")
        else:
            limits = self.config.limits
            try:
                if name in topics.LOAD_NAMES:
                    change = self.sim.load(name, message, limits)
                    text, values = change.summary, {"t_start_s": f"{self.sim.t_model:.9f}"}
                else:
                    if name == topics.DEPLOY_CMD:
                        plan = self.sim.deploy(message.data, limits, self.config.deploy_duration)
                    else:
                        plan = self.sim.follow(message, limits)
                    text = plan.summary
                    values = {"t_start_s": f"{plan.t_start:.9f}", "t_end_s": f"{plan.t_end:.9f}"}
            except CommandError as error:
                outcome, text = topics.REJECTED, str(error)
                self.get_logger().warning(f"rejected {topic}: {error}")
            else:
                outcome = topics.ACCEPTED
                self.get_logger().info(f"{topic} accepted at t = {self.sim.t_model:.6f} s: {text}")
        self._answer(name, info, outcome, text, values)

    def _answer(self, name: str, info: dict, outcome: str, text: str, values: dict) -> None:
        answer = topics.CommandAnswer(
            topic=self.resolve_topic_name(name),
            outcome=outcome,
            message=text,
            source_timestamp_ns=int(info.get("source_timestamp") or 0),
            sequence=int(info.get("publication_sequence_number") or 0),
            values=values,
        )
        self._outputs[topics.COMMAND_STATUS].publish(topics.command_status(self._stamp(), answer))

    @_locked
    def _on_reset(self, request, response):
        self.sim.reset(self.config)
        self._set_running()
        self._start_sampling()
        response.success = True
        response.message = f"reset to the initial state at t = {self.sim.t:.6f} s" + (
            " (paused)" if self.sim.paused else ""
        )
        self.get_logger().info(response.message)
        self._publish_diagnostics()
        return response

    @_locked
    def _on_pause(self, request, response):
        sim = self.sim
        if sim.paused == request.data:
            response.message = "already " + ("paused" if sim.paused else "running")
        else:
            sim.paused = request.data
            self._set_running()
            response.message = f"{'paused' if sim.paused else 'resumed'} at t = {sim.t:.6f} s"
            if sim.error:
                response.message += "; the integration stays stopped until sail/reset"
            self.get_logger().info(response.message)
            self._publish_diagnostics()
        response.success = True
        return response

    # -- publishing -----------------------------------------------------------------------------

    def _start_sampling(self) -> None:
        """Publish the state now; later samples follow every so many steps from here
        (at start, and after a reset, which thereby starts a fresh series)."""
        self._sampled_from = self.sim.steps
        self._publish_state()
        if self._every_shape:
            self._publish_shape()

    def _stamp(self) -> int:
        return topics.stamp_ns(self.epoch_ns, self.sim.t)

    def _publish_state(self) -> None:
        for name, data in self._states.serialize(self._stamp(), self.sim.sample()):
            self._outputs[name].publish(data)  # CDR bytes of `topics.state_messages`

    def _publish_shape(self) -> None:
        q, lengths = self.sim.q, self.sim.lengths
        self._outputs[topics.SHAPE].publish(  # CDR bytes of `topics.shape`
            self._shape.serialize(
                self._stamp(),
                self.surface.vertices(q, lengths),
                self.surface.boom_lines(q, lengths),
            )
        )

    def _window_start(self) -> dict:
        return {
            "wall": time.monotonic(),
            "overruns": self.overruns,
            "rejected": self.sim.rejected,
            "dropped": self.queue.dropped,
        }

    @_locked
    def _publish_diagnostics(self) -> None:
        """The integrator's status: counts over the window since the last message, and
        the last complete real-time factor measurement (`RealTimeFactor`)."""
        stamp, level, message, values = self._status()
        self._outputs[topics.DIAGNOSTICS].publish(
            topics.diagnostics(stamp, level, message, values, self.get_fully_qualified_name())
        )
        if topics.CLOCK in self._outputs:  # fresh for late joiners, also while paused
            self._outputs[topics.CLOCK].publish(topics.clock(stamp))

    def _status(self):
        """`(stamp_ns, level, message, values)` of the status now; a new window starts."""
        sim, config, window = self.sim, self.config, self._window
        span = time.monotonic() - window["wall"]
        rtf = self.real_time_factor
        rtf.update(sim.t)
        steps, mean, largest = sim.step_times.take()
        overruns = self.overruns - window["overruns"]
        rejected = sim.rejected - window["rejected"]
        energy, load_power, dissipation = sim.balance()
        level, message = diagnose(
            Observations(
                state=sim.state,
                error=sim.error or "",
                window_s=span,
                overruns=overruns,
                rejected=rejected,
                dropped=self.queue.dropped - window["dropped"],
                last_rejection=sim.last_rejection,
                paced=self.pacer.paced,
                rtf_measured=bool(rtf.current),
                real_time_factor=rtf.value,
                time_scale=config.time_scale,
                range_warning=sim.range_warning,
            )
        )
        values = {
            "state": sim.state,
            "sim_time_s": round(sim.t, 9),
            "real_time_factor": round(rtf.value, 4),
            "real_time_factor_window_s": round(rtf.window, 4),
            "time_scale": config.time_scale,
            "step_time_ms_mean": round(1e3 * mean, 4),
            "step_time_ms_max": round(1e3 * largest, 4),
            "steps_in_window": steps,
            "overruns": self.overruns,
            "realtime_priority": self.realtime_priority,
            "accepted_commands": sim.accepted,
            "rejected_commands": sim.rejected,
            "dropped_commands": self.queue.dropped,
            "last_command": sim.last_command,
            "last_command_start_s": _time_or_none(sim.last_command_start),
            "last_rejection": sim.last_rejection,
            "motion_end_s": _time_or_none(sim.motion.t_end),
            "mechanical_energy_J": float(f"{energy:.6g}"),
            "load_power_W": float(f"{load_power:.6g}"),
            "damping_dissipation_W": float(f"{dissipation:.6g}"),
        }
        self._window = self._window_start()
        return self._stamp(), level, message, values

    def close(self) -> None:
        """Stop integrating and give subscribers time to acknowledge what was published."""
        self._ticker.stop()
        self._stop_reception()
        deadline = time.monotonic() + ACK_TIMEOUT_S
        for publisher in self._outputs.values():
            remaining = max(0.0, deadline - time.monotonic())
            publisher.wait_for_all_acked(Duration(nanoseconds=int(remaining * 1e9)))

    def _stop_reception(self) -> None:
        self._reception_stop.set()
        self._reception_wake.trigger()
        if self._reception_thread.is_alive():
            self._reception_thread.join()

    def destroy_node(self) -> None:
        self._ticker.stop()
        self._stop_reception()
        self._reception.destroy_node()
        super().destroy_node()


def _time_or_none(t: float) -> float:
    """A simulation time [s] for /diagnostics: -1.0 for none (nan, -inf)."""
    return round(t, 9) if math.isfinite(t) else -1.0


def _parser() -> argparse.ArgumentParser:
    lines = [spec.help_line() for spec in SPECS]
    return argparse.ArgumentParser(
        prog="sail-ros sim",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=PHYSICS_DOC
        + "\n\nROS parameters (--ros-args -p name:=value, or --params-file config/sim.yaml; "
        "write doubles with a decimal point):\n" + "\n".join(lines),
    )


def main(argv=None) -> int:
    """`sail-ros sim [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    return run_node(NODE_NAME, _parser(), argv, _simulate)


def _simulate(_namespace, stop) -> int:
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
        serve_until_stopped(executor, node, stop)
        if stop.received:
            node.get_logger().info(f"{stop.received}: stopping at t = {node.sim.t:.6f} s")
    finally:
        node.close()
        executor.remove_node(node)
        with bounded_teardown():
            node.destroy_node()
    return 0


if __name__ == "__main__":
    sys.exit(main())
