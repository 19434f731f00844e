"""`sail-ros montecarlo`: Monte Carlo deployments on Dask.

Runs every sample of a study file (a base scenario, dispersions of sail
parameters, initial tip deflections and boom rates, a jammed boom; see
config/study_reference.yaml) on a Dask cluster: a local one by default, an
existing one with --scheduler. Writes one row per sample (its inputs, the peak
|tip deflection| and |root moment| of each boom and when (true peaks, from
inside every integration step), final energy, stability margin, or its error)
as CSV (and Parquet with pyarrow), a summary
(5/50/95 % of each output, with a free hub of its peak heave and tilt and
the holds' peak reactions too, inputs ranked by rank correlation with the
peak tip deflection), the worst five samples as scenario files that `sail-ros
deploy` reruns, and figures. Ctrl-C cancels what has not run and still writes
what has.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import yaml
from tqdm import tqdm

from sail_ros.analysis.execution import run_cases
from sail_ros.analysis.montecarlo import (
    HUB_OUTPUTS,
    accuracy_warning,
    check_study,
    csv_text,
    input_unit,
    load_study,
    run_sample,
    sample_scenario,
    study_sail,
    summarize,
    tip_histories,
)
from sail_ros.options import ToolParser, paragraphs
from sail_ros.outputs import staged
from sail_ros.policy import Policy
from sail_ros.tools.cluster import add_cluster_options, check_cluster_options, dask_client
from sail_ros.tools.common import add_sail_options, configuration, print_written, tool_main

WORST = 5
FIGURES = ("envelopes.png", "peaks.png", "influence.png")
EXAMPLES = (
    "sail-ros montecarlo config/study_reference.yaml --samples 40 --out out/study",
    "sail-ros montecarlo config/study_reference.yaml --samples 40 --workers 2 --no-figures",
    "sail-ros montecarlo config/study_reference.yaml --set max_rate=1.2 --out out/study_fast",
    "sail-ros montecarlo config/study_reference.yaml --scheduler tcp://10.0.0.5:8786",
)
WRITES = (
    "into --out DIR: samples.csv (and samples.parquet with pyarrow), summary.txt, "
    "summary.json, worst/worst_<rank>_sample_<index>.yaml (scenario files that `sail-ros "
    f"deploy --scenario` reruns), {', '.join(FIGURES)}; the folder is built under a "
    "temporary name and moved into place when all is written."
)
NOTES = """The study file's keys: docs/scenarios.md. --config/--set give the sail the study's
scenario starts from (its `sail:` section and the dispersions override them) and the
limits, the simulator's: a sample whose draw asks what the simulator would refuse, or
whose run leaves the linear range, is a row with its error."""


def build_parser() -> ToolParser:
    parser = ToolParser.for_tool(
        "montecarlo",
        paragraphs(__doc__, 0, 1),
        EXAMPLES,
        WRITES,
        NOTES,
    )
    parser.add_argument("study", type=Path, metavar="STUDY.yaml", help="the study file")
    parser.add_argument("--out", type=Path, help="output folder (default: <study>_results)")
    parser.add_argument(
        "--samples", type=int, help="run this many samples instead (at least 1: samples 0, 1, ...)"
    )
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    add_sail_options(parser)
    add_cluster_options(parser)
    return parser


def _montecarlo(args) -> int:
    check_cluster_options(args.scheduler, args.workers)
    study = load_study(args.study)
    if args.samples is not None:
        if args.samples < 1:
            raise ValueError(f"--samples must be >= 1, got {args.samples}")
        study = dataclasses.replace(study, samples=args.samples)
    out = args.out or Path(f"{args.study.stem}_results")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: a file, not a folder")
    config = configuration(args)
    base_sail = study_sail(study, config.sail).to_dict()
    config.check(check_study, study, base_sail, config.policy)
    cases = [(study, index, base_sail, config.policy) for index in range(study.samples)]
    print(f"Study {args.study}: {study.samples} samples, seed {study.seed}")
    bar = tqdm(total=len(cases), unit="sample", disable=None, file=sys.stderr)
    with dask_client(args.scheduler, args.workers) as client, bar:
        outcome = run_cases(run_sample, cases, client, progress=bar.update)
    rows = [row for row in outcome.results if row is not None]
    if outcome.interrupted:
        print(f"interrupted: {len(rows)} of {study.samples} samples finished; writing those")
    summary = summarize(study, rows, base_sail, WORST)
    text = _summary_text(study, summary, config.policy)
    print(text)
    warning = accuracy_warning(rows)
    if warning:
        print(warning, file=sys.stderr)
    with staged(out, "--out") as folder:
        folder.mkdir()
        (folder / "samples.csv").write_text(csv_text(study, rows))
        _parquet(folder / "samples.parquet", folder / "samples.csv")
        (folder / "summary.txt").write_text(text + "\n")
        (folder / "summary.json").write_text(
            json.dumps(dataclasses.asdict(summary), indent=2) + "\n"
        )
        (folder / "worst").mkdir()
        for rank, index in enumerate(summary.worst, start=1):
            path = folder / "worst" / f"worst_{rank}_sample_{index}.yaml"
            path.write_text(_worst_scenario(args.study, study, index, base_sail, config.policy))
        if not args.no_figures:
            _figures(study, rows, summary, folder)
        written = sorted(path.relative_to(folder) for path in folder.rglob("*") if path.is_file())
    print_written(out / path for path in written)
    return 130 if outcome.interrupted else 0


def _worst_scenario(study_path: Path, study, index: int, base_sail: dict, policy) -> str:
    """Sample `index` as a scenario file with its whole sail, and the command that reruns
    it with the limits the study ran with."""
    document = sample_scenario(study, index)
    document["sail"] = {**base_sail, **document.get("sail", {})}  # complete: the same sail
    changed = [
        f" --set {name}={value!r}"
        for name, value in dataclasses.asdict(policy).items()
        if value != getattr(Policy(), name)
    ]
    return (
        f"# sample {index} of the study {study_path} (sail-ros montecarlo); rerun it with\n"
        f"#   sail-ros deploy --scenario <this file>{''.join(changed)}\n"
        + yaml.safe_dump(document, sort_keys=False)
    )


def _summary_text(study, summary, policy) -> str:
    lines = [
        f"  {summary.succeeded} samples ran, {summary.failed} failed (their rows hold the error)",
        f"  mode counts n_B = {summary.n_boom_modes}, n_M = {summary.n_membrane_modes} in every "
        "sample; peaks are true peaks (taken inside every integration step) of that model: "
        "`sail-ros deploy --scenario worst/<file> --convergence` shows how they move with more "
        "modes",
        f"  {'output':<28}{'5 %':>14}{'50 %':>14}{'95 %':>14}",
    ]
    hub = [name for name in HUB_OUTPUTS if name in summary.percentiles]
    for name, (low, middle, high) in summary.percentiles.items():
        if name == next(iter(hub), None):
            lines.append("  free hub: peak |z_h|, tilt |theta|, hold reactions |F|, |tau_z|")
        lines.append(f"  {name:<28}{low:>14.6g}{middle:>14.6g}{high:>14.6g}")
    lines.append("  inputs by |Spearman rank correlation| with peak_tip_m:")
    for name, rho in summary.influence:
        lines.append(f"    {name:<30}{rho:+.3f}")
    lines.append(f"  worst samples (largest peak_tip_m): {', '.join(map(str, summary.worst))}")
    longest = f"{policy.max_length:g} m" if policy.max_length else "the full boom length"
    lines.append(
        f"  limits (the simulator's): lengths from {policy.min_length:g} m to {longest}, |rate| "
        f"<= {policy.max_rate:g} m/s, |acceleration| <= {policy.max_acceleration:g} m/s^2, "
        f"|tip| < {policy.tip_error_fraction:g} x length"
    )
    return "\n".join(lines)


def _parquet(path: Path, csv: Path) -> None:
    try:
        import pyarrow.csv
        import pyarrow.parquet
    except ImportError:
        return
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(csv), path)


def _figures(study, rows, summary, out: Path) -> list[Path]:
    from sail_ros.plots.montecarlo import envelopes_figure, influence_figure, peaks_figure

    good = [row for row in rows if not row.get("error")]
    if not good:
        return []
    t, tips = tip_histories(good)
    title = study.description
    envelopes_path, peaks_path, influence_path = (out / name for name in FIGURES)
    written = [envelopes_figure(t, tips, envelopes_path, title)]
    peaks = np.array([[row[f"peak_tip_{b}_m"] for b in "abcd"] for row in good])
    written.append(peaks_figure(peaks, peaks_path, title))
    if summary.influence:
        name, rho = summary.influence[0]
        values = np.array([row[name] for row in good], dtype=float)
        peak = np.array([row["peak_tip_m"] for row in good])
        written.append(
            influence_figure(values, peak, name, rho, influence_path, unit=input_unit(name))
        )
    return written


main = tool_main(build_parser, _montecarlo)
