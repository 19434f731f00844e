"""What `sail-ros plant` found, as one object (`PlantTable`): the plant's size, its
listed poles and its notes; the text and the JSON (`--json`) are rendered from the
same rows, so they agree."""

from __future__ import annotations

import dataclasses

from sail_ros.analysis.json_values import plain
from sail_ros.analysis.plant import LinearPlant, Pole, hub_note, poles, undamped_note


def pole_row(index: int, pole: Pole) -> dict:
    """A listed pole as printed: its number, `s` [1/s, rad/s], natural frequency
    [rad/s, Hz] and damping ratio; the round-off real part of an undamped pole (below
    1e-12 of its frequency) as 0, and its damping ratio 0."""
    tiny = abs(pole.s.real) < 1e-12 * max(pole.omega, 1.0)
    real, zeta = (0.0, 0.0) if tiny else (pole.s.real, pole.zeta)
    return {
        "pole": index,
        "real_1_s": real,
        "imag_rad_s": pole.s.imag,
        "omega_rad_s": pole.omega,
        "frequency_hz": pole.hertz,
        "damping_ratio": zeta,
    }


@dataclasses.dataclass(frozen=True)
class PlantTable:
    """A linear plant and its first poles.

    Attributes:
        plant: the `analysis.plant.LinearPlant`.
        params: the sail it was built from; described: its parameters in words.
        listed: the poles listed, lowest first (`analysis.plant.poles`).
        unstable: how many of its poles (`poles`: one of each oscillatory pair) have a
            positive real part (beyond 1e-9 of their frequency).
    """

    plant: LinearPlant
    params: object
    described: str
    listed: list[Pole]
    unstable: int

    @classmethod
    def of(cls, plant: LinearPlant, params, described: str, count: int) -> PlantTable:
        """The first `count` poles of `plant`, and how many of them all grow."""
        found = poles(plant)
        unstable = sum(p.s.real > 1e-9 * max(p.omega, 1.0) for p in found)
        return cls(plant, params, described, found[:count], int(unstable))

    def rows(self) -> list[dict]:
        return [pole_row(i, pole) for i, pole in enumerate(self.listed, start=1)]

    def text(self) -> str:
        """The heading, the parameters, the pole table and its notes."""
        plant = self.plant
        lines = [
            f"Linear plant of the sail: lengths {', '.join(f'{v:.4g}' for v in plant.lengths)}"
            f" m, rates {', '.join(f'{v:.4g}' for v in plant.rates)} m/s; "
            f"{len(plant.state_names)} states, {len(plant.input_names)} inputs, "
            f"{len(plant.output_names)} outputs",
            self.described,
            "",
            f"  {'pole':>5}{'Re s [1/s]':>14}{'Im s [rad/s]':>14}{'omega [rad/s]':>15}"
            f"{'f [Hz]':>12}{'zeta':>12}",
        ]
        for row in self.rows():
            lines.append(
                f"  {row['pole']:>5}{row['real_1_s']:>14.5g}{row['imag_rad_s']:>14.6g}"
                f"{row['omega_rad_s']:>15.6g}{row['frequency_hz']:>12.5g}"
                f"{row['damping_ratio']:>12.4g}"
            )
        if self.unstable:
            lines.append(
                f"  {self.unstable} pole(s) with a positive real part: the frozen plant is unstable"
            )
        if plant.free_hub:
            lines.append(f"  note: {hub_note(plant)}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The same as one JSON object (`--json`; NaN as null): lengths [m], rates [m/s],
        the plant's size, the parameters, the listed poles, the count of growing poles,
        a free hub's note and the warning of poles on the imaginary axis (null if none)."""
        plant = self.plant
        return {
            "lengths_m": [float(v) for v in plant.lengths],
            "rates_m_s": [float(v) for v in plant.rates],
            "states": len(plant.state_names),
            "inputs": len(plant.input_names),
            "outputs": len(plant.output_names),
            "parameters": self.params.to_dict(),
            "poles": [plain(row) for row in self.rows()],
            "unstable_poles": self.unstable,
            "hub_note": hub_note(plant) if plant.free_hub else None,
            "undamped_note": undamped_note(plant) or None,
        }
