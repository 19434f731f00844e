"""Node `sail_bridge`: the simulator live in Foxglove, over the Foxglove WebSocket protocol.

Subscribes (raw, no deserialisation) to one simulator's topics and serves
each as a channel of a Foxglove WebSocket server (`foxglove-sdk`), every
channel from the start, whether or not the simulator runs yet: message
encoding `cdr`, schema encoding
`ros2msg` with the schema text the recorder writes into the log
(`sail_ros.bag.message_definition`), the received CDR bytes unchanged, under
the topic's absolute name. A Foxglove layout therefore opens on a live run
and on its MCAP log alike.

Clients may publish on the command topics (client publish, encoding `cdr`):
bytes that decode as the topic's type are published on DDS unchanged, so the
simulator checks them as any DDS command and answers on
`sail/command_status`, which the bridge serves too; anything else is refused
with a status message to the clients and a log line, and counted. The
simulator's `sail/pause` and `sail/reset` services are offered as protocol
services (request and response in CDR).

A client that reads slower than the traffic never holds anything up: the
server queues at most `client_queue` messages for each client and drops that
client's oldest when its queue is full (foxglove-sdk's per-client queue). The
server reports such a client in its own log (at most once every 30 s);
the bridge logs the report as a warning naming the client's address and counts
it on /diagnostics (`slow_client_reports`).

By default the server listens on 127.0.0.1 only. Another address exposes the
sail to everyone who can reach that port: the protocol has no
authentication, and any client can command the booms and the loads, pause
and reset (msg_docs/bridge.md).

SIGINT/SIGTERM: close the server, exit 0. A bad parameter or option: exit 2.
A port already in use: exit 1.

    sail-ros bridge
    sail-ros bridge --port 8766 --namespace /sat2
    sail-ros bridge --ros-args -r __ns:=/sat2
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import ipaddress
import sys
import threading
import time

import foxglove
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from foxglove import Schema, Service
from foxglove.websocket import Capability, StatusLevel
from rcl_interfaces.msg import ParameterEvent
from rclpy.executors import SingleThreadedExecutor
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from std_srvs.srv import SetBool, Trigger

from sail_ros import status as key
from sail_ros import topics
from sail_ros.bag import message_definition
from sail_ros.bridging.clients import ClientBook, command_refusal
from sail_ros.bridging.protocol import (
    MESSAGE_ENCODING,
    LineThrottle,
    Listener,
    ServerLog,
    service_schema,
)
from sail_ros.bridging.sockets import disconnect, release_freed_memory
from sail_ros.model.fields import setting, settings_of
from sail_ros.options import docstring_examples
from sail_ros.ros.commanding import command_publisher, decode
from sail_ros.ros.parameters import (
    ConfigError,
    declare,
    destroyed_if_refused,
    make_parser,
    node_options,
    overrides,
)
from sail_ros.ros.program import bounded_teardown, run_node, serve_until_stopped

NODE_NAME = "sail_bridge"
# Every topic it may serve, with its type: the simulator's (topics.TOPICS) and ROS's record
# of parameter changes, as the recorder takes them by default. Known types let every
# channel exist before the server starts: foxglove-sdk 0.30.3 can advertise a channel
# added while a client is connected before it takes subscriptions to it, and refuses
# the client's subscription then ("Unknown channel ID").
SERVABLE = {
    **{name: (topic.message_type, topic.type_name) for name, topic in topics.TOPICS.items()},
    topics.PARAMETER_EVENTS: (ParameterEvent, "rcl_interfaces/msg/ParameterEvent"),
}
# Reliable, as every publisher of these topics (a best-effort command would not reach the
# simulator either); volatile: what comes from now on.
SUBSCRIPTION_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,  # messages DDS keeps for the bridge while it is busy
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
SERVICE_TIMEOUT_S = 5.0  # a protocol service call waits this long for the simulator
# At shutdown the server closes its clients' connections (a close frame each, which a
# client answers in milliseconds) and waits for their tasks: those not ended after this
# long [s] have their sockets shut down, and then it waits at most STOP_WAIT_S more.
STOP_GRACE_S = 0.25
STOP_WAIT_S = 1.0
# the simulator's services, offered over the protocol: name -> (service class, type name)
SERVICES = {
    topics.PAUSE_SERVICE: (SetBool, "std_srvs/srv/SetBool"),
    topics.RESET_SERVICE: (Trigger, "std_srvs/srv/Trigger"),
}


@dataclasses.dataclass(frozen=True)
class BridgeSettings:
    """The bridge's parameters (node `sail_bridge`)."""

    port: int = setting(
        8765,
        "",
        "TCP port of the WebSocket server (8765 is Foxglove's default); 0: any free port "
        "(the log says which)",
        minimum=0,
        maximum=65535,
    )
    address: str = setting(
        "127.0.0.1",
        "",
        "IP address the server listens on: 127.0.0.1 serves this machine only; any other "
        "(0.0.0.0: every interface) lets everyone who reaches the port watch the sail and "
        "command it, without authentication",
    )
    topics: list = setting(
        list(topics.RECORDED_TOPICS),
        "",
        "topics served, among the simulator's topics and /parameter_events (relative names "
        "are in the bridge's namespace)",
    )
    client_publish: bool = setting(
        True,
        "",
        "let clients publish on the command topics (deploy, boom length trajectory, "
        "pressures, tip forces, a free hub's wrench) and call sail/pause and sail/reset",
    )
    client_queue: int = setting(
        1024,
        "",
        "messages queued for each client [messages]; a client that reads slower than the "
        "traffic loses its oldest queued messages (about 4 s of the default traffic)",
        minimum=16,
        maximum=1_000_000,
    )
    max_clients: int = setting(
        16,
        "",
        "clients connected at once [clients]; one more is disconnected as it connects, "
        "logged and counted: with client_queue this bounds what the clients' queues hold",
        minimum=1,
        maximum=10_000,
    )
    diagnostics_period_s: float = setting(
        1.0, "", "period of the bridge's status on /diagnostics [s]", minimum=0.1, maximum=3600.0
    )


