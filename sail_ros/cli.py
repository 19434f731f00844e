"""The umbrella command `sail-ros <tool> [args]`, and how every tool reads its command line.

Each tool is also its own executable under `lib/sail_ros` (what `ros2 run
sail_ros <tool>` starts, `main_<tool>` here); both routes call the tool's same
`main`. This module imports nothing heavy, so that `setup.py` can read `TOOLS`
and so that an entry point keeps an early SIGINT (`early_signals`) before the
tool's imports take their second.

`ToolParser` is the tools' argument parser: an unknown option is answered with
the nearest known one, a number such as `-inf` or `-1e-3` is a value, not an
option, and `--help` ends with the tool's examples (`help_epilog`).
"""

import argparse
import difflib
import importlib
import re
import sys
import textwrap

from sail_ros.early_signals import keep_early_sigint

PHYSICS_DOC = (
    "The physics, its choices and checks: docs/model.md (installed as "
    "share/sail_ros/docs/model.md)."
)

INTERRUPTED = 130  # the exit code of a program ended by SIGINT (128 + 2), as shells give it

# tool name -> "module:function" (a console_scripts target)
TOOLS = {
    "modes": "sail_ros.tools.modes:main",
    "deploy": "sail_ros.tools.deploy:main",
    "stability": "sail_ros.tools.stability:main",
    "plant": "sail_ros.tools.plant:main",
    "montecarlo": "sail_ros.tools.montecarlo:main",
    "report": "sail_ros.tools.report:main",
    "bag": "sail_ros.tools.bag:main",
    "recorder": "sail_ros.nodes.recorder:main",
    "replay": "sail_ros.nodes.replay:main",
    "bridge": "sail_ros.nodes.bridge:main",
    "sim": "sail_ros.nodes.sim:main",
    "control": "sail_ros.nodes.control:main",
    "send": "sail_ros.tools.send:main",
    "watch": "sail_ros.tools.watch:main",
    "demo": "sail_ros.tools.main_job:main",
}


# one line per tool for `sail-ros --help`
SUMMARIES = {
    "modes": "natural frequencies and mode shapes at any boom lengths; --fem cross-check",
    "deploy": "an offline deployment from a scenario: tables, true peaks, MCAP, figures",
    "stability": "largest real part of seed Eq. 3 over lengths, rates, prestress (Dask)",
    "plant": "the linear plant: poles, .npz/.mat matrices, Bode figure; --controller",
    "montecarlo": "Monte Carlo deployments of a study file on Dask: percentiles, worst cases",
    "report": "figures and CSV of a log: tips, root moments, lengths, energies, real time",
    "bag": "bag recover: a complete copy of a log cut short",
    "recorder": "node sail_recorder: record topics to MCAP as rosbag2 does",
    "replay": "node sail_replay: republish a log with its recorded timing and /clock",
    "bridge": "node sail_bridge: the simulator live in Foxglove over WebSocket",
    "sim": "node sail_sim: the sail simulated in real time",
    "control": "node sail_control: holds a free hub's attitude and heave (LQG)",
    "send": "one command to the running simulator, and its answer",
    "watch": "the running simulator live in the terminal (--once, --json)",
    "demo": "the main job: simulator and recorder, the reference deployment, a summary",
}


def docstring_examples(doc: str) -> list[str]:
    """The example commands of a module docstring: its lines indented by four spaces that
    start with `sail-ros `."""
    return [line.strip() for line in doc.splitlines() if line.startswith("    sail-ros ")]


# a value such as -1, -.5, -1e-3, -inf or -nan: argparse's own pattern takes only the
# first two, so `--values -inf` read as an unknown option
NEGATIVE_NUMBER = re.compile(
    r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE
)


def nearest(name: str, known, cutoff: float = 0.6) -> str | None:
    """The known name closest to `name`, or None if none is close (difflib's ratio
    below `cutoff`)."""
    close = difflib.get_close_matches(name, sorted(known), n=1, cutoff=cutoff)
    return close[0] if close else None


