"""`sail-ros report`: time histories of a simulator log as figures and CSV.

Reads a log written by the recorder or by `sail-ros deploy --mcap` (an MCAP
file or a bag folder; a file cut short, e.g. by a killed recorder, is read
up to its last complete record) and writes into `--out`:

- states.csv, tip_deflections.png, boom_lengths.png: boom-tip deflections,
  boom lengths and extension rates (and root moments); the columns are the state
  record's (`sail_ros.model.record`: a_boom_length_m, a_tip_deflection_m, ...);
- with a free hub (/sail/hub_state): its heave, tilts and their rates in
  states.csv, hub_attitude.png (tilt, heave and, for a `sail-ros deploy` log,
  the reactions of the in-plane and spin holds), its peaks in peaks.csv; with hub
  wrench commands (/sail/hub_wrench_cmd: a controller's), hub_commands.png draws
  each hub axis's state against the command on it;
- energies.csv, modal_energies.png: mechanical energy per boom and per
  quadrant coordinate group and in all, with `M` and `K` built from the sail
  parameters recorded in the log (`sail_sim_parameters`);
- real_time_factor.csv, real_time_factor.png: the achieved real-time factor
  from /diagnostics (an offline run has none; the report says so);
- parameter_changes.csv: every change of the simulator's parameters during the
  run (name, old -> new value, at its simulation time), from the recorder's
  `sail_sim_parameter_changes` records or, in logs written before them, from
  /parameter_events; also listed in the output;
- peaks.csv: each boom's peak |tip deflection| and |root moment| with its time,
  interpolated between the logged samples with the logged rates (cubic
  Hermite), with what the sampling cannot follow; then the true peaks of a
  rerun (of a `sail-ros deploy` log's recorded scenario; of a live log's logged
  motion, loads and state, `analysis.log_rerun`) and, unless
  `--no-convergence`, of a rerun on a finer model (`analysis.convergence`: four more
  boom modes, the membrane band 1.25 times wider), each change against the largest
  peak of its kind and against the boom's own (a warning when a peak moves by more
  than 1 % of the largest of its kind).

`--config`/`--set` describe the sail only for a log without recorded parameters; the
limits of a rerun are those the log recorded, changed by `--set`. A log that holds more
than one run of the simulator (restarted under the recorder: other sail parameters, a
state of another size, another epoch) is refused in one line saying what changed.
"""

from __future__ import annotations

import csv
import functools
import sys
import warnings
from pathlib import Path

import numpy as np

from sail_ros import status as key
from sail_ros.analysis.convergence import converge
from sail_ros.analysis.deployment import (
    carried_over,
    hold_reactions,
    run_deployment,
)
from sail_ros.analysis.energy import group_energies
from sail_ros.analysis.load_changes import log_changes, run_description
from sail_ros.analysis.log_peaks import RESOLVED_PHASE, log_peaks
from sail_ros.analysis.log_rerun import rerun_log
from sail_ros.analysis.log_series import read_log
from sail_ros.analysis.parameter_history import parameter_changes
from sail_ros.analysis.scenario import check_scenario, scenario_from_dict
from sail_ros.integrate.errors import AccuracyWarning
from sail_ros.model import SailModel, SailParameters, record, yaml_values
from sail_ros.model.layout import BOOMS, QUADRANTS
from sail_ros.options import ToolParser
from sail_ros.outputs import staged
from sail_ros.plots.histories import (
    boom_lengths_figure,
    energies_figure,
    hub_attitude_figure,
    real_time_factor_figure,
    root_moments_figure,
    tip_deflections_figure,
)
from sail_ros.policy import OutOfRangeError, Policy
from sail_ros.tools.common import (
    add_sail_options,
    configuration,
    print_written,
    refine_hint,
    set_values,
    tool_main,
)
from sail_ros.tools.tables import describe_parameters, print_hub_peak_table, print_peak_table

# first columns of real_time_factor.csv; any other status values follow by name
DIAGNOSTIC_COLUMNS = (
    key.SIM_TIME,
    key.REAL_TIME_FACTOR,
    key.STATE,
    key.STEP_TIME_MEAN,
    key.STEP_TIME_MAX,
    key.OVERRUNS,
    key.REJECTED,
    key.ENERGY,
)


