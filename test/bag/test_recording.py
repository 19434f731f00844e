"""`sail_ros.bag.recording`: the writer thread's splits and the parameters it stores.

No ROS here: the recorder node's threads only enqueue into a `Recording`, so its
state machine is driven directly (a fake clock for the wait for parameters) and the
bag read back with `BagReader`.
"""

import threading
import time

import pytest
from rosgraph_msgs.msg import Clock

from sail_ros.bag import BagReader, BagWriteError, BagWriter
from sail_ros.bag.recording import (
    ParameterChange,
    ParameterUpdate,
    ParameterValues,
    Recording,
    changes_record_of,
    parse_changes_record,
)
from sail_ros.messages.cdr import serialize

pytestmark = pytest.mark.model

T0 = 1_700_000_000_000_000_000  # ns
STEP_NS = 10_000_000
NODE = "/sail_sim"
RECORDS = {
    "parameters_record": "sail_sim_parameters",
    "changes_record": "sail_sim_parameter_changes",
    "dropped_record": "sail_recorder_dropped",
}


def recording(folder, clock_s=0.0, parameter_node=NODE, **writer_options) -> Recording:
    """A Recording of /clock into `folder`, its clock at 0 when it starts and at `clock_s`
    [s] from then on."""
    times = iter([0.0])
    bag = Recording(
        BagWriter(folder, fsync=False, **writer_options),
        max_messages=10_000,
        parameter_node=parameter_node,
        parameters_wait_s=5.0,
        clock=lambda: next(times, clock_s),
        **RECORDS,
    )
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    return bag


def write(bag: Recording, first: int, count: int) -> None:
    for i in range(first, first + count):
        message = Clock()
        message.clock.sec = i
        assert bag.write("/clock", serialize(message), T0 + i * STEP_NS, T0 + i * STEP_NS, i)


def records(path, name: str) -> list[dict]:
    return [data for record, data in BagReader(path).metadata() if record == name]


def test_a_file_ends_only_with_the_parameters_and_the_next_starts_with_the_values_then(
    tmp_path,
):
    """Splits every 0.1 s of log time: none before the first fetch is in (1 s of messages
    in one file), then each file starts with the values of its time; a change is stored
    in the file where it happened, with its times and its old and new value."""
    folder = tmp_path / "run"
    bag = recording(folder, max_file_duration_s=0.1)
    write(bag, 0, 100)  # 1 s: due to split ten times, but no parameters yet
    bag.parameters_fetched({"sail.sail_side": "100.0", "time_scale": "1.0"}, T0 + 100 * STEP_NS)
    write(bag, 100, 30)
    update = ParameterUpdate(
        time_ns=T0 + 129 * STEP_NS,
        log_time_ns=T0 + 130 * STEP_NS,
        changed={"time_scale": "2.0"},
    )
    bag.parameter_event(update)
    write(bag, 130, 20)
    bag.close()
    assert bag.error is None and bag.change_count == 1

    files = BagReader(folder).files
    # 0..99 in one file, then one file per 0.1 s of log time
    assert [BagReader(f).topics()["/clock"].message_count for f in files] == [100] + [10] * 5
    starts = [records(f, "sail_sim_parameters") for f in files]
    assert starts[0] == [{"sail.sail_side": "100.0", "time_scale": "1.0"}]  # stored at once
    assert [s[0]["time_scale"] for s in starts] == ["1.0"] * 4 + ["2.0"] * 2
    assert all(len(s) == 1 for s in starts)
    changes = [records(f, "sail_sim_parameter_changes") for f in files]
    assert changes[:3] + changes[4:] == [[]] * 5  # in the file that holds message 129
    (record,) = changes[3]
    assert parse_changes_record(record) == (
        NODE,
        update.time_ns,
        update.log_time_ns,
        [ParameterChange("time_scale", "1.0", "2.0")],
    )


def test_a_node_fetched_again_is_stored_again_where_it_happened(tmp_path):
    """A fetch after the node appeared again (a simulator restarted under the recorder,
    here with more boom modes) stores its changes and then all its values as a new record,
    in the file where it happened: what follows is read with the new sail."""
    folder = tmp_path / "restart"
    bag = recording(folder)
    bag.parameters_fetched({"sail.n_boom_modes": "4", "time_scale": "1.0"}, T0)
    write(bag, 0, 10)
    bag.parameters_fetched({"sail.n_boom_modes": "8", "time_scale": "1.0"}, T0 + 10 * STEP_NS)
    write(bag, 10, 10)
    bag.close()
    assert [values["sail.n_boom_modes"] for values in records(folder, "sail_sim_parameters")] == [
        "4",
        "8",
    ]
    ((_, _, log_time_ns, changes),) = map(
        parse_changes_record, records(folder, "sail_sim_parameter_changes")
    )
    assert (log_time_ns, changes) == (
        T0 + 10 * STEP_NS,
        [ParameterChange("sail.n_boom_modes", "4", "8")],
    )


