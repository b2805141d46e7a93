"""The data-driven models against exact answers: batch least squares, the true connection."""

import numpy as np
import pytest
from _reference import GAIT, SWIMMER, fit_args
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.gaits import FourierGait
from geogait.models import (
    AdaptiveGaitModel,
    BatchGaitModel,
    PhaseModel,
    PhaseWindows,
    RLSBank,
    load_model,
    regressors,
)
from geogait.simulate import simulate


@pytest.fixture(scope="module")
def runs():
    return {
        "train": simulate(SWIMMER, GAIT, 40, seed=0),
        "test": simulate(SWIMMER, GAIT, 10, seed=1),
        "noisy": simulate(SWIMMER, GAIT, 40, seed=2, sensor_noise=0.3, n_trials=4),
        "noisy_test": simulate(SWIMMER, GAIT, 40, seed=3, sensor_noise=0.3, n_trials=4),
    }


def test_regressor_layout():
    x = regressors(np.array([2.0, 3.0]), np.array([5.0, 7.0]))
    np.testing.assert_array_equal(x, [1, 2, 3, 5, 7, 10, 14, 15, 21])


def test_windows_cover_the_circle_with_overlap():
    windows = PhaseWindows(8, width=2 * 2 * np.pi / 8)
    phase = np.linspace(0, 2 * np.pi, 1000, endpoint=False)
    counts = windows.cover(phase).sum(axis=-1)
    assert counts.min() >= 2 and counts.max() <= 3
    assert windows.cover(2 * np.pi - 1e-9)[0]  # wrap-around
    with pytest.raises(ValueError, match="'width'"):
        PhaseWindows(8, width=0.1)


def test_rls_without_forgetting_equals_batch_least_squares(runs):
    run = runs["train"].cycles(0, 12)
    adaptive = AdaptiveGaitModel(gait=GAIT, forgetting_factor=1.0, initial_covariance=1e8).fit(*fit_args(run))
    batch = BatchGaitModel(gait=GAIT).fit(*fit_args(run))
    scale = np.abs(batch.window_weights_).max(axis=(-2, -1), keepdims=True)
    assert np.abs(adaptive.window_weights_ - batch.window_weights_).max() / scale.max() < 1e-6
    # Independent check of one overlapping window with numpy's lstsq on its own samples.
    windows, m = adaptive.windows_, 3
    inside = windows.cover(run.phase)[:, m]
    centre = windows.centres[m]
    x = regressors(run.shape[inside] - GAIT.shape(centre),
                   run.shape_velocity[inside] - 2 * np.pi * GAIT.velocity(centre))
    solution, *_ = np.linalg.lstsq(x, run.body_velocity[inside], rcond=None)
    np.testing.assert_allclose(adaptive.window_weights_[m], solution, rtol=1e-6, atol=1e-6 * np.abs(solution).max())


def test_noise_free_model_is_accurate_on_held_out_data(runs):
    model = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(runs["train"].cycles(0, 10)))
    assert model.score(*fit_args(runs["test"])) > 0.9
    assert model.gamma_ > 0.9


def test_noisy_model_is_positive_and_improves_with_data(runs):
    noisy, test = runs["noisy"], runs["noisy_test"]
    scores = []
    for cycles in (5, 40):
        part = slice(0, cycles * 100)
        model = AdaptiveGaitModel(gait=GAIT, forgetting_factor=0.999).fit(
            noisy.phase[:, part], noisy.shape[:, part], noisy.shape_velocity[:, part], noisy.body_velocity[:, part])
        scores.append(model.score(*fit_args(test)))
    assert np.all(scores[0] > 0.15) and np.all(scores[1] > 0.3)
    assert np.all(scores[1] > scores[0]) and np.mean(scores[1] - scores[0]) > 0.02


def test_learned_coefficients_match_the_true_connection(runs):
    model = AdaptiveGaitModel(gait=GAIT, forgetting_factor=1.0).fit(*fit_args(runs["train"].cycles(0, 20)))
    phase = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    truth = SWIMMER.connection(GAIT.shape(phase))
    learned = model.coefficients(phase)
    # The learned A estimates -A(θ(φ)); 0.005 absolute is 2 % of max |A| along this gait.
    assert np.abs(learned["A"] + truth).max() < 0.005
    # C estimates -A(θ)θ̇ = the nominal body velocity.
    nominal = -np.einsum("nij,nj->ni", truth, 2 * np.pi * GAIT.velocity(phase))
    assert np.abs(learned["C"] - nominal).max() < 0.03 * np.abs(nominal).max()


