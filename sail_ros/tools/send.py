"""`sail-ros send`: one command to the running simulator, and what it made of it.

Waits until the simulator listens, sends the command, waits for its answer
and prints it: the plan of an accepted command, the reason of a rejected one.
Exit code 0 only when the command was accepted; 1 when it was rejected or no
simulator answered within --timeout; 2 for a bad command line.
"""

from __future__ import annotations

import math
import sys

from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory

from sail_ros import topics
from sail_ros.messages import commands as commands_msg
from sail_ros.messages import hub as hub_msg
from sail_ros.options import ToolParser, paragraphs
from sail_ros.policy import Policy
from sail_ros.ros.sim_client import NoAnswerError, SimClient
from sail_ros.tools.client import add_domain_option, run_client

BOOMS = "abcd"
QUADRANTS = ("ab", "bc", "cd", "da")
ALL = "all"
EXAMPLES = (
    "sail-ros send deploy 30",
    "sail-ros send move --booms a c --point 20 20 25",
    "sail-ros send move --booms b --point 10 12 --point 30 20",
    "sail-ros send pressure --quadrants ab cd --values 2e-3 1e-3",
    "sail-ros send pressure --quadrants all --values 9.1e-6",
    "sail-ros send tip-force --booms b --values -0.05",
    "sail-ros send tip-force --booms all --values 0",
    "sail-ros send hub-wrench --force 0.2 --torque-x 0.05",
    "sail-ros send hub-wrench",
    "sail-ros send pause",
    "sail-ros send resume",
    "sail-ros send reset",
    "sail-ros send --domain-id 7 --timeout 30 deploy 15 --ros-args -r __ns:=/sat2",
)
NOTES = """The simulator is the one in this program's namespace (--ros-args -r __ns:=...)
and DDS domain (--domain-id, else ROS_DOMAIN_ID). Limits on lengths, rates,
accelerations and loads are the simulator's parameters (msg_docs/boom_length_cmd.md).
--values takes one value per name given, or one value for `all`. hub-wrench needs a
simulator with a free hub (sail.free_hub true); the components it does not name are 0."""


def load_command(args) -> tuple[str, object]:
    """`(topic, message)` of a `pressure` or `tip-force` command line: one value per
    name, or one for `all` (ValueError otherwise, or for a value that is not finite)."""
    if args.command == "pressure":
        topic, option, given, known = topics.PRESSURE_CMD, "--quadrants", args.quadrants, QUADRANTS
        prefix = "quadrant_"
    else:
        topic, option, given, known = topics.TIP_FORCE_CMD, "--booms", args.booms, tuple(BOOMS)
        prefix = "boom_"
    values = args.values
    if ALL in given:
        if len(given) > 1:
            raise ValueError(f"{option}: `all` stands alone, got {' '.join(given)}")
        if len(values) != 1:
            raise ValueError(f"--values: one value with {option} all, got {len(values)}")
        given, values = known, values * len(known)
    if len(values) != len(given):
        raise ValueError(
            f"--values: one per name of {option} ({len(given)}: {' '.join(given)}), or one "
            f"with {option} all; got {len(values)}"
        )
    names = [prefix + name for name in given]
    for name, value in zip(names, values, strict=True):
        Policy.finite_load(name, value, args.command == "pressure")
    return topic, commands_msg.load_command(topic, dict(zip(names, values, strict=True)))


# each command: its line in the list of commands, and its own --help's description
COMMANDS = {
    "deploy": (
        "all booms to one length [m] (sail/deploy_cmd)",
        "All booms to LENGTH metres, the fastest smooth motion within the simulator's limits.",
    ),
    "move": (
        "named booms through waypoints (sail/boom_length_cmd)",
        "The named booms through waypoints, from their current length and rate; the others "
        "carry on. Each --point is a time from now [s] followed by one length [m] per named "
        "boom.",
    ),
    "pressure": (
        "uniform pressure [Pa] on named quadrants (sail/pressure_cmd)",
        "Set the pressure [Pa, +z] on the named quadrants from the next step on; the others "
        "keep theirs. Limit: the simulator's max_pressure.",
    ),
    "tip-force": (
        "force [N] at the tips of named booms (sail/tip_force_cmd)",
        "Set the force [N, +z] at the tips of the named booms from the next step on; the "
        "others keep theirs. Limit: the simulator's max_tip_force.",
    ),
    "hub-wrench": (
        "force [N] and torques [N m] on a free hub (sail/hub_wrench_cmd)",
        "Set the force along z [N] and the torques about x and y [N m] on the free hub from "
        "the next step on; those not given are 0 (no options: no wrench). Limits: the "
        "simulator's max_hub_force and max_hub_torque.",
    ),
    "pause": ("hold the simulation (sail/pause, true)", None),
    "resume": ("go on (sail/pause, false)", None),
    "reset": ("back to the initial state (sail/reset)", None),
}
HUB_WRENCH_OPTIONS = (("--force", "N"), ("--torque-x", "N m"), ("--torque-y", "N m"))


