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

from sail_ros.analysis.stability import (
    CRITICAL,
    INSTABILITY_RTOL,
    STABLE,
    UNSTABLE,
    eigenvalue_loci,
    growth,
    stability_sweep,
)
from sail_ros.options import ToolParser
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
FIGURES = ("stability.png", "stability_map.png", "eigenvalue_loci.png")
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
    grid.add_argument(
        "--lengths",
        type=float,
        nargs="+",
        metavar="L",
        help="boom lengths [m], all booms alike (default: fully deployed)",
    )
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


def _describe(sweep) -> str:
    if sweep.status == STABLE:
        return "stable at every prestress"
    if sweep.status == UNSTABLE:
        return "unstable at every prestress"
    text = f"{sweep.critical_prestress:.4g}"
    return text if sweep.monotone else text + " (stability windows below)"


def _critical_rows(sweeps, params) -> list[dict]:
    rows = []
    for sweep in sweeps:
        max_real, max_abs = growth(params, sweep.length, sweep.rate, params.membrane_prestress)
        rows.append(
            {
                "length_m": sweep.length,
                "rate_m_s": sweep.rate,
                "status": sweep.status,
                "critical_prestress_pa": sweep.critical_prestress,
                "critical_tension_n_m": (
                    None
                    if sweep.critical_prestress is None
                    else sweep.critical_prestress * params.membrane_thickness
                ),
                "monotone": sweep.monotone,
                "max_real_at_sail_prestress_1_s": max_real,
                "max_abs_at_sail_prestress_1_s": max_abs,
            }
        )
    return rows


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
    rows = _critical_rows(sweeps, params)

    print(
        "Frozen-length stability (seed Eq. 3): constant rate, all booms alike; "
        "the prestress is varied"
    )
    print(describe_parameters(params))
    print(
        f"  grid: {points} prestresses {low:g}..{high:g} Pa (log-spaced) x "
        f"{len(args.rates)} rates x {len(lengths)} length(s) = {total} points"
    )
    print(f"  unstable when max Re(lambda) > {INSTABILITY_RTOL:g} max |lambda|")
    print()
    sail = f"sigma = {params.membrane_prestress:g} Pa"
    print(
        f"  {'L [m]':>7}{'rate [m/s]':>12}  {'critical prestress [Pa]':<32}max Re at {sail} [1/s]"
    )
    for row, sweep in zip(rows, sweeps, strict=True):
        rate = f"{row['rate_m_s']:+.3g}" if row["rate_m_s"] else "0"
        print(
            f"  {row['length_m']:7.4g}{rate:>12}  {_describe(sweep):<32}"
            f"{row['max_real_at_sail_prestress_1_s']:+.3e}"
        )
    print()
    print("  critical prestress: the frozen system is unstable below it and stable above it;")
    print(
        "  retraction (rate < 0) turns the Md term into negative damping: unstable at any "
        "prestress."
    )

    written = []
    if args.csv:
        write_csv_rows(args.csv, rows)
        written.append(args.csv)
    if args.grid_csv:
        write_csv_rows(
            args.grid_csv,
            [
                {
                    "length_m": s.length,
                    "rate_m_s": s.rate,
                    "prestress_pa": float(p),
                    "max_real_1_s": float(r),
                    "max_abs_1_s": float(a),
                    "unstable": bool(u),
                }
                for s in sweeps
                for p, r, a, u in zip(s.prestress, s.max_real, s.max_abs, s.unstable, strict=True)
            ],
        )
        written.append(args.grid_csv)
    if args.figures:
        from sail_ros.plots.stability import loci_figure, map_figure, max_real_figure

        real_path, map_path, loci_path = (args.figures / name for name in FIGURES)
        written.append(max_real_figure(sweeps, real_path, params.membrane_prestress))
        written.append(map_figure(sweeps, map_path, params.membrane_prestress))
        deploying = [r for r in args.rates if r > 0]
        rate = (
            args.loci_rate
            if args.loci_rate is not None
            else (max(deploying) if deploying else max(args.rates, key=abs))
        )
        length = float(lengths[0])
        critical = next(
            (
                s.critical_prestress
                for s in sweeps
                if s.length == length and s.rate == rate and s.status == CRITICAL
            ),
            None,
        )
        loci = eigenvalue_loci(params, length, rate, prestresses)
        written.append(loci_figure(prestresses, loci, length, rate, loci_path, critical))
    print_written(written)
    return 0


main = tool_main(build_parser, _stability)
