"""What the tools share: which sail and which limits, how a run ends, how outputs are written.

The sail comes from `--config` and `--set`; so do the limits (`sail_ros.policy.Policy`:
the simulator's, with the same names), so an offline run refuses what the simulator
refuses, in the same words; `sail_ros.configuration.merge` lays them over the defaults
(with a scenario's `sail:` section between). The text blocks the tools print alike are
in `tools.tables`. `run` turns a user's mistake into one line and exit
code 2 and ends quietly when the reader of stdout goes away (`| head`).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
import os
import select
import signal
import sys
from pathlib import Path

import yaml

from sail_ros.configuration import Layer, file_layer, merge
from sail_ros.model import SailParameters, yaml_values
from sail_ros.outputs import CREATED, made_for, staged
from sail_ros.policy import OutOfRangeError, Policy
from sail_ros.spelling import did_you_mean

# the --help note of the tools that take --lengths and --rates
LIMITS_NOTE = """Lengths and rates are the simulator's (lengths within [min_length, max_length],
|rate| <= max_rate; --set NAME=VALUE changes the limits)."""
SET_HELP = (
    "a sail parameter or a limit, as the simulator's `-p NAME:=VALUE`: e.g. --set "
    "n_boom_modes=10, --set max_length=100 (repeatable; docs/scenarios.md lists them)"
)


def add_sail_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("sail and limits")
    group.add_argument(
        "--config",
        metavar="YAML",
        help="sail parameters file (keys of SailParameters, at top level or under `sail:`), "
        "or the simulator's params file (config/sim.yaml: its sail and its limits); "
        "default: the built-in defaults (config/sail.yaml)",
    )
    group.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], help=SET_HELP)


@dataclasses.dataclass(frozen=True)
class Configuration:
    """The sail and the limits a tool runs with.

    Attributes:
        sail: the sail's parameters.
        policy: the limits and alarms (the simulator's).
        policy_source: where the limits' values came from, for messages.
    """

    sail: SailParameters
    policy: Policy
    policy_source: str

    def limits_note(self) -> str:
        """`the simulator's limits (defaults; --set NAME=VALUE changes them)`."""
        return f"the simulator's limits ({self.policy_source}; --set NAME=VALUE changes them)"

    def check(self, method, *args, **kwargs):
        """`method(*args, **kwargs)`, a check of the policy; its ValueError says where the
        limits came from."""
        try:
            return method(*args, **kwargs)
        except ValueError as error:
            raise ValueError(f"{error}; {self.limits_note()}") from None

    def per_boom(self, values, option: str) -> list[float]:
        """An option's boom lengths [m]: one for all booms or four (a b c d), each within
        [min_length, max_length] (`Policy.check_lengths`)."""
        if len(values) not in (1, 4):
            raise ValueError(f"{option} takes 1 or 4 values, got {len(values)}")
        lengths = list(values) * (4 // len(values))
        self.check(self.policy.check_lengths, lengths, option, self.sail)
        return [float(v) for v in values]


def set_values(args: argparse.Namespace) -> dict:
    """`--set NAME=VALUE` items as {name: value}; ValueError names a malformed one."""
    changes = {}
    for item in args.set:
        key, separator, text = item.partition("=")
        if not separator:
            raise ValueError(f"--set expects KEY=VALUE, got {item!r}")
        try:
            changes[key.strip()] = yaml_values.load(text)
        except yaml.YAMLError:
            raise ValueError(f"--set {key.strip()}: {text!r} is not a value") from None
    return changes


def configuration(args: argparse.Namespace, sail_section: dict | None = None, where: str = ""):
    """The `Configuration` of --config, `sail_section` (a scenario's `sail:` overrides,
    named `where` in errors) and --set, merged in that order over the defaults
    (`sail_ros.configuration.merge`).

    Raises:
        ValueError: a bad file, name or value (the message names it).
    """
    changes = set_values(args)
    limit_names, sail_names = set(Policy.field_names()), set(SailParameters.field_names())
    for name in changes:
        if name not in limit_names | sail_names:
            hint = did_you_mean(name, limit_names | sail_names)
            raise ValueError(
                f"--set: unknown parameter {name!r}{hint}; sail parameters: "
                f"{', '.join(sorted(sail_names))}; limits: {', '.join(Policy.field_names())}"
            )
    layers = [file_layer(args.config)] if args.config else []
    if sail_section:
        layers.append(Layer(where or "sail section", sail_section))
    limit_changes = {k: v for k, v in changes.items() if k in limit_names}
    layers.append(Layer("", {k: v for k, v in changes.items() if k in sail_names}, limit_changes))
    sail, policy = merge(layers)
    sources = [args.config] if args.config and layers[0].policy else []
    sources += [f"--set {k}={v}" for k, v in limit_changes.items()]
    config = Configuration(sail, policy, ", ".join(sources) or "defaults")
    config.check(policy.check_sail, sail)
    return config


def tool_main(build_parser, body):
    """A tool's `main(argv=None)`: the options of `build_parser()` read from `argv`
    (default: the command line), then `body(args)` under `run`; returns the exit code."""

    def main(argv=None) -> int:
        args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
        return run(body, args)

    return main


def run(main_body, args) -> int:
    """Run a tool body and return its exit code.

    A user's mistake becomes one line and exit code 2: a ValueError (a bad value,
    file or option, named by the message), or an OSError from a path given (a
    missing file, an unwritable folder). A run that left the model's range
    (`OutOfRangeError`, the simulator's alarm) is one line and exit code 1. When
    the reader of stdout goes away (`sail-ros report ... | head`) the tool ends
    as Unix tools do on SIGPIPE: no message, exit code 141.
    """
    CREATED.clear()  # folders made by an earlier tool run in this process are not this one's
    try:
        return main_body(args) or 0
    except BrokenPipeError:
        if stdout_closed():
            return 128 + signal.SIGPIPE
        raise
    except OutOfRangeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        where = f" {str(error.filename)!r}" if error.filename else ""
        print(f"error: cannot use{where}: {error.strerror or error}", file=sys.stderr)
        return 2


def stdout_closed() -> bool:
    """True if stdout is a pipe whose reader has gone (poll says POLLERR on its write
    end); stdout then points at /dev/null, so the interpreter's last flush does not
    complain."""
    try:
        descriptor = sys.stdout.fileno()
    except (OSError, ValueError, io.UnsupportedOperation):  # not a file (a test's buffer)
        return False
    poller = select.poll()
    poller.register(descriptor, select.POLLOUT)
    if not any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0)):
        return False
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, descriptor)
    os.close(devnull)
    return True


def write_csv_rows(path: Path, rows: list[dict]) -> None:
    """One CSV row per dict (the first dict's keys are the header); makes the folder;
    whole or not at all (`outputs.staged`)."""
    with staged(path) as building, building.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def write_text(path: Path, text: str) -> Path:
    """`text` into `path`, whole or not at all (`outputs.staged`)."""
    with staged(path) as building:
        building.write_text(text)
    return Path(path)


def print_written(paths) -> None:
    """Tell the user which files a tool wrote, and in the line of the first written into
    it, the folder made for them (`outputs.made_for`)."""
    for path in paths:
        folder = made_for(path)
        print(f"wrote {path}" + (f" (made the folder {folder})" if folder else ""))


def refine_hint(params: SailParameters) -> str:
    """How to give a run more modes than `params` keep: the membrane band when the count
    is automatic, else the counts."""
    if params.n_membrane_modes:
        return "raise n_membrane_modes (and n_boom_modes) with --set"
    return "raise membrane_band (--set)"
