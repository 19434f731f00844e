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
`--json` prints what the text says as one JSON object (SI units, NaN as null); the files
are written all the same.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

from sail_ros.analysis.log_report import LogReport, log_report
from sail_ros.analysis.log_series import read_log
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
from sail_ros.policy import Policy
from sail_ros.tools.common import (
    add_sail_options,
    configuration,
    print_written,
    set_values,
    tool_main,
)
from sail_ros.tools.report_result import ReportResult

EXAMPLES = (
    "sail-ros deploy --t-end 6 --rate 25 --mcap out/short.mcap",
    "sail-ros report out/short.mcap --out out/short_report",
    "sail-ros report out/short.mcap --out out/short_report --no-convergence",
    "sail-ros report out/short.mcap --out out/short_report --json",
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
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the report as one JSON object instead of text (the files are written "
        "all the same)",
    )
    add_sail_options(parser)  # used only when the log has no recorded parameters
    return parser


def _report(args) -> int:
    if not args.log.exists():
        raise ValueError(f"log {str(args.log)!r} does not exist")
    # --config and --set are read (and checked) whether or not the log's own parameters
    # leave them unused: a mistyped name or a missing file is an error, not nothing
    given = configuration(args).sail
    limits = {k: v for k, v in set_values(args).items() if k in Policy.field_names()}
    log = read_log(args.log, args.namespace)
    found = log_report(log, given, limits, not args.no_convergence, args.namespace)
    result = ReportResult(args.log, found)
    if not args.json:
        result.print_text()
    out = args.out or Path(f"{args.log.stem if args.log.is_file() else args.log.name}_report")
    with staged(out, "--out") as folder:
        folder.mkdir()
        for name, (header, columns) in found.tables().items():
            _write_csv(folder / name, header, columns)
        _figures(found, folder)
        written = sorted(path.relative_to(folder) for path in folder.rglob("*") if path.is_file())
    written = [out / path for path in written]
    if args.json:
        print(json.dumps(result.to_json(written), indent=2, allow_nan=False))
        for line in result.warnings():
            print(line, file=sys.stderr)
    else:
        print_written(written)
    if found.stopped:
        print(f"error: {found.stopped}; the report holds the rest", file=sys.stderr)
        return 1
    return 0


def _write_csv(path: Path, header: list[str], columns) -> Path:
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows(zip(*columns, strict=True))
    return path


def _figures(found: LogReport, folder: Path) -> None:
    """The figures of the time histories the log holds (`plots.histories`, and
    `plots.control` for a free hub's commands against its states)."""
    log, labels = found.log, {"title": found.title, "time_label": found.time_label}
    if log.tips is not None:
        t = log.seconds(log.tips.stamp_ns)
        tip_deflections_figure(t, log.tips.position, folder / "tip_deflections.png",
                               loads=found.loads, **labels)  # fmt: skip
    if log.moments is not None and log.moments.effort.size:
        t = log.seconds(log.moments.stamp_ns)
        modes = found.recorded.n_boom_modes if found.recorded else None
        root_moments_figure(t, log.moments.effort, folder / "root_moments.png",
                            n_boom_modes=modes, loads=found.loads, **labels)  # fmt: skip
    if log.boom is not None:
        t = log.seconds(log.boom.stamp_ns)
        boom_lengths_figure(t, log.boom.position, log.boom.velocity,
                            folder / "boom_lengths.png", **labels)  # fmt: skip
    if log.hub is not None:
        t = log.seconds(log.hub[0])
        hub_attitude_figure(t, log.hub[1], found.holds, folder / "hub_attitude.png", **labels)
        if log.hub_commands is not None:
            from sail_ros.plots.control import commands_figure

            # the commands at the stamps of the samples they answer; a zero wrench of a
            # stale or stopping controller answers none
            stamps, _, wrench = log.hub_commands
            answered = stamps > 0
            commands_figure(t, log.hub[1], log.seconds(stamps[answered]), wrench[answered],
                            folder / "hub_commands.png", **labels)  # fmt: skip
    if found.energies is not None:
        energies, groups = found.energies, found.energies.groups
        energies_figure(energies.t, groups.booms, groups.quadrants, groups.total,
                        folder / "modal_energies.png", loads=found.loads, **labels)  # fmt: skip
    if found.realtime is not None:
        realtime = found.realtime
        real_time_factor_figure(realtime.t, realtime.factor, folder / "real_time_factor.png",
                                time_scale=realtime.time_scale, **labels)  # fmt: skip


main = tool_main(build_parser, _report)
