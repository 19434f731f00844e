"""True peaks: taken inside every integration step, against a closed form, a sine, and a
1 kHz sampling of the same run (unloaded and loaded, moving and at rest)."""

import numpy as np
import pytest
import scipy.linalg
from harness import SMALL

from sail_ros.integrate.peaks import PEAK_ERROR, OutputPeaks, PeakSearch
from sail_ros.integrate.rational import Curves
from sail_ros.model import CycloidalProfile, SailModel, SailParameters, StaticProfile
from sail_ros.model.loads import LoadSchedule

pytestmark = pytest.mark.model


def test_hermite_between_samples_finds_a_sine_peak_within_its_error_bound():
    """A sine sampled every 0.5 rad, its crest midway between two samples: the peak is
    found to < 2e-4 (the bound `peaks` states), where the largest sample misses it by
    1 - cos(0.25) = 3 %."""
    omega, phase = 7.0, np.pi / 2 - 1.25  # the crest at 2.5 sample intervals
    t = np.arange(0.0, np.pi / omega, 0.5 / omega)  # one crest
    y = np.sin(omega * t + phase)[:, None]
    yd = omega * np.cos(omega * t + phase)[:, None]
    search = PeakSearch(1)
    search.add(t[:3], y[:3], yd[:3])
    search.add(t[3:], y[3:], yd[3:])  # the chunks join: the crest lies between them
    assert np.abs(y).max() == pytest.approx(np.cos(0.25))
    assert search.value[0] == pytest.approx(1.0, abs=2e-4)
    assert search.time[0] == pytest.approx(1.25 / omega, abs=1e-3 / omega)


def test_a_single_mode_at_rest_peaks_at_its_amplitude_every_half_period():
    """Constant lengths, no damping, the sail started in one natural mode `v` with
    amplitude A: q(t) = A v cos(omega t), so each tip's peak is A |psi(1)^T v_k| and each
    root moment's A EI |psi''(0)^T v_k| / L^2, at multiples of pi / omega."""
    model = SailModel(SailParameters(n_boom_modes=3, n_membrane_modes=3))
    lengths = np.array([12.0, 13.0, 12.5, 11.0])
    M, K = model.mass_and_stiffness(lengths)
    lam, V = scipy.linalg.eigh(K, M)
    tips_of_modes = np.abs(model.tip_deflections(V.T))  # (n, 4)
    mode = int(np.argmax(tips_of_modes.min(axis=1)))  # one that moves every boom tip
    omega, amplitude = np.sqrt(lam[mode]), 0.05
    q0 = amplitude * V[:, mode]
    peaks = OutputPeaks(model)
    model.simulate(StaticProfile(lengths), 3.3, q0, observer=peaks)
    found = peaks.peaks
    expected_tips = amplitude * tips_of_modes[mode]
    expected_moments = np.abs(model.root_moments(q0, lengths))
    assert found.tip_deflection.value == pytest.approx(expected_tips, rel=1e-9)
    assert found.root_moment.value == pytest.approx(expected_moments, rel=1e-9)
    for times in (found.tip_deflection.time_s, found.root_moment.time_s):
        half_periods = times * omega / np.pi
        assert half_periods == pytest.approx(np.round(half_periods), abs=1e-6)


