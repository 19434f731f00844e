"""The command line of a client of a running simulator (`sail-ros send`, `sail-ros
watch`): its DDS domain, its checks, and the exit codes around a `SimClient`
(`sail_ros.ros.sim_client`, the node)."""

from __future__ import annotations

import os
import signal
import sys

from sail_ros.ros.program import bounded_teardown, parse_command_line
from sail_ros.ros.sim_client import NoAnswerError, SimClient, init_context
from sail_ros.tools.common import stdout_closed
from sail_ros.tools.domains import LAST_DOMAIN


def add_domain_option(parser) -> None:
    parser.add_argument(
        "--domain-id",
        type=int,
        help=f"DDS domain of the simulator, 0 to {LAST_DOMAIN} (default: ROS_DOMAIN_ID, else 0)",
    )


def check_domain(domain_id: int | None) -> None:
    """The domain of --domain-id, else of ROS_DOMAIN_ID, must be one Fast DDS has ports
    for (0 to LAST_DOMAIN); ValueError naming it (rclpy would raise, or Fast DDS print
    raw errors and go on)."""
    if domain_id is None:
        text = os.environ.get("ROS_DOMAIN_ID", "").strip()
        if not text:
            return
        name, value = f"ROS_DOMAIN_ID={text!r}", int(text) if text.isdigit() else None
    else:
        name, value = f"--domain-id {domain_id}", domain_id
    if value is None or not 0 <= value <= LAST_DOMAIN:
        raise ValueError(
            f"{name}: a DDS domain must be an integer in [0, {LAST_DOMAIN}] (the domains Fast "
            "DDS has ports for)"
        )


def run_client(prog: str, parser, argv, name: str, body, check=None, watch: bool = False) -> int:
    """A client tool's `main`: parse `argv` (options, then `--ros-args ...`), check them
    (`check(args)` returns an error text or None: exit 2), run `body(args, client)` with a
    `SimClient` in the namespace and domain asked for, and turn a missing answer into
    one line and exit 1. Returns the exit code."""
    try:
        args, ros_argv = parse_command_line(parser, prog, argv)
    except SystemExit as exit_:
        return exit_.code if isinstance(exit_.code, int) else 2
    try:
        check_domain(args.domain_id)
        problem = check(args) if check is not None else None
    except ValueError as error:
        problem = str(error)
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    context = init_context(ros_argv, args.domain_id)
    client = SimClient(context, name, watch=watch)
    interrupted = False
    try:
        return body(args, client)
    except NoAnswerError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        interrupted = True
        return 130
    except BrokenPipeError:
        if stdout_closed():  # `sail-ros watch --json | head`: end as Unix tools do
            return 128 + signal.SIGPIPE
        raise
    finally:
        client.close(deliver=not interrupted)
        with bounded_teardown():
            context.try_shutdown()
