"""The sail as a linear plant at frozen boom lengths and rates (model.md §12, §13).

`linear_plant` wraps `SailModel.state_space` with the names of its inputs,
outputs and states (8 and 8, or 11 and 14 with a free hub, whose outputs hold
double integrators); `poles` lists its modes (frequency, damping ratio) and
`frequency_response` evaluates `C (jw I - A)^-1 B + D` on a frequency grid.
`undamped_note` says when poles lie on the imaginary axis (the default sail has
no damping) and how to set some. For a Bode figure, `bode_pairs` names the transfers
drawn, `shown_poles` the poles that show in them (by their modal residues),
`bode_band` a band that holds whole resonances and `bode_grid` frequencies that
resolve each of them.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import scipy.linalg

from sail_ros.model import SailModel
from sail_ros.model.layout import per_boom


@dataclasses.dataclass(frozen=True)
class LinearPlant:
    """`xd = A x + B u`, `y = C x + D u` with `x = [q; qd]` (SI units).

    Attributes:
        A, B, C, D: the matrices.
        lengths: boom lengths [m] (4,); rates: extension rates [m/s] (4,).
        input_names, output_names, state_names: one name per column / row / state.
        input_units, output_units: their units.
        mass_damping, stiffness_damping: the Rayleigh alpha [1/s] and beta [s] of
            the sail the plant was built from.
        free_hub: the hub is free: its outputs hold double integrators (`hub_note`).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    lengths: np.ndarray
    rates: np.ndarray
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    state_names: tuple[str, ...]
    input_units: tuple[str, ...]
    output_units: tuple[str, ...]
    mass_damping: float = 0.0
    stiffness_damping: float = 0.0
    free_hub: bool = False

    @functools.cached_property
    def eigenvalues(self) -> np.ndarray:
        """The eigenvalues of `A` (computed once: the notes, bands and poles all read
        them)."""
        return np.linalg.eigvals(self.A)

    @functools.cached_property
    def eigenvectors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`(values, left, right)` of `A` (`scipy.linalg.eig`), computed once."""
        return scipy.linalg.eig(self.A, left=True, right=True)

    def arrays(self) -> dict:
        """Everything as arrays (for `.npz` and MATLAB `.mat`), with the damping and,
        when poles lie on the imaginary axis, their count and a note saying so; with a
        free hub the rigid-body poles' count and `hub_note`."""
        hub = {}
        if self.free_hub:
            hub = {"rigid_body_poles": len(rigid_poles(self)), "hub_note": hub_note(self)}
        return {
            "A": self.A,
            "B": self.B,
            "C": self.C,
            "D": self.D,
            "lengths_m": self.lengths,
            "rates_m_s": self.rates,
            "input_names": np.array(self.input_names),
            "input_units": np.array(self.input_units),
            "output_names": np.array(self.output_names),
            "output_units": np.array(self.output_units),
            "state_names": np.array(self.state_names),
            "mass_damping_1_s": self.mass_damping,
            "stiffness_damping_s": self.stiffness_damping,
            "poles_on_imaginary_axis": len(imaginary_axis_poles(self)),
            "note": undamped_note(self),
            **hub,
        }


def linear_plant(model: SailModel, lengths, rates=0.0) -> LinearPlant:
    """The plant at `lengths` [m] and constant `rates` [m/s] (scalars or 4 values)."""
    lengths = per_boom(lengths, "lengths", positive=True)
    rates = per_boom(rates, "rates")
    A, B, C, D = model.state_space(lengths, rates)
    names = model.coordinate_names
    states = tuple(names) + tuple(f"d/dt {name}" for name in names)
    return LinearPlant(
        A,
        B,
        C,
        D,
        lengths,
        rates,
        model.input_names,
        model.output_names,
        states,
        model.input_units,
        model.output_units,
        mass_damping=model.params.mass_damping,
        stiffness_damping=model.params.stiffness_damping,
        free_hub=model.free_hub,
    )


@dataclasses.dataclass(frozen=True)
class Pole:
    """One mode of the plant: a pole `s`, its natural frequency |s| [rad/s] and
    damping ratio `-Re(s) / |s|` (negative: the mode grows)."""

    s: complex
    omega: float
    zeta: float

    @property
    def hertz(self) -> float:
        return self.omega / (2.0 * np.pi)


def poles(plant: LinearPlant) -> list[Pole]:
    """One pole per oscillatory pair (Im s >= 0) and every real pole, by frequency."""
    eigenvalues = plant.eigenvalues
    kept = eigenvalues[eigenvalues.imag >= -1e-12 * np.maximum(1.0, np.abs(eigenvalues))]
    result = []
    for s in kept:
        omega = float(abs(s))
        zeta = float(-s.real / omega) if omega > 0 else 0.0
        result.append(Pole(complex(s), omega, zeta))
    return sorted(result, key=lambda pole: (pole.omega, pole.zeta))


