"""`sail-ros deploy`: an offline deployment run (model.md §9 reference by default).

By default all booms extend along the cycloidal profile from `--from` to
`--to` metres in `--duration` seconds and boom `--boom` starts bent in its
first mode with tip deflection `--tip`; `--scenario FILE` runs any scenario
instead (per-boom cycloidal or waypoint profiles, any initial state, loads;
docs/scenarios.md). Prints the boom-tip deflections against time and the true
peaks of each boom's tip deflection and root moment with their times (taken
inside every integration step, not from the printed times); a free hub's
heave, tilts and their rates beside them, its true peaks and the peak
reactions of its in-plane and spin holds; a scenario with a `controller:`
section closes the loop with the hub's controller (docs/control.md) and says
how it compares with the open loop; `--convergence`
reruns with more modes and says how far each peak moves; `--json` prints it
all as one JSON object. Writes an MCAP log with the live simulator's topics
(`--mcap`) and figures (`--figures`).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import json
import sys
from pathlib import Path

from tqdm import tqdm

from sail_ros.analysis.convergence import BAR
from sail_ros.analysis.deploy_study import DeployRequest, study
from sail_ros.analysis.reference import OPTIONS, reference_scenario
from sail_ros.analysis.scenario import load_scenario
from sail_ros.integrate.control import (
    ATOL_UNITS,
    DEFAULT_ATOL,
    DEFAULT_MAX_STEP,
    DEFAULT_RTOL,
    OUTPUT_KINDS,
    atol_floors,
)
from sail_ros.options import ToolParser
from sail_ros.plots.deploy_figures import CLOSED_LOOP_FIGURE, FIGURES, HUB_FIGURE, deploy_figures
from sail_ros.tools.common import add_sail_options, configuration, print_written, tool_main
from sail_ros.tools.deploy_result import DeploymentReport

EXAMPLES = (
    "sail-ros deploy --summary",
    "sail-ros deploy --convergence",
    "sail-ros deploy --json --convergence 10 10",
    "sail-ros deploy --to 30 --duration 60 --figures out/deploy_30m",
    "sail-ros deploy --scenario config/scenario_staggered.yaml --mcap out/staggered.mcap "
    "--figures out/staggered",
    "sail-ros deploy --scenario config/scenario_loaded.yaml --set max_tip_force=0.5",
    "sail-ros deploy --scenario config/scenario_free_hub.yaml --summary --figures out/free_hub",
    "sail-ros deploy --scenario config/scenario_free_hub_control.yaml --figures out/control",
)
NOTES = """The limits are the simulator's (min_length, max_length, max_rate, max_acceleration,
max_pressure, max_tip_force, tip_error_fraction; --set NAME=VALUE changes them): a
scenario outside them is refused with exit code 2 and nothing written. A run whose tip
deflection passes tip_error_fraction of its boom's length stops there with the
simulator's alarm, writes what it computed up to there and exits with 1."""
WRITES = (
    "--mcap FILE: a .mcap file, or a bag folder FILE/ with FILE_0.mcap and metadata.yaml; "
    f"--figures DIR: {', '.join('DIR/' + name for name in FIGURES)} (and DIR/{HUB_FIGURE} "
    f"with a free hub, DIR/{CLOSED_LOOP_FIGURE} with a controller). Each output is "
    "written whole or not at all (built under a temporary name)."
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("deploy", __doc__.split("\n\n")[1], EXAMPLES, WRITES, NOTES)
    add_sail_options(parser)
    parser.add_argument(
        "--scenario",
        type=Path,
        metavar="YAML",
        help="scenario file (profiles per boom, initial state, loads, snapshot times; "
        "docs/scenarios.md); its `sail:` section overrides --config, --set overrides both",
    )
    scenario = parser.add_argument_group(
        "reference scenario (docs/model.md §9), without --scenario"
    )
    scenario.add_argument(
        "--from", dest="start", type=float, help="initial boom length L0 [m] (10)"
    )
    scenario.add_argument("--to", dest="end", type=float, help="final boom length Lf [m] (15)")
    scenario.add_argument("--duration", type=float, help="deployment time T [s] (15)")
    scenario.add_argument("--t-end", type=float, help="simulated time [s] (default: T)")
    scenario.add_argument("--boom", choices="abcd", help="boom bent at t = 0 (a)")
    scenario.add_argument("--tip", type=float, help="its tip deflection [m] (0.1)")
    parser.add_argument(
        "--every", type=float, default=1.0, help="output interval for the table [s] (1)"
    )
    parser.add_argument(
        "--max-step", type=float, default=DEFAULT_MAX_STEP,
        help=f"largest integration step [s]; the tolerance chooses the steps below it "
        f"({DEFAULT_MAX_STEP:g})",
    )  # fmt: skip
    parser.add_argument(
        "--rtol", type=float, default=DEFAULT_RTOL,
        help=f"local error allowed per step on tips, root moments and their rates, relative "
        f"to each one's peak so far ({DEFAULT_RTOL:g}: whole runs within 0.2 %% of peak); "
        "0: fixed steps of --max-step",
    )  # fmt: skip
    floors = ", ".join(
        f"{kind}={value:g} {ATOL_UNITS[kind]}" for kind, value in DEFAULT_ATOL.items()
    )
    parser.add_argument(
        "--atol", type=_atol_entry, nargs="+", default=[], metavar="OUTPUT=FLOOR",
        help=f"absolute floors of that error, in the outputs' units ({floors}): where a "
        "floor is above rtol times its output's peak it sets the steps (the accuracy "
        "warning says so), and a smaller one tightens the run",
    )  # fmt: skip
    parser.add_argument(
        "--summary",
        action="store_true",
        help="print the table even when writing --mcap or --figures "
        "(it is printed anyway without them)",
    )
    parser.add_argument(
        "--convergence",
        type=int,
        nargs="*",
        metavar=("N_B", "N_M"),
        help="rerun on finer models (each: 4 more boom modes, membrane modes up to 1.25 "
        "times the band of the one before; or the counts given) until two agree within "
        f"{100 * BAR:g} %% of the largest peak of each kind (at most 3 reruns), and give "
        "each peak's change against the finest; a warning when one is off by more",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object (peaks per boom with times, a free hub's peaks and "
        "hold reactions, parameters, limits, mode counts, wall time, convergence) instead "
        "of the table",
    )
    output = parser.add_argument_group("output")
    output.add_argument(
        "--rate",
        type=float,
        default=50.0,
        help="state samples per simulated second in the log and the time "
        "histories [Hz] (50, as the simulator's state_rate_hz); the "
        "integration steps to each sample",
    )
    output.add_argument(
        "--mcap",
        type=Path,
        metavar="FILE",
        help="write the run as a ROS 2 MCAP log with the simulator's topics "
        "(a .mcap file, replaced if present, or a new bag folder)",
    )
    output.add_argument(
        "--shape-rate",
        type=float,
        default=5.0,
        help="/sail/shape messages per simulated second in the log [Hz] (5; 0: none)",
    )
    output.add_argument(
        "--shape-divisions",
        type=int,
        default=10,
        help="mesh subdivisions of each quadrant edge in /sail/shape (10)",
    )
    output.add_argument(
        "--figures",
        type=Path,
        metavar="DIR",
        help=f"write {', '.join('DIR/' + name for name in FIGURES)} (and DIR/{HUB_FIGURE} "
        f"with a free hub: its tilt, heave and hold reactions; DIR/{CLOSED_LOOP_FIGURE} with a "
        "controller: the open and the closed loop and the commands)",
    )
    output.add_argument(
        "--snapshots",
        type=float,
        nargs="+",
        metavar="T",
        help="snapshot times [s] (default: the scenario's)",
    )
    return parser


def _atol_entry(text: str) -> tuple[str, float]:
    """One `OUTPUT=FLOOR` of --atol, checked as the stepper checks it."""
    kind, equals, value = text.partition("=")
    try:
        if not equals:
            raise ValueError(f"expected OUTPUT=FLOOR, outputs {', '.join(OUTPUT_KINDS)}")
        floor = float(value)
        atol_floors({kind: floor})
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None
    return kind, floor


def _scenario(args, limits=None):
    """The scenario to run and a one-line description of it; `limits` (a `Configuration`),
    if given, bound its waypoints."""
    given = {name: getattr(args, name) for name in OPTIONS}
    if args.scenario is None:
        return reference_scenario(**given)
    if any(value is not None for value in given.values()):
        options = ", ".join(OPTIONS[name] for name, value in given.items() if value is not None)
        raise ValueError(
            f"{options} describe the reference scenario; with --scenario "
            f"{args.scenario} put them in the file"
        )
    points = limits and functools.partial(limits.check, limits.policy.check_points)
    scenario = load_scenario(args.scenario, points)
    return scenario, f"{scenario.description or 'scenario'} ({args.scenario})"


def _deploy(args) -> int:
    # the limits first: a scenario's waypoints are counted before anything is made of them
    limits = configuration(args)
    scenario, description = _scenario(args, limits)
    where = f"{args.scenario}: sail section" if args.scenario else "scenario sail section"
    config = configuration(args, scenario.sail, where)
    config = dataclasses.replace(config, sail=config.sail.resolved(scenario.shortest_length))
    snapshots = args.snapshots or list(scenario.snapshots)
    request = DeployRequest(
        args.every, args.rate, args.max_step, args.rtol, dict(args.atol) or None, tuple(snapshots),
        None if args.convergence is None else tuple(args.convergence), args.shape_rate,
        args.shape_divisions, args.mcap, args.figures, str(args.scenario or ""),
    )  # fmt: skip
    found = study(scenario, config.sail, config.policy, request, config.check, _progress)
    result = found.result
    if result.warning:
        print(
            f"warning: {result.warning} (the simulator's diagnostics turn WARN here)",
            file=sys.stderr,
        )
    if result.accuracy.warning:
        print(f"warning: {result.accuracy.warning}", file=sys.stderr)
    report = DeploymentReport(result, config, description, found.model, found.table_times,
                              found.convergence, found.holds, found.controller)  # fmt: skip
    if args.json:
        print(json.dumps(report.to_json(), indent=2))
    elif args.summary or not (args.mcap or args.figures):
        report.print_text()
    warning = report.convergence_warning()
    if warning:
        print(warning, file=sys.stderr)
    written = []
    if args.mcap:
        from sail_ros.analysis.log_export import write_study_log
        from sail_ros.bag import BagWriteError

        try:
            written.append(write_study_log(found, scenario, config.policy, request, _progress))
        except BagWriteError as error:  # named by the output, not its temporary name
            reason = error.error.strerror or error.error
            print(f"error: --mcap {args.mcap}: cannot write: {reason}; nothing written",
                  file=sys.stderr)  # fmt: skip
            return 1
    if args.figures:
        written += deploy_figures(args.figures, found, scenario, snapshots, description)
    if not args.json:
        print_written(written)
    if found.stopped:
        kept = f"; {'wrote' if written else 'kept'} the run up to t = {result.t[-1]:g} s"
        print(f"error: {found.stopped}{kept if result.alarm else ''}", file=sys.stderr)
        return 1
    return 0


@contextlib.contextmanager
def _progress(what, total):
    """A progress bar on stderr (when it is a terminal) of the simulated time [s]."""
    with tqdm(total=total, unit="s sim", desc=what, disable=None, leave=False,
              file=sys.stderr) as bar:  # fmt: skip
        yield lambda t: bar.update(t - bar.n)


main = tool_main(build_parser, _deploy)