def hub_wrench(args):
    """The `sail/hub_wrench_cmd` of a `hub-wrench` command line (ValueError naming an
    option whose value is not finite; the limits are the simulator's to check)."""
    values = (args.force, args.torque_x, args.torque_y)
    for (option, unit), value in zip(HUB_WRENCH_OPTIONS, values, strict=True):
        if not math.isfinite(value):
            raise ValueError(f"{option} = {value} {unit} is not finite")
    return hub_msg.hub_wrench_command(*values)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("send", paragraphs(__doc__, 0, 1), EXAMPLES, notes=NOTES)
    parser.add_argument(
        "--timeout", type=float, default=10.0, help="seconds to wait for the simulator (10)"
    )
    add_domain_option(parser)
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    made = {
        name: commands.add_parser(name, help=line, description=description)
        for name, (line, description) in COMMANDS.items()
    }
    made["deploy"].add_argument("length", type=float, metavar="LENGTH", help="target length [m]")
    made["move"].add_argument(
        "--booms", nargs="+", required=True, choices=list(BOOMS), help="booms to move (a b c d)"
    )
    made["move"].add_argument(
        "--point", nargs="+", type=float, action="append", required=True, metavar="VALUE",
        help="TIME LENGTH [LENGTH ...]: when [s from now] and where [m] (repeatable)",
    )  # fmt: skip
    made["pressure"].add_argument(
        "--quadrants", nargs="+", required=True, choices=[*QUADRANTS, ALL],
        help="ab bc cd da, or all",
    )  # fmt: skip
    made["tip-force"].add_argument(
        "--booms", nargs="+", required=True, choices=[*BOOMS, ALL], help="a b c d, or all"
    )
    for name, unit, each in (("pressure", "Pa", "quadrant"), ("tip-force", "N", "boom")):
        made[name].add_argument(
            "--values", nargs="+", type=float, required=True,
            help=f"{unit}: one per {each}, or one for all",
        )  # fmt: skip
    axes = ("force along +z", "torque about x (boom a)", "torque about y (boom b)")
    for (option, unit), what in zip(HUB_WRENCH_OPTIONS, axes, strict=True):
        made["hub-wrench"].add_argument(
            option, type=float, default=0.0, metavar=unit.replace(" ", ""),
            help=f"{what} [{unit}] (0)",
        )  # fmt: skip
    for name, command in commands.choices.items():  # each command's own examples
        own = [line for line in EXAMPLES if line.split()[:3] == ["sail-ros", "send", name]]
        command.epilog = "Examples:\n" + "\n".join(f"  {line}" for line in own)
    return parser


def trajectory(booms: list[str], points: list[list[float]]) -> JointTrajectory:
    """The `sail/boom_length_cmd` of `booms` ("a" ...) through `points` ([time, lengths...]),
    checked as a command line (ValueError naming the point)."""
    for point in points:
        seconds, *lengths = point
        if len(lengths) != len(booms):
            raise ValueError(
                f"--point {' '.join(f'{v:g}' for v in point)}: needs a time and {len(booms)} "
                f"length(s), one per boom of --booms {' '.join(booms)}"
            )
        if not (math.isfinite(seconds) and seconds > 0):
            raise ValueError(f"--point: the time must be > 0 s from now, got {seconds:g}")
        for boom, length in zip(booms, lengths, strict=True):
            if not math.isfinite(length):  # the simulator's words (Policy.check_length)
                raise ValueError(f"--point: boom_{boom} is {length!r}, not a finite length")
    return commands_msg.boom_length_command(booms, points)


def run(args, client: SimClient) -> int:
    if args.command in ("deploy", "move"):
        if args.command == "deploy":
            name, message = topics.DEPLOY_CMD, Float64(data=args.length)
        else:
            name, message = topics.BOOM_LENGTH_CMD, trajectory(args.booms, args.point)
        answer = client.send(name, message, args.timeout)
        print(f"{answer.outcome}: {answer.message}")
        if answer.outcome == commands_msg.ACCEPTED:
            start, end = (float(answer.values[k]) for k in ("t_start_s", "t_end_s"))
            print(f"  from t = {start:.3f} s to {end:.3f} s (simulation time)")
        return 0 if answer.outcome == commands_msg.ACCEPTED else 1
    if args.command in ("pressure", "tip-force", "hub-wrench"):
        if args.command == "hub-wrench":
            try:
                answer = client.send(topics.HUB_WRENCH_CMD, hub_wrench(args), args.timeout)
            except NoAnswerError as error:
                raise NoAnswerError(
                    f"{error}; only a simulator with a free hub (sail.free_hub true) listens"
                ) from None
        else:
            answer = client.send(*load_command(args), args.timeout)
        print(f"{answer.outcome}: {answer.message}")
        return 0 if answer.outcome == commands_msg.ACCEPTED else 1
    if args.command == "reset":
        response = client.call(topics.RESET_SERVICE, Trigger.Request(), args.timeout)
    else:
        request = SetBool.Request(data=args.command == "pause")
        response = client.call(topics.PAUSE_SERVICE, request, args.timeout)
    print(response.message)
    return 0 if response.success else 1


def check(args) -> str | None:
    """Why the command line cannot be sent (None if it can)."""
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        return f"--timeout must be > 0 s, got {args.timeout:g}"
    try:  # a bad point or value count is a usage error, before ROS
        if args.command == "move":
            trajectory(args.booms, args.point)
        if args.command in ("pressure", "tip-force"):
            load_command(args)
        if args.command == "hub-wrench":
            hub_wrench(args)
    except ValueError as error:
        return str(error)
    return None


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    return run_client("sail-ros send", build_parser(), argv, "sail_send", run, check)


if __name__ == "__main__":
    sys.exit(main())
