"""The exact step while the booms stand still (docs/model.md §11): `G = N = 0` and `M`,
`K` fixed, so `exp(h B)` follows from the modes of `(K, M)`. Rayleigh damping is
classical (`V^T C_d V` diagonal): each mode is a damped oscillator with its own exact
2 x 2 propagator. A load held over the step moves the elastic modes' equilibrium to
`K^-1 Q`, about which the same propagator acts; a rigid-body mode (`lam = 0` exactly, a
free hub) has no equilibrium and takes the load as `eta + h etad + h^2 f / 2`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sail_ros.model.assembly import MASS, STIFFNESS, STRUCTURAL_DAMPING


class Rest(NamedTuple):
    """A step at rest, as `states_at` and `interpolant` need it: the start's `q0`, `p0`,
    the step `h` [s], the modes (`V`, `lam`, modal damping `d`, `V^T M`), the elastic
    modes' equilibrium `shift` under the load and the rigid modes' modal force."""

    q0: np.ndarray
    p0: np.ndarray
    h: float
    V: np.ndarray
    lam: np.ndarray
    d: np.ndarray
    VtM: np.ndarray
    shift: np.ndarray
    rigid_force: np.ndarray


def exact_propagator(system, lengths, h):
    """exp(h B) for fixed lengths (G = N = 0) from the modes of (K, M): the
    propagator, the mode matrix `V`, eigenvalues `lam` (omega^2; 0 for a free hub's
    rigid-body modes), modal damping `d` and `V^T M`.

    With V^T M V = I and K V = M V diag(lam): eta = V^T M q, etad = V^T p, and each
    mode moves by its own 2 x 2 propagator (`modal_propagator`); Rayleigh damping
    is classical (`V^T C_d V = diag(d)`).
    """
    zero = np.zeros(4)
    M, K, C_d = system.assemble((MASS, STIFFNESS, STRUCTURAL_DAMPING), lengths, zero, zero)
    lam, V = system.modes_of(M, K)
    # diag(V^T C_d V): classical damping; none without Rayleigh damping (the sum over
    # n^2 products of each mode costs most of the step at hundreds of coordinates)
    d = np.einsum("ij,ik,kj->j", V, C_d, V) if C_d.any() else np.zeros(lam.size)
    c, s, sd, cd = modal_propagator(lam, d, h)
    VtM = V.T @ M  # eta = VtM q; q = V eta; p = VtM^T etad
    n = system.n
    P = np.empty((2 * n, 2 * n))
    P[:n, :n] = (V * c) @ VtM
    P[:n, n:] = (V * s) @ V.T
    P[n:, :n] = (VtM.T * sd) @ VtM
    P[n:, n:] = (VtM.T * cd) @ V.T
    return P, V, lam, d, VtM


def rest_step(propagator, q, p, h, force) -> tuple[np.ndarray, np.ndarray, Rest]:
    """The exact step of `h` [s] from `(q, p)` under the held generalised force `force`
    [N] (None: none), `propagator` being `exact_propagator` at the lengths and `h`:
    `(q1, p1, Rest)`."""
    P, V, lam, d, VtM = propagator
    n = q.size
    x = np.concatenate([q, p])
    shift = np.zeros(n)  # the elastic modes' equilibrium under the load
    rigid_force = np.zeros(lam.size)  # modal force on the rigid-body modes (lam = 0)
    if force is None:
        x = P @ x
    else:  # elastic modes about their equilibrium q_s = K^-1 Q (p_s = 0: nothing moves
        # there); rigid ones (model.md §13.7) accelerate uniformly: eta += h^2 f / 2,
        # etad += h f
        rigid = lam == 0.0
        modal = V.T @ force
        elastic = ~rigid
        shift = V[:, elastic] @ (modal[elastic] / lam[elastic])
        rigid_force[rigid] = modal[rigid]
        x[:n] -= shift
        x = P @ x
        x[:n] += shift + V @ (0.5 * h * h * rigid_force)
        x[n:] += VtM.T @ (h * rigid_force)
    return x[:n], x[n:], Rest(q, p, h, V, lam, d, VtM, shift, rigid_force)


def rest_states(rest: Rest, fractions) -> tuple[np.ndarray, np.ndarray]:
    """`(q, qd)` (each (m, n)) at `fractions` (m,) of a step at rest, each mode by its
    own exact propagator over `f h` about the equilibrium of its load (at rest `G = 0`
    and `qd = M^-1 p = V etad`)."""
    tau = np.asarray(fractions, dtype=float)[:, None] * rest.h
    c, s, sd, cd = modal_propagator(rest.lam, rest.d, tau)
    eta0 = rest.VtM @ (rest.q0 - rest.shift)  # q = shift + V eta, p = VtM^T etad
    etad0 = rest.V.T @ rest.p0
    eta = c * eta0 + s * etad0 + 0.5 * tau**2 * rest.rigid_force
    etad = sd * eta0 + cd * etad0 + tau * rest.rigid_force
    return rest.shift + eta @ rest.V.T, etad @ rest.V.T


def modal_propagator(lam, d, tau):
    """`exp(tau [[0, 1], [-lam, -d]])` of every mode as its four entries `(c, s, sd, cd)`:
    `eta(tau) = c eta + s etad`, `etad(tau) = sd eta + cd etad`, for modal stiffness `lam`
    (omega^2; < 0 for a buckled mode) and damping `d` (n,), at times `tau` [s] (a scalar
    or an array broadcasting against (n,)).

    Undamped: `c = cos(omega tau)`, `s = sin(omega tau) / omega` (cosh and sinh for
    lam < 0; `s -> tau` at lam = 0). Damped: from the roots `r = -d/2 +- sqrt(d^2/4 -
    lam)` of each mode, `exp(tau A) = (r1 e^(r2 tau) - r2 e^(r1 tau)) / (r1 - r2) I +
    (e^(r1 tau) - e^(r2 tau)) / (r1 - r2) A`, in complex arithmetic; a critically
    damped mode (equal roots) takes its limit `e^(r tau) ((1 - r tau) I + tau A)`."""
    lam = np.asarray(lam, dtype=float)
    d = np.asarray(d, dtype=float)
    tau = np.asarray(tau, dtype=float)
    if not np.any(d):
        root = np.sqrt(np.abs(lam))
        # the hyperbolic branch only where a mode is buckled: a stiff mode's cosh would
        # overflow in the branch np.where discards
        grow = np.where(lam < 0, root * tau, 0.0)
        c = np.where(lam >= 0, np.cos(root * tau), np.cosh(grow))
        s = np.where(
            lam >= 0,
            tau * np.sinc(root * tau / np.pi),
            np.sinh(grow) / np.where(root > 0, root, 1.0),
        )
        return c, s, -lam * s, c
    half = np.sqrt((0.25 * d * d - lam).astype(complex))
    r2 = -0.5 * d - half
    # r1 r2 = lam: the slow root of an overdamped mode without cancellation
    r1 = np.where(r2 != 0, lam / np.where(r2 != 0, r2, 1.0), -0.5 * d + half)
    e1, e2 = np.exp(r1 * tau), np.exp(r2 * tau)
    gap = r1 - r2
    equal = np.abs(gap) <= 1e-12 * np.maximum(np.abs(r1), 1.0)
    safe = np.where(equal, 1.0, gap)
    # exp(tau A) = a I + b A with A = [[0, 1], [-lam, -d]]
    a = np.where(equal, e1 * (1.0 - r1 * tau), (r1 * e2 - r2 * e1) / safe)
    b = np.where(equal, tau * e1, (e1 - e2) / safe)
    return a.real, b.real, (-lam * b).real, (a - d * b).real


def rest_curve(rest: Rest, fractions, rows) -> tuple[np.ndarray, np.ndarray]:
    """`rows q`, `rows qd` (each (m, r)) at `fractions` (m,) of the step at rest `rest`."""
    q, qd = rest_states(rest, fractions)
    return q @ rows.T, qd @ rows.T
