"""Figure helpers: the PNG and layout checks the tool tests share, and the plot modules'
small rules."""

import dataclasses

import matplotlib.pyplot as plt
import numpy as np
import pytest
from harness import CONFIG, SMALL, SMALL_SET, assert_figure, assert_png

from sail_ros.analysis.montecarlo import input_unit, load_study, run_sample, summarize
from sail_ros.model import SailParameters
from sail_ros.plots.common import (
    DPI,
    break_lines,
    figure,
    reveal_hidden,
    save,
    titled_layout,
)
from sail_ros.plots.figure_check import inspect
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
    left.plot(t, np.sin(t) + 1e-14, label="third")  # the first's data, drawn again
    left.plot([0.0, 0.5, 0.5, 1.0], [0.0, 0.0, 1.0, 1.0], label="step")  # a vertical stroke
    left.axvline(0.2, color="k")  # through the legend
    left.legend(loc="upper left")  # over the step's last points
    left.set_ylabel("a label far longer than the three inches of this figure [m] " * 2)
    left.set_xlabel("t [s]")
    right.set_xlabel("t [s]")  # and its y axis without a unit
    right.tick_params(axis="y", pad=30)  # the tick labels into the left panel
    fig.suptitle("a title far wider than the four inches of this figure " * 3)
    fig.subplots_adjust(bottom=0.2)
    check = inspect(fig, tmp_path / "bad.png", DPI)  # as drawn, before `save` dashes
    assert "panel 0: y label" in check.clipped and "panel 1" not in check.clipped
    assert any("a title far wider" in name for name in check.clipped)
    assert ("panel 1: y tick label '0.4'", "panel 0: plotting area") in check.overlaps
    assert ("panel 0: y label", "figure a title far wider than the four inches o") in (
        check.overlaps
    )
    assert check.duplicates == (("panel 0: first", "panel 0: third"),)
    assert ("panel 0: first", "panel 0: second") in check.hidden
    assert check.jumps == ("panel 0: step",)
    assert "panel 0: step under legend" in check.covered
    assert "panel 0:  under legend" in check.covered  # the vertical line, no label
    assert check.unitless == ("panel 1: y axis",)
    assert check.panels["panel 0"].lines == ("first", "second", "third", "step", "")
    # saved, a line over most of an earlier one is dashed, in the legend too
    save(fig, tmp_path / "bad.png")
    saved = figure_checks[tmp_path / "bad.png"]
    assert not any("second" in pair[1] for pair in saved.hidden)
    second = left.get_lines()[1]
    assert (
        second.get_linestyle() == "--"
        and left.get_legend().legend_handles[1].get_linestyle() == "--"
    )
    with pytest.raises(AssertionError, match="outside the figure"):
        assert_figure(tmp_path / "bad.png", figure_checks, 100, 100)


@pytest.mark.parametrize("kind", ["autoscaled", "equal aspect", "log", "twin", "3d"])
def test_lines_are_dashed_as_the_drawn_figure_shows_them(kind):
    """`reveal_hidden` finds where lines lie on the page without drawing a 2-D figure:
    it dashes the lines it would dash on the drawn figure, whether the panels' limits
    still wait for autoscaling, an aspect moves a panel, a scale is logarithmic, two
    panels share an axis or a panel is 3-D (which it draws)."""
    t = np.linspace(1.0, 100.0, 200)
    y = 10.0 + 8.0 * np.sin(t / 9.0)
    # [data units] between the two lines: under a pixel on the drawn page (with an equal
    # aspect, the panel is 20 units tall on a width of 100, and 0.2 is less than a pixel
    # there, but more than two in the panel before its aspect is applied)
    offset = 0.2 if kind == "equal aspect" else 0.02

    def styles(draw_first: bool) -> list[str]:
        three_d = {"subplot_kw": {"projection": "3d"}} if kind == "3d" else {}
        fig, ax = figure(4.0, 3.0, **three_d)
        z = (0.0 * t,) if kind == "3d" else ()
        ax.plot(t, y, *z, label="under")
        ax.plot(t, y + offset, *z, label="over")
        ax.plot(t, 0.2 * t, *z, label="apart")
        if kind == "equal aspect":
            ax.set_aspect("equal")
        elif kind == "log":
            ax.set_yscale("log")
        elif kind == "twin":
            ax.twinx().plot(t, t, label="twin")
        if draw_first:
            fig.draw_without_rendering()
        reveal_hidden(fig)
        drawn = [line.get_linestyle() for panel in fig.axes for line in panel.get_lines()]
        plt.close(fig)
        return drawn

    found = styles(draw_first=False)
    assert found == styles(draw_first=True)
    assert found[:3] == ["-", "--", "-"]