@pytest.mark.slow
def test_covariance_stays_bounded_without_excitation():
    # 10^6 window updates at λ = 0.7 on samples exactly on the nominal gait (δ = δ̇ = 0).
    phase = np.tile(np.linspace(0, 2 * np.pi, 100, endpoint=False), 5000)
    shape, rate = GAIT.shape(phase), 2 * np.pi * GAIT.velocity(phase)
    body = -np.einsum("nij,nj->ni", SWIMMER.connection(GAIT.shape(np.linspace(0, 2 * np.pi, 100, endpoint=False))),
                      rate[:100])
    model = AdaptiveGaitModel(gait=GAIT, forgetting_factor=0.7)
    model.fit(phase, shape, rate, np.tile(body, (5000, 1)))
    assert model.bank_.n_updates.sum() >= 10**6
    p = model.covariance_
    assert np.all(np.isfinite(p)) and np.array_equal(p, np.swapaxes(p, -1, -2))
    assert np.trace(p, axis1=-2, axis2=-1).max() <= model.bank_.max_trace * (1 + 1e-12)
    assert np.all(np.linalg.eigvalsh(p) > 0)
    prediction = model.predict(phase[:100], shape[:100] + 0.3, rate[:100] - 2)
    assert np.all(np.isfinite(prediction))


@given(seed=st.integers(0, 2**32 - 1), lam=st.floats(0.5, 1.0), scale=st.floats(1e-3, 1e3),
       rank=st.integers(0, 5), graded=st.booleans())
@settings(max_examples=40, deadline=None)
def test_covariance_stays_positive_definite_on_random_data(seed, lam, scale, rank, graded):
    rng = np.random.default_rng(seed)
    prior = 10.0 * 0.3 ** np.arange(6) if graded else 10.0  # a prior variance per regressor, or δ₀ I
    bank = RLSBank((2,), 3, 6, 3, lam, initial_covariance=prior)
    assert bank.max_trace == pytest.approx(np.sum(np.broadcast_to(prior, 6)))
    basis = rng.normal(size=(rank, 6))  # regressors confined to a random subspace (poor excitation)
    for _ in range(60):
        x = scale * (rng.normal(size=(2, 3, rank)) @ basis if rank else np.zeros((2, 3, 6)))
        bank.update(x, rng.normal(size=(2, 3, 3)), rng.random((2, 3)) < 0.8)
    p = bank.covariance
    assert np.array_equal(p, np.swapaxes(p, -1, -2))
    np.linalg.cholesky(p)  # raises unless positive definite
    assert np.trace(p, axis1=-2, axis2=-1).max() <= bank.max_trace * (1 + 1e-12)


@given(seed=st.integers(0, 2**32 - 1), lam=st.sampled_from([1.0, 0.999, 0.95, 0.6]), rank=st.integers(1, 6),
       split=st.integers(1, 150))
@settings(max_examples=30, deadline=None)
def test_sequence_update_equals_sample_by_sample_updates(seed, lam, rank, split):
    """update_sequence (blocks, module docstring) = one update per sample, trace clamp included, whatever the
    split of the sequence into calls; regressors in a random subspace so the clamp acts for λ < 1."""
    rng = np.random.default_rng(seed)
    prior = 10.0 * 0.5 ** np.arange(6)
    blocks, samples = RLSBank((2,), 1, 6, 3, lam, prior), RLSBank((2,), 1, 6, 3, lam, prior)
    x = rng.normal(size=(2, 1, 200, rank)) @ rng.normal(size=(rank, 6))
    y = rng.normal(size=(2, 1, 200, 3))
    expected = np.stack([samples.update(x[:, :, i], y[:, :, i], np.ones((2, 1), bool)) for i in range(200)], -2)
    prior_prediction = np.concatenate([blocks.update_sequence(x[:, :, s:s + split], y[:, :, s:s + split])
                                       for s in range(0, 200, split)], axis=-2)
    # rounding grows with the conditioning (up to ≈ 3e-10 relative at cond ≈ 300 seen); a wrong update is O(1) off
    scale = np.linalg.cond(samples.covariance).max() * max(1.0, np.abs(expected).max())
    np.testing.assert_allclose(prior_prediction, expected, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(blocks.weights, samples.weights, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(blocks.covariance, samples.covariance, rtol=1e-9, atol=1e-10 * scale)
    assert np.array_equal(blocks.covariance, np.swapaxes(blocks.covariance, -1, -2))
    assert np.trace(blocks.covariance, axis1=-2, axis2=-1).max() <= blocks.max_trace * (1 + 1e-12)
    np.testing.assert_array_equal(blocks.n_updates, samples.n_updates)


def test_online_gamma_does_not_depend_on_batching(runs):
    run = runs["train"].cycles(0, 3)
    whole = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run))
    stepwise = AdaptiveGaitModel(gait=GAIT)
    gammas = []
    for n in range(run.n_samples):
        stepwise.partial_fit(run.phase[n], run.shape[n], run.shape_velocity[n], run.body_velocity[n])
        gammas.append(stepwise.gamma_)
    np.testing.assert_allclose(gammas, whole.online_gamma_, atol=1e-10)
    np.testing.assert_allclose(stepwise.window_weights_, whole.window_weights_, atol=1e-10)