EXAMPLES = (
    "sail-ros deploy --t-end 6 --rate 25 --mcap out/short.mcap",
    "sail-ros report out/short.mcap --out out/short_report",
    "sail-ros report out/short.mcap --out out/short_report --no-convergence",
    "sail-ros report out/run1 --namespace /sat1",
)
WRITES = (
    "into --out DIR: states.csv, tip_deflections.png, root_moments.png, boom_lengths.png, "
    "energies.csv, modal_energies.png, real_time_factor.csv, real_time_factor.png, "
    "hub_attitude.png, hub_commands.png (those the log has data for), parameter_changes.csv, "
    "peaks.csv; the "
    "folder is built under a temporary name and moved into place when all is written (an "
    "existing folder keeps its other files)."
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool(
        "report", __doc__.split("\n\n")[0], EXAMPLES, WRITES, __doc__.split("\n\n", 1)[1]
    )
    parser.add_argument("log", type=Path, help="MCAP file or rosbag2 folder")
    parser.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="output folder (default: <log name>_report in the working directory)",
    )
    parser.add_argument(
        "--namespace",
        help="the simulator's namespace in the log, e.g. /sat2 (needed only when the log "
        "holds several sails)",
    )
    parser.add_argument(
        "--no-convergence",
        action="store_true",
        help="skip the rerun on a finer model that says how converged the peaks are",
    )
    add_sail_options(parser)  # used only when the log has no recorded parameters
    return parser


def _write_csv(path: Path, header: list[str], columns) -> Path:
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows(zip(*columns, strict=True))
    return path


def _floats(texts) -> np.ndarray:
    values = []
    for text in texts:
        try:
            values.append(float(text))
        except ValueError:
            values.append(np.nan)
    return np.array(values)


def _report(args) -> int:
    if not args.log.exists():
        raise ValueError(f"log {str(args.log)!r} does not exist")
    # --config and --set are read (and checked) whether or not the log's own parameters
    # leave them unused: a mistyped name or a missing file is an error, not nothing
    given = configuration(args).sail
    log = read_log(args.log, args.namespace)
    out = args.out or Path(f"{args.log.stem if args.log.is_file() else args.log.name}_report")
    with staged(out, "--out") as folder:
        folder.mkdir()
        stopped = _write_report(args, log, folder, given)
        written = sorted(path.relative_to(folder) for path in folder.rglob("*") if path.is_file())
    print_written(out / path for path in written)
    if stopped:
        print(f"error: {stopped}; the report holds the rest", file=sys.stderr)
        return 1
    return 0


def _write_report(args, log, out: Path, given: SailParameters) -> str:
    """Write the report's files into `out`; the alarm of a rerun that stopped, or "".
    `given`: the sail of --config/--set, for a log without recorded parameters."""
    time_label = (
        "simulation time t [s]" if log.simulation_time else "time since the first sample [s]"
    )
    print(f"Log {args.log}")
    if log.incomplete:
        print(
            f"  incomplete (cut short): {', '.join(str(p) for p in log.incomplete)}; "
            f"read up to the last complete record (`sail-ros bag recover {args.log}` writes a "
            "complete copy that every reader opens)"
        )
    for topic, count in sorted(log.topic_counts.items()):
        print(f"  {topic}: {count} messages")
    title = run_description(log)
    loads = [(change.t_s, change.text) for change in log_changes(log)]

    if log.tips is not None:
        t = log.seconds(log.tips.stamp_ns)
        print(
            f"  tip deflections: {t[0]:.3f} .. {t[-1]:.3f} s, peak |tip| "
            f"{1e3 * np.abs(log.tips.position).max():.3f} mm"
        )
        tip_deflections_figure(
            t,
            log.tips.position,
            out / "tip_deflections.png",
            title=title,
            time_label=time_label,
            loads=loads,
        )
    if log.moments is not None and log.moments.effort.size:
        t = log.seconds(log.moments.stamp_ns)
        params = _recorded_parameters(log)
        print(
            f"  root moments: peak |M| {np.abs(log.moments.effort).max():.4g} N m"
            + (f" (n_B = {params.n_boom_modes})" if params else "")
        )
        root_moments_figure(
            t,
            log.moments.effort,
            out / "root_moments.png",
            title=title,
            time_label=time_label,
            n_boom_modes=params.n_boom_modes if params else None,
            loads=loads,
        )
    if log.boom is not None:
        t = log.seconds(log.boom.stamp_ns)
        print(f"  boom lengths: {log.boom.position.min():.3f} .. {log.boom.position.max():.3f} m")
        boom_lengths_figure(
            t,
            log.boom.position,
            log.boom.velocity,
            out / "boom_lengths.png",
            title=title,
            time_label=time_label,
        )
    if log.hub is not None:
        _hub(log, out / HUB_FIGURE, time_label, title)
    if log.hub is not None and log.hub_commands is not None:
        _hub_commands(log, out / COMMANDS_FIGURE, time_label, title)
    _write_states(log, out / "states.csv")
    _parameter_changes(args, log, out / "parameter_changes.csv", time_label)
    stopped = _peaks(args, log, out, given)
    _energies(log, out, time_label, given, title, loads)
    _real_time_factor(log, out, time_label, title)
    return stopped


