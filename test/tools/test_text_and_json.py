"""A tool's text and its JSON say the same, field by field: both are rendered from one
result object, so a number printed is the number written."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from harness import CONFIG, SMALL_SET

from sail_ros.tools import deploy, modes, plant, report

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


CELL = r"([-+]?[0-9.]+(?:e[-+]?\d+)?|-)"  # a peak table's cell: a dash where there is no number
PEAK_ROW = re.compile(rf"^ {{4,}}(\S.*?)\s+{CELL}\s+{CELL}\s+{CELL}\s+{CELL}$")


def peak_rows(lines) -> list[tuple[str, list[float]]]:
    """The rows of the first peak table in `lines` (`print_peak_table`): label and cells,
    NaN for a dash."""
    rows = []
    for line in lines[1:]:  # the table's head row names the booms
        found = PEAK_ROW.match(line)
        if not found:
            break
        cells = [np.nan if cell == "-" else float(cell) for cell in found.groups()[1:]]
        rows.append((found[1].strip(), cells))
    return rows


def expected_rows(peaks: dict, convergence: dict | None = None) -> list:
    """The rows the text's peak table holds of a JSON peaks object, and their precision."""

    def boom_values(values, scale=1.0):
        return [np.nan if values[b] is None else scale * values[b] for b in "abcd"]

    rows = []
    for kind, label, scale, digits in (
        ("tip_deflection", "|tip deflection| [mm]", 1e3, 5e-5),
        ("root_moment", "|root moment| [N m]", 1.0, 0),
    ):
        unit = "m" if kind == "tip_deflection" else "Nm"
        rows.append((label, boom_values(peaks[f"peak_{kind}_{unit}"], scale), digits))
        rows.append(("at t [s]", boom_values(peaks[f"peak_{kind}_time_s"]), 5e-4))
        if convergence is not None:
            for own, of in (("", "the largest"), ("_own", "its own peak")):
                change = boom_values(convergence[f"{kind}_change{own}"], 100.0)
                against = f"({convergence['n_boom_modes']}, {convergence['n_membrane_modes']})"
                rows.append((f"change against {against} modes, % of {of}", change, 5e-4))
    return rows


def assert_table(lines, peaks, convergence=None):
    printed, expected = peak_rows(lines), expected_rows(peaks, convergence)
    assert [label for label, _ in printed] == [label for label, _, _ in expected]
    for (label, cells), (_, values, atol) in zip(printed, expected, strict=True):
        # 5 significant digits where no fixed decimals are printed
        np.testing.assert_allclose(cells, values, rtol=5e-5 if not atol else 0, atol=atol,
                                   err_msg=label)  # fmt: skip


