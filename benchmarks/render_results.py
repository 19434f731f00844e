"""The documentation's benchmarks page, rendered from `results/latest.json` (the latest
run of each benchmark, merged by `results.py`): the machine and the load stated once,
then each benchmark's command and tables."""

from __future__ import annotations

import json
from pathlib import Path

HEADER = """# Benchmarks

Speed and memory are measured by the scripts in `benchmarks/`, which print their
figures and, with `--json FILE`, write them for this page. The page shows the latest
run of each, rendered from `benchmarks/results/latest.json`; earlier runs are in the
history of that file. This machine is a shared virtual machine whose speed drifts: compare
figures of one run, not across runs.

To refresh it, run the benchmarks with `--json` and merge their files:

```text
python benchmarks/model_benchmark.py --json /tmp/model.json
python benchmarks/montecarlo_dask.py --json /tmp/montecarlo.json
python benchmarks/free_hub_benchmark.py --json /tmp/free_hub.json
python benchmarks/sim_cpu.py --quick --json /tmp/sim_cpu.json
python benchmarks/recorder_throughput.py --json /tmp/recorder.json
python benchmarks/bridge_latency.py --json /tmp/bridge.json
python benchmarks/results.py benchmarks/results/latest.json /tmp/model.json ...
```
"""


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value).replace("|", "\\|")


def _table(table: dict) -> list[str]:
    lines = [f"**{table['title']}**", "", "| " + " | ".join(table["columns"]) + " |",
             "|" + "---|" * len(table["columns"])]  # fmt: skip
    lines += ["| " + " | ".join(_cell(value) for value in row) + " |" for row in table["rows"]]
    return lines + [""]


def render(path: Path) -> str:
    runs = json.loads(Path(path).read_text())["runs"] if Path(path).is_file() else []
    lines = [HEADER]
    if not runs:
        return "\n".join(lines + ["No run has been recorded yet.", ""])
    machine = runs[0]["machine"]
    dates = sorted(run["started_utc"] for run in runs)
    low = min(run["load_average_1_5_15"]["before"][0] for run in runs)
    high = max(max(run["load_average_1_5_15"]["before"][0], run["load_average_1_5_15"]["after"][0])
               for run in runs)  # fmt: skip
    lines += [
        "## The run",
        "",
        f"- machine: {machine['processor']}, {machine['cores']} cores, "
        f"{machine['memory_gib']} GiB, {machine['system']}, Python {machine['python']}",
        f"- date (UTC): {dates[0]} to {dates[-1]}",
        f"- load: one-minute load average {low:.1f} to {high:.1f} at the start and end of the "
        "benchmarks (other work was running on the machine)",
        "",
    ]
    for run in runs:
        lines += [f"## `{run['benchmark']}`", "", "```text", run["command"], "```", ""]
        lines.append(f"{run['duration_s']:.0f} s; CPU time the hypervisor took: "
                     f"{run['steal_s']:.2f} s.")  # fmt: skip
        lines.append("")
        for table in run["tables"]:
            lines += _table(table)
        lines += [f"- {note}" for note in run["notes"]]
        lines.append("")
    return "\n".join(lines)
