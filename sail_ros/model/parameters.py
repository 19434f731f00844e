"""Physical and discretisation parameters of the sail (SI units).

Defaults are those of model.md §10: a 100 m square sail whose fully deployed
booms are 70.71 m long, CP1/Kapton-class film at 1 psi prestress, and the
seed's validation setting of no boom axial load.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path

import sail_ros.model.yaml_values as yaml_values
from sail_ros.model.fields import check_fields, setting, spec_of
from sail_ros.spelling import did_you_mean

MAX_BOOM_MODES = 30  # beyond, the cantilever functions' evaluation and the integrals cost more
# than the model is worth; the membrane's integrals take about 10 s and 1 GiB at 400 modes
MAX_MEMBRANE_MODES = 400
# the first root of cos(b) cosh(b) + 1 = 0: a cantilever's first frequency is
# FIRST_CANTILEVER_ROOT^2 sqrt(EI / rho_B) / L^2
FIRST_CANTILEVER_ROOT = 1.8751040687119611
# the fewest membrane modes an automatic count gives (a membrane without waves: no tension
# or no mass)
MIN_AUTOMATIC_MEMBRANE_MODES = 6
# [m] the length the automatic count resolves where no run names one: the reference
# deployment's and the simulator's initial length
DEFAULT_RESOLVED_LENGTH = 10.0

# the node whose parameters in a ROS 2 params file give the sail (the simulator's)
SIMULATOR_NODE = "sail_sim"
# The live simulator's sail defaults where they differ from this table's (the offline
# tools'): a narrower membrane band keeps fewer membrane modes, a model the simulator steps
# faster than real time, whose peaks stay within the convergence bar (docs/model.md
# §10.1). The simulator and the controller node, which
# must design for the simulator's sail, declare these; the simulator says so at start.
LIVE_DEFAULTS = {"membrane_band": 1.4}
SAIL_PREFIX = "sail."  # the simulator's parameter `sail.<field>` is SailParameters.<field>
# a free hub's fields (docs/model.md §13.8): given as parameters only when the hub is free, so
# a clamped sail's parameter set does not depend on them
HUB_FIELDS = ("free_hub", "hub_mass", "hub_inertia_x", "hub_inertia_y", "stowed_mass_on_hub")


@dataclasses.dataclass(frozen=True)
class SailParameters:
    """Parameters of the four-boom, four-quadrant sail: one declaration per field, with
    its unit, range and meaning (`fields.setting`), from which its check, the simulator's
    ROS parameters `sail.<field>`, the tools' `--set` help and the docs table come.
    """

    sail_side: float = setting(
        100.0,
        "m",
        "side a of the square sail; the fully deployed boom length is a/sqrt(2)",
        minimum=0.0,
        maximum=1e4,
        above_minimum=True,
    )
    boom_bending_stiffness: float = setting(
        6000.0, "N m^2", "bending stiffness EI of each boom", minimum=0.0, maximum=1e12,
        above_minimum=True,
    )  # fmt: skip
    boom_linear_density: float = setting(
        0.1, "kg/m", "mass per length rho_B of each boom", minimum=0.0, maximum=1e6,
        above_minimum=True,
    )  # fmt: skip
    membrane_thickness: float = setting(2.5e-6, "m", "film thickness h", minimum=0.0, maximum=1e-2)
    membrane_density: float = setting(
        1430.0, "kg/m^3", "film density rho; areal density rho h", minimum=0.0, maximum=1e5
    )
    membrane_prestress: float = setting(
        6890.0, "Pa", "isotropic film prestress sigma; tension N0 = sigma h", minimum=0.0,
        maximum=1e10,
    )  # fmt: skip
    boom_axial_load: float = setting(
        0.0, "N", "axial compression P the membrane puts on each boom", minimum=0.0,
        maximum=1e12,
    )  # fmt: skip
    n_boom_modes: int = setting(
        8, "-", "cantilever modes per boom n_B", minimum=1, maximum=MAX_BOOM_MODES
    )
    n_membrane_modes: int = setting(
        0, "-", "clamped-triangle modes per quadrant n_M; 0: every mode up to membrane_band "
        "times the first cantilever frequency at resolved_length", minimum=0,
        maximum=MAX_MEMBRANE_MODES,
    )  # fmt: skip
    membrane_band: float = setting(
        1.8, "-", "the automatic n_M keeps every membrane mode up to this multiple of the "
        "booms' first cantilever frequency at resolved_length", minimum=0.0, maximum=10.0,
        above_minimum=True,
    )  # fmt: skip
    resolved_length: float = setting(
        0.0, "m", "the shortest boom length the automatic n_M resolves; 0: the run's "
        "shortest (the simulator's initial lengths, a scenario's profile, the lengths a tool "
        "analyses; 10 m where none is known)", minimum=0.0, maximum=1e4,
    )  # fmt: skip
    mass_damping: float = setting(
        0.0, "1/s", "Rayleigh alpha of the damping C_d = alpha M + beta K", minimum=0.0,
        maximum=1e6,
    )  # fmt: skip
    stiffness_damping: float = setting(
        0.0, "s", "Rayleigh beta of the damping C_d = alpha M + beta K; a mode of frequency "
        "omega has the damping ratio alpha / (2 omega) + beta omega / 2", minimum=0.0,
        maximum=1e6,
    )  # fmt: skip

    free_hub: bool = setting(
        False, "", "the hub heaves and tilts (docs/model.md §13); false: clamped, and the four "
        "fields below are ignored",
    )  # fmt: skip
    hub_mass: float = setting(
        100.0, "kg", "hub mass m_h without stowed material", minimum=0.0, maximum=1e12
    )
    hub_inertia_x: float = setting(
        100.0, "kg m^2", "hub moment of inertia J_x about its x axis (boom a) through its "
        "centre", minimum=0.0, maximum=1e15,
    )  # fmt: skip
    hub_inertia_y: float = setting(
        100.0, "kg m^2", "hub moment of inertia J_y about its y axis (boom b)", minimum=0.0,
        maximum=1e15,
    )  # fmt: skip
    stowed_mass_on_hub: bool = setting(
        True, "", "the hub carries the booms and film not yet deployed, so the total mass is "
        "constant; boom lengths above a/sqrt(2) are then refused",
    )  # fmt: skip

    def __post_init__(self):
        check_fields(self)

    # derived quantities -------------------------------------------------
    @property
    def full_boom_length(self) -> float:
        """Fully deployed boom length a/sqrt(2) [m]."""
        return self.sail_side / math.sqrt(2.0)

    @property
    def membrane_modes(self) -> int:
        """Clamped-triangle modes per quadrant the model keeps: `n_membrane_modes`, or, when
        that is 0, `membrane_mode_need` up to `MAX_MEMBRANE_MODES`."""
        if self.n_membrane_modes:
            return self.n_membrane_modes
        return min(self.membrane_mode_need, MAX_MEMBRANE_MODES)

    @property
    def coordinates(self) -> int:
        """The model's generalised coordinates: `4 (n_B + n_M)`, and a free hub's 3 (n_M as
        `membrane_modes` gives it)."""
        return 4 * (self.n_boom_modes + self.membrane_modes) + 3 * self.free_hub

    @property
    def membrane_mode_need(self) -> int:
        """The automatic count: every clamped-triangle mode `(m, n)` whose frequency
        `(pi / L) sqrt(N0 / rho_M) sqrt(m^2 + n^2)` at `L = resolved_length` (10 m when 0)
        is at most `membrane_band` times the first cantilever frequency
        `beta_1^2 sqrt(EI / rho_B) / L^2` there.

        A boom's vibration loads the film at its own frequency, and the film's spectrum is
        dense: it carries the energy away through the modes around that frequency, so
        those must be in the model (docs/model.md, "Mode counts"). Both frequencies fall
        as the booms grow, the boom's faster, so the shortest length decides. A film
        without waves (no tension or no mass) gets `MIN_AUTOMATIC_MEMBRANE_MODES`."""
        tension, density = self.membrane_tension, self.membrane_areal_density
        if tension == 0 or density == 0:
            return MIN_AUTOMATIC_MEMBRANE_MODES
        length = self.resolved_length or DEFAULT_RESOLVED_LENGTH
        boom = FIRST_CANTILEVER_ROOT**2 * math.sqrt(
            self.boom_bending_stiffness / self.boom_linear_density
        )
        radius = self.membrane_band * boom / (math.pi * length * math.sqrt(tension / density))
        squared = int(radius * radius)  # the modes kept have m^2 + n^2 <= squared, m > n >= 1
        count = sum(
            min(m - 1, math.isqrt(squared - m * m)) for m in range(2, math.isqrt(squared) + 1)
        )
        return max(count, MIN_AUTOMATIC_MEMBRANE_MODES)

    def resolved(self, shortest_length: float) -> SailParameters:
        """These parameters for a run whose booms are never shorter than `shortest_length`
        [m]: `resolved_length` set to it where it is 0 (automatic), else unchanged."""
        if self.resolved_length or not (math.isfinite(shortest_length) and shortest_length > 0):
            return self
        return self.replace(resolved_length=float(shortest_length))

    def fixed_modes(self) -> SailParameters:
        """These parameters with the membrane count written out (`membrane_modes`), so
        that changing the sail (a Monte Carlo sample's prestress) keeps the model's size."""
        return self.replace(n_membrane_modes=self.membrane_modes)

    @property
    def membrane_areal_density(self) -> float:
        """rho_M = rho h [kg/m^2]."""
        return self.membrane_density * self.membrane_thickness

    @property
    def membrane_tension(self) -> float:
        """N0 = sigma h [N/m]."""
        return self.membrane_prestress * self.membrane_thickness

    # (de)serialisation --------------------------------------------------
    @classmethod
    def unit(cls, name: str) -> str:
        """The unit of field `name` ("-" for a pure number), from its declaration."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        return spec_of(fields[name]).unit

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def replace(self, **changes) -> SailParameters:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, values: dict) -> SailParameters:
        """Build from a mapping; unknown keys raise ValueError naming them."""
        if not isinstance(values, dict):
            raise ValueError(f"sail parameters must be a mapping, got {values!r}")
        unknown = sorted(set(values) - set(cls.field_names()))
        if unknown:
            raise ValueError(
                f"unknown sail parameter(s) {', '.join(map(_with_nearest, unknown))}; "
                f"known: {', '.join(cls.field_names())}"
            )
        return cls(**values)

    @classmethod
    def from_yaml(cls, path, node: str = SIMULATOR_NODE) -> SailParameters:
        """Read a YAML file holding the fields, either at top level or under `sail:`.

        A ROS 2 params file works too: the `sail.` parameters it gives the node `node`
        (the simulator's, in any namespace: `<node>: ros__parameters: sail: {...}` or
        `sail.n_boom_modes: 4`; none, the defaults).
        """
        return cls.from_document(yaml_values.load_file(path, "sail parameters"), path, node)

    @classmethod
    def from_document(cls, document, path, node: str = SIMULATOR_NODE) -> SailParameters:
        """As `from_yaml`, from the file's document already read (`path` names it in
        errors); an empty document gives the defaults."""
        return cls.from_dict(sail_section(document or {}, Path(path), node))


