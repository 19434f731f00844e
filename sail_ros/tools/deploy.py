"""`sail-ros deploy`: an offline deployment run (model.md §9 reference by default).

By default all booms extend along the cycloidal profile from `--from` to
`--to` metres in `--duration` seconds and boom `--boom` starts bent in its
first mode with tip deflection `--tip`; `--scenario FILE` runs any scenario
instead (per-boom cycloidal or waypoint profiles, any initial state; see
config/scenario_reference.yaml). Prints the boom-tip deflections against
time and the true peaks of each boom's tip deflection and root moment with
their times (taken inside every integration step, not from the printed
times); `--convergence` reruns with more modes and says how far each peak
moves; `--json` prints it all as one JSON object. Writes an MCAP log with the
live simulator's topics (`--mcap`) and figures (`--figures`).

    sail-ros deploy --summary
    sail-ros deploy --convergence
    sail-ros deploy --json --convergence 10 10
    sail-ros deploy --scenario config/scenario_staggered.yaml --mcap run.mcap --figures out/
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from sail_ros.analysis.deployment import (
    converge,
    finer_mode_counts,
    output_times,
    run_deployment,
)
from sail_ros.analysis.scenario import REFERENCE, load_scenario, scenario_from_dict
from sail_ros.cli import PHYSICS_DOC
from sail_ros.model import SailModel, SailParameters
from sail_ros.model.stepper import DEFAULT_MAX_STEP
from sail_ros.tools.common import (
    add_sail_options,
    describe_parameters,
    print_peak_table,
    print_written,
    run,
    sail_parameters,
)

LEGACY = ("start", "end", "duration", "t_end", "boom", "tip")  # options that build a scenario
CONVERGENCE_WARNING = 0.01  # a peak that moves more than this with more modes is not converged


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sail-ros deploy", description=__doc__.splitlines()[0], epilog=PHYSICS_DOC
    )
    add_sail_options(parser)
    parser.add_argument(
        "--scenario",
        type=Path,
        metavar="YAML",
        help="scenario file (profiles per boom, initial state, snapshot times; "
        "see config/scenario_reference.yaml); its `sail:` section overrides "
        "--config, --set overrides both",
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
        "--max-step", type=float, default=DEFAULT_MAX_STEP, help="largest integration step [s]"
    )
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
        help="rerun with more modes (default: twice n_B and n_M, at most 30 and 100) and "
        "say how far each peak moves; a warning when one moves by more than "
        f"{100 * CONVERGENCE_WARNING:g} %%",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object (peaks per boom with times, parameters, mode counts, "
        "wall time, convergence) instead of the table",
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
        help="write DIR/deployment_snapshots.png, DIR/tip_deflections.png and DIR/boom_lengths.png",
    )
    output.add_argument(
        "--snapshots",
        type=float,
        nargs="+",
        metavar="T",
        help="snapshot times [s] (default: the scenario's)",
    )
    return parser


def _scenario(args):
    """The scenario to run and a one-line description of it."""
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
        scenario = load_scenario(args.scenario)
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
    return scenario_from_dict(document), text


def _parameters(args, scenario) -> SailParameters:
    """--set > the scenario's `sail:` section > --config > defaults."""
    params = sail_parameters(args)
    if scenario.sail:
        explicit = {item.partition("=")[0].strip() for item in args.set}
        overrides = {k: v for k, v in scenario.sail.items() if k not in explicit}
        try:
            params = SailParameters.from_dict({**params.to_dict(), **overrides})
        except ValueError as error:
            raise ValueError(f"scenario sail section: {error}") from None
    return params


def _print_table(run_result, table_times, description, params, wall, duration) -> None:
    rows = [run_result.index_of(t) for t in table_times]
    lengths = run_result.lengths[rows]
    equal = np.allclose(lengths, lengths[:, :1])
    print(f"Deployment: {description}")
    print(describe_parameters(params))
    print()
    label = "L [m]" if equal else "L_a [m]"
    print(f"  {'t [s]':>7}{label:>9}   tip deflection [mm]: {'a':>9}{'b':>10}{'c':>10}{'d':>10}")
    for i in rows:
        tips = run_result.tips[i]
        print(
            f"  {run_result.t[i]:7.2f}{run_result.lengths[i, 0]:9.3f}   {'':21}"
            + "".join(f"{1e3 * v:10.3f}" for v in tips)
        )
    print()
    print(f"  {duration:g} s simulated in {wall:.3f} s wall ({duration / wall:.0f}x real time)")


