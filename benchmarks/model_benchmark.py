"""Benchmark of the model on the reference deployment (model.md §9).

For each (n_B, n_M) it prints, measured in a fresh process pinned to one core:
the one-off build time of the reference integrals, the wall time and
real-time factor (simulated seconds per wall second) of the 15 s deployment,
the peak resident memory, and the accuracy of the boom-tip deflections at 5,
10 and 15 s against a tight reference solution of the same equations
(4th-order commutator-free Magnus with exact exponentials on seed Eq. 3,
step 0.05 s; itself converged to < 1e-5 of the peak).

Each size runs twice: the seed's deployment, and the same deployment loaded
and damped (model.md §11: Rayleigh alpha 0.02 1/s, beta 2e-4 s, 2 mPa on
quadrants ab and cd, 0.05 N at the tip of boom b from 5 s to 10 s); its
accuracy is checked in test_loads_damping, its real-time factor here.

    python benchmarks/model_benchmark.py [--sizes 4,6 10,10 20,20] [--repeat 5]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def measure(
    n_boom_modes: int, n_membrane_modes: int, repeat: int, reference: bool, loaded: bool
) -> dict:
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import resource
    import time

    import numpy as np
    import scipy.linalg

    from sail_ros.model import CycloidalProfile, SailModel, SailParameters

    damping = {"mass_damping": 0.02, "stiffness_damping": 2e-4} if loaded else {}
    started = time.perf_counter()
    model = SailModel(
        SailParameters(n_boom_modes=n_boom_modes, n_membrane_modes=n_membrane_modes, **damping)
    )
    build = time.perf_counter() - started

    def inputs(t):  # switches on the output times 5 and 10 s: steps land on them
        force = 0.05 if 5.0 <= t < 10.0 else 0.0
        return np.array([2e-3, 0.0, 2e-3, 0.0, 0.0, force, 0.0, 0.0])

    profile = CycloidalProfile(10.0, 15.0, 15.0)
    q0 = model.mode_state("a", 0.1)
    t_out = [5.0, 10.0, 15.0]

    walls = []
    for _ in range(repeat):
        started = time.perf_counter()
        stepper = model.stepper(profile, q0=q0, inputs=inputs if loaded else None)
        tips = []
        for t in t_out:
            stepper.advance(t)
            tips.append(model.tip_deflections(stepper.q))
        walls.append(time.perf_counter() - started)
    result = {
        "sizes": (n_boom_modes, n_membrane_modes),
        "n": model.n,
        "build_s": build,
        "wall_s": min(walls),
        "steps": stepper.steps_taken,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    if reference and not loaded:
        c = (0.5 - np.sqrt(3) / 6, 0.5 + np.sqrt(3) / 6)
        w = (0.25 + np.sqrt(3) / 6, 0.25 - np.sqrt(3) / 6)
        x, h, t, exact = np.concatenate([np.zeros(model.n), q0]), 0.05, 0.0, []
        for t_next in t_out:
            while t < t_next - 1e-9:
                a1 = model.state_matrix(*profile(t + c[0] * h))
                a2 = model.state_matrix(*profile(t + c[1] * h))
                x = scipy.linalg.expm(h * (w[0] * a1 + w[1] * a2)) @ x
                x = scipy.linalg.expm(h * (w[1] * a1 + w[0] * a2)) @ x
                t += h
            exact.append(model.tip_deflections(x[model.n :]))
        dense = model.simulate(profile, 15.0, q0, t_eval=np.linspace(0.0, 15.0, 601))[1]
        peak = np.abs(model.tip_deflections(dense)).max()
        result["error_pct"] = 100 * np.abs(np.array(tips) - np.array(exact)).max() / peak
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["4,6", "10,10", "20,20"])
    parser.add_argument("--repeat", type=int, default=5, help="runs per size; the best is kept")
    parser.add_argument("--no-reference", action="store_true", help="skip the accuracy check")
    args = parser.parse_args()
    context = multiprocessing.get_context("spawn")
    print(
        f"{'n_B,n_M':>8}{'case':>8}{'dofs':>6}{'build [s]':>11}{'steps':>7}{'wall [s]':>10}"
        f"{'RTF':>8}{'peak RSS [MB]':>15}{'tip error [% of peak]':>23}"
    )
    for size in args.sizes:
        nb, nm = (int(v) for v in size.split(","))
        for loaded in (False, True):
            with context.Pool(1) as pool:
                r = pool.apply(measure, (nb, nm, args.repeat, not args.no_reference, loaded))
            error = f"{r['error_pct']:.4f}" if "error_pct" in r else "-"
            print(
                f"{size:>8}{'loaded' if loaded else 'seed':>8}{r['n']:>6}{r['build_s']:>11.3f}"
                f"{r['steps']:>7}{r['wall_s']:>10.4f}"
                f"{15.0 / r['wall_s']:>8.0f}{r['peak_rss_mb']:>15.0f}{error:>23}",
                flush=True,
            )


if __name__ == "__main__":
    main()