HUB_FIGURE = "hub_attitude.png"
COMMANDS_FIGURE = "hub_commands.png"


def _hub_commands(log, path: Path, time_label: str, title: str) -> Path:
    """The hub wrench commands in one line and the figure of states against commands;
    the commands at the stamps of the samples they answer (a zero wrench of a stale or
    stopping controller, which answers none, at the last sample's)."""
    from sail_ros.plots.control import commands_figure

    stamps, hub = log.hub
    command_stamps, _, wrench = log.hub_commands
    answered = command_stamps > 0
    peak = np.abs(wrench).max(axis=0)
    print(
        f"  hub wrench commands: {len(wrench)}, peak |F_z| {peak[0]:.4g} N, |tau_x| "
        f"{peak[1]:.4g} N m, |tau_y| {peak[2]:.4g} N m"
    )
    return commands_figure(
        log.seconds(stamps), hub, log.seconds(command_stamps[answered]), wrench[answered],
        path, title=title, time_label=time_label,
    )  # fmt: skip


def _hub(log, path: Path, time_label: str, title: str) -> Path:
    """A free hub's range in one line and its attitude figure; the holds' reactions from a
    deploy log's scenario (a live log holds no boom accelerations)."""
    stamps, hub = log.hub
    t = log.seconds(stamps)
    tilt = np.hypot(hub[:, 1], hub[:, 2])
    print(
        f"  free hub: |z_h| up to {1e3 * np.abs(hub[:, 0]).max():.4g} mm, tilt |theta| up "
        f"to {1e3 * tilt.max():.4g} mrad ({np.degrees(tilt.max()):.3g} deg) in the samples"
    )
    holds = None
    params = _recorded_parameters(log)
    if log.scenario is not None and params is not None:
        profile = scenario_from_dict(log.scenario).profile
        holds = hold_reactions(SailModel(params), profile, t)
    return hub_attitude_figure(t, hub, holds, path, title=title, time_label=time_label)


def _parameter_changes(args, log, path: Path, time_label: str) -> Path:
    """List the simulator's parameter changes; one row each in `path`."""
    changes, source = parameter_changes(log, args.namespace)
    if not changes:
        print("  parameter changes: none" + (f" (in {source})" if source else " recorded"))
    else:
        print(f"  parameter changes ({len(changes)}, from {source}; t: {time_label}):")
        for change in changes:
            print(
                f"    t = {change.t_s:.3f} s  {change.name}: {_shown(change.old)} -> "
                f"{_shown(change.new)}"
            )
    header = ["t_s", "log_time_ns", "time_ns", "name", "old", "new"]
    columns = [
        [c.t_s for c in changes],
        [c.log_time_ns for c in changes],
        [c.time_ns for c in changes],
        [c.name for c in changes],
        ["" if c.old is None else c.old for c in changes],
        ["" if c.new is None else c.new for c in changes],
    ]
    return _write_csv(path, header, columns)


def _shown(value: str | None) -> str:
    return "(none)" if value is None else value


PEAK_COLUMNS = [
    f"peak_{what}_{boom}_{unit}"
    for boom in BOOMS
    for what, unit in (
        ("tip", "m"),
        ("tip", "time_s"),
        ("root_moment", "N_m"),
        ("root_moment", "time_s"),
    )
]


