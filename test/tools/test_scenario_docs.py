"""docs/scenarios.md holds the readers' own declarations, and the readers keep them:
every key documented is read, its default is the one applied, an unknown key is
refused with the nearest one, and every error names the entry down to its element."""

import re

import numpy as np
import pytest
import yaml
from harness import ROOT

from sail_ros.analysis import montecarlo, scenario
from sail_ros.analysis.schema import REQUIRED
from sail_ros.model import CycloidalProfile, SailModel, SailParameters, WaypointProfile
from sail_ros.policy import Policy
from sail_ros.tools import deploy
from sail_ros.tools.scenario_docs import blocks, update

pytestmark = pytest.mark.model

DOCS = ROOT / "docs" / "scenarios.md"


def test_the_page_holds_the_declarations():
    text = DOCS.read_text()
    assert update(text) == text, (
        "docs/scenarios.md is out of date: python -m sail_ros.tools.scenario_docs docs/scenarios.md"
    )
    for name, block in blocks().items():
        assert block and block in text, name
    for section in (*scenario.SECTIONS, *montecarlo.SECTIONS):
        assert f"#### `{section.path}`" in text
        for entry in section.keys:
            assert entry.spec.doc and f"| `{entry.name}` |" in text, (section.path, entry.name)


def every_key_document() -> dict:
    """A scenario using every key of every section (three booms' profiles of each type)."""
    return {
        "scenario": {
            "description": "every key",
            "duration": 4.0,
            "profile": {
                "a": {
                    "type": "cycloidal",
                    "start": 10.0,
                    "end": 11.0,
                    "duration": 4.0,
                    "t0": 0.0,
                    "stop_at": 10.8,
                },
                "b": {
                    "type": "waypoints",
                    "times": [0.0, 4.0],
                    "lengths": [10.0, [11.0] * 4],
                    "start_rates": 0.0,
                    "end_rates": 0.0,
                    "stop_at": 20.0,
                },
                "c": {"type": "static", "lengths": 10.0},
                "d": {"type": "static", "lengths": [10.0] * 4},
            },  # fmt: skip
            "initial": {
                "mode_state": {"a": 0.05},
                "q0": {"membrane_ab_mode_2_1": 0.01},
                "qd0": {"boom_b_mode_1": 0.001},
            },
            "snapshots": [0.0, 4.0],
            "loads": [{"at": 0.0, "pressures": 1e-3, "tip_forces": [0.0, 0.01, 0.0, 0.0]}],
        },
        "sail": {"n_boom_modes": 2, "n_membrane_modes": 2},
        "controller": {"weight_tilt": 1e5},
    }


def test_every_documented_scenario_key_is_read():
    document = every_key_document()
    for section in scenario.SECTIONS:
        if section.path == "top level":
            used = set(document)
        elif section.path == "scenario":
            used = set(document["scenario"])
        elif section.path.startswith("scenario.profile, type "):
            kind = section.path.rsplit(" ", 1)[1]
            used = set().union(*(set(p) for p in document["scenario"]["profile"].values()
                                 if p["type"] == kind))  # fmt: skip
        elif section.path == "scenario.initial":
            used = set(document["scenario"]["initial"])
        else:
            used = set(document["scenario"]["loads"][0])
        assert used == {entry.name for entry in section.keys}, section.path
    read = scenario.scenario_from_dict(document)
    model = SailModel(SailParameters(**read.sail))
    scenario.check_scenario(read, model, Policy())
    q0, qd0 = read.initial_state(model)
    assert q0[model.coordinate_names.index("membrane_ab_mode_2_1")] == 0.01
    assert qd0[model.coordinate_names.index("boom_b_mode_1")] == 0.001
    assert read.loads(1.0)[0].tolist() == [1e-3] * 4
    assert read.controller.weight_tilt == 1e5