class KiloHertz:
    """An independent 1 kHz sampling of the same run: the steps' own interpolants at the
    grid times inside each step, no interpolation between samples."""

    def __init__(self, model, rows=None):
        self.model, self.times, self.values, self.lengths = model, [], [], []
        self.rows = model.length_free_rows if rows is None else rows

    def start(self, stepper):
        self._take(stepper, [stepper.t], stepper.q[None] @ self.rows.T)
        self.t0 = stepper.t

    def after_step(self, stepper):
        t0, t1 = self.t0, stepper.t
        grid = np.arange(np.floor(t0 * 1e3) + 1, np.floor(t1 * 1e3 + 1e-6) + 1) / 1e3
        grid = grid[(grid > t0) & (grid <= t1 + 1e-12)]
        if grid.size:
            values, _ = stepper.interpolant((grid - t0) / (t1 - t0), self.rows)
            self._take(stepper, grid, values)
        self.t0 = t1

    def _take(self, stepper, times, values):
        self.times += list(times)
        self.values += list(values)
        self.lengths += [stepper.boom_motion(t)[0] for t in times]

    def peaks(self):
        values, lengths = np.array(self.values), np.array(self.lengths)
        return (
            np.abs(values[:, :4]).max(axis=0),
            np.abs(values[:, 4:8] / lengths**2).max(axis=0),
            np.abs(values[:, 8:]).max(axis=0),
        )


@pytest.mark.parametrize(
    ("modes", "loaded"),
    [((4, 6), False), ((4, 6), True), ((8, 6), True)],
    ids=["unloaded", "loaded-damped", "loaded-damped-8-boom-modes"],
)
def test_peaks_agree_with_a_1_khz_sampling_of_the_same_run(modes, loaded):
    """The reference deployment and 2 s at rest after it (the steps at rest are exact,
    the moving ones the Padé step's extension); loaded: a pressure from t = 0, a tip force
    switched on and off, Rayleigh damping. Every boom's peak within 0.2 % of its own."""
    params = SailParameters(n_boom_modes=modes[0], n_membrane_modes=modes[1])
    loads = None
    if loaded:
        params = params.replace(mass_damping=0.02, stiffness_damping=2e-4)
        loads = LoadSchedule(
            [(0.0, [2e-3, 0.0, 1e-3, 0.0], None), (3.0, None, [0, 0.05, 0, 0]), (7.0, None, 0.0)]
        )
    model = SailModel(params)
    profile = CycloidalProfile(10.0, 15.0, 15.0)
    q0 = model.mode_state("a", 0.1)
    t_eval = np.union1d(np.arange(18.0), [3.0, 7.0])  # load switches on step boundaries
    ours, reference = OutputPeaks(model), KiloHertz(model)
    for observer in (ours, reference):
        model.simulate(profile, 17.0, q0, t_eval=t_eval, loads=loads, observer=observer)
    tips, moments, _ = reference.peaks()
    found = ours.peaks
    assert found.tip_deflection.value == pytest.approx(tips, rel=2e-3)
    assert found.root_moment.value == pytest.approx(moments, rel=2e-3)
    # between samples, never below what they show by more than the Hermite's error bound
    assert np.all(found.root_moment.value >= moments * (1 - PEAK_ERROR))


def test_a_free_hubs_heave_tilts_and_tilt_peak_with_the_booms():
    """Free hub, the booms deployed to unequal lengths (a and c apart, so the hub tilts
    about y), a tip force on boom b for 2 s: the hub's peak |z_h|, |theta_x|, |theta_y|
    and tilt within 0.2 % of a 1 kHz sampling of the same run, never below it, and the
    tips' and moments' peaks as clamped-hub runs find them."""
    params = SailParameters(n_boom_modes=4, n_membrane_modes=6, free_hub=True)
    model = SailModel(params)
    profile = CycloidalProfile(10.0, [16.0, 12.0, 11.0, 14.0], 12.0)
    loads = LoadSchedule([(2.0, None, [0, 0.05, 0, 0]), (4.0, None, 0.0)])
    q0 = model.mode_state("a", 0.1)
    ours = OutputPeaks(model)
    reference = KiloHertz(model, ours.rows)
    for observer in (ours, reference):
        model.simulate(profile, 14.0, q0, t_eval=[0.0, 2.0, 4.0, 14.0], loads=loads,
                       observer=observer)  # fmt: skip
    tips, moments, hub = reference.peaks()
    values = np.array(reference.values)[:, 9:11]
    tilt = np.hypot(values[:, 0], values[:, 1]).max()
    found = ours.peaks
    assert found.tip_deflection.value == pytest.approx(tips, rel=2e-3)
    assert found.root_moment.value == pytest.approx(moments, rel=2e-3)
    expected = np.append(hub, tilt)
    assert found.hub.value == pytest.approx(expected, rel=2e-3)
    assert np.all(found.hub.value >= expected * (1 - PEAK_ERROR))
    assert found.hub.value[3] >= max(found.hub.value[1:3])  # the tilt bounds each axis
    assert np.all((found.hub.time_s >= 0.0) & (found.hub.time_s <= 14.0))
    clamped = OutputPeaks(SailModel(params.replace(free_hub=False)))
    assert clamped.peaks.hub is None


