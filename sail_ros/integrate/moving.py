"""The moving step: two exponential-midpoint steps of `h / 2` with the rational
approximant, one of `h` for the error estimate, and the high modes followed.

In canonical variables `x = [q; p]`, `p = M qd + G q`, Eq. 2 with damping and the
inputs' generalised forces reads `xd = B(t) x + f`; each step applies
`x1 = R(h B) x0 + h phi_R(h B) f`, `B` and `f` at the step's middle (second-order Magnus,
`rational.moving_step`). The modes a midpoint step does not resolve are followed in
their frozen modes instead (`fast_modes`). The error of the two halves is estimated as a
third of their difference from the whole on the outputs (the rule is of order 2).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sail_ros.integrate.control import largest
from sail_ros.integrate.fast_modes import (
    TURN_BACK_EXPONENT,
    FreeVibration,
    chirps,
    follow,
    follow_floor,
    followed,
    forcing_of,
    middle_frequencies,
    modal_damping,
    slow_part,
    turned,
)
from sail_ros.integrate.rational import extension_weights, moving_step
from sail_ros.integrate.system import potrs

# the continuous extension's weights at a step's middle (`extension_weights`)
_MIDDLE = extension_weights(np.array([0.5]))


class Trial(NamedTuple):
    """One attempted moving step: the state at its end, its error against the tolerance
    (<= 1 meets it), and what dense output needs: the rational steps' extensions and the
    followed modes."""

    q: np.ndarray
    p: np.ndarray
    qd: np.ndarray | None
    error: float
    extensions: tuple
    vibration: tuple  # (FreeVibration at the start, at the end) or ()
    middle: object = None  # the whole step's matrices (`STEP_MATRICES`), at its middle
    outputs: np.ndarray | None = None  # the end's largest outputs (`control.largest`)
    # [rad/s] the highest frozen mode the rational steps carry at the start (not followed)
    carried_frequency: float = math.inf
    # the run of local extrapolations at the step's end (`attempt`): (q, p, and its
    # distance from the step's end per output kind, `control.largest`)
    companion: tuple | None = None
    # the dense output's error inside the step per output kind (`attempt`): the
    # extension's, and half the followed modes' jump at the middle
    interpolation: np.ndarray | None = None
    # [rad/s] the followed modes' damped frequencies at the step's middle, or None, and
    # the chirps of their phase from the start and from the end (`fast_modes.chirps`)
    middle_omega_d: np.ndarray | None = None
    middle_chirps: tuple | None = None


def rational_step(at, force_at, t0, q0, p0, h, mats=None, companion=None):
    """One exponential-midpoint step of `h` [s] from `(q0, p0)` at `t0` with the rational
    approximant: `(q1, p1, extension)`; `at` the `SystemAt`, `force_at(t, lengths)` the
    inputs' generalised force (or None), `mats` the matrices at the middle if at hand.
    With a `companion` start `(q, p)`, its step too, with the same solves: `(q1, p1,
    extension, (q, p) at the end)` (`rational.moving_step`)."""
    t_mid = t0 + 0.5 * h
    lengths = at.motion(t_mid)[0]
    force = force_at(t_mid, lengths)
    if mats is None:
        (mats,) = at.step_matrices((t_mid,))
    return moving_step(q0, p0, mats, h, force, companion)


def _replaced(end, q, qd, p, M, G, factor, invariant):
    """`(q, qd, p)` with the followed modes' part replaced by their vibration `end`, the
    momenta as `_momenta` keeps them (the followed modes are frozen modes, blind to the
    gyroscopic coupling that carries momentum to the hub while the booms move)."""
    q, qd = end.replace_in(q, qd)
    return (q, *_momenta(q, qd, p, M, G, factor, invariant))


def _momenta(q, qd, p, M, G, factor, invariant):
    """`(qd, p_new)` for a state `(q, qd)` changed from one of momenta `p`: `p_new = M qd +
    G q` but on `invariant` (a free hub's coordinates: cyclic, their momenta linear
    invariants, which the rational step keeps exactly), where `p` is kept and the
    velocities are made to agree (`factor`: the Cholesky factor of `M`)."""
    p_new = M @ qd + G @ q
    if invariant is None:
        return qd, p_new
    p_new[invariant] = p[invariant]
    return potrs(factor, p_new - G @ q)[0], p_new


def _middle_jump(vibration, bends, q_middle, h, rows) -> np.ndarray:
    """`rows` (r, n) of the step's state at its middle as the first half represents it
    (the start's followed modes turned on by `h / 2` [s]) less as the second does (the
    end's turned back), the phases bent by `bends` (`fast_modes.chirps`): the slow part
    of `q_middle` in each set of modes, and each set's vibration there."""
    start, end = vibration
    m = start.count
    parts = []
    for vib, t, bend in ((start, 0.5 * h, bends[0]), (end, -0.5 * h, bends[1])):
        modes = vib.modes
        wd, d = modes.omega_d[-m:], modes.d[-m:]
        grow = np.minimum(-0.5 * d * t, TURN_BACK_EXPONENT)
        e = (vib.a * np.exp(1j * turned(t, wd, bend) + grow)).real + vib.s
        parts.append(rows @ slow_part(modes, m, q_middle) + (rows @ modes.V[:, -m:]) @ e)
    return parts[0] - parts[1]


def fixed(at, force_at, t0, q0, p0, h) -> Trial:
    """One rational step of `h` [s], no estimate (fixed steps)."""
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported on commit
        q, p, extension = rational_step(at, force_at, t0, q0, p0, h)
    return Trial(q, p, None, 0.0, (extension,), ())


def attempt(at, force_at, input_at, t0, q0, p0, qd0, h, error_of, companion=None) -> Trial:
    """The moving step of `h` [s] from `(q0, p0)` (velocities `qd0`) at `t0`: two rational
    steps of `h / 2` and one of `h`, the high modes followed over the step in both
    results; `input_at(t)` the inputs (None without), `error_of(estimate, outputs)` the
    controller's error (`StepControl.error`).

    `companion` `(q, p)`: a run beside the steps' whose every step end is moved by the
    step's local error estimate (the run of local extrapolations): stepped with the
    halves' factorisations, its difference from the steps' run is their local errors
    carried to the step's end, the run's error estimate (`Trial.companion`).
    `Trial.interpolation`: the extension's error inside the step, from the whole step's
    extension at its middle against the halves' state there, over `2^5` (the extension
    matches `exp` to order 4; the followed modes' part of that difference, which the
    rational steps carry at hundreds of rad, stands for the followed modes' error:
    model.md §11), plus half the jump of the followed modes' representation at the
    middle (the start's turned on, the end's turned back: the state lies between)."""
    half, t1 = t0 + 0.5 * h, t0 + h
    # the three rational steps' middles, as `rational_step` finds them
    mats = at.step_matrices((t0 + 0.5 * (0.5 * h), half + 0.5 * (0.5 * h), half))
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported on commit
        if companion is None:
            qh, ph, first = rational_step(at, force_at, t0, q0, p0, 0.5 * h, mats[0])
            q2, p2, second = rational_step(at, force_at, half, qh, ph, 0.5 * h, mats[1])
            qc, pc = q2, p2
        else:
            qh, ph, first, middle = rational_step(
                at, force_at, t0, q0, p0, 0.5 * h, mats[0], companion
            )
            q2, p2, second, (qc, pc) = rational_step(
                at, force_at, half, qh, ph, 0.5 * h, mats[1], middle
            )
        q1, p1, whole = rational_step(at, force_at, t0, q0, p0, h, mats[2])
        lengths0, lengths1 = at.motion(t0)[0], at.motion(t1)[0]
        C1, K_extra1, _, M1, G1 = at.matrices(t1)
        factor, _ = at.mass_factor(t1)
        # (n, 3) in LAPACK's column order: no copy on the way in
        qd2, qd1, qdc = potrs(factor, np.array([p2 - G1 @ q2, p1 - G1 @ q1, pc - G1 @ qc]).T)[0].T
    vibration = ()
    modes0 = at.modes(t0)
    floor = follow_floor(0.5 * h, at.resolved(lengths0), at.relative_rate(t0, h))
    count = followed(modes0, floor)
    if count == modes0.omega.size and modes0.below > floor:
        # a set carried on from a shorter step, all of it followed, leaves out modes this
        # step would follow too: all of them afresh
        modes0 = at.modes(t0, None, at.system.n)
        count = followed(modes0, floor)
    if count:
        modes1 = at.modes(t1, modes0, count)
        u = input_at(t0 + 0.5 * h)
        C0, K_extra0, _, _, _ = at.matrices(t0)
        start = FreeVibration.of(
            modes0,
            count,
            q0,
            qd0,
            forcing_of(modes0, count, at.held(u, lengths0), (C0, K_extra0), q0, qd0),
        )
        # the end's slow part is the rational steps' (the halves' and the whole's agree
        # there to the error estimated)
        forcing = forcing_of(modes1, count, at.held(u, lengths1), (C1, K_extra1), q2, qd2)
        middle_omega_d = middle_frequencies(modes0, modes1, count, mats[2], at.rayleigh)
        bends = chirps(modes0.omega_d[-count:], middle_omega_d, modes1.omega_d[-count:], h)
        damping = (modal_damping(modes0, count, C0), modal_damping(modes1, count, C1))
        end = follow(start, modes1, h, forcing, middle_omega_d, damping)
        # the whole step's followed modes are the halves': they leave the estimate
        dq, dqd = slow_part(modes1, count, q2 - q1), slow_part(modes1, count, qd2 - qd1)
        q2, qd2, p2 = _replaced(end, q2, qd2, p2, M1, G1, factor, at.invariant)
        if companion is not None:  # the companion takes the same followed modes
            qc, qdc, pc = _replaced(end, qc, qdc, pc, M1, G1, factor, at.invariant)
        vibration = (start, end)
    else:
        dq, dqd = q2 - q1, qd2 - qd1
    if companion is not None:  # the halves' error is a third of their difference
        qc, qdc = qc + dq / 3.0, qdc + dqd / 3.0
        # a free hub's momenta: exact in every run
        qdc, pc = _momenta(qc, qdc, pc, M1, G1, factor, at.invariant)
    rows = at.rows(lengths1)
    estimate = largest(rows, dq, dqd) / 3.0
    c, w = _MIDDLE
    whole_middle = c[0] * q0 + 2.0 * (w[0] @ whole[1]).real
    interpolation = largest(rows, whole_middle - qh, np.zeros_like(qh)) / 2.0**5
    if count:  # half the jump of the followed modes' representation at the middle
        jump = _middle_jump(vibration, bends, qh, h, rows)
        interpolation[[0, 2]] += 0.5 * np.abs(jump).reshape(2, 4).max(axis=1)
    outputs = largest(rows, q2, qd2)
    # the highest mode not followed: the next below those followed, or, when a set
    # carried on (the highest modes only) is followed whole, below its lowest
    if count < modes0.omega.size:
        carried = float(modes0.omega[-count - 1])
    else:
        carried = float(modes0.omega[0]) if modes0.omega.size < at.system.n else 0.0
    return Trial(
        q2,
        p2,
        qd2,
        error_of(estimate, outputs),
        (first, second),
        vibration,
        mats[2],
        outputs,
        carried,
        None if companion is None else (qc, pc, largest(rows, q2 - qc, qd2 - qdc)),
        interpolation,
        middle_omega_d if count else None,
        bends if count else None,
    )
