"""What `sail-ros report` finds in a simulator log, as one object (`LogReport`).

From a log read back (`log_series.read_log`): the range of its time histories, a free
hub's and its commands' peaks, the simulator's parameter changes, each boom's peaks
between the samples (`log_peaks`) and in a rerun (`log_true_peaks`), the mechanical
energies per coordinate group (`energy`), the achieved real-time factor, and the CSV
tables of them all (`LogReport.tables`). The text and the JSON are rendered from it
(`tools.report_result`), the figures drawn from it (`tools.report`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros import status as key
from sail_ros.analysis import log_tables as tables
from sail_ros.analysis.deployment import hold_reactions
from sail_ros.analysis.energy import GroupEnergies, group_energies
from sail_ros.analysis.load_changes import log_changes, run_description
from sail_ros.analysis.log_peaks import LogPeaks, log_peaks
from sail_ros.analysis.log_series import LogSeries
from sail_ros.analysis.log_true_peaks import RerunPeaks, rerun_peaks
from sail_ros.analysis.parameter_history import LoggedChange, parameter_changes
from sail_ros.analysis.scenario import scenario_from_dict
from sail_ros.model import SailModel, SailParameters


@dataclasses.dataclass(frozen=True)
class Energies:
    """The mechanical energies at the modal state's stamps: times [s], stamps [ns], the
    groups' (`GroupEnergies`), and the sail they were computed for (`recorded`: the
    log's parameters, else those given)."""

    t: np.ndarray
    stamp_ns: np.ndarray
    groups: GroupEnergies
    params: SailParameters
    recorded: bool


@dataclasses.dataclass(frozen=True)
class RealTimeFactor:
    """/diagnostics: times [s], stamps [ns], the status values by key (text), the achieved
    factor (NaN where not measured yet) and the time scale asked for (or None)."""

    t: np.ndarray
    stamp_ns: np.ndarray
    values: dict[str, list[str]]
    factor: np.ndarray
    time_scale: np.ndarray | None

    @property
    def measured(self) -> np.ndarray:
        return self.factor[np.isfinite(self.factor)]

    def summary(self) -> dict:
        """The measured factor's `mean`, `min`, `max` and `count` (`count` 0 alone when
        none was measured)."""
        measured = self.measured
        if not measured.size:
            return {"count": 0}
        return {"mean": measured.mean(), "min": measured.min(), "max": measured.max(),
                "count": measured.size}  # fmt: skip


@dataclasses.dataclass(frozen=True)
class LogReport:
    """A log and what the report finds in it.

    Attributes:
        log: the log (`LogSeries`).
        title: what it holds, for the figures' titles (`run_description`).
        loads: its load changes, `(t [s], what)`.
        recorded: its sail parameters, or None (none recorded, or they do not parse).
        holds: a free hub's hold reactions [N, N, N m] at the hub's stamps (a deploy
            log's scenario), or None.
        changes, changes_source: the simulator's parameter changes and where they were
            found ("": nowhere).
        peak_params: the sail of the log's peaks (recorded, else given).
        peaks: the peaks between the samples (`LogPeaks`).
        rerun: the log run again (`RerunPeaks`), or None when the coordinates are
            another sail's.
        energies: the energies, or None (`missing` says why).
        realtime: the real-time factor, or None (`missing` says why).
        missing: per section ("energies", "real_time_factor"), why it is absent.
    """

    log: LogSeries
    title: str
    loads: list[tuple[float, str]]
    recorded: SailParameters | None
    holds: np.ndarray | None
    changes: list[LoggedChange]
    changes_source: str
    peak_params: SailParameters
    peaks: LogPeaks
    rerun: RerunPeaks | None
    energies: Energies | None
    realtime: RealTimeFactor | None
    missing: dict[str, str]

    @property
    def time_label(self) -> str:
        if self.log.simulation_time:
            return "simulation time t [s]"
        return "time since the first sample [s]"

    @property
    def stopped(self) -> str:
        """The alarm of a rerun that left the linear range ("" if none did)."""
        return self.rerun.stopped if self.rerun is not None else ""

    def ranges(self) -> dict[str, dict]:
        """The range of each time history the log holds, by name (SI units)."""
        log, found = self.log, {}
        if log.tips is not None:
            t = log.seconds(log.tips.stamp_ns)
            peak = np.abs(log.tips.position).max()
            found["tip_deflections"] = {"t_first_s": t[0], "t_last_s": t[-1], "peak_m": peak}
        if log.moments is not None and log.moments.effort.size:
            found["root_moments"] = {
                "peak_N_m": np.abs(log.moments.effort).max(),
                "n_boom_modes": self.recorded.n_boom_modes if self.recorded else None,
            }
        if log.boom is not None:
            position = log.boom.position
            found["boom_lengths"] = {"min_m": position.min(), "max_m": position.max()}
        if log.hub is not None:
            hub = log.hub[1]
            found["hub"] = {
                "peak_heave_m": np.abs(hub[:, 0]).max(),
                "peak_tilt_rad": np.hypot(hub[:, 1], hub[:, 2]).max(),
            }
            if log.hub_commands is not None:
                wrench = log.hub_commands[2]
                peak = np.abs(wrench).max(axis=0)
                found["hub_commands"] = {
                    "count": len(wrench),
                    "peak_F_z_N": peak[0],
                    "peak_tau_x_N_m": peak[1],
                    "peak_tau_y_N_m": peak[2],
                }
        return found

    def unresolved_share(self) -> np.ndarray | None:
        """Per boom, the share of its peak root moment that boom modes the sampling cannot
        follow carry (`LogPeaks.unresolved_moment`), or None when none are known."""
        found = self.peaks
        if found.unresolved_moment is None or not np.isfinite(found.unresolved_frequency_hz):
            return None
        return found.unresolved_moment / np.maximum(found.peaks.root_moment.value, 1e-300)

    def tables(self) -> dict[str, tuple[list[str], list]]:
        """The CSV files: name -> (header, columns)."""
        runs = [("log", self.peak_params, self.peaks.peaks)]
        rerun = self.rerun
        if rerun is not None and rerun.peaks is not None:
            runs.append(("rerun", rerun.params, rerun.peaks))
            if rerun.convergence is not None:
                finest = rerun.convergence.finest.peaks
                runs.append(("rerun, more modes", rerun.finer_params, finest))
        found = {
            "states.csv": tables.states(self.log),
            "parameter_changes.csv": tables.parameter_changes(self.changes),
            "peaks.csv": tables.peaks(runs),
        }
        if self.energies is not None:
            found["energies.csv"] = tables.energies(self.energies)
        if self.realtime is not None:
            found["real_time_factor.csv"] = tables.real_time_factor(self.realtime)
        return found