def test_a_due_split_waits_for_the_parameters_at_most_parameters_wait_s(tmp_path):
    waiting = recording(tmp_path / "waiting", clock_s=0.0, max_file_duration_s=0.1)
    waited = recording(tmp_path / "waited", clock_s=5.5, max_file_duration_s=0.1)
    unwanted = recording(tmp_path / "none", parameter_node=None, max_file_duration_s=0.1)
    for bag in (waiting, waited, unwanted):
        write(bag, 0, 30)
        bag.close()
    assert len(BagReader(tmp_path / "waiting").files) == 1
    assert len(BagReader(tmp_path / "waited").files) == 3
    assert len(BagReader(tmp_path / "none").files) == 3
    assert waited.parameters is None and records(tmp_path / "waited", "sail_sim_parameters") == []


def test_the_wait_for_the_parameters_counts_from_the_first_message(tmp_path):
    """A recorder started long before the node and its publishers (here 100 s) still keeps
    its first file open for the parameters that come just after the first messages
    (counted from the recorder's start, the first file ended without them)."""
    now = [0.0]
    bag = Recording(
        BagWriter(tmp_path / "late", fsync=False, max_file_duration_s=0.1),
        max_messages=10_000,
        parameter_node=NODE,
        parameters_wait_s=5.0,
        clock=lambda: now[0],
        **RECORDS,
    )
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    now[0] = 100.0
    write(bag, 0, 30)  # 0.3 s of messages, due to split twice
    bag.parameters_fetched({"sail.sail_side": "100.0"}, T0 + 30 * STEP_NS)
    write(bag, 30, 30)
    bag.close()
    files = BagReader(tmp_path / "late").files
    assert [BagReader(f).topics()["/clock"].message_count for f in files] == [30, 10, 10, 10]
    assert all(records(f, "sail_sim_parameters") for f in files)


def test_parameter_values_follow_events_and_fetches():
    values = ParameterValues()
    early = ParameterUpdate(1, 1, declared={"a": "1", "b": "2"})
    assert values.apply(early) == []  # before the first fetch: part of the start
    assert values.snapshot({"a": "1"}) == []
    assert values.values == {"a": "1", "b": "2"}  # the early event, on top
    assert values.apply(ParameterUpdate(2, 2, changed={"a": "1"})) == []  # set to the same
    assert values.apply(ParameterUpdate(3, 3, changed={"a": "5"}, deleted=("b", "x"))) == [
        ParameterChange("a", "1", "5"),
        ParameterChange("b", "2", None),
    ]
    assert values.apply(ParameterUpdate(4, 4, declared={"c": "[1, 2]"})) == [
        ParameterChange("c", None, "[1, 2]")
    ]
    # a node that starts again with other values: the fetch tells what changed
    assert values.snapshot({"a": "5", "c": "[1, 3]"}) == [ParameterChange("c", "[1, 2]", "[1, 3]")]


def test_changes_record_keeps_every_value_as_text():
    changes = [
        ParameterChange("time_scale", "1.0", "2.0"),
        ParameterChange("frames", "[a, b]", None),
        ParameterChange("name", None, "'null'"),
    ]
    record = changes_record_of(NODE, 5, 7, changes)
    assert all(isinstance(value, str) for value in record.values())
    assert "\n" not in record["changes"]
    assert parse_changes_record(record) == (NODE, 5, 7, changes)
    with pytest.raises(ValueError, match="not a parameter changes record"):
        parse_changes_record({"node": NODE, "changes": "[{name: a}]"})


def test_a_writer_that_failed_never_blocks_the_threads_that_queue(tmp_path, monkeypatch):
    """The disk fails at the first message while the queue is full: queueing more and
    closing return at once (a blocking put would wait for a writer that is gone)."""
    failing = threading.Event()

    def write(self, *args, **kwargs):
        failing.wait(5.0)  # until the queue is full
        raise BagWriteError(self.path, OSError(28, "No space left on device"))

    monkeypatch.setattr(BagWriter, "write", write)
    bag = Recording(
        BagWriter(tmp_path / "full", fsync=False),
        max_messages=10,
        parameter_node=NODE,
        **RECORDS,
    )
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    started = time.monotonic()
    accepted = [bag.write("/clock", b"\0\1\0\0" + bytes(8), i, i, i) for i in range(30)]
    failing.set()
    bag.add_topic("/other", "rosgraph_msgs/msg/Clock")  # waits while the writer lives
    bag.parameters_fetched({"a": "1"}, 0)
    bag.close()
    assert time.monotonic() - started < 3.0
    assert isinstance(bag.error, BagWriteError) and bag.failed.is_set()
    # 10 wait (a topic among them, or not yet), one may be in the writer
    assert 9 <= sum(accepted) <= 11 and bag.dropped == {"/clock": 30 - sum(accepted)}
