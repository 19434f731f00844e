"""What `sail-ros deploy` found, as one object that prints its text and gives its JSON
from the same fields (`DeploymentReport`), so the two cannot disagree."""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_ros.analysis.json_values import json_number
from sail_ros.integrate.control import ATOL_UNITS, DEFAULT_ATOL
from sail_ros.policy import Policy
from sail_ros.tools.common import refine_hint
from sail_ros.tools.tables import (
    describe_parameters,
    hub_peaks_json,
    print_hub_peak_table,
    print_peak_table,
)


@dataclasses.dataclass
class DeploymentReport:
    """A deployment run and what was asked of it.

    Attributes:
        result: the run (`analysis.deployment.DeploymentRun`).
        config: its sail and limits (`tools.common.Configuration`).
        description: the scenario in words.
        model: the `SailModel` it ran on.
        table_times: the times [s] of the text's table.
        convergence: the reruns with more modes (`analysis.convergence`), or None.
        holds: a free hub's hold reactions (`analysis.deployment.HoldPeaks`), or None.
        controller: the closed loop's summary (`analysis.closed_loop.summary`), or None.
    """

    result: object
    config: object
    description: str
    model: object
    table_times: np.ndarray
    convergence: object = None
    holds: object = None
    controller: dict | None = None

    def print_text(self) -> None:
        """The table of tip deflections, the peaks and their convergence, a free hub's
        peaks and the closed loop's summary, printed line by line (a reader that goes
        away ends the tool at once)."""
        _print_table(self.result, self.table_times, self.description, self.config)
        _print_peaks(self.result.peaks, self.model, self.convergence)
        if self.holds is not None:
            _print_hub_peaks(self.result.peaks.hub, self.holds)
        if self.controller is not None:
            from sail_ros.analysis.closed_loop import summary_lines

            print()
            print("\n".join(summary_lines(self.controller)))

    def to_json(self) -> dict:
        """The same as one JSON object (`--json`)."""
        report = _json_report(
            self.result, self.config, self.description, self.convergence, self.holds
        )
        if self.controller is not None:
            report["controller"] = self.controller
        return report

    def convergence_warning(self) -> str:
        """One line when the peaks did not converge ("" if they did, or none was asked)."""
        if self.convergence is None:
            return ""
        return self.convergence.warning(refine_hint(self.config.sail))


def _policy_line(policy: Policy, low: float, high: float, free_hub: bool = False) -> str:
    line = (
        f"  limits (simulator's)    L in [{low:g}, {high:.4g}] m, |rate| <= {policy.max_rate:g} "
        f"m/s, |accel.| <= {policy.max_acceleration:g} m/s^2, |tip| < "
        f"{policy.tip_error_fraction:g} L (warning {policy.tip_warn_fraction:g} L)"
    )
    if free_hub:
        line += (
            f"\n{'':26}hub tilt < {policy.tilt_error_rad:g} rad (warning "
            f"{policy.tilt_warn_rad:g} rad)"
        )
    return line


def _print_table(run_result, table_times, description, config) -> None:
    rows = [run_result.index_of(t) for t in table_times if t <= run_result.t[-1] + 1e-9]
    lengths = run_result.lengths[rows]
    equal = np.allclose(lengths, lengths[:, :1])
    print(f"Deployment: {description}")
    print(describe_parameters(config.sail))
    print(_policy_line(config.policy, *config.policy.length_range(config.sail),
                       config.sail.free_hub))  # fmt: skip
    print()
    # one length column when the booms are alike, else one per boom
    booms = (0,) if equal else range(4)
    labels = ["L [m]"] if equal else [f"L_{b} [m]" for b in "abcd"]
    print(f"  {'t [s]':>7}" + "".join(f"{label:>9}" for label in labels)
          + f"   tip deflection [mm]: {'a':>9}{'b':>10}{'c':>10}{'d':>10}")  # fmt: skip
    for i in rows:
        tips = run_result.tips[i]
        print(
            f"  {run_result.t[i]:7.2f}"
            + "".join(f"{run_result.lengths[i, k]:9.3f}" for k in booms)
            + f"   {'':21}"
            + "".join(f"{1e3 * v:10.3f}" for v in tips)
        )
    if run_result.hub is not None:
        _print_hub_table(run_result, rows)
    print()
    print(
        f"  {float(run_result.t[-1]):g} s simulated in {run_result.wall_seconds:.3f} s wall "
        f"({run_result.real_time_factor:.0f}x real time)"
    )
    print(_accuracy_line(run_result.accuracy))


HUB_COLUMNS = (  # (header, scale from SI) of a free hub's six values (`StateSample.hub`)
    ("z_h [mm]", 1e3),
    ("theta_x [mrad]", 1e3),
    ("theta_y [mrad]", 1e3),
    ("zd_h [mm/s]", 1e3),
    ("thd_x [mrad/s]", 1e3),
    ("thd_y [mrad/s]", 1e3),
)


