"""What `sail-ros report` found, as one object that prints its text and gives its JSON
from the same fields (`ReportResult`), so the two cannot disagree."""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

from sail_ros.analysis.log_peaks import RESOLVED_PHASE
from sail_ros.analysis.log_report import LogReport
from sail_ros.model.layout import BOOMS
from sail_ros.tools.common import refine_hint
from sail_ros.tools.tables import describe_parameters, print_hub_peak_table, print_peak_table

HUB_NAMES = ("heave_m", "tilt_x_rad", "tilt_y_rad", "tilt_rad")  # of `Peaks.hub`, in JSON


@dataclasses.dataclass(frozen=True)
class ReportResult:
    """A log's report.

    Attributes:
        path: the log as given.
        found: what the report found (`analysis.log_report.LogReport`).
    """

    path: Path
    found: LogReport

    def print_text(self) -> None:
        """The report, line by line, its warnings on stderr where they arise (the files
        it wrote are listed after them, `tools.common.print_written`)."""
        found = self.found
        self._print_log()
        _print_ranges(found.ranges())
        self._print_changes()
        self._print_peaks()
        self._print_rerun()
        self._print_energies()
        self._print_real_time_factor()

    def to_json(self, written: list[Path]) -> dict:
        """The same as one JSON object (`--json`), with the files `written`: SI units, NaN
        as null."""
        found, log = self.found, self.found.log
        peaks = found.peaks
        report = {
            "log": str(self.path),
            "incomplete": [str(path) for path in log.incomplete],
            "topics": dict(sorted(log.topic_counts.items())),
            "time_axis": found.time_label,
            **found.ranges(),
            "parameter_changes": {
                "source": found.changes_source,
                "changes": [dataclasses.asdict(change) for change in found.changes],
            },
            "peaks": {
                "spacing_s": peaks.spacing_s,
                "interpolated": dict(
                    zip(("tip_deflection", "root_moment"), peaks.interpolated, strict=True)
                ),  # fmt: skip
                **_peaks_json(peaks.peaks),
                "unresolved": _unresolved_json(found),
            },
            "rerun": _rerun_json(found.rerun),
            "energies": _energies_json(found.energies),
            "real_time_factor": _realtime_json(found.realtime),
            "not_available": found.missing,
            "warnings": self.warnings(),
            "written": [str(path) for path in written],
            "error": found.stopped,
        }
        return _plain(report)

    def warnings(self) -> list[str]:
        """The warnings the text says on stderr, in its order."""
        rerun = self.found.rerun
        if rerun is None or rerun.peaks is None:
            return []
        said = [f"warning: the rerun: {warning}" for warning in rerun.warnings]
        said += [f"warning: the rerun on a finer model: {w}" for w in rerun.finer_warnings]
        convergence = rerun.convergence
        if convergence is not None and convergence.change.largest() > convergence.bar:
            finest = convergence.finest
            said.append(
                f"warning: peaks not converged: against (n_B, n_M) = ({finest.n_boom_modes}, "
                f"{finest.n_membrane_modes}) they are off by up to "
                f"{100 * convergence.change.largest():.3g} % of the largest of their kind; "
                f"{refine_hint(rerun.params)}"
            )
        return said

    def _print_log(self) -> None:
        log = self.found.log
        print(f"Log {self.path}")
        if log.incomplete:
            print(
                f"  incomplete (cut short): {', '.join(str(p) for p in log.incomplete)}; "
                f"read up to the last complete record (`sail-ros bag recover {self.path}` "
                "writes a complete copy that every reader opens)"
            )
        for topic, count in sorted(log.topic_counts.items()):
            print(f"  {topic}: {count} messages")

    def _print_changes(self) -> None:
        changes, source = self.found.changes, self.found.changes_source
        if not changes:
            print("  parameter changes: none" + (f" (in {source})" if source else " recorded"))
            return
        print(f"  parameter changes ({len(changes)}, from {source}; t: {self.found.time_label}):")
        for change in changes:
            print(
                f"    t = {change.t_s:.3f} s  {change.name}: {_shown(change.old)} -> "
                f"{_shown(change.new)}"
            )

    def _print_peaks(self) -> None:
        found = self.found.peaks
        how = "interpolated with the logged rates (cubic Hermite)"
        if not all(found.interpolated):
            tips, moments = ("interpolated" if yes else "as sampled" for yes in found.interpolated)
            how = f"tips {tips}, root moments {moments}"
        every = 1e3 * found.spacing_s
        print(f"  peaks per boom from the logged samples (every {every:.4g} ms), {how}:")
        print_peak_table(found.peaks, indent="    ")
        if found.peaks.hub is not None:
            print("    free hub, interpolated with the logged rates of /sail/hub_state:")
            print_hub_peak_table(found.peaks.hub, indent="    ")
        share = self.found.unresolved_share()
        if share is not None:
            print(
                f"  boom modes from {found.unresolved_frequency_hz:.3g} Hz up are sampled too "
                f"coarsely to follow (more than {RESOLVED_PHASE:g} rad between samples); they "
                "carry up to " + ", ".join(f"{100 * v:.2g} %" for v in share) + " of the peak "
                "root moments a..d, which may be off by that much between samples"
            )

    def _print_rerun(self) -> None:
        rerun = self.found.rerun
        if rerun is not None and rerun.not_possible:
            print(f"  true peaks need a rerun of the log, which is not possible: "
                  f"{rerun.not_possible}")  # fmt: skip
        if rerun is None or rerun.peaks is None:
            return
        warnings = self.warnings()
        for line in warnings[: len(rerun.warnings)]:
            print(line, file=sys.stderr)
        runs = f" ({rerun.runs} runs: resets)" if rerun.runs > 1 else ""
        print(
            f"  a rerun of {rerun.what}{runs} reproduces the logged tips to "
            f"{rerun.agreement:.2g} of their peak; its true peaks (taken inside every "
            "integration step):"
        )
        print_peak_table(rerun.peaks, rerun.convergence, indent="    ")
        if rerun.peaks.hub is not None and not (rerun.stopped and rerun.convergence is None):
            print("    free hub (true peaks of the rerun):")
            print_hub_peak_table(rerun.peaks.hub, indent="    ")
        for line in warnings[len(rerun.warnings) :]:
            print(line, file=sys.stderr)

    def _print_energies(self) -> None:
        energies = self.found.energies
        if energies is None:
            print(f"  {self.found.missing['energies']}")
            return
        if energies.recorded:
            print("  energies use the sail parameters recorded in the log:")
        else:
            print(
                "  no recorded sail parameters (sail_sim_parameters): energies use "
                "--config/--set (built-in defaults if neither is given)"
            )
        print(describe_parameters(energies.params))
        t, total = energies.t, energies.groups.total
        print(
            f"  mechanical energy: {total[0]:.4g} J at t = {t[0]:.3f} s, "
            f"{total[-1]:.4g} J at t = {t[-1]:.3f} s"
        )

    def _print_real_time_factor(self) -> None:
        realtime = self.found.realtime
        if realtime is None:
            print(f"  {self.found.missing['real_time_factor']}")
        elif realtime.measured.size:
            measured = realtime.measured
            print(
                f"  real-time factor: mean {measured.mean():.3g}, min {measured.min():.3g}, "
                f"max {measured.max():.3g} over {measured.size} diagnostics messages"
            )


