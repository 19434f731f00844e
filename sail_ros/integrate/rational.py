"""The rational step: the exponential midpoint rule with the (4, 4) Padé approximant of
`exp`, and its continuous extension (docs/model.md §4, §11).

One step of `h` from `x = [q; p]` is `x1 = R(h B) x0 + h phi_R(h B) f`, `B` and `f`
at the step's middle. Split into partial fractions, each conjugate pair of `R`'s poles
costs one complex `n x n` solve with `M + tau (G - G^T + C_d) + tau^2 (K - N)`, and the
same solves give `phi_R` (the force changes only the right-hand side). Undamped, `B` is
Hamiltonian and the step symplectic: high modes keep unit amplification and lag only
in phase; damped, none grows (the approximant is A-stable).

Inside a step, `R_f` (the same poles, Taylor series equal to `exp(f z)` to order 4)
recombines the step's own solves into the state at a fraction `f` of it, at no further
solve: `Extension` holds them, with the followed modes (`fast_modes`) put in turned.
"""

from __future__ import annotations

import functools
from math import factorial

import numpy as np
import scipy.linalg

from sail_ros.integrate.fast_modes import (
    TURN_BACK_EXPONENT,
    frequency_ratio,
    oscillation,
    turning,
)
from sail_ros.model.blocks import DenseMatrices
from sail_ros.model.lapack import getrs as _getrs  # what `lu_solve` calls


def _diagonal_pade_partial_fractions(order: int):
    """Constant term and (pole, residue) pairs of the (order, order) Padé
    approximant of exp(z), one pole of each conjugate pair (order even)."""
    c = [
        factorial(2 * order - j)
        * factorial(order)
        / (factorial(2 * order) * factorial(j) * factorial(order - j))
        for j in range(order + 1)
    ]
    numerator = np.polynomial.Polynomial(c)
    denominator = np.polynomial.Polynomial([cj * (-1) ** j for j, cj in enumerate(c)])
    poles = denominator.roots()
    residues = numerator(poles) / denominator.deriv()(poles)
    upper = poles.imag > 0
    return float((-1) ** order), poles[upper], residues[upper]


PADE_ORDER = 4
_PADE_CONSTANT, PADE_POLES, _PADE_RESIDUES = _diagonal_pade_partial_fractions(PADE_ORDER)
PADE_WEIGHTS = -_PADE_RESIDUES / PADE_POLES  # r_k (hB - z_k)^-1 = -(r_k / z_k) (I - tau_k B)^-1
_PADE_WEIGHT_SUM = float(PADE_WEIGHTS.real.sum())


def _extension_system() -> np.ndarray:
    """The LU factors of the linear map from `(c, Re w_k, Im w_k)` to the Taylor
    coefficients of `R_f(z) = c + sum_k 2 Re[w_k / (1 - z / z_k)]` up to order 4: the
    coefficient of `z^m` is `c [m = 0] + 2 Re sum_k w_k z_k^-m`."""
    rows = []
    for m in range(2 * PADE_POLES.size + 1):
        g = 2.0 * PADE_POLES ** (-m)  # Re(w g) = Re w Re g - Im w Im g
        rows.append([float(m == 0), *np.column_stack([g.real, -g.imag]).ravel()])
    return scipy.linalg.lu_factor(np.array(rows))


_EXTENSION_FACTORS = _extension_system()
_EXTENSION_ORDERS = np.arange(2 * PADE_POLES.size + 1)
_EXTENSION_FACTORIALS = np.array([factorial(m) for m in _EXTENSION_ORDERS], dtype=float)


def _weights(fractions, slope: bool = False) -> np.ndarray:
    """(5, m): `(c, Re w_1, Im w_1, Re w_2, Im w_2)` of `extension_weights` at each of
    `fractions` (m,), one column each; with `slope`, those of `dR_f / df`."""
    f = np.atleast_1d(np.asarray(fractions, dtype=float))
    m = _EXTENSION_ORDERS[:, None]
    if slope:
        rhs = m * f[None, :] ** np.maximum(m - 1, 0) / _EXTENSION_FACTORIALS[:, None]
    else:
        rhs = f[None, :] ** m / _EXTENSION_FACTORIALS[:, None]
    x, _ = _getrs(*_EXTENSION_FACTORS, rhs)
    return x


