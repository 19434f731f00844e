"""Natural frequencies and mode shapes at fixed boom lengths (seed Tab. 2, Fig. 2).

Free vibration of Eq. 2 with all rates zero is the generalised eigenproblem

    K v = omega^2 M v,        v^T M v = 1,

solved densely (`SailModel.normal_modes`; with a free hub the three rigid-body
modes come first at exactly 0 rad/s, the elastic ones from the reduced problem
of docs/model.md §13.6). The sail's four-fold symmetry makes
some frequencies double; `group_multiplicities` collects equal frequencies
and `representative_shapes` picks one reproducible vector per group.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from sail_ros.model import SailModel, SailParameters

# Equal frequencies of a symmetric sail agree to round-off (~1e-12 relative);
# distinct ones of the default sail differ by > 1e-3. 1e-6 separates the two.
MULTIPLICITY_RTOL = 1e-6


def group_multiplicities(omega, rtol: float = MULTIPLICITY_RTOL) -> list[tuple[int, int]]:
    """(first index, multiplicity) of each group of equal frequencies, ascending.

    Consecutive values within `rtol` (relative) of a group's first value join it.
    """
    omega = np.asarray(omega, dtype=float)
    groups: list[list[int]] = []
    for i, value in enumerate(omega):
        if groups and abs(value - omega[groups[-1][0]]) <= rtol * abs(value):
            groups[-1][1] += 1
        else:
            groups.append([i, 1])
    return [(first, count) for first, count in groups]


@dataclasses.dataclass(frozen=True)
class Modes:
    """Natural frequencies and mass-normalised mode vectors of one configuration.

    Attributes:
        lengths: boom lengths [m] (a, b, c, d).
        omega: natural frequencies [rad/s], ascending; a buckled mode
            (omega^2 < 0) appears as -sqrt(-omega^2); a free hub's three
            rigid-body modes as 0.0.
        vectors: mode vectors as columns (n, n), `V^T M V = I`.
        groups: (first index, multiplicity) per distinct frequency.
    """

    lengths: np.ndarray
    omega: np.ndarray
    vectors: np.ndarray
    groups: list[tuple[int, int]]


def modal_analysis(model: SailModel, lengths) -> Modes:
    """All natural frequencies and mode vectors at `lengths` [m] (scalar or 4 values)."""
    lengths = np.broadcast_to(np.asarray(lengths, dtype=float), (4,)).copy()
    omega2, vectors = model.normal_modes(lengths)
    omega = np.sign(omega2) * np.sqrt(np.abs(omega2))
    return Modes(lengths, omega, vectors, group_multiplicities(omega))


def representative_shapes(model: SailModel, modes: Modes, count: int):
    """One mode vector for each of the first `count` distinct frequencies.

    Within a group of equal frequencies any combination of its vectors is a
    mode; the one returned maximises boom a's tip deflection (or, if boom a
    is at rest in all of them, the largest coordinate), so that figures are
    reproducible. Signs make that deflection positive.

    Returns:
        list of `(group_number, first_index, multiplicity, omega [rad/s], vector)`,
        `group_number` counting distinct frequencies from 1.
    """
    tip_a = model.tip_deflections(np.eye(model.n))[:, 0]  # psi(1)^T p_a as a row
    shapes = []
    for number, (first, multiplicity) in enumerate(modes.groups[:count], start=1):
        basis = modes.vectors[:, first : first + multiplicity]
        weights = tip_a @ basis
        if np.linalg.norm(weights) <= 1e-9 * np.abs(tip_a).max() * np.abs(basis).max():
            row = int(np.argmax(np.linalg.norm(basis, axis=1)))
            weights = basis[row]
        vector = basis @ (weights / np.linalg.norm(weights))
        shapes.append((number, first, multiplicity, float(modes.omega[first]), vector))
    return shapes


@dataclasses.dataclass(frozen=True)
class CrossCheck:
    """Finite-element and modal frequencies of the fully deployed sail.

    Attributes:
        count: frequencies compared (the lowest `count`).
        fem_levels: one `(settings, omega)` per FE mesh, coarse to fine
            (`settings` as `sail_ros.fem.fem_convergence` returns them).
        modal_levels: one `(n_B, n_M, seconds, omega)` per modal model.
    """

    count: int
    fem_levels: list
    modal_levels: list

    @property
    def fem(self) -> np.ndarray:
        """Frequencies [rad/s] on the finest FE mesh."""
        return self.fem_levels[-1][1]

    @property
    def modal(self) -> np.ndarray:
        """Frequencies [rad/s] of the largest modal model."""
        return self.modal_levels[-1][3]

    @property
    def difference_percent(self) -> np.ndarray:
        """100 (modal - FE) / FE per frequency [%]."""
        return 100.0 * (self.modal - self.fem) / self.fem


def fem_cross_check(params: SailParameters, fem_levels, modal_counts, count: int = 6) -> CrossCheck:
    """Lowest `count` frequencies of the fully deployed sail from both models.

    Args:
        params: the sail; its mode counts are replaced by `modal_counts`.
        fem_levels: `(boom_elements, membrane_divisions, membrane_order)` per
            FE mesh, coarse to fine.
        modal_counts: `(n_B, n_M)` per modal model, small to large.
        count: frequencies to compare.
    """
    from sail_ros.fem import fem_convergence  # sparse FE machinery, only here

    fem = fem_convergence(params, levels=tuple(fem_levels), k=count)
    modal = []
    for n_boom, n_membrane in modal_counts:
        started = time.perf_counter()
        model = SailModel(params.replace(n_boom_modes=n_boom, n_membrane_modes=n_membrane))
        omega = model.natural_frequencies(params.full_boom_length)[:count]
        modal.append((n_boom, n_membrane, time.perf_counter() - started, omega))
    return CrossCheck(count, fem, modal)


@dataclasses.dataclass(frozen=True)
class Counterpart:
    """The clamped group of modes a free hub's elastic group is mostly made of.

    Attributes:
        free_first: the free hub's group's first index (in `Modes.omega`, rigid first).
        clamped_first, clamped_multiplicity: the clamped group (indices of the clamped
            sail's `Modes.omega`).
        omega: the clamped group's frequency [rad/s].
        share: the part of the free group's elastic shapes inside the clamped group's
            span, in the clamped sail's mass norm (1: the same shapes), averaged over
            the group.
    """

    free_first: int
    clamped_first: int
    clamped_multiplicity: int
    omega: float
    share: float


def clamped_counterparts(free: SailModel, modes: Modes, clamped_model: SailModel,
                         clamped: Modes) -> list[Counterpart]:  # fmt: skip
    """For each elastic group of `modes` (of `free`, a free-hub model) the group of
    `clamped` (of `clamped_model`: the same sail with the hub clamped, at the same lengths)
    that holds most of its shapes: the hub stiffens some modes (it turns a boom's clamped
    root into a guided or pinned one when light, model.md §13.7) and leaves others, so
    the order of the two lists differs; pairing by shape puts each beside its own."""
    M = clamped_model.mass_and_stiffness(clamped.lengths)[0]
    elastic = modes.vectors[: free.n_elastic]
    # free elastic shapes in the clamped modal basis (V_c^T M V_c = I): their coordinates
    coordinates = clamped.vectors.T @ M @ elastic
    with np.errstate(invalid="ignore"):  # the rigid-body modes' elastic parts are 0
        energy = coordinates**2 / np.sum(coordinates**2, axis=0)
    pairs = []
    for first, multiplicity in modes.groups:
        if modes.omega[first] == 0.0:  # rigid-body modes: no clamped counterpart
            continue
        columns = slice(first, first + multiplicity)
        shares = [float(energy[c : c + m, columns].sum() / multiplicity) for c, m in clamped.groups]
        best = int(np.argmax(shares))
        c, m = clamped.groups[best]
        pairs.append(Counterpart(first, c, m, float(clamped.omega[c]), shares[best]))
    return pairs