def frequency_response(plant: LinearPlant, omega) -> np.ndarray:
    """`G(j w) = C (j w I - A)^-1 B + D` at angular frequencies `omega` [rad/s]:
    shape (len(omega), outputs, inputs).

    With `x = [q; qd]` (`A = [[0, I], [-K', -C']]`, `B = [[0], [B']]`, as
    `SailModel.state_space` builds it) the solve is of the coordinates' size:
    `(K' + j w C' - w^2 I) q = B' u`, `y = (C_q + j w C_qd) q + D u`, the same
    response in an eighth of the work."""
    omega = np.asarray(omega, dtype=float)
    n = plant.A.shape[0] // 2
    A, B, C = plant.A, plant.B, plant.C
    response = np.empty((omega.size, C.shape[0], B.shape[1]), dtype=complex)
    second_order = not A[:n, :n].any() and np.array_equal(A[:n, n:], np.eye(n)) and not B[:n].any()
    if second_order:
        stiffness, damping, forcing = -A[n:, :n], -A[n:, n:], B[n:]
        identity = np.eye(n)
        for k, w in enumerate(omega):
            q = np.linalg.solve(stiffness + 1j * w * damping - w * w * identity, forcing)
            response[k] = (C[:, :n] + 1j * w * C[:, n:]) @ q + plant.D
        return response
    identity = np.eye(A.shape[0])
    for k, w in enumerate(omega):
        response[k] = C @ np.linalg.solve(1j * w * identity - A, B) + plant.D
    return response


RIGID_POLES = 6  # a free hub's heave and two tilts: a double pole at s = 0 each


def rigid_poles(plant: LinearPlant) -> list[Pole]:
    """A free hub's rigid-body poles: the six of smallest |s|, at s = 0 to round-off
    (model.md §13.6; none when clamped)."""
    return poles(plant)[:RIGID_POLES] if plant.free_hub else []


def imaginary_axis_poles(plant: LinearPlant, tolerance: float = 1e-9) -> list[Pole]:
    """The poles (Im s >= 0) within `tolerance` times the largest |s| of the imaginary
    axis: undamped modes, to round-off (not a free hub's rigid-body poles at 0, which
    no structural damping moves)."""
    listed = poles(plant)[len(rigid_poles(plant)) :]
    largest = max((p.omega for p in listed), default=0.0)
    return [p for p in listed if abs(p.s.real) <= tolerance * largest]


def hub_note(plant: LinearPlant) -> str:
    """One line saying that a free hub's outputs hold double integrators ("" when
    clamped)."""
    if not plant.free_hub:
        return ""
    return (
        f"the hub outputs ({', '.join(plant.output_names[8:11])} and their rates) hold "
        f"double integrators: {RIGID_POLES} poles at s = 0 (the hub's rigid-body modes), "
        "so the plant is not stable, and a Bode plot of a force "
        "or torque to z_h or a tilt falls at -40 dB/dec at low frequency (docs/model.md "
        "§13.6)"
    )


def undamped_note(plant: LinearPlant) -> str:
    """One line saying that poles lie on the imaginary axis and how to damp the sail,
    or "" when none does. The modes are counted as the plant's coordinates are: a free
    hub's three rigid-body modes among them."""
    marginal = imaginary_axis_poles(plant)
    if not marginal:
        return ""
    modes = len(plant.state_names) // 2
    rigid = " (the other 3: the hub's rigid-body modes, at s = 0)" if plant.free_hub else ""
    return (
        f"{len(marginal)} of the {modes} modes{rigid} have their poles on the imaginary "
        f"axis (mass_damping = {plant.mass_damping:g} 1/s, stiffness_damping = "
        f"{plant.stiffness_damping:g} s): an undamped mode's response is unbounded at its "
        "frequency and its phase jumps by 180 deg there; set Rayleigh damping "
        "C_d = alpha M + beta K with --set mass_damping=ALPHA --set stiffness_damping=BETA "
        "(docs/model.md §12)"
    )


def bode_pairs(plant: LinearPlant) -> list[tuple[str, str]]:
    """The transfers of the Bode figure, `(output, input)` names: each tip force to its
    own boom's tip deflection and root moment; with a free hub, its force to its heave
    and each torque to its tilt about the same axis."""
    pairs = [(f"{kind}_{boom}", f"tip_force_{boom}")
             for kind in ("tip_deflection", "root_moment") for boom in "abcd"]  # fmt: skip
    if plant.free_hub:
        pairs += [("hub_heave", "hub_force_z"), ("hub_tilt_x", "hub_torque_x"),
                  ("hub_tilt_y", "hub_torque_y")]  # fmt: skip
    return pairs


