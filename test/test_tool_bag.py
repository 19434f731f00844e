"""`sail-ros bag recover`: a log cut short becomes one that independent readers open."""

import pytest
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from sail_ros.bag import BagReader, BagWriter, default_qos_profile
from sail_ros.message_bytes import serialize
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
