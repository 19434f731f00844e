"""`sail-ros modes`: natural frequencies and mode shapes of the sail at fixed boom lengths.

Prints the frequencies with their multiplicities (seed Tab. 2 layout) and the
parameters used (with a free hub: its three rigid-body modes at 0 rad/s, and
each elastic group beside the clamped sail's group of the same shape); writes
them as CSV/JSON, the first distinct mode shapes as a figure (seed Fig. 2), and
with `--fem` compares the frequencies with the independent finite-element model
(`sail_ros.fem`) on a sequence of meshes.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from sail_ros.analysis.modes import fem_cross_check, representative_shapes
from sail_ros.analysis.modes_table import ModesTable, fem_csv_rows
from sail_ros.options import ToolParser, add_lengths_option
from sail_ros.tools.common import (
    add_sail_options,
    configuration,
    print_written,
    tool_main,
    write_csv_rows,
    write_text,
)
from sail_ros.tools.tables import describe_parameters

# Meshes of the FE cross-check, coarse to fine: (boom elements, membrane
# divisions per quadrant leg, Lagrange order). Halving the element size makes
# the spaces nested, so FE frequencies decrease monotonically; the finest
# (130 052 DOFs) solves in about 8 s on one core.
FEM_LEVELS = ((4, 4, 2), (8, 8, 2), (16, 16, 2), (32, 32, 2), (32, 64, 2), (64, 128, 2))
# Modal models of the cross-check, (n_B, n_M): the default and two refinements.
MODAL_COUNTS = ((4, 6), (10, 10), (20, 20))
FEM_COMPARED = 6  # frequencies compared, as in the seed's Tab. 2
EXAMPLES = (
    "sail-ros modes",
    "sail-ros modes --lengths 30 50 30 50 --figures out/modes --json out/modes/modes.json",
    "sail-ros modes --set n_boom_modes=10 --lengths 30 --csv out/modes_30m.csv",
    "sail-ros modes --fem --fem-csv out/fem_check.csv",
    "sail-ros modes --set free_hub=true --set hub_inertia_x=1e4 --set hub_inertia_y=1e4",
)
WRITES = (
    "--csv FILE (the listed frequencies), --json FILE (parameters, lengths, frequencies, "
    "the FE comparison), --fem-csv FILE (the FE comparison), --figures DIR: "
    "DIR/mode_shapes.png; each whole or not at all."
)
NOTES = """Lengths are the simulator's (within [min_length, max_length]; --set NAME=VALUE
changes the limits)."""


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("modes", __doc__.split("\n\n")[1], EXAMPLES, WRITES, NOTES)
    add_sail_options(parser)
    add_lengths_option(
        parser,
        "boom lengths [m]: one value for all booms or four (a b c d); "
        "default: fully deployed, a/sqrt(2)",
    )
    parser.add_argument("--count", type=int, default=12, help="frequencies to list (default 12)")
    output = parser.add_argument_group("output")
    output.add_argument(
        "--csv", type=Path, metavar="FILE", help="write the listed frequencies as CSV"
    )
    output.add_argument(
        "--json",
        type=Path,
        metavar="FILE",
        help="write parameters, lengths, frequencies (and the FE comparison) as JSON",
    )
    output.add_argument(
        "--figures",
        type=Path,
        metavar="DIR",
        help="write DIR/mode_shapes.png: the first distinct mode shapes",
    )
    output.add_argument(
        "--shapes", type=int, default=6, help="distinct mode shapes in the figure (default 6)"
    )
    output.add_argument(
        "--view",
        choices=("map", "3d"),
        default="map",
        help="mode shapes as filled contour maps seen from above (default) or 3-D surfaces",
    )
    fem = parser.add_argument_group("finite-element cross-check")
    fem.add_argument(
        "--fem",
        action="store_true",
        help="compare the lowest frequencies with the FE model at equal boom "
        "lengths, on a sequence of meshes",
    )
    fem.add_argument(
        "--fem-csv",
        type=Path,
        metavar="FILE",
        help="write the FE comparison (FE, modal, difference per frequency) as CSV",
    )
    fem.add_argument(
        "--fem-level",
        nargs=3,
        type=int,
        action="append",
        metavar=("NB", "ND", "ORDER"),
        help="an FE mesh: boom elements, membrane divisions per quadrant leg "
        "(a multiple of NB), order 1 or 2; repeat, coarse to fine "
        f"(default {' '.join(':'.join(map(str, lv)) for lv in FEM_LEVELS)})",
    )
    fem.add_argument(
        "--fem-modes",
        nargs=2,
        type=int,
        action="append",
        metavar=("NB", "NM"),
        help="modal mode counts n_B n_M to compare; repeat, small to large "
        f"(default {' '.join(':'.join(map(str, c)) for c in MODAL_COUNTS)})",
    )
    return parser


def _modes(args) -> int:
    config = configuration(args)
    params = config.sail
    lengths = config.per_boom(args.lengths or [params.full_boom_length], "--lengths")
    params = params.resolved(min(lengths))
    coordinates = params.coordinates
    if not 1 <= args.count <= coordinates:
        raise ValueError(
            f"--count must be in [1, {coordinates}] (the model's coordinates), got {args.count}"
        )
    if args.shapes < 1:
        raise ValueError(f"--shapes must be >= 1, got {args.shapes}")
    if args.fem_csv and not args.fem:
        raise ValueError(f"--fem-csv {args.fem_csv} needs --fem")
    if args.fem and len(set(lengths)) > 1:
        raise ValueError(f"--fem needs one length for all booms, got --lengths {lengths}")
    found = ModesTable.of(params, describe_parameters(params), lengths, args.count)
    print(found.text())
    if args.fem:
        fem_params = params.replace(sail_side=lengths[0] * np.sqrt(2.0))
        levels, counts = args.fem_level or FEM_LEVELS, args.fem_modes or MODAL_COUNTS
        found = dataclasses.replace(
            found, check=fem_cross_check(fem_params, levels, counts, FEM_COMPARED)
        )
        print(found.fem_text())

    written = []
    if args.csv:
        write_csv_rows(args.csv, found.rows())
        written.append(args.csv)
    if args.fem_csv:
        write_csv_rows(args.fem_csv, fem_csv_rows(found.check))
        written.append(args.fem_csv)
    if args.json:
        written.append(write_text(args.json, json.dumps(found.record(), indent=2) + "\n"))
    if args.figures:
        from sail_ros.plots.modes import mode_shapes_figure  # matplotlib only when drawing

        shapes = representative_shapes(found.model, found.modes, args.shapes)
        path = args.figures / "mode_shapes.png"
        written.append(
            mode_shapes_figure(found.model, found.modes.lengths, shapes, path, view=args.view)
        )
    print_written(written)
    return 0


main = tool_main(build_parser, _modes)
