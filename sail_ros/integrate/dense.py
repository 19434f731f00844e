"""Dense output: the state inside an accepted step, one small class per step kind.

At rest each mode's exact propagator from the step's start (`RestDense`); moving, the
step's continuous extension (`MovingDense`): each rational step's own resolvent
solutions recombined with the weights `R_f` (`rational.extension_weights`), the
followed modes turned in phase.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sail_ros.integrate.rational import PADE_POLES, Extension, extended_momentum, extension_weights
from sail_ros.integrate.rest import Rest, rest_curve, rest_states

# The moving system's frequencies lie within this factor of its frozen modes' (the motion's
# gyroscopic and `N` terms shift them by `|Ld| beta / (L omega)`, below 1e-2: `fast_modes`)
CARRIED_MARGIN = 1.1


class RestDense:
    """A step at rest: `Rest` (`rest.rest_step`), what the peaks sample too."""

    def __init__(self, rest: Rest):
        self.rest = rest

    @property
    def curve_data(self) -> Rest:
        return self.rest

    def states(self, fractions, qd0, qd1, rates):
        """`(q, qd)` (each (m, n)) at `fractions` (m,) of the step; `rates` None: `qd` nan."""
        q, qd = rest_states(self.rest, fractions)
        if rates is None:
            qd[:] = math.nan
        return q, qd

    def curve(self, fractions, rows):
        return rest_curve(self.rest, fractions, rows)


class MovingDense:
    """A moving step of `h` [s] from `t0` [s] (`moving.Trial`) under the system `at`
    (`SystemAt`)."""

    def __init__(self, at, t0: float, h: float, trial):
        self.at, self.t0, self.h, self.trial = at, t0, h, trial
        self._half_velocity = None

    @functools.cached_property
    def extension(self) -> Extension:
        """The step's continuous extension: its `slow` [rad/s] bounds the frequencies of
        all but the followed modes: the highest frozen mode the rational steps carry
        (`CARRIED_MARGIN` over it, and the rise of a boom's frequencies as `1 / L^2`
        where the step shortens it), at most the turning of their extensions
        (polynomials of degree 2 k = 4 in each rational step's fraction, k the Padé pole
        pairs, turning at most that often: `2 pi k` over a rational step)."""
        trial, h = self.trial, self.h
        turning = 2.0 * math.pi * PADE_POLES.size * len(trial.extensions) / h
        shortening = float((self.at.motion(self.t0)[0] / self.at.motion(self.t0 + h)[0]).max())
        carried = trial.carried_frequency * CARRIED_MARGIN * max(1.0, shortening) ** 2
        slow = min(turning, carried)
        return Extension(
            trial.extensions, trial.vibration, h, slow, trial.middle_omega_d, trial.middle_chirps
        )

    @property
    def curve_data(self) -> Extension:
        return self.extension

    def curve(self, fractions, rows):
        return self.extension.curve(fractions, rows)

    def states(self, fractions, qd0, qd1, rates="extension"):
        """`(q, qd)` (each (m, n)) at `fractions` (m values in (0, 1)) of the step, given
        the velocities `qd0`, `qd1` [m/s] at its ends.

        `q(f) = c q0 + sum_k 2 Re[w_k y_q,k]` for each rational step, and with the
        midpoint matrices `M^-1 (p - G q)(f) = c qd*_0 + sum_k 2 Re[w_k u_k]`; `qd*_0` (the
        start's velocity under the midpoint matrices) is taken as the velocity at the
        rational step's start, and a term linear in `f` makes both ends exact; the
        difference is of the midpoint rule's own order. The followed modes are put in as
        the start's free vibration turned on (first half) or the end's turned back.

        `rates`: "extension", as above, at no cost (the live grid; off by about 0.3 % of
        peak on the reference deployment); "exact", the extension's canonical momenta
        `p(f)` and `qd = M^-1 (p - G q)` with the matrices at each sample's own time, so
        that linear invariants (a free hub's momenta) hold at the samples as at the steps'
        ends and the rates are as accurate as the positions; None, none (`qd` nan)."""
        ext = self.extension
        fractions = np.atleast_1d(np.asarray(fractions, dtype=float))
        parts, h, t0 = ext.parts, self.h, self.t0
        # the ends of each rational step: the step's ends, and its middle when halved
        # (the extension's rates start and end there; exact rates need no ends)
        if parts == 2 and rates == "extension":
            if self._half_velocity is None:
                q_half, _, _, _, p_half, _ = ext.extensions[1]
                self._half_velocity = self.at.velocity(
                    t0 + 0.5 * h, q_half, p_half, self.trial.middle
                )
            ends = ((qd0, self._half_velocity), (self._half_velocity, qd1))
        elif rates == "extension":
            ends = ((qd0, qd1),)
        n = ext.extensions[0][0].size
        q = np.empty((fractions.size, n))
        qd = np.full_like(q, math.nan) if rates is None else np.empty_like(q)
        momenta = np.empty_like(q) if rates == "exact" else None
        part = np.minimum((fractions * parts).astype(int), parts - 1)
        local = fractions * parts - part
        weights = extension_weights(local)  # every sample's in one solve
        for k in range(parts):
            inside = part == k
            if not inside.any():
                continue
            q_start, y_q, u, v, p_start, mats = ext.extensions[k]
            c, w = weights[0][inside], weights[1][inside]
            q[inside] = np.outer(c, q_start) + 2.0 * (w @ y_q).real
            if rates is None:
                continue
            velocity = 2.0 * (w @ u).real  # sum_k 2 Re[w_k u_k]
            if rates == "exact":
                momenta[inside] = extended_momentum(mats, c, velocity, q[inside], q_start, p_start)
            else:
                start_qd, end_qd = ends[k]
                drift = np.outer(local[inside], end_qd - start_qd - 2.0 * v)
                qd[inside] = np.outer(c, start_qd) + velocity + drift
        times = t0 + fractions * h
        if rates == "exact":  # every sample's matrices in one pass
            qd[:] = self.at.velocities(times, q, momenta)
        if not ext.vibration:
            return q, qd
        for k in range(parts):  # the followed modes put in
            inside = part == k
            if not inside.any():
                continue
            if rates is None:
                q[inside] = ext.kept(q[inside], k) + ext.free(k, local[inside], velocities=False)
                continue
            q_free, qd_free = ext.free(k, local[inside])
            q[inside] = ext.kept(q[inside], k) + q_free
            qd[inside] = ext.kept(qd[inside], k) + qd_free
        if rates == "exact" and self.at.invariant is not None:
            qd[:] = self.at.velocities(times, q, momenta, qd)
        return q, qd
