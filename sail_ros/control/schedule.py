"""The controller over boom length: design points on a grid, interpolated, kept in a file.

`design_schedule` designs the controller (`design.design_point`) at every length of
the grid, all booms equal; `GainSchedule.at(L)` blends the two design points around
`L` linearly (all five arrays: the estimate's coordinates are the design model's own,
the same at every length, so the blend is a controller of the same state) and holds
the end points beyond the grid. The controller calls it with the mean boom length.

A gains file (`.npz`, `GainSchedule.save`/`load`) holds the grid, the stacked arrays,
the period, the delay, the names of the inputs and measurements and the design's
settings; `load` refuses, in one line naming the array, a file whose arrays do not
fit together or hold a non-finite value.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from sail_ros.control.design import (
    DesignPoint,
    delay_split,
    design_point,
    design_sail,
    input_names,
    measurement_names,
    require_free_hub,
)
from sail_ros.control.settings import DesignSettings, auto_lengths
from sail_ros.model import SailModel, SailParameters

FORMAT = "sail_ros gain schedule 1"


@dataclasses.dataclass(frozen=True)
class GainSchedule:
    """Design points at `lengths` [m] (k,), stacked: `F` (k, n, n), `G` (k, n, nu), `C`
    (k, ny, n), `M` (k, n, ny), `K` (k, nu, n); `period` and `delay` [s]; the names of
    the `inputs` (nu) and `measurements` (ny); `settings`, the design's."""

    lengths: np.ndarray
    F: np.ndarray
    G: np.ndarray
    C: np.ndarray
    M: np.ndarray
    K: np.ndarray
    period: float
    delay: float
    inputs: tuple[str, ...]
    measurements: tuple[str, ...]
    settings: DesignSettings

    @property
    def size(self) -> int:
        """Entries of the estimate `[xi; d]`."""
        return self.F.shape[1]

    def at(self, length: float) -> DesignPoint:
        """The design point at `length` [m]: linear between the grid's two neighbours,
        the end points beyond the grid."""
        grid = self.lengths
        if length <= grid[0]:
            return self._point(0, 0.0)
        if length >= grid[-1]:
            return self._point(len(grid) - 2, 1.0)
        i = int(np.searchsorted(grid, length, "right")) - 1
        return self._point(i, (length - grid[i]) / (grid[i + 1] - grid[i]))

    def _point(self, i: int, f: float) -> DesignPoint:
        return DesignPoint(
            *((1.0 - f) * getattr(self, name)[i] + f * getattr(self, name)[i + 1]
              for name in DesignPoint.ARRAYS)
        )  # fmt: skip

    def save(self, path) -> None:
        """The schedule as a `.npz` (written to `path`, a file object or a name)."""
        np.savez(
            path,
            format=np.array(FORMAT),
            lengths=self.lengths,
            **{name: getattr(self, name) for name in DesignPoint.ARRAYS},
            period=self.period,
            delay=self.delay,
            inputs=np.array(self.inputs),
            measurements=np.array(self.measurements),
            settings=np.array(json.dumps(self.settings.to_dict())),
        )

    @classmethod
    def load(cls, path) -> GainSchedule:
        """A schedule from a gains file `path` (`save`).

        Raises:
            ValueError: not a gains file, an array missing, of the wrong shape or with
                a non-finite value, or settings that are not a design's (one line
                naming the file and the array).
        """
        where = f"gains file {path}"
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
        except (OSError, ValueError) as error:
            raise ValueError(f"{where}: cannot read it as .npz ({error})") from None
        if str(arrays.get("format", "")) != FORMAT:
            raise ValueError(f"{where}: not a gain schedule (no format {FORMAT!r})")
        missing = [
            name
            for name in ("lengths", *DesignPoint.ARRAYS, "period", "delay", "inputs",
                         "measurements", "settings")
            if name not in arrays
        ]  # fmt: skip
        if missing:
            raise ValueError(f"{where}: no {', '.join(missing)}")
        try:
            settings = DesignSettings(**json.loads(str(arrays["settings"])))
        except (TypeError, ValueError) as error:
            raise ValueError(f"{where}: settings: {error}") from None
        lengths = np.asarray(arrays["lengths"], dtype=float)
        k = lengths.size
        if lengths.ndim != 1 or k < 2 or np.any(np.diff(lengths) <= 0):
            raise ValueError(
                f"{where}: lengths must be at least 2 increasing values, got shape {lengths.shape}"
            )
        inputs = tuple(str(v) for v in np.atleast_1d(arrays["inputs"]))
        measurements = tuple(str(v) for v in np.atleast_1d(arrays["measurements"]))
        n = np.shape(arrays["F"])[-1] if np.ndim(arrays["F"]) == 3 else -1
        nu, ny = len(inputs), len(measurements)
        expected = {
            "F": (k, n, n),
            "G": (k, n, nu),
            "C": (k, ny, n),
            "M": (k, n, ny),
            "K": (k, nu, n),
        }
        for name, shape in expected.items():
            array = np.asarray(arrays[name])
            if array.shape != shape or n < 1:
                raise ValueError(
                    f"{where}: {name} has shape {array.shape}, expected {shape} ({k} "
                    f"lengths, {nu} inputs, {ny} measurements, estimate of F's size)"
                )
            if not np.all(np.isfinite(array)):
                raise ValueError(f"{where}: {name} holds a value that is not finite")
        for name in ("lengths", "period", "delay"):
            if not np.all(np.isfinite(arrays[name])):
                raise ValueError(f"{where}: {name} is not finite")
        return cls(
            lengths,
            *(np.asarray(arrays[name], dtype=float) for name in DesignPoint.ARRAYS),
            float(arrays["period"]),
            float(arrays["delay"]),
            inputs,
            measurements,
            settings,
        )

    def check_against(self, settings: DesignSettings, where: str) -> None:
        """Refuse, naming `where` (the file), a schedule that is not of `settings`'
        shape: its period, loop delay, inputs and measurements."""
        if abs(self.period * settings.state_rate_hz - 1.0) > 1e-9:
            raise ValueError(
                f"{where}: designed at {1.0 / self.period:g} Hz, state_rate_hz is "
                f"{settings.state_rate_hz:g} Hz"
            )
        if delay_split(self.period, self.delay) != delay_split(
            settings.period, settings.loop_delay_s
        ):
            raise ValueError(
                f"{where}: designed for loop_delay_s = {self.delay:g} s, the setting is "
                f"{settings.loop_delay_s:g} s"
            )
        for what, have, want in (
            ("inputs", self.inputs, input_names(settings)),
            ("measurements", self.measurements, measurement_names(settings)),
        ):
            if have != want:
                raise ValueError(
                    f"{where}: {what} {', '.join(have)}; these settings (tip_forces, "
                    f"design mode counts) need {', '.join(want)}"
                )