def _peaks(args, log, out: Path, given: SailParameters) -> str:
    """Each boom's peaks: from the log's samples, and for a deploy log from reruns of its
    scenario (the same mode counts, then a finer model); one row each in peaks.csv.
    Returns the alarm of a rerun that left the linear range ("" if none did)."""
    params = _recorded_parameters(log) or given
    model = SailModel(params)
    if log.modal is not None and log.modal.names != model.coordinate_names:
        model = None  # another sail than --config/--set say: the energies say so
    found = log_peaks(log, model)
    how = "interpolated with the logged rates (cubic Hermite)"
    if not all(found.interpolated):
        how = (
            "tips "
            + ("interpolated" if found.interpolated[0] else "as sampled")
            + ", root moments "
            + ("interpolated" if found.interpolated[1] else "as sampled")
        )
    print(
        f"  peaks per boom from the logged samples (every {1e3 * found.spacing_s:.4g} ms), {how}:"
    )
    rows = [_peak_row("log", params, found.peaks)]
    print_peak_table(found.peaks, indent="    ")
    if found.peaks.hub is not None:
        print("    free hub, interpolated with the logged rates of /sail/hub_state:")
        print_hub_peak_table(found.peaks.hub, indent="    ")
    if found.unresolved_moment is not None and np.isfinite(found.unresolved_frequency_hz):
        share = found.unresolved_moment / np.maximum(found.peaks.root_moment.value, 1e-300)
        print(
            f"  boom modes from {found.unresolved_frequency_hz:.3g} Hz up are sampled too "
            f"coarsely to follow (more than {RESOLVED_PHASE:g} rad between samples); they carry "
            "up to " + ", ".join(f"{100 * v:.2g} %" for v in share) + " of the peak root "
            "moments a..d, which may be off by that much between samples"
        )
    stopped = ""
    if model is not None:
        reruns, stopped = _rerun_peaks(args, log, model)
        rows += reruns
    header = ["source", "n_boom_modes", "n_membrane_modes", *PEAK_COLUMNS]
    if found.peaks.hub is not None:
        header += HUB_PEAK_COLUMNS
        rows = [row + [np.nan] * (len(header) - len(row)) for row in rows]  # a clamped rerun
    _write_csv(out / "peaks.csv", header, zip(*rows, strict=True))
    return stopped


HUB_PEAK_COLUMNS = [
    f"peak_hub_{what}_{unit}"
    for what, si in (("heave", "m"), ("tilt_x", "rad"), ("tilt_y", "rad"), ("tilt", "rad"))
    for unit in (si, "time_s")
]


def _peak_row(source: str, params, peaks) -> list:
    cells = [source, params.n_boom_modes, params.membrane_modes]
    for k in range(4):
        cells += [
            peaks.tip_deflection.value[k],
            peaks.tip_deflection.time_s[k],
            peaks.root_moment.value[k],
            peaks.root_moment.time_s[k],
        ]
    if peaks.hub is not None:
        for value, time_s in zip(peaks.hub.value, peaks.hub.time_s, strict=True):
            cells += [value, time_s]
    return cells


def _rerun_peaks(args, log, model) -> tuple[list[list], str]:
    """The log run again (a deploy log's recorded scenario, within the limits it recorded;
    a live log's logged motion, loads and state, `analysis.log_rerun`): its true peaks,
    how well it reproduces the logged tips, and unless --no-convergence how its peaks
    move on a finer model. The rows, and the alarm of a rerun that left the linear
    range ("")."""
    what, rerun = "the logged motion, loads and state", rerun_log
    if log.scenario is not None:  # refused by the limits: ValueError, exit 2
        what, rerun = "the recorded scenario", _scenario_rerun(log, model, _rerun_policy(args, log))
    try:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", AccuracyWarning)
            peaks, agreement, runs = rerun(log, model)
        for warning in {str(w.message) for w in said if w.category is AccuracyWarning}:
            print(f"warning: the rerun: {warning}", file=sys.stderr)
    except OutOfRangeError as error:
        return [], f"the rerun of {what}: {error}"
    except ValueError as error:
        print(f"  true peaks need a rerun of the log, which is not possible: {error}")
        return [], ""
    runs = f" ({runs} runs: resets)" if runs > 1 else ""
    print(
        f"  a rerun of {what}{runs} reproduces the logged tips to {agreement:.2g} of their "
        "peak; its true peaks (taken inside every integration step):"
    )
    rows = [_peak_row("rerun", model.params, peaks)]
    if args.no_convergence:
        print_peak_table(peaks, indent="    ")
        _print_rerun_hub(peaks)
        return rows, ""
    try:
        convergence = converge(
            lambda finer: rerun(log, finer, carried_from=model)[0], model, peaks, max_levels=1
        )
    except OutOfRangeError as error:
        print_peak_table(peaks, indent="    ")
        return rows, str(error)
    finest, change = convergence.finest, convergence.change
    print_peak_table(peaks, convergence, indent="    ")
    _print_rerun_hub(peaks)
    finer_params = model.params.replace(
        n_boom_modes=finest.n_boom_modes, n_membrane_modes=finest.n_membrane_modes
    )
    rows.append(_peak_row("rerun, more modes", finer_params, finest.peaks))
    if change.largest() > convergence.bar:
        print(
            f"warning: peaks not converged: against (n_B, n_M) = ({finest.n_boom_modes}, "
            f"{finest.n_membrane_modes}) they are off by up to {100 * change.largest():.3g} % "
            f"of the largest of their kind; {refine_hint(model.params)}",
            file=sys.stderr,
        )
    return rows, ""


