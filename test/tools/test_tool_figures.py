"""Figure helpers: the PNG and layout checks the tool tests share, and the plot modules'
small rules."""

import dataclasses

import numpy as np
import pytest
from harness import CONFIG, SMALL, assert_figure, assert_png

from sail_ros.analysis.montecarlo import input_unit, load_study, run_sample, summarize
from sail_ros.model import SailParameters
from sail_ros.plots.common import break_lines, figure, fit_width, save
from sail_ros.plots.histories import equal_groups, tip_deflections_figure
from sail_ros.plots.sail3d import exaggeration_for, true_box_height

pytestmark = pytest.mark.model


def test_assert_png_rejects_a_blank_figure(tmp_path):
    fig, ax = figure(6.0, 4.0)
    ax.set_axis_off()
    path = save(fig, tmp_path / "blank.png")
    with pytest.raises(AssertionError, match="blank|drawn|small"):
        assert_png(path)


def test_the_check_finds_clipped_overlapping_and_hidden_artists(tmp_path, figure_checks):
    fig, (left, right) = figure(4.0, 3.0, ncols=2)
    t = np.linspace(0.0, 1.0, 50)
    left.plot(t, np.sin(t), label="first")
    left.plot(t, np.sin(t) + 1e-9, label="second")  # within half a pixel everywhere
    left.plot([0.0, 0.5, 0.5, 1.0], [0.0, 0.0, 1.0, 1.0], label="step")  # a vertical stroke
    left.legend(loc="upper left")  # over the step's last points
    left.set_ylabel("a label far longer than the three inches of this figure " * 2)
    right.tick_params(axis="y", pad=30)  # the tick labels into the left panel
    fig.suptitle("a title far wider than the four inches of this figure " * 3)
    check = figure_checks[save(fig, tmp_path / "bad.png")]
    assert "panel 0: y label" in check.clipped and "panel 1" not in check.clipped
    assert any("a title far wider" in name for name in check.clipped)
    assert ("panel 1: y tick label '0.4'", "panel 0: plotting area") in check.overlaps
    assert ("panel 0: y label", "figure a title far wider than the four inches o") in (
        check.overlaps
    )
    assert check.hidden == (("panel 0: first", "panel 0: second"),)
    assert check.jumps == ("panel 0: step",)
    assert "panel 0: step" in check.covered
    assert check.panels["panel 0"].lines == ("first", "second", "step")
    with pytest.raises(AssertionError, match="outside the figure"):
        assert_figure(tmp_path / "bad.png", figure_checks, 100, 100)


def test_fit_width_wraps_a_long_title_inside_the_figure(tmp_path, figure_checks):
    fig, ax = figure(4.0, 3.0)
    ax.plot([0, 1], [0, 1])
    ax.set_title("Boom-tip deflections\n" + "a long scenario description " * 6)
    fit_width(ax.title)
    fig.tight_layout()
    save(fig, tmp_path / "wrapped.png")
    assert ax.title.get_text().count("\n") >= 3  # broken at spaces, first line kept
    assert ax.title.get_text().startswith("Boom-tip deflections\na long")
    assert_figure(tmp_path / "wrapped.png", figure_checks, 300, 200)


def test_a_repeated_stamp_breaks_every_line_there(tmp_path, figure_checks):
    # a reset: the last sample before it and the fresh one share the stamp 2.0 s
    t = np.array([0.0, 1.0, 2.0, 2.0, 3.0])
    tips = np.array([[0.1, 0.0, 0.0, 0.0], [0.2, 0.0, 0.0, 0.0], [0.3, 0.0, 0.0, 0.0],
                     [0.1, 0.0, 0.0, 0.0], [0.2, 0.0, 0.0, 0.0]])  # fmt: skip
    broken_t, broken = break_lines(t, tips)
    np.testing.assert_array_equal(broken_t[:3], t[:3])
    assert np.isnan(broken_t[3]) and np.all(np.isnan(broken[3]))
    np.testing.assert_array_equal(broken[4:], tips[3:])
    path = tip_deflections_figure(t, tips, tmp_path / "tips.png", title="reset at 2 s")
    check = assert_figure(path, figure_checks)
    panel = check.panels["Boom-tip deflections reset at 2 s"]
    assert panel.lines == ("boom a", "booms b, c, d") and panel.segments == (2, 2)


@pytest.mark.parametrize(
    ("height", "extent", "expected"),
    [
        (0.1, 15.0, 50.0),  # 0.35 * 15 / 0.1 = 52.5 -> 50
        (1.0, 70.0, 20.0),  # 24.5 -> 20
        (0.01, 10.0, 200.0),  # 350 -> 200
    ],
    ids=["deploy", "full-size", "tiny"],
)
def test_exaggeration_is_a_round_number_below_the_target(height, extent, expected):
    assert exaggeration_for(height, extent, fraction=0.35) == expected


