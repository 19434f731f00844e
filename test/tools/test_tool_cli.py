"""The tools' command lines: every mistake one clear line and its exit code, unknown
names answered with the nearest known one, quiet broken pipes, and `--help` that ends
with examples that parse and names every file the tool writes."""

import argparse
import contextlib
import importlib
import io
import shlex
import subprocess
import sys
from types import SimpleNamespace

import pytest
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from harness import SMALL_SET, run_tool

from sail_ros import cli, topics
from sail_ros import status as key
from sail_ros.messages import state as state_msg
from sail_ros.ros.program import parse_command_line
from sail_ros.tools import deploy, montecarlo, report, send, watch

pytestmark = pytest.mark.model

# the tools whose command lines live in sail_ros/tools (the nodes' in sail_ros/nodes)
TOOLS = ("modes", "deploy", "stability", "plant", "montecarlo", "report", "send", "watch", "demo")
DOMAIN = "a DDS domain must be an integer in [0, 232] (the domains Fast DDS has ports for)"

CASES = [
    ("send", ["--domain-id", "-1", "reset"], 2, f"error: --domain-id -1: {DOMAIN}"),
    ("send", ["--domain-id", "300", "reset"], 2, f"error: --domain-id 300: {DOMAIN}"),
    ("modes", ["--set", "sail_side=1e300"], 2,
     "error: sail_side must be in (0, 10000] m, got 1e+300"),
    ("modes", ["--set", "max_rat=2"], 2,
     "error: --set: unknown parameter 'max_rat' (did you mean 'max_rate'?); sail parameters: "),
    ("send", ["pressure", "--quadrants", "ab", "cd", "--values", "2e-3"], 2,
     "error: --values: one per name of --quadrants (2: ab cd), or one with --quadrants all; "
     "got 1"),
    ("send", ["pressure", "--quadrants", "all", "--values", "1e-3", "2e-3"], 2,
     "error: --values: one value with --quadrants all, got 2"),
    ("send", ["tip-force", "--booms", "all", "a", "--values", "0"], 2,
     "error: --booms: `all` stands alone, got all a"),
    ("send", ["pressure", "--quadrants", "ab", "--values", "-inf"], 2,
     "error: quadrant_ab = -inf Pa is not finite"),
    ("send", ["tip-force", "--booms", "a", "b", "--values", "-1e-3", "nan"], 2,
     "error: boom_b = nan N is not finite"),
    ("send", ["hub-wrench", "--force", "nan"], 2, "error: --force = nan N is not finite"),
    ("send", ["hub-wrench", "--torque-y", "-inf"], 2,
     "error: --torque-y = -inf N m is not finite"),
    ("send", ["move", "--booms", "a", "--point", "5", "-inf"], 2,
     "error: --point: boom_a is -inf, not a finite length"),
    ("send", ["reset", "--timeout", "3"], 2,
     "sail-ros send: error: unrecognized arguments: --timeout 3 (--timeout goes before the "
     "command)"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("tool", "argv", "code", "line"), CASES, ids=[" ".join(c[1]) for c in CASES]
)
def test_each_mistake_is_one_clear_line(tool, argv, code, line):
    got, out, err = run_tool(tool, argv)
    assert got == code and "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith(line), err


def test_a_bad_ros_domain_id_in_the_environment_is_named(monkeypatch):
    for value in ("300", "abc", "-1"):
        monkeypatch.setenv("ROS_DOMAIN_ID", value)
        code, _, err = run_tool("watch", ["--once"])
        assert code == 2 and err == f"error: ROS_DOMAIN_ID={value!r}: {DOMAIN}\n"


def test_all_quadrants_or_booms_take_one_value():
    parser = send.build_parser()
    topic, message = send.load_command(
        parser.parse_args(["pressure", "--quadrants", "all", "--values", "9.1e-6"])
    )
    assert list(message.name) == ["quadrant_ab", "quadrant_bc", "quadrant_cd", "quadrant_da"]
    assert list(message.effort) == [9.1e-6] * 4
    _, message = send.load_command(
        parser.parse_args(["tip-force", "--booms", "d", "b", "--values", "-1e-3", "-.5"])
    )
    assert list(message.name) == ["boom_d", "boom_b"] and list(message.effort) == [-1e-3, -0.5]


def test_unknown_tools_and_options_name_the_nearest():
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert cli.main(["mode"]) == 2
    assert err.getvalue().startswith("sail-ros: unknown tool 'mode' (did you mean 'modes'?)")
    misspelt = {
        "modes": ("--lenghts", "--lengths"),
        "deploy": ("--figuers", "--figures"),
        "stability": ("--pionts", "--points"),
        "plant": ("--figuer", "--figure"),
        "montecarlo": ("--sampels", "--samples"),
        "report": ("--no-convergance", "--no-convergence"),
        "send": ("--timout", "--timeout"),
        "watch": ("--oncee", "--once"),
        "demo": ("--time-scael", "--time-scale"),
    }
    for tool in TOOLS:
        wrong, right = misspelt[tool]
        argv = {"montecarlo": ["study.yaml"], "report": ["log.mcap"], "send": []}.get(tool, [])
        code, _, err = run_tool(tool, [*argv, f"{wrong}=1"] + (["reset"] if tool == "send" else []))
        assert code == 2, (tool, err)
        assert f"(did you mean '{right}'?)" in err.strip().splitlines()[-1], (tool, err)


@pytest.mark.parametrize(
    "argv",
    [
        ["deploy", *SMALL_SET, "--to", "10", "--t-end", "3", "--every", "0.002"],  # 125 kB
        ["report", "LOG", "--out", "REPORT", "--no-convergence"],  # prints between its work
    ],
    ids=["deploy", "report"],
)
def test_a_broken_pipe_ends_quietly(tmp_path, ros_env, argv):
    """`sail-ros ... | head -1`: the reader goes away after one line; the tool ends as
    Unix tools do on SIGPIPE (exit code 141, nothing on stderr)."""
    if argv[0] == "report":
        log = tmp_path / "run.mcap"
        argv_log = [*SMALL_SET, "--t-end", "2", "--rate", "10", "--mcap", str(log)]
        assert run_tool("deploy", argv_log)[0] == 0
        argv = [str(log) if a == "LOG" else str(tmp_path / "r") if a == "REPORT" else a
                for a in argv]  # fmt: skip
    process = subprocess.Popen(
        [sys.executable, "-m", "sail_ros.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env={**ros_env, "PYTHONUNBUFFERED": "1"},
        cwd=tmp_path,
    )
    assert process.stdout.readline()
    process.stdout.close()  # as head does after its line
    err = process.stderr.read().decode()
    assert process.wait(timeout=120) == 141, err
    assert err == ""


def module_of(tool: str):
    return importlib.import_module(cli.TOOLS[tool].split(":")[0])


def parse_example(example: str):
    """The example's arguments as its tool parses them (up to a shell pipe)."""
    words = shlex.split(example.split(" | ")[0])
    assert words[0] == "sail-ros" and words[1] in cli.TOOLS, example
    tool = words[1]
    parser = module_of(tool).build_parser()
    if tool in ("send", "watch"):  # ROS tools: --ros-args ... go to rclpy
        return parse_command_line(parser, f"sail-ros {tool}", words[2:])[0]
    return parser.parse_args(words[2:])


@pytest.mark.parametrize("tool", TOOLS)
def test_help_ends_with_examples_that_parse(tool):
    module = module_of(tool)
    text = module.build_parser().format_help()
    block = "Examples:\n" + "\n".join(f"  {example}" for example in module.EXAMPLES)
    assert text.rstrip().endswith(block), text[-600:]
    # its own, at least two (a report's example may first make a log with deploy)
    assert sum(example.split()[1] == tool for example in module.EXAMPLES) >= 2
    for example in module.EXAMPLES:
        parse_example(example)


@pytest.mark.parametrize("tool", ["send", "bag"])
def test_each_command_of_a_tool_ends_its_help_with_its_own_examples(tool):
    parser = module_of(tool).build_parser()
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for name, command in commands.choices.items():
        text = command.format_help()
        assert "\nExamples:\n" in text, (tool, name)
        examples = [line.strip() for line in text.split("\nExamples:\n")[1].strip().splitlines()]
        assert examples, (tool, name)
        for example in examples:
            assert example.split()[:3] == ["sail-ros", tool, name], example
            parse_example(example)


def test_help_names_the_files_written(tmp_path, monkeypatch):
    """What the tools write is named in their --help: the figures of each, and every file
    a report and a study actually wrote."""
    helps = {tool: module_of(tool).build_parser().format_help() for tool in TOOLS}
    assert "stability_map.png" in helps["stability"]
    for tool in ("deploy", "stability", "montecarlo"):
        for name in module_of(tool).FIGURES:
            assert name in helps[tool], (tool, name)
    assert "mode_shapes.png" in helps["modes"] and "--npz FILE and --mat FILE" in helps["plant"]
    log = tmp_path / "run.mcap"
    argv = [*SMALL_SET, "--t-end", "2", "--rate", "10", "--mcap", str(log)]
    assert deploy.main(argv) == 0
    assert report.main([str(log), "--out", str(tmp_path / "r"), "--no-convergence"]) == 0
    for path in (tmp_path / "r").iterdir():
        assert path.name in " ".join(helps["report"].split()), path.name
    monkeypatch.setattr(montecarlo, "dask_client", lambda *_: contextlib.nullcontext())
    study = tmp_path / "study.yaml"
    study.write_text(
        "study:\n  samples: 3\n  scenario: {scenario: {duration: 1.0, profile: {type: static, "
        "lengths: 10.0}}}\n  dispersions: {initial_tip_deflection.a: {distribution: uniform, "
        "low: 0.05, high: 0.1}}\n"
    )
    out = tmp_path / "study"
    assert montecarlo.main([str(study), "--out", str(out), "--set", "n_membrane_modes=2"]) == 0
    named = " ".join(helps["montecarlo"].split())
    for path in out.rglob("*.*"):
        name = str(path.relative_to(out))
        if name.startswith("worst/"):
            assert "worst/worst_<rank>_sample_<index>.yaml" in named
        else:
            assert name in named, name


def test_a_hub_wrench_command_names_its_three_components_the_others_zero():
    args = send.build_parser().parse_args(["hub-wrench", "--force", "0.2", "--torque-y", "-0.05"])
    message = send.hub_wrench(args)
    wrench = message.wrench
    assert (wrench.force.z, wrench.torque.x, wrench.torque.y) == (0.2, 0.0, -0.05)
    assert (wrench.force.x, wrench.force.y, wrench.torque.z) == (0.0, 0.0, 0.0)


def test_watch_shows_the_time_of_the_state_it_shows():
    """The diagnostics come once a second, the state every step: `watch` gives the newest
    state's simulation time (the diagnostics' moved on by the stamps), not the older
    diagnostics' own."""
    epoch = 1_700_000_000_000_000_000
    status = DiagnosticStatus(values=[KeyValue(key=key.SIM_TIME, value="2.0")])
    latest = {
        "diagnostics": status,
        "diagnostics_stamp_ns": topics.stamp_ns(epoch, 2.0),
        topics.BOOM_STATE: state_msg.boom_state(
            topics.stamp_ns(epoch, 2.73), [10.5] * 4, [0.1] * 4
        ),
    }
    view = watch.snapshot(SimpleNamespace(latest=latest, sim_name="/sail_sim"))
    assert view[key.SIM_TIME] == 2.73 and view["boom_length_m"]["a"] == 10.5
    # a state of another run (a restarted simulator, before its first diagnostics)
    latest[topics.BOOM_STATE].header.stamp = topics.stamp(epoch - 5 * 10**9)
    view = watch.snapshot(SimpleNamespace(latest=latest, sim_name="/sail_sim"))
    assert view[key.SIM_TIME] == 2.0


def test_watch_counts_the_commands_by_every_outcome():
    """Superseded commands (a newer one came before they started) and ignored ones are
    counted beside the accepted and rejected: together, every command received."""
    counts = {key.ACCEPTED: 3, key.SUPERSEDED: 40, key.REJECTED: 2, key.IGNORED: 1}
    status = DiagnosticStatus(
        values=[KeyValue(key=name, value=str(value)) for name, value in counts.items()]
    )
    latest = {"diagnostics": status, "diagnostics_stamp_ns": 0}
    view = watch.snapshot(SimpleNamespace(latest=latest, sim_name="/sail_sim"))
    assert {name: view[name] for name in counts} == counts
    line = next(row for row in watch.table(view).splitlines() if "commands:" in row)
    assert line.strip().startswith("commands: 3 accepted, 40 superseded")
    assert line.endswith("2 rejected, 1 ignored")


@pytest.mark.parametrize("node", ["sim", "control", "recorder", "replay", "bridge"])
def test_a_nodes_help_ends_with_its_examples(node, capsys):
    try:
        code = cli.main([node, "--help"])
    except SystemExit as exit_info:
        code = exit_info.code
    text = capsys.readouterr().out
    assert code == 0
    assert "\nExamples:\n" in text, text[-600:]
    examples = [line.strip() for line in text.split("\nExamples:\n")[1].strip().splitlines()]
    assert len(examples) >= 2 and all(e.startswith(f"sail-ros {node}") for e in examples)


def test_the_umbrella_help_gives_one_line_per_tool(capsys):
    assert cli.main(["--help"]) == 0
    text = capsys.readouterr().out
    assert set(cli.SUMMARIES) == set(cli.TOOLS)
    for name in cli.TOOLS:
        (line,) = [line for line in text.splitlines() if line.split()[:1] == [name]]
        assert cli.SUMMARIES[name] in line
    assert "sail_ros." not in text  # summaries, not module paths
