"""The sail's linear analysis at frozen lengths and rates: the first-order form and its
eigenvalues (seed Eq. 3), the linear plant, the static answer to constant loads (model.md
§7, §12, §13.6). Functions of a `SailModel` (its methods `state_matrix`, `eigenvalues`,
`static_deflection`, `rigid_body_acceleration` and `state_space` call those names) and
the helpers they share."""

from __future__ import annotations

import numpy as np
import scipy.linalg

from sail_ros.model.layout import per_boom


def without_rigid(eigenvalues, free_hub: bool) -> np.ndarray:
    """`eigenvalues` of Eq. 3 without the six smallest in modulus when the hub is free:
    its rigid-body modes, 0 at rest, slow while the booms move (the mass and tilt
    inertia change; model.md §13.6), far below the first elastic frequency. They are no
    vibration, so stability studies leave them out; the order is kept."""
    eigenvalues = np.asarray(eigenvalues)
    if not free_hub:
        return eigenvalues
    rigid = np.argsort(np.abs(eigenvalues), kind="stable")[:6]
    return np.delete(eigenvalues, rigid)


def first_order(M, C, K) -> np.ndarray:
    """`A = [-M^-1 C, -M^-1 K; I, 0]` of `M qdd + C qd + K q = 0`, `x = [qd; q]`."""
    n = M.shape[0]
    factor = scipy.linalg.cho_factor(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, :n] = -scipy.linalg.cho_solve(factor, C)
    A[:n, n:] = -scipy.linalg.cho_solve(factor, K)
    A[n:, :n] = np.eye(n)
    return A


def modal_eigenvalues(M, C, K) -> np.ndarray | None:
    """The eigenvalues of `M qdd + C qd + K q = 0` from the modes of `(K, M)` when they
    decouple it (at rest, with Rayleigh damping: `V^T C V` diagonal to round-off), each
    mode's two roots of `lambda^2 + d lambda + omega^2 = 0`; None otherwise (`K` not
    symmetric to round-off, or `C` coupling the modes). A symmetric eigenproblem of
    size n costs a fraction of the general one of size 2 n, and an undamped mode's
    roots are exactly imaginary."""
    if np.abs(K - K.T).max() > 1e-12 * np.abs(K).max():
        return None
    lam, V = scipy.linalg.eigh(0.5 * (K + K.T), M)
    modal = V.T @ C @ V
    d = np.diag(modal).copy()
    np.fill_diagonal(modal, 0.0)
    if np.abs(modal).max() > 1e-12 * max(np.abs(d).max(), np.sqrt(np.abs(lam).max())):
        return None
    root = np.sqrt((0.25 * d * d - lam).astype(complex))
    return np.concatenate([-0.5 * d + root, -0.5 * d - root])


def state_matrix(model, lengths, rates=0.0, accelerations=0.0) -> np.ndarray:
    """`A` of the first-order form `xd = A x`, `x = [qd; q]` (seed Eq. 3).

    `A = [-M^-1 C, -M^-1 K_eq; I, 0]`.
    """
    return first_order(*model.matrices(lengths, rates, accelerations))


def eigenvalues(model, lengths, rates=0.0) -> np.ndarray:
    """Eigenvalues [1/s] of Eq. 3 at frozen lengths with constant rates.

    Accelerations are zero. Sorted by imaginary part, then real part; any
    positive real part means the frozen system is unstable. With a free hub at
    rest, six are the rigid-body modes, exactly 0, and the others those of the
    reduced system `(M_r,qq, C_qq, K_qq)` (model.md §13.6); while booms move the
    rigid ones leave zero, the six smallest in modulus.
    """
    rates = per_boom(rates, "rates")
    eig = None
    if model.free_hub and not rates.any():
        M, C, K = model.matrices(lengths)
        e, h = slice(0, model.n_elastic), model.hub_slice
        reduced = M[e, e] - M[e, h] @ np.linalg.solve(M[h, h], M[h, e])
        eig = np.concatenate(
            [np.zeros(6), np.linalg.eigvals(first_order(reduced, C[e, e], K[e, e]))]
        )
    elif not rates.any():
        eig = modal_eigenvalues(*model.matrices(lengths))
    if eig is None:
        eig = np.linalg.eigvals(model.state_matrix(lengths, rates, 0.0))
    return eig[np.lexsort((eig.real, eig.imag))]


