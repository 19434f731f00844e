"""`sail-ros modes`: natural frequencies of the sail at fixed boom lengths.

Prints the frequencies with their multiplicities (seed Tab. 2 layout) and the
parameters used.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from sail_ros.model import SailModel
from sail_ros.tools.common import add_sail_options, describe_parameters, run, sail_parameters


def group_multiplicities(omega: np.ndarray, rtol: float = 1e-6) -> list[tuple[int, int]]:
    """(first index, multiplicity) of each group of equal frequencies, ascending."""
    groups = []
    for i, value in enumerate(omega):
        if groups and abs(value - omega[groups[-1][0]]) <= rtol * abs(value):
            groups[-1][1] += 1
        else:
            groups.append([i, 1])
    return [(first, count) for first, count in groups]


def frequency_table(omega: np.ndarray, count: int) -> str:
    """Rows `mode(s)  omega [rad/s]  f [Hz]  period [s]  multiplicity` for the first
    `count` frequencies (whole groups)."""
    lines = [f"  {'mode':<8}{'omega [rad/s]':>15}{'f [Hz]':>12}{'period [s]':>12}  multiplicity"]
    for first, multiplicity in group_multiplicities(omega):
        if first >= count:
            break
        label = f"{first + 1}" if multiplicity == 1 else f"{first + 1}-{first + multiplicity}"
        value = omega[first]
        period = f"{2 * np.pi / value:12.2f}" if value > 0 else f"{'divergent':>12}"
        lines.append(f"  {label:<8}{value:15.5f}{value / (2 * np.pi):12.6f}{period}  {multiplicity}")
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sail-ros modes", description=__doc__.splitlines()[0])
    add_sail_options(parser)
    parser.add_argument(
        "--lengths", type=float, nargs="+", metavar="L",
        help="boom lengths [m]: one value for all booms or four (a b c d); "
        "default: fully deployed, a/sqrt(2)",
    )
    parser.add_argument("--count", type=int, default=12, help="frequencies to list (default 12)")
    return parser


def _modes(args) -> int:
    params = sail_parameters(args)
    lengths = args.lengths or [params.full_boom_length]
    if len(lengths) not in (1, 4):
        raise ValueError(f"--lengths takes 1 or 4 values, got {len(lengths)}")
    if args.count < 1:
        raise ValueError(f"--count must be >= 1, got {args.count}")
    model = SailModel(params)
    omega = model.natural_frequencies(lengths[0] if len(lengths) == 1 else lengths)
    shown = ", ".join(f"{v:.4g}" for v in lengths)
    print(f"Natural frequencies of the sail, boom lengths {shown} m, at rest")
    print(describe_parameters(params))
    print()
    print(frequency_table(omega, args.count))
    return 0


def main(argv=None) -> int:
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    return run(_modes, args)


if __name__ == "__main__":
    sys.exit(main())
