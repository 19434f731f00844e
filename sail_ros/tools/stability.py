"""`sail-ros stability`: frozen-length stability against membrane prestress and extension rate.

For every boom length and extension rate (deployment > 0, retraction < 0),
the largest real part of the seed's Eq. 3 eigenvalues over a log-spaced
prestress grid, and the critical prestress below which the frozen system is
unstable (bracketed on the grid, then bisected), and per length the critical
prestress against the rate. Each (length, rate) is one case on Dask: a local
cluster by default, an existing one with --scheduler. See
`sail_ros.analysis.stability` for the physics and the numerical instability
threshold.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from sail_ros.analysis.stability import stability_sweep
from sail_ros.analysis.stability_table import FIGURES, StabilityTable
from sail_ros.options import ToolParser, add_lengths_option
from sail_ros.policy import Policy
from sail_ros.tools.cluster import add_cluster_options, check_cluster_options, dask_client
from sail_ros.tools.common import (
    LIMITS_NOTE,
    add_sail_options,
    configuration,
    print_written,
    tool_main,
    write_csv_rows,
)
from sail_ros.tools.tables import describe_parameters

DEFAULT_RATES = (-1.0, -0.3, -0.1, -0.03, -0.01, 0.0, 0.01, 0.03, 0.1, 0.3, 1.0)
DEFAULT_PRESTRESS = (1e-2, 1e5)  # Pa
POINTS_PER_DECADE = 8
EXAMPLES = (
    "sail-ros stability",
    "sail-ros stability --lengths 10 35 70.71 --rates -0.1 0.1 1 --figures out/stability "
    "--csv out/stability/critical.csv",
    "sail-ros stability --lengths 20 40 70.71 --workers 2 --grid-csv out/stability_grid.csv",
    "sail-ros stability --lengths 20 40 70.71 --scheduler tcp://10.0.0.5:8786",
)
WRITES = (
    "--csv FILE (critical prestress per length and rate), --grid-csv FILE (every grid "
    "point), --figures DIR: DIR/stability.png (max Re against prestress), "
    "DIR/stability_map.png (stable and unstable over rate x prestress, the critical "
    "prestress of each length), DIR/eigenvalue_loci.png; each whole or not at all."
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool(
        "stability", __doc__.split("\n\n")[1], EXAMPLES, WRITES, LIMITS_NOTE
    )
    add_sail_options(parser)
    grid = parser.add_argument_group("grid")
    add_lengths_option(grid, "boom lengths [m], all booms alike (default: fully deployed)")
    grid.add_argument(
        "--rates",
        type=float,
        nargs="+",
        metavar="RATE",
        default=list(DEFAULT_RATES),
        help="extension rates [m/s], > 0 deployment, < 0 retraction "
        f"(default {' '.join(f'{r:g}' for r in DEFAULT_RATES)})",
    )
    grid.add_argument(
        "--prestress",
        type=float,
        nargs=2,
        metavar=("MIN", "MAX"),
        default=list(DEFAULT_PRESTRESS),
        help="prestress range [Pa], log-spaced (default 0.01 1e5)",
    )
    grid.add_argument(
        "--points", type=int, help=f"prestress grid points (default {POINTS_PER_DECADE} per decade)"
    )
    add_cluster_options(parser)
    output = parser.add_argument_group("output")
    output.add_argument(
        "--csv",
        type=Path,
        metavar="FILE",
        help="write the critical prestress per length and rate as CSV",
    )
    output.add_argument(
        "--grid-csv",
        type=Path,
        metavar="FILE",
        help="write max Re and max |lambda| at every grid point as CSV",
    )
    output.add_argument(
        "--figures",
        type=Path,
        metavar="DIR",
        help=f"write {', '.join('DIR/' + name for name in FIGURES)}",
    )
    output.add_argument(
        "--loci-rate",
        type=float,
        metavar="RATE",
        help="rate [m/s] of the eigenvalue loci, at the first length "
        "(default: the fastest deployment rate)",
    )
    return parser


def _stability(args) -> int:
    check_cluster_options(args.scheduler, args.workers)
    config = configuration(args)
    params = config.sail
    lengths = args.lengths or [params.full_boom_length]
    for length in lengths:
        config.check(config.policy.check_length, length, "--lengths", params)
    for rate in args.rates:
        config.check(config.policy.check_rate, rate, "--rates")
    low, high = args.prestress
    if not 0 < low < high:
        raise ValueError(f"--prestress needs 0 < MIN < MAX [Pa], got {low:g} {high:g}")
    points = args.points
    if points is None:
        points = int(round(POINTS_PER_DECADE * np.log10(high / low))) + 1
    if points < 2:
        raise ValueError(f"--points must be >= 2, got {points}")
    total = len(lengths) * len(args.rates) * points
    n = 4 * (params.n_boom_modes + params.resolved(min(lengths)).membrane_modes)
    # per point: prestress, max Re, max |lambda|, unstable; the loci: 2n eigenvalues
    fewer = "fewer --points, --lengths or --rates"
    Policy.check_output(total, 4 * 8, "the stability grid", fewer)
    Policy.check_output(points, 2 * n * 16, "the eigenvalue loci", fewer)
    prestresses = np.logspace(np.log10(low), np.log10(high), points)
    bar = tqdm(total=total, unit="pt", disable=None, leave=False, file=sys.stderr)
    with dask_client(args.scheduler, args.workers) as client, bar:
        sweeps = stability_sweep(
            params, lengths, args.rates, prestresses, client=client, progress=bar.update
        )
    table = StabilityTable.of(
        params, describe_parameters(params), lengths, args.rates, prestresses, sweeps
    )
    print(table.text())

    written = []
    if args.csv:
        write_csv_rows(args.csv, table.rows)
        written.append(args.csv)
    if args.grid_csv:
        write_csv_rows(args.grid_csv, table.grid_rows())
        written.append(args.grid_csv)
    if args.figures:
        from sail_ros.plots.stability import stability_figures  # matplotlib only when drawing

        written += stability_figures(table, args.figures, args.loci_rate)
    print_written(written)
    return 0


main = tool_main(build_parser, _stability)
