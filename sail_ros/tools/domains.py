"""A DDS domain of its own for a run that must not mix with anything else on the machine.

Fast DDS gives domain `d` the UDP ports `7400 + 250 d` ... `7400 + 250 d + 249`
(its default port mapping: discovery and user traffic of every participant);
a domain with none of them bound on this machine has no participant here.
`DomainLease` picks such a domain and holds a lock file until the caller's
processes have bound their ports, so two runs started at once pick two
different domains.
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path

PORT_BASE, DOMAIN_GAIN = 7400, 250
FIRST_DOMAIN, LAST_DOMAIN = 100, 232  # Fast DDS supports domains up to 232
LOCK_PATH = Path(tempfile.gettempdir()) / "sail_ros_domains.lock"


def bound_udp_ports() -> set[int]:
    """Local UDP ports bound on this machine (Linux /proc/net/udp, udp6)."""
    ports = set()
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            local = line.split()[1]  # "0100007F:1CE8": address:port in hex
            ports.add(int(local.rsplit(":", 1)[1], 16))
    return ports


def domain_in_use(domain: int, ports: set[int]) -> bool:
    low = PORT_BASE + DOMAIN_GAIN * domain
    return any(low <= port < low + DOMAIN_GAIN for port in ports)


class DomainLease:
    """`with DomainLease() as domain:` a free domain id; keep the block open until the
    run's processes have joined it (the lock then passes to the next run)."""

    def __init__(self, lock_path: Path = LOCK_PATH):
        self._lock_path = lock_path
        self._lock = None

    def __enter__(self) -> int:
        self._lock = open(self._lock_path, "a")  # noqa: SIM115 (held across the block)
        fcntl.flock(self._lock, fcntl.LOCK_EX)
        ports = bound_udp_ports()
        start = FIRST_DOMAIN + os.getpid() % (LAST_DOMAIN - FIRST_DOMAIN + 1)
        span = LAST_DOMAIN - FIRST_DOMAIN + 1
        for offset in range(span):
            domain = FIRST_DOMAIN + (start - FIRST_DOMAIN + offset) % span
            if not domain_in_use(domain, ports):
                return domain
        self.__exit__()
        raise RuntimeError(f"every DDS domain from {FIRST_DOMAIN} to {LAST_DOMAIN} is in use")

    def __exit__(self, *exc_info) -> None:
        if self._lock is not None:
            fcntl.flock(self._lock, fcntl.LOCK_UN)
            self._lock.close()
            self._lock = None
