"""The server's connections as this process holds them, for what foxglove-sdk has no call
for: ending a connection (one beyond `max_clients`, or every one at shutdown, a client
that never finished its WebSocket handshake included), and handing the memory its queue
held back to the system.

foxglove-sdk 0.30.3 accepts every connection and waits without a limit for its
handshake: `WebSocketServer.stop` waits for every connection's task, so a TCP client
that connected and sent nothing (or half a GET) held the bridge's shutdown for as long
as it stayed. Shutting a connection's socket down (`shutdown(2)`, on a duplicate of the
server's descriptor, which stays the server's to close) ends its reads and writes at
once: the server drops the client as if it had left. The sockets are found among the
process's descriptors (Linux `/proc/self/fd`) by their local port and peer address.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import socket
from collections.abc import Iterator
from pathlib import Path

_FDS = Path("/proc/self/fd")


def _address(sockname) -> str:
    """`ip:port` as foxglove-sdk names a client (IPv6 in brackets)."""
    host, port = sockname[0], sockname[1]
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def connections(port: int) -> Iterator[tuple[socket.socket, str]]:
    """The TCP connections accepted on local `port` in this process: a duplicate of each
    one's socket (the caller closes it) and its peer's address (`ip:port`)."""
    try:
        descriptors = [int(name) for name in os.listdir(_FDS)]
    except OSError:  # no /proc: nothing can be found
        return
    for fd in descriptors:
        try:
            if not os.readlink(_FDS / str(fd)).startswith("socket:"):
                continue
            duplicate = os.dup(fd)
        except OSError:  # closed meanwhile
            continue
        try:
            each = socket.socket(fileno=duplicate)
        except OSError:
            os.close(duplicate)
            continue
        try:
            if (
                each.family in (socket.AF_INET, socket.AF_INET6)
                and each.type == socket.SOCK_STREAM
                and each.getsockname()[1] == port
            ):
                peer = _address(each.getpeername())  # OSError for the listening socket
                yield each, peer
        except OSError:
            pass
        finally:
            each.close()


def disconnect(port: int, address: str | None = None) -> int:
    """Shut down the connections accepted on `port` from `address` (`ip:port`; None: every
    one); how many."""
    ended = 0
    for each, peer in connections(port):
        if address is None or peer == address:
            with contextlib.suppress(OSError):
                each.shutdown(socket.SHUT_RDWR)
                ended += 1
    return ended


def release_freed_memory() -> None:
    """Hand the memory freed in this process back to the system (glibc's `malloc_trim`):
    the server's threads each allocate in an arena of their own, and a client's queue,
    once freed, would otherwise stay in the process's resident memory."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).malloc_trim(0)
