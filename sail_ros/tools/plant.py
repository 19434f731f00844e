"""`sail-ros plant`: the sail as a linear plant at given boom lengths and rates.

Prints the poles (natural frequency [rad/s, Hz], damping ratio), writes the
matrices `A, B, C, D` of `xd = A x + B u`, `y = C x + D u` (`x = [q; qd]`;
inputs: 4 quadrant pressures [Pa], 4 tip forces [N]; outputs: 4 tip
deflections [m], 4 root moments [N m]; with a free hub 11 inputs and 14
outputs: the hub force [N] and torques [N m], the hub's heave [m], tilts
[rad] and their rates, which hold double integrators) with their names to
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

import sys
from pathlib import Path

import numpy as np

from sail_ros.analysis.plant import (
    bode_band,
    bode_grid,
    bode_pairs,
    frequency_response,
    hub_note,
    linear_plant,
    poles,
    undamped_note,
    undamped_shown,
)
from sail_ros.model import SailModel
from sail_ros.options import ToolParser, paragraphs
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
)
WRITES = (
    "--npz FILE and --mat FILE (A, B, C, D with the names and units of states, inputs and "
    "outputs), --figure PNG (the Bode figure), --gains FILE (the controller's gain "
    "schedule, .npz); each whole or not at all."
)


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool(
        "plant",
        paragraphs(__doc__, 0, 1),
        EXAMPLES,
        WRITES,
        LIMITS_NOTE,
    )
    add_sail_options(parser)
    parser.add_argument(
        "--lengths",
        type=float,
        nargs="+",
        metavar="L",
        help="boom lengths [m]: one for all booms or four (a b c d); default: fully deployed",
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
    listed = poles(plant)[: args.count]
    print(
        f"Linear plant of the sail: lengths {', '.join(f'{v:.4g}' for v in plant.lengths)} m, "
        f"rates {', '.join(f'{v:.4g}' for v in plant.rates)} m/s; {len(plant.state_names)} "
        f"states, {len(plant.input_names)} inputs, {len(plant.output_names)} outputs"
    )
    print(describe_parameters(params))
    print()
    print(f"  {'pole':>5}{'Re s [1/s]':>14}{'Im s [rad/s]':>14}{'omega [rad/s]':>15}"
          f"{'f [Hz]':>12}{'zeta':>12}")  # fmt: skip
    for i, pole in enumerate(listed, start=1):
        # round-off of an undamped plant reads as 0, not as +-1e-16
        tiny = abs(pole.s.real) < 1e-12 * max(pole.omega, 1.0)
        real, zeta = (0.0, 0.0) if tiny else (pole.s.real, pole.zeta)
        print(
            f"  {i:>5}{real:>14.5g}{pole.s.imag:>14.6g}{pole.omega:>15.6g}"
            f"{pole.hertz:>12.5g}{zeta:>12.4g}"
        )
    unstable = [p for p in poles(plant) if p.s.real > 1e-9 * max(p.omega, 1.0)]
    if unstable:
        print(f"  {len(unstable)} pole(s) with a positive real part: the frozen plant is unstable")
    if plant.free_hub:
        print(f"  note: {hub_note(plant)}")
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
        from sail_ros.plots.plant import bode_figure  # matplotlib only when drawing

        pairs = bode_pairs(plant)
        low, high = args.band or bode_band(plant, pairs, listed)
        omega = bode_grid(plant, pairs, low, high)
        undamped = undamped_shown(plant, pairs, low, high)
        count = len({f for found in undamped.values() for f in found})
        title = (
            f"lengths {', '.join(f'{v:.4g}' for v in plant.lengths)} m, n_B = "
            f"{params.n_boom_modes}, n_M = {params.membrane_modes}, alpha = "
            f"{params.mass_damping:g} 1/s, beta = {params.stiffness_damping:g} s"
        )
        if count:
            title += (
                f"\nundamped: {count} poles that show here (v, along the top) lie on the "
                "imaginary axis, where |G| is unbounded: the lines are drawn to within 1e-4 of "
                "them and break there"
            )
        written.append(
            bode_figure(
                omega, frequency_response(plant, omega), plant, args.figure, title, marked=undamped
            )  # fmt: skip
        )
    print_written(written)
    return 0


main = tool_main(build_parser, _plant)
