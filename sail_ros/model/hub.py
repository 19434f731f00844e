"""A free hub's momenta and the holds' reactions (model.md §13.3, §13.5): functions of a
`SailModel` (its methods `hold_loads` and `momenta` call those names) and the helpers
behind them and its modes and inputs with a free hub."""

from __future__ import annotations

import numpy as np
import scipy.linalg

from sail_ros.model.assembly import GYROSCOPIC, MASS
from sail_ros.model.layout import (
    BOOM_DIRECTIONS,
    QUADRANT_BOOMS,
    QUADRANTS,
    hub_tilt_axis,
    per_boom,
)
from sail_ros.model.loads import N_INPUTS
from sail_ros.model.parameters import SailParameters


def in_plane_momenta(params: SailParameters, lengths, rates, accelerations):
    """`(P, Pd, H_z, Hd_z)` of the deploying material (model.md §13.3): in-plane momentum
    `P` (2,) [kg m/s] in the `sail` frame and its rate [N], spin momentum about z `H_z`
    [kg m^2/s] (the film's; booms carry none) and its rate [N m]. For motions at m times
    (`lengths`, `rates`, `accelerations` (m, 4)): `P`, `Pd` (m, 2), `H_z`, `Hd_z` (m,)."""
    rho_b, rho_m = params.boom_linear_density, params.membrane_areal_density
    L, Ld, Ldd = (np.asarray(x, dtype=float)[..., None] for x in (lengths, rates, accelerations))
    # each boom's values as a column (..., 4, 1): a quadrant's terms are (..., 2) or (..., 1)
    P = rho_b * ((L * Ld) * BOOM_DIRECTIONS).sum(axis=-2)
    Pd = rho_b * ((Ld**2 + L * Ldd) * BOOM_DIRECTIONS).sum(axis=-2)
    spin = spin_rate = 0.0
    for _, a, b in QUADRANTS:
        e_a, e_b = BOOM_DIRECTIONS[a], BOOM_DIRECTIONS[b]
        La, Lda, Ldda = L[..., a, :], Ld[..., a, :], Ldd[..., a, :]
        Lb, Ldb, Lddb = L[..., b, :], Ld[..., b, :], Ldd[..., b, :]
        area = La * Lb
        velocity = Lda * e_a + Ldb * e_b
        P = P + rho_m * 0.5 * area * velocity
        Pd = Pd + rho_m * (
            0.5 * (Lda * Lb + La * Ldb) * velocity + 0.5 * area * (Ldda * e_a + Lddb * e_b)
        )
        spin += rho_m * area * (La * Ldb - Lb * Lda) / 6.0
        spin_rate += (rho_m / 6.0) * (La**2 * (Ldb**2 + Lb * Lddb) - Lb**2 * (Lda**2 + La * Ldda))
    return P, Pd, spin[..., 0], spin_rate[..., 0]


