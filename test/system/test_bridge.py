"""`sail-ros bridge` with Foxglove's own client: what it serves is what the log holds.

The simulator, a recorder and the bridge run as processes over DDS; Foxglove's
WebSocket client (@foxglove/ws-protocol on `ws`, run with node:
test/js/bridge_client.mjs) connects, checks nothing itself but writes down
everything: the advertised channels with their schemas and services, every
message (its SHA-256, stamp and, for some topics, its value decoded by
@foxglove/rosmsg2-serialization from the advertised schema), the status
messages, service answers. It also publishes commands, encoded from the
advertised schemas. The test compares with the recorder's log of the same run:
the same schemas, the same bytes for the same stamps, and the commands the
client sent are in the log as the bytes it sent.

A second run has a client that stops reading while another reads on: the
bridge drops for the slow one and reports it, the other is served without a
gap and the simulator keeps real time.
"""

import asyncio
import contextlib
import hashlib
import json
import re
import signal
import socket
import subprocess
import time
from pathlib import Path

import psutil
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from harness import JS, SMALL_SIM, wait_until
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from tornado.httpclient import HTTPRequest
from tornado.websocket import WebSocketClosedError, websocket_connect

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bag import BagReader, bag_files
from sail_ros.messages import diagnostics as diagnostics_msg
from sail_ros.nodes import bridge

pytestmark = pytest.mark.multiprocess

SERVED = re.compile(r"serving on (ws://127\.0\.0\.1:\d+)")
# a clamped simulator's: no hub topics
SIM_TOPICS = [
    topics.absolute(name)
    for name in topics.TOPICS
    if name != topics.CLOCK and name not in (topics.HUB_STATE, topics.HUB_WRENCH_CMD)
]
COMMAND_SCHEMA = "std_msgs/msg/Float64"
# the client's run: a deployment, a command beyond max_length, bytes that are no Float64,
# a channel on a state topic, pause and resume over the protocol's services
STEPS = [
    {"wait": 0.5},
    {"publish": {"topic": "/sail/deploy_cmd", "type": COMMAND_SCHEMA, "value": {"data": 11.0}}},
    {"wait": 1.5},
    {"publish": {"topic": "/sail/deploy_cmd", "type": COMMAND_SCHEMA, "value": {"data": 500.0}}},
    {"publish_hex": {"topic": "/sail/deploy_cmd", "type": COMMAND_SCHEMA, "hex": "0001000001"}},
    {
        "publish": {
            "topic": "/sail/boom_state",
            "type": "sensor_msgs/msg/JointState",
            "value": {
                "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
                "name": [],
                "position": [],
                "velocity": [],
                "effort": [],
            },
        }
    },
    {"call": {"service": "/sail/pause", "value": {"data": True}}},
    {"call": {"service": "/sail/pause", "value": {"data": False}}},
    {"wait": 0.5},
]


def served_url(tool, timeout: float = 20.0) -> str:
    """The bridge's URL, once its log says it serves."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = SERVED.search(tool.log())
        if found:
            return found.group(1)
        assert tool.process.poll() is None, tool.log()
        time.sleep(0.05)
    pytest.fail(f"the bridge did not serve within {timeout} s:\n{tool.log()}")


def run_client(node: Path, url: str, plan: dict, out: Path, timeout: float = 60.0):
    """Start bridge_client.mjs with `plan`; returns the process (its result: `out`)."""
    plan_path = out.with_suffix(".plan.json")
    plan_path.write_text(json.dumps(plan))
    return subprocess.Popen(
        [str(node), str(JS / "bridge_client.mjs"), url, str(out), str(plan_path)],
        cwd=JS,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def finished(process, out: Path, timeout: float = 60.0) -> dict:
    output, _ = process.communicate(timeout=timeout)
    assert process.returncode == 0, output
    result = json.loads(out.read_text())
    assert not result["errors"], result["errors"]
    return result


def stamp_ns(message) -> int | None:
    """The stamp [ns] as bridge_client.mjs takes it: the header's, the first marker's, the
    message's own `stamp` or `clock`; None without."""
    if hasattr(message, "markers"):
        message = message.markers[0] if message.markers else None
    if hasattr(message, "header"):
        message = message.header
    time_ = getattr(message, "stamp", None) or getattr(message, "clock", None)
    return None if time_ is None else time_.sec * 1_000_000_000 + time_.nanosec


def stop(*tools) -> None:
    for tool in tools:
        tool.process.send_signal(signal.SIGINT)
    for tool in tools:
        assert tool.process.wait(20.0) == 0, tool.log()