class ToolParser(argparse.ArgumentParser):
    """An `argparse.ArgumentParser` that reads negative numbers of any form as values
    and names the nearest option for an unknown one (its subcommands' parsers too)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def parse_args(self, args=None, namespace=None):
        return parse_arguments(self, sys.argv[1:] if args is None else args, namespace)


def parse_arguments(parser: argparse.ArgumentParser, args, namespace=None):
    """`parser.parse_args(args)`, but an unknown option is named with the nearest option
    of the parser (or of the subcommand given): `unrecognized arguments: --lenghts
    (did you mean '--lengths'?)`. Exits as argparse does (code 2) on a bad command line.
    """
    parsed, extras = parser.parse_known_args(args, namespace)
    if extras:
        unknown = next((item for item in extras if item.startswith("-")), "")
        name = unknown.partition("=")[0]
        hint = ""
        if name in _option_strings(parser, None):  # an option of the tool after its command
            hint = f" ({name} goes before the command)"
        elif name:
            # options share their "--": a higher bar than for names
            close = nearest(name, _option_strings(parser, parsed), 0.75)
            hint = f" (did you mean {close!r}?)" if close else ""
        parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
    return parsed


def _option_strings(parser: argparse.ArgumentParser, parsed) -> set[str]:
    """The long options of `parser` and of the subcommand parsers `parsed` chose (None:
    of `parser` alone)."""
    found = set()
    for action in parser._actions:
        found.update(option for option in action.option_strings if option.startswith("--"))
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(parsed, action.dest, None) or "")
            if chosen is not None:
                found |= _option_strings(chosen, parsed)
    return found


def help_epilog(examples, writes: str = "", notes: str = "") -> str:
    """The end of a tool's `--help`: `notes` (paragraphs), the files it writes, where the
    physics is documented, and last the examples (commands, one a line; a comment after
    `#` is kept)."""
    paragraphs = [_filled(p) for p in notes.split("\n\n") if p.strip()]
    if writes:
        paragraphs.append(textwrap.fill("Writes: " + " ".join(writes.split()), 88))
    paragraphs.append(textwrap.fill(PHYSICS_DOC, 88))
    paragraphs.append("Examples:\n" + "\n".join(f"  {line}" for line in examples))
    return "\n\n".join(paragraphs)


def _filled(paragraph: str) -> str:
    """A paragraph of a docstring wrapped to 88 columns, a list (lines starting "- ") as a
    list: each item wrapped under its dash."""
    lines = []
    for item in re.split(r"\n\s*(?=- )", paragraph.strip()):
        text = " ".join(item.split())
        if text.startswith("- "):
            lines.append(textwrap.fill(text[2:], 88, initial_indent="- ", subsequent_indent="  "))
        else:
            lines.append(textwrap.fill(text, 88))
    return "\n".join(lines)


def _usage():
    width = max(len(name) for name in TOOLS)
    lines = ["usage: sail-ros <tool> [args]", "", "tools:"]
    for name in TOOLS:
        lines.append(f"  {name:<{width}}  {SUMMARIES[name]}")
    lines.append("")
    lines.append("`sail-ros <tool> --help` describes a tool. " + PHYSICS_DOC)
    return "\n".join(lines)


def main(argv=None):
    """`sail-ros <tool> [args]`; returns the exit code."""
    keep_early_sigint()
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage())
        return 0
    name, rest = argv[0], argv[1:]
    if name not in TOOLS:
        close = nearest(name, TOOLS)
        hint = f" (did you mean {close!r}?)" if close else ""
        print(
            f"sail-ros: unknown tool {name!r}{hint}; tools: {', '.join(TOOLS)}",
            file=sys.stderr,
        )
        return 2
    return _run_tool(name, rest, f"sail-ros {name}")


def _run_tool(name: str, args: list[str], prog: str) -> int:
    module_name, function_name = TOOLS[name].split(":")
    try:
        tool_main = getattr(importlib.import_module(module_name), function_name)
        sys.argv = [prog, *args]
        return tool_main(args)
    except KeyboardInterrupt:
        # Ctrl-C before a node took SIGINT over (its second of imports), or in an offline
        # tool: the shell's exit code for it, without a traceback
        return INTERRUPTED


def _entry_point(name: str):
    def entry() -> int:
        keep_early_sigint()
        return _run_tool(name, sys.argv[1:], sys.argv[0])

    entry.__name__ = entry.__qualname__ = f"main_{name}"
    entry.__doc__ = f"The executable `{name}` (`ros2 run sail_ros {name}`)."
    return entry


# the console scripts of setup.py: `<tool> = sail_ros.cli:main_<tool>`
for _name in TOOLS:
    globals()[f"main_{_name}"] = _entry_point(_name)


if __name__ == "__main__":
    sys.exit(main())
