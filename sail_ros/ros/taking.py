"""Taking the messages that already wait on a subscription, in one go.

rclpy's executors take one message per subscription per wait set, so every message
costs a wake-up and a new wait set (~0.1 ms of Python). A recorder that, once woken,
takes everything already waiting pays that once per batch: at the simulator's rates
half the CPU per message, and on 2 cores the highest lossless rate of
`benchmarks/recorder_throughput.py` is 4000 steps/s instead of 3000, past which
taking one message per wake-up falls far behind (14 000 of 24 000 messages lost at
4000 steps/s; msg_docs/recorder.md).

Jazzy's rclpy has no public call for this. `Subscription.handle.take_message` is
what its own executors (`Executor._take_subscription`) and `wait_for_message` call;
its alternative, `rclpy.experimental.EventsExecutor`, does not hand over the message
info (a callback taking `(message, info)` fails with "SystemError: null argument to
internal routine" in rclpy 7.1.5), and the recorder needs DDS's reception and
source times. This is the one place that calls it; test_recorder_node checks it
against the installed rclpy.
"""

from __future__ import annotations

from collections.abc import Iterator


def take_waiting(subscription, limit: int) -> Iterator[tuple[object, dict]]:
    """Up to `limit` (message, info) pairs already received by `subscription`, oldest
    first, as its callback would get them (bytes for a raw subscription; `info` with
    `source_timestamp`, `received_timestamp`, `publication_sequence_number`)."""
    for _ in range(limit):
        with subscription.handle:
            taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
        if taken is None:
            return
        yield taken
