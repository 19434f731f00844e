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

import copy
import dataclasses
import functools
import json
import math
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from sail_ros.analysis.convergence import BAR, converge, finer_parameters
from sail_ros.analysis.deployment import (
    hold_peaks,
    hold_reactions,
    output_count,
    output_times,
    rerun_peaks,
    run_deployment,
    sample_bytes,
)
from sail_ros.analysis.scenario import (
    REFERENCE,
    check_scenario,
    load_scenario,
    scenario_from_dict,
)
from sail_ros.integrate.control import DEFAULT_MAX_STEP, DEFAULT_RTOL
from sail_ros.model import SailModel
from sail_ros.model.layout import Layout
from sail_ros.options import ToolParser
from sail_ros.outputs import staged
from sail_ros.policy import OutOfRangeError, Policy
from sail_ros.tools.common import (
    add_sail_options,
    configuration,
    print_written,
    tool_main,
)
from sail_ros.tools.deploy_result import DeploymentReport

LEGACY = ("start", "end", "duration", "t_end", "boom", "tip")  # options that build a scenario
FIGURES = ("deployment_snapshots.png", "tip_deflections.png", "boom_lengths.png")
HUB_FIGURE = "hub_attitude.png"  # with a free hub: its tilt, heave and hold reactions
CLOSED_LOOP_FIGURE = "closed_loop.png"  # with a controller: open against closed loop
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


def _scenario(args, limits=None):
    """The scenario to run and a one-line description of it; `limits` (a `Configuration`),
    if given, bound its waypoints."""
    given = [name for name in LEGACY if getattr(args, name) is not None]
    if args.scenario is not None:
        if given:
            options = ", ".join(
                "--" + {"start": "from", "end": "to"}.get(n, n).replace("_", "-") for n in given
            )
            raise ValueError(
                f"{options} describe the reference scenario; with --scenario "
                f"{args.scenario} put them in the file"
            )
        points = limits and functools.partial(limits.check, limits.policy.check_points)
        scenario = load_scenario(args.scenario, points)
        return scenario, f"{scenario.description or 'scenario'} ({args.scenario})"
    document = copy.deepcopy(REFERENCE)
    body = document["scenario"]
    reference = body["profile"]
    start = reference["start"] if args.start is None else args.start
    end = reference["end"] if args.end is None else args.end
    duration = reference["duration"] if args.duration is None else args.duration
    boom = args.boom or "a"
    tip = body["initial"]["mode_state"]["a"] if args.tip is None else args.tip
    body["profile"] = {"type": "cycloidal", "start": start, "end": end, "duration": duration}
    body["duration"] = duration if args.t_end is None else args.t_end
    body["initial"] = {"mode_state": {boom: tip}}
    if args.t_end is not None or args.duration is not None:
        body["snapshots"] = np.linspace(0.0, body["duration"], 6).round(6).tolist()
    text = (
        f"booms {start:g} m -> {end:g} m in {duration:g} s (cycloidal), "
        f"boom {boom} tip {tip:g} m at t = 0"
    )
    body["description"] = text
    labels = {"profile": "--from/--to/--duration", "initial": "--boom/--tip"}
    try:
        return scenario_from_dict(document, labels), text
    except ValueError as error:  # a field of the document is an option here: name it so
        options = {
            "scenario.profile.start": "--from",
            "scenario.profile.end": "--to",
            "scenario.profile.duration": "--duration",
            "scenario.duration": "--duration" if args.t_end is None else "--t-end",
            f"scenario.initial.mode_state.{boom}": "--tip",
        }
        message = str(error)
        for field, option in options.items():
            if message.startswith(field + " "):
                raise ValueError(option + message[len(field) :]) from None
        raise ValueError(f"the reference deployment of the options: {message}") from None


def _check_options(args, duration: float, snapshots) -> None:
    if not args.every > 0:
        raise ValueError(f"--every must be > 0, got {args.every}")
    if not args.rate > 0:
        raise ValueError(f"--rate must be > 0 Hz, got {args.rate}")
    if not (math.isfinite(args.max_step) and args.max_step > 0):
        raise ValueError(f"--max-step must be finite and > 0 s, got {args.max_step}")
    if not 0.0 <= args.rtol < 1.0:
        raise ValueError(f"--rtol must be in [0, 1) (0: fixed steps), got {args.rtol}")
    if args.shape_rate < 0 or args.shape_rate > args.rate:
        raise ValueError(
            f"--shape-rate must be in [0, --rate = {args.rate:g}] Hz, got {args.shape_rate}"
        )
    if args.shape_divisions < 1:
        raise ValueError(f"--shape-divisions must be >= 1, got {args.shape_divisions}")
    for t in snapshots:
        if not 0.0 <= t <= duration:
            raise ValueError(f"--snapshots: {t:g} s is outside [0, {duration:g}] s")
    if args.convergence is not None and len(args.convergence) not in (0, 2):
        raise ValueError(f"--convergence takes no value or two (N_B N_M), got {args.convergence}")
    mcap = args.mcap
    if (
        mcap is not None
        and mcap.suffix != ".mcap"
        and mcap.exists()
        and (not mcap.is_dir() or any(mcap.iterdir()))
    ):
        raise ValueError(f"--mcap {mcap}: exists; give a new bag folder or a .mcap file")


