"""A client of a running simulator: commands with their answers, services, live state.

`SimClient` is the node behind `sail-ros send`, `sail-ros watch` (both through
`tools.client.run_client`) and the demo. It resolves every name in its own
namespace, as the simulator does, so `--ros-args -r __ns:=/sat2` reaches the
simulator started in /sat2.

A command is published transient local (`topics.LATCHED_COMMAND_QOS`), so
the simulator gets it even if it sees this publisher only after the message
went out; its answer (`sail/command_status`) is kept by the simulator for the
same reason. The answer to this client's command is the one whose source
timestamp lies between the moments just before and just after the publish,
with this publisher's sequence number.
"""

from __future__ import annotations

import contextlib
import os
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from sail_ros import status as key
from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.ros.discovery import CLIENT_PROFILE, announce_often, subscriptions_of
from sail_ros.ros.program import bounded_teardown

# A reliable writer resends what a reader missed at its next heartbeat (Fast DDS: every
# 3 s); a watcher waits this long [s] at most for the newest state sample.
CATCH_UP_S = 4.0
# the state topics a watcher shows (a free hub's state besides, where the simulator has one)
WATCHED_STATE = (topics.BOOM_STATE, topics.TIP_DEFLECTION, topics.ROOT_MOMENT)
# how the graph names a writer's node before it has learnt it (rmw's placeholder)
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
# Once the answers the diagnostics counted arrived, the watcher takes more until none
# came for this long [s]: the rest of the history arrives within milliseconds.
ANSWER_HISTORY_S = 0.3
# At close, a command publisher is kept until every subscription of its topic has
# acknowledged its commands (a recorder's, besides the simulator's), at most this long [s].
DELIVERY_WAIT_S = 2.0


class NoAnswerError(RuntimeError):
    """The simulator did not appear, or did not answer, in time; the message says which."""


