"""`sail-ros plant`: poles, matrices to .npz and .mat with names, a Bode figure; the
matrices load into python-control with the same poles."""

import control
import numpy as np
import pytest
import scipy.io
from harness import SMALL, SMALL_SET, assert_figure

from sail_ros.analysis.plant import frequency_response, linear_plant, poles
from sail_ros.model import SailModel, SailParameters
from sail_ros.model.loads import INPUT_NAMES, OUTPUT_NAMES
from sail_ros.plots.plant import wrapped_phase
from sail_ros.tools.plant import main

pytestmark = pytest.mark.model

DAMPED = ["--set", "mass_damping=0.02", "--set", "stiffness_damping=1e-3"]


def test_plant_writes_matrices_that_python_control_loads_with_equal_poles(
    tmp_path, capsys, figure_checks
):
    npz, mat, png = tmp_path / "p.npz", tmp_path / "p.mat", tmp_path / "bode.png"
    code = main([*SMALL_SET, "--lengths", "20", "22", "20", "22", "--rates", "0.05", *DAMPED,
                 "--npz", str(npz), "--mat", str(mat), "--figure", str(png)])  # fmt: skip
    assert code == 0
    captured = capsys.readouterr()
    assert "80 states, 8 inputs, 8 outputs" in captured.out and f"wrote {png}" in captured.out
    assert captured.err == ""  # damped: no warning

    saved = np.load(npz)
    assert list(saved["input_names"]) == list(INPUT_NAMES)
    assert list(saved["output_names"]) == list(OUTPUT_NAMES)
    assert saved["state_names"][0] == "boom_a_mode_1" and len(saved["state_names"]) == 80
    matlab = scipy.io.loadmat(mat)
    assert [str(v[0]) for v in matlab["input_names"].ravel()] == list(INPUT_NAMES)
    assert np.array_equal(matlab["A"], saved["A"]) and np.array_equal(matlab["B"], saved["B"])

    system = control.ss(matlab["A"], matlab["B"], matlab["C"], matlab["D"])
    ours = np.linalg.eigvals(saved["A"])
    theirs = system.poles()
    key = lambda s: (round(s.imag, 6), round(s.real, 9))  # noqa: E731
    assert np.allclose(sorted(ours, key=key), sorted(theirs, key=key), rtol=1e-9, atol=1e-12)
    assert saved["poles_on_imaginary_axis"] == 0 and str(saved["note"]) == ""
    assert saved["mass_damping_1_s"] == 0.02 and matlab["stiffness_damping_s"] == 1e-3

    # booms a, c (20 m) respond alike, and b, d (22 m): one line each, in every panel
    check = assert_figure(png, figure_checks)
    for panel in check.panels.values():
        assert len(panel.lines) == 2
    magnitude = check.panels["tip force -> tip deflection (same boom)"]
    assert magnitude.lines == ("booms a, c", "booms b, d")
    phases = [p for name, p in check.panels.items() if name.startswith("panel")]
    assert [p.ylim for p in phases] == [(-285.0, 105.0)] * 2


def test_poles_carry_the_rayleigh_damping_ratio_and_the_response_its_dc_gain():
    params = SMALL.replace(mass_damping=0.02, stiffness_damping=1e-3)
    model = SailModel(params)
    plant = linear_plant(model, 25.0)
    listed = poles(plant)
    omega = model.natural_frequencies(25.0)
    assert [p.omega for p in listed[:8]] == pytest.approx(omega[:8], rel=1e-9)
    assert [p.zeta for p in listed[:8]] == pytest.approx(0.01 / omega[:8] + 5e-4 * omega[:8])
    static = model.static_deflection(25.0, tip_forces=[0.0, 1.0, 0.0, 0.0])
    response = frequency_response(plant, [1e-9])[0]
    column = list(INPUT_NAMES).index("tip_force_b")
    assert response[list(OUTPUT_NAMES).index("tip_deflection_b"), column].real == pytest.approx(
        model.tip_deflections(static)[1], rel=1e-6
    )


