"""`sail-ros bag recover`: a log cut short becomes one that independent readers open."""

import struct

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from sail_ros.bag import BagReader, BagWriteError, BagWriter, MessageDefinition, default_qos_profile
from sail_ros.messages.cdr import serialize
from sail_ros.tools.bag import main

pytestmark = pytest.mark.model

TOPIC = "/sail/boom_state"


def state(i: int) -> bytes:
    message = JointState(name=["boom_a"], position=[0.1 * i])
    message.header.stamp.sec = i
    return serialize(message)


@pytest.fixture
def cut_bag(tmp_path):
    """A recorder-style folder whose file was cut at 60 % of its bytes (no summary,
    no metadata.yaml), as a kill or a full disk leaves it."""
    folder = tmp_path / "run"
    latched = default_qos_profile(durability="transient_local", history="keep_last", depth=1)
    with BagWriter(folder, compression="zstd", chunk_size=2000, fsync=False) as writer:
        writer.add_topic(TOPIC, "sensor_msgs/msg/JointState", [latched])
        writer.add_metadata("sail_sim_parameters", {"sail.sail_side": "100.0"})
        for i in range(400):
            writer.write(TOPIC, state(i), 1_000_000_000 + i * 10_000_000)
    (folder / "metadata.yaml").unlink()
    file = folder / "run_0.mcap"
    data = file.read_bytes()
    file.write_bytes(data[: int(0.6 * len(data))])
    return folder


def test_recover_keeps_every_complete_message_for_every_reader(cut_bag, tmp_path, capsys):
    kept = [m.data for m in BagReader(cut_bag).messages()]
    assert 100 < len(kept) < 400  # the cut lost the tail, not the complete chunks
    with pytest.raises(FileNotFoundError, match="metadata"), AnyReader([cut_bag]):
        pass  # rosbags refuses the folder as it is

    assert main(["recover", str(cut_bag)]) == 0
    recovered = tmp_path / "run_recovered"
    assert f"recovered {len(kept)} messages into {recovered}" in capsys.readouterr().out
    assert (recovered / "metadata.yaml").is_file()

    with AnyReader([recovered]) as reader:  # rosbags
        rows = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [row.header.stamp.sec for row in rows] == list(range(len(kept)))
    with (recovered / "run_recovered_0.mcap").open("rb") as stream:  # mcap's default reader
        messages = [m.data for _, _, m in make_reader(stream).iter_messages()]
    assert messages == kept
    info = BagReader(recovered).topics()[TOPIC]
    assert info.offered_qos_profiles[0]["durability"] == "transient_local"
    records = dict(BagReader(recovered).metadata())
    assert records["sail_sim_parameters"] == {"sail.sail_side": "100.0"}
    assert deserialize_message(kept[-1], JointState).position[0] == pytest.approx(
        0.1 * (len(kept) - 1)
    )


def test_recover_refuses_to_overwrite(cut_bag, tmp_path, capsys):
    (tmp_path / "taken").mkdir()
    assert main(["recover", str(cut_bag), "-o", str(tmp_path / "taken")]) == 2
    assert "--output" in capsys.readouterr().err


def run_recover(argv, capsys) -> tuple[int, str]:
    code = main(["recover", *map(str, argv)])
    return code, capsys.readouterr().err


def test_a_recover_that_fails_while_writing_leaves_nothing(cut_bag, tmp_path, capsys, monkeypatch):
    """A disk that fills up half way: exit 1, one line, and neither the output folder
    nor the temporary one it was built in."""
    original, written = BagWriter.write, []

    def write_until_full(self, *args, **kwargs):
        if len(written) == 50:
            raise BagWriteError(self.path / "x.mcap", OSError(28, "No space left on device"))
        written.append(args)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(BagWriter, "write", write_until_full)
    code, err = run_recover([cut_bag], capsys)
    assert code == 1
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"error: recovering into '{tmp_path / 'run_recovered'}' failed: ")
    assert "No space left on device [errno 28]" in err
    assert sorted(path.name for path in tmp_path.iterdir()) == ["run"]  # nothing else


def test_recover_into_an_unwritable_place_is_one_line_and_exit_2(cut_bag, tmp_path, capsys):
    (tmp_path / "blocker").write_text("")
    code, err = run_recover([cut_bag, "-o", tmp_path / "blocker" / "out"], capsys)
    assert code == 2
    assert err == (
        f"error: --output '{tmp_path / 'blocker' / 'out'}' cannot be created: "
        f"'{tmp_path / 'blocker'}': File exists\n"
    )


THING = "custom_msgs/msg/Thing"  # a type installed nowhere


def test_recover_keeps_the_recorded_schema_of_a_type_not_installed(tmp_path, capsys):
    log = tmp_path / "custom.mcap"
    definition = MessageDefinition("ros2msg", "float64 x\nstring label")
    with BagWriter(log, fsync=False) as writer:
        writer.add_topic("/thing", THING, definition=definition)
        for i in range(5):  # CDR: encapsulation, float64, string (length, text, NUL)
            label = f"n{i}".encode() + b"\0"
            data = struct.pack("<4sdI", b"\0\1\0\0", 0.5 * i, len(label)) + label
            writer.write("/thing", data, 1_000 + i)
    code, err = run_recover([log, "-o", tmp_path / "fixed"], capsys)
    assert code == 0, err
    info = BagReader(tmp_path / "fixed").topics()["/thing"]
    assert (info.type_name, info.definition) == (THING, definition)
    with AnyReader([tmp_path / "fixed"]) as reader:  # rosbags, from the recorded schema alone
        rows = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [(row.x, row.label) for row in rows] == [(0.5 * i, f"n{i}") for i in range(5)]


def test_recover_of_a_type_defined_nowhere_is_one_line_and_exit_2(tmp_path, capsys):
    log = tmp_path / "bare.mcap"
    with log.open("wb") as stream:  # a foreign writer that stored no schema text
        writer = Writer(stream)
        writer.start("ros2", "test")
        channel = writer.register_channel("/thing", "cdr", writer.register_schema(THING, "", b""))
        writer.add_message(channel, 1_000, b"\0\1\0\0" + bytes(8), 1_000)
        writer.finish()
    code, err = run_recover([log], capsys)
    assert code == 2
    assert err == (
        f"error: '{log}': /thing has type '{THING}', which neither the log (no schema) nor "
        "the installed packages define\n"
    )
    assert sorted(path.name for path in tmp_path.iterdir()) == ["bare.mcap"]
