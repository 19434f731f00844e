"""The benchmarks page is rendered from the scripts' JSON (benchmarks/results.py,
render_results.py): the machine, the dates and the load stated once, then each
benchmark's command and tables as written."""

import json
import sys

import pytest
from harness import ROOT

pytestmark = pytest.mark.model

sys.path.insert(0, str(ROOT / "benchmarks"))
from render_results import render  # noqa: E402
from results import Results, merge  # noqa: E402


def test_the_page_states_the_run_once_and_every_table(tmp_path):
    paths = []
    for name in ("model_benchmark", "sim_cpu"):
        results = Results(name, [f"benchmarks/{name}.py", "--json", "x.json"])
        results.table(f"{name} table", ["case", "wall [s]"], [["a|b", 0.123456], ["c", 2]])
        results.note(f"{name} note")
        results.write(tmp_path / f"{name}.json")
        paths.append(tmp_path / f"{name}.json")
    merge(paths, tmp_path / "latest.json")
    runs = json.loads((tmp_path / "latest.json").read_text())["runs"]
    assert [run["benchmark"] for run in runs] == ["model_benchmark", "sim_cpu"]
    page = render(tmp_path / "latest.json")
    assert page.count("- machine: ") == 1 and page.count("- load: ") == 1
    assert page.count("- date (UTC): ") == 1
    assert "python benchmarks/sim_cpu.py\n" in page  # the command, without where it wrote
    assert "| a\\|b | 0.1235 |" in page and "- model_benchmark note" in page


def test_a_merge_replaces_the_run_of_each_benchmark_given_and_keeps_the_others(tmp_path):
    def run(name, value):
        results = Results(name, [f"benchmarks/{name}.py"])
        results.table("t", ["case", "wall [s]"], [["a", value]])
        results.write(tmp_path / f"{name}_{value}.json")
        return tmp_path / f"{name}_{value}.json"

    latest = tmp_path / "latest.json"
    merge([run("model_benchmark", 1), run("sim_cpu", 2)], latest)
    merge([run("sim_cpu", 3), run("bridge_latency", 4)], latest)
    runs = json.loads(latest.read_text())["runs"]
    assert [run["benchmark"] for run in runs] == ["model_benchmark", "sim_cpu", "bridge_latency"]
    assert [run["tables"][0]["rows"][0][1] for run in runs] == [1, 3, 4]


def test_the_committed_run_renders():
    page = render(ROOT / "benchmarks" / "results" / "latest.json")
    assert page.startswith("# Benchmarks")
    assert page.count("## The run") == 1 and "- load: one-minute load average" in page
    assert "## `model_benchmark`" in page and "## `montecarlo_dask`" in page
