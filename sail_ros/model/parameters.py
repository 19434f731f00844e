"""Physical and discretisation parameters of the sail (SI units).

Defaults are those of model.md §10: a 100 m square sail whose fully deployed
booms are 70.71 m long, CP1/Kapton-class film at 1 psi prestress, and the
seed's validation setting of no boom axial load.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import yaml

import sail_ros.model.yaml_values as yaml_values


@dataclasses.dataclass(frozen=True)
class SailParameters:
    """Parameters of the four-boom, four-quadrant sail.

    Attributes:
        sail_side: side `a` of the square sail [m]; full boom length a/sqrt(2).
        boom_bending_stiffness: boom `EI` [N m^2].
        boom_linear_density: boom mass per length `rho_B` [kg/m].
        membrane_thickness: film thickness `h` [m].
        membrane_density: film density `rho` [kg/m^3]; areal density rho h.
        membrane_prestress: isotropic film prestress `sigma` [Pa]; N0 = sigma h.
        boom_axial_load: axial compression `P` on each boom [N] (>= 0).
        n_boom_modes: cantilever modes per boom `n_B` (>= 1).
        n_membrane_modes: clamped-triangle modes per quadrant `n_M` (>= 1).
        mass_damping: Rayleigh `alpha` [1/s] of `C_d = alpha M + beta K` (>= 0).
        stiffness_damping: Rayleigh `beta` [s] (>= 0); a mode of frequency omega
            then has the damping ratio `alpha / (2 omega) + beta omega / 2`.
        free_hub: the hub heaves and tilts (model.md §13); False: clamped, and the
            four fields below are ignored.
        hub_mass: hub mass `m_h` without stowed material [kg] (>= 0).
        hub_inertia_x: hub moment of inertia `J_x` about its x axis (boom a)
            through its centre [kg m^2] (>= 0).
        hub_inertia_y: `J_y` about its y axis (boom b) [kg m^2] (>= 0).
        stowed_mass_on_hub: the hub carries the booms and film not yet deployed,
            so the total mass is constant; boom lengths above `a / sqrt(2)` are
            then refused.
    """

    sail_side: float = 100.0
    boom_bending_stiffness: float = 6000.0
    boom_linear_density: float = 0.1
    membrane_thickness: float = 2.5e-6
    membrane_density: float = 1430.0
    membrane_prestress: float = 6890.0
    boom_axial_load: float = 0.0
    n_boom_modes: int = 4
    n_membrane_modes: int = 6
    mass_damping: float = 0.0
    stiffness_damping: float = 0.0
    free_hub: bool = False
    hub_mass: float = 100.0
    hub_inertia_x: float = 100.0
    hub_inertia_y: float = 100.0
    stowed_mass_on_hub: bool = True

    # fields that must be > 0; the others must be >= 0 (mode counts >= 1)
    _POSITIVE = ("sail_side", "boom_bending_stiffness", "boom_linear_density")
    _MODE_COUNTS = ("n_boom_modes", "n_membrane_modes")
    _BOOLEANS = ("free_hub", "stowed_mass_on_hub")

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.name in self._BOOLEANS:
                if not isinstance(value, bool):
                    raise ValueError(f"{field.name} must be true or false, got {value!r}")
                continue
            if field.name in self._MODE_COUNTS:
                if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                    raise ValueError(f"{field.name} must be an integer >= 1, got {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{field.name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{field.name} must be finite, got {value!r}")
            if field.name in self._POSITIVE and value <= 0:
                raise ValueError(f"{field.name} must be > 0, got {value!r}")
            if value < 0:
                raise ValueError(f"{field.name} must be >= 0, got {value!r}")
            object.__setattr__(self, field.name, float(value))

    # derived quantities -------------------------------------------------
    @property
    def full_boom_length(self) -> float:
        """Fully deployed boom length a/sqrt(2) [m]."""
        return self.sail_side / math.sqrt(2.0)

    @property
    def membrane_areal_density(self) -> float:
        """rho_M = rho h [kg/m^2]."""
        return self.membrane_density * self.membrane_thickness

    @property
    def membrane_tension(self) -> float:
        """N0 = sigma h [N/m]."""
        return self.membrane_prestress * self.membrane_thickness

    @property
    def total_mass(self) -> float:
        """Hub, four full booms and the whole film [kg]: `m_h + 4 rho_B L_f + 2 rho_M L_f^2`
        (the free hub's constant `M[z, z]` with stowed material on the hub)."""
        full = self.full_boom_length
        return (
            self.hub_mass
            + 4.0 * self.boom_linear_density * full
            + 2.0 * self.membrane_areal_density * full**2
        )

    # (de)serialisation --------------------------------------------------
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
                f"unknown sail parameter(s) {', '.join(map(repr, unknown))}; "
                f"known: {', '.join(cls.field_names())}"
            )
        return cls(**values)

    @classmethod
    def from_yaml(cls, path) -> SailParameters:
        """Read a YAML file holding the fields, either at top level or under `sail:`.

        A ROS 2 params file (`<node>: ros__parameters: sail: {...}`) works too.
        """
        try:
            with open(path) as stream:
                document = yaml_values.load(stream) or {}
        except OSError as error:
            raise ValueError(f"cannot read {str(path)!r}: {error.strerror}") from None
        except yaml.YAMLError as error:
            raise ValueError(f"{path}: not valid YAML: {yaml_values.describe(error)}") from None
        return cls.from_dict(_find_sail_section(document, Path(path)))

    def to_yaml(self, path) -> None:
        with open(path, "w") as stream:
            yaml.safe_dump({"sail": self.to_dict()}, stream, sort_keys=False)


def _find_sail_section(document, path: Path) -> dict:
    if not isinstance(document, dict):
        raise ValueError(f"{path}: expected a mapping at top level, got {document!r}")
    if "sail" in document:
        return document["sail"]
    for value in document.values():  # ROS 2 params file: <node>: ros__parameters:
        if isinstance(value, dict) and "ros__parameters" in value:
            section = value["ros__parameters"].get("sail")
            if section is not None:
                return section
    return document