def static_deflection(model, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
    """Coordinates of the sail under constant loads: with a clamped hub at rest,
    `q = K^-1 Q`; with a free hub the deflection `q_s` riding on the uniformly
    accelerating rigid motion (inertia relief, model.md §13.6),
    `q_s = K_qq^-1 (Q_q - M_qh a)` with `a = rigid_body_acceleration(...)`, its hub
    entries 0.

    Raises:
        ValueError: the sail is buckled or neutrally stable (K not positive
            definite): it has no static answer; a hub wrench on a clamped hub.
    """
    M, K = model.mass_and_stiffness(lengths)
    Q = model.load_vector(lengths, pressures, tip_forces, hub_wrench)
    e = slice(0, model.n_elastic)
    deflection = np.zeros(model.n)
    if model.free_hub:
        Q = Q[e] - M[e, model.hub_slice] @ hub_acceleration(model, M, Q)
        K = K[e, e]
    try:
        deflection[e] = scipy.linalg.cho_solve(scipy.linalg.cho_factor(K), Q)
    except np.linalg.LinAlgError:
        why = (
            f"membrane_prestress = {model.params.membrane_prestress:g} Pa: the film "
            "has no out-of-plane stiffness"
            if model.params.membrane_prestress <= 0.0
            else "an axial load at or above buckling"
        )
        raise ValueError(
            f"the stiffness is not positive definite at these lengths ({why}): no static deflection"
        ) from None
    return deflection


def rigid_body_acceleration(model, lengths, pressures=0.0, tip_forces=0.0, hub_wrench=0.0):
    """The free sail's uniform acceleration under constant loads (model.md §13.6):
    `a = M_hh^-1 Q_h` (3,) [m/s^2, rad/s^2, rad/s^2] of `z_h`, `theta_x`, `theta_y`.

    Raises:
        ValueError: the hub is clamped.
    """
    model._require_free_hub()
    M, _ = model.mass_and_stiffness(lengths)
    Q = model.load_vector(lengths, pressures, tip_forces, hub_wrench)
    return hub_acceleration(model, M, Q)


def state_space(model, lengths, rates=0.0):
    """The linear plant `xd = A x + B u`, `y = C x + D u` at frozen lengths [m]
    and constant rates [m/s] (accelerations 0), `x = [q; qd]` (model.md §12).

    Inputs `u`: `input_names`; outputs `y`: `output_names` (4 tip deflections
    [m] and 4 root moments [N m] relative to the hub; with a free hub then
    `z_h` [m], `theta_x`, `theta_y` [rad] and their rates, which hold double
    integrators: `A` is singular, model.md §13.6); `D = 0`.
    """
    lengths = model._lengths(lengths)
    M, C, K = model.matrices(lengths, rates, 0.0)
    n = model.n
    factor = scipy.linalg.cho_factor(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -scipy.linalg.cho_solve(factor, K)
    A[n:, n:] = -scipy.linalg.cho_solve(factor, C)
    inputs_matrix = model.input_matrix(lengths)
    B = np.zeros((2 * n, inputs_matrix.shape[1]))
    B[n:] = scipy.linalg.cho_solve(factor, inputs_matrix)
    C_out = np.zeros((len(model.output_names), 2 * n))
    C_out[:4, :n] = model._tip_rows
    C_out[4:8, :n] = (
        model.params.boom_bending_stiffness * model._curvature_rows / lengths[:, None] ** 2
    )
    if model.free_hub:
        hub = np.arange(model.n_elastic, n)
        C_out[8:11, hub] = np.eye(3)
        C_out[11:14, n + hub] = np.eye(3)
    return A, B, C_out, np.zeros((C_out.shape[0], B.shape[1]))


def hub_acceleration(model, M, Q) -> np.ndarray:
    """`a = M_hh^-1 Q_h`: the hub rows of a free sail's uniform acceleration."""
    h = model.hub_slice
    return scipy.linalg.cho_solve(scipy.linalg.cho_factor(M[h, h]), Q[h])
