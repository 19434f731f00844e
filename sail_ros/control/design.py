"""The controller at one set of boom lengths: design model, sampling with the loop
delay, LQR gain and Kalman filter (docs/control.md).

**Design model** (`design_model`), continuous, at frozen lengths and zero rates:

- rigid body (`design_boom_modes = design_membrane_modes = 0`): the hub's heave and
  tilts carrying all the deployed material, `M_hh xdd_h = B_h u + d`, with `M_hh` the
  hub block of the sail's mass matrix (model.md §13.4: the rigid inertia; elastic
  coordinates 0 move nothing relative to the hub) and `B_h` the hub rows of the input
  matrix; it measures the hub's six outputs;
- with modes: `SailModel.state_space` of the sail with those mode counts, every elastic
  mode given `design_damping_ratio` (`zeta`: `A_vv -= V_e diag(2 zeta omega) V_e^T M`,
  with the `M`-orthonormal elastic modes `V_e`); it measures the hub's outputs, the tip
  deflections and their rates.

`d` is a constant disturbance on the hub wrench channels (the pressure's force and
torque, and whatever else the model lacks), estimated and fed back against.

**Sampling** (`sampled`) with zero-order hold at the period `T` and a loop delay
`tau = m T + f` (`0 <= f < T`): over `[t_k, t_k+1]` the plant sees `u_{k-m-1}` until
`t_k + f`, then `u_{k-m}`, so

    x_k+1 = Phi x_k + Gamma_late u_k-m + Gamma_early u_k-m-1 + Gamma_d d_k,
    Gamma_late = int_0^(T-f) e^(As) ds B,  Gamma_early = e^(A(T-f)) int_0^f e^(As) ds B,

and the state carries the commands still to act, `w_k = (u_k-1, ..., u_k-p)`,
`p = m + (f > 0)`: `xi = [x; w]`, `xi_k+1 = F xi_k + G u_k + G_d d_k`.

**LQR**: `u = -K_x xi - d^` minimises `sum z^T Q_z z + u^T R u` (`z` the performance
outputs, the weights of `DesignSettings`), `K_x` from the discrete Riccati equation;
`-d^` cancels the estimated disturbance on the hub channels.

**Kalman filter** on `[xi; d]` (the delay line known, not estimated): process noise
`Gamma_d (q_w^2 / T) Gamma_d^T` (white wrench noise) and `q_d^2 T` (the disturbance's
random walk), measurement noise `diag(r^2)`; the gain `M = P C^T (C P C^T + V)^-1` of
the filtered estimate, from the dual Riccati equation.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from sail_ros.control.settings import DesignSettings
from sail_ros.model import SailModel, SailParameters
from sail_ros.model.layout import per_boom
from sail_ros.model.loads import HUB_INPUT_NAMES, HUB_OUTPUT_NAMES, INPUT_NAMES
from sail_ros.policy import Policy

HUB_WRENCH = list(range(8, 11))  # the hub wrench's columns of the model's inputs
TIP_FORCES = list(range(4, 8))  # the tip forces' columns
TIP_NAMES = tuple(f"tip_deflection_{b}" for b in "abcd")
TIP_RATE_NAMES = tuple(f"tip_deflection_rate_{b}" for b in "abcd")
N_DISTURBANCES = 3  # on the hub wrench channels


def input_names(settings: DesignSettings) -> tuple[str, ...]:
    """What the controller commands: the hub wrench, then the tip forces if asked."""
    return HUB_INPUT_NAMES + (INPUT_NAMES[4:8] if settings.tip_forces else ())


def measurement_names(settings: DesignSettings) -> tuple[str, ...]:
    """What it measures: the hub's six outputs (`loads.HUB_OUTPUT_NAMES`), then with a
    design model with modes the tip deflections and their rates."""
    return HUB_OUTPUT_NAMES + (() if settings.rigid else TIP_NAMES + TIP_RATE_NAMES)


def command_limits(policy: Policy, inputs) -> np.ndarray:
    """The largest |command| of each input: max_hub_force [N], max_hub_torque [N m]
    twice, max_tip_force [N] per tip force (the simulator's limits, `Policy`)."""
    table = {"hub_force_z": policy.max_hub_force}
    table |= dict.fromkeys(("hub_torque_x", "hub_torque_y"), policy.max_hub_torque)
    return np.array([table.get(name, policy.max_tip_force) for name in inputs])


@dataclasses.dataclass(frozen=True)
class ContinuousModel:
    """`xd = A x + B u + B_d d`, measured `y = C_y x`, weighed `z = C_z x` with weights
    `q_z` (one per row of `C_z`)."""

    A: np.ndarray
    B: np.ndarray
    B_d: np.ndarray
    C_y: np.ndarray
    C_z: np.ndarray
    q_z: np.ndarray


def require_free_hub(params: SailParameters) -> None:
    if not params.free_hub:
        raise ValueError(
            "sail.free_hub is false: the controller holds a free hub (set free_hub: true)"
        )


def design_sail(params: SailParameters, settings: DesignSettings) -> SailParameters:
    """The sail of the design model: the plant's, with the design's mode counts (the
    rigid-body model reads only the hub block of `M`, which no mode count changes: the
    fewest modes)."""
    if settings.rigid:
        return params.replace(n_boom_modes=1, n_membrane_modes=1)
    return params.replace(
        n_boom_modes=settings.design_boom_modes, n_membrane_modes=settings.design_membrane_modes
    )


def design_model(model: SailModel, settings: DesignSettings, lengths) -> ContinuousModel:
    """The continuous design model at `lengths` [m] (scalar or 4), rates zero; `model` is
    the design sail's (`design_sail`)."""
    lengths = per_boom(lengths, "lengths", positive=True)
    columns = HUB_WRENCH + (TIP_FORCES if settings.tip_forces else [])
    s = settings
    hub_weights = [s.weight_heave, s.weight_tilt, s.weight_tilt]
    hub_weights += [s.weight_heave_rate, s.weight_tilt_rate, s.weight_tilt_rate]
    if settings.rigid:
        M, _ = model.mass_and_stiffness(lengths)
        h = model.hub_slice
        inverse = np.linalg.inv(M[h, h])
        A = np.zeros((6, 6))
        A[:3, 3:] = np.eye(3)
        B = np.zeros((6, len(columns)))
        B[3:] = inverse @ model.input_matrix(lengths)[h][:, columns]
        B_d = np.zeros((6, 3))
        B_d[3:] = inverse
        return ContinuousModel(A, B, B_d, np.eye(6), np.eye(6), np.array(hub_weights))
    A, B_all, C, _ = model.state_space(lengths)
    n = model.n
    lam, V = model.normal_modes(lengths)
    elastic = lam > 0.0
    omega = np.sqrt(lam[elastic])
    M, _ = model.mass_and_stiffness(lengths)
    V_e = V[:, elastic]
    A[n:, n:] -= (V_e * (2.0 * settings.design_damping_ratio * omega)) @ (V_e.T @ M)
    B = B_all[:, columns]
    tip_rates = np.zeros((4, 2 * n))
    tip_rates[:, n:] = C[:4, :n]
    measured = np.vstack([C[8:14], C[:4], tip_rates])
    weights = hub_weights + [s.weight_tip] * 4 + [s.weight_tip_rate] * 4
    return ContinuousModel(A, B, B_all[:, HUB_WRENCH], measured, measured, np.array(weights))


@dataclasses.dataclass(frozen=True)
class Sampled:
    """`xi_k+1 = F xi_k + G u_k + G_d d_k` with `xi = [x; u_k-1, ..., u_k-p]`
    (`delay_inputs` = p past commands kept)."""

    F: np.ndarray
    G: np.ndarray
    G_d: np.ndarray
    n_x: int
    delay_inputs: int


def _integrals(A: np.ndarray, B: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """`(e^(At), int_0^t e^(As) ds B)` from one exponential of `[[A, B], [0, 0]] t`."""
    n, m = A.shape[0], B.shape[1]
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = A, B
    exponential = scipy.linalg.expm(block * t)
    return exponential[:n, :n], exponential[:n, n:]


def delay_split(period: float, delay: float) -> tuple[int, float]:
    """`(m, f)` of `delay = m period + f`, `0 <= f < period` (a delay within 1e-9 of a
    whole number of periods is that number)."""
    m = int(np.floor(delay / period + 1e-9))
    f = delay - m * period
    return m, (0.0 if f < 1e-9 * period else f)


def sampled(A, B, B_d, period: float, delay: float) -> Sampled:
    """The plant `xd = A x + B u + B_d d` sampled at `period` [s] with its commands
    acting `delay` [s] after their sample (module docstring)."""
    n, nu = A.shape[0], B.shape[1]
    m, f = delay_split(period, delay)
    p = m + (1 if f > 0 else 0)
    both = np.hstack([B, B_d])
    Phi, integral = _integrals(A, both, period)
    G_d = integral[:, nu:]
    if f > 0:
        Phi_late, late = _integrals(A, B, period - f)
        _, early = _integrals(A, B, f)
        Gamma_late, Gamma_early = late, Phi_late @ early
    else:
        Gamma_late, Gamma_early = integral[:, :nu], None
    size = n + p * nu
    F = np.zeros((size, size))
    G = np.zeros((size, nu))
    F[:n, :n] = Phi

    def slot(j):  # u_k-1-j in xi
        return slice(n + j * nu, n + (j + 1) * nu)

    if m == 0:
        G[:n] = Gamma_late
    else:
        F[:n, slot(m - 1)] = Gamma_late
    if Gamma_early is not None:
        F[:n, slot(m)] = Gamma_early
    if p:
        G[slot(0)] = np.eye(nu)
        for j in range(1, p):
            F[slot(j), slot(j - 1)] = np.eye(nu)
    G_d_full = np.zeros((size, G_d.shape[1]))
    G_d_full[:n] = G_d
    return Sampled(F, G, G_d_full, n, p)


@dataclasses.dataclass(frozen=True)
class DesignPoint:
    """The discrete controller at one set of lengths, on the estimate `e = [xi; d]`.

    `e^ = e^- + M (y - C e^-)`, `u = sat(-K e^)`, `e^-_next = F e^ + G u`.
    """

    F: np.ndarray
    G: np.ndarray
    C: np.ndarray
    M: np.ndarray
    K: np.ndarray

    ARRAYS = ("F", "G", "C", "M", "K")


def design_point(
    model: SailModel, settings: DesignSettings, lengths, delay: float | None = None
) -> DesignPoint:
    """The controller designed at `lengths` [m] (module docstring); `model` the design
    sail's; `delay` [s] the loop delay (default the settings').

    Raises:
        ValueError: a Riccati equation without a stabilising solution (the design's
            modes out of the inputs' or the outputs' reach and undamped), naming the
            lengths.
    """
    plant = design_model(model, settings, lengths)
    period = settings.period
    delay = settings.loop_delay_s if delay is None else delay
    s = sampled(plant.A, plant.B, plant.B_d, period, delay)
    n_xi, nu, nd = s.F.shape[0], s.G.shape[1], N_DISTURBANCES
    C_xi = np.zeros((plant.C_z.shape[0], n_xi))
    C_xi[:, : s.n_x] = plant.C_z
    Q = C_xi.T @ (plant.q_z[:, None] * C_xi)
    r = [settings.weight_force] + [settings.weight_torque] * 2
    r += [settings.weight_tip_force] * (nu - 3)
    R = np.diag(r)
    where = f"at lengths {np.round(np.atleast_1d(lengths), 6).tolist()} m"
    P = _riccati(s.F, s.G, Q, R, f"the LQR {where}")
    K_xi = np.linalg.solve(R + s.G.T @ P @ s.G, s.G.T @ P @ s.F)
    # the estimate [xi; d]: the disturbance constant, the delay line known
    F = np.zeros((n_xi + nd, n_xi + nd))
    F[:n_xi, :n_xi], F[:n_xi, n_xi:], F[n_xi:, n_xi:] = s.F, s.G_d, np.eye(nd)
    G = np.vstack([s.G, np.zeros((nd, nu))])
    C = np.zeros((plant.C_y.shape[0], n_xi + nd))
    C[:, : s.n_x] = plant.C_y
    W = np.zeros_like(F)
    gamma = s.G_d[: s.n_x]
    W[: s.n_x, : s.n_x] = gamma @ gamma.T * (settings.wrench_noise**2 / period)
    W[n_xi:, n_xi:] = np.eye(nd) * (settings.disturbance_noise**2 * period)
    noise = [settings.hub_position_noise] * 3 + [settings.hub_rate_noise] * 3
    if not settings.rigid:
        noise += [settings.tip_noise] * 4 + [settings.tip_rate_noise] * 4
    V = np.diag(np.square(noise))
    P_f = _riccati(F.T, C.T, W, V, f"the Kalman filter {where}")
    gain = np.linalg.solve(C @ P_f @ C.T + V, C @ P_f).T
    gain[s.n_x : n_xi] = 0.0  # the commands still to act are known, not estimated
    K = np.zeros((nu, n_xi + nd))
    K[:, :n_xi] = K_xi
    K[:nd, n_xi:] = np.eye(nd)  # -d^ on the hub wrench channels
    return DesignPoint(F, G, C, gain, K)


def _riccati(a, b, q, r, what: str) -> np.ndarray:
    try:
        solution = scipy.linalg.solve_discrete_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as error:
        raise ValueError(
            f"{what}: no stabilising solution of the Riccati equation ({error}); raise "
            "design_damping_ratio or change the weights"
        ) from None
    if not np.all(np.isfinite(solution)):
        raise ValueError(f"{what}: the Riccati equation's solution is not finite")
    return solution
