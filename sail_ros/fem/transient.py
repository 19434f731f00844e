"""Free vibration of the finite-element sail at a fixed boom length.

An independent check on the modal model's time histories: the same continuum
(`SailFEM`: Hermite booms, Lagrange triangles riding on them) stepped in time by the
Newmark average-acceleration rule (the trapezoidal rule on `M a + C v + K u = 0`),

    (M + h/2 C + h^2/4 K) a1 = -C (v0 + h/2 a0) - K (u0 + h v0 + h^2/4 a0)
    u1 = u0 + h v0 + h^2/4 (a0 + a1),    v1 = v0 + h/2 (a0 + a1),

unconditionally stable and, undamped, energy-conserving; its period error
`(omega h)^2 / 12` is below 1e-4 for the booms' first modes at the default step. The
matrix on the left is factored once: a step is one sparse solve.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.fem.beam import HermiteBoom
from sail_ros.fem.sail_fem import SailFEM, factorize
from sail_ros.model.basis import cantilever_modes
from sail_ros.model.parameters import SailParameters


@dataclasses.dataclass(frozen=True)
class Transient:
    """A finite-element time history.

    Attributes:
        t: times [s] (k,).
        tips: boom-tip deflections [m] (k, 4), booms a..d, along +z.
        root_moments: root bending moments `EI u''(0)` [N m] (k, 4).
        description: the mesh and time step, one line.
    """

    t: np.ndarray
    tips: np.ndarray
    root_moments: np.ndarray
    description: str


def first_mode_dofs(boom: HermiteBoom, tip_deflection: float) -> np.ndarray:
    """Hermite DOFs of a boom bent in its first cantilever mode to `tip_deflection` [m]:
    the mode's deflection and slope at every unclamped node (`psi_1(1) = 2`)."""
    xi = np.arange(1, boom.n_elements + 1) / boom.n_elements
    deflection = cantilever_modes(1, xi)[0]
    slope = cantilever_modes(1, xi, 1)[0] / boom.length
    return 0.5 * tip_deflection * np.column_stack([deflection, slope]).ravel()


def free_vibration(
    params: SailParameters,
    length: float,
    tip_deflections,
    duration: float,
    time_step: float = 0.005,
    output_spacing: float = 0.01,
    boom_elements: int = 16,
    membrane_divisions: int = 32,
    membrane_order: int = 2,
    progress=None,
) -> Transient:
    """The sail at rest with each boom bent in its first cantilever mode, let go.

    Args:
        params: the sail (its Rayleigh damping included; the mode counts unused).
        length: the four booms' common length [m].
        tip_deflections: each boom's initial tip deflection [m] (4 values, a..d), the
            film's own displacement zero (it rides on the booms), as
            `SailModel.initial_coordinates`.
        duration: simulated time [s].
        time_step: Newmark step [s].
        output_spacing: time between outputs [s], a multiple of `time_step`.
        boom_elements: Hermite elements per boom (`SailFEM`).
        membrane_divisions: mesh divisions per quadrant leg; the defaults (7940 DOFs at
            16, 32 and P2) run 10 s in a few seconds; the film's waves need about 48
            divisions for its peaks to settle within 0.3 %.
        membrane_order: Lagrange order of the film, 1 or 2.
        progress: optional callable `progress(t)` after each output.

    Returns:
        `Transient` with the outputs at `0, output_spacing, ...` up to `duration`.
    """
    tips0 = np.broadcast_to(np.asarray(tip_deflections, dtype=float), (4,))
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"length must be finite and > 0 m, got {length!r}")
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be finite and > 0 s, got {duration!r}")
    if not (np.isfinite(time_step) and 0 < time_step <= duration):
        raise ValueError(f"time_step must be in (0, duration] s, got {time_step!r}")
    every = round(output_spacing / time_step)
    if every < 1 or not np.isclose(every * time_step, output_spacing, rtol=1e-9):
        raise ValueError(
            f"output_spacing must be a multiple of time_step = {time_step} s, "
            f"got {output_spacing!r}"
        )
    fem = SailFEM(params, boom_elements, membrane_divisions, membrane_order)
    M, K = fem.matrices(length)
    C = params.mass_damping * M + params.stiffness_damping * K
    boom = HermiteBoom(length, boom_elements)
    nb = fem.n_boom_dofs
    booms = [slice(k * nb, (k + 1) * nb) for k in range(4)]
    u = np.zeros(fem.n_dofs)
    for k, dofs in enumerate(booms):
        u[dofs] = first_mode_dofs(boom, tips0[k])
    v = np.zeros_like(u)
    a = factorize(M).solve(-(K @ u))
    h = time_step
    step = factorize(M + (0.5 * h) * C + (0.25 * h * h) * K)
    damped = C.nnz > 0 and bool(np.any(C.data))
    tip_rows = [dofs.stop - 2 for dofs in booms]  # the tip node's deflection
    curvature = boom.evaluate(np.zeros(1), 2).toarray()[0]  # u''(0) per boom DOF [1/m^2]

    def outputs():
        moments = [params.boom_bending_stiffness * float(curvature @ u[dofs]) for dofs in booms]
        return u[tip_rows].copy(), moments

    count = int(np.floor(duration / h + 1e-9))
    t, tips, moments = [0.0], *([value] for value in outputs())
    for i in range(1, count + 1):
        predicted = u + h * v + (0.25 * h * h) * a
        rhs = -(K @ predicted)
        if damped:
            rhs -= C @ (v + (0.5 * h) * a)
        a_next = step.solve(rhs)
        u = predicted + (0.25 * h * h) * a_next
        v = v + (0.5 * h) * (a + a_next)
        a = a_next
        if i % every == 0:
            tip, moment = outputs()
            t.append(i * h)
            tips.append(tip)
            moments.append(moment)
            if progress is not None:
                progress(i * h)
    return Transient(
        t=np.array(t),
        tips=np.array(tips),
        root_moments=np.array(moments),
        description=f"{fem.mesh_description()}, Newmark average acceleration, step {h:g} s",
    )