def _print_peaks(peaks, params, convergence=None) -> None:
    """Each boom's peak |tip| and |root moment| with its time, and their convergence."""
    print()
    print(
        f"  peaks over the whole run, per boom (taken inside every integration step; "
        f"n_B = {params.n_boom_modes}, n_M = {params.n_membrane_modes}):"
    )
    changes = None
    if convergence is not None:
        label = (
            f"  change at ({convergence.n_boom_modes}, {convergence.n_membrane_modes}) modes [%]"
        )
        changes = (label, convergence.tip_change, convergence.moment_change)
    print_peak_table(peaks, changes)


def _convergence_warning(convergence) -> str:
    """One line naming every peak that moved by more than CONVERGENCE_WARNING ("" if none)."""
    moved = [
        f"{what} {boom} {100 * change:+.2f} %"
        for what, changes in (
            ("tip", convergence.tip_change),
            ("moment", convergence.moment_change),
        )
        for boom, change in zip("abcd", changes, strict=True)
        if abs(change) > CONVERGENCE_WARNING
    ]
    if not moved:
        return ""
    return (
        f"warning: peaks not converged: with (n_B, n_M) = ({convergence.n_boom_modes}, "
        f"{convergence.n_membrane_modes}) they move by more than "
        f"{100 * CONVERGENCE_WARNING:g} % ({', '.join(moved)}); raise n_boom_modes and "
        "n_membrane_modes (--set) until they stop moving"
    )


def _json_report(result, params, description, convergence) -> dict:
    def per_boom(values):
        return dict(zip("abcd", (float(v) for v in values), strict=True))

    peaks = result.peaks
    report = {
        "description": description,
        "duration_s": float(result.t[-1] - result.t[0]),
        "peak_tip_deflection_m": per_boom(peaks.tip_deflection.value),
        "peak_tip_deflection_time_s": per_boom(peaks.tip_deflection.time_s),
        "peak_root_moment_Nm": per_boom(peaks.root_moment.value),
        "peak_root_moment_time_s": per_boom(peaks.root_moment.time_s),
        "n_boom_modes": params.n_boom_modes,
        "n_membrane_modes": params.n_membrane_modes,
        "parameters": params.to_dict(),
        "wall_time_s": result.wall_seconds,
    }
    if convergence is not None:
        fine = convergence.peaks
        report["convergence"] = {
            "n_boom_modes": convergence.n_boom_modes,
            "n_membrane_modes": convergence.n_membrane_modes,
            "peak_tip_deflection_m": per_boom(fine.tip_deflection.value),
            "peak_root_moment_Nm": per_boom(fine.root_moment.value),
            "tip_deflection_change": per_boom(convergence.tip_change),
            "root_moment_change": per_boom(convergence.moment_change),
            "converged": convergence.largest() <= CONVERGENCE_WARNING,
        }
    return report