def test_trial_axis_equals_independent_models(runs):
    noisy = runs["noisy"]
    batched = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(noisy))
    single = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(noisy.trial(2)))
    np.testing.assert_allclose(batched.window_weights_[2], single.window_weights_, atol=1e-12)
    np.testing.assert_allclose(batched.gamma_[2], single.gamma_, atol=1e-12)
    test = runs["noisy_test"]
    np.testing.assert_allclose(batched.predict(test.phase, test.shape, test.shape_velocity)[2],
                               single.predict(test.phase[2], test.shape[2], test.shape_velocity[2]), atol=1e-12)


@pytest.mark.parametrize("terms", ["constant", "all"])
def test_rebase_improves_predictions_on_a_nearby_gait(runs, terms):
    # After the nominal gait moves, the windows must expand about the new gait. Eq. 7 moves the
    # constant term with it; the un-rebased model ("none") keeps weights fitted about the old gait.
    new_gait = FourierGait(GAIT.coefficients + np.array([[0.05, 0.1, 0.0], [-0.05, 0.0, 0.08]]))
    new_run = simulate(SWIMMER, new_gait, 3, seed=7)

    def error_after(rebase_terms):
        model = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(runs["train"].cycles(0, 10)))
        model.rebase(new_gait, terms=rebase_terms)
        assert model.gait_ == new_gait
        prediction = model.predict(new_run.phase, new_run.shape, new_run.shape_velocity)
        return np.abs(prediction - new_run.body_velocity).mean()

    assert error_after(terms) < 0.5 * error_after("none")


def test_full_rebase_leaves_window_polynomials_unchanged(runs):
    model = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(runs["train"].cycles(0, 5)))
    rng = np.random.default_rng(0)
    shape, rate = rng.normal(size=(2, 20, 2))
    centres = model.windows_.centres

    def window_outputs(gait):
        x = regressors(shape[:, None] - gait.shape(centres), rate[:, None] - 2 * np.pi * gait.velocity(centres))
        return np.einsum("nmi,mij->nmj", x, model.window_weights_)

    before = window_outputs(GAIT)
    new_gait = FourierGait(GAIT.coefficients * 1.2 + 0.1)
    model.rebase(new_gait, terms="all")
    np.testing.assert_allclose(window_outputs(new_gait), before, atol=1e-12)


def test_phase_model_recovers_phase_average():
    phase = np.tile(np.linspace(0, 2 * np.pi, 200, endpoint=False), 30)
    rng = np.random.default_rng(0)
    truth = np.stack([np.cos(phase), 0.5 * np.sin(2 * phase), 0.2 + 0 * phase], axis=-1)
    model = PhaseModel(n_windows=30, smoothing_order=6).fit(phase, truth + rng.normal(scale=0.5, size=truth.shape))
    grid = np.linspace(0, 2 * np.pi, 50)
    expected = np.stack([np.cos(grid), 0.5 * np.sin(2 * grid), 0.2 + 0 * grid], axis=-1)
    # Window averaging blurs by about the window width; 0.1 bounds blur plus noise.
    assert np.abs(model.predict(grid) - expected).max() < 0.1


def test_batch_refit_forgets_and_partial_fit_accumulates(runs):
    run = runs["train"]
    first, second = run.cycles(0, 5), run.cycles(5, 10)
    accumulated = BatchGaitModel(gait=GAIT).fit(*fit_args(first)).partial_fit(*fit_args(second))
    at_once = BatchGaitModel(gait=GAIT).fit(*fit_args(run.cycles(0, 10)))
    np.testing.assert_allclose(accumulated.window_weights_, at_once.window_weights_, atol=1e-9)
    refit = BatchGaitModel(gait=GAIT).fit(*fit_args(first)).fit(*fit_args(second))
    np.testing.assert_allclose(refit.window_weights_, BatchGaitModel(gait=GAIT).fit(*fit_args(second)).window_weights_,
                               atol=1e-12)