def test_report_text_and_json_agree(tmp_path, capsys):
    """A small deploy log's report, with its rerun on a finer model: each number the text
    prints is the JSON's, to the digits printed; the warnings and the files written too."""
    log = tmp_path / "run.mcap"
    assert deploy.main([*SMALL_SET, "--t-end", "2", "--rate", "10", "--mcap", str(log)]) == 0
    capsys.readouterr()
    assert report.main([str(log), "--out", str(tmp_path / "text")]) == 0
    text, warnings = capsys.readouterr()
    assert report.main([str(log), "--out", str(tmp_path / "json"), "--json"]) == 0
    out, err = capsys.readouterr()
    found = json.loads(out)
    assert err == warnings and warnings.splitlines() == found["warnings"]
    assert "peaks not converged" in warnings  # (4, 6) modes against (8, 9)
    lines = text.splitlines()

    assert lines[0] == f"Log {found['log']}" and found["incomplete"] == []
    topics = re.findall(r"^  (/\S+): (\d+) messages$", text, re.MULTILINE)
    assert {topic: int(count) for topic, count in topics} == found["topics"]
    tips = found["tip_deflections"]
    printed = re.search(rf"tip deflections: {NUMBER} \.\. {NUMBER} s, peak \|tip\| {NUMBER} mm",
                        text).groups()  # fmt: skip
    np.testing.assert_allclose(
        np.array(printed, float), [tips["t_first_s"], tips["t_last_s"], 1e3 * tips["peak_m"]],
        atol=5e-4,
    )  # fmt: skip
    moments = re.search(rf"root moments: peak \|M\| {NUMBER} N m \(n_B = (\d+)\)", text)
    assert float(moments[1]) == pytest.approx(found["root_moments"]["peak_N_m"], rel=5e-4)
    assert int(moments[2]) == found["root_moments"]["n_boom_modes"]
    lengths = re.search(rf"boom lengths: {NUMBER} \.\. {NUMBER} m", text).groups()
    np.testing.assert_allclose(np.array(lengths, float),
                               list(found["boom_lengths"].values()), atol=5e-4)  # fmt: skip
    assert "  parameter changes: none recorded" in lines
    assert found["parameter_changes"] == {"source": "", "changes": []}

    # the peaks between the logged samples, and what the sampling cannot follow
    peaks = found["peaks"]
    first = next(i for i, line in enumerate(lines) if "peaks per boom from the logged" in line)
    every = float(re.search(rf"every {NUMBER} ms", lines[first])[1])
    assert every == pytest.approx(1e3 * peaks["spacing_s"], rel=5e-4)
    assert lines[first].endswith("interpolated with the logged rates (cubic Hermite):")
    assert peaks["interpolated"] == {"tip_deflection": True, "root_moment": True}
    assert_table(lines[first + 1 :], peaks)
    unresolved = re.search(
        rf"boom modes from {NUMBER} Hz up .*more than {NUMBER} rad .* carry up to "
        + ", ".join([rf"{NUMBER} %"] * 4),
        text,
    ).groups()  # fmt: skip
    assert float(unresolved[0]) == pytest.approx(peaks["unresolved"]["frequency_hz"], rel=5e-3)
    assert float(unresolved[1]) == peaks["unresolved"]["phase_rad"]
    shares = [100 * peaks["unresolved"]["root_moment_share"][b] for b in "abcd"]
    np.testing.assert_allclose(np.array(unresolved[2:], float), shares, rtol=5e-2)

    # the rerun's true peaks and their change on the finer model
    rerun = found["rerun"]
    first = next(i for i, line in enumerate(lines) if line.startswith("  a rerun of"))
    said = re.search(rf"a rerun of (.+) reproduces the logged tips to {NUMBER} of", lines[first])
    assert said[1] == rerun["of"] == "the recorded scenario" and rerun["runs"] == 1
    assert float(said[2]) == pytest.approx(rerun["agreement"], abs=5e-3)
    assert_table(lines[first + 1 :], rerun, rerun["convergence"])
    assert not rerun["convergence"]["converged"]

    # the energies, with the sail they were computed for
    energies = found["energies"]
    assert "  energies use the sail parameters recorded in the log:" in lines
    assert energies["parameters_recorded"]
    counts = re.search(r"modes n_B, n_M\s+(\d+), (\d+)", text).groups()
    parameters = energies["parameters"]
    assert tuple(map(int, counts)) == (parameters["n_boom_modes"], parameters["n_membrane_modes"])
    energy = re.search(rf"mechanical energy: {NUMBER} J at t = {NUMBER} s, {NUMBER} J at t = "
                       rf"{NUMBER} s", text).groups()  # fmt: skip
    for printed, key in zip(energy, ("first_J", "first_t_s", "last_J", "last_t_s"), strict=True):
        # 4 significant digits of an energy, 3 decimals of a time
        close = {"rel": 5e-4} if key.endswith("_J") else {"abs": 5e-4}
        assert float(printed) == pytest.approx(energies[key], **close)
    assert found["real_time_factor"] is None
    assert f"  {found['not_available']['real_time_factor']}" in lines

    written = [line.split()[1] for line in lines if line.startswith("wrote ")]
    assert [Path(path).name for path in written] == [Path(p).name for p in found["written"]]
    assert all(Path(path).is_file() for path in found["written"])
    assert found["error"] == "" and "NaN" not in out


