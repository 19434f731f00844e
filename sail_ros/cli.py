"""The umbrella command `sail-ros <tool> [args]`.

Each tool is also its own executable under `lib/sail_ros` (what `ros2 run
sail_ros <tool>` starts); both routes call the same `main`. This module
imports nothing heavy so that `setup.py` can read `TOOLS`.
"""

import importlib
import sys

PHYSICS_DOC = (
    "The physics, its choices and checks: docs/model.md (installed as "
    "share/sail_ros/docs/model.md)."
)

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
    "sim": "sail_ros.nodes.sim:main",
    "send": "sail_ros.tools.send:main",
    "watch": "sail_ros.tools.watch:main",
    "demo": "sail_ros.tools.main_job:main",
}


def _usage():
    width = max(len(name) for name in TOOLS)
    lines = ["usage: sail-ros <tool> [args]", "", "tools:"]
    for name, target in TOOLS.items():
        lines.append(f"  {name:<{width}}  ({target.split(':')[0]})")
    lines.append("")
    lines.append("`sail-ros <tool> --help` describes a tool. " + PHYSICS_DOC)
    return "\n".join(lines)


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage())
        return 0
    name, rest = argv[0], argv[1:]
    if name not in TOOLS:
        print(f"sail-ros: unknown tool {name!r}\n\n{_usage()}", file=sys.stderr)
        return 2
    module_name, function_name = TOOLS[name].split(":")
    tool_main = getattr(importlib.import_module(module_name), function_name)
    sys.argv = [f"sail-ros {name}", *rest]
    return tool_main(rest)


if __name__ == "__main__":
    sys.exit(main())
