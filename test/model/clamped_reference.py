"""Every array the clamped model gives, written to one `.npz` (docs/model.md check 23).

    python test/model/clamped_reference.py OUT.npz

Run with `PYTHONPATH` pointing at a tree of `sail_ros`: `test_free_hub.py` runs it on
the code before the free hub (commit 4d5d094, from `git archive`) and on this tree,
and requires the two files to agree bit for bit. It uses only what both trees have.
"""

import inspect
import sys

import numpy as np

import sail_ros.model
from sail_ros.analysis.modes import modal_analysis
from sail_ros.analysis.plant import linear_plant
from sail_ros.model import CycloidalProfile, SailModel, SailParameters, SailStepper, StaticProfile
from sail_ros.model.loads import LoadSchedule

# The time histories in the fixed steps of the code before the free hub (its default
# max_step 0.05 s): a tree with error-controlled stepping takes them with rtol None (its
# tolerance's steps are checked against references of their own, test_tolerance.py).
FIXED_STEPS = (
    {"rtol": None, "max_step": 0.05} if "rtol" in inspect.signature(SailStepper).parameters else {}
)

LENGTHS = np.array([10.0, 11.5, 12.0, 13.0])
RATES = np.array([0.1, 0.3, 0.0, 0.2])
ACCELERATIONS = np.array([0.01, -0.02, 0.0, 0.03])
OUTPUTS = ("M", "C", "C_d", "G - G^T + C_d", "K_eq", "K", "G", "G - G^T", "K - N")


def arrays(name: str, params: SailParameters, seconds: float) -> dict:
    model = SailModel(params)
    out = {}
    motion = (LENGTHS, RATES, ACCELERATIONS)
    out["matrices"] = np.stack(model.matrices(*motion))
    out["evaluate"] = model.evaluate(OUTPUTS, *motion)
    out["blocks"] = model.assemble_blocks(OUTPUTS, *motion).dense()
    out["mass_and_stiffness"] = np.stack(model.mass_and_stiffness(LENGTHS))
    out["structural_damping"] = model.structural_damping(LENGTHS)
    out["frequencies"] = model.natural_frequencies(LENGTHS)
    out["state_matrix"] = model.state_matrix(*motion)
    out["eigenvalues"] = model.eigenvalues(LENGTHS, RATES)
    for i, matrix in enumerate(model.state_space(LENGTHS, RATES)):
        out[f"state_space_{i}"] = matrix
    out["input_matrix"] = model.input_matrix(LENGTHS)
    out["load_vector"] = model.load_vector(LENGTHS, [2e-3, 0, 1e-3, 0], [0, 0.05, 0, 0])
    out["static"] = model.static_deflection(LENGTHS, [2e-3, 0, 1e-3, 0], [0, 0.05, 0, 0])
    modes = modal_analysis(model, LENGTHS)
    out["modes_omega"], out["modes_vectors"] = modes.omega, modes.vectors
    plant = linear_plant(model, LENGTHS, RATES)
    out["plant_A"], out["plant_B"], out["plant_C"] = plant.A, plant.B, plant.C
    q0 = model.initial_coordinates([0.1, -0.05, 0.0, 0.02])
    loads = LoadSchedule([(0.0, [2e-3, 0, 1e-3, 0], 0.0), (1.0, None, [0, 0.05, 0, 0])])
    t_eval = np.linspace(0.0, seconds, 9)
    for label, profile in (
        ("moving", CycloidalProfile(LENGTHS, LENGTHS + 2.0, seconds)),
        ("static", StaticProfile(LENGTHS)),
    ):
        t, q, qd = model.simulate(
            profile, seconds, q0=q0, t_eval=t_eval, loads=loads, **FIXED_STEPS
        )
        out[f"simulate_{label}"] = np.concatenate([q, qd], axis=1)
        t, q, qd = model.simulate_on_grid(profile, seconds, 0.01, q0=q0, loads=loads, **FIXED_STEPS)
        out[f"grid_{label}"] = np.concatenate([q, qd], axis=1)
    sample = model.sample(0.5, LENGTHS, RATES, q[-1], qd[-1])
    fields = tuple(sample)[:8]  # t .. root_moments: the fields both trees have
    out["sample"] = np.concatenate([np.atleast_1d(np.asarray(v, float)) for v in fields])
    return {f"{name}/{key}": value for key, value in out.items()}


def main(path: str) -> None:
    damped = dict(mass_damping=0.02, stiffness_damping=5e-4)
    results = {}
    results |= arrays("default", SailParameters(n_boom_modes=4, n_membrane_modes=6), 2.0)
    results |= arrays("damped", SailParameters(n_boom_modes=3, n_membrane_modes=5, **damped), 2.0)
    # 120 coordinates: the moving step solves by blocks
    results |= arrays("blocks", SailParameters(n_boom_modes=10, n_membrane_modes=20, **damped), 0.5)
    results["source"] = np.array(sail_ros.model.__file__)
    np.savez(path, **results)


if __name__ == "__main__":
    main(sys.argv[1])
