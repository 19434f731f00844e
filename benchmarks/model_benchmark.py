"""Benchmark of the model on the reference deployment (model.md §9) against a tuned peer.

For each (n_B, n_M) it prints, measured in a fresh process pinned to one core, four
cases of the stepper at its defaults: two loads (`mild`, `harsh`) each given as a
`LoadSchedule` (whose switch times the stepper reads) and as a plain Python callable
(whose jumps it must find), beside the Radau peer of each load. Columns: the wall time
and real-time factor (simulated seconds per wall second) of the 15 s deployment, the
ratio to the peer, the accuracy of the tip deflections and root moments at the output
times in % of their peaks against a tight reference (DOP853 at rtol 1e-10 on the
first-order Eq. 2, restarted at every load step, kept under `benchmarks/.cache/`, which
git ignores), and the run's own error estimate (`est.`, the larger of tips and root
moments). Then where the stepper's time goes: its steps (refused ones included) times
one generalised symmetric eigen-decomposition at the model's size, the least a step
with frozen modes costs.

The deployment: 10 m to 15 m in 15 s, boom a's tip at 0.1 m, undamped.
- `mild`: 2e-5 Pa on quadrant ab throughout, 1 mN on boom b's tip over [4, 9) s,
  outputs every 0.25 s;
- `harsh`: 2 mPa on quadrants ab and cd throughout, 50 mN on boom b's tip over
  [5, 10) s, outputs every 0.05 s.
The peer is what a competent user would write: `solve_ivp(method="Radau")` on the
first-order Eq. 2 with the analytic Jacobian and a right-hand side from the project's
own assembly (one Cholesky solve of `M`), restarted at the load steps, tuned to just
meet the bar (0.2 % of peak) on tips and root moments: the fastest over an `rtol`
ladder (steps of 10^(1/8) from 0.03) and `atol` in {1e-2, 1e-3, 1e-4} x rtol x the
largest initial coordinate. `steps` counts the stepper's accepted steps and the peer's
right-hand-side calls. Every case of a size is timed in the same process, the cases
interleaved, best of `--repeat` each: the machine's drift reaches them alike, so their
ratios hold.

Then the live simulator's sampling (`GridSampler`, 0.01 s grid, moving) at `--sampler`
sizes: the wall time per grid step of `advance`; then the build of the reference
integrals alone for `--integrals` sizes, and their read back from the integral store
(`model/integral_store.py`) that keeps them for the next process. `--json FILE` also
writes the figures for the documentation's benchmarks page (`results.py`).

    python benchmarks/model_benchmark.py [--sizes 10,10 20,20] [--repeat 3]
        [--integrals 40,40] [--sampler 20,20] [--json FILE]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import pathlib
import sys
import time

from results import Results

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


ACCURACY_BAR_PCT = 0.2
T_END = 15.0
CACHE = pathlib.Path(__file__).resolve().parent / ".cache"
# load -> (pressures per quadrant ab, bc, cd, da [Pa], boom b's tip force [N], its on and
# off times [s], output interval [s])
LOADS = {
    "mild": ((2e-5, 0.0, 0.0, 0.0), 1e-3, (4.0, 9.0), 0.25),
    "harsh": ((2e-3, 0.0, 2e-3, 0.0), 0.05, (5.0, 10.0), 0.05),
}
ATOL_FACTORS = (1e-2, 1e-3, 1e-4)


def deployment(n_boom_modes, n_membrane_modes, load, callable_loads=False):
    """The model, motion, initial state and loads of a case: a `LoadSchedule`, or with
    `callable_loads` a plain function of time giving the same pressures and forces."""
    import numpy as np

    from sail_ros.model import CycloidalProfile, SailModel, SailParameters
    from sail_ros.model.loads import LoadSchedule

    model = SailModel(SailParameters(n_boom_modes=n_boom_modes, n_membrane_modes=n_membrane_modes))
    pressures, force, (on, off), _ = LOADS[load]
    pressures, tip_forces = np.array(pressures), np.array([0.0, force, 0.0, 0.0])
    if callable_loads:

        def loads(t):
            return pressures, tip_forces if on <= t < off else np.zeros(4)

    else:
        loads = LoadSchedule([(0.0, pressures, 0.0), (on, None, tip_forces), (off, None, 0.0)])
    return model, CycloidalProfile(10.0, 15.0, T_END), q0_of(model), loads


def outputs(load):
    """The output times [s] of a load's case."""
    import numpy as np

    every = LOADS[load][3]
    return np.linspace(0.0, T_END, round(T_END / every) + 1)


