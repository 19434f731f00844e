"""The simulator's real-time run without ROS: pacing, stepping, commands, status.

`RealTimeRun` holds a `Simulation` and runs it against a clock it is given
(`clock`, the steady clock by default): each `tick` first acts on the commands
that arrived (`submit`, from any thread; see `intake` for the batch rule), then
integrates whole grid steps up to the simulation time due (`pacing.Pacer`),
hands every state sample and shape that falls due to its `Outputs`, and the
integrator status when it is due. `reset`, `pause` and `configure` are the
services and parameters. The node (`nodes.sim`) only wires topics, services,
parameters and a `Ticker` to it; tests drive it with a fake clock.

`lock` is held by `tick` (the ticker holds it around each call) and by the
services, so they never see a half-made step; `submit` and `later` only queue.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from typing import Protocol

from sail_ros import names
from sail_ros import status as key
from sail_ros.model import SailModel
from sail_ros.model.record import StateSample
from sail_ros.runtime.commands import CommandError
from sail_ros.runtime.config import SimConfig
from sail_ros.runtime.diagnosis import Observations, diagnose
from sail_ros.runtime.intake import (
    DUPLICATE,
    STALE,
    CommandIntake,
    CommandQueue,
    Pending,
    covered,
    split_batch,
)
from sail_ros.runtime.pacing import Pacer, RealTimeFactor
from sail_ros.runtime.simulation import RUNNING, Simulation
from sail_ros.runtime.ticker import following_call

RTF_MIN_WINDOW_S = 0.5  # the real-time factor is measured over running windows this long
OVERRUN_LOG_INTERVAL_S = 5.0  # overruns are counted in the status, logged this seldom
COMMAND_LOG_INTERVAL_S = 5.0  # beyond a few lines, commands are logged as counts this often
COMMAND_LINES = 3  # command lines per interval and outcome before they turn into counts


class Outputs(Protocol):
    """Where a run's results go (the node's publishers and logger)."""

    def state(self, stamp_ns: int, sample: StateSample) -> None:
        """A state sample at `stamp_ns` [ns]."""

    def shape(self, stamp_ns: int, q, lengths) -> None:
        """The sail's shape for coordinates `q` at boom `lengths` [m]."""

    def status(self, stamp_ns: int, level: str, message: str, values: dict) -> None:
        """The integrator status (/diagnostics)."""

    def answers(self, answers: list[names.CommandAnswer]) -> None:
        """The answers to commands handled together, in that order (sail/command_status)."""

    def log(self, severity: str, text: str) -> None:
        """A line for the log: severity "info", "warning" or "error"."""


class CommandLog:
    """Log lines about commands without flooding: the first `COMMAND_LINES` of each
    outcome per interval one by one, the rest as one line of counts per interval."""

    def __init__(self, log, clock):
        self._log, self._clock = log, clock
        self._lines: dict[str, int] = {}
        self._held: dict[str, int] = {}
        self._last_rejection = ""
        self._window_end = -math.inf

    def record(self, outcome: str, severity: str, text: str) -> None:
        self.roll()
        if outcome == names.REJECTED:
            self._last_rejection = text
        if self._lines.get(outcome, 0) < COMMAND_LINES:
            self._lines[outcome] = self._lines.get(outcome, 0) + 1
            self._log(severity, text)
        else:
            self._held[outcome] = self._held.get(outcome, 0) + 1

    def roll(self, end: bool = False) -> None:
        """At the end of an interval (or of the run, `end`): one line with the counts held
        back, if any; a new interval starts with the next command."""
        now = self._clock()
        if now < self._window_end and not end:
            return
        if self._held:
            counts = ", ".join(f"{count} {outcome}" for outcome, count in self._held.items())
            last = ""
            if self._held.get(names.REJECTED):
                last = f" (last rejection: {self._last_rejection})"
            self._log(
                "warning",
                f"commands not logged one by one in the last {COMMAND_LOG_INTERVAL_S:g} s: "
                f"{counts}{last}; /diagnostics counts every outcome",
            )
        self._lines, self._held = {}, {}
        self._window_end = now + COMMAND_LOG_INTERVAL_S


