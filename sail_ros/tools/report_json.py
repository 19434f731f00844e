"""The JSON of what `sail-ros report` found (`--json`): the fields the text prints
(`tools.report_result`), by the same names, in SI units."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from sail_ros.analysis.json_values import plain
from sail_ros.analysis.log_peaks import RESOLVED_PHASE
from sail_ros.analysis.log_report import LogReport
from sail_ros.model.layout import BOOMS
from sail_ros.tools.tables import HUB_NAMES


def report_json(path: Path, found: LogReport, warnings: list[str], written: list[Path]) -> dict:
    """What the report of the log at `path` found, as one JSON object: SI units, NaN as
    null, with its `warnings` and the files `written`."""
    log = found.log
    peaks = found.peaks
    report = {
        "log": str(path),
        "incomplete": [str(file) for file in log.incomplete],
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
        "warnings": warnings,
        "written": [str(file) for file in written],
        "error": found.stopped,
    }
    return plain(report)


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
            "converged": convergence.holds,
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
    return None if realtime is None else realtime.summary()