def hold_loads(model, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
    """`(F_x [N], F_y [N], tau_z [N m])` the holds of a free hub supply (model.md
    §13.3): the force in the inertial x-y plane at the hub centre, the rate of the
    in-plane momentum `P` of the deploying material, and the torque about body z,
    the rate of its spin momentum `H_z`. Zero for point-symmetric motion."""
    motion = (
        model._lengths(lengths),
        per_boom(rates, "rates"),
        per_boom(accelerations, "accelerations"),
    )
    return hold_loads_over(model.params, *motion)


def hold_loads_over(params: SailParameters, lengths, rates, accelerations) -> np.ndarray:
    """`hold_loads` of motions at m times (checked `lengths`, `rates`, `accelerations`
    (m, 4)): (m, 3); of one motion (4 values each): (3,)."""
    _, force, _, torque = in_plane_momenta(params, lengths, rates, accelerations)
    return np.concatenate([force, torque[..., None]], axis=-1)


def momenta(model, q, qd, lengths, rates=0.0) -> tuple[float, float, float]:
    """`(p_z [kg m/s], H_x [kg m^2/s], H_y [kg m^2/s])`: the linear momentum along
    inertial z and the angular momentum about the inertial x, y axes of hub,
    stowed and deployed material (model.md §13.5, first order):
    `p_z = (M qd + G q)_z`, `H_x = (M qd + G q)_thx - z_h P_y + theta_y H_z`,
    `H_y = (M qd + G q)_thy + z_h P_x - theta_x H_z`.

    Raises:
        ValueError: the hub is clamped.
    """
    model._require_free_hub()
    lengths, rates = model._lengths(lengths), per_boom(rates, "rates")
    M, G = model.assemble((MASS, GYROSCOPIC), lengths, rates, np.zeros(4))
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    canonical = (M @ qd + G @ q)[model.hub_slice]
    z, theta_x, theta_y = q[model.hub_slice]
    P, _, spin, _ = in_plane_momenta(model.params, lengths, rates, np.zeros(4))
    return (
        float(canonical[0]),
        float(canonical[1] - z * P[1] + theta_y * spin),
        float(canonical[2] + z * P[0] - theta_x * spin),
    )


def free_modes(model, M: np.ndarray, K: np.ndarray):
    """`(omega^2, V)` of a free sail from `M` and `K` (`SailModel.modes_of`): the three
    rigid-body modes, `omega^2 = 0.0` exactly, `V = [0; L^-T]` with `M_hh = L L^T`; the
    others solve `K_qq v = omega^2 M_r,qq v` and are lifted to `(v, -M_hh^-1 M_hq v)`
    (model.md §13.6)."""
    e, h = slice(0, model.n_elastic), model.hub_slice
    factor = scipy.linalg.cho_factor(M[h, h])
    lift = scipy.linalg.cho_solve(factor, M[h, e])  # M_hh^-1 M_hq
    reduced = M[e, e] - M[e, h] @ lift
    omega2, elastic = scipy.linalg.eigh(K[e, e], 0.5 * (reduced + reduced.T))
    V = np.zeros((model.n, model.n))
    lower = np.linalg.cholesky(M[h, h])
    V[h, :3] = np.linalg.inv(lower).T
    V[e, 3:] = elastic
    V[h, 3:] = -lift @ elastic
    return np.concatenate([np.zeros(3), omega2]), V


# `layout.hub_tilt_axis` of booms a..d, and as a (2, 4) matrix of signs: the stepper
# assembles the inputs at every evaluation
_BOOMS = np.arange(4)
_TILT_AXES, _TILT_SIGNS = (np.array(v) for v in zip(*map(hub_tilt_axis, range(4)), strict=True))
_TILT = np.zeros((2, 4))
_TILT[_TILT_AXES, _BOOMS] = _TILT_SIGNS
_FIRST, _SECOND = QUADRANT_BOOMS


def with_hub_inputs(model, elastic: np.ndarray, lengths) -> np.ndarray:
    """`B_u` (n, 11) of a free sail from its elastic part `elastic` (n, 8) at 4 checked
    `lengths` [m]: the pressures and tip forces push and tilt the hub too (virtual work
    on the absolute deflection, model.md §13.5), and the hub wrench acts on it alone."""
    matrix = np.zeros((model.n, N_INPUTS + 3))
    matrix[:, :N_INPUTS] = elastic
    hub = matrix[model.hub_slice]  # rows z_h, theta_x, theta_y (a view)
    area = lengths[_FIRST] * lengths[_SECOND]
    hub[0, :4] = 0.5 * area
    hub[0, 4:8] = 1.0
    hub[:, 8:] = np.eye(3)
    for booms in (_FIRST, _SECOND):  # each quadrant's two arms: its booms' lengths
        hub[1:, :4] += _TILT[:, booms] * area * lengths[booms] / 6.0
    hub[1 + _TILT_AXES, 4 + _BOOMS] = _TILT_SIGNS * lengths
    return matrix