class Dense:
    """Every 20 us of the same run (the steps' own interpolants), the largest |value|, no
    interpolation: within 1 - cos(290 rad/s x 10 us) = 4e-6 of a peak of the highest
    followed modes here, 2.6 % of `PEAK_ERROR`."""

    def __init__(self, model, rows, spacing=2e-5):
        self.rows, self.spacing, self.largest = rows, spacing, np.zeros(len(rows))

    def start(self, stepper):
        self.t0 = stepper.t
        self._take(stepper, [stepper.t], (stepper.q @ self.rows.T)[None])

    def after_step(self, stepper):
        count = max(1, int(np.ceil((stepper.t - self.t0) / self.spacing)))
        fractions = np.arange(1, count + 1) / count
        values, _ = stepper.interpolant(fractions, self.rows)
        self._take(stepper, self.t0 + fractions * (stepper.t - self.t0), values)
        self.t0 = stepper.t

    def _take(self, stepper, times, values):
        lengths = np.array([stepper.boom_motion(t)[0] for t in times])
        values = np.abs(values)
        values[:, 4:8] /= lengths**2
        self.largest = np.maximum(self.largest, values.max(axis=0))


@pytest.mark.parametrize(
    ("profile", "boom"),
    [(CycloidalProfile(10.0, 15.0, 8.0), "a"), (CycloidalProfile(15.0, 10.0, 8.0), "b")],
    ids=["deploying", "retracting"],
)
def test_samples_close_enough_for_the_followed_modes_they_weigh(profile, boom):
    """The followed modes set the samples' spacing by what they weigh in each output
    (`OutputPeaks.spacings`): over the first 4 s, every peak within `PEAK_ERROR` of a 50
    kHz sampling of the same run, retracting too (the booms' frequencies rise as they
    shorten), with fewer samples than 0.5 rad of the highest followed mode would take."""
    model = SailModel(SMALL)
    ours = OutputPeaks(model)
    dense = Dense(model, ours.rows)
    highest = []  # samples at 0.5 rad of each step's highest followed mode

    class Steps:
        def start(self, stepper):
            for observer in (ours, dense):
                observer.start(stepper)

        def after_step(self, stepper):
            omega, _ = stepper.last_curve().followed(ours.rows)  # the booms move throughout
            h = stepper.t - dense.t0
            highest.append(np.ceil(h * max(omega.max(initial=0.0) / 0.5, 100.0)))
            for observer in (ours, dense):
                observer.after_step(stepper)

    model.simulate(profile, 4.0, model.mode_state(boom, 0.1), observer=Steps())
    found = ours.peaks
    values = np.concatenate([found.tip_deflection.value, found.root_moment.value])
    assert values == pytest.approx(dense.largest, rel=PEAK_ERROR)
    assert ours.samples < sum(highest)