def extension_weights(fractions, slope: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """`(c, w)` ((m,) and (m, 2)) of `R_f(z) = c + sum_k 2 Re[w_k / (1 - z / z_k)]`, the
    continuous extension of the step's Padé approximant to the fractions `f` of the step:
    same poles `z_k`, Taylor series equal to `exp(f z)` to order 4 (error ~(omega h)^5
    for a mode), `R_1` the approximant itself. On the imaginary axis `|R_f| <= 1` for
    the fractions j / k, k <= 5 (an undamped mode is not amplified), at most 1.026 for
    k <= 20 (near f = 0 or 1, at omega h ~ 5.5); the extension only samples, nothing
    integrated grows. With `slope`, the weights of `dR_f / df` (the same conditions on
    the derivative of the Taylor series, `m f^(m-1) / m!`)."""
    x = _weights(fractions, slope)
    return x[0], (x[1::2] + 1j * x[2::2]).T


class Extension:
    """A moving step's continuous extension (`SailStepper.between`): its rational steps
    (the `parts` of the step of `h` [s], each with its own fraction `f`), each as
    `moving_step` returns its `extension`, and their followed modes (`fast_modes`: the
    first half's free vibration at the step's start, the second's at its end,
    `vibration`), whose part the extension's samples leave (`kept`) and take turned
    instead (`free`); `curve` and `followed` for the peaks (`Curves`, of this step
    alone). `slow` [rad/s]: what bounds the frequencies of all but the followed modes
    in its samples (`SailStepper.last_curve`); `middle_omega_d` [rad/s], the followed
    modes' damped frequencies at the step's middle, through which their phase turns,
    bent by `middle_chirps` (`fast_modes.chirps`, from the start and from the end)."""

    def __init__(
        self,
        extensions: tuple,
        vibration: tuple,
        h: float,
        slow: float,
        middle_omega_d=None,
        middle_chirps=None,
    ):
        self.extensions = extensions
        self.parts = len(extensions)
        self.h = h
        self.vibration = vibration
        self.slow = slow
        self.count = vibration[0].count if vibration else 0
        self.middle_omega_d = middle_omega_d
        self.middle_chirps = middle_chirps

    @functools.cached_property
    def curves(self) -> Curves:
        """This step alone as `Curves`."""
        return Curves((self,))

    def part_modes(self, part: int) -> tuple:
        """The followed modes of rational step `part` (the step's free vibration at its
        start for the first half, at its end for the second): `(V, MV, omega_d, d, static,
        a, chirp)` of the `count` modes; `chirp` (`fast_modes.chirps`) None where the step
        has none."""
        near, k = self.vibration[part], self.count
        modes = near.modes
        chirp = None if self.middle_omega_d is None else self.middle_chirps[part]
        return (
            modes.V[:, -k:],
            modes.MV[:, -k:],
            modes.omega_d[-k:],
            modes.d[-k:],
            near.s,
            near.a,
            chirp,
        )

    @functools.cached_property
    def _followed_parts(self) -> tuple:
        """Per rational step, its followed modes as `free` and `kept` use them: `(V, MV,
        omega_d, decay, chirp, on_e, on_v, static)`, as `Curves` holds them for this step
        alone, without the padding and stacking that several steps need."""
        parts = [self.part_modes(part) for part in range(len(self.vibration))]
        damped = any(d.any() for _, _, _, d, *_ in parts)
        followed = []
        for V, MV, omega_d, d, static, a, chirp in parts:
            decay = d if damped else None
            on_e, on_v = turning(a, omega_d, decay)
            chirp = np.zeros((self.count, 2)) if chirp is None else chirp
            followed.append((V, MV, omega_d, decay, chirp, on_e, on_v, static))
        return tuple(followed)

    def followed(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """`Curves.followed` of this step: (k,) and (r, k)."""
        omega, amplitude = self.curves.followed(rows)
        return omega[0], amplitude[0]

    def curve(self, fractions, rows) -> tuple[np.ndarray, np.ndarray]:
        """`Curves.curve` of this step at `fractions` (m,) of it."""
        fractions = np.asarray(fractions, dtype=float)
        return self.curves.curve(np.zeros(fractions.size, dtype=int), fractions, rows)

    def jumps(self) -> tuple[float, ...]:
        """Fractions of the step where the curve may jump: its middle, where the followed
        modes' static response passes from the start's to the end's (none without)."""
        return (0.5,) if self.vibration and self.parts == 2 else ()

    def kept(self, x: np.ndarray, part: int) -> np.ndarray:
        """`x` (m, n): the rational step `part`'s coordinates or velocities less their part
        in its followed modes."""
        if not self.vibration:
            return x
        V, MV, *_ = self._followed_parts[part]
        return x - (x @ MV) @ V.T

    def free(self, part: int, local, velocities: bool = True):
        """The followed modes' coordinates and velocities (each (m, n)) at fractions
        `local` (m,) of the rational step `part`: its free vibration turned on by `(local
        - part) h / parts` (`fast_modes.oscillation`, `fast_modes.turning`); without
        `velocities`, the coordinates alone."""
        V, _, omega_d, decay, chirp, on_e, on_v, static = self._followed_parts[part]
        seconds = (local - part) * (self.h / self.parts)
        turns = oscillation(seconds, omega_d, decay, chirp)
        count = self.count
        shapes = V.T
        e = turns * on_e
        e = e[:, :count] + e[:, count:] + static
        if not velocities:
            return e @ shapes
        v = turns * on_v
        v = (v[:, :count] + v[:, count:]) * frequency_ratio(seconds, omega_d, chirp)
        return e @ shapes, v @ shapes


class Curves:
    """The continuous extensions (`Extension`) of moving steps of as many rational steps
    (`parts`) each, stacked: the peaks sample many steps in a few calls, where one step's
    few samples cost what numpy's calls do, not their arithmetic. A step's followed
    modes are padded to the most any has (`count`) with null ones (no shape, frequency 0,
    amplitude 0), which add nothing to its curve.

    Attributes (S steps): `h` (S,) [s]; `count` the most followed modes of any; `V`,
    `MV` (S, parts, n, count) their shapes and `M V` at each part's end; `omega_d`,
    `decay`, `static` (S, parts, count) (`decay` None: all undamped); `on_e`, `on_v`
    (S, parts, 2 count) (`fast_modes.turning`).
    """

    def __init__(self, steps):
        steps = tuple(steps)
        first = steps[0]
        self.parts, n = first.parts, first.extensions[0][0].size
        if any(step.parts != self.parts for step in steps):
            raise ValueError("Curves: steps of different numbers of rational steps")
        # the rational steps' own results, not the steps (an `Extension` holds its
        # `Curves`: no reference cycle keeps a step's matrices alive after it)
        self._extensions = [step.extensions for step in steps]
        self.h = np.array([step.h for step in steps])
        count = self.count = max(step.count for step in steps)
        shape = (len(steps), self.parts)
        self.V, self.MV = np.zeros((*shape, n, count)), np.zeros((*shape, n, count))
        omega_d, decay = np.zeros((*shape, count)), np.zeros((*shape, count))
        self.static, a = np.zeros((*shape, count)), np.zeros((*shape, count), dtype=complex)
        self.chirp = np.zeros((*shape, count, 2))
        self.omega_middle = np.zeros((len(steps), count))
        for i, step in enumerate(steps):
            pad = count - step.count  # the null modes first
            for part in range(len(step.vibration)):
                V, MV, wd, d, static, amplitude, chirp = step.part_modes(part)
                self.V[i, part, :, pad:], self.MV[i, part, :, pad:] = V, MV
                omega_d[i, part, pad:], decay[i, part, pad:] = wd, d
                self.static[i, part, pad:], a[i, part, pad:] = static, amplitude
                if chirp is not None:
                    self.chirp[i, part, pad:] = chirp
            if step.count and step.middle_omega_d is not None:
                self.omega_middle[i, pad:] = step.middle_omega_d
        self.omega_d = omega_d
        self.decay = decay if decay.any() else None
        self.on_e, self.on_v = turning(a, omega_d, self.decay)
        self._coefficients_of = ((), None)  # (rows, `coefficients`): none yet

    @functools.cached_property
    def raw(self) -> np.ndarray:
        """(S, parts, 5, n): the rows that the weights `(c, Re w_1, Im w_1, ...)` of a
        fraction combine into the coordinates (each rational step's start, `2 Re y_q,k`,
        `-2 Im y_q,k`), the followed modes' part included."""
        starts = np.array([[part[0] for part in step] for step in self._extensions])
        y_q = np.array([[part[1] for part in step] for step in self._extensions])
        raw = np.empty((*starts.shape[:2], _EXTENSION_ORDERS.size, starts.shape[2]))
        raw[:, :, 0], raw[:, :, 1::2], raw[:, :, 2::2] = starts, y_q.real, y_q.imag
        raw[:, :, 1:] *= _SIGNS
        return raw

    def coefficients(self, rows) -> np.ndarray:
        """(S, parts, 5 + 2 count, 2 r): what each rational step's features (`curve`) give
        the outputs `rows` (r, n; None: the coordinates) and their slopes: the
        extension's coordinates less their followed modes' part (`rows (x - V MV^T x) =
        rows x - (rows V) (MV^T x)`) through the weights' power series
        (`_POWER_WEIGHTS`; `_POWER_SLOPES`, per second), the static part on `x^0`, the
        followed modes' shapes weighted by `on_e` (`on_v`) on their turns
        (`Extension.free`); kept for the last rows asked."""
        if self._coefficients_of[0] is rows:
            return self._coefficients_of[1]
        count, raw = self.count, self.raw
        if rows is None:
            shapes, coordinates = self.V, raw
        else:
            shapes, coordinates = rows @ self.V, raw @ rows.T
        if count:
            coordinates = coordinates - (raw @ self.MV) @ np.swapaxes(shapes, -1, -2)
        steps, parts, orders, r = coordinates.shape
        X = np.empty((steps, parts, orders + 2 * count, 2 * r))
        powers = _POWER_SERIES @ coordinates  # (S, parts, 2 orders, r): weights, then slopes
        X[..., :orders, :r] = powers[..., :orders, :]
        per_second = (parts / self.h)[:, None, None, None]
        np.multiply(powers[..., orders:, :], per_second, out=X[..., :orders, r:])
        if count:
            shapes = np.swapaxes(shapes, -1, -2)  # (S, parts, count, r)
            X[..., orders : orders + count, :r] = shapes
            X[..., orders + count :, :r] = shapes
            X[..., orders:, r:] = X[..., orders:, :r]
            X[..., orders:, :r] *= self.on_e[..., None]
            X[..., orders:, r:] *= self.on_v[..., None]
            X[..., 0, :r] += (self.static[..., None, :] @ shapes)[..., 0, :]
        self._coefficients_of = (rows, X)
        return X

    def followed(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """The followed modes' frequencies [rad/s] (S, count) and the largest amplitude of
        each in each output row of `rows` (r, n) over its step (S, r, count): `|rows V_j|
        |a_j|` of the start's free vibration, and of the end's turned back over the second
        half (grown by `e^(d h / 4)` where damped; `oscillation`), read off the curve's
        coefficients of the turns (`coefficients`: `Re a rows V_j` on the cosine, `-Im a
        rows V_j` on the sine); a damped mode's frequency is `hypot(omega_d, d / 2)`,
        which its fourth derivative goes with. Null modes: 0 and 0."""
        count, orders = self.count, _EXTENSION_ORDERS.size
        X = self.coefficients(rows)
        r = X.shape[-1] // 2
        turns = X[..., orders:, :r]  # (S, parts, 2 count, r): cosines, then sines
        amplitude = np.hypot(turns[..., :count, :], turns[..., count:, :])
        omega = self.omega_d
        if self.decay is not None:  # the first half decays from the start: at most |a|
            seconds = (self.h / self.parts)[:, None, None]
            back = np.minimum(0.5 * self.decay[:, 1:] * seconds, TURN_BACK_EXPONENT)
            amplitude[:, 1:] *= np.exp(back)[..., None]
            omega = np.hypot(omega, 0.5 * self.decay)
        # the frequency between the ends passes through the middle's (`chirps`)
        highest = np.maximum(omega.max(axis=1), self.omega_middle)
        return highest, np.swapaxes(amplitude.max(axis=1), -1, -2)

    def curve(self, step, fractions, rows, grid=None) -> tuple[np.ndarray, np.ndarray]:
        """`rows q` and its slope `rows dq/dt` [per s] (each (m, r); `rows` None: `q` and
        `dq/dt` themselves) at `fractions` (m,) of the steps `step` (m,): each sample's
        features in its own rational step (the powers `x^j` of its fraction `x` of that
        step, the followed modes' turns) times that step's coefficients (`coefficients`).
        The same curve as `between`'s positions, summed otherwise (round-off apart).
        `grid`: each step's number of equal intervals (S,), most samples being at their
        ends (`_turns`)."""
        fractions = np.asarray(fractions, dtype=float)
        parts, m = self.parts, fractions.size
        part = np.minimum((fractions * parts).astype(int), parts - 1)
        local = fractions * parts - part
        orders = _EXTENSION_ORDERS.size
        count = self.count
        features = np.empty((m, orders + 2 * count))
        features[:, 0] = 1.0
        for j in range(1, orders):
            np.multiply(features[:, j - 1], local, out=features[:, j])
        slopes = features
        if count:
            # from the first half's start, back from the second half's end (`free`)
            seconds = (local - part) * (self.h[step] / parts)
            omega_d, chirp = self.omega_d[step, part], self.chirp[step, part]
            if grid is not None and self.decay is None and parts == 2:
                features[:, orders:] = self._turns(step, part, seconds, fractions, grid)
            else:
                decay = None if self.decay is None else self.decay[step, part]
                features[:, orders:] = oscillation(seconds, omega_d, decay, chirp)
            # the turns' velocities (`coefficients`) at the frequency of the moment
            slopes = features.copy()
            slopes[:, orders:] *= np.tile(frequency_ratio(seconds, omega_d, chirp), 2)
        X = self.coefficients(rows)
        X = X.reshape(-1, *X.shape[2:])
        r = X.shape[-1] // 2
        group = step * parts + part
        values = _grouped_products(features, group, X[..., :r])
        return values, _grouped_products(slopes, group, X[..., r:])

    def _turns(self, step, part, seconds, fractions, grid) -> np.ndarray:
        """`oscillation` of undamped followed modes at `seconds` (m,) (`curve`) of samples
        at `fractions` (m,) of their steps, each step of `grid` (S,) equal intervals: at
        an interval's end, `e` of them from its half's end (forward in the first half,
        back in the second), the phase is a cubic in `e` (`chirps`), whose turns are
        running products of running products of running products of one turn each (the
        third difference of a cubic is constant; round-off growing as `e^3`, 4e-12 at
        60, where cosines and sines would cost most of the peaks' time); the others (the
        middle's sides, times asked) their cosines and sines."""
        intervals = grid[step]
        position = fractions * intervals
        nearest = np.rint(position)
        power = np.where(part == 0, nearest, intervals - nearest).astype(int)
        count = self.count
        # the phase at e intervals from a half's end: a e + b e^2 + c e^3 (`oscillation`)
        spacing = np.array([1.0, -1.0])[None, :, None] * (self.h / grid)[:, None, None]
        a = self.omega_d * spacing
        b = self.chirp[..., 0] * spacing**2
        c = self.chirp[..., 1] * spacing**3
        longest = int(power.max(initial=0))
        z = np.ones((*a.shape[:2], longest + 1, count), dtype=complex)  # (S, 2, e, count)
        if longest:
            # the phase's differences: a + b + c at e = 1, growing by 2 b + 6 c at e = 2,
            # that growth by 6 c at each e after
            z[:, :, 1] = np.exp(1j * (a + b + c))
            if longest > 1:
                z[:, :, 2] = np.exp(1j * (2.0 * b + 6.0 * c))
                z[:, :, 3:] = np.exp(6j * c)[:, :, None, :]
                np.cumprod(z[:, :, 2:], axis=2, out=z[:, :, 2:])
            np.cumprod(z[:, :, 1:], axis=2, out=z[:, :, 1:])
            np.cumprod(z, axis=2, out=z)
        z = z[step, part, power]
        turns = np.empty((fractions.size, 2 * count))
        turns[:, :count], turns[:, count:] = z.real, z.imag
        off = np.flatnonzero(np.abs(position - nearest) > 1e-9 * intervals)
        if off.size:
            chirp = self.chirp[step[off], part[off]]
            turns[off] = oscillation(seconds[off], self.omega_d[step[off], part[off]], None, chirp)
        return turns


def _grouped_products(features, group, matrices) -> np.ndarray:
    """Each row of `features` (m, F) times its own matrix `matrices[group]` ((g, F, c),
    `group` (m,)): (m, c), one product per run of rows of one group (in group order)."""
    if len(matrices) == 1:
        return features @ matrices[0]
    order = None
    if np.any(group[1:] < group[:-1]):
        order = np.argsort(group, kind="stable")
        group, features = group[order], features[order]
    ends = np.append(np.flatnonzero(group[1:] != group[:-1]) + 1, group.size)
    out = np.empty((group.size, matrices.shape[2]))
    start = 0
    for end in ends.tolist():
        np.matmul(features[start:end], matrices[group[start]], out=out[start:end])
        start = end
    if order is None:
        return out
    unsorted = np.empty_like(out)
    unsorted[order] = out
    return unsorted


def _power_series() -> tuple[np.ndarray, np.ndarray]:
    """`(P, D)` (5, 5): the weights `(c, Re w_1, Im w_1, ...)` of `_weights` at `x` are
    `P^T [1, x, ..., x^4]` (they solve a linear system whose right-hand side is `x^m /
    m!`), so `rows . weights = [1, x, ..., x^4] . (P rows)`; `D` gives the slopes': the
    derivative of `x^m` is `m x^(m-1)`."""
    inverse, _ = _getrs(*_EXTENSION_FACTORS, np.diag(1.0 / _EXTENSION_FACTORIALS))
    P = inverse.T
    shift = np.diag(_EXTENSION_ORDERS[1:].astype(float), -1)  # d x^m / dx = m x^(m-1)
    return P, shift.T @ P


_POWER_WEIGHTS, _POWER_SLOPES = _power_series()
_POWER_SERIES = np.vstack([_POWER_WEIGHTS, _POWER_SLOPES])
# the factors of `Curves.raw`'s rows after the start: 2 Re y_q,k, -2 Im y_q,k
_SIGNS = np.array([2.0, -2.0] * PADE_POLES.size)[:, None]


def moving_step(q0, p0, mats, h, force, companion=None):
    """One step of `h` [s] from `(q0, p0)` with the matrices `mats` (`STEP_MATRICES`) at
    its middle and the generalised force `force` [N] (or None) held over it: `(q1, p1,
    extension)`, `extension` what `Extension` needs of it; with a `companion` start
    `(q, p)`, its step too, solved with the same factorisations: `(q1, p1, extension,
    (q, p) at the end)`.

    x1 = R(h B) x0 + h phi_R(h B) f with R the (4,4) Padé approximant of exp and
    phi_R(z) = (R(z) - 1) / z, by partial fractions:
    R(hB) x = c0 x + sum_k 2 Re[r_k (hB - z_k)^-1 x],
    h phi_R(hB) f = sum_k 2 Re[(h r_k / z_k) (hB - z_k)^-1 f], and
    (hB - z)^-1 x = -(1/z) (I - tau B)^-1 x with tau = h / z; so
    x1 = c0 x0 + sum_k 2 Re[w_k (I - tau_k B)^-1 (x0 + tau_k f)], w_k = -r_k / z_k.

    (I - tau B) y = x  <=>  [M + tau (G - G^T + C_d) + tau^2 (K - N)] u
    = x_p - (G + tau (K - N)) x_q, y_q = x_q + tau u, y_p = M u + G y_q; the real
    matrices act on the sums over k: q1 = c0 q0 + 2 s, p1 = c0 p0 + 2 (M v + G s),
    v = Re sum_k w_k u_k, s = Re sum_k w_k y_q,k."""
    taus = h / PADE_POLES
    _, _, Kq, Gq = mats.matvec(q0)
    if force is not None:  # x_p = p0 + tau f
        Kq = Kq - force
    rhs = (p0 - Gq) - taus[:, None] * Kq
    if companion is not None:
        _, _, Kc, Gc = mats.matvec(companion[0])
        if force is not None:
            Kc = Kc - force
        both = mats.solve_shifted(
            taus, np.stack([rhs, (companion[1] - Gc) - taus[:, None] * Kc], axis=-1)
        )
        u, u_c = both[..., 0], both[..., 1]
    else:
        u = mats.solve_shifted(taus, rhs)
    q1, p1, v = _recombined(q0, p0, u, taus, mats)
    # y_q,k, u_k and the matrices at the middle: for the continuous extension
    extension = (q0, q0 + taus[:, None] * u, u, v, p0, mats)
    if companion is None:
        return q1, p1, extension
    end_c = _recombined(*companion, u_c, taus, mats)[:2]
    return q1, p1, extension, end_c


def _recombined(q0, p0, u, taus, mats):
    """`(q1, p1, v)` of a rational step from `(q0, p0)` whose solves are `u_k` (`u`, one
    row a pole pair) at `taus` under its matrices `mats` (`moving_step`)."""
    weighted = PADE_WEIGHTS[:, None] * u
    v = weighted.sum(axis=0).real
    s = _PADE_WEIGHT_SUM * q0 + (taus[:, None] * weighted).sum(axis=0).real
    return _PADE_CONSTANT * q0 + 2.0 * s, _PADE_CONSTANT * p0 + 2.0 * _products(mats, v, s), v


def _products(mats, v: np.ndarray, s: np.ndarray) -> np.ndarray:
    """`M v + G s` with a step's matrices `mats` (`STEP_MATRICES`)."""
    if isinstance(mats, DenseMatrices):
        M, _, _, G = mats.matrices
        return M @ v + G @ s
    zero = np.zeros_like(v)
    Mv, _, _, Gs = mats.matvec(np.stack([v, zero, zero, s]))
    return Mv + Gs


def extended_momentum(mats, c, velocity, q, q_start, p_start) -> np.ndarray:
    """The canonical momenta (m, n) of a rational step's continuous extension: `p(f) =
    c p0 + sum_k 2 Re[w_k y_p,k]` with `y_p,k = M u_k + G y_q,k` under the step's own
    middle matrices `mats` (`STEP_MATRICES`), so `c p0 + M sum 2 Re[w_k u_k] + G (q(f)
    - c q0)`."""
    p = np.outer(c, p_start)
    shift = q - np.outer(c, q_start)
    if isinstance(mats, DenseMatrices):
        M, _, _, G = mats.matrices
        return p + velocity @ M.T + shift @ G.T
    for i, (v, s) in enumerate(zip(velocity, shift, strict=True)):
        p[i] += _products(mats, v, s)
    return p
