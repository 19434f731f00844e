"""The matrices as component blocks (`model/blocks.py`): the same matrices, products and
shifted solves as the assembled ones, and a moving step that does not depend on which
form the stepper uses, nor the velocities at output times."""

import numpy as np
import pytest

from sail_ros.integrate import system as system_module
from sail_ros.integrate.fast_modes import STEP_MATRICES
from sail_ros.integrate.rational import PADE_POLES
from sail_ros.model import CycloidalProfile, SailModel, SailParameters
from sail_ros.model.blocks import DenseMatrices

pytestmark = pytest.mark.model

LENGTHS = np.array([10.0, 11.5, 12.0, 13.0])
RATES = np.array([0.1, 0.3, 0.0, 0.2])
ACCELERATIONS = np.array([0.01, -0.02, 0.0, 0.03])
SIZES = [(1, 1), (2, 3), (3, 7), (6, 2)]


# a free hub (docs/model.md §13) borders the blocks; with mass damping also a rank-3 part
HUBS = {
    "clamped": {},
    "free hub": dict(free_hub=True, mass_damping=0.0),
    "free hub, mean-axes damping": dict(free_hub=True, hub_mass=30.0, stowed_mass_on_hub=False),
}


def _model(n_boom_modes, n_membrane_modes, **hub):
    fields = dict(mass_damping=0.02, stiffness_damping=5e-4) | hub
    return SailModel(
        SailParameters(n_boom_modes=n_boom_modes, n_membrane_modes=n_membrane_modes, **fields)
    )


@pytest.mark.parametrize("hub", HUBS.values(), ids=HUBS.keys())
@pytest.mark.parametrize(("n_boom_modes", "n_membrane_modes"), SIZES)
def test_blocks_add_up_to_the_assembled_matrices_and_act_like_them(
    n_boom_modes, n_membrane_modes, hub
):
    model = _model(n_boom_modes, n_membrane_modes, **hub)
    motion = (LENGTHS, RATES, ACCELERATIONS)
    full = model.assemble(STEP_MATRICES, *motion)
    blocks = model.assemble_blocks(STEP_MATRICES, *motion)
    assert np.array_equal(blocks.dense(), full)
    rng = np.random.default_rng(1)
    x = rng.standard_normal((len(STEP_MATRICES), model.n))
    expected = np.einsum("kij,kj->ki", full, x)
    for products in (blocks.matvec(x), DenseMatrices(full).matvec(x)):
        assert np.allclose(products, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    # the quadratic forms of many columns (the followed modes' frequencies at a middle)
    V = rng.standard_normal((model.n, 7))
    for k in range(len(STEP_MATRICES)):
        forms = np.einsum("jm,jm->m", V, full[k] @ V)
        scale = 1e-12 * np.abs(full[k]).max() * np.abs(V).sum(axis=0) ** 2
        for mine in (blocks.forms(k, V), DenseMatrices(full).forms(k, V)):
            assert np.all(np.abs(mine - forms) <= scale)

    taus = 0.07 / PADE_POLES
    rhs = rng.standard_normal((taus.size, model.n)) + 1j * rng.standard_normal((taus.size, model.n))
    systems = full[0] + taus[:, None, None] * full[1] + taus[:, None, None] ** 2 * full[2]
    for u in (blocks.solve_shifted(taus, rhs), DenseMatrices(full).solve_shifted(taus, rhs)):
        residual = np.einsum("pij,pj->pi", systems, u) - rhs
        assert np.abs(residual).max() < 1e-12 * np.abs(rhs).max() * np.abs(systems).max()
    # the first matrix alone (the mass matrix's solve, `velocities`), real
    b = rng.standard_normal(model.n)
    u = blocks.solve(b)
    assert not np.iscomplexobj(u)
    assert np.abs(full[0] @ u - b).max() < 1e-12 * np.abs(b).max() * np.abs(full[0]).max()


@pytest.mark.parametrize("hub", HUBS.values(), ids=HUBS.keys())
def test_moving_steps_by_blocks_and_in_full_agree(monkeypatch, hub):
    model = _model(3, 7, **hub)
    profile = CycloidalProfile(10.0, 14.0, 8.0)
    loads = ([2e-3, 0.0, 1e-3, 0.0], [0.0, 0.05, 0.0, 0.0])
    if model.free_hub:
        loads += ([0.5, 0.1, -0.2],)
    runs = []
    for threshold in (model.n, model.n + 1):  # by blocks, then in full
        monkeypatch.setattr(system_module, "BLOCK_SOLVE_MIN_COORDINATES", threshold)
        runs.append(model.simulate(profile, 8.0, q0=model.mode_state("a", 0.1), loads=loads)[1:])
    (q_blocks, qd_blocks), (q_full, qd_full) = runs
    assert np.abs(q_full).max() > 0
    assert np.allclose(q_blocks, q_full, rtol=0, atol=1e-11 * np.abs(q_full).max())
    assert np.allclose(qd_blocks, qd_full, rtol=0, atol=1e-11 * np.abs(qd_full).max())


@pytest.mark.parametrize("hub", HUBS.values(), ids=HUBS.keys())
def test_matrices_at_many_motions_at_once_are_those_at_each(hub):
    """`assemble` at (m, 4) motions (the exact rates of samples inside a step) gives each
    motion's own matrices, the free hub's mean-axes damping included."""
    model = _model(3, 4, **hub)
    rng = np.random.default_rng(7)
    motions = (
        LENGTHS + rng.uniform(-2.0, 2.0, (5, 4)),
        RATES + rng.uniform(-0.5, 0.5, (5, 4)),
        ACCELERATIONS + rng.uniform(-0.1, 0.1, (5, 4)),
    )
    many = model.assemble(STEP_MATRICES, *motions)
    assert many.shape == (5, len(STEP_MATRICES), model.n, model.n)
    for i in range(5):
        one = model.assemble(STEP_MATRICES, *(m[i] for m in motions))
        np.testing.assert_allclose(many[i], one, rtol=1e-13, atol=1e-13 * np.abs(one).max())
