"""The CSV tables of `sail-ros report` (`analysis.log_report.LogReport.tables`): each
a header and its columns, in SI units, NaN where a value is missing."""

from __future__ import annotations

import functools

import numpy as np

from sail_ros import status as key
from sail_ros.analysis.log_series import LogSeries
from sail_ros.model import record
from sail_ros.model.layout import BOOMS, QUADRANTS

# first columns of real_time_factor.csv; any other status values follow by name
DIAGNOSTIC_COLUMNS = (
    key.SIM_TIME,
    key.REAL_TIME_FACTOR,
    key.STATE,
    key.STEP_TIME_MEAN,
    key.STEP_TIME_MAX,
    key.OVERRUNS,
    key.REJECTED,
    key.ENERGY,
)
PEAK_COLUMNS = [
    f"peak_{what}_{boom}_{unit}"
    for boom in BOOMS
    for what, unit in (
        ("tip", "m"),
        ("tip", "time_s"),
        ("root_moment", "N_m"),
        ("root_moment", "time_s"),
    )
]
HUB_PEAK_COLUMNS = [
    f"peak_hub_{what}_{unit}"
    for what, si in (("heave", "m"), ("tilt_x", "rad"), ("tilt_y", "rad"), ("tilt", "rad"))
    for unit in (si, "time_s")
]


def peaks(runs) -> tuple[list[str], list]:
    """peaks.csv: a row per `(source, params, Peaks)` of `runs` (the log's, its rerun's, the
    finer rerun's); a free hub's columns when the first has them."""
    rows = [_peak_row(source, params, found) for source, params, found in runs]
    header = ["source", "n_boom_modes", "n_membrane_modes", *PEAK_COLUMNS]
    if runs[0][2].hub is not None:
        header += HUB_PEAK_COLUMNS
        rows = [row + [np.nan] * (len(header) - len(row)) for row in rows]  # a clamped rerun
    return header, list(zip(*rows, strict=True))


def _peak_row(source: str, params, peaks) -> list:
    cells = [source, params.n_boom_modes, params.membrane_modes]
    for k in range(4):
        cells += [
            peaks.tip_deflection.value[k],
            peaks.tip_deflection.time_s[k],
            peaks.root_moment.value[k],
            peaks.root_moment.time_s[k],
        ]
    if peaks.hub is not None:
        for value, time_s in zip(peaks.hub.value, peaks.hub.time_s, strict=True):
            cells += [value, time_s]
    return cells


def states(log: LogSeries) -> tuple[list[str], list]:
    """states.csv: one row per stamp of the log's state messages, a column per component of each of
    the state record's table fields (`model.record`: boom lengths and rates, tips and
    their rates, root moments, a free hub's six values), NaN where a message is
    missing."""
    hub = log.hub is not None
    fields = record.table_fields(hub)
    series = {field.name: log.field(field.name) for field in fields}
    present = [found[0] for found in series.values() if found is not None]
    stamps = functools.reduce(np.union1d, present, np.array([], dtype=np.int64)).astype(np.int64)
    header = ["t_s", "stamp_ns", *record.column_names(hub)]
    columns = [log.seconds(stamps), stamps]
    for field in fields:
        block = np.full((stamps.size, len(record.component_names(field))), np.nan)
        found = series[field.name]
        if found is not None:
            block[np.searchsorted(stamps, found[0])] = found[1]
        columns += list(block.T)
    return header, columns


def parameter_changes(changes) -> tuple[list[str], list]:
    """parameter_changes.csv: a row per `LoggedChange`."""
    header = ["t_s", "log_time_ns", "time_ns", "name", "old", "new"]
    columns = [
        [c.t_s for c in changes],
        [c.log_time_ns for c in changes],
        [c.time_ns for c in changes],
        [c.name for c in changes],
        ["" if c.old is None else c.old for c in changes],
        ["" if c.new is None else c.new for c in changes],
    ]
    return header, columns


def energies(energies) -> tuple[list[str], list]:
    """energies.csv: a row per modal state sample (`log_report.Energies`)."""
    header = (
        ["t_s", "stamp_ns"]
        + [f"boom_{b}_J" for b in BOOMS]
        + [f"membrane_{name}_J" for name, _, _ in QUADRANTS]
        + ["coupling_J", "total_J"]
    )
    groups = energies.groups
    columns = [
        energies.t,
        energies.stamp_ns,
        *groups.booms.T,
        *groups.quadrants.T,
        groups.coupling,
        groups.total,
    ]
    return header, columns


def real_time_factor(realtime) -> tuple[list[str], list]:
    """real_time_factor.csv: a row per /diagnostics message (`log_report.RealTimeFactor`)."""
    names = [name for name in DIAGNOSTIC_COLUMNS if name in realtime.values]
    names += sorted(set(realtime.values) - set(names))
    columns = [realtime.t, realtime.stamp_ns, *[realtime.values[name] for name in names]]
    return ["t_s", "stamp_ns", *names], columns