def _output_size(args, duration: float, n: int, extra: int) -> None:
    """Refuse, before anything is allocated, a run whose outputs would not fit
    (`Policy.check_output`), naming the estimate; `n` coordinates, `extra` more times."""
    samples = output_count(duration, 1.0 / args.every)
    what = f"the run over {duration:g} s (a table row every {args.every:g} s"
    if args.mcap or args.figures:
        samples += output_count(duration, args.rate) + extra
        what += f", {args.rate:g} Hz for --mcap/--figures"
    Policy.check_output(
        samples, sample_bytes(n), what + ")", "a shorter duration, a longer --every, a lower --rate"
    )


def _deploy(args) -> int:
    # the limits first: a scenario's waypoints are counted before anything is made of them
    limits = configuration(args)
    scenario, description = _scenario(args, limits)
    where = f"{args.scenario}: sail section" if args.scenario else "scenario sail section"
    config = configuration(args, scenario.sail, where)
    config = dataclasses.replace(config, sail=config.sail.resolved(scenario.shortest_length))
    params, policy = config.sail, config.policy
    duration = scenario.duration
    snapshots = args.snapshots or list(scenario.snapshots)
    _check_options(args, duration, snapshots)
    if args.convergence:  # explicit counts: checked before the run
        finer_parameters(params, *args.convergence)
    coordinates = 4 * (params.n_boom_modes + params.membrane_modes) + 3 * params.free_hub
    _output_size(args, duration, coordinates, len(snapshots))
    table_times = np.unique(np.append(np.arange(0.0, duration, args.every), duration))
    grid = output_times(duration, args.rate)
    if args.mcap or args.figures:
        t_eval = output_times(duration, args.rate, extra=[*table_times, *snapshots])
    else:  # the table alone: no fine grid, whose short steps would slow the run
        t_eval = table_times

    try:  # what the scenario names: its coordinates, before the model's integrals
        layout = Layout(params.n_boom_modes, params.membrane_modes, params.free_hub)
        scenario.check_coordinates(layout)
    except ValueError as error:
        raise ValueError(f"{args.scenario or 'the reference deployment'}: {error}") from None
    model = SailModel(params)
    config.check(check_scenario, scenario, model, policy)
    closed = open_loop = None
    if scenario.controller is not None:
        if args.convergence is not None:
            raise ValueError(
                "--convergence reruns the open loop; a scenario with a controller section "
                "runs closed (raise n_boom_modes and n_membrane_modes with --set instead)"
            )
        closed, open_loop = _closed_loop(args, model, scenario, policy, t_eval)
        result = closed.run
    else:
        with tqdm(total=duration, unit="s sim", disable=None, leave=False, file=sys.stderr) as bar:
            result = run_deployment(
                model, scenario, t_eval, args.max_step, lambda t: bar.update(t - bar.n),
                policy=policy, rtol=args.rtol or None,
            )  # fmt: skip
    if result.warning:
        print(
            f"warning: {result.warning} (the simulator's diagnostics turn WARN here)",
            file=sys.stderr,
        )
    if result.accuracy.warning:
        print(f"warning: {result.accuracy.warning}", file=sys.stderr)
    convergence, stopped = None, result.alarm
    if args.convergence is not None and not stopped:

        def rerun(finer):
            desc = f"rerun at (n_B, n_M) = ({finer.n_boom_modes}, {finer.n_membrane_modes})"
            with tqdm(total=duration, unit="s sim", desc=desc, disable=None, leave=False,
                      file=sys.stderr) as bar:  # fmt: skip
                return rerun_peaks(
                    model, scenario, result, finer, args.max_step,
                    lambda t: bar.update(t - bar.n), policy,
                )  # fmt: skip

        try:
            convergence = converge(rerun, model, result.peaks, args.convergence or None)
        except OutOfRangeError as error:
            stopped = str(error)

    holds = None
    if model.free_hub:  # over the time the run reached
        holds = hold_peaks(model, scenario.profile, float(result.t[-1]))
    numbers = None
    if closed is not None:
        from sail_ros.analysis.closed_loop import summary

        numbers = summary(closed, open_loop)
    found = DeploymentReport(
        result, config, description, model, table_times, convergence, holds, numbers
    )
    if args.json:
        print(json.dumps(found.to_json(), indent=2))
    elif args.summary or not (args.mcap or args.figures):
        found.print_text()
    warning = found.convergence_warning()
    if warning:
        print(warning, file=sys.stderr)

    written = []
    if args.mcap:
        from sail_ros.bag import BagWriteError

        try:
            written.append(_write_log(args, model, result, grid, scenario, policy, closed))
        except BagWriteError as error:  # named by the output, not its temporary name
            reason = error.error.strerror or error.error
            print(f"error: --mcap {args.mcap}: cannot write: {reason}; nothing written",
                  file=sys.stderr)  # fmt: skip
            return 1
    if args.figures:
        written += _write_figures(args.figures, model, result, snapshots, scenario, description)
        if closed is not None:
            written.append(_closed_loop_figure(args.figures, closed, open_loop, description))
    if not args.json:
        print_written(written)
    if stopped:
        kept = f"; {'wrote' if written else 'kept'} the run up to t = {result.t[-1]:g} s"
        print(f"error: {stopped}{kept if result.alarm else ''}", file=sys.stderr)
        return 1
    return 0


