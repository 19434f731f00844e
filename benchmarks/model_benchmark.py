"""Benchmark of the model on the reference deployment (model.md §9), loaded and not.

For each (n_B, n_M) it prints, measured in a fresh process pinned to one core:
the one-off build time of the reference integrals, the wall time and
real-time factor (simulated seconds per wall second) of the 15 s deployment
with its state at every 0.05 s (301 outputs), the ratio to the Radau peer,
and the accuracy of the tip deflections and root moments at those 301 times,
in % of their peaks, against a tight reference: DOP853 at rtol 1e-10 on the
first-order Eq. 2, restarted at every load step (kept on disk under
`benchmarks/.cache/`, which git ignores: at (20, 20) it takes minutes).

The deployment: 10 m to 15 m in 15 s, boom a's tip at 0.1 m, undamped;
`loaded` adds 2 mPa on quadrants ab and cd from t = 0 and 0.05 N on boom b's
tip from 5 s to 10 s, `unloaded` has neither. Rows per size:
- `default`: the stepper at its defaults (tolerance `DEFAULT_RTOL`, steps up to
  `DEFAULT_MAX_STEP`), outputs inside steps from their continuous extension;
  `est.` is its own estimate of the error (`SailStepper.relative_error_estimate`,
  the larger of tips and root moments);
- `fixed 0.05 s`: the stepper as it was, fixed 0.05 s steps and no estimate;
- `Radau`: the peer a competent user would write, `solve_ivp(method="Radau")`
  on the first-order Eq. 3 with the analytic Jacobian and a right-hand side
  from the project's own assembly (one Cholesky solve of `M`), restarted at
  the load steps, tuned to just meet the bar (0.2 % of peak) on tips and
  root moments of the loaded case: the fastest of an `rtol` ladder (steps of
  10^(1/8) from 0.03, `atol = rtol x 0.01` and `x 0.1` of the largest initial
  coordinate) that meets it.
The `steps` column counts the stepper's steps (rejected ones apart), and
Radau's right-hand-side calls. Every case of a size is timed in the same
process, the cases interleaved, best of `--repeat` each: the machine's drift
reaches them alike, so their ratios hold.

Then the live simulator's sampling (`GridSampler`, 0.01 s grid, moving) at
(20, 20): the wall time per grid step of `advance`, at the defaults and as it
was (fixed 0.05 s), interleaved; then the build of the reference integrals
alone for `--integrals` sizes.

    python benchmarks/model_benchmark.py [--sizes 10,10 20,20] [--repeat 5]
        [--integrals 40,40] [--sampler 20,20]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import pathlib
import sys

from results import Results

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


ACCURACY_BAR_PCT = 0.2
T_END = 15.0
SWITCHES = (5.0, 10.0)  # s: the tip force's on and off
CACHE = pathlib.Path(__file__).resolve().parent / ".cache"


def deployment(n_boom_modes, n_membrane_modes, loaded):
    """The model, motion, initial state and loads (a `LoadSchedule` or None) of a case."""
    import numpy as np

    from sail_ros.model import CycloidalProfile, SailModel, SailParameters
    from sail_ros.model.loads import LoadSchedule

    model = SailModel(SailParameters(n_boom_modes=n_boom_modes, n_membrane_modes=n_membrane_modes))
    loads = None
    if loaded:
        pressures = np.array([2e-3, 0.0, 2e-3, 0.0])
        loads = LoadSchedule(
            [(0.0, pressures, 0.0), (SWITCHES[0], None, [0, 0.05, 0, 0]), (SWITCHES[1], None, 0.0)]
        )
    return model, CycloidalProfile(10.0, 15.0, T_END), model.mode_state("a", 0.1), loads


def _pieces(loads):
    """The intervals between load steps and the input vector held on each."""
    import numpy as np

    from sail_ros.model.loads import input_function

    edges = [0.0, *(SWITCHES if loads is not None else ()), T_END]
    u = input_function(loads)
    return [
        (a, b, np.zeros(8) if u is None else u(0.5 * (a + b)))
        for a, b in zip(edges[:-1], edges[1:], strict=True)
    ]


def _first_order(model, profile, loads, method, t_out, **tolerances):
    """`x = [qd; q]` at `t_out` by `solve_ivp` on Eq. 2, restarted at the load steps;
    returns (coordinates (k, n), right-hand-side calls)."""
    import numpy as np
    import scipy.linalg
    from scipy.integrate import solve_ivp

    from sail_ros.model.assembly import DAMPING, MASS, STIFFNESS_EQ

    n = model.n

    def motion(t):
        return tuple(np.broadcast_to(np.asarray(v, dtype=float), (4,)) for v in profile(t))

    def rhs(t, x, u):
        lengths, rates, accelerations = motion(t)
        M, C, K = model.assemble((MASS, DAMPING, STIFFNESS_EQ), lengths, rates, accelerations)
        force = model.assemble_inputs(lengths) @ u
        qdd = scipy.linalg.cho_solve(scipy.linalg.cho_factor(M), force - C @ x[:n] - K @ x[n:])
        return np.concatenate([qdd, x[:n]])

    def jacobian(t, x, u):
        return model.state_matrix(*profile(t))

    x = np.concatenate([np.zeros(n), q0_of(model)])
    rows, calls = [], 0
    for a, b, u in _pieces(loads):
        inside = [t for t in t_out if a <= t < b]
        options = {"jac": jacobian} if method == "Radau" else {}
        solution = solve_ivp(
            rhs, (a, b), x, method=method, t_eval=[*inside, b], args=(u,), **options, **tolerances
        )
        rows.extend(solution.y[n:, : len(inside)].T)
        calls += solution.nfev
        x = solution.y[:, -1]
    if t_out[-1] == T_END:
        rows.append(x[n:])
    return np.array(rows), calls


def q0_of(model):
    return model.mode_state("a", 0.1)


def reference(n_boom_modes, n_membrane_modes, loaded, t_out):
    """DOP853 at rtol 1e-10 (atol 1e-13 m), cached on disk."""
    import numpy as np

    path = CACHE / f"reference_{n_boom_modes}_{n_membrane_modes}_{int(loaded)}.npz"
    if path.exists():
        stored = np.load(path)
        if np.array_equal(stored["t"], t_out):
            return stored["q"]
    model, profile, _, loads = deployment(n_boom_modes, n_membrane_modes, loaded)
    q, _ = _first_order(model, profile, loads, "DOP853", t_out, rtol=1e-10, atol=1e-13)
    CACHE.mkdir(exist_ok=True)
    np.savez(path, t=t_out, q=q)
    return q


def measure(n_boom_modes: int, n_membrane_modes: int, repeat: int) -> list[dict]:
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import resource
    import time

    import numpy as np

    from sail_ros.integrate.driver import simulate
    from sail_ros.model.loads import input_function

    started = time.perf_counter()
    model, profile, q0, loads = deployment(n_boom_modes, n_membrane_modes, True)
    build = time.perf_counter() - started
    t_out = np.linspace(0.0, T_END, 301)
    lengths = np.array([profile(t)[0] for t in t_out])
    exact = {loaded: reference(n_boom_modes, n_membrane_modes, loaded, t_out) for loaded in (1, 0)}

    def errors_pct(q, loaded):
        out = []
        for series in (model.tip_deflections, lambda x: model.root_moments(x, lengths)):
            expected = series(exact[loaded])
            out.append(100 * np.abs(series(q) - expected).max() / np.abs(expected).max())
        return out

    def stepper_run(loaded, **options):
        inputs = input_function(loads) if loaded else None

        def run():
            result = simulate(model, profile, T_END, q0=q0, t_eval=t_out, inputs=inputs, **options)
            estimate = result.relative_error_estimate
            worst = max(estimate["tips"], estimate["root_moments"])
            return result.steps, result[1], 100 * worst if result.rtol else None

        return run

    def radau_run(rtol, atol_factor):
        def run():
            scale = np.abs(q0).max()
            q, calls = _first_order(
                model, profile, loads, "Radau", t_out, rtol=rtol, atol=rtol * atol_factor * scale
            )
            return calls, q, None

        return run

    fastest = (np.inf, None)
    for atol_factor in (0.01, 0.1):
        for k in range(24):
            run = radau_run(10 ** (-1.5 - k / 8), atol_factor)
            began = time.perf_counter()
            _, q, _ = run()
            wall = time.perf_counter() - began
            if max(errors_pct(q, 1)) <= ACCURACY_BAR_PCT:
                fastest = min(fastest, (wall, run), key=lambda pair: pair[0])
                break
    cases = [
        ("default", 1, stepper_run(1)),
        ("fixed 0.05 s", 1, stepper_run(1, rtol=None, max_step=0.05)),
        ("Radau", 1, fastest[1]),
        ("default", 0, stepper_run(0)),
        ("fixed 0.05 s", 0, stepper_run(0, rtol=None, max_step=0.05)),
    ]
    cases = [case for case in cases if case[2] is not None]
    walls = {(name, loaded): [] for name, loaded, _ in cases}
    outcomes = {}
    for _ in range(repeat):
        for name, loaded, run in cases:
            began = time.perf_counter()
            outcomes[name, loaded] = run()
            walls[name, loaded].append(time.perf_counter() - began)
    peak_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    rows = []
    for name, loaded, _ in cases:
        steps, q, estimate = outcomes[name, loaded]
        tips, moments = errors_pct(q, loaded)
        rows.append(
            {
                "sizes": (n_boom_modes, n_membrane_modes),
                "case": f"{name} {'loaded' if loaded else 'unloaded'}",
                "n": model.n,
                "build_s": build,
                "wall_s": min(walls[name, loaded]),
                "steps": steps,
                "tips_pct": tips,
                "moments_pct": moments,
                "estimate_pct": estimate,
                "peak_rss_mb": peak_rss,
            }
        )
    return rows


def measure_sampler(n_boom_modes: int, n_membrane_modes: int, repeat: int) -> dict:
    """Wall time per grid step [s] of `GridSampler.advance` while the booms move (0.01 s
    grid, the reference deployment, loaded), defaults against fixed 0.05 s steps."""
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import time

    from sail_ros.integrate.sampling import GridSampler
    from sail_ros.model.loads import input_function

    model, profile, q0, loads = deployment(n_boom_modes, n_membrane_modes, True)
    grid_steps = int(T_END / 0.01)

    def run(**options):
        sampler = GridSampler(
            model.stepper(profile, q0=q0, inputs=input_function(loads), **options), 0.01
        )
        began = time.perf_counter()
        for _ in range(grid_steps):
            sampler.advance()
        return (time.perf_counter() - began) / grid_steps

    cases = {"default": {}, "fixed 0.05 s": {"rtol": None, "max_step": 0.05}}
    best = {name: min(run(**options) for _ in range(1)) for name, options in cases.items()}
    for _ in range(repeat - 1):
        for name, options in cases.items():
            best[name] = min(best[name], run(**options))
    return best


def measure_integrals(n_boom_modes: int, n_membrane_modes: int) -> dict:
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import resource
    import time

    from sail_ros.model.integrals import default_quadrature_order, quadrant_integrals

    order = default_quadrature_order(n_boom_modes, n_membrane_modes)
    started = time.perf_counter()
    quadrant_integrals(n_boom_modes, n_membrane_modes, order)
    return {
        "wall_s": time.perf_counter() - started,
        "order": order,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["10,10", "20,20"])
    parser.add_argument("--repeat", type=int, default=5, help="runs per case; the best is kept")
    parser.add_argument("--integrals", nargs="*", default=["40,40"], help="integral builds alone")
    parser.add_argument("--sampler", nargs="*", default=["20,20"], help="grid sampling cost")
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args()
    results = Results("model_benchmark", sys.argv)
    table = []
    context = multiprocessing.get_context("spawn")
    print(
        f"{'n_B,n_M':>8}{'case':>24}{'dofs':>6}{'build [s]':>11}{'steps':>7}{'wall [s]':>10}"
        f"{'RTF':>7}{'x Radau':>9}{'tips [%]':>10}{'moments [%]':>13}{'est. [%]':>10}"
        f"{'RSS [MB]':>10}"
    )
    for size in args.sizes:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            rows = pool.apply(measure, (nb, nm, args.repeat))
        peer = next((r for r in rows if r["case"].startswith("Radau")), None)
        for r in rows:
            ratio = "-" if peer is None else f"{peer['wall_s'] / r['wall_s']:.1f}"
            estimate = "-" if r["estimate_pct"] is None else f"{r['estimate_pct']:.3f}"
            print(
                f"{size:>8}{r['case']:>24}{r['n']:>6}{r['build_s']:>11.3f}"
                f"{r['steps']:>7}{r['wall_s']:>10.4f}{T_END / r['wall_s']:>7.0f}{ratio:>9}"
                f"{r['tips_pct']:>10.4f}{r['moments_pct']:>13.4f}{estimate:>10}"
                f"{r['peak_rss_mb']:>10.0f}",
                flush=True,
            )
            table.append(
                [size, r["case"], r["n"], round(r["build_s"], 3), r["steps"],
                 round(r["wall_s"], 4), round(T_END / r["wall_s"]), ratio,
                 round(r["tips_pct"], 4), round(r["moments_pct"], 4), estimate,
                 round(r["peak_rss_mb"])]
            )  # fmt: skip
    results.table(
        "The reference deployment (model.md §9), 301 outputs; accuracy against DOP853 at "
        "rtol 1e-10, in % of each output's peak; best of --repeat runs",
        ["n_B,n_M", "case", "coordinates", "build [s]", "steps", "wall [s]",
         "real-time factor", "x Radau", "tips [%]", "root moments [%]", "est. [%]",
         "peak RSS [MB]"],
        table,
    )  # fmt: skip
    for size in args.sampler:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            best = pool.apply(measure_sampler, (nb, nm, args.repeat))
        print(
            f"sampler {size}, 0.01 s grid, moving: "
            + ", ".join(f"{name} {1e3 * wall:.3f} ms" for name, wall in best.items())
            + " per grid step",
            flush=True,
        )
        results.note(
            f"the live simulator's sampling at ({size}), 0.01 s grid, moving: "
            + ", ".join(f"{name} {1e3 * wall:.3f} ms" for name, wall in best.items())
            + " per grid step"
        )
    for size in args.integrals:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            r = pool.apply(measure_integrals, (nb, nm))
        print(
            f"integrals {size}: {r['order']}^2 points, {r['wall_s']:.3f} s, "
            f"peak RSS {r['peak_rss_mb']:.0f} MB",
            flush=True,
        )
        results.note(
            f"integrals at ({size}) built alone: {r['order']}^2 points, {r['wall_s']:.3f} s, "
            f"peak RSS {r['peak_rss_mb']:.0f} MB"
        )
    results.write(args.json)


if __name__ == "__main__":
    main()
