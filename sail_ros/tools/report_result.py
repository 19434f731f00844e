"""What `sail-ros report` found, as one object that prints its text and gives its JSON
from the same fields (`ReportResult`), so the two cannot disagree."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from sail_ros.analysis.log_peaks import RESOLVED_PHASE
from sail_ros.analysis.log_report import LogReport
from sail_ros.tools.common import refine_hint
from sail_ros.tools.report_json import report_json
from sail_ros.tools.tables import describe_parameters, print_hub_peak_table, print_peak_table


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
        as null (`tools.report_json`)."""
        return report_json(self.path, self.found, self.warnings(), written)

    def warnings(self) -> list[str]:
        """The warnings the text says on stderr, in its order."""
        rerun = self.found.rerun
        if rerun is None or rerun.peaks is None:
            return []
        said = [f"warning: the rerun: {warning}" for warning in rerun.warnings]
        said += [f"warning: the rerun on a finer model: {w}" for w in rerun.finer_warnings]
        convergence = rerun.convergence
        if convergence is not None and not convergence.holds:
            said.append(convergence.warning(refine_hint(rerun.params)))
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
            rtf = realtime.summary()
            print(
                f"  real-time factor: mean {rtf['mean']:.3g}, min {rtf['min']:.3g}, "
                f"max {rtf['max']:.3g} over {rtf['count']} diagnostics messages"
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