SHOWN_SHARE = 1e-3  # a pole shows in a transfer when its part is this share of the largest
BAND_SHARE = 1e-2  # a pole whose part is this share keeps the band's end clear of it
RESONANCE_SPAN = 1.5  # a band ends this factor or more away from such a pole


def shown_poles(plant: LinearPlant, pairs, share: float = SHOWN_SHARE) -> list[Pole]:
    """The oscillating poles (not a free hub's rigid-body ones) whose part in any of the
    transfers `pairs` (`(output, input)` names) is at least `share` of the largest part
    in it, by frequency. A pole's part is its modal residue's static contribution
    `2 |R_i| / |s_i|`, `R_i = (C v_i)(w_i^H B) / (w_i^H v_i)` (right and left eigenvectors
    of A): the part of the response it carries away from its own frequency."""
    values, left, right = plant.eigenvectors
    rigid = len(rigid_poles(plant))
    order = np.argsort(np.abs(values))
    upper = [i for i in order[rigid:] if values[i].imag > 0]  # rigid: the zero eigenvalues
    norms = np.einsum("ij,ij->j", left.conj(), right)
    outputs, inputs = list(plant.output_names), list(plant.input_names)
    kept = set()
    for output, source in pairs:
        c, b = plant.C[outputs.index(output)], plant.B[:, inputs.index(source)]
        residues = (c @ right[:, upper]) * (left[:, upper].conj().T @ b) / norms[upper]
        parts = 2.0 * np.abs(residues) / np.abs(values[upper])
        if parts.size and parts.max() > 0:
            kept |= {upper[k] for k in np.flatnonzero(parts >= share * parts.max())}
    found = []
    for i in kept:
        s_i = complex(values[i])
        found.append(Pole(s_i, float(abs(s_i)), float(-s_i.real / abs(s_i))))
    return sorted(found, key=lambda pole: pole.omega)


def bode_band(plant: LinearPlant, pairs, listed) -> tuple[float, float]:
    """A default frequency band [Hz] from a decade below the first of the `listed` poles
    that oscillates to a decade above the last, its end moved up until no pole that
    shows in `pairs` (with `BAND_SHARE`) lies within `RESONANCE_SPAN` of it: every
    resonance drawn is drawn whole."""
    rigid = rigid_poles(plant)
    oscillating = [p.hertz for p in listed if p.omega > 0 and p not in rigid]
    low = 0.1 * min(oscillating, default=0.01)
    high = 10.0 * max(oscillating, default=1.0)
    for pole in shown_poles(plant, pairs, BAND_SHARE):  # by frequency
        if high / RESONANCE_SPAN < pole.hertz < high * RESONANCE_SPAN:
            high = RESONANCE_SPAN * pole.hertz
    return low, high


def bode_grid(plant: LinearPlant, pairs, low_hz: float, high_hz: float,
              points: int = 600) -> np.ndarray:  # fmt: skip
    """Angular frequencies [rad/s] from `low_hz` to `high_hz`: log-spaced, and across the
    resonance of every pole that shows in `pairs`, where the log-spaced points would miss
    its peak: 13 points within 3 half-power widths of a damped pole narrower than the
    log-spaced points, and for an undamped one points closing in on it from both sides
    to 1e-4 of its frequency (never at it, where the response is unbounded)."""
    omega = [2 * np.pi * np.geomspace(low_hz, high_hz, points)]
    spacing = (high_hz / low_hz) ** (1.0 / (points - 1)) - 1.0  # relative
    for pole in shown_poles(plant, pairs):
        if not low_hz <= pole.hertz <= high_hz:
            continue
        damped = abs(pole.s.imag)
        if pole.zeta > 1e-9:
            if 2.0 * pole.zeta < 3.0 * spacing:
                omega.append(damped * (1.0 + pole.zeta * np.linspace(-3.0, 3.0, 13)))
        else:
            approach = np.geomspace(1e-1, 1e-4, 13)
            omega.append(damped * np.concatenate([1.0 - approach, 1.0 + approach]))
    grid = np.unique(np.concatenate(omega))
    # a multiple pole's copies differ by round-off: their points are one
    grid = grid[np.concatenate([[True], np.diff(grid) > 1e-9 * grid[1:]])]
    return grid[(grid >= 2 * np.pi * low_hz) & (grid <= 2 * np.pi * high_hz)]


def undamped_shown(plant: LinearPlant, pairs, low_hz: float, high_hz: float) -> dict:
    """Per transfer of `pairs`, the frequencies [Hz] in the band of the undamped poles (on
    the imaginary axis to round-off) that show in it (`shown_poles`)."""
    found = {}
    for pair in pairs:
        found[pair] = [
            p.hertz for p in shown_poles(plant, [pair])
            if p.zeta <= 1e-9 and low_hz <= p.hertz <= high_hz
        ]  # fmt: skip
    return found