def test_foxglove_client_sees_the_log_and_commands_the_sail(processes, js_readers, tmp_path):  # noqa: F811
    sim = processes(
        "sim", parameters={**SMALL_SIM, "shape_divisions": 4, "diagnostics_rate_hz": 2.0}
    )
    bag = tmp_path / "bag"
    recorder = processes("recorder", "-o", str(bag))
    served = processes("bridge", "--port", "0", "--diagnostics-period-s", "0.5")
    url = served_url(served)
    recorder.wait_for_lines([f"recording {topic} " for topic in SIM_TOPICS])
    out = tmp_path / "client.json"
    plan = {
        "topics": SIM_TOPICS,
        "receiving": [topics.absolute(topic) for topic in topics.STATE_TOPICS],
        "keep_values": ["/sail/boom_state", "/sail/command_status"],
        "steps": STEPS,
    }
    result = finished(run_client(js_readers, url, plan, out), out)
    time.sleep(0.3)  # the recorder takes what is in flight
    stop(recorder, served, sim)

    # what the server offers
    info = result["server_info"]
    assert set(info["capabilities"]) >= {"clientPublish", "services"}
    assert info["supportedEncodings"] == ["cdr"]
    assert {s["name"]: s["type"] for s in result["services"]} == {
        "/sail/pause": "std_srvs/srv/SetBool",
        "/sail/reset": "std_srvs/srv/Trigger",
    }

    # the same channels and schemas as the log
    channels = {c["topic"]: c for c in result["channels"]}
    with open(bag_files(bag)[0], "rb") as stream:
        summary = make_reader(stream).get_summary()
    logged = {
        channel.topic: summary.schemas[channel.schema_id] for channel in summary.channels.values()
    }
    assert set(SIM_TOPICS) <= set(logged) and set(SIM_TOPICS) <= set(channels)
    for topic, schema in logged.items():
        served_channel = channels[topic]
        assert served_channel["encoding"] == "cdr", topic
        assert served_channel["schemaEncoding"] == schema.encoding == "ros2msg", topic
        assert served_channel["schemaName"] == schema.name, topic
        assert served_channel["schema"] == schema.data.decode(), topic

    # the same bytes for the same stamps
    log = list(BagReader(bag).messages())
    by_key: dict[tuple, set[str]] = {}
    values: dict[tuple, object] = {}
    for message in log:
        decoded = deserialize_message(message.data, _type(message.type_name))
        sample = (message.topic, stamp_ns(decoded))
        by_key.setdefault(sample, set()).add(hashlib.sha256(message.data).hexdigest())
        values[sample] = decoded
    matched: dict[str, int] = {}
    for message in result["messages"]:
        if message["stamp_ns"] is None:
            continue
        sample = (message["topic"], int(message["stamp_ns"]))
        if sample not in by_key:
            continue  # before the recorder subscribed, or after it stopped
        assert message["sha256"] in by_key[sample], (sample, message["size"])
        matched[message["topic"]] = matched.get(message["topic"], 0) + 1
        if message["topic"] == "/sail/boom_state":  # the value Foxglove's reader decoded
            assert message["value"]["position"] == list(values[sample].position)
            assert message["value"]["name"] == list(values[sample].name)
    for topic in topics.STATE_TOPICS:
        assert matched.get(topics.absolute(topic), 0) >= 50, (topic, matched)
    assert matched.get("/sail/shape", 0) >= 5, matched
    assert matched.get("/diagnostics", 0) >= 3, matched
    assert matched.get("/sail/command_status", 0) == 2, matched

    # the client's commands went out as the bytes it sent, and were answered
    deploys = [m.data for m in log if m.topic == "/sail/deploy_cmd"]
    assert deploys == [serialize_message(Float64(data=v)) for v in (11.0, 500.0)]
    answers = [
        m["value"]["status"][0] for m in result["messages"] if m["topic"] == "/sail/command_status"
    ]
    assert [(a["level"], a["message"].split(":")[0]) for a in answers[:1]] == [
        (0, "deploy to 11 m")
    ]
    assert answers[1]["level"] == 2 and "outside [min_length, max_length]" in answers[1]["message"]
    lengths = [
        m["value"]["position"] for m in result["messages"] if m["topic"] == "/sail/boom_state"
    ]
    assert lengths[0] == [10.0] * 4 and min(lengths[-1]) > 10.2, lengths[-1]

    # refused by the bridge, with the reason, to the client
    statuses = [s["message"] for s in result["statuses"] if s["level"] == 2]
    assert any("5 bytes on /sail/deploy_cmd are not a std_msgs/msg/Float64" in s for s in statuses)
    assert any("may not publish on /sail/boom_state: not a command topic" in s for s in statuses)
    # pause and resume over the protocol, answered by the simulator
    calls = [(c["service"], c["response"]["success"], c["response"]["message"].split()[0])
             for c in result["calls"]]  # fmt: skip
    assert calls == [("/sail/pause", True, "paused"), ("/sail/pause", True, "resumed")]

    # the bridge's own count of it, on /diagnostics
    status = _bridge_status(log)
    assert status[key.CLIENT_COMMANDS] == "2"
    assert status[key.SERVICE_CALLS] == "2"
    assert int(status[key.REFUSED]) >= 2


