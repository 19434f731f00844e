"""`sail-ros plant --controller`: the hub's controller against the full plant.

The design comes from a scenario's `controller:` section (or the defaults), each field
changed by `--set NAME=VALUE` like a sail parameter; `control.check` makes the discrete
loop and its poles at each time of the scenario's deployment (or at the `--lengths`
and `--rates` given). One row per time: the lengths, the largest real part of the
closed-loop poles and where it is, the open plant's, and how many poles lie on the
imaginary axis (modes the loop does not reach). Exit code 1 when a pole has a positive
real part.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from tqdm import tqdm

from sail_ros.analysis.deployment import output_times
from sail_ros.analysis.scenario import load_scenario
from sail_ros.control.check import NEUTRAL, check_deployment
from sail_ros.control.design import require_free_hub
from sail_ros.control.schedule import design_schedule
from sail_ros.control.settings import DesignSettings
from sail_ros.model import SailModel, yaml_values
from sail_ros.model.profiles import StaticProfile
from sail_ros.outputs import staged
from sail_ros.tools.common import configuration, print_written
from sail_ros.tools.tables import describe_parameters


def design_of(args, base: DesignSettings | None) -> tuple[DesignSettings, list[str]]:
    """The design of `base` (default `DesignSettings()`) with the controller's fields of
    `--set`, and the `--set` items left for the sail and the limits."""
    names = set(DesignSettings.field_names())
    changes, rest = {}, []
    for item in args.set:
        name, separator, text = item.partition("=")
        if separator and name.strip() in names:
            try:
                changes[name.strip()] = yaml_values.load(text)
            except Exception:  # noqa: BLE001 (a YAML error of any kind: the value is bad)
                raise ValueError(f"--set {name.strip()}: {text!r} is not a value") from None
        else:
            rest.append(item)
    base = base or DesignSettings()
    try:
        return DesignSettings(**{**base.to_dict(), **changes}), rest
    except ValueError as error:
        raise ValueError(f"controller: {error}") from None


def check_loop(args) -> int:
    scenario = load_scenario(args.scenario) if args.scenario else None
    design, rest = design_of(args, scenario.controller if scenario else None)
    sail_args = argparse.Namespace(**{**vars(args), "set": rest})
    where = f"{args.scenario}: sail section" if scenario else ""
    config = configuration(sail_args, scenario.sail if scenario else None, where)
    params = config.sail
    require_free_hub(params)
    if not args.every > 0:
        raise ValueError(f"--every must be > 0 s, got {args.every}")
    if scenario is not None:
        if args.lengths or args.rates != [0.0]:
            raise ValueError("--lengths and --rates: with --scenario its deployment sets them")
        profile, times = scenario.profile, output_times(scenario.duration, 1.0 / args.every)
        what = f"every {args.every:g} s of {scenario.description or args.scenario}"
    else:
        lengths = config.per_boom(args.lengths or [params.full_boom_length], "--lengths")
        if len(args.rates) not in (1, 4):
            raise ValueError(f"--rates takes 1 or 4 values, got {len(args.rates)}")
        rates = config.check(
            config.policy.check_rates, args.rates * (4 // len(args.rates)), "--rates"
        )
        profile, times = _frozen(lengths * (4 // len(lengths)), rates), np.zeros(1)
        what = "the lengths and rates given"
    model = SailModel(params)
    schedule = design_schedule(params, design)
    print(
        f"Closed loop of the hub's controller (docs/control.md): design model "
        f"{design.design_model_text()}, {design.state_rate_hz:g} Hz (Nyquist "
        f"{np.pi * design.state_rate_hz:.4g} rad/s), loop delay {design.loop_delay_s:g} s; the "
        f"plant with every mode of (n_B, n_M) = ({params.n_boom_modes}, "
        f"{params.n_membrane_modes}), frozen at {what}"
    )
    print(describe_parameters(params))
    print()
    with tqdm(total=len(times), unit="point", disable=None, leave=False, file=sys.stderr) as bar:
        rows = check_deployment(model, schedule, profile, times, lambda t: bar.update())
    print(
        f"  {'t [s]':>7}  {'lengths a b c d [m]':>27}  {'max Re s [1/s]':>15}  "
        f"{'at Im s [rad/s]':>15}  {'open loop':>10}  {'on axis':>7}"
    )
    for row in rows:
        lengths = " ".join(f"{v:6.3f}" for v in row.lengths)
        print(
            f"  {row.t:7.2f}  {lengths:>27}  {row.largest_real:+15.3e}  "
            f"{abs(row.largest_pole.imag):15.4g}  {row.open_loop_real:+10.2e}  {row.neutral:7d}"
        )
    print()
    print(_verdict(rows, design))
    written = []
    if args.gains:
        with staged(args.gains, "--gains") as building, building.open("wb") as stream:
            schedule.save(stream)
        written.append(args.gains)
    print_written(written)
    return 0 if all(row.stable for row in rows) else 1


def _frozen(lengths, rates):
    """A profile standing at `lengths` [m] whose rates [m/s] read as `rates` (the plant
    is frozen: only its matrices are asked for)."""
    standing = StaticProfile(lengths)
    return lambda t: (standing(t)[0], np.asarray(rates, dtype=float), np.zeros(4))


def _verdict(rows, design: DesignSettings) -> str:
    worst = max(rows, key=lambda row: row.largest_real)
    nyquist = max(row.above_nyquist for row in rows)
    note = ""
    if nyquist:
        note = (
            f"; {nyquist} of the plant's elastic modes lie above the Nyquist frequency "
            f"{np.pi * design.state_rate_hz:.4g} rad/s: a sampled loop moves an undamped one "
            "either way (raise state_rate_hz, or give the sail damping)"
        )
    if worst.stable:
        moved = max(row.reached_real for row in rows)
        axis = max(row.neutral for row in rows)
        on_axis = (
            f"; up to {axis} poles stay on the imaginary axis (within {NEUTRAL:g} 1/s): modes "
            "of the undamped sail that neither load the hub nor show in the measurements"
            if axis
            else ""
        )
        return (
            f"stable: no closed-loop pole with Re s > {NEUTRAL:g} 1/s at any of the "
            f"{len(rows)} times; of the poles the loop moves, the largest real part is "
            f"{moved:+.3e} 1/s{on_axis}{note}"
        )
    return (
        f"unstable: a closed-loop pole with Re s = {worst.largest_real:+.3e} 1/s at "
        f"{abs(worst.largest_pole.imag):.4g} rad/s at t = {worst.t:g} s (lengths "
        f"{', '.join(f'{v:.4g}' for v in worst.lengths)} m){note}"
    )