def _print_rerun_hub(peaks) -> None:
    if peaks.hub is not None:
        print("    free hub (true peaks of the rerun):")
        print_hub_peak_table(peaks.hub, indent="    ")


def _rerun_policy(args, log) -> Policy:
    """The limits a rerun keeps: those the log recorded (the simulator's parameters of
    the same names), changed by --set."""
    recorded = {
        name: yaml_values.load(log.parameters[name])
        for name in Policy.field_names()
        if log.parameters and name in log.parameters
    }
    changes = {k: v for k, v in set_values(args).items() if k in Policy.field_names()}
    return Policy(**{**recorded, **changes})


def _scenario_rerun(log, model: SailModel, policy: Policy):
    """A rerun of a deploy log's scenario within `policy`, as `log_rerun.rerun_log` runs a
    live log: `(log, model, carried_from=None) -> (peaks, agreement, runs)`, which raises
    OutOfRangeError with the alarm of a rerun that left the linear range.

    Raises:
        ValueError: the scenario asks what `policy` refuses (`check_scenario`).
    """
    scenario = scenario_from_dict(log.scenario)
    try:
        check_scenario(scenario, model, policy)
    except ValueError as error:
        raise ValueError(f"the recorded scenario: {error}") from None
    step = float(log.parameters.get("max_model_step", "0.05")) if log.parameters else 0.05

    def rerun(log, model, carried_from=None):
        if log.tips is None or not log.simulation_time:
            raise ValueError("the log holds no tip deflections on simulation time")
        t = log.seconds(log.tips.stamp_ns)
        initial = None
        if carried_from is not None:
            initial = tuple(
                carried_over(values, carried_from, model)
                for values in scenario.initial_state(carried_from)
            )
        if scenario.controller is not None:  # the recorded loop, closed again
            from sail_ros.analysis.closed_loop import run_closed_loop

            closed = run_closed_loop(model, scenario, scenario.controller, policy, max_step=step)
            run = closed.run.subset(np.isin(np.round(closed.run.t, 6), np.round(t, 6)))
        else:
            run = run_deployment(model, scenario, t, step, initial=initial, policy=policy)
        if run.alarm:
            raise OutOfRangeError(run.alarm)
        if run.accuracy.warning:  # said once by the report
            warnings.warn(run.accuracy.warning, AccuracyWarning, stacklevel=1)
        logged = log.tips.position
        agreement = np.abs(run.tips - logged).max() / max(float(np.abs(logged).max()), 1e-300)
        return run.peaks, float(agreement), 1

    return rerun


def _recorded_parameters(log):
    """The log's sail parameters, or None when it has none or they do not parse."""
    try:
        return log.sail_parameters()
    except ValueError:
        return None


def _write_states(log, path: Path) -> Path:
    """One row per stamp of the log's state messages, a column per component of each of
    the state record's table fields (`model.record`: boom lengths and rates, tips and
    their rates, root moments, a free hub's six values), empty where a message is
    missing."""
    hub = log.hub is not None
    fields = record.table_fields(hub)
    series = {field.name: log.field(field.name) for field in fields}
    present = [found[0] for found in series.values() if found is not None]
    stamps = functools.reduce(np.union1d, present, np.array([], dtype=np.int64)).astype(np.int64)
    header = ["t_s", "stamp_ns", *record.column_names(hub)]
    columns = [log.seconds(stamps), stamps]
    for field in fields:
        block = np.full((stamps.size, len(record.component_names(field))), np.nan)
        found = series[field.name]
        if found is not None:
            block[np.searchsorted(stamps, found[0])] = found[1]
        columns += list(block.T)
    return _write_csv(path, header, columns)