def _type(type_name: str):
    from sail_ros.ros.program import message_class

    return message_class(type_name)


def _bridge_status(log) -> dict[str, str]:
    found = {}
    for message in log:
        if message.topic == topics.DIAGNOSTICS:
            array = deserialize_message(message.data, DiagnosticArray)
            for status in array.status:
                if status.name == bridge.NODE_NAME + bridge.STATUS_SUFFIX:
                    found = {pair.key: pair.value for pair in status.values}
    assert found, "no status of the bridge in the log"
    return found


# a reader that keeps up loses nothing only while it is scheduled: on 2 cores shared with
# other tests' simulators it can be starved past its queue (a wall-clock property)
@pytest.mark.timing
def test_a_client_that_stops_reading_loses_messages_alone(
    processes,
    operator,
    js_readers,  # noqa: F811
    tmp_path,
):
    # big shapes, often (190 kB at 25 Hz): the stalled client's socket buffers (small: it
    # stalls before it read anything, so the kernel did not grow them) and its queue fill
    # early in the stall; the reading client takes the state only
    processes("sim", parameters={**SMALL_SIM, "shape_divisions": 20, "shape_rate_hz": 25.0})
    served = processes(
        "bridge", "--port", "0", "--client-queue", "32", "--diagnostics-period-s", "0.5"
    )
    url = served_url(served)
    bridge_status = []
    operator.create_subscription(
        DiagnosticArray,
        topics.DIAGNOSTICS,
        lambda array: bridge_status.extend(
            {p.key: p.value for p in s.values}
            for s in array.status
            if s.name == bridge.NODE_NAME + bridge.STATUS_SUFFIX
        ),
        topics.DIAGNOSTICS_QOS,
    )
    # when each boom state reached this process straight from DDS: where the simulator
    # (or the whole machine) stalled, the reading client's gaps are these gaps
    from_dds = []
    operator.create_subscription(
        JointState,
        topics.BOOM_STATE,
        lambda _, info: from_dds.append(info["received_timestamp"]),
        topics.STATE_QOS,
    )
    operator.wait_for_simulator(subscribers=2)  # the simulator and the bridge
    state = [topics.absolute(name) for name in topics.STATE_TOPICS]
    reading = {
        "topics": SIM_TOPICS,
        "subscribe": state,
        "receiving": state,
        "steps": [{"wait": 4.0}],
    }
    stalling = {"topics": SIM_TOPICS, "steps": [{"stall": 3.0}, {"wait": 0.5}]}
    fast = run_client(js_readers, url, reading, tmp_path / "fast.json")
    slow = run_client(js_readers, url, stalling, tmp_path / "slow.json")
    operator.spin_for(4.5)
    fast_result = finished(fast, tmp_path / "fast.json")
    slow_result = finished(slow, tmp_path / "slow.json")
    wait_until(lambda: bridge_status, 5.0, "the bridge's status", executor=operator.spinner)
    operator.spin_for(0.6)

    # the reading client got every state sample in order, never held up for the stall: a
    # second without one only where DDS brought none either (the simulator or the
    # machine stalled, not the bridge)
    arrivals = [int(m["arrival_ns"]) for m in fast_result["messages"]
                if m["topic"] == "/sail/boom_state"]  # fmt: skip
    assert len(arrivals) > 100 and len(from_dds) > 100, (len(arrivals), len(from_dds))
    for a, b in zip(arrivals, arrivals[1:], strict=False):
        if b - a < 1e9:
            continue
        edges = [a, *(t for t in from_dds if a < t < b), b]
        quiet = max(y - x for x, y in zip(edges, edges[1:], strict=False))
        assert quiet > b - a - 0.5e9, (
            f"{(b - a) * 1e-9:.2f} s without a sample {(a - arrivals[0]) * 1e-9:.2f} s after "
            f"the first, while DDS brought {len(edges) - 2} (at most {quiet * 1e-9:.2f} s apart)"
        )
    stamps = [int(m["stamp_ns"]) for m in fast_result["messages"]
              if m["topic"] == "/sail/boom_state"]  # fmt: skip
    assert all(b - a == 20_000_000 for a, b in zip(stamps, stamps[1:], strict=False))
    # the stalled one lost some, and the bridge said so
    # the stalled one lost over a second of them (what was queued when it stalled), and
    # the bridge said so
    lost = len(arrivals) - slow_result["received"].get("/sail/boom_state", 0)
    assert lost > 50, slow_result["received"]
    assert "reads slower than the traffic" in served.log()
    assert int(bridge_status[-1][key.SLOW_REPORTS]) >= 1
    # and the simulator kept real time: no window held up (a wait for the stalled client
    # would take seconds), and over the run within 2 % (it catches up after a late tick)
    statuses = [
        (diagnostics_msg.diagnostic_values(array), published)
        for array, published in zip(operator.diagnostics, operator.published_ns, strict=True)
        if diagnostics_msg.diagnostic_values(array)
    ]
    factors = [float(values[key.REAL_TIME_FACTOR]) for values, _ in statuses[1:]]
    assert len(factors) >= 4 and min(factors) > 0.5, factors
    (first, first_ns), (last, last_ns) = statuses[1], statuses[-1]
    span = float(last[key.SIM_TIME]) - float(first[key.SIM_TIME])
    assert span / ((last_ns - first_ns) * 1e-9) == pytest.approx(1.0, abs=0.02), factors
    stop(served)