SPECS = settings_of(BridgeSettings)
# the bridge's status on /diagnostics (msg_docs/bridge.md)
STATUS_SUFFIX = ": websocket"  # its name: the node's, then this; keys in sail_ros.status

# the one WebSocket subprotocol foxglove-sdk's server accepts (and its minor revision)
SUBPROTOCOL = "foxglove.sdk.v1"


class Bridge(Node):
    """The `sail_bridge` node and its WebSocket server (listening once constructed).

    Its arguments are `ros.parameters.node_options`'s.

    Raises:
        ConfigError: a parameter has a value the bridge cannot use.
        OSError: the server cannot listen on the address and port.
    """

    def __init__(self, parameter_overrides=(), context=None, namespace=None):
        super().__init__(NODE_NAME, **node_options(parameter_overrides, context, namespace))
        with destroyed_if_refused(self):
            self._set_up()

    def _set_up(self) -> None:
        """The served topics, the command publishers and the server (raises ConfigError,
        OSError)."""
        self.config = declare(self, SPECS)
        address = self.config["address"]
        try:
            loopback = ipaddress.ip_address(address).is_loopback
        except ValueError:
            raise ConfigError(f"address: {address!r} is not an IP address") from None
        served = self._served_topics(self.config["topics"])
        self.served: dict[str, int] = {}  # topic -> messages handed to the server (executor)
        self._channels: dict[str, foxglove.Channel] = {}  # served topic -> channel
        self._commands = {
            self.resolve_topic_name(name): (topics.TOPICS[name], command_publisher(self, name))
            for name in (*topics.COMMAND_TOPICS, topics.HUB_WRENCH_CMD)
        }
        self._service_clients = {
            name: self.create_client(kind, name) for name, (kind, _) in SERVICES.items()
        }
        self._status = self.create_publisher(
            DiagnosticArray, topics.DIAGNOSTICS, topics.DIAGNOSTICS_QOS
        )

        self._port = None  # the server's, once it listens
        self._server_log = ServerLog(
            self.get_logger(), self._on_slow_client, self._on_client
        ).attach()
        # the bridge's own refusals, one a client message or connection at worst
        self._refusals = LineThrottle(self.get_logger(), "refused: ", key.REFUSED)
        self._connections = LineThrottle(self.get_logger(), "", key.REFUSED_CONNECTIONS)
        self.foxglove_context = foxglove.Context()
        for name in served:
            self._serve(name)
        self.client_book = ClientBook(len(self._channels))  # before the server calls back
        capabilities = []
        services = []
        if self.config["client_publish"]:
            capabilities = [Capability.ClientPublish, Capability.Services]
            services = [self._service(name) for name in SERVICES]
        try:
            self.server = foxglove.start_server(
                name=self.get_fully_qualified_name(),
                host=address,
                port=self.config["port"],
                capabilities=capabilities,
                server_listener=Listener(self),
                supported_encodings=[MESSAGE_ENCODING],
                services=services,
                context=self.foxglove_context,
                message_backlog_size=self.config["client_queue"],
            )
        except RuntimeError as error:  # foxglove-sdk's error for a bind that failed
            self._server_log.detach()
            raise OSError(f"cannot listen on {address}:{self.config['port']}: {error}") from None
        self._port = self.server.port
        self.url = self.client_book.url = f"ws://{address}:{self.server.port}"
        self.get_logger().info(
            f"serving on {self.url} (WebSocket subprotocol {SUBPROTOCOL}, as foxglove_bridge "
            "3.x: a client that offers only foxglove.websocket.v1 is refused with HTTP 400 and "
            "a 'handshake failed' line)"
        )
        if not loopback:
            self.get_logger().warning(
                f"listening on {address}: everyone who reaches port {self.server.port} can "
                "watch the sail and command it (booms, loads, pause, reset); the protocol has "
                "no authentication"
            )
        self.create_timer(self.config["diagnostics_period_s"], self._publish_status)

    def _served_topics(self, names: list[str]) -> list[str]:
        """The names of SERVABLE that `names` (relative or absolute) mean here.

        Raises:
            ConfigError: a name is not a topic the bridge can serve.
        """
        known = {self.resolve_topic_name(name): name for name in SERVABLE}
        chosen = []
        for name in names:
            try:
                resolved = self.resolve_topic_name(name)
            except Exception:  # rclpy raises several kinds for a bad name
                resolved = None
            if resolved not in known:
                raise ConfigError(
                    f"topics: {name!r} is not a topic of the simulator in namespace "
                    f"{self.get_namespace()!r} (they are: {', '.join(sorted(known))})"
                )
            chosen.append(known[resolved])
        return list(dict.fromkeys(chosen))

    # -- serving the simulator's topics (executor thread) -------------------------------------

    def _serve(self, name: str) -> None:
        """A channel for topic `name` (of SERVABLE), fed by a raw subscription."""
        message_type, type_name = SERVABLE[name]
        topic = self.resolve_topic_name(name)
        definition = message_definition(type_name)  # the recorder's schema
        channel = foxglove.Channel(
            topic,
            schema=Schema(
                name=type_name, encoding=definition.encoding, data=definition.text.encode()
            ),
            message_encoding=MESSAGE_ENCODING,
            context=self.foxglove_context,
        )
        self._channels[topic] = channel
        self.served[topic] = 0
        self.create_subscription(
            message_type,
            name,
            functools.partial(self._forward, topic, channel.base),
            SUBSCRIPTION_QOS,
            raw=True,
        )

    def _forward(self, topic: str, channel, data: bytes, info: dict) -> None:
        if len(data) % 4:
            # DDS pads every message to a 4-byte boundary on the way between processes
            # (what the recorder logs), but not one that stays in this process: the
            # bridge's own status and the commands it publishes
            data += bytes(4 - len(data) % 4)
        # log time: DDS's reception time, as the recorder's log time
        channel.log(data, info.get("received_timestamp") or time.time_ns())
        self.client_book.count(key.SERVED)
        self.served[topic] += 1

    # -- clients (the server's threads) ---------------------------------------------------------

    def on_subscribe(self, client_id: int, channel_id: int) -> None:
        self.client_book.subscribe(client_id, channel_id)

    def on_unsubscribe(self, client_id: int, channel_id: int) -> None:
        self.client_book.unsubscribe(client_id, channel_id)

    def on_client_advertise(self, client_id: int, channel) -> None:
        """A client's channel: accepted if it is a command topic of the simulator in CDR of
        the topic's type; else refused (its messages are then dropped, counted)."""
        try:
            topic = self.resolve_topic_name(channel.topic)
        except Exception:  # rclpy raises several kinds for a bad name
            topic = channel.topic
        commands = {name: spec for name, (spec, _) in self._commands.items()}
        reason = command_refusal(topic, channel.schema_name, channel.encoding, commands)
        if reason is not None:
            self._refuse(f"client {client_id} may not publish on {channel.topic}: {reason}")
            return
        self.client_book.accept_channel(client_id, channel.id, topic)
        self.get_logger().info(f"client {client_id} publishes on {topic}")

    def on_client_unadvertise(self, client_id: int, channel_id: int) -> None:
        self.client_book.drop_channel(client_id, channel_id)

    def on_message_data(self, client_id: int, channel_id: int, data: bytes) -> None:
        """A client's command: published on DDS unchanged if it decodes as its type."""
        topic = self.client_book.topic_of(client_id, channel_id)
        if topic is None:
            self._refuse(
                f"client {client_id}: message on channel {channel_id} dropped (channel refused)",
                quiet=True,
            )
            return
        spec, publisher = self._commands[topic]
        try:
            decode(data, spec.message_type)
        except ValueError as error:
            self._refuse(f"client {client_id}: {len(data)} bytes on {topic} are not a "
                         f"{spec.type_name} in CDR ({error})")  # fmt: skip
            return
        try:
            publisher.publish(data)
        except Exception as error:  # rclpy's RCLError: DDS refused the bytes (trailing data)
            reason = str(error).split(",", 1)[0]
            self._refuse(f"client {client_id}: {len(data)} bytes on {topic} could not be "
                         f"published on DDS ({reason})")  # fmt: skip
            return
        self.client_book.count(key.CLIENT_COMMANDS)

    def _refuse(self, text: str, quiet: bool = False) -> None:
        self.client_book.refused(text)
        if not quiet:
            self._refusals.line("warning", text)
            self.server.publish_status(text, StatusLevel.Error)

    def _on_client(self, address: str, connected: bool) -> None:
        """A client connected (the server registers it, on its thread) or left: one beyond
        `max_clients` is disconnected at once, before anything is queued for it."""
        if not connected:
            self.client_book.disconnect(address)
            return
        most = self.config["max_clients"]
        if self.client_book.connect(address, most) or self._port is None:
            return
        disconnect(self._port, address)
        self._connections.line(
            "warning",
            f"client {address} disconnected: {most} clients are connected already (max_clients)",
        )

    def _on_slow_client(self, address: str) -> None:
        self.client_book.slow(address)
        self.get_logger().warning(
            f"client {address} reads slower than the traffic: its queue of "
            f"{self.config['client_queue']} messages is full and its oldest messages are "
            "dropped (reported at most every 30 s)"
        )

    # -- services over the protocol -------------------------------------------------------------

    def _service(self, name: str) -> Service:
        _, type_name = SERVICES[name]
        return Service(
            topics.absolute(name, self.get_namespace()),
            schema=service_schema(type_name),
            handler=functools.partial(self._call, name),
        )

    def _call(self, name: str, request) -> bytes:
        """A protocol service call (a server thread): the simulator's service, its answer in
        CDR. An exception is the call's failure, its text sent to the client."""
        kind, _ = SERVICES[name]
        client = self._service_clients[name]
        if request.encoding != MESSAGE_ENCODING:
            raise ValueError(f"request encoding {request.encoding!r}, expected {MESSAGE_ENCODING}")
        message = deserialize_message(request.payload, kind.Request)
        if not client.service_is_ready():
            raise RuntimeError(f"{client.srv_name}: the simulator does not offer it (running?)")
        done = threading.Event()
        future = client.call_async(message)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(SERVICE_TIMEOUT_S):
            future.cancel()
            raise TimeoutError(f"{client.srv_name}: no answer within {SERVICE_TIMEOUT_S} s")
        self.client_book.count(key.SERVICE_CALLS)
        self.get_logger().info(f"client {request.client_id} called {client.srv_name}")
        return serialize_message(future.result())

    # -- status -----------------------------------------------------------------------------

    def status_values(self) -> dict[str, str]:
        """The key/value pairs of the bridge's status (msg_docs/bridge.md)."""
        return {
            **self.client_book.status_values(),
            key.SERVER_PROBLEMS: str(self._server_log.problems),
        }

    def _publish_status(self) -> None:
        for lines in (self._server_log, self._refusals, self._connections):
            lines.roll()
        if self.client_book.take_left():
            release_freed_memory()  # what the clients' queues held, back to the system
        values = self.status_values()
        slow = int(values[key.SLOW_REPORTS]) > 0
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if slow else DiagnosticStatus.OK,
            name=self.get_fully_qualified_name().lstrip("/") + STATUS_SUFFIX,
            message=(
                f"{values[key.CLIENTS]} client(s); slow clients lost messages: "
                f"{values[key.SLOW_CLIENTS]}"
                if slow
                else f"{values[key.CLIENTS]} client(s), {values[key.CHANNELS]} channel(s)"
            ),
            hardware_id=NODE_NAME,
        )
        status.values = [KeyValue(key=name, value=value) for name, value in values.items()]
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self._status.publish(array)

    def close(self) -> None:
        """Stop the server (clients see the connection close), say what was served and
        release the SDK's log. The server's stop waits for every connection's task, and
        one still in its handshake (a client that connected and sent nothing) would hold
        it for as long as it stays: what has not ended after `STOP_GRACE_S` has its
        socket shut down."""
        stopping = threading.Thread(target=self.server.stop, name="server stop", daemon=True)
        stopping.start()
        stopping.join(STOP_GRACE_S)
        if stopping.is_alive():
            disconnect(self._port)
            stopping.join(STOP_WAIT_S)
        if stopping.is_alive():
            self.get_logger().warning(
                f"the server did not stop within {STOP_WAIT_S:g} s (a connection it still "
                "waits for); exiting without it"
            )
        for topic, count in sorted(self.served.items()):
            self.get_logger().info(f"  {topic}: {count} messages served")
        for lines in (self._server_log, self._refusals, self._connections):
            lines.roll(end=True)
        self._server_log.detach()


