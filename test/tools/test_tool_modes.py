"""`sail-ros modes`: frequency table, CSV/JSON, mode-shape figures, FE cross-check."""

import csv
import json

import numpy as np
import pytest
from harness import SMALL, SMALL_SET, assert_figure

from sail_ros.analysis.modes import group_multiplicities, modal_analysis, representative_shapes
from sail_ros.model import SailModel, SailParameters
from sail_ros.tools import modes

pytestmark = pytest.mark.model


def test_table_csv_and_json_agree_with_the_model(tmp_path, capsys):
    csv_path, json_path = tmp_path / "f.csv", tmp_path / "f.json"
    assert (
        modes.main([*SMALL_SET, "--count", "8", "--csv", str(csv_path), "--json", str(json_path)])
        == 0
    )
    out = capsys.readouterr().out
    assert "2-3" in out and "multiplicity" in out and "6890 Pa" in out

    omega = SailModel(SMALL).natural_frequencies(SailParameters().full_boom_length)
    rows = list(csv.DictReader(csv_path.open()))
    assert [int(r["mode"]) for r in rows] == list(range(1, 9))
    np.testing.assert_allclose([float(r["omega_rad_s"]) for r in rows], omega[:8], rtol=1e-12)
    # the sail's four-fold symmetry: single, double, single, single, double, single
    assert [int(r["multiplicity"]) for r in rows] == [1, 2, 2, 1, 1, 2, 2, 1]

    record = json.loads(json_path.read_text())
    assert record["parameters"]["membrane_prestress"] == 6890.0
    assert record["lengths_m"] == pytest.approx([50 * np.sqrt(2)] * 4)
    assert [r["group"] for r in record["frequencies"]] == [1, 2, 2, 3, 4, 5, 5, 6]


def test_mode_shape_figure_is_a_real_picture(tmp_path, figure_checks):
    assert modes.main(["--count", "4", "--figures", str(tmp_path), "--shapes", "4"]) == 0
    assert_figure(tmp_path / "mode_shapes.png", figure_checks)


def test_three_d_view_and_unequal_lengths(tmp_path, figure_checks):
    assert (
        modes.main(
            [
                "--lengths",
                "30",
                "50",
                "30",
                "50",
                "--figures",
                str(tmp_path),
                "--shapes",
                "4",
                "--view",
                "3d",
            ]
        )
        == 0
    )
    # two columns: the colour bar clears the right column's z axis; z has its values and
    # its label
    check = assert_figure(tmp_path / "mode_shapes.png", figure_checks)
    shapes = [panel for panel in check.panels.values() if panel.zlabel]
    assert len(shapes) == 4 and {panel.zlabel for panel in shapes} == {"w [-]"}


def test_representative_of_a_double_mode_is_a_mode_with_boom_a_tip_up():
    model = SailModel(SMALL)
    found = modal_analysis(model, model.params.full_boom_length)
    number, first, multiplicity, omega, vector = representative_shapes(model, found, 2)[1]
    assert (number, first, multiplicity) == (2, 1, 2)
    M, K = model.mass_and_stiffness(model.params.full_boom_length)
    np.testing.assert_allclose(K @ vector, omega**2 * (M @ vector), atol=1e-9 * omega**2)
    assert model.tip_deflections(vector)[0] > 0


def test_group_multiplicities_uses_a_relative_tolerance():
    assert group_multiplicities([1.0, 1.0 + 1e-9, 2.0, 2.0, 2.0, 3.0]) == [(0, 2), (2, 3), (5, 1)]


