"""The matrices of Eq. 2 as named terms, lifted to the whole sail (model.md §5-§6).

Every matrix of the model is a sum of terms, each a scalar coefficient (of
the boom lengths L, rates Ld and accelerations Ldd, and the physical
constants) times one constant reference integral (`integrals.py`), added
into one or more of the system matrices:

    MASS                 M
    DAMPING              C = Md + G - G^T + C_d    (Eq. 2, model.md §12)
    STRUCTURAL_DAMPING   C_d = alpha M + beta K    (Rayleigh, model.md §12)
    STIFFNESS_EQ         K_eq = Gd + K - N         (Eq. 2)
    STIFFNESS            K, the elastic part (bending, axial load, tension)
    GYROSCOPIC           G                         (canonical form)
    GYROSCOPIC_SKEW      G - G^T                   (canonical form)
    STIFFNESS_CANONICAL  K - N                     (canonical form)
    CANONICAL_DAMPING    G - G^T + C_d             (canonical form)

`BOOM_TERMS` and `QUADRANT_TERMS` below are the whole physics of the
assembly, one entry per term of model.md §5; adding a term is adding an
entry. A boom term lands on that boom's diagonal block, a quadrant term on
the rows and columns of `[p_first, p_second, q_quadrant]` (Tab. 1).

The `SystemAssembler` precomputes where every entry of every integral lands,
so one evaluation is: the term coefficients (a few dozen scalars), one small
matrix product per component, and one scatter-add (`numpy.bincount`) that
builds all requested matrices together.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from sail_ros.model.blocks import BlockLayout, BlockMatrices
from sail_ros.model.integrals import BoomIntegrals, QuadrantIntegrals
from sail_ros.model.layout import QUADRANTS, Layout

MASS = "M"
DAMPING = "C"
STRUCTURAL_DAMPING = "C_d"
CANONICAL_DAMPING = "G - G^T + C_d"
STIFFNESS_EQ = "K_eq"
STIFFNESS = "K"
GYROSCOPIC = "G"
GYROSCOPIC_SKEW = "G - G^T"
STIFFNESS_CANONICAL = "K - N"
ALL_OUTPUTS = (
    MASS,
    DAMPING,
    STIFFNESS_EQ,
    STIFFNESS,
    GYROSCOPIC,
    GYROSCOPIC_SKEW,
    STIFFNESS_CANONICAL,
    STRUCTURAL_DAMPING,
    CANONICAL_DAMPING,
)


class Constants(NamedTuple):
    """The physical constants the coefficients use (SI)."""

    boom_linear_density: float  # rho_B [kg/m]
    boom_bending_stiffness: float  # EI [N m^2]
    boom_axial_load: float  # P [N]
    membrane_areal_density: float  # rho_M [kg/m^2]
    membrane_tension: float  # N0 [N/m]
    mass_damping: float = 0.0  # Rayleigh alpha [1/s]
    stiffness_damping: float = 0.0  # Rayleigh beta [s]


class BoomKinematics(NamedTuple):
    """One value per boom (4,): length L [m], rate Ld [m/s], acceleration Ldd [m/s^2]."""

    L: np.ndarray
    Ld: np.ndarray
    Ldd: np.ndarray


class QuadrantKinematics(NamedTuple):
    """One value per quadrant (4,): the motion of its first (a) and second (b) boom."""

    La: np.ndarray
    Lda: np.ndarray
    Ldda: np.ndarray
    Lb: np.ndarray
    Ldb: np.ndarray
    Lddb: np.ndarray


@dataclasses.dataclass(frozen=True)
class Term:
    """`coefficient x integral`, added into each matrix of `matrices`.

    Attributes:
        name: what the term is, in model.md's words.
        integral: the field of `BoomIntegrals` / `QuadrantIntegrals`.
        coefficient: `(motion, constants) -> 4 values` (one per boom or quadrant).
        matrices: the outputs the term belongs to.
        skew: use `integral - integral^T` (the gyroscopic `G - G^T`).
    """

    name: str
    integral: str
    coefficient: Callable[[NamedTuple, Constants], np.ndarray]
    matrices: tuple[str, ...]
    skew: bool = False

    @property
    def integral_key(self) -> tuple[str, bool]:
        return self.integral, self.skew


# Rayleigh damping enters every matrix that holds the damping
_RAYLEIGH = (DAMPING, STRUCTURAL_DAMPING, CANONICAL_DAMPING)
# The gyroscopic `G` of a term feeds G, and G - G^T feeds C and the canonical damping.
_SKEW = (DAMPING, GYROSCOPIC_SKEW, CANONICAL_DAMPING)


def _mass(name: str, integral: str, coefficient) -> tuple[Term, ...]:
    """A term of the mass `M`, and its share `alpha M` of the Rayleigh damping."""
    return (
        Term(name, integral, coefficient, (MASS,)),
        Term(
            f"mass damping alpha {name}", integral, _times("mass_damping", coefficient), _RAYLEIGH
        ),
    )


def _elastic(name: str, integral: str, coefficient) -> tuple[Term, ...]:
    """A term of the elastic stiffness `K`, and its share `beta K` of the Rayleigh damping."""
    return (
        Term(name, integral, coefficient, (STIFFNESS_EQ, STIFFNESS, STIFFNESS_CANONICAL)),
        Term(
            f"stiffness damping beta {name}",
            integral,
            _times("stiffness_damping", coefficient),
            _RAYLEIGH,
        ),
    )


def _transport(name: str, integral: str, coefficient) -> tuple[Term, ...]:
    """A term of the gyroscopic `G`, and of `G - G^T` (the same coefficient, skew)."""
    return (
        Term(name, integral, coefficient, (GYROSCOPIC,)),
        Term(f"{name} - G^T", integral, coefficient, _SKEW, skew=True),
    )


def _times(constant: str, coefficient):
    """The coefficient times a physical constant (a Rayleigh factor)."""
    return lambda motion, c: getattr(c, constant) * coefficient(motion, c)


# Boom k (n_B x n_B), model.md §5: M_B, Md_B, G_B, Gd_B, N_B, K_B; §12: C_d = alpha M + beta K
# comes from the M and K terms (`_mass`, `_elastic`), G - G^T from G (`_transport`).
BOOM_TERMS = (
    *_mass("mass M_B", "psi_psi", lambda b, c: c.boom_linear_density * b.L),
    Term("mass rate Md_B", "psi_psi", lambda b, c: c.boom_linear_density * b.Ld, (DAMPING,)),
    *_transport("transport G_B", "psi_r", lambda b, c: c.boom_linear_density * b.Ld),
    Term(
        "transport rate Gd_B", "psi_r", lambda b, c: c.boom_linear_density * b.Ldd, (STIFFNESS_EQ,)
    ),
    Term(
        "transport stiffness -N_B",
        "r_r",
        lambda b, c: -c.boom_linear_density * b.Ld**2 / b.L,
        (STIFFNESS_EQ, STIFFNESS_CANONICAL),
    ),
    *_elastic("bending K_B", "d2_d2", lambda b, c: c.boom_bending_stiffness / b.L**3),
    *_elastic("axial load K_B", "d1_d1", lambda b, c: -c.boom_axial_load / b.L),
)

# Quadrant Q_ab (n~ x n~), model.md §5: M_M, Md_M, G_M, Gd_M, N_M, K_M; §12: C_d as above.
QUADRANT_TERMS = (
    *_mass("mass M_M", "s_s", lambda q, c: c.membrane_areal_density * q.La * q.Lb),
    Term(
        "mass rate Md_M",
        "s_s",
        lambda q, c: c.membrane_areal_density * (q.Lda * q.Lb + q.La * q.Ldb),
        (DAMPING,),
    ),
    *_transport(
        "transport G_M (first boom)", "s_ra", lambda q, c: c.membrane_areal_density * q.Lb * q.Lda
    ),
    *_transport(
        "transport G_M (second boom)", "s_rb", lambda q, c: c.membrane_areal_density * q.La * q.Ldb
    ),
    Term(
        "transport rate Gd_M (first boom)",
        "s_ra",
        lambda q, c: c.membrane_areal_density * (q.Lda * q.Ldb + q.Lb * q.Ldda),
        (STIFFNESS_EQ,),
    ),
    Term(
        "transport rate Gd_M (second boom)",
        "s_rb",
        lambda q, c: c.membrane_areal_density * (q.Lda * q.Ldb + q.La * q.Lddb),
        (STIFFNESS_EQ,),
    ),
    Term(
        "transport stiffness -N_M (first boom)",
        "ra_ra",
        lambda q, c: -c.membrane_areal_density * q.Lb * q.Lda**2 / q.La,
        (STIFFNESS_EQ, STIFFNESS_CANONICAL),
    ),
    Term(
        "transport stiffness -N_M (both booms)",
        "ra_rb",
        lambda q, c: -c.membrane_areal_density * q.Lda * q.Ldb,
        (STIFFNESS_EQ, STIFFNESS_CANONICAL),
    ),
    Term(
        "transport stiffness -N_M (second boom)",
        "rb_rb",
        lambda q, c: -c.membrane_areal_density * q.La * q.Ldb**2 / q.Lb,
        (STIFFNESS_EQ, STIFFNESS_CANONICAL),
    ),
    *_elastic(
        "tension K_M (along the first boom)",
        "sxi_sxi",
        lambda q, c: c.membrane_tension * q.Lb / q.La,
    ),
    *_elastic(
        "tension K_M (along the second boom)",
        "seta_seta",
        lambda q, c: c.membrane_tension * q.La / q.Lb,
    ),
)


class _Component:
    """The terms of one kind of component (the 4 booms or the 4 quadrants).

    The distinct integrals are stacked once; a plan maps the term coefficients
    of the requested outputs onto them (a 0/1 matrix: each (integral, output)
    pair has at most one term, so the mapping adds nothing but zeros).
    """

    def __init__(self, terms, integrals, targets: np.ndarray):
        self.terms = terms
        keys = list(dict.fromkeys(term.integral_key for term in terms))
        self._column = {key: i for i, key in enumerate(keys)}
        stacked = []
        for name, skew in keys:
            matrix = getattr(integrals, name)
            stacked.append(matrix - matrix.T if skew else matrix)
        self.size = stacked[0].shape[0]  # of each block: n_B, or n~ for a quadrant
        self.integrals = np.stack(stacked).reshape(len(keys), -1)
        self.targets = targets  # (4, size^2): flat system index of every block entry

    def selection(self, outputs: tuple[str, ...]) -> np.ndarray:
        """(terms, outputs x integrals): 1 where a term feeds an integral of an output."""
        select = np.zeros((len(self.terms), len(outputs), len(self._column)))
        for t, term in enumerate(self.terms):
            for o, output in enumerate(outputs):
                if output in term.matrices:
                    select[t, o, self._column[term.integral_key]] = 1.0
        return select.reshape(len(self.terms), -1)

    def values(self, motion, constants: Constants, selection: np.ndarray, k: int) -> np.ndarray:
        """Entries of every block of every requested output, flat, component-major."""
        return (
            self._weights(motion, constants, selection).reshape(4 * k, -1) @ self.integrals
        ).ravel()

    def blocks(self, motion, constants: Constants, selection: np.ndarray, k: int) -> np.ndarray:
        """Every block of every requested output, (k, 4, size, size), output-major."""
        weights = self._weights(motion, constants, selection).reshape(4, k, -1).transpose(1, 0, 2)
        return (weights @ self.integrals).reshape(k, 4, self.size, self.size)

    def _weights(self, motion, constants: Constants, selection: np.ndarray) -> np.ndarray:
        """(4, outputs x integrals): the coefficient of each integral in each output."""
        coefficients = np.array([term.coefficient(motion, constants) for term in self.terms]).T
        return coefficients @ selection


class SystemAssembler:
    """Builds the matrices of Eq. 2 from the boom motion.

    Physical constants enter once here; `evaluate` takes only the outputs
    wanted and the boom lengths, rates and accelerations (4 values each,
    order a, b, c, d).
    """

    def __init__(
        self,
        boom: BoomIntegrals,
        quadrant: QuadrantIntegrals,
        layout: Layout,
        constants: Constants,
    ):
        self.layout = layout
        self.n = n = layout.n
        self.constants = constants

        def flat(slots):
            return (slots[:, None] * n + slots[None, :]).ravel()

        self._booms = _Component(
            BOOM_TERMS, boom, np.stack([flat(layout.boom_slots(k)) for k in range(4)])
        )
        self._quadrants = _Component(
            QUADRANT_TERMS, quadrant, np.stack([flat(layout.quadrant_slots(q)) for q in QUADRANTS])
        )
        self._first = np.array([q.first for q in QUADRANTS])
        self._second = np.array([q.second for q in QUADRANTS])
        self._plans: dict[tuple[str, ...], tuple] = {}
        self.blocks = BlockLayout(layout)

    def _plan(self, outputs: tuple[str, ...]):
        """Term-to-integral selections and scatter indices for `outputs`."""
        plan = self._plans.get(outputs)
        if plan is None:
            unknown = [name for name in outputs if name not in ALL_OUTPUTS]
            if unknown:
                raise ValueError(f"unknown output(s) {unknown!r}; known: {', '.join(ALL_OUTPUTS)}")
            offsets = (self.n * self.n * np.arange(len(outputs)))[None, :, None]
            scatter = np.concatenate(
                [
                    (component.targets[:, None, :] + offsets).ravel()
                    for component in (self._booms, self._quadrants)
                ]
            )
            plan = (self._booms.selection(outputs), self._quadrants.selection(outputs), scatter)
            self._plans[outputs] = plan
        return plan

    def evaluate_blocks(self, outputs, lengths, rates, accelerations) -> BlockMatrices:
        """The requested matrices as their boom and quadrant blocks (`blocks.py`),
        unassembled; arguments as for `evaluate`."""
        outputs = tuple(outputs)
        k = len(outputs)
        boom_selection, quadrant_selection, _ = self._plan(outputs)
        booms, quadrants = self._kinematics(lengths, rates, accelerations)
        return BlockMatrices(
            self._booms.blocks(booms, self.constants, boom_selection, k),
            self._quadrants.blocks(quadrants, self.constants, quadrant_selection, k),
            self.blocks,
        )

    def _kinematics(self, lengths, rates, accelerations):
        first, second = self._first, self._second
        return BoomKinematics(lengths, rates, accelerations), QuadrantKinematics(
            lengths[first],
            rates[first],
            accelerations[first],
            lengths[second],
            rates[second],
            accelerations[second],
        )

    def evaluate(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """The requested matrices stacked, shape (len(outputs), n, n).

        Args:
            outputs: a tuple of the output names above, in any order.
            lengths: boom lengths [m], 4 values, already validated.
            rates: extension rates [m/s], 4 values.
            accelerations: extension accelerations [m/s^2], 4 values.
        """
        outputs = tuple(outputs)
        k = len(outputs)
        boom_selection, quadrant_selection, scatter = self._plan(outputs)
        booms, quadrants = self._kinematics(lengths, rates, accelerations)
        values = np.concatenate(
            [
                self._booms.values(booms, self.constants, boom_selection, k),
                self._quadrants.values(quadrants, self.constants, quadrant_selection, k),
            ]
        )
        out = np.bincount(scatter, weights=values, minlength=k * self.n * self.n)
        return out.reshape(k, self.n, self.n)
