"""A tool's text and its JSON say the same, field by field: both are rendered from one
result object, so a number printed is the number written."""

import json
import re

import numpy as np
import pytest
from harness import SMALL_SET

from sail_ros.tools import deploy, modes, plant

pytestmark = pytest.mark.model

NUMBER = r"(-?[0-9.]+(?:e[-+]?\d+)?)"


def run(main, args, capsys) -> str:
    assert main(args) == 0
    return capsys.readouterr().out


def test_deploy_text_and_json_agree(capsys):
    short = [*SMALL_SET, "--duration", "6", "--to", "12", "--every", "2"]
    text = run(deploy.main, short, capsys)
    found = json.loads(run(deploy.main, [*short, "--json"], capsys))

    assert text.splitlines()[0] == f"Deployment: {found['description']}"
    # the limits: max_length 0 stands for the full length, in both
    low, high = map(float, re.search(rf"L in \[{NUMBER}, {NUMBER}\] m", text).groups())
    limits = found["limits"]
    assert low == limits["min_length"] and high == pytest.approx(limits["max_length"], rel=1e-3)
    rate = float(re.search(rf"\|rate\| <= {NUMBER} m/s", text)[1])
    assert rate == limits["max_rate"]
    counts = re.search(r"modes n_B, n_M\s+(\d+), (\d+)", text).groups()
    assert tuple(map(int, counts)) == (found["n_boom_modes"], found["n_membrane_modes"])
    simulated = float(re.search(rf"{NUMBER} s simulated", text)[1])
    assert simulated == pytest.approx(found["duration_s"])
    steps = re.search(rf"(\d+) steps \(\d+ refused\) at rtol {NUMBER}", text).groups()
    assert (int(steps[0]), float(steps[1])) == (found["steps"], found["rtol"])
    error = re.search(rf"error estimate: tips {NUMBER} %, root moments {NUMBER} %", text)
    estimate = found["relative_error_estimate"]
    assert float(error[1]) == pytest.approx(100 * estimate["tips"], rel=0.06)
    assert float(error[2]) == pytest.approx(100 * estimate["root_moments"], rel=0.06)
    # the peaks per boom and their times, as printed (4 to 6 digits)
    rows = {
        "tip": re.search(r"\|tip deflection\| \[mm\]" + rf"\s+{NUMBER}" * 4, text).groups(),
        "moment": re.search(r"\|root moment\| \[N m\]" + rf"\s+{NUMBER}" * 4, text).groups(),
    }
    times = re.findall(r"at t \[s\]" + rf"\s+{NUMBER}" * 4, text)
    expected = {
        "tip": [1e3 * found["peak_tip_deflection_m"][b] for b in "abcd"],
        "moment": [found["peak_root_moment_Nm"][b] for b in "abcd"],
    }
    for kind, printed in rows.items():
        np.testing.assert_allclose(np.array(printed, float), expected[kind], rtol=5e-4, atol=1e-9)
    for printed, key in zip(times, ("peak_tip_deflection_time_s", "peak_root_moment_time_s"),
                            strict=True):  # fmt: skip
        np.testing.assert_allclose(
            np.array(printed, float), [found[key][b] for b in "abcd"], atol=6e-4
        )


def test_modes_text_and_json_agree(capsys, tmp_path):
    path = tmp_path / "modes.json"
    text = run(modes.main, [*SMALL_SET, "--count", "8", "--json", str(path)], capsys)
    found = json.loads(path.read_text())
    lengths = float(re.search(rf"boom lengths {NUMBER} m", text)[1])
    assert found["lengths_m"] == pytest.approx([lengths] * 4, rel=1e-3)
    printed = re.findall(rf"^  (\d+)(?:-(\d+))?\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+(\d+)$", text,
                         re.MULTILINE)  # fmt: skip
    assert printed
    by_mode = {row["mode"]: row for row in found["frequencies"]}
    for first, last, omega, hertz, period, multiplicity in printed:
        row = by_mode[int(first)]
        assert row["omega_rad_s"] == pytest.approx(float(omega), rel=1e-4)
        assert row["frequency_hz"] == pytest.approx(float(hertz), rel=1e-4)
        assert row["period_s"] == pytest.approx(float(period), rel=1e-3)
        assert row["multiplicity"] == int(multiplicity) == (int(last or first) - int(first) + 1)


def test_plant_text_and_json_agree(capsys):
    # a free hub, damped and retracting: rigid-body, growing and damped poles, both notes
    short = [*SMALL_SET, "--set", "free_hub=true", "--set", "mass_damping=0.02",
             "--lengths", "20", "22", "20", "22", "--rates", "-0.05", "--count", "12"]  # fmt: skip
    text = run(plant.main, short, capsys)
    found = json.loads(run(plant.main, [*short, "--json"], capsys))

    heading = re.match(
        r"Linear plant of the sail: lengths (.+) m, rates (.+) m/s; (\d+) states, (\d+) inputs, "
        r"(\d+) outputs",
        text,
    ).groups()
    assert [float(v) for v in heading[0].split(", ")] == pytest.approx(found["lengths_m"])
    assert [float(v) for v in heading[1].split(", ")] == pytest.approx(found["rates_m_s"])
    sizes = tuple(map(int, heading[2:]))
    assert sizes == (found["states"], found["inputs"], found["outputs"])
    counts = re.search(r"modes n_B, n_M\s+(\d+), (\d+)", text).groups()
    parameters = found["parameters"]
    assert tuple(map(int, counts)) == (parameters["n_boom_modes"], parameters["n_membrane_modes"])
    coordinates = 4 * sum(map(int, counts)) + 3  # and the free hub's three
    assert sizes == (2 * coordinates, 11, 14)
    assert float(re.search(rf"alpha = {NUMBER} 1/s", text)[1]) == parameters["mass_damping"]

    printed = re.findall(r"^\s+(\d+)" + rf"\s+{NUMBER}" * 5 + "$", text, re.MULTILINE)
    assert len(printed) == len(found["poles"]) == 12
    keys = ("real_1_s", "imag_rad_s", "omega_rad_s", "frequency_hz", "damping_ratio")
    for (index, *values), row in zip(printed, found["poles"], strict=True):
        assert int(index) == row["pole"]
        for value, key in zip(values, keys, strict=True):  # printed to 4 to 6 digits
            assert float(value) == pytest.approx(row[key], rel=6e-4, abs=1e-12), (index, key)
    assert any(row["real_1_s"] > 0 for row in found["poles"])  # retraction: growing modes
    growing = int(re.search(r"(\d+) pole\(s\) with a positive real part", text)[1])
    assert growing == found["unstable_poles"] > 0
    assert f"  note: {found['hub_note']}" in text.splitlines()
    assert found["undamped_note"] is None  # damped: no warning, in either