class RealTimeRun:
    """The simulator's real-time run (module docstring).

    Args:
        model: the sail model.
        config: the validated configuration.
        outputs: where samples, shapes, statuses, answers and log lines go.
        started_ns: the wall-clock time of the start [ns since the Unix epoch]: commands
            published before it are ignored.
        clock: the steady clock [s] (injected for tests).
        on_schedule: called with the tick period [s] whenever it changes (the node's
            ticker); 0 means back to back.
        resolve: a command topic's full name (the node's namespace), for its answers
            and log lines.
    """

    def __init__(
        self,
        model: SailModel,
        config: SimConfig,
        outputs: Outputs,
        started_ns: int,
        clock=time.monotonic,
        on_schedule=None,
        resolve=str,
    ):
        self.lock = threading.RLock()
        self.resolve = resolve
        self.config = config
        self.outputs = outputs
        self.clock = clock
        self.on_schedule = on_schedule or (lambda period: None)
        self.sim = Simulation(model, config)
        self.pacer = Pacer(
            config.time_scale,
            config.integration_step,
            config.steps_between(config.state_rate_hz),
            now=clock,
        )
        self.real_time_factor = RealTimeFactor(RTF_MIN_WINDOW_S, now=clock)
        self.intake = CommandIntake(started_ns)
        self.queue = CommandQueue(config.max_queued_commands)
        self.epoch_ns = int(started_ns)  # the stamp of simulation time 0 (again at `start`)
        self.overruns = 0
        self.superseded = 0
        self.ignored = 0
        self.realtime_priority = 0  # the node says what its ticks' thread runs at
        self._overrun_logged = -math.inf
        self._commands = CommandLog(outputs.log, clock)
        self._started = False
        self._diagnostics_period = 1.0 / config.diagnostics_rate_hz  # s
        self._diagnostics_due = math.inf
        self._window = self._window_start()
        self._sampled_from = 0
        self._state_published_t = math.nan  # simulation time of the last state sent [s]
        self.state_samples = 0  # state samples published since start
        self._waiting_since: float | None = None  # [s, clock] a step waits for its command
        self.missed_commands = 0  # steps that waited command_wait_s in vain
        self._excused_until = -math.inf  # [s] the steps of a wait in vain go up to here
        self._later: collections.deque = collections.deque()  # actions for the next tick
        self._use_config()

    # -- lifecycle ---------------------------------------------------------------------------

    def start(self, epoch_ns: int) -> None:
        """Start the clock at simulation time `t` = stamp `epoch_ns` [ns] + t, publish the
        initial state, and set the schedule."""
        with self.lock:
            if self._started:
                return
            self._started = True
            self.epoch_ns = int(epoch_ns)
            self.pacer.run_from(self.sim.t)
            self.real_time_factor.restart(self.sim.t, self.sim.state == RUNNING)
            self._window = self._window_start()
            self._diagnostics_due = self.clock() + self._diagnostics_period
            self._start_sampling()
            self._schedule()

    def finish(self) -> None:
        """At the end of the run: the command counts not logged yet (after the last tick)."""
        with self.lock:
            self._commands.roll(end=True)

    @property
    def tick_period(self) -> float:
        """Wall time between ticks [s]: the pacing's while running (at most the
        diagnostics' period), else the diagnostics' period."""
        period = self._diagnostics_period
        if self.sim.state == RUNNING:
            period = min(period, self.pacer.tick_period)
        return period

    def later(self, action) -> None:
        """Call `action()` at the start of the next tick (from any thread): what a service
        or a parameter change does, on the ticks' thread, so that the thread that serves
        them never waits for the model's work."""
        self._later.append(action)

    def tick(self) -> None:
        """One wake-up (the ticker holds `lock`): what `later` asked for, act on the
        commands, integrate what is due while running, publish the status when due."""
        woke = self.clock()  # the commands' work is the tick's, not lateness
        while self._later:
            self._later.popleft()()
        self._run_commands()
        if self.sim.state == RUNNING:
            self._integrate(woke)
        now = self.clock()
        if now >= self._diagnostics_due:
            self.publish_status()
            self._commands.roll()
            self._diagnostics_due = following_call(
                self._diagnostics_due, now, self._diagnostics_period
            )

    # -- commands ------------------------------------------------------------------------------

    def submit(self, topic: str, message, info: dict) -> bool:
        """A command from DDS (any thread): queued for the next tick, or answered at once
        when it cannot wait (published before the start; the queue full). Returns whether
        the run should be woken (it does not tick while paused or stopped)."""
        why_not = self.intake.admit(topic, info)
        if why_not == DUPLICATE:
            return False
        pending = Pending(topic, message, info)
        if why_not == STALE:
            self.ignored += 1
            text = "published before this simulator started; not run"
            self.outputs.answers([self._answer(pending, names.IGNORED, text, {}, "warning")])
            return False
        if self.queue.offer(pending):
            return self.sim.state != RUNNING or (self.waiting and topic == names.HUB_WRENCH_CMD)
        error = CommandError(
            f"{self.queue.capacity} commands were already waiting (max_queued_commands); not run"
        )
        with self.lock:
            self.sim.count_rejection(error)
        self.outputs.answers([self._answer(pending, names.REJECTED, str(error), {}, "warning")])
        return False

    def _run_commands(self) -> None:
        """The waiting commands as one batch (`intake.split_batch`): bytes that are no
        command rejected, oldest first; motion commands planned newest first, one a
        newer accepted one replaces answered superseded unplanned, the accepted ones
        applied oldest first; then the loads in order. Their answers go out together,
        one message."""
        batch = self.queue.take()
        if not batch:
            return
        unread, motions, loads = split_batch(batch)
        sim = self.sim
        plans = {}
        answers = []
        for index in unread:
            error = CommandError(str(batch[index].message))
            sim.count_rejection(error)
            answers.append(self._answer(batch[index], names.REJECTED, str(error), {}, "warning"))
        for index in motions:
            pending = batch[index]
            if covered(batch, index, plans):
                self.superseded += 1
                text = "replaced by a newer command before it started; not run"
                answers.append(self._answer(pending, names.SUPERSEDED, text, {}, "info"))
                continue
            try:
                if pending.topic == names.DEPLOY_CMD:
                    plans[index] = sim.plan_deploy(
                        pending.message.data, self.config.deploy_duration
                    )
                else:
                    plans[index] = sim.plan_trajectory(pending.message)
            except CommandError as error:
                sim.count_rejection(error)
                answers.append(self._answer(pending, names.REJECTED, str(error), {}, "warning"))
        for index in sorted(plans):
            plan = sim.apply_motion(plans[index])
            values = {"t_start_s": repr(plan.t_start), "t_end_s": repr(plan.t_end)}
            answers.append(self._accepted(batch[index], plan.summary, values))
        for index in loads:
            topic = batch[index].topic
            try:
                if topic == names.HUB_WRENCH_CMD:
                    stamp = names.stamp_ns_of(batch[index].message.header.stamp)
                    at = (stamp - self.epoch_ns) / 1e9 if stamp else None
                    change = sim.wrench(batch[index].message, self.config.frame_id, at)
                else:
                    change = sim.load(topic, batch[index].message)
            except CommandError as error:
                answers.append(
                    self._answer(batch[index], names.REJECTED, str(error), {}, "warning")
                )
                continue
            # the loads now held, all of the kind: a log then tells the loads from the answers
            held = change.values
            start = sim.t_model if change.t_start is None else change.t_start
            values = {"t_start_s": repr(start), names.LOADS_HELD: _numbers(held)}
            answers.append(self._accepted(batch[index], change.summary, values))
        self.outputs.answers(answers)

    def _accepted(self, pending: Pending, summary: str, values: dict) -> names.CommandAnswer:
        text = f"accepted at t = {self.sim.t_model:.6f} s: {summary}"
        return self._answer(pending, names.ACCEPTED, summary, values, "info", text)

    def _answer(self, pending, outcome, text, values, severity, line=None) -> names.CommandAnswer:
        """The answer to `pending`, its line logged (`CommandLog`); the caller publishes."""
        topic = self.resolve(pending.topic)
        self._commands.record(outcome, severity, f"{topic} {line or f'{outcome}: {text}'}")
        return names.CommandAnswer(
            topic=topic,
            outcome=outcome,
            message=text,
            source_timestamp_ns=int(pending.info.get("source_timestamp") or 0),
            sequence=int(pending.info.get("publication_sequence_number") or 0),
            values=values,
        )

    # -- integration ---------------------------------------------------------------------------

    def _integrate(self, woke: float) -> None:
        """Integrate whole grid steps up to the time due when the tick woke at `woke`
        [s, steady clock] (never beyond), publishing the samples that fall on them,
        within the tick's wall-time budget."""
        sim = self.sim
        if self.waiting and self._waits_for_command():
            return  # the clock holds while the step waits: no overrun
        due, deadline, overrun = self.pacer.tick(sim.t, woke)
        if overrun:
            self.overruns += 1
            now = self.clock()
            if now >= self._overrun_logged + OVERRUN_LOG_INTERVAL_S:
                self._overrun_logged = now
                self.outputs.log(
                    "warning",
                    f"overrun at t = {sim.t:.3f} s: the model is {due - sim.t:.3g} s behind "
                    f"the clock (at most one such line every {OVERRUN_LOG_INTERVAL_S:g} s)",
                )
        limit = due + 1e-9 * sim.step_size  # round-off must not cost a step
        while sim.t + sim.step_size <= limit and self.clock() < deadline:
            if self._waits_for_command():
                return  # the command's arrival pokes the next tick
            warned = sim.range_warning
            if not sim.step():
                self._set_running()
                self.outputs.log(
                    "error",
                    f"integration stopped: {sim.error}; call {names.RESET_SERVICE} to start again",
                )
                self.publish_status()
                return
            if sim.range_warning and not warned:  # say it now, not at the next status
                self.outputs.log("warning", f"leaving the linear range: {sim.range_warning}")
                self.publish_status()
            steps = sim.steps - self._sampled_from
            if steps % self._every_state == 0:
                self._publish_state()
            if self._every_shape and steps % self._every_shape == 0:
                self._publish_shape()

    @property
    def waiting(self) -> bool:
        """A step waits for the hub wrench command that acts at its sample."""
        return self._waiting_since is not None

    def _waits_for_command(self) -> bool:
        """With `command_wait_s` (a controller in the loop): whether the next step must wait
        for a hub wrench command acting at or before the sample it starts from (one period
        of samples covered by the latest, `Simulation.commanded_until`), at most
        `command_wait_s` of the clock; the clock holds meanwhile (the pacing starts again
        from the model's time when the step goes), so how late the command comes does not
        change the run. A wait in vain is counted (`missed_commands`) and the step goes."""
        sim, wait = self.sim, self.config.command_wait_s
        if wait <= 0.0 or not sim.model.free_hub:
            return False
        period = self._every_state * sim.step_size
        covered = max(sim.commanded_until + period, self._excused_until)
        if sim.t < covered - 1e-9 * period:
            self._stop_waiting()
            return False
        now = self.clock()
        if self._waiting_since is None:
            self._waiting_since = now
            self.pacer.hold(sim.t)
        if now - self._waiting_since < wait:
            return True
        self.missed_commands += 1
        self._excused_until = sim.t + period  # this sample goes without
        self._stop_waiting()
        return False

    def _stop_waiting(self) -> None:
        if self._waiting_since is not None:
            self._waiting_since = None
            # the clock held while the step waited; it goes on as if the step were due now
            period = self._every_state * self.sim.step_size
            self.pacer.run_from(self.sim.t + period)

    def _set_running(self) -> None:
        """Integrate while the simulation runs; hold the clock otherwise."""
        self._waiting_since = None  # a wait starts again from here
        running = self.sim.state == RUNNING
        if running:
            self.pacer.run_from(self.sim.t)
        else:
            self.pacer.hold(self.sim.t)
        self.real_time_factor.restart(self.sim.t, running)
        self._schedule()

    def _schedule(self) -> None:
        if self._started:
            self.on_schedule(self.tick_period)

    # -- services and parameters ---------------------------------------------------------------

    def reset(self, config: SimConfig | None = None) -> str:
        """Back to the initial state at the current time (`Simulation.reset`); the answer."""
        with self.lock:
            # the state the reset leaves goes out first where a tick ended between two
            # samples, so that the reset's own sample repeats its stamp: that is how a
            # log tells a reset (`analysis.log_rerun`). After an error the state there is
            # out of range or non-finite and stays unpublished.
            if self.sim.t != self._state_published_t and not self.sim.error:
                self._publish_state()
            self.sim.reset(config or self.config)
            self._set_running()
            self._start_sampling()
            text = f"reset to the initial state at t = {self.sim.t:.6f} s" + (
                " (paused)" if self.sim.paused else ""
            )
            self.outputs.log("info", text)
            self.publish_status()
            return text

    def pause(self, paused: bool) -> str:
        """Pause or resume; the answer."""
        with self.lock:
            sim = self.sim
            if sim.paused == paused:
                return "already " + ("paused" if sim.paused else "running")
            sim.paused = paused
            self._set_running()
            text = f"{'paused' if sim.paused else 'resumed'} at t = {sim.t:.6f} s"
            if sim.error:
                text += "; the integration stays stopped until sail/reset"
            self.outputs.log("info", text)
            self.publish_status()
            return text

    def configure(self, config: SimConfig) -> None:
        """Use a new configuration's writable values from now on."""
        with self.lock:
            self.config = config
            self._use_config()
            self._schedule()

    def _use_config(self) -> None:
        """Publication intervals, the policy and loads, and the status period."""
        config, sim = self.config, self.sim
        sim.policy = config.policy
        if config.solar_pressure != sim.solar_pressure:
            sim.set_solar_pressure(config.solar_pressure)
        self._every_state = config.steps_between(config.state_rate_hz)
        self._every_shape = config.steps_between(config.shape_rate_hz)
        self.pacer.tick_steps = self._every_state
        period = 1.0 / config.diagnostics_rate_hz
        if period != self._diagnostics_period:
            self._diagnostics_period = period
            self._diagnostics_due = min(self._diagnostics_due, self.clock() + period)

    # -- publishing ----------------------------------------------------------------------------

    def stamp_ns(self) -> int:
        """The stamp of the latest sample [ns]: epoch + simulation time."""
        return names.stamp_ns(self.epoch_ns, self.sim.t)

    def _start_sampling(self) -> None:
        """Publish the state now; later samples follow every so many steps from here
        (at start, and after a reset, which thereby starts a fresh series)."""
        self._sampled_from = self.sim.steps
        self._publish_state()
        if self._every_shape:
            self._publish_shape()

    def _publish_state(self) -> None:
        self.outputs.state(self.stamp_ns(), self.sim.sample())
        self._state_published_t = self.sim.t
        self.state_samples += 1

    def _publish_shape(self) -> None:
        self.outputs.shape(self.stamp_ns(), self.sim.q, self.sim.lengths)

    def _window_start(self) -> dict:
        return {
            "wall": self.clock(),
            "overruns": self.overruns,
            "rejected": self.sim.rejected,
            "dropped": self.queue.overflowed,
        }

    def publish_status(self) -> None:
        """The integrator status now (`status`); a new window starts."""
        with self.lock:
            self.outputs.status(*self.status())

    def status(self):
        """`(stamp_ns, level, message, values)`: counts over the window since the last
        status, and the last complete real-time factor measurement (`RealTimeFactor`);
        a new window starts."""
        sim, config, window = self.sim, self.config, self._window
        span = self.clock() - window["wall"]
        rtf = self.real_time_factor
        rtf.update(sim.t)
        steps, mean, largest = sim.step_times.take()
        energy, load_power, dissipation = sim.balance()
        level, message = diagnose(
            Observations(
                state=sim.state,
                error=sim.error or "",
                window_s=span,
                overruns=self.overruns - window["overruns"],
                rejected=sim.rejected - window["rejected"],
                dropped=self.queue.overflowed - window["dropped"],
                last_rejection=sim.last_rejection,
                paced=self.pacer.paced,
                rtf_measured=bool(rtf.current),
                real_time_factor=rtf.value,
                time_scale=config.time_scale,
                range_warning=sim.range_warning,
            )
        )
        values = {
            key.STATE: sim.state,
            key.SIM_TIME: round(sim.t, 9),
            key.STATE_SAMPLES: self.state_samples,
            key.REAL_TIME_FACTOR: round(rtf.value, 4),
            key.REAL_TIME_FACTOR_WINDOW: round(rtf.window, 4),
            key.TIME_SCALE: config.time_scale,
            key.STEP_TIME_MEAN: round(1e3 * mean, 4),
            key.STEP_TIME_MAX: round(1e3 * largest, 4),
            key.STEPS_IN_WINDOW: steps,
            key.OVERRUNS: self.overruns,
            key.MISSED_COMMANDS: self.missed_commands,
            key.REALTIME_PRIORITY: self.realtime_priority,
            key.ACCEPTED: sim.accepted,
            key.SUPERSEDED: self.superseded,
            key.REJECTED: sim.rejected,
            key.IGNORED: self.ignored,
            key.DROPPED: self.queue.overflowed,
            key.LAST_COMMAND: sim.last_command,
            key.LAST_COMMAND_START: _time_or_none(sim.last_command_start),
            key.LAST_REJECTION: sim.last_rejection,
            key.MOTION_END: _time_or_none(sim.motion.t_end),
            key.MODEL_RTOL: config.model_rtol,
            key.ERROR_ESTIMATE: float(f"{sim.relative_error_estimate():.3g}"),
            key.ENERGY: float(f"{energy:.6g}"),
            key.LOAD_POWER: float(f"{load_power:.6g}"),
            key.DISSIPATION: float(f"{dissipation:.6g}"),
        }
        self._window = self._window_start()
        return self.stamp_ns(), level, message, values


def _time_or_none(t: float) -> float:
    """A simulation time [s] for the status, every digit kept (a replay starts the
    command's motion where the simulator did, and so takes the same adaptive steps):
    -1.0 for none (nan, -inf)."""
    return float(t) if math.isfinite(t) else -1.0


def _numbers(values) -> str:
    """Numbers as one line of text, every digit kept: "[0.002, 0.0, 0.0, 0.0]"."""
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"
