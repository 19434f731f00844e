"""Samples between moving steps: the continuous extension of the Padé step
(`SailStepper.between`) and the grid sampler built on it (`GridSampler`)."""

import numpy as np
import pytest
import scipy.linalg
from harness import SMALL

from sail_ros.integrate.rational import PADE_POLES, PADE_WEIGHTS, extension_weights
from sail_ros.integrate.sampling import GridSampler
from sail_ros.model import CycloidalProfile, SailModel, SailParameters, StaticProfile
from sail_ros.model.assembly import GYROSCOPIC, MASS, STIFFNESS_CANONICAL
from sail_ros.model.loads import inputs

pytestmark = pytest.mark.model


def extension(fraction, z):
    (c,), (w,) = extension_weights(fraction)
    return c + sum(wk / (1 - z / zk) + np.conj(wk) / (1 - z / np.conj(zk))
                   for wk, zk in zip(w, PADE_POLES, strict=True))  # fmt: skip


def test_the_extension_is_the_pade_step_at_its_end_and_amplifies_no_mode():
    (c,), (w,) = extension_weights(1.0)
    assert c == pytest.approx(1.0, abs=1e-12) and w == pytest.approx(PADE_WEIGHTS, rel=1e-12)
    y = np.concatenate([np.linspace(0.0, 50.0, 20001), np.geomspace(50.0, 1e8, 2000)])
    for k in range(2, 6):
        for j in range(1, k):
            f = j / k
            R = extension(f, 1j * y)
            assert np.abs(R).max() <= 1.0 + 1e-12, f
            # order 4: the error of a resolved mode falls as (omega h)^5
            small = y[(y > 0) & (y <= 0.5)]
            error = np.abs(extension(f, 1j * small) - np.exp(1j * f * small))
            assert np.all(error <= 1e-4 * small**5 + 1e-14), f
            # damped modes decay
            assert np.abs(extension(f, -1.0 + 1j * y)).max() < 1.0


def test_samples_inside_a_moving_step_are_the_extension_of_the_frozen_system():
    """Booms held still by a plain callable (so every step takes the Padé path) under a
    constant tip force: the system is `xd = B x + f` with `B` constant, and each sample
    inside a step is `x_s + R_f(h B) (x0 - x_s)`, `x_s = -B^-1 f`, evaluated here from
    the eigenvectors of `B` (to round-off)."""
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=2))
    n, lengths, zero = model.n, np.full(4, 12.0), np.zeros(4)
    u = inputs(0.0, [0.0, 0.02, 0.0, 0.0])
    stepper = model.stepper(
        lambda t: (lengths, zero, zero),
        q0=model.initial_coordinates([0.1, 0.0, -0.05, 0.0]),
        max_step=0.05,
        inputs=lambda t: u,
        rtol=None,  # single rational steps, whose extension this checks
    )
    sampler = GridSampler(stepper, 0.01)
    M, G, K = model.assemble((MASS, GYROSCOPIC, STIFFNESS_CANONICAL), lengths, zero, zero)
    Minv = np.linalg.inv(M)
    B = np.block([[-Minv @ G, Minv], [-G.T @ Minv @ G - K, G.T @ Minv]])
    force = np.concatenate([np.zeros(n), model.assemble_inputs(lengths) @ u])
    x_s = -np.linalg.solve(B, force)
    lam, V = scipy.linalg.eig(0.05 * B)
    for _ in range(3):  # three steps of five samples
        start = sampler.point
        x0 = np.concatenate([start.q, M @ start.qd + G @ start.q]) - x_s
        for j in range(1, 6):
            point = sampler.advance()
            assert point.t == pytest.approx(start.t + 0.01 * j, abs=1e-12)
            x = x_s + (V @ (extension(j / 5, lam) * np.linalg.solve(V, x0))).real
            scale = np.abs(x0).max()
            assert point.q == pytest.approx(x[:n], abs=1e-11 * scale)
            assert point.qd == pytest.approx(Minv @ (x[n:] - G @ x[:n]), abs=1e-9 * scale)
        assert stepper.t == pytest.approx(point.t, abs=1e-12)  # the step's end: exact
    assert stepper.steps_taken == 3


def test_the_sampled_deployment_keeps_the_accuracy_bar():
    """The reference deployment sampled every 0.01 s from 0.05 s steps, against 0.002 s
    steps: the tips within 0.05 % of their peak (the bar is 0.2 %; measured 0.01 %)."""
    model = SailModel(SMALL)
    profile, q0 = CycloidalProfile(10.0, 12.0, 4.0), model.initial_coordinates([0.1, 0, 0, 0])
    t, q, qd = model.simulate_on_grid(profile, 5.0, 0.01, q0, max_step=0.05)
    _, reference, _ = model.simulate(profile, 5.0, q0, t_eval=t, max_step=0.002)
    tips, expected = model.tip_deflections(q), model.tip_deflections(reference)
    assert np.abs(tips - expected).max() <= 5e-4 * np.abs(expected).max()
    assert np.diff(t) == pytest.approx(0.01, abs=1e-12) and t[-1] == pytest.approx(5.0)


def test_at_rest_every_sample_is_one_exact_step():
    model = SailModel(SMALL)
    q0 = model.initial_coordinates([0.1, 0, 0, 0])
    stepper = model.stepper(StaticProfile(10.0), q0=q0)
    sampler = GridSampler(stepper, 0.01)
    for _ in range(30):
        point = sampler.advance()
    assert stepper.steps_taken == 30 and point.t == pytest.approx(0.3)
    _, q, qd = model.simulate(StaticProfile(10.0), 0.3, q0, t_eval=[0.3], max_step=0.01)
    assert point.q == pytest.approx(q[0], abs=1e-14) and point.qd == pytest.approx(qd[0], abs=1e-13)


def test_a_steps_extension_is_freed_with_the_step_not_left_to_the_garbage_collector():
    """An `Extension` holds its `Curves`; the curves must not hold it back (a reference
    cycle kept each step's matrices alive until a collection: the live grid's moving
    steps at (20, 20) took 13 % longer)."""
    import gc
    import weakref

    model = SailModel(SMALL)
    stepper = model.stepper(CycloidalProfile(10.0, 15.0, 20.0), q0=model.mode_state("a", 0.1))
    stepper.advance_step(1.0)
    extension = stepper.last_curve()
    assert extension.count  # its followed modes: the curves' padded arrays are made
    stepper.between([0.5], *[stepper.qd] * 2)
    extension.curve([0.25, 0.75], None)
    freed = weakref.ref(extension)
    del extension
    gc.disable()
    try:
        stepper.advance_step(2.0)
        stepper.between([0.5], *[stepper.qd] * 2)  # the next step's extension
        assert freed() is None
    finally:
        gc.enable()