def _closed_loop(args, model, scenario, policy, t_eval):
    """The scenario with its controller (`analysis.closed_loop`), and without it on the
    output times `t_eval` for the comparison."""
    from sail_ros.analysis.closed_loop import run_closed_loop

    design = scenario.controller
    ratio = design.state_rate_hz / args.rate
    if args.mcap and abs(ratio - round(ratio)) > 1e-9:
        raise ValueError(
            f"--rate {args.rate:g} Hz: the log of a closed loop takes every state sample's "
            f"multiple; it must divide the controller's state_rate_hz = "
            f"{design.state_rate_hz:g} Hz"
        )
    runs = []
    for what in ("closed loop", "open loop"):
        with tqdm(total=scenario.duration, unit="s sim", desc=what, disable=None, leave=False,
                  file=sys.stderr) as bar:  # fmt: skip
            progress = lambda t, bar=bar: bar.update(t - bar.n)  # noqa: E731
            if what == "closed loop":
                runs.append(run_closed_loop(
                    model, scenario, design, policy, progress=progress, max_step=args.max_step,
                    rtol=args.rtol or None,
                ))  # fmt: skip
            else:
                runs.append(run_deployment(
                    model, scenario, t_eval, args.max_step, progress, policy=policy,
                    rtol=args.rtol or None,
                ))  # fmt: skip
    return runs


def _closed_loop_figure(folder: Path, closed, open_loop, description) -> Path:
    from sail_ros.plots.control import closed_loop_figure

    run = closed.run
    return closed_loop_figure(
        (open_loop.t, open_loop.hub),
        (run.t, run.hub),
        (run.t, closed.commands, closed.inputs, closed.limits),
        folder / CLOSED_LOOP_FIGURE,
        description,
    )


def _write_log(args, model, result, grid, scenario, policy, closed=None) -> Path:
    """The run at the grid's times as an MCAP log at --mcap (whole or not at all); a closed
    loop's commands with it."""
    from sail_ros.analysis.log_export import recorded_parameters, write_deployment_log

    logged = result.subset(np.isin(result.t, grid))
    shape_every = round(args.rate / args.shape_rate) if args.shape_rate > 0 else 0
    parameters = recorded_parameters(
        model,
        logged,
        state_rate_hz=args.rate,
        shape_rate_hz=args.rate / shape_every if shape_every else 0.0,
        max_step=args.max_step,
        shape_divisions=args.shape_divisions,
        policy=policy,
    )
    with (
        staged(args.mcap, "--mcap") as building,
        tqdm(
            total=logged.t[-1], unit="s sim", desc="mcap", disable=None, leave=False,
            file=sys.stderr,
        ) as bar,
    ):  # fmt: skip
        write_deployment_log(
            building,
            model,
            logged,
            parameters=parameters,
            scenario_document=scenario.document,
            shape_every=shape_every,
            shape_divisions=args.shape_divisions,
            progress=lambda t: bar.update(t - bar.n),
            commands=None if closed is None else (
                result.t, closed.commands, closed.schedule.delay, closed.inputs
            ),
        )  # fmt: skip
    return args.mcap


def _write_figures(folder: Path, model, result, snapshots, scenario, description) -> list[Path]:
    from sail_ros.analysis.load_changes import schedule_changes
    from sail_ros.plots.deployment import snapshots_figure
    from sail_ros.plots.histories import (
        boom_lengths_figure,
        hub_attitude_figure,
        tip_deflections_figure,
    )

    loads = [(change.t_s, change.text) for change in schedule_changes(scenario.loads)]
    rows = [result.index_of(t) for t in snapshots if t <= result.t[-1] + 1e-9] or [0]
    snapshots_path, tips_path, lengths_path = (folder / name for name in FIGURES)
    hub = []
    if result.hub is not None:
        holds = hold_reactions(model, scenario.profile, result.t)
        hub.append(
            hub_attitude_figure(result.t, result.hub, holds, folder / HUB_FIGURE, description)
        )
    return [
        snapshots_figure(
            model,
            result.t[rows],
            result.lengths[rows],
            result.q[rows],
            snapshots_path,
            title=f"Deployment snapshots: {description}",
        ),
        tip_deflections_figure(result.t, result.tips, tips_path, title=description, loads=loads),
        boom_lengths_figure(
            result.t, result.lengths, result.rates, lengths_path, title=description
        ),
        *hub,
    ]


main = tool_main(build_parser, _deploy)
