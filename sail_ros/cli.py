"""The umbrella command `sail-ros <tool> [args]` and every tool's executable.

Each tool is also its own executable under `lib/sail_ros` (what `ros2 run
sail_ros <tool>` starts, `main_<tool>` here); both routes call the tool's same
`main`. This module imports nothing but `early_signals` at its top, so that
`setup.py` can read `TOOLS` and so that a SIGINT in a program's first tens of
milliseconds meets the entry point's guard (exit 130, no traceback) rather than an
import, and an entry point keeps an early SIGINT (`early_signals`) before the tool's
imports take their second.

How every program reads its command line is in `sail_ros.options`.
"""

import importlib
import sys

from sail_ros.early_signals import keep_early_sigint

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


def _usage():
    from sail_ros.options import PHYSICS_DOC

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
    try:
        argv = list(sys.argv[1:] if argv is None else argv)
        if not argv or argv[0] in ("-h", "--help"):
            print(_usage())
            return 0
        name, rest = argv[0], argv[1:]
        if name not in TOOLS:
            from sail_ros.spelling import did_you_mean

            hint = did_you_mean(name, TOOLS)
            print(
                f"sail-ros: unknown tool {name!r}{hint}; tools: {', '.join(TOOLS)}",
                file=sys.stderr,
            )
            return 2
        return _run_tool(name, rest, f"sail-ros {name}")
    except KeyboardInterrupt:
        return INTERRUPTED


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
