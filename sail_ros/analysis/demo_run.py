"""The demo's reference deployment (model.md §9) and what its recording shows.

`summarise` reads the bag of a `sail-ros demo` run: the messages per topic, the
simulator's stored parameters, the tip deflections at `REPORT_TIMES` beside the same
run computed offline (stepped and sampled as the simulator does), the real-time
factor and the overruns; `DemoSummary.text` prints them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from sail_ros import status as key
from sail_ros.analysis.log_series import read_log
from sail_ros.bag import BagReader
from sail_ros.integrate.control import DEFAULT_MAX_STEP
from sail_ros.model import CycloidalProfile, SailModel, SailParameters

START, END, DURATION, TIP = 10.0, 15.0, 15.0, 0.1  # m, m, s, m (model.md §9)
REPORT_TIMES = (5.0, 10.0, 15.0)  # s after the start of the deployment
SETTLE_S = 1.0  # s of simulation after the booms stop


@dataclasses.dataclass(frozen=True)
class DemoSummary:
    """A demo run's recording.

    Attributes:
        folder: the bag folder (absolute); files: its files as (name, size [B]).
        counts: messages per topic; wall_s: wall time [s] from first to last message.
        stored: the simulator's parameters stored; sail: its sail parameters;
            time_scale: its `time_scale` as stored (None if absent).
        t: the report times [s] after the start, as recorded (3,); live, offline: the
            tip deflections [m] there, recorded and computed offline (3, 4).
        running: the real-time factors measured while running; scale: the time scale.
        longest_step_ms: the longest integration step [ms]; step: the grid step [s].
        overruns, rejected: the last status's counts, as sent.
    """

    folder: Path
    files: list[tuple[str, int]]
    counts: dict[str, int]
    wall_s: float
    stored: int
    sail: SailParameters
    time_scale: str | None
    t: np.ndarray
    live: np.ndarray
    offline: np.ndarray
    running: list[float]
    scale: float
    longest_step_ms: float
    step: float
    overruns: str
    rejected: str

    def text(self) -> str:
        lines = [f"MCAP log: {self.folder}"]
        lines += [f"  {name}  {size / 1024:.0f} KiB" for name, size in self.files]
        lines.append(
            f"  {sum(self.counts.values())} messages over {self.wall_s:.2f} s of wall time"
        )
        lines += [f"    {name:<24}{count:>7}" for name, count in self.counts.items()]
        lines.append(
            f"  simulator parameters stored: {self.stored} (n_B = {self.sail.n_boom_modes}, "
            f"n_M = {self.sail.membrane_modes}, time_scale = {self.time_scale})"
        )
        lines.append(
            "\n  tip deflection [mm]      boom a     boom b     boom c     boom d   "
            "(offline, same model: max |difference|)"
        )
        for t, live, reference in zip(self.t, self.live, self.offline, strict=True):
            lines.append(
                f"    t = {t:5.2f} s   "
                + "".join(f"{1e3 * v:11.4f}" for v in live)
                + f"   ({np.abs(live - reference).max():.1e} m)"
            )
        running = self.running
        factor = (
            f"max {max(running):.3f}, median {np.median(running):.3f}"
            if running
            else "not measured"
        )
        lines.append(
            f"\n  real-time factor: {factor} (time scale {self.scale:g}); longest integration "
            f"step {self.longest_step_ms:.3f} ms"
        )
        lines.append(
            f"  overruns (ticks that came over one step, {1e3 * self.step / self.scale:.1f} ms, "
            f"late): {self.overruns}; rejected commands: {self.rejected}"
        )
        return "\n".join(lines)


def summarise(output: Path, t_start: float) -> DemoSummary:
    """What the bag at `output` holds, the deployment starting at `t_start` [s] of
    simulation time."""
    reader = BagReader(output)
    counts = {name: info.message_count for name, info in sorted(reader.topics().items())}
    log_times = [m.log_time_ns for m in reader.messages()]
    log = read_log(output)  # t: simulation time, from the first status that tells it
    statuses = log.diagnostics[1]
    parameters = log.parameters or {}
    sail = log.sail_parameters() or SailParameters()

    t = log.seconds(log.tips.stamp_ns) - t_start
    chosen = [int(np.argmin(np.abs(t - wanted))) for wanted in REPORT_TIMES]
    model = SailModel(sail)
    step = float(parameters.get("integration_step", "0.01"))
    _, q, _ = model.simulate_on_grid(  # stepped and sampled as the simulator does
        CycloidalProfile(START, END, DURATION),
        DURATION + SETTLE_S,
        step,
        model.initial_coordinates([TIP, 0.0, 0.0, 0.0]),
        max_step=float(parameters.get("max_model_step", DEFAULT_MAX_STEP)),
    )
    offline = model.tip_deflections(q[np.rint(t[chosen] / step).astype(int)])
    # while running; each status carries the last measurement over >= 0.5 s of running
    # (window 0 before the first)
    running = [
        float(factor)
        for state, factor, window in zip(
            statuses[key.STATE],
            statuses[key.REAL_TIME_FACTOR],
            statuses[key.REAL_TIME_FACTOR_WINDOW],
            strict=True,
        )
        if state == "running" and float(window) > 0
    ]
    return DemoSummary(
        folder=output.resolve(),
        files=[(file.name, file.stat().st_size) for file in reader.files],
        counts=counts,
        wall_s=(max(log_times) - min(log_times)) * 1e-9,
        stored=len(parameters),
        sail=sail,
        time_scale=parameters.get("time_scale"),
        t=t[chosen],
        live=log.tips.position[chosen],
        offline=np.asarray(offline),
        running=running,
        scale=float(parameters.get("time_scale", "1.0")),
        longest_step_ms=max(map(float, statuses[key.STEP_TIME_MAX])),
        step=step,
        overruns=statuses[key.OVERRUNS][-1],
        rejected=statuses[key.REJECTED][-1],
    )
