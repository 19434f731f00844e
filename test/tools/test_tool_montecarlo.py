"""`sail-ros montecarlo` of a free-hub sail: the hub's peaks and the holds' peak
reactions per sample, and their percentiles in the summary; none for a clamped sail."""

import contextlib
import csv

import numpy as np
import pytest
import yaml
from harness import SMALL, run_tool

from sail_ros.analysis.deployment import hold_reactions
from sail_ros.analysis.execution import batch_size, batch_sizes
from sail_ros.analysis.montecarlo import (
    HUB_OUTPUTS,
    accuracy_warning,
    run_sample,
    sample_scenario,
    study_from_dict,
    summarize,
)
from sail_ros.analysis.scenario import scenario_from_dict
from sail_ros.model import SailModel
from sail_ros.tools import montecarlo

pytestmark = pytest.mark.model

# boom d stops at 10.5 m while the others reach 11 m: the holds push along y
BOOM = {"type": "cycloidal", "start": 10.0, "end": 11.0, "duration": 4.0}
SCENARIO = {
    "scenario": {
        "duration": 4.0,
        "profile": {
            **dict.fromkeys("abc", BOOM),
            "d": {"type": "cycloidal", "start": 10.0, "end": 10.5, "duration": 3.0},
        },
        "initial": {"mode_state": {"a": 0.05}},
        "loads": [{"at": 0.0, "pressures": 1.0e-3}],
    },
    "sail": {"free_hub": True, "n_boom_modes": 2, "n_membrane_modes": 2},
}
STUDY = {
    "study": {
        "description": "free hub, scattered hub inertia",
        "samples": 3,
        "seed": 3,
        "scenario": SCENARIO,
        "output_rate_hz": 5.0,
        "dispersions": {"hub_inertia_x": {"distribution": "uniform", "low": 20.0, "high": 200.0}},
    }
}


def test_a_free_hub_study_summarises_the_hubs_peaks_and_hold_reactions(tmp_path, monkeypatch):
    """Each row carries the hub's peak heave and tilt and the holds' peak in-plane force
    (within 1e-4 of a 1 ms sampling of the motion) and spin torque (0: booms a and c move
    alike); summary.txt and summary.json give their 5/50/95 % as numpy takes them from
    samples.csv; a lighter hub (smaller J_x) tilts further."""
    monkeypatch.setattr(montecarlo, "dask_client", lambda *_: contextlib.nullcontext())
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(STUDY))
    out = tmp_path / "out"
    code, stdout, err = run_tool("montecarlo", [str(path), "--out", str(out), "--no-figures"])
    assert code == 0, err
    rows = list(csv.DictReader((out / "samples.csv").open()))
    assert len(rows) == 3 and all(row["error"] == "" for row in rows)
    assert all(name in rows[0] for name in HUB_OUTPUTS)

    study = study_from_dict(STUDY)
    scenario = scenario_from_dict(sample_scenario(study, 0))
    model = SailModel(SMALL.replace(**scenario.sail))
    t = np.linspace(0.0, 4.0, 4001)
    holds = hold_reactions(model, scenario.profile, t)
    assert float(rows[0]["peak_hold_force_N"]) == pytest.approx(
        np.hypot(holds[:, 0], holds[:, 1]).max(), rel=1e-4
    )
    assert all(float(row["peak_hold_torque_N_m"]) == 0.0 for row in rows)
    inertia = [float(row["hub_inertia_x"]) for row in rows]
    tilt = [float(row["peak_hub_tilt_rad"]) for row in rows]
    assert np.argsort(inertia).tolist() == np.argsort(tilt)[::-1].tolist()

    text = (out / "summary.txt").read_text()
    assert "  free hub: peak |z_h|, tilt |theta|, hold reactions |F|, |tau_z|" in stdout
    lines = text.splitlines()
    for name in HUB_OUTPUTS:
        printed = next(line for line in lines if line.split()[:1] == [name]).split()[1:]
        expected = np.percentile([float(row[name]) for row in rows], [5, 50, 95])
        np.testing.assert_allclose([float(v) for v in printed], expected, rtol=1e-5)
    summary = yaml.safe_load((out / "summary.json").read_text())
    assert summary["percentiles"]["peak_hub_tilt_rad"][1] == pytest.approx(np.median(tilt))


def test_a_clamped_study_has_no_hub_outputs():
    sail = {"n_boom_modes": 2, "n_membrane_modes": 2}
    clamped = {"study": {**STUDY["study"], "samples": 1, "dispersions": {},
               "scenario": {**SCENARIO, "sail": sail}}}  # fmt: skip
    study = study_from_dict(clamped)
    row = run_sample((study, 0, SMALL.to_dict()))
    assert row["error"] == "" and not set(HUB_OUTPUTS) & set(row)
    summary = summarize(study, [row], SMALL.to_dict())
    assert not set(HUB_OUTPUTS) & set(summary.percentiles)


def test_the_samples_accuracy_warnings_are_counted_and_the_largest_said():
    """One line for a study whose samples' error estimates exceed twice their tolerance:
    how many of them, and the largest estimate's own warning; none when no sample warns."""
    rows = [
        {"sample": 0, "error_estimate": 0.001, "_accuracy_warning": ""},
        {"sample": 1, "error_estimate": 0.006, "_accuracy_warning": "six"},
        {"sample": 2, "error_estimate": 0.009, "_accuracy_warning": "nine"},
        {"sample": 3, "error_estimate": 0.005, "_accuracy_warning": "five"},
    ]
    line = accuracy_warning(rows)
    assert line.startswith("warning: 3 of 4 samples' error estimates exceed twice")
    assert line.endswith("the largest sample 2: nine")
    assert accuracy_warning(rows[:1]) == ""


def test_a_switch_is_no_dispersion():
    study = {"study": {**STUDY["study"], "dispersions": {"free_hub": {"distribution": "uniform",
             "low": 0.0, "high": 1.0}}}}  # fmt: skip
    with pytest.raises(ValueError, match="unknown key 'free_hub'"):
        study_from_dict(study)


@pytest.mark.parametrize(("cases", "workers"), [(1000, 2), (200, 4), (37, 3), (5, 8), (1, 2)])
def test_batches_shrink_to_single_cases_at_the_end_of_a_study(cases, workers):
    sizes = batch_sizes(cases, workers)
    assert sum(sizes) == cases and min(sizes) >= 1
    assert sizes == sorted(sizes, reverse=True)  # never a longer batch after a shorter
    assert sizes[0] == batch_size(cases, workers)
    # the last task of each worker is a single case: no worker is left with a long batch
    assert sizes[-workers:] == [1] * min(workers, cases)
