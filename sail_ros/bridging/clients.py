"""What the bridge knows of its clients, and its counts: shared by the executor thread
(messages served), the server's threads (subscriptions, client channels, commands) and
service calls, so every read and change holds one lock."""

from __future__ import annotations

import threading

from sail_ros import status as key
from sail_ros.bridging.protocol import MESSAGE_ENCODING, full_type_or_none

COUNTED = (
    key.SERVED,
    key.CLIENT_COMMANDS,
    key.REFUSED,
    key.SERVICE_CALLS,
    key.SLOW_REPORTS,
    key.REFUSED_CONNECTIONS,
)


class ClientBook:
    """Subscriptions by client, the client channels accepted for publishing, the counts of
    the bridge's status, the last refusal and the clients reported slow."""

    def __init__(self, channels: int):
        self.channels = channels  # topics served
        self.url = ""  # where the server listens, once it does
        self._lock = threading.Lock()
        self._counts = dict.fromkeys(COUNTED, 0)
        self._subscribers: dict[int, set[int]] = {}  # client id -> channel ids
        self._client_channels: dict[tuple[int, int], str] = {}  # (client, channel) -> topic
        self._last_refusal = ""
        self._slow_clients: set[str] = set()
        self._connected: set[str] = set()  # addresses of the clients connected
        self.left = False  # a client left since `take_left` last asked

    def connect(self, address: str, most: int) -> bool:
        """A client connected from `address`: whether it may stay, at most `most` being
        connected at once (else it is counted refused and not kept)."""
        with self._lock:
            if len(self._connected) >= most:
                self._counts[key.REFUSED_CONNECTIONS] += 1
                return False
            self._connected.add(address)
            return True

    def disconnect(self, address: str) -> None:
        """The client from `address` is gone (a refused one too)."""
        with self._lock:
            self._connected.discard(address)
            self.left = True

    def take_left(self) -> bool:
        """Whether a client left since the last call."""
        with self._lock:
            left, self.left = self.left, False
            return left

    def count(self, name: str) -> None:
        """One more of `name` (COUNTED)."""
        with self._lock:
            self._counts[name] += 1

    def subscribe(self, client_id: int, channel_id: int) -> None:
        with self._lock:
            self._subscribers.setdefault(client_id, set()).add(channel_id)

    def unsubscribe(self, client_id: int, channel_id: int) -> None:
        with self._lock:
            channels = self._subscribers.get(client_id, set())
            channels.discard(channel_id)
            if not channels:
                self._subscribers.pop(client_id, None)

    def accept_channel(self, client_id: int, channel_id: int, topic: str) -> None:
        with self._lock:
            self._client_channels[(client_id, channel_id)] = topic

    def drop_channel(self, client_id: int, channel_id: int) -> None:
        with self._lock:
            self._client_channels.pop((client_id, channel_id), None)

    def topic_of(self, client_id: int, channel_id: int) -> str | None:
        """The command topic of an accepted client channel, or None."""
        with self._lock:
            return self._client_channels.get((client_id, channel_id))

    def refused(self, text: str) -> None:
        with self._lock:
            self._counts[key.REFUSED] += 1
            self._last_refusal = text

    def slow(self, address: str) -> None:
        with self._lock:
            self._counts[key.SLOW_REPORTS] += 1
            self._slow_clients.add(address)

    def status_values(self) -> dict[str, str]:
        """The key/value pairs of the bridge's status (msg_docs/bridge.md)."""
        with self._lock:
            return {
                key.BRIDGE_URL: self.url,
                key.CLIENTS: str(len(self._subscribers)),
                key.CONNECTIONS: str(len(self._connected)),
                key.CHANNELS: str(self.channels),
                **{name: str(value) for name, value in self._counts.items()},
                key.SLOW_CLIENTS: " ".join(sorted(self._slow_clients)),
                key.LAST_REFUSAL: self._last_refusal,
            }


def command_refusal(topic: str, schema_name: str, encoding: str, commands: dict) -> str | None:
    """Why a client may not publish on `topic` with that schema and encoding (`commands`:
    resolved command topic -> its `topics.Topic`), or None if it may."""
    command = commands.get(topic)
    if command is None:
        return f"not a command topic (commands: {', '.join(sorted(commands))})"
    if full_type_or_none(schema_name) != command.type_name:
        return f"schema {schema_name!r}, expected {command.type_name}"
    if encoding != MESSAGE_ENCODING:
        return f"encoding {encoding!r}, expected {MESSAGE_ENCODING}"
    return None