def test_a_steps_curve_has_the_slope_of_its_values_as_its_modes_change_frequency():
    """Inside a step the followed modes' frequencies change (retracting from 15 m the
    booms' rise as `1 / L^2`): the curve's slope, which the peaks' Hermite search takes,
    is the derivative of its values, the turns' velocities at each moment's frequency
    (central differences of the values, away from the middle, where the curve passes
    from the start's modes to the end's)."""
    model = SailModel(SMALL)
    steps = step_curves(model, CycloidalProfile(15.0, 10.0, 8.0), 4.0)
    rows = OutputPeaks(model).rows
    t0, checked = 0.0, 0
    for t1, curve in steps:
        h = t1 - t0
        omega, _ = curve.followed(rows)
        if omega.size:
            delta = 1e-3 / (omega.max() * h)  # a fraction: 1e-3 rad of the fastest mode
            fractions = np.array([0.1, 0.3, 0.7, 0.9])
            values = [curve.curve(fractions + k * delta, rows)[0] for k in (-1, 1)]
            _, slope = curve.curve(fractions, rows)
            differences = (values[1] - values[0]) / (2.0 * delta * h)
            scale = np.abs(slope).max(axis=0)
            assert np.all(np.abs(differences - slope) <= 1e-5 * scale), (t1, h)
            checked += 1
        t0 = t1
    assert checked > 5


def test_a_batch_of_steps_gives_each_step_its_own_curve():
    """`rational.Curves` stacks steps that follow different numbers of modes (12, 8, 5 and
    4 here, retracting from 15 m to 6 m), padded with null modes: each step's samples and followed
    modes are those of its own `Extension`, to round-off, in any order; damped, and
    undamped on a grid of equal intervals (their turns as running products)."""
    check_batch_of_steps(SMALL.replace(mass_damping=0.02, stiffness_damping=2e-4))
    check_batch_of_steps(SMALL, grid=True)


def step_curves(model, profile, seconds: float) -> list:
    """`(t, curve)` of each step of `seconds` [s] of `profile`, boom a bent 0.1 m at the
    start: the step's end [s] and its `SailStepper.last_curve`."""
    steps = []

    class Steps:
        def start(self, stepper):
            pass

        def after_step(self, stepper):
            steps.append((stepper.t, stepper.last_curve()))

    model.simulate(profile, seconds, model.mode_state("a", 0.1), observer=Steps())
    return steps


def check_batch_of_steps(params, grid=False):
    model = SailModel(params)
    steps = [curve for _, curve in step_curves(model, CycloidalProfile(15.0, 6.0, 6.0), 3.0)]
    counts = [step.count for step in steps]
    assert len(set(counts)) >= 3 and min(counts) > 0
    batch = Curves(steps)
    assert (batch.decay is not None) == (params.stiffness_damping > 0)
    assert batch.count == max(counts)
    rows = OutputPeaks(model).rows
    rng = np.random.default_rng(3)
    intervals = rng.integers(5, 60, size=len(steps))  # odd ones: 0.5 is off the grid
    fractions = [np.sort(np.concatenate([rng.random(7), [np.nextafter(0.5, 0.0), 0.5],
                                         np.arange(1, c + 1) / c]))
                 for c in intervals]  # fmt: skip
    index = np.repeat(np.arange(len(steps)), [f.size for f in fractions])
    order = rng.permutation(index.size)  # the samples in any order
    y, yd = batch.curve(index[order], np.concatenate(fractions)[order], rows,
                        grid=intervals if grid else None)  # fmt: skip
    omega, amplitude = batch.followed(rows)
    for i, step in enumerate(steps):
        mine = index[order] == i
        own_y, own_yd = step.curve(np.concatenate(fractions)[order][mine], rows)
        np.testing.assert_allclose(y[mine], own_y, rtol=0, atol=1e-12 * np.abs(own_y).max())
        np.testing.assert_allclose(yd[mine], own_yd, rtol=0, atol=1e-12 * np.abs(own_yd).max())
        own_omega, own_amplitude = step.followed(rows)
        pad = batch.count - step.count  # the null modes come first
        assert np.array_equal(omega[i, pad:], own_omega) and not omega[i, :pad].any()
        np.testing.assert_allclose(amplitude[i, :, pad:], own_amplitude, rtol=1e-12)
        assert not amplitude[i, :, :pad].any()