def test_the_check_finds_a_slanted_3d_axis_label_over_a_tick_value(tmp_path):
    """A 3-D panel's x label pulled onto its axis lies over the middle tick value "0";
    measured on the slanted label, not its upright box, which covers the ticks beside
    it: the labels of a sail panel as the tools draw it touch no tick value."""
    from matplotlib.tri import Triangulation

    from sail_ros.plots.sail3d import draw_sail, label_axes, symmetric_norm

    def overlaps(pad):
        fig, ax = figure(3.6, 3.0, subplot_kw={"projection": "3d"})
        x, y = (v.ravel() for v in np.meshgrid(np.linspace(-50, 50, 9), np.linspace(-50, 50, 9)))
        vertices = np.column_stack([x, y, np.sin(x / 20.0)])
        booms = np.zeros((4, 2, 3))
        booms[:, 1, :2] = [[50, 0], [0, 50], [-50, 0], [0, -50]]
        draw_sail(ax, vertices, Triangulation(x, y).triangles, booms, z_factor=1.0,
                  norm=symmetric_norm(1.0), extent=52.0, z_limit=1.0, box_height=0.4,
                  zoom=0.85)  # fmt: skip
        label_axes(ax, "w [-]", [-1, 0, 1])
        if pad is not None:
            ax.set_xlabel("x [m]", labelpad=pad)
        return inspect(fig, tmp_path / "panel.png", DPI).overlaps

    assert ("panel 0: x label", "panel 0: x tick label '0'") in overlaps(-9.0)
    assert overlaps(None) == ()


def test_a_long_title_wraps_inside_the_figure(tmp_path, figure_checks):
    fig, ax = figure(4.0, 3.0)
    ax.plot([0, 1], [0, 1])
    ax.set(xlabel="t [s]", ylabel="tip deflection [mm]")
    titled_layout(fig, ax, "Boom-tip deflections\n" + "a long scenario description " * 6)
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


def test_snapshots_keep_their_exaggeration_unless_the_sail_would_stand_taller_than_wide():
    from sail_ros.plots.deployment import EXAGGERATION, shown_exaggeration

    # +-0.2 m drawn 20x: 8 m on a 30 m wide plane
    assert shown_exaggeration(0.2, 15.0, EXAGGERATION) == EXAGGERATION
    # +-1 m drawn 20x would stand 40 m tall: 5x draws 10 m, the round factor below 7.5x
    assert shown_exaggeration(1.0, 15.0, EXAGGERATION) == 5.0


def test_the_snapshots_mesh_samples_the_highest_membrane_mode_four_times_a_wave():
    from sail_ros.model import SailModel
    from sail_ros.model.layout import triangle_mode_indices
    from sail_ros.plots.sail3d import resolving_divisions

    model = SailModel(SailParameters(n_boom_modes=2, n_membrane_modes=181))
    highest = max(m for m, _ in triangle_mode_indices(181))  # sin(m pi xi): m half-waves
    assert resolving_divisions(model) >= 2 * highest > 12
    assert resolving_divisions(SailModel(SMALL)) == 12  # a coarse model: the least


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
        assert panel.ylabel == "samples [-]" and panel.yticks
        assert all(tick == round(tick) for tick in panel.yticks), panel.yticks
    (influence,) = checks["influence"].panels.values()
    name = summary.influence[0][0]
    unit = "mm" if input_unit(name) == "m" else input_unit(name)  # a length as the peaks
    assert influence.xlabel == f"{name} [{unit}]"
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
    tilt = next(iter(check.panels.values()))  # in mrad, as the tools print it
    assert tilt.ylabel == "hub tilt [mrad]" and tilt.ylim[1] > 1e3 * abs(tilt_x[-1])


def _short_scenario(tmp_path, name: str, duration: float):
    """config/scenario_<name>.yaml cut to `duration` [s] (its snapshots within it)."""
    import yaml

    document = yaml.safe_load((CONFIG / f"scenario_{name}.yaml").read_text())
    body = document["scenario"]
    body["duration"] = duration
    body["snapshots"] = [t for t in body["snapshots"] if t <= duration]
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def test_booms_that_move_nearly_alike_each_show_in_the_staggered_figures(tmp_path, figure_checks):
    """config/scenario_staggered.yaml: booms a and c deploy alike from the same state but
    beside different quadrants, so their tips stay within a pixel of each other without
    being equal: both are drawn, the later one dashed over the earlier (in its legend
    entry too), in deploy's figures and in the report of its log; the report's titles
    give the scenario, not the file."""
    from sail_ros.tools import deploy, report

    scenario, log = _short_scenario(tmp_path, "staggered", 12.0), tmp_path / "run.mcap"
    argv = [*SMALL_SET, "--scenario", str(scenario), "--rate", "10", "--mcap", str(log),
            "--figures", str(tmp_path / "deploy")]  # fmt: skip
    assert deploy.main(argv) == 0
    assert report.main([str(log), "--out", str(tmp_path / "report"), "--no-convergence"]) == 0
    for folder in ("deploy", "report"):
        (tips,) = assert_figure(
            tmp_path / folder / "tip_deflections.png", figure_checks
        ).panels.items()
        title, panel = tips
        assert "staggered deployment, one profile per boom" in title and "run.mcap" not in title
        assert panel.lines == ("boom a", "boom b", "boom c", "boom d")
        assert panel.styles[0] == "-" and panel.styles[2] == "--"  # c over a
    for name in ("root_moments", "boom_lengths", "modal_energies"):
        assert_figure(tmp_path / "report" / f"{name}.png", figure_checks)
    snapshots = assert_figure(tmp_path / "deploy" / "deployment_snapshots.png", figure_checks)
    assert {panel.zlabel for panel in snapshots.panels.values() if panel.zlabel} == {"w [mm]"}