def _pieces(load):
    """The intervals between load steps and the input vector held on each."""
    from sail_ros.model.loads import input_function

    _, _, switches, _ = LOADS[load]
    *_, loads = deployment(1, 1, load)
    edges = [0.0, *switches, T_END]
    u = input_function(loads)
    return [(a, b, u(0.5 * (a + b))) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _first_order(model, profile, load, method, t_out, **tolerances):
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
    for a, b, u in _pieces(load):
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


def reference(n_boom_modes, n_membrane_modes, load, t_out):
    """DOP853 at rtol 1e-10 (atol 1e-13 m), cached on disk."""
    import numpy as np

    path = CACHE / f"reference_{n_boom_modes}_{n_membrane_modes}_{load}.npz"
    if path.exists():
        stored = np.load(path)
        if np.array_equal(stored["t"], t_out):
            return stored["q"]
    model, profile, _, _ = deployment(n_boom_modes, n_membrane_modes, load)
    # minutes at (20, 20) (DOP853's steps are bounded by the highest mode): say so
    print(f"({n_boom_modes},{n_membrane_modes}) {load}: computing the tight reference once, "
          f"kept in {CACHE}", file=sys.stderr, flush=True)  # fmt: skip
    started = time.perf_counter()
    q, _ = _first_order(model, profile, load, "DOP853", t_out, rtol=1e-10, atol=1e-13)
    print(f"({n_boom_modes},{n_membrane_modes}) {load}: tight reference in "
          f"{time.perf_counter() - started:.0f} s", file=sys.stderr, flush=True)  # fmt: skip
    CACHE.mkdir(exist_ok=True)
    np.savez(path, t=t_out, q=q)
    return q


def eigh_seconds(model, repeat: int = 20) -> float:
    """The least a moving step with frozen modes costs [s]: one generalised symmetric
    eigen-decomposition of the model's `(K, M)` at the deployment's middle (12.5 m),
    best of `repeat`."""
    import numpy as np
    import scipy.linalg

    M, K = model.mass_and_stiffness(np.full(4, 12.5))
    decompositions = []
    for _ in range(repeat):
        began = time.perf_counter()
        scipy.linalg.eigh(K, M)
        decompositions.append(time.perf_counter() - began)
    return min(decompositions)


def measure(n_boom_modes: int, n_membrane_modes: int, repeat: int) -> list[dict]:
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import warnings

    import numpy as np

    from sail_ros.integrate.driver import simulate
    from sail_ros.model.loads import input_function

    warnings.simplefilter("ignore")  # the estimate is printed
    model, profile, q0, _ = deployment(n_boom_modes, n_membrane_modes, "mild")

    def errors_pct(q, load):
        t_out = outputs(load)
        lengths = np.array([profile(t)[0] for t in t_out])
        exact = reference(n_boom_modes, n_membrane_modes, load, t_out)
        out = []
        for series in (model.tip_deflections, lambda x: model.root_moments(x, lengths)):
            expected = series(exact)
            out.append(100 * np.abs(series(q) - expected).max() / np.abs(expected).max())
        return out

    def stepper_run(load, callable_loads):
        inputs = input_function(deployment(1, 1, load, callable_loads)[3])
        t_out = outputs(load)

        def run():
            result = simulate(model, profile, T_END, q0=q0, t_eval=t_out, inputs=inputs)
            estimate = result.relative_error_estimate
            worst = max(estimate["tips"], estimate["root_moments"])
            return result.steps, result[1], 100 * worst, result.rejected

        return run

    def radau_run(load, rtol, atol_factor):
        def run():
            scale = np.abs(q0).max()
            q, calls = _first_order(
                model, profile, load, "Radau", outputs(load), rtol=rtol,
                atol=rtol * atol_factor * scale,
            )  # fmt: skip
            return calls, q, None, 0

        return run

    def tuned_peer(load):
        """The fastest Radau over the ladder that meets the bar, with its tolerances."""
        fastest = (np.inf, None, None)
        for atol_factor in ATOL_FACTORS:
            for k in range(24):
                rtol = 10 ** (-1.5 - k / 8)
                run = radau_run(load, rtol, atol_factor)
                began = time.perf_counter()
                _, q, _, _ = run()
                wall = time.perf_counter() - began
                if max(errors_pct(q, load)) <= ACCURACY_BAR_PCT:
                    if wall < fastest[0]:
                        fastest = (wall, run, f"Radau rtol {rtol:.2g} atol {atol_factor:g}")
                    break
        return fastest[1], fastest[2]

    cases = []
    for load in LOADS:
        cases.append((f"{load} schedule", load, stepper_run(load, False)))
        cases.append((f"{load} callable", load, stepper_run(load, True)))
        run, name = tuned_peer(load)
        if run is not None:
            cases.append((f"{load} {name}", load, run))
    walls = {name: [] for name, _, _ in cases}
    outcomes = {}
    for _ in range(repeat):
        for name, _, run in cases:
            began = time.perf_counter()
            outcomes[name] = run()
            walls[name].append(time.perf_counter() - began)
    eigh_s = eigh_seconds(model)
    rows = []
    for name, load, _ in cases:
        steps, q, estimate, refused = outcomes[name]
        tips, moments = errors_pct(q, load)
        peer = next((c for c, of, _ in cases if of == load and "Radau" in c), None)
        rows.append(
            {
                "sizes": [n_boom_modes, n_membrane_modes],
                "case": name,
                "load": load,
                "n": model.n,
                "wall_s": min(walls[name]),
                "peer_wall_s": None if peer is None else min(walls[peer]),
                "steps": steps,
                "refused": refused,
                "tips_pct": tips,
                "moments_pct": moments,
                "estimate_pct": estimate,
                "eigh_s": eigh_s,
            }
        )
    return rows


def measure_sampler(n_boom_modes: int, n_membrane_modes: int, repeat: int) -> float:
    """Wall time per grid step [s] of `GridSampler.advance` at the defaults while the
    booms move (0.01 s grid, the reference deployment, harsh loads)."""
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import time

    from sail_ros.integrate.sampling import GridSampler
    from sail_ros.model.loads import input_function

    model, profile, q0, loads = deployment(n_boom_modes, n_membrane_modes, "harsh")
    grid_steps = int(T_END / 0.01)

    def run():
        sampler = GridSampler(model.stepper(profile, q0=q0, inputs=input_function(loads)), 0.01)
        began = time.perf_counter()
        for _ in range(grid_steps):
            sampler.advance()
        return (time.perf_counter() - began) / grid_steps

    return min(run() for _ in range(repeat))


def measure_integrals(n_boom_modes: int, n_membrane_modes: int) -> dict:
    """The integrals' build alone, and their read back from the integral store (a
    process's cost at these counts once another stored them), in one process."""
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    import resource
    import time

    from sail_ros.model import integrals

    nb, nm = n_boom_modes, n_membrane_modes
    order = integrals.default_quadrature_order(nb, nm)
    started = time.perf_counter()
    integrals._built(nb, nm, order)
    built = time.perf_counter() - started
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    integrals.quadrant_integrals(nb, nm, order)  # stored (if not already)
    integrals.quadrant_integrals.cache_clear()
    started = time.perf_counter()
    integrals.quadrant_integrals(nb, nm, order)
    return {
        "wall_s": built,
        "read_s": time.perf_counter() - started,
        "order": order,
        "peak_rss_mb": peak,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["10,10", "20,20"])
    parser.add_argument("--repeat", type=int, default=3, help="runs per case; the best is kept")
    parser.add_argument("--integrals", nargs="*", default=["40,40"], help="integral builds alone")
    parser.add_argument("--sampler", nargs="*", default=["20,20"], help="grid sampling cost")
    parser.add_argument(
        "--json", metavar="FILE", help="also write the figures as JSON (results.py) for the docs"
    )
    args = parser.parse_args()
    results = Results("model_benchmark", sys.argv)
    cases, floors = [], []
    context = multiprocessing.get_context("spawn")
    print(
        f"{'n_B,n_M':>8}{'case':>34}{'dofs':>6}{'steps':>7}{'wall [s]':>10}{'RTF':>7}"
        f"{'x peer':>8}{'tips [%]':>10}{'moments [%]':>13}{'est. [%]':>10}"
    )
    for size in args.sizes:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            rows = pool.apply(measure, (nb, nm, args.repeat))
        for r in rows:
            peer = r["peer_wall_s"]
            ratio = "-" if peer is None else f"{peer / r['wall_s']:.1f}"
            estimate = "-" if r["estimate_pct"] is None else f"{r['estimate_pct']:.3f}"
            print(
                f"{size:>8}{r['case']:>34}{r['n']:>6}{r['steps']:>7}{r['wall_s']:>10.4f}"
                f"{T_END / r['wall_s']:>7.0f}{ratio:>8}{r['tips_pct']:>10.4f}"
                f"{r['moments_pct']:>13.4f}{estimate:>10}",
                flush=True,
            )
            cases.append(
                [size, r["case"], r["n"], r["steps"], round(r["wall_s"], 4),
                 round(T_END / r["wall_s"]), ratio, round(r["tips_pct"], 4),
                 round(r["moments_pct"], 4), estimate]
            )  # fmt: skip
        for r in rows:
            if r["estimate_pct"] is None:
                continue
            floor = (r["steps"] + r["refused"]) * r["eigh_s"]
            print(
                f"{size:>8}{r['case']:>34}: {r['steps']} + {r['refused']} refused steps x "
                f"{1e3 * r['eigh_s']:.2f} ms (one eigh at n = {r['n']}) = {floor:.4f} s, "
                f"the wall {r['wall_s'] / floor:.1f} times that",
                flush=True,
            )
            floors.append(
                [size, r["case"], r["steps"] + r["refused"], round(1e3 * r["eigh_s"], 3),
                 round(floor, 4), round(r["wall_s"] / floor, 1)]
            )  # fmt: skip
    results.table(
        "The reference deployment (model.md §9) at the defaults, mild and harsh loads each "
        "as a LoadSchedule and as a plain callable, beside the Radau peer tuned to 0.2 % of "
        "peak; accuracy against DOP853 at rtol 1e-10, in % of each output's peak; best of "
        "--repeat runs",
        ["n_B,n_M", "case", "coordinates", "steps", "wall [s]", "real-time factor",
         "x peer", "tips [%]", "root moments [%]", "est. [%]"],
        cases,
    )  # fmt: skip
    results.table(
        "Where the stepper's time goes: its steps against one generalised symmetric "
        "eigen-decomposition each (the least a step with frozen modes costs)",
        ["n_B,n_M", "case", "steps", "eigh [ms]", "floor [s]", "wall / floor"],
        floors,
    )  # fmt: skip
    for size in args.sampler:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            wall = pool.apply(measure_sampler, (nb, nm, args.repeat))
        line = f"the live sampler at ({size}), 0.01 s grid, moving: {1e3 * wall:.3f} ms a step"
        print(line, flush=True)
        results.note(line)
    for size in args.integrals:
        nb, nm = (int(v) for v in size.split(","))
        with context.Pool(1) as pool:
            r = pool.apply(measure_integrals, (nb, nm))
        line = (
            f"integrals at ({size}) built alone: {r['order']}^2 points, {r['wall_s']:.3f} s, "
            f"peak RSS {r['peak_rss_mb']:.0f} MB; read back from the integral store "
            f"{1e3 * r['read_s']:.1f} ms"
        )
        print(line, flush=True)
        results.note(line)
    results.write(args.json)


if __name__ == "__main__":
    main()
