"""`sail-ros montecarlo`: Monte Carlo deployments on Dask.

Runs every sample of a study file (a base scenario, dispersions of sail
parameters, initial tip deflections and boom rates, a jammed boom; see
config/study_reference.yaml) on a Dask cluster: a local one by default, an
existing one with --scheduler. Writes one row per sample (its inputs, the peak
|tip deflection| and |root moment| of each boom and when (true peaks, from
inside every integration step), final energy, stability margin, or its error)
as CSV (and Parquet with pyarrow), a summary
(5/50/95 % of each output, inputs ranked by rank correlation with the peak
tip deflection), the worst five samples as scenario files that `sail-ros
deploy` reruns, and figures. Ctrl-C cancels what has not run and still writes
what has.

    sail-ros montecarlo config/study_reference.yaml --out out/study
    sail-ros montecarlo config/study_reference.yaml --samples 40 --workers 2
    sail-ros montecarlo STUDY.yaml --scheduler tcp://10.0.0.5:8786
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import yaml
from tqdm import tqdm

from sail_ros.analysis.execution import run_cases
from sail_ros.analysis.montecarlo import (
    csv_text,
    input_unit,
    load_study,
    run_sample,
    sample_scenario,
    summarize,
)
from sail_ros.model import SailParameters
from sail_ros.tools.cluster import add_cluster_options, dask_client
from sail_ros.tools.common import print_written, run

WORST = 5


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sail-ros montecarlo",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("study", type=Path, metavar="STUDY.yaml", help="the study file")
    parser.add_argument("--out", type=Path, help="output folder (default: <study>_results)")
    parser.add_argument("--samples", type=int, help="run this many samples instead (0, 1, ...)")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    add_cluster_options(parser)
    return parser


def _montecarlo(args) -> int:
    study = load_study(args.study)
    if args.samples is not None:
        if args.samples < 1:
            raise ValueError(f"--samples must be >= 1, got {args.samples}")
        study = dataclasses.replace(study, samples=args.samples)
    out = args.out or Path(f"{args.study.stem}_results")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: a file, not a folder")
    base_sail = SailParameters().to_dict()
    cases = [(study, index, base_sail) for index in range(study.samples)]
    print(f"Study {args.study}: {study.samples} samples, seed {study.seed}")
    bar = tqdm(total=len(cases), unit="sample", disable=None, file=sys.stderr)
    with dask_client(args.scheduler, args.workers) as client, bar:
        outcome = run_cases(run_sample, cases, client, progress=bar.update)
    rows = [row for row in outcome.results if row is not None]
    if outcome.interrupted:
        print(f"interrupted: {len(rows)} of {study.samples} samples finished; writing those")
    out.mkdir(parents=True, exist_ok=True)
    written = [_write(out / "samples.csv", csv_text(study, rows))]
    parquet = _parquet(out / "samples.parquet", out / "samples.csv")
    if parquet:
        written.append(parquet)
    summary = summarize(study, rows, base_sail, WORST)
    text = _summary_text(study, summary)
    print(text)
    written.append(_write(out / "summary.txt", text + "\n"))
    written.append(
        _write(out / "summary.json", json.dumps(dataclasses.asdict(summary), indent=2) + "\n")
    )
    for rank, index in enumerate(summary.worst, start=1):
        document = sample_scenario(study, index)
        document.setdefault("sail", {})
        document["sail"] = {**base_sail, **document["sail"]}  # complete: reruns the same sail
        path = out / "worst" / f"worst_{rank}_sample_{index}.yaml"
        path.parent.mkdir(parents=True, exist_ok=True)
        written.append(_write(path, yaml.safe_dump(document, sort_keys=False)))
    if not args.no_figures:
        written += _figures(study, rows, summary, out)
    print_written(written)
    return 130 if outcome.interrupted else 0


def _summary_text(study, summary) -> str:
    lines = [
        f"  {summary.succeeded} samples ran, {summary.failed} failed (their rows hold the error)",
        f"  mode counts n_B = {summary.n_boom_modes}, n_M = {summary.n_membrane_modes} in every "
        "sample; peaks are true peaks (taken inside every integration step) of that model: "
        "`sail-ros deploy --scenario worst/<file> --convergence` shows how they move with more "
        "modes",
        f"  {'output':<28}{'5 %':>14}{'50 %':>14}{'95 %':>14}",
    ]
    for name, (low, middle, high) in summary.percentiles.items():
        lines.append(f"  {name:<28}{low:>14.6g}{middle:>14.6g}{high:>14.6g}")
    lines.append("  inputs by |Spearman rank correlation| with peak_tip_m:")
    for name, rho in summary.influence:
        lines.append(f"    {name:<30}{rho:+.3f}")
    lines.append(f"  worst samples (largest peak_tip_m): {', '.join(map(str, summary.worst))}")
    return "\n".join(lines)


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _parquet(path: Path, csv: Path) -> Path | None:
    try:
        import pyarrow.csv
        import pyarrow.parquet
    except ImportError:
        return None
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(csv), path)
    return path


def _figures(study, rows, summary, out: Path) -> list[Path]:
    from sail_ros.plots.montecarlo import envelopes_figure, influence_figure, peaks_figure

    good = [row for row in rows if not row.get("error")]
    if not good:
        return []
    t = good[0]["_t"]
    tips = np.stack(
        [[np.interp(t, row["_t"], row["_tips"][:, k]) for k in range(4)] for row in good]
    ).transpose(0, 2, 1)  # (samples, times, booms) on the first sample's times
    title = study.description
    written = [envelopes_figure(t, tips, out / "envelopes.png", title)]
    peaks = np.array([[row[f"peak_tip_{b}_m"] for b in "abcd"] for row in good])
    written.append(peaks_figure(peaks, out / "peaks.png", title))
    if summary.influence:
        name, rho = summary.influence[0]
        values = np.array([row[name] for row in good], dtype=float)
        peak = np.array([row["peak_tip_m"] for row in good])
        written.append(
            influence_figure(values, peak, name, rho, out / "influence.png", unit=input_unit(name))
        )
    return written


def main(argv=None) -> int:
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    return run(_montecarlo, args)


if __name__ == "__main__":
    sys.exit(main())
