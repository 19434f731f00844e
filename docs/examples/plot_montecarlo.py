"""
A Monte Carlo study
===================

`sail-ros montecarlo config/study_reference.yaml` runs the reference deployment with
the boom stiffness and the film prestress scattered, boom a's initial tip deflection
drawn, boom b deploying a little faster or slower, and one sample in ten jamming a boom.
The tool runs its samples on Dask; here the same functions run 24 samples serially
(4 boom and 6 membrane modes, so the site builds quickly), and the figures are drawn by
the tool's own plotting functions (`sail_ros.plots.montecarlo`).
"""

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

from sail_ros.analysis.execution import run_cases
from sail_ros.analysis.montecarlo import input_unit, load_study, run_sample, study_sail, summarize
from sail_ros.model import SailParameters
from sail_ros.plots.montecarlo import envelopes_figure, influence_figure, peaks_figure
from sail_ros.policy import Policy

FIGURES = Path(tempfile.mkdtemp())
# sphinx-gallery runs an example in its own folder: the tree is the nearest one up
ROOT = next(
    (
        p
        for p in (Path.cwd(), *Path.cwd().parents)
        if (p / "config" / "study_reference.yaml").is_file()
    ),
    None,
)
if ROOT is None:
    raise SystemExit(
        "run this example inside the sail_ros tree: it reads config/study_reference.yaml"
    )

study = dataclasses.replace(load_study(ROOT / "config" / "study_reference.yaml"), samples=24)
sail = SailParameters(n_boom_modes=4, n_membrane_modes=6)
base = study_sail(study, sail).to_dict()
cases = [(study, index, base, Policy()) for index in range(study.samples)]

# %%
# The samples, run here (`client=None`), and the study's summary.
rows = [row for row in run_cases(run_sample, cases, client=None).results if row]
summary = summarize(study, rows, base)
print(f"{summary.succeeded} samples ran, {summary.failed} failed")
for name, (low, middle, high) in list(summary.percentiles.items())[:4]:
    print(f"  {name:<24} 5 % {low:.4g}  50 % {middle:.4g}  95 % {high:.4g}")

# %%
# Tip envelopes, peak histograms and the input that weighs most on the peak tip.
good = [row for row in rows if not row.get("error")]
t = good[0]["_t"]
tips = np.stack([[np.interp(t, row["_t"], row["_tips"][:, k]) for k in range(4)]
                 for row in good]).transpose(0, 2, 1)  # fmt: skip
envelopes_figure(t, tips, FIGURES / "envelopes.png", study.description)
peaks = np.array([[row[f"peak_tip_{b}_m"] for b in "abcd"] for row in good])
peaks_figure(peaks, FIGURES / "peaks.png", study.description)
name, rho = summary.influence[0]
values = np.array([row[name] for row in good], dtype=float)
peak = np.array([row["peak_tip_m"] for row in good])
influence_figure(values, peak, name, rho, FIGURES / "influence.png", unit=input_unit(name))