def _print_ranges(ranges: dict) -> None:
    """One line per time history: its time span and peak, or its range."""
    if "tip_deflections" in ranges:
        tips = ranges["tip_deflections"]
        print(
            f"  tip deflections: {tips['t_first_s']:.3f} .. {tips['t_last_s']:.3f} s, peak "
            f"|tip| {1e3 * tips['peak_m']:.3f} mm"
        )
    if "root_moments" in ranges:
        moments = ranges["root_moments"]
        modes = moments["n_boom_modes"]
        print(
            f"  root moments: peak |M| {moments['peak_N_m']:.4g} N m"
            + (f" (n_B = {modes})" if modes else "")
        )
    if "boom_lengths" in ranges:
        lengths = ranges["boom_lengths"]
        print(f"  boom lengths: {lengths['min_m']:.3f} .. {lengths['max_m']:.3f} m")
    if "hub" in ranges:
        heave, tilt = ranges["hub"]["peak_heave_m"], ranges["hub"]["peak_tilt_rad"]
        print(
            f"  free hub: |z_h| up to {1e3 * heave:.4g} mm, tilt |theta| up to "
            f"{1e3 * tilt:.4g} mrad ({np.degrees(tilt):.3g} deg) in the samples"
        )
    if "hub_commands" in ranges:
        commands = ranges["hub_commands"]
        print(
            f"  hub wrench commands: {commands['count']}, peak |F_z| "
            f"{commands['peak_F_z_N']:.4g} N, |tau_x| {commands['peak_tau_x_N_m']:.4g} N m, "
            f"|tau_y| {commands['peak_tau_y_N_m']:.4g} N m"
        )