def test_an_undamped_plant_says_so_in_one_line_in_its_files_and_its_figure(
    tmp_path, capsys, figure_checks
):
    npz, mat, png = tmp_path / "p.npz", tmp_path / "p.mat", tmp_path / "bode.png"
    small = ["--set", "n_boom_modes=2", "--set", "n_membrane_modes=2"]  # 16 modes
    assert main([*small, "--npz", str(npz), "--mat", str(mat), "--figure", str(png)]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("warning: 16 of the 16 modes have their poles ")
    assert "--set mass_damping=ALPHA --set stiffness_damping=BETA" in err
    assert "docs/model.md §12" in err
    saved, matlab = np.load(npz), scipy.io.loadmat(mat)
    assert saved["poles_on_imaginary_axis"] == 16 and matlab["poles_on_imaginary_axis"] == 16
    assert f"warning: {saved['note']}\n" == err
    assert str(matlab["note"][0]) == str(saved["note"])
    assert saved["mass_damping_1_s"] == 0.0 and saved["stiffness_damping_s"] == 0.0

    check = assert_figure(png, figure_checks)
    assert all(len(p.lines) == 1 for p in check.panels.values())  # four booms alike
    assert check.panels["tip force -> tip deflection (same boom)"].lines == ("booms a, b, c, d",)
    phases = [p for name, p in check.panels.items() if name.startswith("panel")]
    assert [p.ylim for p in phases] == [(-285.0, 105.0)] * 2


def test_the_phase_is_wrapped_into_one_turn_and_breaks_where_it_wraps():
    f = np.geomspace(0.01, 10.0, 400)
    lag = np.linspace(0.0, -700.0, f.size)  # a phase falling two turns
    frequencies, phase = wrapped_phase(f, np.exp(1j * np.radians(lag)))
    finite = np.isfinite(phase)
    assert np.all((phase[finite] > -270.0) & (phase[finite] <= 90.0 + 1e-9))
    assert np.sum(~finite) == 2  # it wraps at -270 and -630
    assert np.array_equal(np.isnan(frequencies), ~finite)
    turns = (phase[finite] - lag) / 360.0  # the same angle: whole turns apart
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-12)
    np.testing.assert_array_equal(frequencies[finite], f)
    # an undamped response is real: 0 or -180 exactly, never flipping to +180, and the
    # line breaks where it flips (a pole or a zero between the points)
    _, real = wrapped_phase(f[:3], np.array([2.0, -3.0, -1e-300]))
    assert real[0] == 0.0 and np.isnan(real[1]) and real[2:].tolist() == [-180.0, -180.0]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--lengths", "1", "2"], "--lengths takes 1 or 4 values, got 2"),
        (["--rates", "0", "0", "0"], "--rates takes 1 or 4 values, got 3"),
        (["--lengths", "-3"], "--lengths of boom a = -3 m is outside [min_length, max_length]"),
        ([*SMALL_SET, "--count", "0"], "--count must be in [1, 80]"),
        (["--band", "2", "1"], "--band needs 0 < F_MIN < F_MAX"),
        (["--set", "mass_damping=-1"], "mass_damping must be in [0, 1e+06] 1/s, got -1"),
    ],
    ids=str,
)
def test_bad_options_are_one_line_and_exit_2(args, message, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


def test_modes_reports_the_damping_ratio_when_damping_is_set(tmp_path, capsys):
    from sail_ros.tools.modes import main as modes

    csv = tmp_path / "modes.csv"
    damping = ["--set", "mass_damping=0.01", "--set", "stiffness_damping=0.01"]
    assert modes(["--count", "4", *damping, "--csv", str(csv)]) == 0
    assert "zeta" in capsys.readouterr().out
    rows = [line.split(",") for line in csv.read_text().splitlines()]
    header, first = rows[0], rows[1]
    omega = float(first[header.index("omega_rad_s")])
    assert float(first[header.index("damping_ratio")]) == pytest.approx(
        0.01 / (2 * omega) + 0.01 * omega / 2, rel=1e-12
    )
    assert modes(["--count", "4"]) == 0 and "zeta" not in capsys.readouterr().out


def test_a_free_hub_plant_has_11_inputs_14_outputs_with_names_and_its_double_integrators(
    tmp_path, capsys
):
    """With a free hub: the 11-input, 14-output plant, every name in .npz and .mat, which
    python-control takes with its names; six poles at s = 0 (the hub's rigid-body modes,
    which no Rayleigh damping moves: not counted as undamped), a note saying the hub
    outputs hold double integrators; the low-frequency gain of the hub force to z_h is
    -1/(m w^2) with m the whole sail's mass (-40 dB/dec), and of torque_x to
    theta_x -1/(J_x w^2)."""
    from sail_ros.model.loads import HUB_INPUT_NAMES, HUB_OUTPUT_NAMES

    npz, mat = tmp_path / "p.npz", tmp_path / "p.mat"
    hub = ["--set", "free_hub=true", "--set", "n_boom_modes=2", "--set", "n_membrane_modes=2"]
    assert main([*hub, *DAMPED, "--lengths", "30", "--npz", str(npz), "--mat", str(mat)]) == 0
    captured = capsys.readouterr()
    assert "38 states, 11 inputs, 14 outputs" in captured.out
    assert (
        "note: the hub outputs (hub_heave, hub_tilt_x, hub_tilt_y and their rates) hold "
        "double integrators: 6 poles at s = 0" in captured.out
    )
    assert "-40 dB/dec" in captured.out and captured.err == ""  # damped: no warning

    saved, matlab = np.load(npz), scipy.io.loadmat(mat)
    inputs, outputs = (*INPUT_NAMES, *HUB_INPUT_NAMES), (*OUTPUT_NAMES, *HUB_OUTPUT_NAMES)
    assert list(saved["input_names"]) == list(inputs) and len(inputs) == 11
    assert list(saved["output_names"]) == list(outputs) and len(outputs) == 14
    assert [str(v[0]) for v in matlab["output_names"].ravel()] == list(outputs)
    assert [str(v[0]) for v in matlab["input_units"].ravel()][8:] == ["N", "N m", "N m"]
    assert saved["rigid_body_poles"] == 6 and saved["poles_on_imaginary_axis"] == 0
    assert str(matlab["hub_note"][0]) == str(saved["hub_note"])

    names = {"inputs": list(saved["input_names"]), "outputs": list(saved["output_names"])}
    system = control.ss(saved["A"], saved["B"], saved["C"], saved["D"], **names)
    assert system.ninputs == 11 and system.noutputs == 14
    assert system.input_labels[8] == "hub_force_z" and system.output_labels[9] == "hub_tilt_x"
    assert np.sum(np.abs(system.poles()) < 1e-9) == 6

    model = SailModel(SailParameters(free_hub=True, n_boom_modes=2, n_membrane_modes=2))
    M = model.mass_and_stiffness(30.0)[0]
    rigid = M[model.hub_slice, model.hub_slice]  # the whole sail moving with the hub
    w = 1e-4
    response = frequency_response(linear_plant(model, 30.0), [w])[0]
    heave = response[outputs.index("hub_heave"), inputs.index("hub_force_z")]
    tilt = response[outputs.index("hub_tilt_x"), inputs.index("hub_torque_x")]
    assert heave.real == pytest.approx(-1.0 / (rigid[0, 0] * w**2), rel=1e-5)
    assert tilt.real == pytest.approx(-1.0 / (rigid[1, 1] * w**2), rel=1e-5)
