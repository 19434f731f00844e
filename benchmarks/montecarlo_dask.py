"""Benchmark of Monte Carlo studies on Dask: 1000 samples of the reference deployment.

Prints, on this machine: the wall time of the study on a local cluster of 1 and
of 2 worker processes (one thread each) and the speed-up, with the cases batched
(`execution.batch_sizes`: down to one case per task at the end) and one case per
task; the time of one sample called directly, its integration's steps against the
least a step costs (one eigen-decomposition), and at the default (converged) mode
counts; a sample's cost split into building its model, integrating, its outputs and the
rest (transport: the worker-seconds per sample beyond the sample's own); Dask's overhead
per case (an empty case through the cluster); whether the rows are the same from 1 and
2 workers; the CPU time the hypervisor took from the machine's cores during each
measurement (steal: on a shared virtual machine the same run takes longer while it is
high); and the cluster size (workers like these) that a 100 000-sample study needs to
finish in ten minutes.

    python benchmarks/montecarlo_dask.py [--samples 1000]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from machine import stolen_seconds
from model_benchmark import eigh_seconds
from results import Results

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

STUDY = {
    "study": {
        "description": "benchmark: the reference deployment, scattered",
        "samples": 1000,
        "seed": 1,
        "output_rate_hz": 10.0,
        "scenario": {
            "scenario": {
                "duration": 15.0,
                "profile": {"type": "cycloidal", "start": 10.0, "end": 15.0, "duration": 15.0},
                "initial": {"mode_state": {"a": 0.1}},
            }
        },
        "dispersions": {
            "boom_bending_stiffness": {"distribution": "normal", "mean": 6000.0, "std": 300.0},
            "membrane_prestress": {"distribution": "lognormal", "median": 6890.0, "sigma": 0.2},
            "initial_tip_deflection.a": {"distribution": "uniform", "low": 0.05, "high": 0.15},
            "rate.b": {"distribution": "normal", "mean": 1.0, "std": 0.05},
        },
    }
}


def empty(case):
    return case


def step_floor(params, rows) -> dict:
    """Where a sample's integration goes: its steps (accepted and refused, the mean over
    `rows`) against the least a step with frozen modes costs, one generalised symmetric
    eigen-decomposition at the model's size (`model_benchmark.eigh_seconds`)."""
    import numpy as np

    from sail_ros.model import SailModel

    model = SailModel(params)
    steps = np.mean([sum(row["_steps"]) for row in rows])
    integrate = np.mean([row["_seconds"][1] for row in rows])
    eigh = eigh_seconds(model)
    return {"n": model.n, "steps": steps, "eigh_s": eigh, "integrate_s": integrate,
            "ratio": integrate / (steps * eigh)}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args()
    results = Results("montecarlo_dask", sys.argv)

    import numpy as np

    from sail_ros.analysis.execution import batch_sizes, run_cases
    from sail_ros.analysis.montecarlo import run_sample, study_from_dict
    from sail_ros.model import SailParameters
    from sail_ros.tools.cluster import dask_client

    study = study_from_dict({"study": {**STUDY["study"], "samples": args.samples}})
    base = SailParameters(n_boom_modes=4, n_membrane_modes=6).to_dict()  # as printed below
    cases = [(study, i, base) for i in range(args.samples)]

    run_sample(cases[0])  # integrals built and cached, as in a warm worker
    started, stolen_before = time.perf_counter(), stolen_seconds()
    direct_rows = [run_sample(case) for case in cases[:20]]
    direct = (time.perf_counter() - started) / 20
    stolen_direct = stolen_seconds() - stolen_before
    assert not any(row["error"] for row in direct_rows)
    floor = step_floor(SailParameters.from_dict(base), direct_rows)

    # the same sample at the default (converged) counts, called directly
    default = SailParameters().resolved(10.0)
    converged = [(study, i, default.to_dict()) for i in range(3)]
    run_sample(converged[0])
    started = time.perf_counter()
    for case in converged:
        assert not run_sample(case)["error"]
    direct_default = (time.perf_counter() - started) / len(converged)
    default_counts = f"{default.n_boom_modes}, {default.membrane_modes}"

    walls, rows, stolen = {}, {}, {}
    for workers, batch in ((1, None), (2, None), (2, 1)):
        with dask_client(workers=workers) as client:
            client.run(run_sample, cases[0])  # warm every worker: integrals built once each
            started, stolen_before = time.perf_counter(), stolen_seconds()
            outcome = run_cases(run_sample, cases, client, batch=batch)
            walls[workers, batch] = time.perf_counter() - started
            stolen[workers, batch] = stolen_seconds() - stolen_before
            rows[workers, batch] = outcome.results
            assert not any(r["error"] for r in outcome.results)
            if workers == 2 and batch is None:
                started = time.perf_counter()
                run_cases(empty, list(range(2000)), client, batch=1)
                empty_per_case = (time.perf_counter() - started) / 2000

    def public(results):
        return [{k: v for k, v in r.items() if not k.startswith("_")} for r in results]

    same = public(rows[1, None]) == public(rows[2, None]) == public(rows[2, 1])
    split = np.mean([r["_seconds"] for r in rows[2, None]], axis=0)
    per_worker_sample = 2 * walls[2, None] / args.samples
    batched = batch_sizes(args.samples, 2)
    print(f"samples                      {args.samples} (reference deployment, n_B, n_M = 4, 6)")
    print(f"one sample, called directly  {1e3 * direct:.1f} ms  (20 samples; steal "
          f"{stolen_direct:.2f} s)")  # fmt: skip
    print(f"its integration              {1e3 * floor['integrate_s']:.1f} ms: {floor['steps']:.1f} "
          f"steps (refused too) x {1e3 * floor['integrate_s'] / floor['steps']:.2f} ms, "
          f"{floor['ratio']:.0f} times one eigh a step ({1e3 * floor['eigh_s']:.3f} ms at "
          f"n = {floor['n']})")  # fmt: skip
    print(f"at the default counts        {1e3 * direct_default:.0f} ms a sample (n_B, n_M = "
          f"{default_counts}; 3 samples)")  # fmt: skip
    print(f"1 worker                     {walls[1, None]:.1f} s  "
          f"({1e3 * walls[1, None] / args.samples:.1f} ms/sample; "
          f"steal {stolen[1, None]:.1f} s)")  # fmt: skip
    print(f"2 workers                    {walls[2, None]:.1f} s  (speed-up "
          f"{walls[1, None] / walls[2, None]:.2f}x; {len(batched)} tasks of "
          f"{max(batched)} samples down to {min(batched)}; "
          f"steal {stolen[2, None]:.1f} s)")  # fmt: skip
    print(f"2 workers, 1 sample per task {walls[2, 1]:.1f} s  (steal {stolen[2, 1]:.1f} s)")
    print(f"a sample on 2 workers [ms]   build {1e3 * split[0]:.1f}, integrate "
          f"{1e3 * split[1]:.1f}, outputs {1e3 * split[2]:.1f}, transport and the rest "
          f"{1e3 * (per_worker_sample - split.sum()):.1f} (worker-time per sample "
          f"{1e3 * per_worker_sample:.1f})")  # fmt: skip
    print(f"Dask overhead per task       {1e3 * empty_per_case:.2f} ms (an empty case, 2 workers)")
    print(f"rows from 1 and 2 workers, batched or not: {'identical' if same else 'DIFFERENT'}")
    needed = 100_000 * walls[1, None] / args.samples / 600.0
    print(f"100 000 samples in 10 min    about {needed:.0f} workers like these "
          f"({100_000 * walls[1, None] / args.samples / 3600:.1f} worker-hours)")  # fmt: skip
    results.table(
        f"{args.samples} samples of the reference deployment (n_B, n_M = 4, 6), local workers",
        ["measure", "value"],
        [
            ["one sample, called directly [ms]", round(1e3 * direct, 1)],
            ["its integration [ms]", round(1e3 * floor["integrate_s"], 1)],
            ["its steps (refused too)", round(floor["steps"], 1)],
            [f"one eigh at n = {floor['n']} [ms]", round(1e3 * floor["eigh_s"], 3)],
            ["integration / (steps x eigh)", round(floor["ratio"])],
            [
                f"one sample at the default counts ({default_counts}) [ms]",
                round(1e3 * direct_default),
            ],
            ["1 worker [s]", round(walls[1, None], 1)],
            ["2 workers [s]", round(walls[2, None], 1)],
            ["speed-up, 2 workers", round(walls[1, None] / walls[2, None], 2)],
            ["2 workers, 1 sample per task [s]", round(walls[2, 1], 1)],
            ["worker time per sample, 2 workers [ms]", round(1e3 * per_worker_sample, 1)],
            ["Dask's cost per case [ms]", round(1e3 * empty_per_case, 2)],
            ["rows from 1 and 2 workers, batched or not", "identical" if same else "DIFFERENT"],
        ],
    )
    results.write(args.json)


if __name__ == "__main__":
    main()