def _energies(log, out: Path, time_label: str, given: SailParameters, title: str,
              loads) -> list[Path]:  # fmt: skip
    if log.modal is None:
        print("  no /sail/modal_state: energies not available")
        return []
    if log.boom is None:
        print("  no /sail/boom_state: the boom lengths needed for the energies are missing")
        return []
    params = log.sail_parameters()
    if params is None:
        params = given
        print(
            "  no recorded sail parameters (sail_sim_parameters): energies use "
            "--config/--set (built-in defaults if neither is given)"
        )
    else:
        print("  energies use the sail parameters recorded in the log:")
    print(describe_parameters(params))
    model = SailModel(params)
    if log.modal.names != model.coordinate_names:
        raise ValueError(
            f"/sail/modal_state has {len(log.modal.names)} coordinates "
            f"({log.modal.names[0]} ...), the sail's model has {model.n} "
            f"(n_B = {model.n_boom_modes}, n_M = {model.n_membrane_modes}); "
            "give the recorded mode counts with --set n_boom_modes=.. --set n_membrane_modes=.."
        )
    t_boom = log.boom.stamp_ns
    lengths = np.column_stack(
        [np.interp(log.modal.stamp_ns, t_boom, log.boom.position[:, k]) for k in range(4)]
    )
    energies = group_energies(model, lengths, log.modal.position, log.modal.velocity)
    t = log.seconds(log.modal.stamp_ns)
    print(
        f"  mechanical energy: {energies.total[0]:.4g} J at t = {t[0]:.3f} s, "
        f"{energies.total[-1]:.4g} J at t = {t[-1]:.3f} s"
    )
    header = (
        ["t_s", "stamp_ns"]
        + [f"boom_{b}_J" for b in BOOMS]
        + [f"membrane_{name}_J" for name, _, _ in QUADRANTS]
        + ["coupling_J", "total_J"]
    )
    columns = [
        t,
        log.modal.stamp_ns,
        *energies.booms.T,
        *energies.quadrants.T,
        energies.coupling,
        energies.total,
    ]
    return [
        _write_csv(out / "energies.csv", header, columns),
        energies_figure(
            t,
            energies.booms,
            energies.quadrants,
            energies.total,
            out / "modal_energies.png",
            title=title,
            time_label=time_label,
            loads=loads,
        ),
    ]


def _real_time_factor(log, out: Path, time_label: str, title: str) -> list[Path]:
    if log.diagnostics is None:
        print(
            "  no /diagnostics in the log (an offline run from sail-ros deploy has none): "
            "real-time factor not available"
        )
        return []
    stamps, values = log.diagnostics
    if key.REAL_TIME_FACTOR not in values:
        print("  /diagnostics has no real_time_factor value: real-time factor not available")
        return []
    t = log.seconds(stamps)
    factor = _floats(values[key.REAL_TIME_FACTOR])
    if key.REAL_TIME_FACTOR_WINDOW in values:  # 0: no measurement yet (the value reads 0)
        factor[_floats(values[key.REAL_TIME_FACTOR_WINDOW]) <= 0] = np.nan
    finite = factor[np.isfinite(factor)]
    if finite.size:
        print(
            f"  real-time factor: mean {finite.mean():.3g}, min {finite.min():.3g}, "
            f"max {finite.max():.3g} over {finite.size} diagnostics messages"
        )
    names = [name for name in DIAGNOSTIC_COLUMNS if name in values]
    names += sorted(set(values) - set(names))
    header = ["t_s", "stamp_ns", *names]
    columns = [t, stamps, *[values[name] for name in names]]
    return [
        _write_csv(out / "real_time_factor.csv", header, columns),
        real_time_factor_figure(
            t,
            factor,
            out / "real_time_factor.png",
            title=title,
            time_label=time_label,
            time_scale=_floats(values[key.TIME_SCALE]) if key.TIME_SCALE in values else None,
        ),
    ]


main = tool_main(build_parser, _report)