def _shown(value: str | None) -> str:
    return "(none)" if value is None else value


def _per_boom(values) -> dict:
    return dict(zip(BOOMS, values, strict=True))


def _peaks_json(peaks) -> dict:
    """Each boom's peaks and their times, and a free hub's (`Peaks`)."""
    found = {
        "peak_tip_deflection_m": _per_boom(peaks.tip_deflection.value),
        "peak_tip_deflection_time_s": _per_boom(peaks.tip_deflection.time_s),
        "peak_root_moment_Nm": _per_boom(peaks.root_moment.value),
        "peak_root_moment_time_s": _per_boom(peaks.root_moment.time_s),
    }
    if peaks.hub is not None:
        found["hub"] = {}
        for name, value, time_s in zip(HUB_NAMES, peaks.hub.value, peaks.hub.time_s,
                                       strict=True):  # fmt: skip
            found["hub"][f"peak_{name}"] = value
            found["hub"][f"peak_{name.rsplit('_', 1)[0]}_time_s"] = time_s
    return found


def _unresolved_json(found: LogReport) -> dict | None:
    share = found.unresolved_share()
    if share is None:
        return None
    return {
        "frequency_hz": found.peaks.unresolved_frequency_hz,
        "phase_rad": RESOLVED_PHASE,
        "root_moment_share": _per_boom(share),
    }


def _rerun_json(rerun) -> dict | None:
    if rerun is None:
        return None
    report = {
        "of": rerun.what,
        "not_possible": rerun.not_possible,
        "stopped": rerun.stopped,
        "n_boom_modes": rerun.params.n_boom_modes,
        "n_membrane_modes": rerun.params.membrane_modes,
    }
    if rerun.peaks is None:
        return report
    report |= {"runs": rerun.runs, "agreement": rerun.agreement, **_peaks_json(rerun.peaks)}
    convergence = rerun.convergence
    if convergence is not None:
        finest, change = convergence.finest, convergence.change
        report["convergence"] = {
            "n_boom_modes": finest.n_boom_modes,
            "n_membrane_modes": finest.n_membrane_modes,
            **_peaks_json(finest.peaks),
            "bar": convergence.bar,
            "tip_deflection_change": _per_boom(change.tips),
            "tip_deflection_change_own": _per_boom(change.tips_own),
            "root_moment_change": _per_boom(change.moments),
            "root_moment_change_own": _per_boom(change.moments_own),
            "converged": change.largest() <= convergence.bar,
        }
    return report


def _energies_json(energies) -> dict | None:
    if energies is None:
        return None
    t, total = energies.t, energies.groups.total
    return {
        "parameters_recorded": energies.recorded,
        "parameters": energies.params.to_dict(),
        "first_J": total[0],
        "first_t_s": t[0],
        "last_J": total[-1],
        "last_t_s": t[-1],
    }


def _realtime_json(realtime) -> dict | None:
    if realtime is None:
        return None
    measured = realtime.measured
    if not measured.size:
        return {"count": 0}
    return {
        "mean": measured.mean(),
        "min": measured.min(),
        "max": measured.max(),
        "count": measured.size,
    }


def _plain(value):
    """`value` as JSON takes it: numpy values as Python's, paths as text, NaN and
    infinities as None."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value