def schedule_lengths(params: SailParameters, settings: DesignSettings) -> np.ndarray:
    """The grid [m]: the settings' `schedule_lengths`, or `auto_lengths` up to the fully
    deployed boom."""
    lengths = settings.schedule_lengths or auto_lengths(params.full_boom_length)
    return np.asarray(lengths, dtype=float)


def design_schedule(params: SailParameters, settings: DesignSettings) -> GainSchedule:
    """The controller of `settings` for the sail `params` at every length of the grid.

    Raises:
        ValueError: a clamped hub; a length the sail refuses; a design point without
            a stabilising Riccati solution (naming the length).
    """
    require_free_hub(params)
    model = SailModel(design_sail(params, settings))
    lengths = schedule_lengths(params, settings)
    points = []
    for length in lengths:
        try:
            points.append(design_point(model, settings, float(length)))
        except ValueError as error:
            if "Riccati" in str(error):
                raise
            raise ValueError(f"schedule_lengths: {length:g} m: {error}") from None
    stacked = {name: np.stack([getattr(p, name) for p in points]) for name in DesignPoint.ARRAYS}
    return GainSchedule(
        lengths,
        **stacked,
        period=settings.period,
        delay=settings.loop_delay_s,
        inputs=input_names(settings),
        measurements=measurement_names(settings),
        settings=settings,
    )
