"""Phase estimation (Phaser) and the nominal gait fitted against phase."""

import numpy as np
import pytest

from geogait.gaits import FourierGait, seed_gait
from geogait.phase import Phaser, cycle_index, fit_nominal_gait
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


def oscillator(seed, n_cycles=20, rate=50, frequency=(1.0, 1.0), noise=0.1, diffusion=0.02):
    """Four nonlinear channels of a phase φ(t) with a frequency ramp and phase diffusion.

    Returns the true phase ``(n,)`` and the channels ``(n, 4)`` with Gaussian noise of ``noise``
    times each channel's standard deviation.
    """
    rng = np.random.default_rng(seed)
    n = int(n_cycles / np.mean(frequency) * rate)
    drift = 2 * np.pi * np.linspace(*frequency, n) / rate
    phase = np.cumsum(drift + rng.normal(0, diffusion / np.sqrt(rate), n))
    channels = np.stack([np.cos(phase) + 0.4 * np.cos(2 * phase + 0.3),
                         np.sin(phase) ** 3 + 0.3 * np.sin(phase),
                         np.exp(np.cos(phase - 1)),
                         np.tanh(3 * np.sin(phase + 2))], axis=1)
    return phase, channels + noise * channels.std(axis=0) * rng.normal(size=channels.shape)


def circular_error(estimate, truth):
    """|estimate − truth| on the circle after removing the best constant offset."""
    difference = np.exp(1j * (np.asarray(estimate) - truth))
    return np.abs(np.angle(difference * np.conj(difference.mean()) / np.abs(difference.mean())))


@pytest.mark.parametrize("frequency", [(1.0, 1.0), (1.0, 1.5)])
def test_phase_of_a_noisy_nonlinear_oscillator(frequency):
    truth, x = oscillator(0, frequency=frequency)
    phaser = Phaser().fit(x)
    error = circular_error(phaser.transform(x), truth)
    # Measured: median 0.032 / 0.034 rad, 95th percentile 0.12 rad (10 % channel noise). The raw
    # Hilbert phase of one channel errs by a median 0.27 rad on the same data.
    assert np.median(error) < 0.05 and np.percentile(error, 95) < 0.16
    new_truth, new_x = oscillator(1, frequency=frequency)  # applied to data it was not fitted on
    new_error = circular_error(phaser.transform(new_x), new_truth)
    assert np.median(new_error) < 0.05 and np.percentile(new_error, 95) < 0.16


def test_noise_free_phase_is_accurate_and_edges_are_bounded():
    truth, x = oscillator(2, frequency=(1.0, 1.5), noise=0.0, diffusion=0.0)
    error = circular_error(Phaser().fit_transform(x), truth)
    half_cycle = 25
    # Measured: median 0.005 rad; Hilbert edge effects raise the mean over the first and last
    # half cycle to about 0.02 rad.
    assert np.median(error) < 0.01
    assert error[:half_cycle].mean() < 0.06 and error[-half_cycle:].mean() < 0.06


def test_records_fit_together_and_transform_separately():
    truths, records = zip(*[oscillator(seed, n_cycles=4, frequency=(1.0, 1.3)) for seed in range(3)],
                          strict=True)
    with pytest.raises(ValueError, match="at least min_cycles = 5 cycles. Got '[34]\\.[0-9]{2} cycles'"):
        Phaser().fit(records[0])
    phaser = Phaser().fit(list(records))
    assert 11 < phaser.n_cycles_ < 13
    phases = phaser.transform(list(records))
    assert [p.shape for p in phases] == [r.shape[:1] for r in records]
    # One estimator for all records: the same offset to the truth in every record.
    offsets = [np.angle(np.mean(np.exp(1j * (p - t)))) for p, t in zip(phases, truths, strict=True)]
    assert np.ptp(offsets) < 0.1
    assert all(np.median(circular_error(p, t)) < 0.06 for p, t in zip(phases, truths, strict=True))


def test_swimmer_shape_phase_matches_the_commanded_phase():
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=30, seed=0)
    phaser = Phaser().fit(run.shape)
    error = circular_error(phaser.transform(run.shape), run.phase)
    # Measured: median 0.079 rad, 95th percentile 0.20 rad — the perturbations δ (std 0.15 rad on
    # a 1 rad gait) move the shape off the nominal cycle, which no phase estimate can undo.
    assert np.median(error) < 0.1 and np.percentile(error, 95) < 0.25
    other = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=10, seed=5)
    assert np.median(circular_error(phaser.transform(other.shape), other.phase)) < 0.1
    # Phase 0: joint 0 (cos φ) crosses its mean upwards, i.e. commanded φ = 3π/2.
    offset = np.angle(np.mean(np.exp(1j * (phaser.transform(run.shape) - run.phase))))
    assert abs(np.angle(np.exp(1j * (offset - np.pi / 2)))) < 0.05
    # Online use: the last sample of a sliding two-cycle window (measured median 0.09 rad).
    ends = np.arange(200, run.n_samples, 13)
    last = np.array([phaser.transform(run.shape[end - 200:end])[-1] for end in ends])
    online = np.abs(np.angle(np.exp(1j * (last - run.phase[ends - 1] - offset))))
    assert np.median(online) < 0.15


