"""`sail-ros modes`: natural frequencies and mode shapes of the sail at fixed boom lengths.

Prints the frequencies with their multiplicities (seed Tab. 2 layout) and the
parameters used (with a free hub: its three rigid-body modes at 0 rad/s, and
each elastic group beside the clamped sail's group of the same shape); writes
them as CSV/JSON, the first distinct mode shapes as a figure (seed Fig. 2), and
with `--fem` compares the frequencies with the independent finite-element model
(`sail_ros.fem`) on a sequence of meshes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sail_ros.analysis.modes import (
    clamped_counterparts,
    fem_cross_check,
    group_multiplicities,
    modal_analysis,
    representative_shapes,
)
from sail_ros.model import SailModel
from sail_ros.options import ToolParser
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
AGREEMENT_PERCENT = 1.0
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


def damping_ratios(params, omega: np.ndarray) -> np.ndarray | None:
    """Rayleigh damping ratios `alpha / (2 omega) + beta omega / 2` of the modes at
    rest (model.md §12; NaN for a free hub's rigid-body modes, which do not oscillate);
    None for an undamped sail."""
    alpha, beta = params.mass_damping, params.stiffness_damping
    if alpha == 0.0 and beta == 0.0:
        return None
    with np.errstate(divide="ignore"):
        zeta = alpha / (2.0 * np.abs(omega)) + beta * np.abs(omega) / 2.0
    return np.where(omega == 0.0, np.nan, zeta)


def frequency_table(
    omega: np.ndarray, count: int, zeta: np.ndarray | None = None, counterparts=None
) -> str:
    """Rows `mode(s)  omega [rad/s]  f [Hz]  period [s]  multiplicity` (and the damping
    ratio when `zeta` is given) for the first `count` frequencies (whole groups); with
    `counterparts` (a free hub's `clamped_counterparts`) the clamped sail's group of the
    same shape beside each elastic group: its modes, frequency, the change to the free
    hub's and how much of the shape they share."""
    lines = [f"  {'mode':<8}{'omega [rad/s]':>15}{'f [Hz]':>12}{'period [s]':>12}  multiplicity"]
    if zeta is not None:
        lines[0] += f"{'zeta':>10}"
    beside = {}
    if counterparts is not None:
        lines[0] += f"  {'clamped':<8}{'omega [rad/s]':>15}{'change [%]':>12}{'shape share':>13}"
        for pair in counterparts:
            label = _label(pair.clamped_first, pair.clamped_multiplicity)
            change = 100.0 * (omega[pair.free_first] / pair.omega - 1.0)
            beside[pair.free_first] = (
                f"  {label:<8}{pair.omega:15.5f}{change:+12.2f}{pair.share:13.3f}"
            )
    for first, multiplicity in group_multiplicities(omega):
        if first >= count:
            break
        label = f"{first + 1}" if multiplicity == 1 else f"{first + 1}-{first + multiplicity}"
        value = omega[first]
        period = f"{2 * np.pi / value:12.2f}" if value > 0 else f"{'divergent':>12}"
        if value == 0.0:  # a free hub's rigid-body modes
            period = f"{'rigid':>12}"
        hertz = value / (2 * np.pi)
        line = f"  {label:<8}{value:15.5f}{hertz:12.6f}{period}  {multiplicity:<12}"
        if zeta is not None:
            line += f"{'-':>10}" if np.isnan(zeta[first]) else f"{zeta[first]:10.4g}"
        line += beside.get(first, "")
        lines.append(line.rstrip())
    return "\n".join(lines)


def frequency_rows(
    omega: np.ndarray, count: int, zeta: np.ndarray | None = None, counterparts=None
) -> list[dict]:
    """One record per frequency (the first `count`, whole groups): mode number,
    omega [rad/s], f [Hz], period [s] (None if divergent or rigid), distinct-frequency
    group and its multiplicity, the damping ratio when `zeta` is given (None for a rigid
    mode), and with `counterparts` the clamped group of the same shape (its first mode,
    omega [rad/s], shape share; None for a rigid mode)."""
    paired = {pair.free_first: pair for pair in counterparts or ()}
    rows = []
    for group, (first, multiplicity) in enumerate(group_multiplicities(omega), start=1):
        if first >= count:
            break
        for index in range(first, first + multiplicity):
            value = float(omega[index])
            rows.append(
                {
                    "mode": index + 1,
                    "omega_rad_s": value,
                    "frequency_hz": value / (2 * np.pi),
                    "period_s": 2 * np.pi / value if value > 0 else None,
                    "group": group,
                    "multiplicity": multiplicity,
                    **({"damping_ratio": _number(zeta[index])} if zeta is not None else {}),
                }
            )
            if counterparts is not None:
                pair = paired.get(first)
                rows[-1] |= {
                    "clamped_mode": pair.clamped_first + 1 if pair else None,
                    "clamped_omega_rad_s": pair.omega if pair else None,
                    "shape_share": pair.share if pair else None,
                }
    return rows


def _label(first: int, multiplicity: int) -> str:
    return f"{first + 1}" if multiplicity == 1 else f"{first + 1}-{first + multiplicity}"


def moved_note(omega, count: int, counterparts, clamped) -> str:
    """One line naming the clamped groups within the listed frequencies that no listed
    free-hub group is beside, and where the free hub moved each (or "")."""
    listed = [first for first, _ in group_multiplicities(omega) if first < count]
    highest = omega[listed[-1]]
    beside = {p.clamped_first for p in counterparts if p.free_first in listed}
    moved = []
    for first, multiplicity in clamped.groups:
        if clamped.omega[first] > highest:
            break
        if first in beside:
            continue
        text = f"{_label(first, multiplicity)} ({clamped.omega[first]:.5f} rad/s)"
        found = [p for p in counterparts if p.clamped_first == first]
        if found:
            free_first = found[0].free_first
            free_count = dict(group_multiplicities(omega))[free_first]
            text += (
                f" is free-hub mode {_label(free_first, free_count)} "
                f"({omega[free_first]:.5f} rad/s)"
            )
        moved.append(text)
    if not moved:
        return ""
    return (
        "  clamped modes the free hub moved beyond the listed ones (the hub moves with "
        f"them): {'; '.join(moved)}"
    )


def _number(value) -> float | None:
    return None if np.isnan(value) else float(value)


def cross_check_table(check) -> str:
    """The FE comparison in the seed's Tab. 2 layout, then both refinement tables."""
    k = check.count
    fem_settings = check.fem_levels[-1][0]
    n_boom, n_membrane = check.modal_levels[-1][:2]
    header = "  " + f"{'Modal frequency':<22}" + "".join(f"{f'w{i + 1}':>10}" for i in range(k))
    lines = [
        f"  FE:    {fem_settings['description']}",
        f"  modal: n_B = {n_boom}, n_M = {n_membrane} ({4 * n_boom + 4 * n_membrane} coordinates)",
        "",
        header,
        "  " + f"{'FE (rad/s)':<22}" + "".join(f"{v:10.5f}" for v in check.fem),
        "  " + f"{'Modal (rad/s)':<22}" + "".join(f"{v:10.5f}" for v in check.modal),
        # + 0.0 turns a rounded -0.000 into +0.000
        "  "
        + f"{'Difference (%)':<22}"
        + "".join(f"{round(v, 3) + 0.0:+10.3f}" for v in check.difference_percent),
        "",
        f"  FE mesh refinement: lowest {k} frequencies [rad/s]",
        f"  {'NB':>4}{'ND':>5}{'order':>6}{'DOFs':>8}{'time [s]':>10}  "
        + "".join(f"{f'w{i + 1}':>11}" for i in range(k)),
    ]
    for settings, omega in check.fem_levels:
        lines.append(
            f"  {settings['boom_elements']:>4}{settings['membrane_divisions']:>5}"
            f"{settings['membrane_order']:>6}{settings['n_dofs']:>8}"
            f"{settings['seconds']:>10.2f}  " + "".join(f"{v:11.7f}" for v in omega)
        )
    lines += [
        "",
        f"  Modal refinement: lowest {k} frequencies [rad/s]",
        f"  {'n_B':>4}{'n_M':>5}{'coords':>8}{'time [s]':>10}       "
        + "".join(f"{f'w{i + 1}':>11}" for i in range(k)),
    ]
    for n_boom, n_membrane, seconds, omega in check.modal_levels:
        lines.append(
            f"  {n_boom:>4}{n_membrane:>5}{4 * n_boom + 4 * n_membrane:>8}"
            f"{seconds:>10.2f}       " + "".join(f"{v:11.7f}" for v in omega)
        )
    worst = float(np.max(np.abs(check.difference_percent)))
    verdict = "agree" if worst <= AGREEMENT_PERCENT else "DISAGREE"
    lines += [
        "",
        f"  largest |difference| over the first {k}: {worst:.3f} % "
        f"({verdict} within {AGREEMENT_PERCENT:g} %)",
    ]
    return "\n".join(lines)


def cross_check_record(check) -> dict:
    """The FE comparison as plain data for JSON."""
    return {
        "compared": check.count,
        "fem": [float(v) for v in check.fem],
        "modal": [float(v) for v in check.modal],
        "difference_percent": [float(v) for v in check.difference_percent],
        "fem_levels": [
            {**settings, "omega_rad_s": [float(v) for v in omega]}
            for settings, omega in check.fem_levels
        ],
        "modal_levels": [
            {
                "n_boom_modes": nb,
                "n_membrane_modes": nm,
                "seconds": seconds,
                "omega_rad_s": [float(v) for v in omega],
            }
            for nb, nm, seconds, omega in check.modal_levels
        ],
    }


def _fem_csv_rows(check) -> list[dict]:
    return [
        {
            "mode": i + 1,
            "fem_rad_s": float(f),
            "modal_rad_s": float(m),
            "difference_percent": float(d),
        }
        for i, (f, m, d) in enumerate(
            zip(check.fem, check.modal, check.difference_percent, strict=True)
        )
    ]


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool("modes", __doc__.split("\n\n")[1], EXAMPLES, WRITES, NOTES)
    add_sail_options(parser)
    parser.add_argument(
        "--lengths",
        type=float,
        nargs="+",
        metavar="L",
        help="boom lengths [m]: one value for all booms or four (a b c d); "
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
    coordinates = 4 * (params.n_boom_modes + params.membrane_modes) + 3 * params.free_hub
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
    model = SailModel(params)
    modes = modal_analysis(model, lengths[0] if len(lengths) == 1 else lengths)
    omega = modes.omega
    shown = ", ".join(f"{v:.4g}" for v in lengths)
    print(f"Natural frequencies of the sail, boom lengths {shown} m, at rest")
    print(describe_parameters(params))
    print()
    zeta = damping_ratios(params, omega)
    counterparts = None
    if model.free_hub:
        clamped_model = SailModel(params.replace(free_hub=False))
        clamped = modal_analysis(clamped_model, modes.lengths)
        counterparts = clamped_counterparts(model, modes, clamped_model, clamped)
        print(
            "  free hub: three rigid-body modes at exactly 0 rad/s (heave, tilts about x and "
            "y); beside each elastic group, the group of the same sail with the hub clamped "
            "(free_hub = false) that holds most of its shape (shape share: 1 = the same)"
        )
    print(frequency_table(omega, args.count, zeta, counterparts))
    if counterparts is not None:
        note = moved_note(omega, args.count, counterparts, clamped)
        if note:
            print(note)

    check = None
    if args.fem:
        fem_params = params.replace(sail_side=lengths[0] * np.sqrt(2.0))
        check = fem_cross_check(
            fem_params, args.fem_level or FEM_LEVELS, args.fem_modes or MODAL_COUNTS, FEM_COMPARED
        )
        print()
        print(
            f"Independent finite-element cross-check (seed Tab. 2 layout), L = "
            f"{lengths[0]:.4g} m, physical parameters above"
        )
        print(cross_check_table(check))

    written = []
    rows = frequency_rows(omega, args.count, zeta, counterparts)
    if args.csv:
        write_csv_rows(args.csv, rows)
        written.append(args.csv)
    if args.fem_csv:
        write_csv_rows(args.fem_csv, _fem_csv_rows(check))
        written.append(args.fem_csv)
    if args.json:
        record = {
            "parameters": params.to_dict(),
            "lengths_m": list(modes.lengths),
            "frequencies": rows,
        }
        if check is not None:
            record["fem_cross_check"] = cross_check_record(check)
        written.append(write_text(args.json, json.dumps(record, indent=2) + "\n"))
    if args.figures:
        from sail_ros.plots.modes import mode_shapes_figure  # matplotlib only when drawing

        shapes = representative_shapes(model, modes, args.shapes)
        written.append(
            mode_shapes_figure(
                model, modes.lengths, shapes, args.figures / "mode_shapes.png", view=args.view
            )
        )
    print_written(written)
    return 0


main = tool_main(build_parser, _modes)
