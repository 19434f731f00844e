"""`sail-ros plant`: the sail as a linear plant at given boom lengths and rates.

Prints the poles (natural frequency [rad/s, Hz], damping ratio; with --json the
same as one JSON object), writes the matrices `A, B, C, D` of `xd = A x + B u`,
`y = C x + D u` (`x = [q; qd]`; inputs: 4 quadrant pressures [Pa], 4 tip forces
[N]; outputs: 4 tip deflections [m], 4 root moments [N m]; with a free hub 11
inputs and 14 outputs: the hub force [N] and torques [N m], the hub's heave [m],
tilts [rad] and their rates, which hold double integrators) with their names to
`.npz` and MATLAB `.mat`, and a Bode figure of each tip force to its own
boom's tip deflection and root moment (with a free hub also its force to its heave
and its torques to its tilts). The matrices load into python-control
with their names as `control.ss(A, B, C, D, inputs=list(input_names),
outputs=list(output_names))`.

With --controller, the hub's controller (docs/control.md) closes the loop on the
plant, every mode of it included: the discrete loop with its period and loop delay,
frozen at the lengths and rates given, or at every --every seconds of the deployment
of --scenario (whose `controller:` section is the design, changed by --set); it
prints the largest real part of the closed-loop poles at each and exits 1 when one is
in the right half-plane. --gains writes the controller's gain schedule for the node
`sail_control` (its parameter gains_file).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from sail_ros.analysis.plant import linear_plant, undamped_note
from sail_ros.analysis.plant_table import PlantTable
from sail_ros.model import SailModel
from sail_ros.options import ToolParser, add_lengths_option, paragraphs
from sail_ros.outputs import staged
from sail_ros.tools.common import (
    LIMITS_NOTE,
    add_sail_options,
    configuration,
    print_written,
    tool_main,
)
from sail_ros.tools.tables import describe_parameters

EXAMPLES = (
    "sail-ros plant --lengths 30",
    "sail-ros plant --controller --scenario config/scenario_free_hub_control.yaml",
    "sail-ros plant --controller --lengths 16 16 16 12 --set free_hub=true --set state_rate_hz=50",
    "sail-ros plant --controller --set free_hub=true --gains out/gains.npz",
    "sail-ros plant --lengths 20 22 20 22 --rates 0.1 --set mass_damping=0.02",
    "sail-ros plant --lengths 30 --npz out/plant.npz --mat out/plant.mat --figure out/bode.png",
    "sail-ros plant --lengths 30 --count 6 --json",
)
WRITES = (
    "--npz FILE and --mat FILE (A, B, C, D with the names and units of states, inputs and "
    "outputs), --figure PNG (the Bode figure), --gains FILE (the controller's gain "
    "schedule, .npz); each whole or not at all."
)


def build_parser() -> ToolParser:
    description = paragraphs(__doc__, 0, 1)
    parser = ToolParser.for_tool("plant", description, EXAMPLES, WRITES, LIMITS_NOTE)
    add_sail_options(parser)
    add_lengths_option(
        parser, "boom lengths [m]: one for all booms or four (a b c d); default: fully deployed"
    )
    parser.add_argument(
        "--rates",
        type=float,
        nargs="+",
        default=[0.0],
        metavar="LD",
        help="constant extension rates [m/s], one or four (default 0)",
    )
    parser.add_argument("--count", type=int, default=12, help="poles to list (default 12)")
    output = parser.add_argument_group("output")
    output.add_argument(
        "--json", action="store_true",
        help="print one JSON object (lengths, rates, sizes, parameters, the listed poles, "
        "the notes; NaN as null) instead of the text; the files asked for are still written",
    )  # fmt: skip
    output.add_argument("--npz", type=Path, metavar="FILE", help="write the plant as .npz")
    output.add_argument("--mat", type=Path, metavar="FILE", help="write the plant as MATLAB .mat")
    output.add_argument("--figure", type=Path, metavar="PNG", help="write the Bode figure")
    output.add_argument(
        "--band",
        type=float,
        nargs=2,
        metavar=("F_MIN", "F_MAX"),
        help="Bode frequency band [Hz] (default: a decade below the first pole to a decade "
        "above the listed ones, and on past a resonance there)",
    )
    loop = parser.add_argument_group("closed loop (docs/control.md)")
    loop.add_argument(
        "--controller", action="store_true",
        help="close the loop with the hub's controller (free hub) and print the largest real "
        "part of its poles; --set takes the controller's fields too (weight_tilt=1e5, "
        "state_rate_hz=50, ...)",
    )  # fmt: skip
    loop.add_argument(
        "--scenario", type=Path, metavar="YAML",
        help="with --controller: check at every --every seconds of this scenario's deployment "
        "(its sail and controller sections apply)",
    )  # fmt: skip
    loop.add_argument(
        "--every", type=float, default=0.25, help="with --scenario: the spacing of the checked "
        "times [s] (0.25)",
    )  # fmt: skip
    loop.add_argument(
        "--gains", type=Path, metavar="FILE", help="with --controller: write the gain schedule "
        "(.npz) for sail_control's gains_file",
    )  # fmt: skip
    return parser


def _plant(args) -> int:
    if args.controller:
        from sail_ros.tools.loop_check import check_loop

        if args.json:
            raise ValueError("--json prints the open plant; it does not go with --controller")
        return check_loop(args)
    if args.scenario or args.gains:
        raise ValueError("--scenario and --gains go with --controller")
    config = configuration(args)
    params = config.sail
    lengths = config.per_boom(args.lengths or [params.full_boom_length], "--lengths")
    lengths = lengths[0] if len(lengths) == 1 else lengths
    if len(args.rates) not in (1, 4):
        raise ValueError(f"--rates takes 1 or 4 values, got {len(args.rates)}")
    rates = config.check(config.policy.check_rates, args.rates * (4 // len(args.rates)), "--rates")
    params = params.resolved(float(np.min(lengths)))
    model = SailModel(params)
    if not 1 <= args.count <= 2 * model.n:
        raise ValueError(f"--count must be in [1, {2 * model.n}], got {args.count}")
    if args.band is not None and not 0 < args.band[0] < args.band[1]:
        raise ValueError(f"--band needs 0 < F_MIN < F_MAX [Hz], got {args.band}")
    plant = linear_plant(model, lengths, rates)
    found = PlantTable.of(plant, params, describe_parameters(params), args.count)
    if not args.json:
        print(found.text())
    note = undamped_note(plant)
    if note:
        print(f"warning: {note}", file=sys.stderr)

    written = []
    if args.npz:
        with staged(args.npz, "--npz") as building, building.open("wb") as stream:
            np.savez(stream, **plant.arrays())  # a stream: the name as given, no ".npz" added
        written.append(args.npz)
    if args.mat:
        import scipy.io

        arrays = plant.arrays()
        for key in ("input_names", "input_units", "output_names", "output_units", "state_names"):
            arrays[key] = np.array(arrays[key], dtype=object)  # MATLAB cell arrays of text
        with staged(args.mat, "--mat") as building, building.open("wb") as stream:
            scipy.io.savemat(stream, arrays)
        written.append(args.mat)
    if args.figure:
        from sail_ros.plots.plant import plant_figure  # matplotlib only when drawing

        written.append(plant_figure(plant, params, found.listed, args.figure, args.band))
    if args.json:
        print(json.dumps(found.to_json(), indent=2))
    else:
        print_written(written)
    return 0


main = tool_main(build_parser, _plant)
