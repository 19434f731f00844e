"""`sail-ros deploy`: an offline deployment run (model.md §9 reference by default).

All booms extend along the cycloidal profile from `--from` to `--to` metres in
`--duration` seconds; boom `--boom` starts bent in its first mode with tip
deflection `--tip`. Prints the boom-tip deflections against time.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from sail_ros.model import CycloidalProfile, SailModel
from sail_ros.tools.common import add_sail_options, describe_parameters, run, sail_parameters


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sail-ros deploy", description=__doc__.splitlines()[0])
    add_sail_options(parser)
    scenario = parser.add_argument_group("scenario (defaults: model.md §9)")
    scenario.add_argument("--from", dest="start", type=float, default=10.0,
                          help="initial boom length L0 [m] (10)")
    scenario.add_argument("--to", dest="end", type=float, default=15.0,
                          help="final boom length Lf [m] (15)")
    scenario.add_argument("--duration", type=float, default=15.0, help="deployment time T [s] (15)")
    scenario.add_argument("--t-end", type=float, help="simulated time [s] (default: T)")
    scenario.add_argument("--boom", default="a", choices="abcd", help="boom bent at t = 0 (a)")
    scenario.add_argument("--tip", type=float, default=0.1, help="its tip deflection [m] (0.1)")
    parser.add_argument("--every", type=float, default=1.0,
                        help="output interval for the table [s] (1)")
    parser.add_argument("--max-step", type=float, default=0.2, help="largest integration step [s]")
    parser.add_argument("--summary", action="store_true",
                        help="print the table and run figures (the default output today)")
    return parser


def _deploy(args) -> int:
    params = sail_parameters(args)
    t_end = args.duration if args.t_end is None else args.t_end
    if not args.every > 0:
        raise ValueError(f"--every must be > 0, got {args.every}")
    profile = CycloidalProfile(args.start, args.end, args.duration)
    model = SailModel(params)
    q0 = model.mode_state(args.boom, args.tip)
    t_eval = np.unique(np.append(np.arange(0.0, t_end, args.every), t_end))

    started = time.perf_counter()
    with tqdm(total=t_end, unit="s sim", disable=None, leave=False, file=sys.stderr) as bar:
        def progress(t):
            bar.update(t - bar.n)

        t, q, qd = model.simulate(profile, t_end, q0, t_eval=t_eval, progress=progress,
                                  max_step=args.max_step)
    wall = time.perf_counter() - started

    tips = model.tip_deflections(q)
    print(f"Deployment: booms {args.start:g} m -> {args.end:g} m in {args.duration:g} s "
          f"(cycloidal), boom {args.boom} tip {args.tip:g} m at t = 0")
    print(describe_parameters(params))
    print()
    print(f"  {'t [s]':>7}{'L [m]':>9}   tip deflection [mm]: "
          f"{'a':>9}{'b':>10}{'c':>10}{'d':>10}")
    for ti, tip in zip(t, tips, strict=True):
        length = profile(ti)[0][0]
        print(f"  {ti:7.2f}{length:9.3f}   {'':21}" + "".join(f"{1e3 * v:10.3f}" for v in tip))
    peak = np.abs(tips).max()
    print()
    print(f"  peak |tip| {1e3 * peak:.3f} mm over the printed times; "
          f"{t_end:g} s simulated in {wall:.3f} s wall ({t_end / wall:.0f}x real time)")
    return 0


def main(argv=None) -> int:
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    return run(_deploy, args)


if __name__ == "__main__":
    sys.exit(main())