def test_poincare_section_sets_phase_zero():
    time = np.arange(2000) * 0.01
    truth = 2 * np.pi * time
    x = np.stack([np.sin(truth), np.cos(truth) + 0.2], axis=1)
    phase = Phaser().fit_transform(x)
    np.testing.assert_allclose(np.angle(np.exp(1j * (phase - truth)))[100:-100], 0, atol=0.01)
    # Channel 1 crossing 0.7 upwards: cos φ = 0.5 rising, at φ = 5π/3.
    shifted = Phaser(section_channel=1, section_level=0.7).fit_transform(x)
    residual = np.angle(np.exp(1j * (shifted - truth + 5 * np.pi / 3)))
    np.testing.assert_allclose(residual[100:-100], 0, atol=0.01)
    unwrapped = Phaser().fit(x).transform(x, unwrap=True)
    assert np.all(np.diff(unwrapped) > 0)
    assert np.isclose(unwrapped[-1] - unwrapped[0], truth[-1] - truth[0], atol=0.1)


def test_phaser_errors():
    _, x = oscillator(0)
    with pytest.raises(ValueError, match="'x'.*constant channel\\(s\\) \\[2\\]"):
        Phaser().fit(np.column_stack([x[:, :2], np.ones(len(x))]))
    with pytest.raises(ValueError, match="'order'.*int >= 1"):
        Phaser(order=0).fit(x)
    with pytest.raises(ValueError, match="'section_channel'.*\\[0, 3\\]"):
        Phaser(section_channel=4).fit(x)
    with pytest.raises(ValueError, match="'section_level'.*crosses"):
        Phaser(section_level=100.0).fit(x)
    with pytest.raises(ValueError, match="Phaser is not fitted yet"):
        Phaser().transform(x)
    phaser = Phaser().fit(x)
    with pytest.raises(ValueError, match="'x'.*4 channels.*2 channels"):
        phaser.transform(x[:, :2])
    with pytest.raises(ValueError, match="'x\\[1\\]'.*finite"):
        phaser.transform([x, np.full((10, 4), np.nan)])


# -- nominal gait -------------------------------------------------------------------------------------
def test_nominal_gait_recovers_the_commanded_seed_gait():
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=30, seed=0)
    fit = fit_nominal_gait(run.phase, run.shape)
    # Measured: order 1 chosen; coefficient error 0.024 (perturbations of std 0.15 rad, 30 cycles).
    assert fit.order == 1 and fit.orders.tolist() == [1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(fit.gait.coefficients, seed_gait(2).coefficients, atol=0.05)
    assert fit.held_out_rmse.shape == fit.held_out_stderr.shape == (6,)
    given = fit_nominal_gait(run.phase, run.shape, order=2)
    assert given.order == 2 and given.gait.order == 2 and given.orders.tolist() == [2]


@pytest.mark.parametrize("seed", range(3))
def test_order_selection_picks_first_order_under_perturbations(seed):
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=30, seed=seed)
    assert fit_nominal_gait(run.phase, run.shape).order == 1


def test_order_selection_finds_higher_harmonics_and_works_with_estimated_phase():
    coefficients = np.zeros((2, 7))
    coefficients[:, [1, 4]] = [[1.0, 0.0], [0.0, 1.0]]
    coefficients[:, [3, 6]] = [[0.3, 0.0], [0.0, -0.25]]  # third harmonic
    run = simulate(PurcellSwimmer(3), FourierGait(coefficients), n_cycles=30, seed=0)
    assert fit_nominal_gait(run.phase, run.shape).order == 3
    plain = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=30, seed=0)
    estimated = Phaser().fit_transform(plain.shape)
    assert fit_nominal_gait(estimated, plain.shape).order == 1


def test_nominal_gait_errors_and_cycle_index():
    phase = np.tile(np.linspace(0, 2 * np.pi, 20, endpoint=False), 3)
    np.testing.assert_array_equal(np.unique(cycle_index(phase)), [0, 1, 2])
    with pytest.raises(ValueError, match="at least n_folds = 5 cycles.*3 cycle"):
        fit_nominal_gait(phase, np.cos(phase)[:, None])
    with pytest.raises(ValueError, match="'shape'.*len\\(phase\\) = 60"):
        fit_nominal_gait(phase, np.zeros((59, 2)))
    groups = np.repeat(np.arange(6), 10)
    fit = fit_nominal_gait(phase, np.cos(phase)[:, None], groups=groups, order=1)
    np.testing.assert_allclose(fit.gait.coefficients, [[0, 1, 0]], atol=1e-12)
