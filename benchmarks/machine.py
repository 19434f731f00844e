"""What this machine itself did during a benchmark: the CPU time the hypervisor took from
its cores (a shared virtual machine's cores stall while another guest runs)."""

from __future__ import annotations

import os
from pathlib import Path


def stolen_seconds() -> float:
    """CPU time [s] the hypervisor has taken from this machine's cores (/proc/stat's
    steal, all cores)."""
    fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()
    return int(fields[8]) / os.sysconf("SC_CLK_TCK")