class SimClient(Node):
    """Talks to the simulator node `sail_sim` of its own namespace.

    Args:
        context: an initialised rclpy context.
        name: this node's name (made unique with the process id).
        watch: also keep the latest state, diagnostics and command answers.
    """

    def __init__(self, context, name: str = "sail_client", watch: bool = False):
        super().__init__(f"{name}_{os.getpid()}", context=context)
        self.executor_ = SingleThreadedExecutor(context=context)
        self.executor_.add_node(self)
        self.sim_name = self.resolve_topic_name(topics.SIM_NODE)  # e.g. /sat2/sail_sim
        self.answers: list[commands_msg.CommandAnswer] = []
        self.status_subscription = self.create_subscription(
            DiagnosticArray, topics.COMMAND_STATUS, self._on_answer, topics.COMMAND_STATUS_QOS
        )
        self._command_publishers: dict[str, object] = {}
        self._sent: dict[str, int] = {}  # messages published per command topic
        self._readers: dict[str, int] = {}  # subscriptions the simulator counted per topic
        self.latest: dict[str, object] = {}
        self.received = 0  # state messages taken
        # per state topic: the writer's sequence number of the sample held (None: not given)
        self.sequences: dict[str, int | None] = {}
        self._states_from_simulator: bool | None = None  # found when the graph says
        self._hub_subscription = None
        if watch:
            for name_ in WATCHED_STATE:
                self.create_subscription(
                    JointState, name_, self._keeper(name_), topics.NEWEST_STATE_QOS
                )
            self.create_subscription(
                DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics, topics.DIAGNOSTICS_QOS
            )
            hub = topics.TOPICS[topics.HUB_STATE]  # a free hub's; none arrive when clamped
            self._hub_subscription = self.create_subscription(
                hub.message_type, topics.HUB_STATE, self._keeper(topics.HUB_STATE),
                topics.NEWEST_STATE_QOS,
            )  # fmt: skip

    # -- spinning -------------------------------------------------------------------------

    def spin_until(self, condition, timeout: float, what: str, check=None) -> None:
        """Spin until `condition()`; NoAnswerError naming `what` after `timeout` [s].
        `check()`, if given, is called on every turn and may raise to give up early."""
        deadline = time.monotonic() + timeout
        while not condition():
            if check is not None:
                check()
            if time.monotonic() > deadline:
                raise NoAnswerError(f"no {what} within {timeout:g} s")
            self.executor_.spin_once(timeout_sec=0.02)

    def settle(self, quiet: float = 0.01, limit: float = CATCH_UP_S) -> None:
        """Take the newest of the state samples the simulator keeps: its transient-local
        history comes as a burst, whose tail a loaded machine may lose and DDS resend
        only at the writer's next heartbeat. Spin until each state topic's sample held is
        the one the status counts (`status.STATE_SAMPLES`, the writers' sequence
        numbers) or a later one; where the status or the middleware gives no count, until
        no state message arrived for `quiet` [s]. At most `limit` [s]."""
        deadline = time.monotonic() + limit
        while time.monotonic() < deadline:
            before = self.received
            end = time.monotonic() + quiet
            while time.monotonic() < end:
                self.executor_.spin_once(timeout_sec=quiet / 4)
            newest = self._holds_newest()
            if newest or (newest is None and self.received == before):
                return

    def _holds_newest(self) -> bool | None:
        """Whether a sample of each state topic is held (a free hub's too, where the
        simulator writes one) and each is the newest the last status counted; None where
        that is not known (no count in the status, no sequence numbers, or a state another
        node writes: a log's replay republishes the status it recorded, whose count is the
        recorded simulator's)."""
        counted = int(self.latest.get("diagnostics_values", {}).get(key.STATE_SAMPLES, 0))
        if not counted or not self.sequences or None in self.sequences.values():
            return None
        if self._states_from_simulator is None:
            self._states_from_simulator = self._writer_is_simulator()
        if self._states_from_simulator is False:
            return None
        expected = list(WATCHED_STATE)
        if self._hub_subscription is not None and self._hub_subscription.get_publisher_count():
            expected.append(topics.HUB_STATE)
        return all(self.sequences.get(name, 0) >= counted for name in expected)

    def _writer_is_simulator(self) -> bool | None:
        """Whether the simulator writes the state (a node of its name among the writers of
        its boom state); None while the graph does not name them yet (it learns a
        writer's node after the writer itself)."""
        writers = self.get_publishers_info_by_topic(self.resolve_topic_name(topics.BOOM_STATE))
        if any(
            info.node_name == topics.SIM_NODE and info.node_namespace == self.get_namespace()
            for info in writers
        ):
            return True
        if not writers or any(info.node_name == UNKNOWN_NODE for info in writers):
            return None
        return False

    def settle_answers(self, timeout: float, limit: float = ANSWER_HISTORY_S) -> None:
        """Take the simulator's answers already given: their transient-local history
        comes on a writer of its own, which may match after the state arrived. Waits for
        it to match (up to `timeout` [s]), then for as many answers as the diagnostics
        counted commands (the kept ones at most; up to `timeout`), then until none came
        for `limit` [s] (answers to commands not counted, e.g. stale ones)."""
        self.spin_until(
            lambda: self.status_subscription.get_publisher_count() > 0,
            timeout,
            f"{topics.COMMAND_STATUS} of {self.sim_name}",
        )
        status = self.latest.get("diagnostics_values", {})
        counted = (key.ACCEPTED, key.REJECTED, key.DROPPED)
        expected = min(
            topics.COMMAND_STATUS_QOS.depth, sum(int(status.get(name, 0)) for name in counted)
        )
        self.spin_until(
            lambda: len(self.answers) >= expected,
            timeout,
            f"the {expected} answer(s) on {topics.COMMAND_STATUS} the diagnostics count",
        )
        heard = len(self.answers)
        quiet_until = time.monotonic() + limit
        while time.monotonic() < quiet_until:
            self.executor_.spin_once(timeout_sec=0.01)
            if len(self.answers) != heard:
                heard, quiet_until = len(self.answers), time.monotonic() + limit

    def close(self, deliver: bool = True) -> None:
        """Let the commands sent reach their readers (`_deliver`; not after Ctrl-C, and
        a Ctrl-C ends the wait), then leave the graph."""
        if deliver:
            with contextlib.suppress(KeyboardInterrupt):
                self._deliver()
        self.executor_.shutdown()
        with bounded_teardown():
            self.destroy_node()

    def _deliver(self) -> None:
        """Keep each command publisher until as many subscriptions as the simulator
        counted on its topic when it answered (`commands_msg.SUBSCRIBERS`; a recorder's
        among them), and as this client's graph shows, have matched it and acknowledged
        its commands, at most DELIVERY_WAIT_S: the answer says only that the simulator
        has the command, and a subscription this client has not yet discovered gets it
        (transient local) when it matches; destroyed sooner, the publisher would take
        the command with it."""
        deadline = time.monotonic() + DELIVERY_WAIT_S
        for name, publisher in self._command_publishers.items():
            topic, type_name = self.resolve_topic_name(name), topics.TOPICS[name].type_name
            while (
                publisher.get_subscription_count()
                < max(self._readers.get(name, 0), subscriptions_of(self, topic, type_name))
                and time.monotonic() < deadline
            ):
                self.executor_.spin_once(timeout_sec=0.01)
            left = max(0.0, deadline - time.monotonic())
            publisher.wait_for_all_acked(Duration(nanoseconds=int(left * 1e9)))

    # -- commands ---------------------------------------------------------------------------

    def send(self, name: str, message, timeout: float) -> commands_msg.CommandAnswer:
        """Publish a command on topic `name` once the simulator listens, and return its
        answer.

        Raises:
            NoAnswerError: no simulator subscribed within `timeout` [s], or no answer came.
        """
        publisher = self._command_publishers.get(name)
        if publisher is None:
            topic = topics.TOPICS[name]
            publisher = self.create_publisher(topic.message_type, name, topics.LATCHED_COMMAND_QOS)
            self._command_publishers[name] = publisher
        resolved = self.resolve_topic_name(name)
        self.spin_until(
            lambda: (
                publisher.get_subscription_count() >= 1
                and self._simulator_listens(resolved)
                and self.status_subscription.get_publisher_count() >= 1
            ),
            timeout,
            f"simulator listening on {resolved} (is `sail-ros sim` running in this namespace "
            f"and ROS_DOMAIN_ID {os.environ.get('ROS_DOMAIN_ID', '0')}?)",
        )
        self._sent[name] = sequence = self._sent.get(name, 0) + 1  # DDS numbers from 1
        before = time.time_ns()
        publisher.publish(message)
        after = time.time_ns()
        found: list[commands_msg.CommandAnswer] = []

        def answered() -> bool:
            found.extend(
                answer
                for answer in self.answers
                if answer.topic == resolved
                and answer.sequence == sequence
                and before <= answer.source_timestamp_ns <= after
            )
            return bool(found)

        self.spin_until(answered, timeout, f"answer from {self.sim_name} on {resolved}")
        self._readers[name] = int(found[0].values.get(commands_msg.SUBSCRIBERS, 0))
        return found[0]

    def _simulator_listens(self, topic: str) -> bool:
        """Whether the graph shows the simulator's own subscription of `topic` (a
        recorder's is not one: a command only it took would go unanswered)."""
        return any(
            info.node_name == topics.SIM_COMMANDS_NODE
            and info.node_namespace == self.get_namespace()
            for info in self.get_subscriptions_info_by_topic(topic)
        )

    def call(self, service: str, request, timeout: float):
        """Call a service of the simulator (`sail/pause`, `sail/reset`); its response.

        Raises:
            NoAnswerError: the service did not appear or answer within `timeout` [s].
        """
        kind = SetBool if service == topics.PAUSE_SERVICE else Trigger
        client = self.create_client(kind, service)
        try:
            self.spin_until(
                client.service_is_ready, timeout, f"service {self.resolve_service_name(service)}"
            )
            future = client.call_async(request)
            self.spin_until(future.done, timeout, f"response from {client.srv_name}")
            return future.result()
        finally:
            self.destroy_client(client)

    def resolve_service_name(self, name: str) -> str:
        return topics.absolute(name, self.get_namespace())

    # -- watching ---------------------------------------------------------------------------

    def _on_answer(self, array: DiagnosticArray) -> None:
        answers = commands_msg.command_answers(array)
        if answers:
            self.answers.extend(answers)
            self.latest["answer"] = answers[-1]

    def _keeper(self, name: str):
        def keep(message: JointState, info: dict) -> None:
            self.latest[name] = message
            self.sequences[name] = info.get("publication_sequence_number") or None
            self.received += 1

        return keep

    def _on_diagnostics(self, array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name == topics.integrator_status_name(self.sim_name):
                self.latest["diagnostics"] = status
                self.latest["diagnostics_stamp_ns"] = topics.stamp_ns_of(array.header.stamp)
                self.latest["diagnostics_values"] = {p.key: p.value for p in status.values}


def init_context(ros_argv: list[str], domain_id: int | None):
    """An rclpy context for a client: ROS arguments, a domain, no signal handlers of its own
    (the tool decides how Ctrl-C ends it)."""
    from rclpy.signals import SignalHandlerOptions

    announce_often(profile=CLIENT_PROFILE)
    context = rclpy.Context()
    options = {} if domain_id is None else {"domain_id": domain_id}
    rclpy.init(
        args=ros_argv,
        context=context,
        signal_handler_options=SignalHandlerOptions.NO,
        **options,
    )
    return context