def _print_hub_table(run_result, rows) -> None:
    """A free hub's heave, tilts, tilt magnitude and rates at the table's rows."""
    print()
    print(
        "  free hub: heave z_h, tilts theta_x (about boom a) and theta_y (about boom b), "
        "tilt |theta|, their rates"
    )
    headers = [h for h, _ in HUB_COLUMNS[:3]] + ["|theta| [mrad]"]
    headers += [h for h, _ in HUB_COLUMNS[3:]]
    print(f"  {'t [s]':>7}" + "".join(f"{h:>15}" for h in headers))
    for i in rows:
        hub = run_result.hub[i]
        values = [scale * v for (_, scale), v in zip(HUB_COLUMNS, hub, strict=True)]
        values.insert(3, 1e3 * float(np.hypot(hub[1], hub[2])))
        print(f"  {run_result.t[i]:7.2f}" + "".join(f"{v:15.3f}" for v in values))


def _accuracy_line(accuracy) -> str:
    """The tolerance, the steps and the achieved error estimate, in one line."""
    steps = f"{accuracy.steps} steps ({accuracy.rejected} refused)"
    if accuracy.rtol is None:
        return f"  {steps} of fixed length: no error estimate"
    error = accuracy.relative_error
    changed = {
        kind: floor for kind, floor in (accuracy.atol or {}).items() if floor != DEFAULT_ATOL[kind]
    }
    tolerance = f"rtol {accuracy.rtol:g}"
    if changed:  # the floors asked: the defaults go without saying
        floors = ", ".join(
            f"{kind} {floor:g} {ATOL_UNITS[kind]}" for kind, floor in changed.items()
        )
        tolerance += f" (atol {floors})"
    return (
        f"  {steps} at {tolerance}; error estimate: tips "
        f"{100 * error['tips']:.2g} %, root moments {100 * error['root_moments']:.2g} % of peak"
    )


def _print_peaks(peaks, model, convergence=None) -> None:
    """Each boom's peak |tip| and |root moment| with its time, and their convergence."""
    print()
    print(
        f"  peaks over the whole run, per boom (taken inside every integration step; "
        f"n_B = {model.n_boom_modes}, n_M = {model.n_membrane_modes}):"
    )
    print_peak_table(peaks, convergence)
    if convergence is not None:
        for level in convergence.levels:
            print(
                f"  rerun at (n_B, n_M) = ({level.n_boom_modes}, {level.n_membrane_modes}): "
                f"the peaks before it move by {100 * level.change_before.largest():.2g} % "
                "of the largest of their kind"
            )


def _print_hub_peaks(hub, holds) -> None:
    """A free hub's true peaks (`Peaks.hub`) and its holds' peak reactions (`HoldPeaks`)."""
    print()
    print("  free hub peaks over the whole run (taken inside every integration step):")
    print_hub_peak_table(hub)

    def when(value: float, time_s: float) -> str:
        return f"at t = {time_s:.3f} s" if value else "throughout"

    print(
        f"  hold reactions (of the boom motion, every {1e3 * holds.spacing_s:g} ms): in-plane "
        f"|F| {holds.force:.4g} N {when(holds.force, holds.force_time_s)}, spin |tau_z| "
        f"{holds.torque:.4g} N m {when(holds.torque, holds.torque_time_s)}"
    )


def _json_report(result, config, description, convergence, holds=None) -> dict:
    def per_boom(values):
        return dict(zip("abcd", (json_number(v) for v in values), strict=True))

    params, peaks = config.sail, result.peaks
    limits = dataclasses.asdict(config.policy)  # the lengths as in force (max_length 0: full)
    limits["min_length"], limits["max_length"] = config.policy.length_range(params)
    report = {
        "description": description,
        "duration_s": float(result.t[-1] - result.t[0]),
        "peak_tip_deflection_m": per_boom(peaks.tip_deflection.value),
        "peak_tip_deflection_time_s": per_boom(peaks.tip_deflection.time_s),
        "peak_root_moment_Nm": per_boom(peaks.root_moment.value),
        "peak_root_moment_time_s": per_boom(peaks.root_moment.time_s),
        "n_boom_modes": params.n_boom_modes,
        "n_membrane_modes": params.membrane_modes,
        "parameters": params.to_dict(),
        "limits": limits,
        "wall_time_s": result.wall_seconds,
        "rtol": result.accuracy.rtol,
        "atol": result.accuracy.atol if result.accuracy.rtol is not None else None,
        "steps": result.accuracy.steps,
        "relative_error_estimate": {  # null where nothing moved (0 of a peak of 0)
            name: json_number(value) for name, value in result.accuracy.relative_error.items()
        },
        "error_estimate": {
            name: json_number(value) for name, value in (result.accuracy.error or {}).items()
        },
        "accuracy_warning": result.accuracy.warning,
        "warning": result.warning,
        "alarm": result.alarm,
    }
    if peaks.hub is not None:
        report["hub"] = hub_peaks_json(peaks.hub, holds)
    if convergence is not None:
        change = convergence.change
        report["convergence"] = {
            "bar": convergence.bar,
            "levels": [
                {
                    "n_boom_modes": level.n_boom_modes,
                    "n_membrane_modes": level.n_membrane_modes,
                    "peak_tip_deflection_m": per_boom(level.peaks.tip_deflection.value),
                    "peak_root_moment_Nm": per_boom(level.peaks.root_moment.value),
                    "change_before": level.change_before.largest(),
                }
                for level in convergence.levels
            ],
            "tip_deflection_change": per_boom(change.tips),
            "root_moment_change": per_boom(change.moments),
            "tip_deflection_change_own": per_boom(change.tips_own),
            "root_moment_change_own": per_boom(change.moments_own),
            "converged": convergence.holds,
            "stopped": convergence.stopped,
        }
    return report
