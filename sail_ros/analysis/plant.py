"""The sail as a linear plant at frozen boom lengths and rates (model.md §12, §13).

`linear_plant` wraps `SailModel.state_space` with the names of its inputs,
outputs and states (8 and 8, or 11 and 14 with a free hub, whose outputs hold
double integrators); `poles` lists its modes (frequency, damping ratio) and
`frequency_response` evaluates `C (jw I - A)^-1 B + D` on a frequency grid.
`undamped_note` says when poles lie on the imaginary axis (the default sail has
no damping) and how to set some.
"""

from __future__ import annotations

import dataclasses

import numpy as np

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
    eigenvalues = np.linalg.eigvals(plant.A)
    kept = eigenvalues[eigenvalues.imag >= -1e-12 * np.maximum(1.0, np.abs(eigenvalues))]
    result = []
    for s in kept:
        omega = float(abs(s))
        zeta = float(-s.real / omega) if omega > 0 else 0.0
        result.append(Pole(complex(s), omega, zeta))
    return sorted(result, key=lambda pole: (pole.omega, pole.zeta))


def frequency_response(plant: LinearPlant, omega) -> np.ndarray:
    """`G(j w) = C (j w I - A)^-1 B + D` at angular frequencies `omega` [rad/s]:
    shape (len(omega), outputs, inputs)."""
    omega = np.asarray(omega, dtype=float)
    n = plant.A.shape[0]
    identity = np.eye(n)
    response = np.empty((omega.size, plant.C.shape[0], plant.B.shape[1]), dtype=complex)
    for k, w in enumerate(omega):
        response[k] = plant.C @ np.linalg.solve(1j * w * identity - plant.A, plant.B) + plant.D
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
    or "" when none does."""
    marginal = imaginary_axis_poles(plant)
    if not marginal:
        return ""
    return (
        f"{len(marginal)} of {len(poles(plant)) - len(rigid_poles(plant))} modes have their "
        "poles on the imaginary "
        f"axis (mass_damping = {plant.mass_damping:g} 1/s, stiffness_damping = "
        f"{plant.stiffness_damping:g} s): an undamped mode's response is unbounded at its "
        "frequency and its phase jumps by 180 deg there; set Rayleigh damping "
        "C_d = alpha M + beta K with --set mass_damping=ALPHA --set stiffness_damping=BETA "
        "(docs/model.md §12)"
    )
