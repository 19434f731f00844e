"""`sail-ros demo`: the reference deployment live, recorded, and read back.

Starts the simulator (`sail-ros sim`) and the recorder (`sail-ros recorder`)
as separate processes, runs the seed paper's deployment (model.md §9: all
booms 10 m -> 15 m in 15 s along the cycloidal profile, boom a starting bent
in its first mode with a 0.1 m tip deflection) through /sail/deploy_cmd,
stops both with SIGINT once the booms have been at rest for a second, and
summarises the MCAP log: messages per topic, duration, the tip deflections
at 5, 10 and 15 s next to the same run computed offline, and the achieved
real-time factor.

To start the deployment exactly from the initial state, the simulator is
paused, reset, given the command and resumed: t = 0 of the scenario is the
simulation time of that reset.
"""

from __future__ import annotations

import datetime
import os
import signal
import subprocess
import sys
from pathlib import Path

from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from sail_ros import status as key
from sail_ros import topics
from sail_ros.analysis.demo_run import DURATION, END, SETTLE_S, START, TIP, summarise
from sail_ros.messages import commands as commands_msg
from sail_ros.options import ToolParser
from sail_ros.ros.program import bounded_teardown
from sail_ros.ros.sim_client import NoAnswerError, SimClient, init_context
from sail_ros.tools.common import tool_main
from sail_ros.tools.domains import DomainLease

START_TIMEOUT_S = 60.0  # wall time for the processes to come up


class ProcessExitedError(RuntimeError):
    """A process of the run ended before the run did."""


def exited(processes):
    """A check for `SimClient.spin_until`: raise if one of `processes` has exited."""

    def check() -> None:
        for name, process in processes:
            if process.poll() is not None:
                raise ProcessExitedError(f"the {name} exited with code {process.returncode}")

    return check


EXAMPLES = (
    "sail-ros demo",
    "sail-ros demo --time-scale 1 -o out/demo_realtime",
)
NOTES = """By default the simulation runs at 2x real time (about 8 s for the 16 s run),
publishing /clock; --time-scale 1 runs it in real time. At 2x a grid step (0.01 s of
simulation) is 5 ms of wall time, and a moving step of the model (one for many grid
steps while the booms deploy, about 40 ms at the simulator's mode counts on a 2-core
machine) takes longer: the tick that computes it comes late and counts as an overrun,
about one for each of the deployment's 35 or so moving steps. The run uses
a DDS domain that nothing else on this machine uses (two demos at once stay apart);
discovery stays on this machine unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."""
WRITES = (
    "the recorder's bag folder (-o, default out/demo_<UTC time>: <name>_0.mcap, "
    "metadata.yaml) and the two processes' logs beside it, <name>.sim.log and "
    "<name>.recorder.log."
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("demo", __doc__.split("\n\n")[0], EXAMPLES, WRITES, NOTES)
    parser.add_argument(
        "-o", "--output", type=Path, help="bag folder to create (default: out/demo_<UTC time>)"
    )
    parser.add_argument(
        "--time-scale",
        type=float,
        default=2.0,
        help="simulation seconds per wall second (default 2.0)",
    )
    return parser


def _demo(args) -> int:
    if not args.time_scale > 0:
        raise ValueError("--time-scale must be > 0")
    output = args.output or Path("out") / (
        "demo_" + datetime.datetime.now(datetime.UTC).strftime("%Y_%m_%d-%H_%M_%S")
    )
    if output.exists():
        raise ValueError(f"{output} exists; give a new --output")
    output.parent.mkdir(parents=True, exist_ok=True)
    lease = DomainLease()
    domain = lease.__enter__()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    parameters = {
        "initial_lengths": f"[{START}]",
        "initial_tip_deflection": f"[{TIP},0.0,0.0,0.0]",
        "deploy_duration": str(DURATION),
        "time_scale": str(args.time_scale),
        "diagnostics_rate_hz": "10.0",
    }
    sim_command = [sys.executable, "-m", "sail_ros.cli", "sim", "--ros-args"] + [
        item for name, value in parameters.items() for item in ("-p", f"{name}:={value}")
    ]
    logs = output.parent / f"{output.name}.sim.log", output.parent / f"{output.name}.recorder.log"
    print(
        f"starting the simulator and the recorder in DDS domain {domain}, a domain of this "
        f"run alone (logs: {logs[0]}, {logs[1]})",
        flush=True,
    )
    with open(logs[0], "w") as sim_log, open(logs[1], "w") as recorder_log:
        sim = subprocess.Popen(sim_command, stdout=sim_log, stderr=subprocess.STDOUT, env=env)
        recorder = subprocess.Popen(
            [sys.executable, "-m", "sail_ros.cli", "recorder", "-o", str(output)],
            stdout=recorder_log,
            stderr=subprocess.STDOUT,
            env=env,
        )
    processes = [("simulator", sim), ("recorder", recorder)]
    try:
        t_start = _run(processes, args.time_scale, domain, lease)
    except (RuntimeError, NoAnswerError) as error:
        print(f"error: {error}; see {logs[0]} and {logs[1]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # the children got the SIGINT too and finish their files
        print(f"interrupted; the recording so far is in {output}", file=sys.stderr)
        return 130
    finally:
        lease.__exit__()
        codes = {}
        for name, process in processes:  # the simulator first: the recorder takes its last
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
            try:
                codes[name] = process.wait(30)
            except subprocess.TimeoutExpired:
                process.kill()
                codes[name] = process.wait()
    if any(codes.values()):
        print(f"error: exit codes {codes}; see {logs[0]} and {logs[1]}", file=sys.stderr)
        return 1
    print("simulator and recorder stopped cleanly (exit code 0)\n")
    print(summarise(output, t_start).text())
    return 0


def _run(processes, time_scale: float, domain: int, lease: DomainLease) -> float:
    """Drive the deployment; returns its start (simulation time [s])."""
    context = init_context([], domain)
    client = SimClient(context, "sail_demo", watch=True)
    check = exited(processes)

    def sim_time() -> float:
        return float(client.latest.get("diagnostics_values", {}).get(key.SIM_TIME, "nan"))

    try:
        client.spin_until(
            # the recorder subscribes to the state, besides this client
            lambda: (
                "diagnostics" in client.latest and client.count_subscribers(topics.BOOM_STATE) >= 2
            ),
            START_TIMEOUT_S,
            "simulator and recorder",
            check,
        )
        lease.__exit__()  # both joined the domain: another run may now pick its own
        client.call(topics.PAUSE_SERVICE, SetBool.Request(data=True), 10.0)
        client.call(topics.RESET_SERVICE, Trigger.Request(), 10.0)
        answer = client.send(topics.DEPLOY_CMD, Float64(data=END), 10.0)
        if answer.outcome != commands_msg.ACCEPTED:
            raise RuntimeError(f"the deployment was {answer.outcome}: {answer.message}")
        t_start = float(answer.values["t_start_s"])
        client.call(topics.PAUSE_SERVICE, SetBool.Request(data=False), 10.0)
        print(
            f"deploying 10 m -> 15 m in 15 s from t = {t_start:.2f} s (simulation time), "
            f"{time_scale:g}x real time",
            flush=True,
        )
        done = t_start + DURATION + SETTLE_S
        client.spin_until(
            lambda: sim_time() >= done,
            (DURATION + SETTLE_S) / time_scale + 30.0,
            "end of the deployment",
            check,
        )
        return t_start
    finally:
        client.close()
        with bounded_teardown():
            context.try_shutdown()


main = tool_main(build_parser, _demo)
