"""`sail-ros stability` and the frozen-system analysis behind it (seed Eq. 3)."""

import numpy as np
import pytest
import scipy.optimize
from harness import SMALL

from sail_ros.analysis.stability import (
    CRITICAL,
    frozen_eigenvalues,
    growth,
    is_unstable,
    prestress_sweep,
)
from sail_ros.model import SailModel
from sail_ros.tools import stability

pytestmark = pytest.mark.model

PARAMS = SMALL
L = PARAMS.full_boom_length


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


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--prestress", "10", "1"], "--prestress needs 0 < MIN < MAX [Pa], got 10 1"),
        (["--points", "1"], "--points must be >= 2, got 1"),
        (["--workers", "0", "--rates", "0.1"], "--workers must be >= 1, got 0"),
        (["--lengths", "-5"], "--lengths = -5 m is outside [min_length, max_length] = [5, 70.71"),
    ],
    ids=["range", "points", "workers", "length"],
)
def test_errors_name_the_option_and_value(argv, message, capsys):
    assert stability.main(argv) == 2
    assert message in capsys.readouterr().err