def test_true_box_height_draws_the_stated_exaggeration():
    # 0.1 m drawn 50x over a 2 x 15 m plane: 5 m of 30 m, and the z range is +-0.1 m
    assert true_box_height(0.1, 15.0, 50.0) == pytest.approx(2 * 5.0 / 30.0)


def test_equal_groups_merge_identical_series_only():
    t = np.linspace(0, 1, 50)
    columns = np.column_stack([np.sin(t), np.cos(t), np.sin(t), np.cos(t) + 1e-3])
    assert equal_groups(columns) == [[0, 2], [1], [3]]


def test_montecarlo_figures_count_whole_samples_and_give_the_input_unit(tmp_path, figure_checks):
    """Five samples of the reference study (few modes), drawn as `sail-ros montecarlo`
    draws them: whole numbers on the histograms' count axes, the unit of the most
    influential input on its axis."""
    from sail_ros.tools.montecarlo import _figures

    study = dataclasses.replace(load_study(CONFIG / "study_reference.yaml"), samples=5)
    sail = SailParameters(n_boom_modes=2, n_membrane_modes=3).to_dict()
    rows = [run_sample((study, index, sail)) for index in range(study.samples)]
    summary = summarize(study, rows, sail)
    paths = _figures(study, rows, summary, tmp_path)
    assert [p.name for p in paths] == ["envelopes.png", "peaks.png", "influence.png"]
    # five dots on the scatter: fewer pixels drawn than a page of lines
    checks = {p.stem: assert_figure(p, figure_checks, min_drawn=0.02) for p in paths}
    for panel in checks["peaks"].panels.values():
        assert panel.ylabel == "samples" and panel.yticks
        assert all(tick == round(tick) for tick in panel.yticks), panel.yticks
    (influence,) = checks["influence"].panels.values()
    name = summary.influence[0][0]
    assert influence.xlabel == f"{name} [{input_unit(name)}]"
    assert all(panel.lines == ("median",) for panel in checks["envelopes"].panels.values())


@pytest.mark.parametrize(
    ("name", "unit"),
    [
        ("initial_tip_deflection.a", "m"),
        ("rate.b", "-"),
        ("jam_boom", "-"),
        ("jam_fraction", "-"),
        ("boom_bending_stiffness", "N m^2"),
        ("membrane_prestress", "Pa"),
        ("mass_damping", "1/s"),
    ],
)
def test_every_study_input_has_its_unit(name, unit):
    assert input_unit(name) == unit


def test_every_parameter_declares_its_unit():
    units = {name: SailParameters.unit(name) for name in SailParameters.field_names()}
    assert units["sail_side"] == "m" and units["n_boom_modes"] == "-"
    flags = {"free_hub", "stowed_mass_on_hub"}  # true or false: no unit
    assert all(unit for name, unit in units.items() if name not in flags), units


def test_the_free_hub_scenario_draws_its_attitude_heave_and_holds(tmp_path, figure_checks):
    """config/scenario_free_hub.yaml: booms a and c deploy alike, b and d not, so the
    holds push along y only (F_x = 0, F_y up to ~1 N) and the pressure's centre, off the
    hub once boom d jams, tilts it about x; every panel drawn clear of the others."""
    from sail_ros.analysis.deployment import hold_reactions, output_times, run_deployment
    from sail_ros.analysis.scenario import load_scenario
    from sail_ros.model import SailModel
    from sail_ros.plots.histories import hub_attitude_figure

    scenario = load_scenario(CONFIG / "scenario_free_hub.yaml")
    model = SailModel(SMALL.replace(**scenario.sail))
    run = run_deployment(model, scenario, output_times(scenario.duration, 20.0))
    holds = hold_reactions(model, scenario.profile, run.t)
    assert np.all(holds[:, 0] == 0.0) and 0.5 < np.abs(holds[:, 1]).max() < 2.0
    assert np.all(holds[run.t > 15.0] == 0.0)  # nothing moves after 15 s
    tilt_x = run.hub[:, 1]
    assert abs(tilt_x[-1]) > 10 * np.abs(run.hub[:, 2]).max()  # about x, and growing
    assert run.peaks.hub.value[1] == pytest.approx(abs(tilt_x[-1]), rel=1e-6)
    path = hub_attitude_figure(run.t, run.hub, holds, tmp_path / "hub.png", scenario.description)
    check = assert_figure(path, figure_checks)
    assert len(check.panels) >= 3
