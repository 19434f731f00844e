"""`sail-ros watch`: the running simulator at a glance, refreshed in place.

Boom lengths and rates, tip deflections, state, simulation time, real-time
factor, mechanical energy, a free hub's heave and tilt, the commands by outcome
(accepted, superseded, rejected, ignored), the last command, rejection and
answer, from the simulator's topics. `--once` prints
one sample and exits; `--json` prints JSON (one object per refresh, one line
each) for scripts. Ctrl-C stops.
"""

from __future__ import annotations

import json
import math
import sys
import time

from sail_ros import status as key
from sail_ros import topics
from sail_ros.messages import state as state_msg
from sail_ros.model import record
from sail_ros.model.record import HUB_COMPONENTS
from sail_ros.options import ToolParser, paragraphs
from sail_ros.ros.sim_client import WATCHED_STATE
from sail_ros.tools.client import SimClient, add_domain_option, run_client

CLEAR = "\033[H\033[2J"  # cursor home, clear screen


EXAMPLES = (
    "sail-ros watch",
    "sail-ros watch --once --timeout 30",
    "sail-ros watch --once --json",
    "sail-ros watch --json --rate 1 | head -5",
    "sail-ros watch --ros-args -r __ns:=/sat2",
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("watch", paragraphs(__doc__, 0, 1), EXAMPLES)
    parser.add_argument("--once", action="store_true", help="print one sample and exit")
    parser.add_argument("--json", action="store_true", help="JSON instead of a table")
    parser.add_argument("--rate", type=float, default=4.0, help="refreshes per second [Hz] (4)")
    parser.add_argument(
        "--timeout", type=float, default=10.0, help="seconds to wait for the simulator (10)"
    )
    add_domain_option(parser)
    return parser


# Diagnostics come at least once a second of wall time: a state this much simulation
# time (per unit of time scale) after them belongs to another run
STAMPS_APART_S = 10.0


def snapshot(client: SimClient) -> dict:
    """What the client last heard, as plain data (SI units)."""
    status = client.latest["diagnostics"]
    values = {pair.key: pair.value for pair in status.values}
    answer = client.latest.get("answer")
    t = float(values.get(key.SIM_TIME, "nan"))
    state = client.latest.get(topics.BOOM_STATE)
    if state is not None:  # the state's time: the diagnostics' moved on by the stamps
        ahead = 1e-9 * (
            topics.stamp_ns_of(state.header.stamp) - client.latest["diagnostics_stamp_ns"]
        )
        scale = float(values.get(key.TIME_SCALE, "1"))
        # one run's stamps share an epoch; a restarted simulator's state before its first
        # diagnostics does not: then the diagnostics' own time
        if 0.0 <= ahead <= (STAMPS_APART_S * max(1.0, scale) if scale > 0 else math.inf):
            t += ahead
    return {
        "simulator": client.sim_name,
        "level": ("OK", "WARN", "ERROR", "STALE")[min(int.from_bytes(status.level), 3)],
        "message": status.message,
        key.STATE: values.get(key.STATE, ""),
        key.SIM_TIME: round(t, 9),
        key.REAL_TIME_FACTOR: float(values.get(key.REAL_TIME_FACTOR, "nan")),
        key.ENERGY: float(values.get(key.ENERGY, "nan")),
        # the record's per-boom fields and a free hub's, as the record names them
        **record.view(state_msg.sample(client.latest)),
        key.LOAD_POWER: float(values.get(key.LOAD_POWER, "nan")),
        key.DISSIPATION: float(values.get(key.DISSIPATION, "nan")),
        key.ACCEPTED: int(values.get(key.ACCEPTED, "0")),
        key.SUPERSEDED: int(values.get(key.SUPERSEDED, "0")),
        key.REJECTED: int(values.get(key.REJECTED, "0")),
        key.IGNORED: int(values.get(key.IGNORED, "0")),
        key.LAST_COMMAND: values.get(key.LAST_COMMAND, ""),
        key.LAST_REJECTION: values.get(key.LAST_REJECTION, ""),
        "last_answer": f"{answer.outcome}: {answer.message}" if answer else "",
    }


def table(view: dict) -> str:
    """The snapshot as a few lines of text."""

    def row(label, values, scale=1.0, digits=3):
        return f"  {label:<22}" + "".join(f"{scale * values[b]:>12.{digits}f}" for b in "abcd")

    hub = []
    if "hub" in view:
        z, theta_x, theta_y = (view["hub"][name] for name in HUB_COMPONENTS[:3])
        hub.append(
            f"  free hub: heave z_h {1e3 * z:.3f} mm, tilt theta_x {1e3 * theta_x:.3f} mrad, "
            f"theta_y {1e3 * theta_y:.3f} mrad, |theta| {1e3 * math.hypot(theta_x, theta_y):.3f}"
            " mrad"
        )
    return "\n".join(
        [
            f"{view['simulator']}  {view[key.STATE]}  t = {view[key.SIM_TIME]:.2f} s  "
            f"real-time factor {view[key.REAL_TIME_FACTOR]:.3g}  "
            f"E = {view[key.ENERGY]:.4g} J",
            f"  {view['level']}: {view['message']}",
            f"  {'':<22}" + "".join(f"{'boom ' + b:>12}" for b in "abcd"),
            row("length [m]", view["boom_length_m"]),
            row("rate [m/s]", view["boom_rate_m_s"], digits=4),
            row("tip deflection [mm]", view["tip_deflection_m"], scale=1e3),
            row("root moment [N m]", view["root_moment_N_m"], digits=4),
            *hub,
            f"  load power {view[key.LOAD_POWER]:.4g} W, damping dissipation "
            f"{view[key.DISSIPATION]:.4g} W",
            f"  commands: {view[key.ACCEPTED]} accepted, {view[key.SUPERSEDED]} superseded "
            f"(a newer one came before they started), {view[key.REJECTED]} rejected, "
            f"{view[key.IGNORED]} ignored",
            f"  last command: {view[key.LAST_COMMAND] or '-'}",
            f"  last rejection: {view[key.LAST_REJECTION] or '-'}",
            f"  last answer: {view['last_answer'] or '-'}",
        ]
    )


def check(args) -> str | None:
    for name in ("rate", "timeout"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            return f"--{name} must be > 0, got {value:g}"
    return None


def run(args, client: SimClient) -> int:
    wanted = (*WATCHED_STATE, "diagnostics")
    client.spin_until(
        lambda: all(name in client.latest for name in wanted),
        args.timeout,
        f"state and diagnostics from {client.sim_name} (is `sail-ros sim` running in this "
        "namespace and domain?)",
    )
    client.settle()  # the newest of the kept samples, not the first to arrive
    client.settle_answers(args.timeout)
    try:
        while True:
            view = snapshot(client)
            text = json.dumps(view) if args.json else table(view)
            if args.once:
                print(text)
                return 0
            print(text if args.json else CLEAR + text, flush=True)
            deadline = time.monotonic() + 1.0 / args.rate
            while time.monotonic() < deadline:
                client.executor_.spin_once(timeout_sec=max(0.0, deadline - time.monotonic()))
    except KeyboardInterrupt:  # the way to stop watching
        return 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    return run_client("sail-ros watch", parser, argv, "sail_watch", run, check, watch=True)


if __name__ == "__main__":
    sys.exit(main())
