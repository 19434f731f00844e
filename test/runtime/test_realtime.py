"""`RealTimeRun` without ROS, on a fake clock: pacing, samples, overruns, the real-time
factor, and commands taken in batches (floods of valid and malformed commands held
without stalling, every command answered and counted)."""

import math

import numpy as np
import pytest
from harness import SMALL, SMALL_SIM
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from sail_ros import status as key
from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.model import SailModel
from sail_ros.runtime.config import config_from_values
from sail_ros.runtime.intake import Undecodable
from sail_ros.runtime.realtime import COMMAND_LINES, RTF_MIN_WINDOW_S, RealTimeRun
from sail_ros.runtime.simulation import PAUSED, RUNNING

pytestmark = pytest.mark.model

START_NS = 1_700_000_000_000_000_000


class Clock:
    """A steady clock that moves only when told."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Outputs:
    """Everything a run hands out, kept."""

    def __init__(self):
        self.states, self.shapes, self.statuses, self.answered, self.lines = [], [], [], [], []
        self.answer_messages = 0

    def state(self, stamp_ns, sample):
        self.states.append((stamp_ns, sample))

    def shape(self, stamp_ns, q, lengths):
        self.shapes.append(stamp_ns)

    def status(self, stamp_ns, level, message, values):
        self.statuses.append({"level": level, "message": message, **values})

    def answers(self, answers):
        assert answers, "an empty batch of answers"
        self.answered.extend(answers)
        self.answer_messages += 1

    def log(self, severity, text):
        self.lines.append((severity, text))


@pytest.fixture(scope="module")
def model():
    return SailModel(SMALL)


def make_run(model, **values):
    clock, outputs = Clock(), Outputs()
    periods = []
    run = RealTimeRun(
        model,
        config_from_values({**SMALL_SIM, **values}),
        outputs,
        START_NS,
        clock=clock,
        on_schedule=periods.append,
    )
    run.start(START_NS)
    return run, clock, outputs, periods


def advance(run, clock, seconds, period=None):
    """Tick every `period` [s of the fake clock] (default the run's) for `seconds`."""
    period = period or run.tick_period
    end = clock.now + seconds
    while clock.now < end - 1e-12:
        clock.now += period
        with run.lock:
            run.tick()


def deploy(target):
    return Float64(data=float(target))


def trajectory(booms, length, seconds):
    point = JointTrajectoryPoint(positions=[float(length)] * len(booms))
    point.time_from_start.sec = int(seconds)
    return JointTrajectory(joint_names=[f"boom_{b}" for b in booms], points=[point])


def info(sequence):
    return {"source_timestamp": START_NS + 1 + sequence, "publication_sequence_number": sequence}


def test_the_simulation_keeps_pace_with_the_clock_and_samples_on_its_grid(model):
    run, clock, outputs, periods = make_run(model, shape_rate_hz=5.0)
    assert periods == [pytest.approx(0.02)]  # 2 steps of 0.01 s per tick at 50 Hz
    advance(run, clock, 2.0)
    assert run.sim.t == pytest.approx(2.0, abs=1e-9)
    stamps = [stamp for stamp, _ in outputs.states]
    assert len(stamps) == 101 and stamps[0] == START_NS  # the start's own sample
    assert np.diff(stamps) == pytest.approx(2e7)  # every 0.02 s of simulation
    assert len(outputs.shapes) == 11  # 5 Hz
    assert run.overruns == 0
    advance(run, clock, 1.0)
    assert outputs.statuses and outputs.statuses[-1][key.REAL_TIME_FACTOR] == pytest.approx(1.0)


def test_overruns_are_counted_each_and_logged_once_in_five_seconds(model):
    run, clock, outputs, _ = make_run(model, shape_rate_hz=0.0)
    advance(run, clock, 0.5)
    for _ in range(3):  # a tick 50 ms late: the model is five steps behind
        clock.now += 0.05
        advance(run, clock, 0.2)
    assert run.overruns == 3
    assert sum("overrun at t = " in text for _, text in outputs.lines) == 1
    clock.now += 6.0  # past the interval: the next overrun says so again
    advance(run, clock, 0.1)
    assert sum("overrun at t = " in text for _, text in outputs.lines) == 2


def test_a_tick_is_late_by_when_it_woke_not_by_its_commands_work(model):
    """Planning a command takes wall time inside the tick (12 ms here, over one 10 ms
    step): the tick came on time, so no overrun; it integrates to the time it woke at."""
    run, clock, outputs, _ = make_run(model, shape_rate_hz=0.0)
    advance(run, clock, 0.5)
    plan = run.sim.plan_deploy

    def slow_plan(*args):
        clock.now += 0.012
        return plan(*args)

    run.sim.plan_deploy = slow_plan
    for sequence in range(10):
        run.submit(topics.DEPLOY_CMD, deploy(10.5 + 0.01 * sequence), info(sequence))
        woke = clock.now + run.tick_period
        advance(run, clock, run.tick_period)
        assert run.sim.t == pytest.approx(0.5 + 0.02 * (sequence + 1), abs=1e-9)
        clock.now = woke  # the next tick one period after this one woke
    assert run.overruns == 0 and count(outputs, commands_msg.ACCEPTED) == 10
    clock.now += 0.05  # a tick that woke 50 ms late is one
    advance(run, clock, run.tick_period)
    assert run.overruns == 1


def test_the_real_time_factor_is_not_taken_over_short_windows(model):
    """A status off the schedule (a reset or a pause publishes one) must not close a
    window of a few milliseconds: the factor would read tens of times the time scale."""
    run, clock, outputs, _ = make_run(model, time_scale=2.0, diagnostics_rate_hz=4.0)
    advance(run, clock, 1.0)
    clock.now += 0.05  # the model falls 0.1 s of simulation behind
    run.publish_status()
    advance(run, clock, 0.02, period=0.02)  # it catches up at once
    run.publish_status()  # a few ms after the previous one
    advance(run, clock, 2.0)
    measured = [s for s in outputs.statuses if s[key.REAL_TIME_FACTOR_WINDOW] > 0]
    assert len(measured) >= 4
    for status in measured:
        assert status[key.REAL_TIME_FACTOR_WINDOW] >= RTF_MIN_WINDOW_S
        assert status[key.REAL_TIME_FACTOR] == pytest.approx(2.0, rel=0.1), status


def test_a_slow_state_rate_does_not_slow_the_integration(model):
    run, clock, outputs, periods = make_run(model, state_rate_hz=0.1, shape_rate_hz=0.0)
    assert periods[-1] == pytest.approx(0.05)  # ticks at least every 50 ms of wall time
    advance(run, clock, 3.0)
    assert run.sim.t == pytest.approx(3.0, abs=0.011)
    assert len(outputs.states) == 1  # the next sample is due at 10 s


def test_pause_resume_and_reset_hold_and_restart_the_clock(model):
    run, clock, outputs, periods = make_run(model, initial_tip_deflection=[0.0, 0.05, 0.0, 0.0])
    advance(run, clock, 0.5)
    assert run.pause(True) == f"paused at t = {run.sim.t:.6f} s" and run.sim.state == PAUSED
    assert periods[-1] == pytest.approx(1.0)  # only the status while paused
    held = run.sim.t
    advance(run, clock, 1.0, period=0.02)
    assert run.sim.t == held and run.pause(True) == "already paused"
    assert run.reset().endswith("(paused)")
    assert run.sim.q == pytest.approx(model.initial_coordinates([0, 0.05, 0, 0]), abs=1e-15)
    assert run.sim.t == held  # time goes on from where it was: stamps never go backwards
    assert run.pause(False).startswith("resumed") and run.sim.state == RUNNING
    advance(run, clock, 0.3)
    assert run.sim.t == pytest.approx(held + 0.3, abs=1e-9)


def test_a_reset_between_two_samples_sends_the_state_it_leaves_then_repeats_its_stamp(model):
    """A tick may end between two state samples (50 Hz: every 2nd step of 10 ms); a reset
    there first sends the state it leaves, so its own sample repeats that stamp (a log
    tells a reset by it); stamps never decrease; the status counts every sample sent."""
    run, clock, outputs, _ = make_run(model, initial_tip_deflection=[0.0, 0.05, 0.0, 0.0])
    advance(run, clock, 0.35, period=0.01)
    steps = run.sim.steps
    assert steps % 2 == 1 and outputs.states[-1][1].t < run.sim.t  # between two samples
    left = run.sim.q
    sent = len(outputs.states)
    run.reset()
    (before_ns, before), (reset_ns, after) = outputs.states[sent:]
    assert before_ns == reset_ns and before.t == after.t == run.sim.t
    np.testing.assert_array_equal(before.q, left)
    assert after.q == pytest.approx(model.initial_coordinates([0, 0.05, 0, 0]), abs=1e-15)
    # on a sample, nothing more goes out than the reset's own
    advance(run, clock, 0.02, period=0.02)
    assert outputs.states[-1][1].t == run.sim.t
    sent = len(outputs.states)
    run.reset()
    assert len(outputs.states) == sent + 1 and outputs.states[-1][0] == outputs.states[-2][0]
    stamps = [stamp for stamp, _ in outputs.states]
    assert np.all(np.diff(stamps) >= 0)
    # the status counts every sample sent, the reset's pairs included (a watcher waits for
    # the sample it counts: the state after the reset)
    run.publish_status()
    assert outputs.statuses[-1][key.STATE_SAMPLES] == len(outputs.states)


def count(outputs, outcome):
    return sum(answer.outcome == outcome for answer in outputs.answered)


def test_a_flood_of_deploy_commands_costs_one_plan_a_tick(model):
    """1000 valid deploy commands a second for 2 s, 20 between two ticks: the newest of
    each batch is planned and applied, the others are answered superseded unplanned; the
    run never falls behind, every command is answered and counted, and the log holds a
    few lines and counts instead of 2000 lines; a tick's answers go out as one message."""
    run, clock, outputs, _ = make_run(model, shape_rate_hz=0.0)
    planned = []
    plan = run.sim.plan_deploy
    run.sim.plan_deploy = lambda *args: planned.append(args) or plan(*args)
    sent = 0
    for _ in range(100):  # 100 ticks of 20 ms
        for _ in range(20):
            run.submit(topics.DEPLOY_CMD, deploy(10.0 + 0.001 * (sent % 500)), info(sent))
            sent += 1
        advance(run, clock, 0.02)
    status = run.status()[3]
    assert status[key.ACCEPTED] == 100 and status[key.SUPERSEDED] == 1900
    assert status[key.REJECTED] == 0 and len(planned) == 100
    assert count(outputs, commands_msg.ACCEPTED) + count(outputs, commands_msg.SUPERSEDED) == sent
    assert outputs.answer_messages == 100
    assert run.overruns == 0 and run.sim.t == pytest.approx(2.0, abs=1e-9)
    advance(run, clock, 6.0)
    assert len(outputs.lines) < 20
    assert sum(f"{1900 - COMMAND_LINES} superseded" in text for _, text in outputs.lines) == 1


UNDECODABLE = Undecodable(5, "std_msgs/msg/Float64", "failed to deserialize ROS message")


@pytest.mark.parametrize(
    ("message", "reason"),
    [(deploy(math.nan), "not a finite length"), (UNDECODABLE, "5 bytes are not a std_msgs")],
    ids=["nan", "undecodable"],
)
def test_a_flood_of_malformed_commands_is_rejected_and_counted(model, message, reason):
    run, clock, outputs, _ = make_run(model, shape_rate_hz=0.0)
    sent = 0
    for _ in range(50):
        for _ in range(20):
            run.submit(topics.DEPLOY_CMD, message, info(sent))
            sent += 1
        advance(run, clock, 0.02)
    status = run.status()[3]
    assert status[key.REJECTED] == sent and status[key.ACCEPTED] == 0
    assert count(outputs, commands_msg.REJECTED) == sent
    assert all(reason in a.message for a in outputs.answered)
    advance(run, clock, 6.0)  # the interval of the counts ends
    warnings = [text for severity, text in outputs.lines if severity == "warning"]
    assert sum(text.startswith("sail/deploy_cmd rejected:") for text in warnings) == COMMAND_LINES
    assert sum(f"{sent - COMMAND_LINES} rejected" in text for text in warnings) == 1
    assert run.overruns == 0


@pytest.mark.parametrize(
    ("commands", "outcomes", "final_a", "final_b"),
    [
        # a newer rejected deploy leaves the older one to run, as one by one would
        ([deploy(12.0), deploy(500.0)], ["accepted", "rejected"], 12.0, 12.0),
        # a deploy then a trajectory of boom a: both run, a follows the trajectory
        ([deploy(12.0), trajectory("a", 11.0, 8)], ["accepted", "accepted"], 11.0, 12.0),
        # a trajectory of a and b, then one of b: both run, b follows the newer
        ([trajectory("ab", 11.0, 8), trajectory("b", 13.0, 8)], ["accepted"] * 2, 11.0, 13.0),
        # a trajectory of b replaced by a deploy before it started
        ([trajectory("b", 13.0, 8), deploy(12.0)], ["superseded", "accepted"], 12.0, 12.0),
        # a trajectory naming an unknown boom replaces nothing, and is rejected
        (
            [trajectory("b", 13.0, 8), trajectory("be", 12.0, 8)],
            ["accepted", "rejected"],
            10.0,
            13.0,
        ),
        # bytes that are no command, the newest of the batch, replace nothing
        ([deploy(12.0), UNDECODABLE], ["accepted", "rejected"], 12.0, 12.0),
    ],
    ids=[
        "rejected-newest",
        "deploy-then-boom",
        "overlapping",
        "replaced",
        "unknown-boom",
        "undecodable-newest",
    ],
)
def test_a_batch_ends_as_acting_on_its_commands_one_by_one(
    model, commands, outcomes, final_a, final_b
):
    run, clock, outputs, _ = make_run(model, shape_rate_hz=0.0)
    for i, message in enumerate(commands):
        motion = isinstance(message, Float64 | Undecodable)
        topic = topics.DEPLOY_CMD if motion else topics.BOOM_LENGTH_CMD
        run.submit(topic, message, info(i))
    advance(run, clock, 0.02)
    by_sequence = sorted(outputs.answered, key=lambda answer: answer.sequence)
    assert [answer.outcome for answer in by_sequence] == outcomes
    lengths = run.sim.motion(1e6)[0]
    assert (lengths[0], lengths[1]) == pytest.approx((final_a, final_b))


def test_a_full_intake_rejects_and_counts(model):
    run, clock, outputs, _ = make_run(model, max_queued_commands=5)
    for i in range(8):
        run.submit(topics.PRESSURE_CMD, commands_msg.load_command(topics.PRESSURE_CMD, {}), info(i))
    rejected = [a for a in outputs.answered if a.outcome == commands_msg.REJECTED]
    assert len(rejected) == 3 and "5 commands were already waiting" in rejected[0].message
    advance(run, clock, 0.02)
    status = run.status()[3]
    assert status[key.DROPPED] == 3 and status[key.REJECTED] == 8  # 5 name nothing


def test_commands_published_before_the_start_are_ignored_and_counted(model):
    run, clock, outputs, _ = make_run(model)
    stale = {"source_timestamp": START_NS - 1, "publication_sequence_number": 1}
    assert run.submit(topics.DEPLOY_CMD, deploy(12.0), stale) is False
    assert outputs.answered[-1].outcome == commands_msg.IGNORED
    assert run.status()[3][key.IGNORED] == 1
    assert run.submit(topics.DEPLOY_CMD, deploy(12.0), stale) is False  # the same again
    assert len(outputs.answered) == 1  # a repeat of a sample is not a new command


FREE = {**SMALL_SIM, "sail.free_hub": True, "sail.hub_mass": 20.0, "sail.hub_inertia_x": 10.0,
        "sail.hub_inertia_y": 10.0}  # fmt: skip


def wrench(force_z=0.0, torque_x=0.0, torque_y=0.0, **held):
    message = hub_msg.hub_wrench_command(force_z, torque_x, torque_y)
    for name, value in held.items():
        part, axis = name.split("_")
        setattr(getattr(message.wrench, part), axis, value)
    return message


def test_a_free_hub_is_in_every_sample_and_takes_its_wrench(model):
    """The hub's state (heave, tilts and their rates) rides with every sample; a wrench
    command moves it as Newton says (F_z = m a from rest while nothing else acts:
    the heave after t is F t^2 / (2 m_total)); a wrench on a held axis, in another
    frame, beyond the limits, or with a clamped hub is rejected with its reason."""
    free = SailModel(config_from_values(FREE).sail)
    run, clock, outputs, _ = make_run(free, **FREE, initial_hub_velocity=[0.0, 0.01, 0.0])
    assert outputs.states[0][1].hub.tolist() == [0.0, 0.0, 0.0, 0.0, 0.01, 0.0]
    for i, (command, reason) in enumerate(
        [
            (wrench(force_x=0.1), "force.x = 0.1: the hub is held in the sail plane"),
            (wrench(torque_z=0.1), "torque.z = 0.1: the hub is held"),
            (wrench(force_z=5.0), "|force.z| = 5 N exceeds max_hub_force = 1 N"),
            (wrench(torque_y=math.nan), "torque.y = nan N m is not finite"),
        ]
    ):
        run.submit(topics.HUB_WRENCH_CMD, command, info(i))
        advance(run, clock, 0.02)
        assert outputs.answered[-1].outcome == commands_msg.REJECTED
        assert reason in outputs.answered[-1].message
    other = wrench(force_z=0.5)
    other.header.frame_id = "base_link"
    run.submit(topics.HUB_WRENCH_CMD, other, info(10))
    advance(run, clock, 0.02)
    assert "header.frame_id is 'base_link'" in outputs.answered[-1].message
    run.submit(topics.HUB_WRENCH_CMD, wrench(force_z=0.5, torque_x=0.2), info(11))
    advance(run, clock, 0.02)
    answer = outputs.answered[-1]
    assert answer.outcome == commands_msg.ACCEPTED and answer.values[commands_msg.LOADS_HELD] == (
        "[0.5, 0.2, 0.0]"
    )
    assert run.sim.inputs()[8:].tolist() == [0.5, 0.2, 0.0]
    assert run.reset() and run.sim.inputs()[8:].tolist() == [0.0, 0.0, 0.0]

    clamped, clock, outputs, _ = make_run(model)
    clamped.submit(topics.HUB_WRENCH_CMD, wrench(force_z=0.5), info(0))
    advance(clamped, clock, 0.02)
    assert "the hub is clamped" in outputs.answered[-1].message
    assert outputs.states[0][1].hub is None


def test_a_tilt_beyond_its_limit_stops_the_run(model):
    free = SailModel(config_from_values(FREE).sail)
    run, clock, outputs, _ = make_run(
        free, **FREE, initial_hub_velocity=[0.0, 0.5, 0.0], tilt_warn_rad=0.05,
        tilt_error_rad=0.1,
    )  # fmt: skip
    advance(run, clock, 1.0)
    assert run.sim.state == "error" and "hub tilt is" in run.sim.error
    assert "beyond tilt_error_rad 0.1: out of the small-angle range" in run.sim.error
    warned = [text for severity, text in outputs.lines if "tilt_warn_rad" in text]
    assert warned, outputs.lines


def stamped(run, t, **values):
    """A hub wrench stamped to act at simulation time `t` [s] of `run`."""
    command = wrench(**values)
    command.header.stamp = topics.stamp(topics.stamp_ns(run.epoch_ns, t))
    return command


def test_a_hub_wrench_stamped_ahead_acts_from_its_stamp(model):
    """Wrenches stamped ahead of the model are held until their times: the run is the
    one whose commands came at those times unstamped (to round-off), the answers say
    when; a later command replaces those still to act from its own time on; a stamp more
    than a second ahead (another clock) is rejected."""
    free = SailModel(config_from_values(FREE).sail)
    run, clock, outputs, _ = make_run(free, **FREE)
    advance(run, clock, 0.1)
    run.submit(topics.HUB_WRENCH_CMD, stamped(run, 0.16, force_z=0.5), info(0))
    run.submit(topics.HUB_WRENCH_CMD, stamped(run, 0.24, force_z=0.8), info(1))
    run.submit(topics.HUB_WRENCH_CMD, stamped(run, 0.2, force_z=0.4), info(2))  # replaces 0.24
    advance(run, clock, 0.02)
    answers = outputs.answered[-3:]
    assert [a.outcome for a in answers] == [commands_msg.ACCEPTED] * 3
    assert [float(a.values["t_start_s"]) for a in answers] == pytest.approx([0.16, 0.24, 0.2])
    assert run.sim.inputs()[8] == 0.0  # not yet
    advance(run, clock, 0.28)  # to t = 0.4
    assert run.sim.inputs()[8] == 0.4 and not run.sim.pending_wrenches
    twin, twin_clock, twin_outputs, _ = make_run(free, **FREE)
    advance(twin, twin_clock, 0.16)
    twin.submit(topics.HUB_WRENCH_CMD, wrench(force_z=0.5), info(0))
    advance(twin, twin_clock, 0.04)
    twin.submit(topics.HUB_WRENCH_CMD, wrench(force_z=0.4), info(1))
    advance(twin, twin_clock, 0.2)
    assert [float(a.values["t_start_s"]) for a in twin_outputs.answered] == pytest.approx(
        [0.16, 0.2]
    )
    assert outputs.states[-1][1].hub == pytest.approx(twin_outputs.states[-1][1].hub, rel=1e-12)
    run.submit(topics.HUB_WRENCH_CMD, stamped(run, 1.5, force_z=0.1), info(3))
    advance(run, clock, 0.02)
    assert "1.1 s ahead of the simulation" in outputs.answered[-1].message


def test_with_command_wait_a_step_waits_for_its_command_and_the_clock_with_it(model):
    """`command_wait_s`: the simulation goes no further than a sample period past the
    latest hub wrench command's time, waiting with the clock held; a command lets it
    on (and asks for a tick at once); a wait of the whole `command_wait_s` lets one step
    go without, counted."""
    free = SailModel(config_from_values(FREE).sail)
    run, clock, outputs, _ = make_run(free, **FREE, command_wait_s=0.5)
    advance(run, clock, 0.1)
    assert run.sim.t == pytest.approx(0.0) and run.waiting  # no command yet: waits
    assert run.submit(topics.HUB_WRENCH_CMD, stamped(run, 0.0, force_z=0.2), info(0))  # wake
    advance(run, clock, 0.2)
    assert run.sim.t == pytest.approx(0.02)  # one sample, then waits again
    run.submit(topics.HUB_WRENCH_CMD, stamped(run, 0.02, force_z=0.2), info(1))
    advance(run, clock, 0.02)
    assert run.sim.t == pytest.approx(0.04) and run.missed_commands == 0
    assert run.overruns == 0  # waiting is no overrun: the clock held
    advance(run, clock, 0.6)  # longer than command_wait_s: one step goes without
    assert run.missed_commands >= 1 and run.sim.t > 0.04
    run.publish_status()
    assert outputs.statuses[-1][key.MISSED_COMMANDS] == run.missed_commands