def test_fem_cross_check_converges_and_agrees_within_one_percent(tmp_path, capsys):
    """Small meshes and mode counts (well under a second); `sail-ros modes --fem`
    shows the finest settings (0.06 % at n_B = n_M = 20). At these settings the FE
    frequencies are converged to ~1e-5 and the modal ones lie within 0.2 % above."""
    path, fem_csv = tmp_path / "m.json", tmp_path / "fem.csv"
    assert (
        modes.main(
            [
                "--fem",
                "--fem-level",
                "4",
                "4",
                "2",
                "--fem-level",
                "8",
                "8",
                "2",
                "--fem-level",
                "16",
                "16",
                "2",
                "--fem-modes",
                "4",
                "6",
                "--fem-modes",
                "10",
                "10",
                "--json",
                str(path),
                "--fem-csv",
                str(fem_csv),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "Difference (%)" in out and "FE mesh refinement" in out and "agree within 1 %" in out
    check = json.loads(path.read_text())["fem_cross_check"]
    levels = np.array([level["omega_rad_s"] for level in check["fem_levels"]])
    # nested meshes: every FE frequency decreases under refinement, and converges
    assert np.all(np.diff(levels, axis=0) <= 1e-12)
    assert np.all(np.abs(levels[-1] - levels[-2]) < 1e-3 * levels[-1])
    # Rayleigh-Ritz: more modes never raise a frequency
    modal = np.array([level["omega_rad_s"] for level in check["modal_levels"]])
    assert np.all(np.diff(modal, axis=0) <= 1e-12)
    assert np.max(np.abs(check["difference_percent"])) < 1.0
    rows = list(csv.DictReader(fem_csv.open()))
    assert len(rows) == 6 and float(rows[0]["fem_rad_s"]) == pytest.approx(levels[-1][0])


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--lengths", "10", "20"], "--lengths takes 1 or 4 values, got 2"),
        (["--fem", "--lengths", "30", "50", "30", "50"], "--fem needs one length for all booms"),
        (["--fem-csv", "x.csv"], "--fem-csv x.csv needs --fem"),
        (["--set", "membrane_prestress=-1"], "membrane_prestress must be in [0, 1e+10] Pa, got -1"),
    ],
    ids=["lengths", "fem-unequal", "fem-csv", "bad-parameter"],
)
def test_errors_name_the_option_and_value(argv, message, capsys):
    assert modes.main(argv) == 2
    assert message in capsys.readouterr().err


def test_a_free_hub_lists_its_rigid_zeros_and_each_elastic_group_beside_its_clamped_one(
    tmp_path, capsys
):
    """With a free hub: three rigid-body modes at exactly 0 rad/s, then each elastic
    group beside the clamped sail's group of the same shape. A hub as heavy as 1e8 kg
    (and kg m^2) is a clamp: every group beside the clamped one of its rank, sharing its
    shape, within 1e-3 of its frequency. The default 100 kg hub is light beside the
    booms' tilt inertia: it stiffens the heave mode and moves the tilting pair (clamped
    2-3) far up, which a note says; modes that leave the hub still are unchanged."""
    csv_path = tmp_path / "f.csv"
    heavy = [*SMALL_SET, "--set", "free_hub=true"] + [
        f"--set={name}=1e8" for name in ("hub_mass", "hub_inertia_x", "hub_inertia_y")
    ]
    assert modes.main([*heavy, "--count", "12", "--csv", str(csv_path)]) == 0
    out = capsys.readouterr().out
    assert "three rigid-body modes at exactly 0 rad/s" in out and "clamped modes" not in out
    rows = list(csv.DictReader(csv_path.open()))
    assert [float(r["omega_rad_s"]) for r in rows[:3]] == [0.0] * 3
    assert [r["period_s"] + r["clamped_mode"] for r in rows[:3]] == [""] * 3
    clamped = SailModel(SMALL).natural_frequencies(SailParameters().full_boom_length)
    for row in rows[3:]:  # beside the clamped group of its rank (free mode 4: clamped 1)
        rank = int(row["mode"]) - 4
        paired = clamped[int(row["clamped_mode"]) - 1]
        assert float(row["clamped_omega_rad_s"]) == pytest.approx(paired, rel=1e-12)
        assert paired == pytest.approx(clamped[rank], rel=1e-9)
        assert float(row["omega_rad_s"]) == pytest.approx(clamped[rank], rel=1e-3)
        assert float(row["shape_share"]) > 0.999

    assert modes.main([*SMALL_SET, "--set", "free_hub=true", "--count", "16"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    header = lines.index(next(line for line in lines if line.startswith("  mode ")))
    assert lines[header + 1].split() == ["1-3", "0.00000", "0.000000", "rigid", "3"]
    heave = next(line for line in lines if line.startswith("  4 ")).split()
    assert heave[5] == "1" and float(heave[7]) > 10.0  # clamped mode 1, stiffened
    still = next(line for line in lines if line.startswith("  5 ")).split()
    assert still[5] == "4" and float(still[7]) == 0.0 and still[8] == "1.000"
    note = next(line for line in lines if line.startswith("  clamped modes the free hub"))
    assert f"2-3 ({clamped[1]:.5f} rad/s) is free-hub mode" in note