def test_a_runs_load_changes_are_marked_and_its_first_loads_named(tmp_path, figure_checks):
    """config/scenario_loaded.yaml: 2 and 1 mPa on quadrants ab and cd from the start,
    0.05 N at boom b's tip from 3 to 7 s: the pressures in the titles, the force's on and
    off as dotted lines named along the top of the time histories, of deploy and of the
    report of its log."""
    from sail_ros.analysis.load_changes import LoadChange, schedule_changes
    from sail_ros.analysis.scenario import load_scenario
    from sail_ros.tools import deploy, report

    changes = schedule_changes(load_scenario(CONFIG / "scenario_loaded.yaml").loads)
    assert changes == [LoadChange(0.0, "p_ab 2 mPa, p_cd 1 mPa"),
                       LoadChange(3.0, "F_b 0.05 N"), LoadChange(7.0, "F_b off")]  # fmt: skip
    log = tmp_path / "loaded.mcap"
    argv = [*SMALL_SET, "--scenario", str(CONFIG / "scenario_loaded.yaml"), "--rate", "10",
            "--mcap", str(log), "--figures", str(tmp_path / "deploy")]  # fmt: skip
    assert deploy.main(argv) == 0
    assert report.main([str(log), "--out", str(tmp_path / "report"), "--no-convergence"]) == 0
    for path in (tmp_path / "deploy" / "tip_deflections.png",
                 tmp_path / "report" / "tip_deflections.png",
                 tmp_path / "report" / "root_moments.png",
                 tmp_path / "report" / "modal_energies.png"):  # fmt: skip
        title, panel = next(iter(assert_figure(path, figure_checks).panels.items()))
        assert title.endswith("loads from the start: p_ab 2 mPa, p_cd 1 mPa"), title
        assert panel.marks == ("F_b 0.05 N", "F_b off")


def test_a_free_hub_plants_figure_draws_its_hub_inputs_and_counts_every_mode(
    tmp_path, capsys, figure_checks
):
    """With a free hub the Bode figure adds the hub's force to its heave and torques to
    its tilts; undamped, the warning counts the modes as the coordinates (the three
    rigid-body modes among them), and the figure marks the undamped poles."""
    from sail_ros.tools import plant

    png = tmp_path / "bode.png"
    assert plant.main([*SMALL_SET, "--set", "free_hub=true", "--lengths", "30",
                       "--figure", str(png)]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert err.startswith("warning: 40 of the 43 modes (the other 3: the hub's rigid-body modes")
    check = assert_figure(png, figure_checks)
    titles = [name for name in check.panels if not name.startswith("panel")]
    assert titles == ["tip force -> tip deflection (same boom)", "tip force -> root moment "
        "(same boom)", "hub force -> hub heave", "hub torque -> hub tilt (same axis)"]  # fmt: skip
    assert check.panels["hub force -> hub heave"].ylabel == "|G| [m/N]"
    assert check.panels["hub torque -> hub tilt (same axis)"].lines == (
        "tau_x -> theta_x, tau_y -> theta_y",
    )


def test_the_stability_figures_state_their_scales(tmp_path, figure_checks):
    """The three figures of `sail-ros stability` from a serial sweep: the rate axis of the
    map is a symmetric-log one, a cell centred on each rate, and says so; the real parts'
    axis says where it is linear (round-off at rest within it)."""
    from sail_ros.analysis.stability import eigenvalue_loci, stability_sweep
    from sail_ros.plots.stability import loci_figure, map_figure, max_real_figure

    params = SailParameters(n_boom_modes=2, n_membrane_modes=3)
    prestress = np.logspace(-1, 4, 11)
    sweeps = stability_sweep(params, [20.0, 40.0], [-0.1, 0.0, 0.1, 1.0], prestress)
    paths = [
        max_real_figure(sweeps, tmp_path / "stability.png", params.membrane_prestress),
        map_figure(sweeps, tmp_path / "stability_map.png", params.membrane_prestress),
        loci_figure(
            prestress,
            eigenvalue_loci(params, 20.0, 1.0, prestress),
            20.0,
            1.0,
            tmp_path / "loci.png",
        ),  # fmt: skip
    ]
    real, stability_map, _ = (assert_figure(path, figure_checks) for path in paths)
    assert all("linear within" in p.ylabel for p in real.panels.values() if p.ylabel)
    rates = [p for name, p in stability_map.panels.items() if name.startswith("L = ")]
    assert rates and all(
        p.xlabel == "extension rate [m/s] (symlog, linear within $\\pm$0.1)" for p in rates
    )