def _with_nearest(name: str) -> str:
    """`'name'`, and the field it was most likely meant to be, if one is close."""
    return repr(name) + did_you_mean(name, SailParameters.field_names())


def sail_section(document, path: Path, node: str = SIMULATOR_NODE):
    """The sail's fields a parameters file's `document` gives (`from_document`), unchecked:
    its `sail:` section, the `sail.` parameters of the node `node` in a ROS 2 params file,
    or the document itself."""
    if not isinstance(document, dict):
        raise ValueError(f"{path}: expected a mapping at top level, got {document!r}")
    if "sail" in document:
        return document["sail"]
    given = yaml_values.node_parameters(document, node, path)
    if given is None:
        return document
    # a ROS 2 params file: the node's `sail.` parameters, nested (`sail: {n_boom_modes:
    # 4}`) or by name (`sail.n_boom_modes: 4`); none, the defaults
    if "sail" in given:
        raise ValueError(f"{path}: sail of {node} must be a mapping, got {given['sail']!r}")
    return sail_fields(given)


# -- the flat names `sail.<field>` of the simulator's parameters: the one conversion ----------


def sail_fields(values: Mapping[str, object]) -> dict:
    """The `sail.<field>` entries of flat parameter values, by field name (others left
    out): `{"sail.n_boom_modes": 4, "max_rate": 2}` gives `{"n_boom_modes": 4}`."""
    return {
        name.removeprefix(SAIL_PREFIX): value
        for name, value in values.items()
        if name.startswith(SAIL_PREFIX)
    }


def flat_sail_parameters(params: SailParameters) -> dict[str, object]:
    """`sail.<field>` -> value: the sail as the simulator's parameters (the hub's fields
    only with a free hub; absent, they take their defaults)."""
    return {
        SAIL_PREFIX + name: value
        for name, value in params.to_dict().items()
        if params.free_hub or name not in HUB_FIELDS
    }


def sail_parameters_from_flat(values: Mapping[str, object]) -> SailParameters:
    """`SailParameters` from the `sail.<field>` entries of `values` (others ignored).

    Raises:
        ValueError: a field is unknown or its value invalid, named `sail.<field>`.
    """
    try:
        return SailParameters.from_dict(sail_fields(values))
    except ValueError as error:
        raise ValueError(f"{SAIL_PREFIX}{error}") from None