def log_report(
    log: LogSeries, given: SailParameters, limits: dict, finer: bool, namespace=None
) -> LogReport:
    """What the report holds of `log` (`read_log`).

    Args:
        log: the log.
        given: the sail for a log without recorded parameters (`--config`/`--set`).
        limits: limits that replace those the log recorded, for its rerun (`--set`).
        finer: rerun on a finer model too.
        namespace: the simulator's namespace (None: the log's sail's).

    Raises:
        ValueError: a rerun the limits refuse, recorded parameters that do not parse, or
            modal coordinates that are not the sail's, naming it.
    """
    recorded = _recorded_parameters(log)
    holds = None
    if log.hub is not None and log.scenario is not None and recorded is not None:
        profile = scenario_from_dict(log.scenario).profile
        holds = hold_reactions(SailModel(recorded), profile, log.seconds(log.hub[0]))
    changes, source = parameter_changes(log, namespace)
    params = recorded or given
    model = SailModel(params)
    if log.modal is not None and log.modal.names != model.coordinate_names:
        model = None  # another sail than --config/--set say: the energies say so
    peaks = log_peaks(log, model)
    rerun = rerun_peaks(log, model, limits, finer) if model is not None else None
    missing = {}
    energies = _energies(log, given, missing)
    realtime = _real_time_factor(log, missing)
    loads = [(change.t_s, change.text) for change in log_changes(log)]
    return LogReport(
        log, run_description(log), loads, recorded, holds, changes, source, params, peaks,
        rerun, energies, realtime, missing,
    )  # fmt: skip


def _recorded_parameters(log):
    """The log's sail parameters, or None when it has none or they do not parse."""
    try:
        return log.sail_parameters()
    except ValueError:
        return None


def _energies(log: LogSeries, given: SailParameters, missing: dict) -> Energies | None:
    if log.modal is None:
        missing["energies"] = "no /sail/modal_state: energies not available"
        return None
    if log.boom is None:
        missing["energies"] = (
            "no /sail/boom_state: the boom lengths needed for the energies are missing"
        )
        return None
    params = log.sail_parameters()
    recorded = params is not None
    params = params if recorded else given
    model = SailModel(params)
    if log.modal.names != model.coordinate_names:
        raise ValueError(
            f"/sail/modal_state has {len(log.modal.names)} coordinates "
            f"({log.modal.names[0]} ...), the sail's model has {model.n} "
            f"(n_B = {model.n_boom_modes}, n_M = {model.n_membrane_modes}); "
            "give the recorded mode counts with --set n_boom_modes=.. --set n_membrane_modes=.."
        )
    stamps = log.modal.stamp_ns
    lengths = np.column_stack(
        [np.interp(stamps, log.boom.stamp_ns, log.boom.position[:, k]) for k in range(4)]
    )
    groups = group_energies(model, lengths, log.modal.position, log.modal.velocity)
    return Energies(log.seconds(stamps), stamps, groups, params, recorded)


def _real_time_factor(log: LogSeries, missing: dict) -> RealTimeFactor | None:
    if log.diagnostics is None:
        missing["real_time_factor"] = (
            "no /diagnostics in the log (an offline run from sail-ros deploy has none): "
            "real-time factor not available"
        )
        return None
    stamps, values = log.diagnostics
    if key.REAL_TIME_FACTOR not in values:
        missing["real_time_factor"] = (
            "/diagnostics has no real_time_factor value: real-time factor not available"
        )
        return None
    factor = _floats(values[key.REAL_TIME_FACTOR])
    if key.REAL_TIME_FACTOR_WINDOW in values:  # 0: no measurement yet (the value reads 0)
        factor[_floats(values[key.REAL_TIME_FACTOR_WINDOW]) <= 0] = np.nan
    scale = _floats(values[key.TIME_SCALE]) if key.TIME_SCALE in values else None
    return RealTimeFactor(log.seconds(stamps), stamps, values, factor, scale)


def _floats(texts) -> np.ndarray:
    values = []
    for text in texts:
        try:
            values.append(float(text))
        except ValueError:
            values.append(np.nan)
    return np.array(values)
