"""Cost of the free hub (docs/model.md §13) against the clamped sail at the same mode counts.

For each (n_B, n_M), in a fresh process pinned to one core, the reference deployment
(model.md §9: all booms 10 -> 15 m in 15 s, boom a bent to 0.1 m) is run by the
default stepper on the clamped sail and on the same sail with the default free hub
(100 kg, 100 kg m^2, stowed material on the hub), the two interleaved, best of
`--repeat` each (the machine's drift reaches both alike). It prints the steps, the
best wall and CPU times, the real-time factor and the ratio free / clamped, then the
parts of one moving step at t = 3.3 s (assembly of the step's matrices, as blocks
from 120 coordinates, and the shifted solves), best CPU time of repeated calls.

    python benchmarks/free_hub_benchmark.py [--sizes 4,6 10,10 20,20] [--repeat 9]

Both models take the same steps here: the free hub's step bound (4.39 x the
cantilever frequency, model.md §13.10) stays above 1 / max_step at 10 m and longer.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys

from results import Results

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def measure(n_boom_modes: int, n_membrane_modes: int, repeat: int) -> dict:
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import time

    import numpy as np

    from sail_ros.integrate import system as system_module
    from sail_ros.integrate.fast_modes import STEP_MATRICES
    from sail_ros.integrate.rational import PADE_POLES
    from sail_ros.model import CycloidalProfile, SailModel, SailParameters
    from sail_ros.model.blocks import DenseMatrices

    profile = CycloidalProfile(10.0, 15.0, 15.0)
    models = {
        hub: SailModel(
            SailParameters(
                n_boom_modes=n_boom_modes,
                n_membrane_modes=n_membrane_modes,
                free_hub=hub == "free",
            )
        )
        for hub in ("clamped", "free")
    }
    walls = {hub: [] for hub in models}
    cpus = {hub: [] for hub in models}
    steps = {}
    for _ in range(repeat):
        for hub, model in models.items():
            started, cpu = time.perf_counter(), time.process_time()
            stepper = model.stepper(profile, q0=model.mode_state("a", 0.1))
            stepper.advance(15.0)
            walls[hub].append(time.perf_counter() - started)
            cpus[hub].append(time.process_time() - cpu)
            steps[hub] = stepper.steps_taken

    def best_cpu(call, count=200):
        best = np.inf
        for _ in range(repeat):
            started = time.process_time()
            for _ in range(count):
                call()
            best = min(best, (time.process_time() - started) / count)
        return best

    motion = tuple(np.broadcast_to(np.asarray(v, float), (4,)) for v in profile(3.3))
    taus = 0.05 / PADE_POLES
    parts = {}
    for hub, model in models.items():
        blocks = model.n >= system_module.BLOCK_SOLVE_MIN_COORDINATES

        def assemble(model=model, blocks=blocks):
            if blocks:
                return model.assemble_blocks(STEP_MATRICES, *motion)
            return DenseMatrices(model.assemble(STEP_MATRICES, *motion))

        matrices = assemble()
        rhs = np.ones((taus.size, model.n), dtype=complex)
        parts[hub] = (
            best_cpu(assemble),
            best_cpu(lambda matrices=matrices, rhs=rhs: matrices.solve_shifted(taus, rhs)),
        )
    return {
        "n": {hub: model.n for hub, model in models.items()},
        "steps": steps,
        "wall": {hub: min(v) for hub, v in walls.items()},
        "cpu": {hub: min(v) for hub, v in cpus.items()},
        "parts": parts,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["4,6", "10,10", "20,20"])
    parser.add_argument("--repeat", type=int, default=9, help="runs per case; the best is kept")
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args()
    results = Results("free_hub_benchmark", sys.argv)
    table = []
    context = multiprocessing.get_context("spawn")
    print(
        f"{'n_B,n_M':>8}{'hub':>9}{'dofs':>6}{'steps':>7}{'wall [s]':>10}{'CPU [s]':>9}"
        f"{'RTF':>7}{'assembly [us]':>15}{'solves [us]':>13}"
    )
    for size in args.sizes:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            r = pool.apply(measure, (nb, nm, args.repeat))
        for hub in ("clamped", "free"):
            assembly, solves = r["parts"][hub]
            print(
                f"{size:>8}{hub:>9}{r['n'][hub]:>6}{r['steps'][hub]:>7}{r['wall'][hub]:>10.4f}"
                f"{r['cpu'][hub]:>9.4f}{15.0 / r['wall'][hub]:>7.0f}"
                f"{1e6 * assembly:>15.1f}{1e6 * solves:>13.1f}"
            )
            table.append(
                [size, hub, r["n"][hub], r["steps"][hub], round(r["wall"][hub], 4),
                 round(r["cpu"][hub], 4), round(15.0 / r["wall"][hub]),
                 round(1e6 * assembly, 1), round(1e6 * solves, 1)]
            )  # fmt: skip
        print(
            f"{size:>8}  free / clamped: wall {r['wall']['free'] / r['wall']['clamped']:.3f}, "
            f"CPU {r['cpu']['free'] / r['cpu']['clamped']:.3f}",
            flush=True,
        )
    results.table(
        "A 15 s deployment, the hub clamped and free; best of --repeat runs",
        ["n_B,n_M", "hub", "coordinates", "steps", "wall [s]", "CPU [s]",
         "real-time factor", "assembly [us]", "solves [us]"],
        table,
    )  # fmt: skip
    results.write(args.json)


if __name__ == "__main__":
    main()