def test_documented_defaults_are_the_ones_applied():
    bare = {"scenario": {"duration": 2.0, "profile": {"type": "cycloidal", "start": 10.0,
                                                       "end": 10.5, "duration": 2.0}}}  # fmt: skip
    read = scenario.scenario_from_dict(bare)
    section = scenario.PROFILES["cycloidal"]
    assert isinstance(read.profile, CycloidalProfile)
    assert read.profile.t0 == section["t0"].default
    assert read.description == scenario.SCENARIO["description"].default
    assert read.snapshots == tuple(np.linspace(0.0, 2.0, 6))  # "6 times evenly"
    assert read.loads is None and read.initial == {}
    waypoints = scenario.scenario_from_dict(
        {
            "scenario": {
                "duration": 2.0,
                "profile": {"type": "waypoints", "times": [0, 2], "lengths": [10, 10.5]},
            }
        }  # fmt: skip
    ).profile
    assert isinstance(waypoints, WaypointProfile)
    assert waypoints(0.0)[1].tolist() == [scenario.PROFILES["waypoints"]["start_rates"].default] * 4
    study = montecarlo.study_from_dict(
        {"study": {"samples": 2, "scenario": scenario.REFERENCE}}, ROOT / "config"
    )
    assert study.seed == montecarlo.STUDY["seed"].default
    assert study.output_rate_hz == montecarlo.STUDY["output_rate_hz"].default
    assert study.description == montecarlo.STUDY["description"].default
    required = [e.name for e in montecarlo.STUDY.keys if e.default == REQUIRED]
    assert required == ["samples", "scenario"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["scenario"]["loads"][0]["tip_forces"].__setitem__(1, "x"),
         "scenario.loads[0].tip_forces.b must be a number, got 'x'"),
        (lambda d: d["scenario"]["loads"][0].__setitem__("pressures", [1e-3, 2e-3]),
         "scenario.loads[0].pressures must be a scalar or 4 values (quadrants ab, bc, cd, da)"),
        (lambda d: d["scenario"]["profile"]["a"].__setitem__("strat", 10.0),
         "scenario.profile.a (cycloidal): unknown key(s) 'strat' (did you mean 'start'?)"),
        (lambda d: d["scenario"]["profile"]["b"]["lengths"].__setitem__(1, [11, 11, -1, 11]),
         "scenario.profile.b.lengths[1].c must be > 0 m, got -1"),
        (lambda d: d["scenario"]["profile"]["d"]["lengths"].__setitem__(3, True),
         "scenario.profile.d.lengths.d must be a number, got True"),
        (lambda d: d["scenario"]["initial"]["q0"].__setitem__("membrane_ab_mode_2_1", "big"),
         "scenario.initial.q0.membrane_ab_mode_2_1 must be a number, got 'big'"),
        (lambda d: d["scenario"]["snapshots"].__setitem__(1, float("nan")),
         "scenario.snapshots[1] must be finite, got nan"),
        (lambda d: d["scenario"].__setitem__("duratoin", 3.0),
         "scenario: unknown key(s) 'duratoin' (did you mean 'duration'?)"),
    ],
    ids=["element", "count", "nearest", "waypoint", "bool", "coordinate", "snapshot", "key"],
)  # fmt: skip
def test_errors_point_into_the_file(tmp_path, capsys, change, message):
    document = every_key_document()
    change(document)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(document))
    assert deploy.main(["--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: {message}") and err.count("\n") == 1, err


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"seed": -1}, "study.seed must be an integer >= 0, got -1"),
        ({"output_rate_hz": 0}, "study.output_rate_hz must be in (0, 1000] Hz, got 0"),
        ({"sampels": 3}, "study: unknown key(s) 'sampels' (did you mean 'samples'?)"),
        ({"jam": {"probability": 0.5, "fraction": {"distribution": "uniform", "low": 0,
                                                   "high": "x"}}},
         "study.jam.fraction.high must be a number, got 'x'"),
        ({"dispersions": {"sail_side": {"distribution": "lognormal", "median": 0,
                                        "sigma": 0.1}}},
         "study.dispersions.sail_side.median must be > 0, got 0"),
    ],
    ids=["seed", "rate", "nearest", "distribution-value", "median"],
)  # fmt: skip
def test_study_errors_point_into_the_file(change, message):
    document = {"study": {"samples": 2, "scenario": scenario.REFERENCE, **change}}
    with pytest.raises(ValueError, match="^" + re.escape(message)):
        montecarlo.study_from_dict(document)
