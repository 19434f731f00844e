"""Machine-readable results of a benchmark (`--json FILE`): the tables a script prints,
with the machine it ran on, when, and the load around it, for the documentation's
benchmarks page (`render_results.py`)."""

from __future__ import annotations

import json
import os
import platform
import re
import time
from pathlib import Path

from machine import stolen_seconds


def machine() -> dict:
    """What ran the benchmark: processor, cores, memory, Python, the load averages now."""
    model = "unknown"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    memory_kib = 0
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemTotal:"):
            memory_kib = int(line.split()[1])
    return {
        "processor": model,
        "cores": os.cpu_count(),
        "memory_gib": round(memory_kib / 2**20, 1),
        "python": platform.python_version(),
        "system": f"{platform.system()} {platform.release()}",
    }


class Results:
    """Tables of one benchmark run, written as JSON by `write` (only if a path was given).

    Attributes:
        name: the script's name (`model_benchmark`, ...).
        command: the command line that produced the run, from the repository's root.
    """

    def __init__(self, name: str, argv: list[str]):
        self.name = name
        shown = " ".join(["python", f"benchmarks/{Path(argv[0]).name}", *argv[1:]])
        self.command = re.sub(r" --json(=| )\S+", "", shown)  # where it was written: no figure
        self.tables: list[dict] = []
        self.notes: list[str] = []
        self._load_before = os.getloadavg()
        self._steal_before = stolen_seconds()
        self._start = time.time()

    def table(self, title: str, columns: list[str], rows: list[list]) -> None:
        self.tables.append({"title": title, "columns": columns, "rows": rows})

    def note(self, text: str) -> None:
        self.notes.append(text)

    def write(self, path: str | Path | None) -> None:
        if not path:
            return
        document = {
            "benchmark": self.name,
            "command": self.command,
            "started_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime(self._start)),
            "duration_s": round(time.time() - self._start, 1),
            "load_average_1_5_15": {"before": [round(x, 2) for x in self._load_before],
                                    "after": [round(x, 2) for x in os.getloadavg()]},
            "steal_s": round(stolen_seconds() - self._steal_before, 2),
            "machine": machine(),
            "tables": self.tables,
            "notes": self.notes,
        }  # fmt: skip
        Path(path).write_text(json.dumps(document, indent=1) + "\n")


def merge(paths: list[Path], out: Path) -> None:
    """The latest run of each benchmark in `out` (`latest.json`): each run in `paths`
    replaces the one of its benchmark in place; the runs of benchmarks not given stay,
    and a new benchmark's run comes last."""
    runs = json.loads(out.read_text())["runs"] if out.is_file() else []
    for path in paths:
        run = json.loads(Path(path).read_text())
        same = [i for i, kept in enumerate(runs) if kept["benchmark"] == run["benchmark"]]
        if same:
            runs[same[0]] = run
        else:
            runs.append(run)
    out.write_text(json.dumps({"runs": runs}, indent=1) + "\n")


if __name__ == "__main__":
    import sys

    merge([Path(p) for p in sys.argv[2:]], Path(sys.argv[1]))