def hub_rows(hub: dict) -> list:
    """The rows the text's free hub table holds of a JSON hub object [mm, mrad; s]."""
    names = ("heave", "tilt_x", "tilt_y", "tilt")
    units = ("m", "rad", "rad", "rad")
    return [
        ("peak", [1e3 * hub[f"peak_{n}_{u}"] for n, u in zip(names, units, strict=True)], 5e-5),
        ("at t [s]", [hub[f"peak_{name}_time_s"] for name in names], 5e-4),
    ]


def test_report_text_and_json_agree_on_a_free_hub_and_its_commands(tmp_path, capsys,
                                                                   monkeypatch):  # fmt: skip
    """config/scenario_free_hub_control.yaml cut to 0.5 s at (n_B, n_M) = (2, 2): the hub's
    range, its commands and its peaks, in the log and in the rerun of the closed loop (the
    figures, which test_tool_report.py checks, left out)."""
    monkeypatch.setattr(report, "_figures", lambda found, folder: None)
    document = yaml.safe_load((CONFIG / "scenario_free_hub_control.yaml").read_text())
    document["scenario"] |= {"duration": 0.5, "snapshots": [0.0, 0.5]}
    scenario, log = tmp_path / "short.yaml", tmp_path / "closed.mcap"
    scenario.write_text(yaml.safe_dump(document))
    counts = ["--set", "n_boom_modes=2", "--set", "n_membrane_modes=2"]
    argv = ["--scenario", str(scenario), "--rate", "20", "--mcap", str(log), *counts]
    assert deploy.main(argv) == 0
    capsys.readouterr()
    text = run(report.main, [str(log), "--out", str(tmp_path / "t"), "--no-convergence"], capsys)
    found = json.loads(run(report.main, [str(log), "--out", str(tmp_path / "j"),
                                         "--no-convergence", "--json"], capsys))  # fmt: skip
    lines = text.splitlines()

    hub = re.search(rf"free hub: \|z_h\| up to {NUMBER} mm, tilt \|theta\| up to {NUMBER} mrad "
                    rf"\({NUMBER} deg\)", text).groups()  # fmt: skip
    heave, tilt = found["hub"]["peak_heave_m"], found["hub"]["peak_tilt_rad"]
    np.testing.assert_allclose(np.array(hub, float), [1e3 * heave, 1e3 * tilt, np.degrees(tilt)],
                               rtol=5e-3)  # fmt: skip
    commands = re.search(rf"hub wrench commands: (\d+), peak \|F_z\| {NUMBER} N, \|tau_x\| "
                         rf"{NUMBER} N m, \|tau_y\| {NUMBER} N m", text).groups()  # fmt: skip
    wrench = found["hub_commands"]
    assert int(commands[0]) == wrench["count"] == found["topics"]["/sail/hub_wrench_cmd"]
    np.testing.assert_allclose(
        np.array(commands[1:], float),
        [wrench["peak_F_z_N"], wrench["peak_tau_x_N_m"], wrench["peak_tau_y_N_m"]],
        rtol=5e-4,
    )
    for head, peaks in (
        ("    free hub, interpolated with the logged rates", found["peaks"]["hub"]),
        ("    free hub (true peaks of the rerun):", found["rerun"]["hub"]),
    ):
        first = next(i for i, line in enumerate(lines) if line.startswith(head))
        printed, expected = peak_rows(lines[first + 1 :]), hub_rows(peaks)
        assert [label for label, _ in printed] == [label for label, _, _ in expected]
        for (label, cells), (_, values, atol) in zip(printed, expected, strict=True):
            np.testing.assert_allclose(cells, values, atol=atol, err_msg=label)
    assert "convergence" not in found["rerun"]  # --no-convergence