def _deploy(args) -> int:
    scenario, description = _scenario(args)
    params = _parameters(args, scenario)
    if not args.every > 0:
        raise ValueError(f"--every must be > 0, got {args.every}")
    if not args.rate > 0:
        raise ValueError(f"--rate must be > 0 Hz, got {args.rate}")
    if args.shape_rate < 0 or args.shape_rate > args.rate:
        raise ValueError(
            f"--shape-rate must be in [0, --rate = {args.rate:g}] Hz, got {args.shape_rate}"
        )
    if args.shape_divisions < 1:
        raise ValueError(f"--shape-divisions must be >= 1, got {args.shape_divisions}")
    duration = scenario.duration
    snapshots = args.snapshots or list(scenario.snapshots)
    for t in snapshots:
        if not 0.0 <= t <= duration:
            raise ValueError(f"--snapshots: {t:g} s is outside [0, {duration:g}] s")
    table_times = np.unique(np.append(np.arange(0.0, duration, args.every), duration))
    grid = output_times(duration, args.rate)
    if args.mcap or args.figures:
        t_eval = output_times(duration, args.rate, extra=[*table_times, *snapshots])
    else:  # the table alone: no fine grid, whose short steps would slow the run
        t_eval = table_times

    finer = None
    if args.convergence is not None:
        if len(args.convergence) not in (0, 2):
            raise ValueError(
                f"--convergence takes no value or two (N_B N_M), got {args.convergence}"
            )
        finer = finer_mode_counts(params, *args.convergence)

    model = SailModel(params)
    with tqdm(total=duration, unit="s sim", disable=None, leave=False, file=sys.stderr) as bar:

        def progress(t):
            bar.update(t - bar.n)

        result = run_deployment(model, scenario, t_eval, max_step=args.max_step, progress=progress)
    convergence = None
    if finer is not None:
        with tqdm(
            total=duration,
            unit="s sim",
            desc=f"rerun at (n_B, n_M) = {finer}",
            disable=None,
            leave=False,
            file=sys.stderr,
        ) as bar:
            convergence = converge(
                model, scenario, result, *finer, args.max_step, lambda t: bar.update(t - bar.n)
            )

    if args.json:
        print(json.dumps(_json_report(result, params, description, convergence), indent=2))
    elif args.summary or not (args.mcap or args.figures):
        _print_table(result, table_times, description, params, result.wall_seconds, duration)
        _print_peaks(result.peaks, params, convergence)
    warning = _convergence_warning(convergence) if convergence is not None else ""
    if warning:
        print(warning, file=sys.stderr)

    written = []
    if args.mcap:
        from sail_ros.analysis.log_export import simulator_parameters, write_deployment_log

        on_grid = np.isin(result.t, grid)
        logged = result.subset(on_grid)
        shape_every = round(args.rate / args.shape_rate) if args.shape_rate > 0 else 0
        parameters = simulator_parameters(
            model,
            logged,
            state_rate_hz=args.rate,
            shape_rate_hz=args.rate / shape_every if shape_every else 0.0,
            max_step=args.max_step,
            shape_divisions=args.shape_divisions,
        )
        from sail_ros.bag import BagWriteError

        if args.mcap.suffix == ".mcap":
            args.mcap.parent.mkdir(parents=True, exist_ok=True)
        with tqdm(
            total=duration, unit="s sim", desc="mcap", disable=None, leave=False, file=sys.stderr
        ) as bar:
            try:
                write_deployment_log(
                    args.mcap,
                    model,
                    logged,
                    parameters=parameters,
                    scenario_document=scenario.document,
                    shape_every=shape_every,
                    shape_divisions=args.shape_divisions,
                    progress=lambda t: bar.update(t - bar.n),
                )
            except BagWriteError as error:
                print(f"error: --mcap: {error}", file=sys.stderr)
                return 1
        written.append(args.mcap)
    if args.figures:
        from sail_ros.plots.deployment import snapshots_figure
        from sail_ros.plots.histories import boom_lengths_figure, tip_deflections_figure

        rows = [result.index_of(t) for t in snapshots]
        written.append(
            snapshots_figure(
                model,
                result.t[rows],
                result.lengths[rows],
                result.q[rows],
                args.figures / "deployment_snapshots.png",
                title=f"Deployment snapshots: {description}",
            )
        )
        written.append(
            tip_deflections_figure(
                result.t, result.tips, args.figures / "tip_deflections.png", title=description
            )
        )
        written.append(
            boom_lengths_figure(
                result.t,
                result.lengths,
                result.rates,
                args.figures / "boom_lengths.png",
                title=description,
            )
        )
    if not args.json:
        print_written(written)
    return 0


def main(argv=None) -> int:
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    return run(_deploy, args)


if __name__ == "__main__":
    sys.exit(main())
