"""The matrices of Eq. 2 as named terms, lifted to the whole sail (model.md §5-§6).

Every matrix of the model is a sum of terms, each a scalar coefficient (of
the boom lengths L, rates Ld and accelerations Ldd, and the physical
constants) times one constant reference integral (`integrals.py`), added
into one or more of the system matrices:

    MASS                 M
    DAMPING              C = Md + G - G^T + S_h + C_d    (Eq. 2, model.md §12, §13)
    STRUCTURAL_DAMPING   C_d = alpha M_r + beta K  (Rayleigh, model.md §12, §13.5)
    STIFFNESS_EQ         K_eq = Gd + K - N         (Eq. 2)
    STIFFNESS            K, the elastic part (bending, axial load, tension)
    GYROSCOPIC           G                         (canonical form)
    GYROSCOPIC_SKEW      G - G^T                   (canonical form)
    STIFFNESS_CANONICAL  K - N                     (canonical form)
    CANONICAL_DAMPING    G - G^T + S_h + C_d       (canonical form; S_h with a free hub)
    SPIN_HOLD            S_h, the spin hold's gyroscopic term (free hub, model.md §13.3)

`BOOM_TERMS` and `QUADRANT_TERMS` below are the whole physics of the
assembly, one entry per term of model.md §5; adding a term is adding an
entry. A boom term lands on that boom's diagonal block, a quadrant term on
the rows and columns of `[p_first, p_second, q_quadrant]` (Tab. 1).

With a free hub (model.md §13.4), `BOOM_HUB_TERMS` and `QUADRANT_HUB_TERMS`
couple each boom and quadrant to the hub. They are written in the
component's own hub coordinates: heave `z` and the tilt `d_k^T theta` of each
of its booms (`layout.hub_tilt_axis`: one of `+-theta_x`, `+-theta_y`), so the
four booms (and the four quadrants) share one table, and lifting is a signed
scatter. The hub's own mass and inertia are constants on `M`; the mean-axes
damping `alpha (M - M[:,h] M_hh^-1 M[h,:])` is `alpha M` on the elastic
coordinates less a rank-3 correction (`_mean_axes_correction`).

The `SystemAssembler` precomputes where every entry of every integral lands,
so one evaluation is: the term coefficients (a few dozen scalars), one small
matrix product per component, and one scatter-add (`numpy.bincount`) that
builds all requested matrices together.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from sail_ros.model.blocks import BlockLayout, BlockMatrices, Border, LowRank
from sail_ros.model.integrals import BoomIntegrals, QuadrantIntegrals
from sail_ros.model.layout import QUADRANT_BOOMS, QUADRANTS, Layout, hub_tilt_axis

MASS = "M"
DAMPING = "C"
STRUCTURAL_DAMPING = "C_d"
CANONICAL_DAMPING = "G - G^T + C_d"
STIFFNESS_EQ = "K_eq"
STIFFNESS = "K"
GYROSCOPIC = "G"
GYROSCOPIC_SKEW = "G - G^T"
STIFFNESS_CANONICAL = "K - N"
SPIN_HOLD = "S_h"
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
    SPIN_HOLD,
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
    full_boom_length: float = 0.0  # L_f [m], up to which material is stowed on the hub


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
        integral: the field of `BoomIntegrals` / `QuadrantIntegrals` (a hub term's: of
            the hub's integrals, `hub_integrals`).
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
    return _vanishing(constant, lambda motion, c: getattr(c, constant) * coefficient(motion, c))


def _vanishing(constant: str, coefficient):
    """`coefficient`, marked as 0 wherever the physical constant `constant` is (a plan
    leaves it out then: `_Component.selection`)."""
    coefficient.vanishes_with = constant
    return coefficient


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
    *_elastic(
        "axial load K_B",
        "d1_d1",
        _vanishing("boom_axial_load", lambda b, c: -c.boom_axial_load / b.L),
    ),
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


class Polynomial:
    """A term coefficient: a physical constant (a `Constants` field) times `scale` times a
    polynomial in the component's kinematic variables (the fields of `BoomKinematics`
    or `QuadrantKinematics`) and `Lf` (the full boom length), written as in model.md:
    `Polynomial(RHO_M, "2 La Lda Lb + La^2 Ldb")`. Callable like the other coefficients;
    a component whose coefficients are all polynomials evaluates their monomials in
    one pass (`_PolynomialBatch`)."""

    def __init__(self, constant: str, text: str, scale: float = 1.0):
        self.constant, self.text, self.scale = constant, text, scale
        self.monomials = []  # (factor, {variable: power})
        for sign, body in re.findall(r"([+-]?)\s*([^+-]+)", text):
            factor, powers = -1.0 if sign == "-" else 1.0, {}
            for item in body.split():
                if item[0].isdigit():
                    factor *= float(item)
                else:
                    name, _, power = item.partition("^")
                    powers[name] = powers.get(name, 0) + int(power or 1)
            self.monomials.append((factor, powers))

    def __call__(self, motion, constants: Constants) -> np.ndarray:
        total = 0.0
        for factor, powers in self.monomials:
            value = factor
            for name, power in powers.items():
                value = value * _variable(motion, constants, name) ** power
            total = total + value
        return getattr(constants, self.constant) * self.scale * total

    def __repr__(self) -> str:
        return f"{self.constant} * {self.scale:g} * ({self.text})"


def _variable(motion, constants: Constants, name: str):
    return constants.full_boom_length if name == "Lf" else getattr(motion, name)


class _PolynomialBatch:
    """Several `Polynomial`s times the 0/1 matrix `weights` (functions, columns) that
    sends them to integrals of outputs: every distinct monomial in the kinematic
    variables once, as `prod_i v_i^e_i` over an exponent table, then one matrix
    product with the factors (constants, powers of `Lf`) folded into `weights`."""

    def __init__(self, functions, weights: np.ndarray):
        self.functions, self.weights = functions, weights
        self.names = sorted(
            {name for f in functions for _, p in f.monomials for name in p} - {"Lf"}
        )
        self._keys: dict = {}  # exponents of a monomial -> its row
        self._entries = []  # (function, monomial row, factor, power of Lf)
        for i, f in enumerate(functions):
            for factor, powers in f.monomials:
                key = tuple(powers.get(name, 0) for name in self.names)
                row = self._keys.setdefault(key, len(self._keys))
                self._entries.append((i, row, factor * f.scale, powers.get("Lf", 0)))
        self.exponents = np.array(list(self._keys), dtype=float).reshape(-1, len(self.names))
        self._cache = (None, None, None)  # constants, motion type -> (folded weights, rows)

    def __call__(self, motion, constants: Constants) -> np.ndarray:
        """(..., 4, columns): the weight of each column for each of the 4 components (at
        each motion, the kinematic variables of shape (..., 4))."""
        if self._cache[0] is not constants or self._cache[1] is not type(motion):
            factors = np.zeros((len(self.functions), len(self._keys)))
            for i, row, factor, lf_power in self._entries:
                constant = getattr(constants, self.functions[i].constant)
                factors[i, row] += constant * factor * constants.full_boom_length**lf_power
            rows = [motion._fields.index(name) for name in self.names]
            self._cache = (constants, type(motion), (factors.T @ self.weights, rows))
        weights, rows = self._cache[2]
        variables = np.array(motion)[rows]  # (names, ..., 4)
        flat = variables.reshape(len(rows), -1)
        monomials = np.prod(flat[None, :, :] ** self.exponents[:, :, None], axis=1)
        return (monomials.T @ weights).reshape(*variables.shape[1:], -1)


RHO_B, RHO_M = "boom_linear_density", "membrane_areal_density"


def _gyroscopic(name, integral, constant, coefficient, rate):
    """`G` (coefficient x integral), its skew part, and `Gd` (the coefficient's time
    derivative `rate`) in K_eq; coefficients are `Polynomial` texts."""
    g = Polynomial(constant, coefficient)
    return (
        Term(f"{name} G", integral, g, (GYROSCOPIC,)),
        Term(f"{name} G - G^T", integral, g, _SKEW, skew=True),
        Term(f"{name} Gd", integral, Polynomial(constant, rate), (STIFFNESS_EQ,)),
    )


def _inertia(name, integral, constant, coefficient, rate, scale=1.0):
    """`M` (coefficient x integral) and `Md` (its time derivative `rate`) in C."""
    return (
        Term(f"{name} M", integral, Polynomial(constant, coefficient, scale), (MASS,)),
        Term(f"{name} Md", integral, Polynomial(constant, rate, scale), (DAMPING,)),
    )


# Boom k and the hub (model.md §13.4): local coordinates [p_k, z, phi], phi = d_k^T theta.
# Boom k is quadrant k's first boom, so these are evaluated and lifted with quadrant k's
# hub terms (`_on_first_boom`: L, Ld, Ldd are that quadrant's La, Lda, Ldda).
BOOM_HUB_TERMS = (
    *_inertia("hub-boom mass", "hub_1", RHO_B, "L", "Ld"),
    *_inertia("hub-boom first moment", "hub_x", RHO_B, "L^2", "2 L Ld"),
    *_inertia("hub-boom tilt inertia", "hub_xx", RHO_B, "L^3", "3 L^2 Ld"),
    *_gyroscopic("hub-boom transport (heave)", "hub_g_z", RHO_B, "Ld", "Ldd"),
    *_gyroscopic("hub-boom transport (tilt)", "hub_g_phi", RHO_B, "L Ld", "Ld^2 + L Ldd"),
)
# the undeployed part of a boom, on the hub's axis (stowed_mass_on_hub)
BOOM_STOWED_TERMS = _inertia("boom stowed on the hub", "hub_zz", RHO_B, "Lf - L", "-Ld")

# Quadrant Q_ab and the hub: local coordinates [q~, z, phi_a, phi_b], phi_a = d_a^T theta.
QUADRANT_HUB_TERMS = (
    *_inertia("hub-film mass", "hub_1", RHO_M, "La Lb", "Lda Lb + La Ldb"),
    *_inertia(
        "hub-film first moment (first boom)", "hub_a", RHO_M, "La^2 Lb", "2 La Lda Lb + La^2 Ldb"
    ),
    *_inertia(
        "hub-film first moment (second boom)", "hub_b", RHO_M, "La Lb^2", "Lda Lb^2 + 2 La Lb Ldb"
    ),
    *_inertia(
        "hub-film tilt inertia (first boom)",
        "hub_aa",
        RHO_M,
        "La^3 Lb",
        "3 La^2 Lda Lb + La^3 Ldb",
    ),
    *_inertia(
        "hub-film tilt inertia (second boom)",
        "hub_bb",
        RHO_M,
        "La Lb^3",
        "Lda Lb^3 + 3 La Lb^2 Ldb",
    ),
    *_inertia(
        "hub-film tilt inertia (product)",
        "hub_ab",
        RHO_M,
        "La^2 Lb^2",
        "2 La Lda Lb^2 + 2 La^2 Lb Ldb",
    ),
    *_gyroscopic(
        "hub-film transport (heave, first boom)", "hub_g_za", RHO_M, "Lb Lda", "Ldb Lda + Lb Ldda"
    ),
    *_gyroscopic(
        "hub-film transport (heave, second boom)", "hub_g_zb", RHO_M, "La Ldb", "Lda Ldb + La Lddb"
    ),
    *_gyroscopic(
        "hub-film transport (tilt a, first boom)",
        "hub_g_a",
        RHO_M,
        "La Lb Lda",
        "Lda^2 Lb + La Ldb Lda + La Lb Ldda",
    ),
    *_gyroscopic(
        "hub-film transport (tilt b, second boom)",
        "hub_g_b",
        RHO_M,
        "La Lb Ldb",
        "Lda Lb Ldb + La Ldb^2 + La Lb Lddb",
    ),
    *_gyroscopic(
        "hub-film transport (tilt a, second boom)",
        "hub_g_ab",
        RHO_M,
        "La^2 Ldb",
        "2 La Lda Ldb + La^2 Lddb",
    ),
    *_gyroscopic(
        "hub-film transport (tilt b, first boom)",
        "hub_g_ba",
        RHO_M,
        "Lb^2 Lda",
        "2 Lb Ldb Lda + Lb^2 Ldda",
    ),
    # the spin hold (model.md §13.3): H_z [[0, 1], [-1, 0]] on (phi_a, phi_b) as on theta
    Term(
        "spin hold S_h",
        "spin",
        Polynomial(RHO_M, "La^2 Lb Ldb - La Lb^2 Lda", 1.0 / 6.0),
        (DAMPING, CANONICAL_DAMPING, SPIN_HOLD),
    ),
)
# the undeployed film, on the hub's axis (stowed_mass_on_hub)
QUADRANT_STOWED_TERMS = _inertia(
    "film stowed on the hub", "hub_zz", RHO_M, "Lf^2 - La Lb", "-Lda Lb - La Ldb", scale=0.5
)


def _on_first_boom(terms):
    """Boom terms as terms of the quadrant whose first boom it is: integral `boom_<name>`,
    polynomials in `La`, `Lda`, `Ldda`."""
    rename = {"L": "La", "Ld": "Lda", "Ldd": "Ldda"}

    def moved(f: Polynomial) -> Polynomial:
        text = re.sub(r"\b(Ldd|Ld|L)\b", lambda m: rename[m.group(1)], f.text)
        return Polynomial(f.constant, text, f.scale)

    polynomials = {}  # a coefficient shared by terms stays shared
    return tuple(
        dataclasses.replace(
            term,
            integral=f"boom_{term.integral}",
            coefficient=polynomials.setdefault(id(term.coefficient), moved(term.coefficient)),
        )
        for term in terms
    )


class _HubIntegrals:
    """The local matrices of the hub terms of one kind of component, `(m + h) x (m + h)`:
    `m` elastic coordinates (a boom's `p_k`, or a quadrant's `q~`) then `h` hub ones
    (`z`, then one tilt per boom of the component); nonzero only in the hub rows and
    columns. Built from the reference vectors of `integrals.py` (model.md §13.4)."""

    def __init__(self, elastic: int, tilts: int):
        self.elastic = elastic
        self.size = elastic + 1 + tilts
        self.z = elastic

    def unit(self, row: int, column: int, value: float = 1.0, symmetric: bool = False):
        matrix = np.zeros((self.size, self.size))
        matrix[row, column] += value
        if symmetric and row != column:
            matrix[column, row] += value
        return matrix

    def row(self, row: int, vector: np.ndarray, symmetric: bool = False):
        matrix = np.zeros((self.size, self.size))
        matrix[row, : self.elastic] = vector
        if symmetric:
            matrix[: self.elastic, row] = vector
        return matrix

    def entries(self) -> np.ndarray:
        """Flat local indices of the hub rows and columns (the rest is zero)."""
        rows, columns = np.indices((self.size, self.size))
        return np.flatnonzero((rows >= self.elastic) | (columns >= self.elastic))


def hub_integrals(boom: BoomIntegrals, quadrant: QuadrantIntegrals) -> _HubIntegrals:
    """Quadrant `Q_ab` and its first boom with the hub, local `[q~, z, phi_a, phi_b]`
    (boom a's `[p_a, z, phi_a]` is part of it): the quadrant's integrals, and its first
    boom's as `boom_<name>`."""
    local = _HubIntegrals(quadrant.s_mean.size, 2)
    z, a, b = local.z, local.z + 1, local.z + 2
    nb = boom.psi_mean.size
    booms = np.zeros(quadrant.s_mean.size)  # a boom vector in the quadrant's first-boom rows

    def first(vector):
        booms[:nb] = vector
        return booms.copy()

    local.boom_hub_1 = local.unit(z, z) + local.row(z, first(boom.psi_mean), symmetric=True)
    local.boom_hub_x = local.unit(z, a, 0.5, symmetric=True) + local.row(
        a, first(boom.xi_psi), symmetric=True
    )
    local.boom_hub_xx = local.unit(a, a, 1.0 / 3.0)
    local.boom_hub_zz = local.unit(z, z)
    local.boom_hub_g_z = local.row(z, first(boom.r_mean))
    local.boom_hub_g_phi = local.row(a, first(boom.xi_r - boom.psi_mean)) + local.unit(z, a)
    local.hub_1 = local.unit(z, z, 0.5) + local.row(z, quadrant.s_mean, symmetric=True)
    local.hub_a = local.unit(z, a, 1.0 / 6.0, symmetric=True) + local.row(
        a, quadrant.xi_s, symmetric=True
    )
    local.hub_b = local.unit(z, b, 1.0 / 6.0, symmetric=True) + local.row(
        b, quadrant.eta_s, symmetric=True
    )
    local.hub_aa = local.unit(a, a, 1.0 / 12.0)
    local.hub_bb = local.unit(b, b, 1.0 / 12.0)
    local.hub_ab = local.unit(a, b, 1.0 / 24.0, symmetric=True)
    local.hub_zz = local.unit(z, z)
    local.hub_g_za = local.row(z, quadrant.ra_mean)
    local.hub_g_zb = local.row(z, quadrant.rb_mean)
    local.hub_g_a = local.row(a, quadrant.xi_ra - quadrant.s_mean) + local.unit(z, a, 0.5)
    local.hub_g_b = local.row(b, quadrant.eta_rb - quadrant.s_mean) + local.unit(z, b, 0.5)
    local.hub_g_ab = local.row(a, quadrant.xi_rb)
    local.hub_g_ba = local.row(b, quadrant.eta_ra)
    local.spin = local.unit(a, b) - local.unit(b, a)
    return local


class _Component:
    """The terms of one kind of component (the 4 booms or the 4 quadrants, or their
    couplings to the hub).

    The distinct integrals are stacked once; a plan maps the term coefficients
    of the requested outputs onto them (a 0/1 matrix: each (integral, output)
    pair has at most one term, so the mapping adds nothing but zeros). With
    `entries`, only those flat entries of each block are kept (the hub rows and
    columns of a coupling), each multiplied by its `signs` when it lands.
    """

    def __init__(self, terms, integrals, targets: np.ndarray, entries=None, signs=None):
        self.terms = terms
        keys = list(dict.fromkeys(term.integral_key for term in terms))
        self._column = {key: i for i, key in enumerate(keys)}
        stacked = []
        for name, skew in keys:
            matrix = getattr(integrals, name)
            stacked.append(matrix - matrix.T if skew else matrix)
        self.size = stacked[0].shape[0]  # of each block: n_B, or n~ for a quadrant
        self.integrals = np.stack(stacked).reshape(len(keys), -1)
        if entries is not None:
            self.integrals = self.integrals[:, entries]
        self.targets = targets  # (4, entries): flat system index of every block entry
        self.signs = signs  # (4, entries) or None: +-1 of every entry as it lands
        self.signed = signs is not None

    def selection(self, outputs: tuple[str, ...], constants: Constants):
        """`(functions, weights, integrals)`: the distinct coefficient functions that feed
        `outputs` (a term's `G` and `G - G^T` share one), (functions, outputs x
        integrals) with 1 where a function's value goes into an integral of an output,
        and the integrals (the ones the outputs use, for a signed component); the other
        terms, and those that vanish with a physical constant that is 0 here (a
        coefficient `_vanishing`, e.g. the Rayleigh damping's when there is none), are
        not evaluated."""
        select = np.zeros((len(self.terms), len(outputs), len(self._column)))
        for t, term in enumerate(self.terms):
            vanishes_with = getattr(term.coefficient, "vanishes_with", None)
            if vanishes_with is not None and getattr(constants, vanishes_with) == 0.0:
                continue
            for o, output in enumerate(outputs):
                if output in term.matrices:
                    select[t, o, self._column[term.integral_key]] = 1.0
        rows: dict = {}
        for term, row in zip(self.terms, select.reshape(len(self.terms), -1), strict=True):
            if row.any():
                rows[term.coefficient] = rows.get(term.coefficient, 0.0) + row
        functions = tuple(rows)
        weights = np.array(list(rows.values())).reshape(len(rows), select[0].size)
        integrals = self.integrals
        if self.signed:  # (a coupling to the hub) only the integrals the outputs use
            by_output = weights.reshape(len(rows), len(outputs), len(self._column))
            used = np.flatnonzero(by_output.any(axis=(0, 1)))
            weights = by_output[:, :, used].reshape(len(rows), len(outputs) * used.size)
            integrals = self.integrals[used]
        if functions and all(isinstance(f, Polynomial) for f in functions):
            functions = _PolynomialBatch(functions, weights)
        return functions, weights, integrals

    def values(self, motion, constants: Constants, selection, k: int) -> np.ndarray:
        """Entries of every block of every requested output, flat, component-major; (...,
        entries) for motions of shape (..., 4)."""
        weights = self._weights(motion, constants, selection)
        lead = weights.shape[:-2]
        values = weights.reshape(*lead, 4 * k, -1) @ selection[2]
        if self.signed:
            values = values.reshape(*lead, 4, k, -1) * self.signs[:, None, :]
        return values.reshape(*lead, -1)

    def blocks(self, motion, constants: Constants, selection, k: int) -> np.ndarray:
        """Every block of every requested output, (k, 4, size, size), output-major."""
        weights = self._weights(motion, constants, selection).reshape(4, k, -1).transpose(1, 0, 2)
        return (weights @ self.integrals).reshape(k, 4, self.size, self.size)

    def _weights(self, motion, constants: Constants, selection) -> np.ndarray:
        """(..., 4, outputs x integrals): the coefficient of each integral in each output."""
        functions, weights, _ = selection
        if isinstance(functions, _PolynomialBatch):
            return functions(motion, constants)
        if not functions:
            return np.zeros((*np.shape(motion[0]), weights.shape[1]))
        coefficients = np.array([function(motion, constants) for function in functions])
        # the functions' axis last (`np.moveaxis` as a plain transpose)
        return coefficients.transpose(*range(1, coefficients.ndim), 0) @ weights


class _HubCoupling:
    """The hub terms (each quadrant's and its first boom's): the `_Component` of their
    values, and where each value lands in a dense `n x n` matrix and in the border
    (`blocks.Border`: the hub rows `(3, n)`, then the hub columns of the elastic rows
    `(n_e, 3)`)."""

    def __init__(self, terms, local: _HubIntegrals, slots: list, n: int, n_elastic: int):
        entries = local.entries()
        rows, columns = np.unravel_index(entries, (local.size, local.size))
        places = np.stack([place for place, _ in slots])  # (4, local size): system index
        signs = np.stack([sign for _, sign in slots])
        row, column = places[:, rows], places[:, columns]
        self.dense_targets = row * n + column
        on_hub_rows = row >= n_elastic
        self.border_targets = np.where(
            on_hub_rows,
            (row - n_elastic) * n + column,
            3 * n + row * 3 + (column - n_elastic),
        )
        self.component = _Component(
            terms, local, self.dense_targets, entries, signs[:, rows] * signs[:, columns]
        )


class _Plan(NamedTuple):
    """What one tuple of outputs needs: term selections, scatter indices, and the
    outputs computed (the requested ones, plus `M` when the mean-axes damping needs it)."""

    outputs: tuple[str, ...]
    selections: tuple  # per component: `_Component.selection`
    scatter: np.ndarray  # where each value lands (the constants' places last)
    constant_values: np.ndarray  # the hub's own mass and inertia, where `M` is computed
    damped: tuple[int, ...]  # outputs that hold alpha M_r (free hub, alpha != 0)
    border_scatter: np.ndarray  # the hub terms' and constants' places in the border


class SystemAssembler:
    """Builds the matrices of Eq. 2 from the boom motion.

    Physical constants enter once here; `evaluate` takes only the outputs
    wanted and the boom lengths, rates and accelerations (4 values each,
    order a, b, c, d).

    Args:
        boom, quadrant: the reference integrals.
        layout: the coordinates (with the hub's when free).
        constants: the physical constants.
        hub: with a free hub, `(m_h, J_x, J_y, stowed)` (model.md §13): hub mass [kg],
            inertias [kg m^2], and whether undeployed material rides on the hub.
    """

    def __init__(
        self,
        boom: BoomIntegrals,
        quadrant: QuadrantIntegrals,
        layout: Layout,
        constants: Constants,
        hub: tuple[float, float, float, bool] | None = None,
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
        self._quadrant_booms = QUADRANT_BOOMS.ravel()  # the first booms, then the second
        self._plans: dict[tuple[str, ...], _Plan] = {}
        self._scatters: dict[tuple[str, ...], np.ndarray] = {}  # `_stacked_scatter`
        self.blocks = BlockLayout(layout)
        self._hub: _HubCoupling | None = None  # the hub terms, lifted with the quadrants'
        self._hub_inertia = None
        self._border_size = 3 * self.n + 3 * layout.n_elastic  # hub rows, hub columns
        if hub is not None:
            self._set_hub(boom, quadrant, *hub)

    def _set_hub(self, boom, quadrant, mass, inertia_x, inertia_y, stowed):
        layout, n, n_e = self.layout, self.n, self.layout.n_elastic
        z = n_e  # the hub's coordinates follow the elastic ones: z_h, theta_x, theta_y

        def tilt(k):  # system index and sign of d_k^T theta
            axis, sign = hub_tilt_axis(k)
            return z + 1 + axis, sign

        def slots(elastic, booms):
            tilts = [tilt(k) for k in booms]
            places = np.concatenate([elastic, [z], [place for place, _ in tilts]])
            signs = np.concatenate([np.ones(elastic.size + 1), [sign for _, sign in tilts]])
            return places, signs

        terms = _on_first_boom(BOOM_HUB_TERMS) + QUADRANT_HUB_TERMS
        if stowed:
            terms += _on_first_boom(BOOM_STOWED_TERMS) + QUADRANT_STOWED_TERMS
        self._hub = _HubCoupling(
            terms,
            hub_integrals(boom, quadrant),
            [slots(layout.quadrant_slots(q), [q.first, q.second]) for q in QUADRANTS],
            n,
            n_e,
        )
        self._hub_inertia = np.array([mass, inertia_x, inertia_y], dtype=float)

    @property
    def free_hub(self) -> bool:
        return self._hub is not None

    def _components(self):
        hub = (self._hub.component,) if self.free_hub else ()
        return (self._booms, self._quadrants) + hub

    def _plan(self, outputs: tuple[str, ...]) -> _Plan:
        """Term-to-integral selections and scatter indices for `outputs`."""
        plan = self._plans.get(outputs)
        if plan is None:
            unknown = [name for name in outputs if name not in ALL_OUTPUTS]
            if unknown:
                raise ValueError(f"unknown output(s) {unknown!r}; known: {', '.join(ALL_OUTPUTS)}")
            computed = outputs
            damped = ()
            if self.free_hub and self.constants.mass_damping != 0.0:
                damped = tuple(i for i, name in enumerate(outputs) if name in _RAYLEIGH)
                if damped and MASS not in outputs:
                    computed = outputs + (MASS,)
            offsets = (self.n * self.n * np.arange(len(computed)))[None, :, None]
            scatter = np.concatenate(
                [
                    (component.targets[:, None, :] + offsets).ravel()
                    for component in self._components()
                ]
            )
            n, n_e, k = self.n, self.layout.n_elastic, len(computed)
            constant_values = constant_targets = border_constants = np.zeros(0, dtype=int)
            if self.free_hub and MASS in computed:
                hub = np.arange(3)
                constant_values = self._hub_inertia
                constant_targets = computed.index(MASS) * n * n + (n_e + hub) * (n + 1)
                border_constants = computed.index(MASS) * self._border_size + hub * n + n_e + hub
            border_offsets = self._border_size * np.arange(k)[None, :, None]
            border_scatter = border_constants
            if self.free_hub:
                hub_targets = self._hub.border_targets[:, None, :] + border_offsets
                border_scatter = np.concatenate([hub_targets.ravel(), border_constants])
            plan = _Plan(
                computed,
                tuple(
                    component.selection(computed, self.constants)
                    for component in self._components()
                ),
                np.concatenate([scatter, constant_targets]),
                constant_values,
                damped,
                border_scatter,
            )
            self._plans[outputs] = plan
        return plan

    def evaluate_blocks(self, outputs, lengths, rates, accelerations) -> BlockMatrices:
        """The requested matrices as their boom and quadrant blocks (`blocks.py`),
        unassembled, with the hub's rows and columns as a border when it is free;
        arguments as for `evaluate`."""
        outputs = tuple(outputs)
        plan = self._plan(outputs)
        k = len(plan.outputs)
        booms, quadrants = self._kinematics(lengths, rates, accelerations)
        boom_blocks = self._booms.blocks(booms, self.constants, plan.selections[0], k)
        quadrant_blocks = self._quadrants.blocks(quadrants, self.constants, plan.selections[1], k)
        if not self.free_hub:
            return BlockMatrices(boom_blocks, quadrant_blocks, self.blocks)
        n, n_e, size = self.n, self.layout.n_elastic, self._border_size
        values = self._hub.component.values(quadrants, self.constants, plan.selections[2], k)
        flat = np.bincount(
            plan.border_scatter,
            weights=np.concatenate([values, plan.constant_values]),
            minlength=k * size,
        ).reshape(k, size)
        border = Border(flat, n, n_e)
        low_rank = None
        if plan.damped:
            mass = border.rows[plan.outputs.index(MASS)]
            coefficients = np.zeros(k)
            coefficients[list(plan.damped)] = self.constants.mass_damping
            low_rank = LowRank(coefficients[: len(outputs)], mass[:, :n_e].T, mass[:, n_e:])
        keep = len(outputs)
        return BlockMatrices(
            boom_blocks[:keep],
            quadrant_blocks[:keep],
            self.blocks,
            Border(flat[:keep], n, n_e),
            low_rank,
        )

    def _kinematics(self, lengths, rates, accelerations):
        pairs = np.array([lengths, rates, accelerations])[..., self._quadrant_booms]
        first, second = pairs[..., :4], pairs[..., 4:]
        return BoomKinematics(lengths, rates, accelerations), QuadrantKinematics(*first, *second)

    def evaluate(self, outputs, lengths, rates, accelerations) -> np.ndarray:
        """The requested matrices stacked, shape (len(outputs), n, n); for `m` motions
        (arrays (m, 4)), (m, len(outputs), n, n) in one pass.

        Args:
            outputs: a tuple of the output names above, in any order.
            lengths: boom lengths [m], 4 values (or (m, 4)), already validated.
            rates: extension rates [m/s], 4 values (or (m, 4)).
            accelerations: extension accelerations [m/s^2], 4 values (or (m, 4)).
        """
        outputs = tuple(outputs)
        plan = self._plan(outputs)
        k = len(plan.outputs)
        booms, quadrants = self._kinematics(lengths, rates, accelerations)
        motions = (booms, quadrants, quadrants)  # the hub terms go with the quadrants
        components = self._components()
        lead = np.shape(lengths)[:-1]
        parts = [
            component.values(motion, self.constants, selection, k)
            for component, selection, motion in zip(
                components, plan.selections, motions[: len(components)], strict=True
            )
        ]
        if plan.constant_values.size:
            parts.append(np.broadcast_to(plan.constant_values, (*lead, plan.constant_values.size)))
        values = np.concatenate(parts, axis=-1)
        size = k * self.n * self.n
        count = math.prod(lead)
        scatter = plan.scatter if not lead else self._stacked_scatter(outputs, plan, count)
        out = np.bincount(scatter.ravel(), weights=values.ravel(), minlength=count * size)
        out = out.reshape(*lead, k, self.n, self.n)
        if plan.damped:
            n_e = self.layout.n_elastic
            for matrices in out.reshape(-1, k, self.n, self.n):
                correction = _mean_axes_correction(matrices[plan.outputs.index(MASS)], n_e)
                for index in plan.damped:
                    matrices[index, :n_e, :n_e] -= self.constants.mass_damping * correction
        return out[..., : len(outputs), :, :]

    def _stacked_scatter(self, outputs, plan: _Plan, count: int) -> np.ndarray:
        """`plan.scatter` for `count` motions at once, each into its own matrices: the
        first `count` of the most asked for so far, kept per `outputs` (a moving step asks
        for three middles, its dense output for as many times as it holds samples)."""
        found = self._scatters.get(outputs)
        if found is None or found.size < count * plan.scatter.size:
            size = len(plan.outputs) * self.n * self.n
            found = (plan.scatter + size * np.arange(count)[:, None]).ravel()
            self._scatters[outputs] = found
        return found[: count * plan.scatter.size]


def _mean_axes_correction(M: np.ndarray, n_elastic: int) -> np.ndarray:
    """`M_qh M_hh^-1 M_hq` (n_e x n_e): what `M_r = M - M[:,h] M_hh^-1 M[h,:]` takes from
    the elastic block of `M` (its hub rows and columns are then zero; model.md §13.5)."""
    coupling = M[:n_elastic, n_elastic:]
    return coupling @ np.linalg.solve(M[n_elastic:, n_elastic:], coupling.T)