def _parser() -> argparse.ArgumentParser:
    parser = make_parser(
        "sail-ros bridge", __doc__.split("\n\n")[0], SPECS, docstring_examples(__doc__)
    )
    parser.add_argument(
        "--namespace",
        default=None,
        help="the simulator's namespace, e.g. /sat2 (the same as --ros-args -r __ns:=/sat2)",
    )
    return parser


def main(argv=None) -> int:
    """`sail-ros bridge [options] [--ros-args ...]`; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    return run_node(NODE_NAME, _parser(), argv, _bridge)


def _bridge(args, stop) -> int:
    namespace = args.namespace
    if namespace is not None and not namespace.startswith("/"):
        namespace = "/" + namespace
    try:
        bridge = Bridge(overrides(args, SPECS), namespace=namespace)
    except OSError as error:
        get_logger(NODE_NAME).error(str(error))
        return 1
    executor = SingleThreadedExecutor()
    executor.add_node(bridge)
    try:
        serve_until_stopped(executor, bridge, stop)
        if stop.received:
            bridge.get_logger().info(f"{stop.received}: closing the server")
    finally:
        bridge.close()
        executor.remove_node(bridge)
        with bounded_teardown():
            bridge.destroy_node()
    return 0


if __name__ == "__main__":
    sys.exit(main())
