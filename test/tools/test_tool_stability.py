"""`sail-ros stability` and the frozen-system analysis behind it (seed Eq. 3)."""

import csv

import numpy as np
import pytest
import scipy.optimize
from harness import assert_figure

from sail_ros.analysis.stability import (
    CRITICAL,
    STABLE,
    UNSTABLE,
    frozen_eigenvalues,
    growth,
    is_unstable,
    prestress_sweep,
    stability_sweep,
)
from sail_ros.model import SailModel, SailParameters
from sail_ros.tools import stability

pytestmark = pytest.mark.model

PARAMS = SailParameters()
L = PARAMS.full_boom_length


def test_tool_finds_instability_in_retraction_and_none_at_rest(tmp_path, capsys, figure_checks):
    """Two worker processes over a small grid; CSVs and figures hold what they claim."""
    critical, grid = tmp_path / "critical.csv", tmp_path / "grid.csv"
    assert (
        stability.main(
            [
                "--rates",
                "-0.1",
                "0",
                "0.1",
                "1",
                "--prestress",
                "1",
                "1e4",
                "--points",
                "9",
                "--workers",
                "2",
                "--csv",
                str(critical),
                "--grid-csv",
                str(grid),
                "--figures",
                str(tmp_path),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "unstable at every prestress" in out and "stable at every prestress" in out

    rows = {float(r["rate_m_s"]): r for r in csv.DictReader(critical.open())}
    assert rows[-0.1]["status"] == UNSTABLE
    assert rows[0.0]["status"] == STABLE
    assert rows[0.1]["status"] == rows[1.0]["status"] == CRITICAL
    # the membrane's N term scales with rate^2, so does the critical prestress
    ratio = float(rows[1.0]["critical_prestress_pa"]) / float(rows[0.1]["critical_prestress_pa"])
    assert ratio == pytest.approx(100.0, rel=0.02)
    # at the sail's own 6890 Pa: retraction grows, deployment decays, rest is neutral
    assert float(rows[-0.1]["max_real_at_sail_prestress_1_s"]) > 1e-4
    assert float(rows[0.1]["max_real_at_sail_prestress_1_s"]) < -1e-4
    assert abs(float(rows[0.0]["max_real_at_sail_prestress_1_s"])) < 1e-12

    points = list(csv.DictReader(grid.open()))
    assert len(points) == 4 * 9
    at_rest = [p for p in points if float(p["rate_m_s"]) == 0.0]
    assert not any(p["unstable"] == "True" for p in at_rest)
    assert all(p["unstable"] == "True" for p in points if float(p["rate_m_s"]) < 0)
    # one length: the narrowest map, whose legend ran off its sides in one row
    for name in ("stability", "stability_map", "eigenvalue_loci"):
        assert_figure(tmp_path / f"{name}.png", figure_checks)


def test_critical_prestress_separates_unstable_from_stable():
    sweep = prestress_sweep(PARAMS, L, 0.3, np.logspace(0, 4, 9))
    assert sweep.status == CRITICAL and sweep.monotone
    sigma = sweep.critical_prestress
    assert is_unstable(*growth(PARAMS, L, 0.3, sigma * 0.99))
    assert not is_unstable(*growth(PARAMS, L, 0.3, sigma * 1.01))


def test_round_off_at_zero_rate_is_not_instability():
    """Exact eigenvalues are +-i omega; computed real parts are round-off of either sign,
    orders of magnitude below the threshold (1e-9 max |lambda|)."""
    eigenvalues = frozen_eigenvalues(PARAMS, L, 0.0, PARAMS.membrane_prestress)
    assert abs(eigenvalues.real).max() < 1e-13 * abs(eigenvalues).max()
    assert not is_unstable(eigenvalues.real.max(), abs(eigenvalues).max())


def test_retraction_growth_tends_to_rate_over_length():
    """Md = rho Ld <psi psi^T> with M = rho L <psi psi^T>: negative damping |Ld| / L."""
    max_real, _ = growth(PARAMS, L, -0.05, 1e6)
    assert max_real == pytest.approx(0.05 / L, rel=0.02)


def test_the_prestress_scaling_equals_a_model_rebuilt_at_that_prestress():
    params = PARAMS.replace(mass_damping=0.01, stiffness_damping=1e-3)
    for prestress in (10.0, 3000.0):
        rebuilt = SailModel(params.replace(membrane_prestress=prestress)).eigenvalues(L, 0.1)
        scaled = frozen_eigenvalues(params, L, 0.1, prestress)
        # matched by nearest value: sorting would order a double eigenvalue's two copies
        # by their round-off
        rows, columns = scipy.optimize.linear_sum_assignment(
            np.abs(scaled[:, None] - rebuilt[None, :])
        )
        assert np.array_equal(rows, np.arange(rebuilt.size))
        assert np.allclose(scaled[rows], rebuilt[columns], atol=1e-11 * np.abs(rebuilt).max())


def test_serial_and_dask_sweeps_agree():
    from sail_ros.tools.cluster import dask_client

    grid = np.logspace(0, 3, 4)
    serial = stability_sweep(PARAMS, [L, 20.0], [-0.1, 0.1], grid)
    with dask_client(workers=2) as client:
        parallel = stability_sweep(PARAMS, [L, 20.0], [-0.1, 0.1], grid, client=client)
    for a, b in zip(serial, parallel, strict=True):
        assert (a.length, a.rate, a.status) == (b.length, b.rate, b.status)
        np.testing.assert_array_equal(a.max_real, b.max_real)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--prestress", "10", "1"], "--prestress needs 0 < MIN < MAX [Pa], got 10 1"),
        (["--points", "1"], "--points must be >= 2, got 1"),
        (["--workers", "0", "--rates", "0.1"], "--workers must be >= 1, got 0"),
        (["--lengths", "-5"], "--lengths = -5 m is outside [min_length, max_length] = [1, 70.71"),
    ],
    ids=["range", "points", "workers", "length"],
)
def test_errors_name_the_option_and_value(argv, message, capsys):
    assert stability.main(argv) == 2
    assert message in capsys.readouterr().err
