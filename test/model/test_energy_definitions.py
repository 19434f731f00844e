"""The matrices against the energies they come from (model.md §3-§4).

Kinetic and potential energy are computed here straight from their
definitions: the physical fields u_k(x, t) and w(x, y, t) of Eq. 1 are
evaluated at fixed material-frame points while the booms move, the material
derivative `D/Dt = d/dt + Ld d/dx` is taken by finite differences in time and
space, and the squares are integrated over the physical booms and quadrants.
The model's quadratic forms `1/2 qd^T M qd + qd^T G q + 1/2 q^T N q` and
`1/2 q^T K q` must give the same numbers, for unequal lengths and rates.
"""

import numpy as np
import pytest

from sail_ros.model import SailModel, SailParameters
from sail_ros.model.assembly import GYROSCOPIC, MASS, STIFFNESS_CANONICAL
from sail_ros.model.basis import cantilever_modes, triangle_modes
from sail_ros.model.integrals import collapsed_gauss_triangle, gauss_unit_interval
from sail_ros.model.layout import BOOMS, QUADRANTS

pytestmark = pytest.mark.model

LENGTHS = np.array([31.0, 44.0, 37.5, 52.0])
RATES = np.array([0.7, -0.4, 0.15, 0.9])
DT = 1e-4  # s, time step of the central differences
DX = 1e-4  # m, space step of the central differences


@pytest.fixture(scope="module")
def setup():
    p = SailParameters(n_boom_modes=3, n_membrane_modes=4, boom_axial_load=0.4)
    model = SailModel(p)
    rng = np.random.default_rng(11)
    q, qd = rng.normal(size=model.n), rng.normal(size=model.n)
    return model, q, qd


def boom_field(model, boom, q, qd, t, x):
    """u_k(x, t) with p(t) = p + pd t and L(t) = L + Ld t, x the physical coordinate."""
    k = BOOMS.index(boom)
    length = LENGTHS[k] + RATES[k] * t
    coords = (q + qd * t)[model.boom_slice(boom)]
    return coords @ cantilever_modes(model.n_boom_modes, x / length)


def membrane_field(model, index, q, qd, t, x, y):
    """w(x, y, t) on quadrant `index` (Eq. 1), (x, y) physical local coordinates."""
    name, first, second = QUADRANTS[index]
    la = LENGTHS[first] + RATES[first] * t
    lb = LENGTHS[second] + RATES[second] * t
    state = q + qd * t
    phi, _, _ = triangle_modes(model.n_membrane_modes, x / la, y / lb)
    return (
        state[model.boom_slice(BOOMS[first])] @ cantilever_modes(model.n_boom_modes, x / la)
        + state[model.boom_slice(BOOMS[second])] @ cantilever_modes(model.n_boom_modes, y / lb)
        + state[model.membrane_slice(name)] @ phi
    )


def energies_from_definitions(model, q, qd):
    p = model.params
    x01, w01 = gauss_unit_interval(60)
    kinetic = potential = 0.0
    for k, boom in enumerate(BOOMS):
        length, rate = LENGTHS[k], RATES[k]
        x, w = x01 * length, w01 * length

        def u(t, x, boom=boom):
            return boom_field(model, boom, q, qd, t, x)

        du_dt = (u(DT, x) - u(-DT, x)) / (2 * DT)
        du_dx = (u(0, x + DX) - u(0, x - DX)) / (2 * DX)
        d2u_dx2 = (u(0, x + DX) - 2 * u(0, x) + u(0, x - DX)) / DX**2
        material = du_dt + rate * du_dx
        kinetic += 0.5 * p.boom_linear_density * np.sum(w * material**2)
        potential += 0.5 * p.boom_bending_stiffness * np.sum(w * d2u_dx2**2)
        potential -= 0.5 * p.boom_axial_load * np.sum(w * du_dx**2)
    xi, eta, wt = collapsed_gauss_triangle(40)
    for index, (_, first, second) in enumerate(QUADRANTS):
        la, lb = LENGTHS[first], LENGTHS[second]
        x, y, w = xi * la, eta * lb, wt * la * lb

        def wf(t, x, y, index=index):
            return membrane_field(model, index, q, qd, t, x, y)

        dw_dt = (wf(DT, x, y) - wf(-DT, x, y)) / (2 * DT)
        dw_dx = (wf(0, x + DX, y) - wf(0, x - DX, y)) / (2 * DX)
        dw_dy = (wf(0, x, y + DX) - wf(0, x, y - DX)) / (2 * DX)
        material = dw_dt + RATES[first] * dw_dx + RATES[second] * dw_dy
        kinetic += 0.5 * p.membrane_areal_density * np.sum(w * material**2)
        potential += 0.5 * p.membrane_tension * np.sum(w * (dw_dx**2 + dw_dy**2))
    return kinetic, potential


def test_kinetic_and_potential_energy_match_matrices(setup):
    model, q, qd = setup
    kinetic, potential = energies_from_definitions(model, q, qd)
    M, G, K_minus_N = model.evaluate((MASS, GYROSCOPIC, STIFFNESS_CANONICAL), LENGTHS, RATES, 0.0)
    _, K = model.mass_and_stiffness(LENGTHS)
    N = K - K_minus_N
    quadratic_kinetic = 0.5 * qd @ M @ qd + qd @ G @ q + 0.5 * q @ N @ q
    assert quadratic_kinetic == pytest.approx(kinetic, rel=1e-8)
    assert 0.5 * q @ K @ q == pytest.approx(potential, rel=1e-6)
    # each part matters: dropping G or N would be seen
    assert abs(qd @ G @ q) > 1e-3 * kinetic and abs(0.5 * q @ N @ q) > 1e-5 * kinetic
