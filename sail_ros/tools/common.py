"""Options shared by the tools: which sail, and how to print it."""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import yaml

from sail_ros.model import SailParameters, yaml_values


def add_sail_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("sail")
    group.add_argument(
        "--config",
        metavar="YAML",
        help="sail parameters file (keys of SailParameters, at top level or under `sail:`); "
        "default: the built-in defaults (config/sail.yaml)",
    )
    group.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        help="override one parameter, e.g. --set n_boom_modes=10 (repeatable)",
    )


def sail_parameters(args: argparse.Namespace) -> SailParameters:
    """Parameters from --config and --set; ValueError names a bad key or value."""
    params = SailParameters.from_yaml(args.config) if args.config else SailParameters()
    changes = {}
    for item in args.set:
        key, separator, text = item.partition("=")
        if not separator:
            raise ValueError(f"--set expects KEY=VALUE, got {item!r}")
        try:
            changes[key.strip()] = yaml_values.load(text)
        except yaml.YAMLError:
            raise ValueError(f"--set {key.strip()}: {text!r} is not a value") from None
    if changes:
        params = SailParameters.from_dict({**params.to_dict(), **changes})
    return params


def describe_parameters(params: SailParameters) -> str:
    """The parameters in one block, with units, for printing next to results."""
    return "\n".join(
        [
            f"  sail side a             {params.sail_side:g} m (full boom length "
            f"{params.full_boom_length:.4g} m)",
            f"  boom EI                 {params.boom_bending_stiffness:g} N m^2",
            f"  boom rho_B              {params.boom_linear_density:g} kg/m",
            f"  film h, rho             {params.membrane_thickness:g} m, "
            f"{params.membrane_density:g} kg/m^3 "
            f"(rho_M = {params.membrane_areal_density:.4g} kg/m^2)",
            f"  film prestress          {params.membrane_prestress:g} Pa "
            f"(N0 = {params.membrane_tension:.4g} N/m)",
            f"  boom axial load P       {params.boom_axial_load:g} N",
            f"  modes n_B, n_M          {params.n_boom_modes}, {params.n_membrane_modes} "
            f"({4 * params.n_boom_modes + 4 * params.n_membrane_modes} coordinates)",
            f"  Rayleigh damping        alpha = {params.mass_damping:g} 1/s, "
            f"beta = {params.stiffness_damping:g} s",
        ]
    )


def run(main_body, args) -> int:
    """Run a tool body. A user's mistake becomes one line and exit code 2: a
    ValueError (a bad value, file or option, named by the message), or an OSError
    from a path given (a missing file, an unwritable folder)."""
    try:
        return main_body(args) or 0
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        where = f" {str(error.filename)!r}" if error.filename else ""
        print(f"error: cannot use{where}: {error.strerror or error}", file=sys.stderr)
        return 2


def write_csv_rows(path: Path, rows: list[dict]) -> None:
    """One CSV row per dict (the first dict's keys are the header); makes the folder."""
    for folder in (path.parent, *path.parent.parents):
        if folder.exists() and not folder.is_dir():
            raise ValueError(f"cannot write '{path}': '{folder}' is a file, not a folder")
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def print_written(paths) -> None:
    """Tell the user which files a tool wrote."""
    for path in paths:
        print(f"wrote {path}")


def print_peak_table(peaks, changes=None, indent: str = "  ") -> None:
    """Each boom's peak |tip deflection| [mm] and |root moment| [N m] with its time, and
    with `changes = (label, tip, moment)` their relative changes [%] (e.g. with more
    modes) under each."""
    lines = [
        ("|tip deflection| [mm]", 1e3 * peaks.tip_deflection.value, "12.4f"),
        ("  at t [s]", peaks.tip_deflection.time_s, "12.3f"),
        ("|root moment| [N m]", peaks.root_moment.value, "12.5g"),
        ("  at t [s]", peaks.root_moment.time_s, "12.3f"),
    ]
    if changes is not None:
        label, tip, moment = changes
        lines[1:1] = [(label, 100 * tip, "+12.3f")]
        lines.append((label, 100 * moment, "+12.3f"))
    width = max(len(label) for label, _, _ in lines) + 2
    print(f"{indent}{'':{width}}" + "".join(f"{'boom ' + b:>12}" for b in "abcd"))
    for label, values, spec in lines:
        print(f"{indent}{label:<{width}}" + "".join(f"{v:>{spec}}" for v in values))