def test_gait_estimated_from_data_when_not_given(runs):
    model = AdaptiveGaitModel().fit(*fit_args(runs["train"].cycles(0, 10)))
    # Perturbations (std 0.15 rad, correlated over ~half a cycle) leave ~0.03 rad of error in 10 cycles.
    np.testing.assert_allclose(model.gait_.coefficients, GAIT.coefficients, atol=0.06)
    with pytest.raises(ValueError, match="'gait'"):
        AdaptiveGaitModel().partial_fit(0.0, [0.1, 0.2], [0.0, 0.0], [0.0, 0.0, 0.0])


@pytest.mark.parametrize("cls", [AdaptiveGaitModel, BatchGaitModel])
def test_save_load_continues_identically(tmp_path, runs, cls):
    run = runs["train"]
    first, second = run.cycles(0, 4), run.cycles(4, 8)
    reference = cls(gait=GAIT).fit(*fit_args(first)).partial_fit(*fit_args(second))
    path = cls(gait=GAIT).fit(*fit_args(first)).save(tmp_path / "model.npz")
    restored = cls.load(path).partial_fit(*fit_args(second))
    np.testing.assert_array_equal(restored.window_weights_, reference.window_weights_)
    np.testing.assert_array_equal(restored.predict(run.phase[:50], run.shape[:50], run.shape_velocity[:50]),
                                  reference.predict(run.phase[:50], run.shape[:50], run.shape_velocity[:50]))
    if cls is AdaptiveGaitModel:
        assert restored.gamma_ == reference.gamma_
    assert restored.get_params().keys() == reference.get_params().keys()


def test_load_rejects_bad_files(tmp_path, runs):
    path = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(runs["train"].cycles(0, 2))).save(tmp_path / "m.npz")
    with pytest.raises(ValueError, match="shape dimension 2.*4 was given"):
        load_model(path, n_joints=4)
    with pytest.raises(ValueError, match="not a BatchGaitModel"):
        BatchGaitModel.load(path)
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    with pytest.raises(ValueError, match="corrupt or truncated"):
        load_model(truncated)
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(ValueError, match="corrupt or truncated"):
        load_model(tmp_path / "text.npz")
    with pytest.raises(ValueError, match="does not exist"):
        load_model(tmp_path / "missing.npz")
    model = load_model(path)
    with pytest.raises(ValueError, match=r"'shape'.*\(\.\.\., 2\)"):
        model.partial_fit([0.1], [[0.1, 0.2, 0.3]], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]])


@pytest.mark.parametrize(
    ("params", "match"),
    [
        (dict(forgetting_factor=1.3), r"The 'forgetting_factor' parameter of AdaptiveGaitModel must be a finite "
                                      r"float in \(0, 1\]. Got 1.3 instead."),
        (dict(forgetting_factor=0.0), "'forgetting_factor'"),
        (dict(initial_covariance=-1.0), "'initial_covariance'"),
        (dict(n_windows=0), "'n_windows'"),
        (dict(window_width=0.01), "'window_width'"),
        (dict(smoothing_order=20), "'smoothing_order'"),
        (dict(gamma_forgetting=2.0), "'gamma_forgetting'"),
        (dict(gait="circle"), "'gait'"),
    ],
)
def test_bad_hyper_parameters_are_reported_at_fit(runs, params, match):
    model = AdaptiveGaitModel(**params)  # __init__ only stores
    with pytest.raises(ValueError, match=match):
        model.fit(*fit_args(runs["train"].cycles(0, 1)))


def test_bad_samples_name_the_field(runs):
    run = runs["train"].cycles(0, 1)
    model = AdaptiveGaitModel(gait=GAIT)
    with pytest.raises(ValueError, match="'body_velocity'"):
        model.fit(run.phase, run.shape, run.shape_velocity, run.body_velocity[:, :2])
    with pytest.raises(ValueError, match="'shape_velocity'.*matching 'phase'"):
        model.fit(run.phase, run.shape, run.shape_velocity[:-1], run.body_velocity)
    bad = run.shape.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="'shape'.*finite"):
        model.fit(run.phase, bad, run.shape_velocity, run.body_velocity)
    with pytest.raises(ValueError, match="not fitted"):
        AdaptiveGaitModel().predict(run.phase, run.shape, run.shape_velocity)


def test_model_without_the_bilinear_block(runs):
    run = runs["train"].cycles(0, 10)
    model = AdaptiveGaitModel(gait=GAIT, interaction=False).fit(*fit_args(run))
    assert model.window_weights_.shape == (20, 1 + 2 * 2, 3)
    assert np.all(model.coefficients([0.3])["dA"] == 0)
    assert model.score(*fit_args(runs["test"])) > 0.9  # noise-free: the linear terms carry most of ξ
    batch = BatchGaitModel(gait=GAIT, interaction=False).fit(*fit_args(run))
    np.testing.assert_allclose(model.window_weights_, batch.window_weights_, atol=0.05)