@pytest.mark.timing
def test_sigterm_ends_the_bridge_while_a_client_has_not_finished_its_handshake(processes):
    """Two TCP clients that never finish the WebSocket handshake (one sends nothing, one
    half a GET) do not hold the bridge: SIGTERM ends it within 2 s, exit code 0, where the
    server's stop once waited for them for as long as they stayed."""
    tool = processes("bridge", "--port", "0")
    host, port = served_url(tool).removeprefix("ws://").rsplit(":", 1)
    silent = socket.create_connection((host, int(port)))
    partial = socket.create_connection((host, int(port)))
    partial.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\nUpgrade: websocket\r\n")
    time.sleep(0.3)  # both accepted, each in its handshake
    try:
        assert tool.stop(signal.SIGTERM, timeout=2.0) == 0, tool.log()
    finally:
        silent.close()
        partial.close()
    assert "SIGTERM: closing the server" in tool.log()


@pytest.mark.slow
def test_two_hundred_clients_that_never_read_and_twenty_thousand_bad_frames(processes):
    """The full size of test_bridge_node's clients beyond max_clients and bad frames: 200
    clients subscribe to every channel of a running simulator and never read for 20 s,
    then leave; one more sends up to 20000 frames that are no protocol message (the server
    drops a client that sends faster than it reads the answers). The bridge keeps
    max_clients (16) of them, disconnects and counts the rest, hands back what their
    queues held once they leave, and logs a few of the server's error lines and their
    count. Prints the bridge's resident memory and log size."""
    processes("sim", parameters=SMALL_SIM)
    tool = processes("bridge", "--port", "0")
    url = served_url(tool)
    memory = psutil.Process(tool.process.pid).memory_info
    mib = {"start": memory().rss / 2**20}

    async def subscriber():
        request = HTTPRequest(url, headers={"Sec-WebSocket-Protocol": "foxglove.sdk.v1"})
        client = await websocket_connect(request)
        while (message := await client.read_message()) is not None:
            channels = json.loads(message).get("channels") if isinstance(message, str) else None
            if channels:
                ids = [{"id": c["id"], "channelId": c["id"]} for c in channels]
                await client.write_message(json.dumps({"op": "subscribe", "subscriptions": ids}))
                return client
        return None

    async def drain(client):
        while await client.read_message() is not None:
            pass

    async def run():
        clients = [await subscriber() for _ in range(200)]
        kept = [client for client in clients if client is not None]
        await asyncio.sleep(20.0)
        mib["held"] = memory().rss / 2**20
        for client in kept:
            client.close()
        await asyncio.sleep(3.0)  # a status of the bridge comes meanwhile
        sender, sent = await subscriber(), 0
        answers = asyncio.ensure_future(drain(sender))  # a status answers each frame
        with contextlib.suppress(WebSocketClosedError):  # the server may drop such a client
            while sent < 20000:
                await sender.write_message("not json")
                sent += 1
        await asyncio.sleep(6.0)  # the interval of the counts ends
        sender.close()
        await answers
        return len(kept), sent

    kept, sent = asyncio.run(run())
    mib["closed"] = memory().rss / 2**20
    assert tool.stop(signal.SIGINT) == 0
    log = tool.log()
    print(
        f"\nbridge resident memory: {mib['start']:.0f} MiB at start, {mib['held']:.0f} MiB "
        f"with {kept} clients that never read, {mib['closed']:.0f} MiB after they left; "
        f"{sent} bad frames sent before the server dropped the sender; log "
        f"{len(log.encode())} bytes"
    )
    assert kept == 16 and log.count("(max_clients)") <= 3 + 1, log[-2000:]
    assert "181 warning line(s) not logged one by one" in log
    # one by one, and the last in the count; the rest counted
    assert 1 <= log.count("Invalid message from") <= 3 + 1, log[-2000:]
    assert re.search(r"\d+ error line\(s\) not logged one by one .*Invalid message", log)
    assert mib["closed"] < mib["start"] + 32.0, mib
