"""The compiled one-sample path (geogait._kernels) against the NumPy reference path, and the
fallback when numba is missing."""

import importlib.util

import numpy as np
import pytest
from _reference import GAIT, SWIMMER, fit_args
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait import GeogaitError, GeogaitWarning, _kernels
from geogait.gaits import Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

#: Tests of the compiled path itself; the others also run (on the reference path alone) without numba.
needs_numba = pytest.mark.skipif(importlib.util.find_spec("numba") is None,
                                 reason="the compiled path needs numba (pip install geogait[fast])")


@pytest.fixture
def reference(monkeypatch):
    """Switch the compiled path off for the test (what a missing numba does)."""
    monkeypatch.setattr(_kernels, "ENABLED", False)


def one_at_a_time(model, run, start=0, stop=None, compiled=True):
    """Feed samples one ``partial_fit`` each; returns the a-priori predictions and Γ after each."""
    enabled, _kernels.ENABLED = _kernels.ENABLED, compiled
    try:
        prediction, gamma = [], []
        for s in range(start, run.n_samples if stop is None else stop):
            model.partial_fit(*(a[s] for a in fit_args(run)))
            prediction.append(model.prior_prediction_[0])
            gamma.append(model.gamma_)
    finally:
        _kernels.ENABLED = enabled
    return np.array(prediction), np.array(gamma)


def assert_close(actual, expected, rtol=1e-12):
    """Agreement to ``rtol`` of the array's scale (the paths differ in summation order only)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape
    scale = max(float(np.abs(expected).max()), 1e-300)
    assert float(np.abs(actual - expected).max()) <= rtol * scale


def assert_same_state(fast, slow):
    for a, b in ((fast.window_weights_, slow.window_weights_), (fast.covariance_, slow.covariance_),
                 (fast.phase_model_.bank_.weights, slow.phase_model_.bank_.weights),
                 (fast.phase_model_.bank_.covariance, slow.phase_model_.bank_.covariance), (fast.psi_, slow.psi_)):
        assert_close(a, b)
    np.testing.assert_array_equal(fast.bank_.n_updates, slow.bank_.n_updates)
    np.testing.assert_array_equal(fast.phase_model_.bank_.n_updates, slow.phase_model_.bank_.n_updates)
    assert fast.n_samples_seen_ == slow.n_samples_seen_
    assert fast.phase_model_.n_samples_seen_ == slow.phase_model_.n_samples_seen_


@needs_numba
def test_the_compiled_path_is_used_when_numba_is_installed():
    assert _kernels.fast_path_available() and _kernels.fast_path_note() is None
    model = AdaptiveGaitModel(gait=GAIT)
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    one_at_a_time(model, run, stop=2)  # the first sample starts the model (reference path)
    assert model._learn_one_compiled(*(a[2] for a in fit_args(run)))


@settings(max_examples=12, deadline=None)
@given(links=st.sampled_from([2, 3, 5, 9]), lam=st.sampled_from([1.0, 0.99, 0.9, 0.6]),
       gamma_forgetting=st.sampled_from([1.0, 0.995, 0.9]), noise=st.sampled_from([0.0, 0.1, 0.5]),
       phase_rate=st.sampled_from([2 * np.pi, 3.0]), interaction=st.booleans(),
       width=st.sampled_from([None, 2 * np.pi / 20, 6 * np.pi / 20]), seed=st.integers(0, 2**16))
def test_compiled_and_reference_paths_agree(links, lam, gamma_forgetting, noise, phase_rate, interaction, width,
                                            seed):
    gait = seed_gait(links - 1)
    run = simulate(PurcellSwimmer(links), gait, 3, seed=seed, sensor_noise=noise, cycle_period=2 * np.pi / phase_rate)
    params = dict(gait=gait, forgetting_factor=lam, gamma_forgetting=gamma_forgetting, phase_rate=phase_rate,
                  interaction=interaction, window_width=width, initial_covariance=10.0)
    fast, slow = AdaptiveGaitModel(**params), AdaptiveGaitModel(**params)
    fast_prediction, fast_gamma = one_at_a_time(fast, run)
    slow_prediction, slow_gamma = one_at_a_time(slow, run, compiled=False)
    assert_close(fast_prediction, slow_prediction)
    assert_close(fast_gamma, slow_gamma)
    np.testing.assert_allclose(fast.online_gamma_, slow.online_gamma_, rtol=0, atol=1e-12)
    assert_same_state(fast, slow)
    assert fast.prior_prediction_.shape == (1, 3) and fast.online_gamma_.shape == (1,) and fast.psi_.shape == (2,)


def test_paths_agree_where_the_trace_clamp_acts():
    """Fast forgetting and a still robot: the clamp acts on most updates, identically on both paths."""
    run = simulate(SWIMMER, GAIT, 4, seed=1, perturbation=Perturbation.from_std(0.0))
    fast, slow = (AdaptiveGaitModel(gait=GAIT, forgetting_factor=0.5) for _ in range(2))
    assert_close(one_at_a_time(fast, run)[0], one_at_a_time(slow, run, compiled=False)[0])
    assert_same_state(fast, slow)
    trace = np.einsum("...ii->...", fast.covariance_)
    np.testing.assert_allclose(trace, fast.bank_.max_trace, rtol=1e-12)  # clamped


def test_paths_agree_after_rebase_forget_and_reload(tmp_path):
    run = simulate(SWIMMER, GAIT, 4, seed=2, sensor_noise=0.1)
    models = [AdaptiveGaitModel(gait=GAIT), AdaptiveGaitModel(gait=GAIT)]
    for model, compiled in zip(models, (True, False), strict=True):
        one_at_a_time(model, run, stop=150, compiled=compiled)
        model.rebase(seed_gait(2, amplitude=1.1), constant_variance=0.1).forget(3.0)
        one_at_a_time(model, run, start=150, stop=250, compiled=compiled)
        model.save(tmp_path / f"{compiled}.npz")
    loaded = [AdaptiveGaitModel.load(tmp_path / f"{compiled}.npz") for compiled in (True, False)]
    one_at_a_time(loaded[0], run, start=250)
    one_at_a_time(loaded[1], run, start=250, compiled=False)
    assert_same_state(loaded[0], loaded[1])


def test_the_reference_path_alone_equals_the_batch_path_bit_for_bit(reference):
    run = simulate(SWIMMER, GAIT, 3, seed=3, sensor_noise=0.1)
    single = AdaptiveGaitModel(gait=GAIT)
    prediction, _ = one_at_a_time(single, run, compiled=False)
    batch = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run))
    np.testing.assert_array_equal(single.window_weights_, batch.window_weights_)
    np.testing.assert_array_equal(single.covariance_, batch.covariance_)
    np.testing.assert_allclose(prediction, batch.prior_prediction_, rtol=0, atol=1e-13)


def test_without_numba_the_reference_path_runs_and_says_so(monkeypatch):
    monkeypatch.setattr(_kernels, "_kernel", None)
    monkeypatch.setattr(_kernels, "_missing", "No module named 'numba'")  # what a failed import leaves
    assert not _kernels.fast_path_available()
    assert "pip install 'geogait[fast]'" in _kernels.fast_path_note()
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    model = AdaptiveGaitModel(gait=GAIT)
    one_at_a_time(model, run, stop=20)
    assert not model._learn_one_compiled(*(a[20] for a in fit_args(run)))
    batch = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(run, 20))
    np.testing.assert_array_equal(model.window_weights_, batch.window_weights_)


def test_switched_off_the_note_says_so(reference):
    assert not _kernels.fast_path_available() and "switched off" in _kernels.fast_path_note()


@pytest.mark.parametrize("field, value, match", [
    ("shape", np.array([np.nan, 0.0]), "'shape' parameter.*finite"),
    ("shape_velocity", np.array([1e13, 0.0]), "'shape_velocity' parameter"),
    ("body_velocity", np.array([0.0, np.inf, 0.0]), "'body_velocity' parameter.*finite"),
    ("phase", np.float64(np.nan), "'phase' parameter"),
    ("phase", 2e9, "'phase' parameter"),
])
def test_bad_samples_get_the_reference_errors_and_change_nothing(field, value, match):
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    model = AdaptiveGaitModel(gait=GAIT)
    one_at_a_time(model, run, stop=10)
    before = (model.window_weights_.copy(), model.covariance_.copy(), model.psi_.copy(), model.n_samples_seen_)
    sample = dict(zip(("phase", "shape", "shape_velocity", "body_velocity"), (a[10] for a in fit_args(run)),
                      strict=True))
    sample[field] = value
    with pytest.raises(GeogaitError, match=match):
        model.partial_fit(**sample)
    np.testing.assert_array_equal(model.window_weights_, before[0])
    np.testing.assert_array_equal(model.covariance_, before[1])
    np.testing.assert_array_equal(model.psi_, before[2])
    assert model.n_samples_seen_ == before[3]


def test_degrees_still_warn_on_the_compiled_path():
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    model = AdaptiveGaitModel(gait=GAIT)
    one_at_a_time(model, run, stop=10)
    phase, shape, rate, velocity = (a[10] for a in fit_args(run))
    with pytest.warns(GeogaitWarning, match="degrees"):
        model.partial_fit(phase, shape * 0 + 60.0, rate, velocity)


def test_other_inputs_take_the_reference_path():
    """Lists, ints, float32 and a time axis of one are accepted as before (by the reference path)."""
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    fast, slow = AdaptiveGaitModel(gait=GAIT), AdaptiveGaitModel(gait=GAIT)
    one_at_a_time(fast, run, stop=10)
    one_at_a_time(slow, run, stop=10, compiled=False)
    phase, shape, rate, velocity = (a[10] for a in fit_args(run))
    fast.partial_fit(float(phase), shape.tolist(), rate.astype(np.float32), velocity.tolist())
    slow.partial_fit(float(phase), shape.tolist(), rate.astype(np.float32), velocity.tolist())
    fast.partial_fit(phase[None], shape[None], rate[None], velocity[None])
    slow.partial_fit(phase[None], shape[None], rate[None], velocity[None])
    assert_same_state(fast, slow)


@needs_numba
def test_one_compiled_signature_serves_every_caller():
    """A second signature would compile again (seconds) at some later sample: warm_up's must be the only one."""
    import io

    from _reference import lines

    from geogait.learn import StreamLearner, run_stream

    assert _kernels.warm_up()
    kernel = _kernels.learn_one_kernel()
    signatures = len(kernel.signatures)
    for links in (2, 3, 5):
        gait = seed_gait(links - 1)
        run = simulate(PurcellSwimmer(links), gait, 1, seed=0, sensor_noise=0.1)
        run_stream(StreamLearner(AdaptiveGaitModel(gait=gait)), io.StringIO(lines(run)), io.StringIO())
        model = AdaptiveGaitModel(gait=gait, forgetting_factor=1, gamma_forgetting=1, interaction=False)
        model.fit(*fit_args(run, 30))  # a batch first (ψ is then a strided view)
        one_at_a_time(model, run, start=30, stop=40)
        assert model.n_samples_seen_ == 40
    assert len(kernel.signatures) == signatures


def test_geogait_stream_says_in_one_line_when_numba_is_missing(monkeypatch, tmp_path):
    import json

    from _reference import lines
    from typer.testing import CliRunner

    from geogait.cli import app

    monkeypatch.setattr(_kernels, "_kernel", None)
    monkeypatch.setattr(_kernels, "_missing", "No module named 'numba'")
    config = tmp_path / "config.json"
    config.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    run = simulate(SWIMMER, GAIT, 1, seed=0)
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "model.npz")],
                                input=lines(run, stop=20))
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if "numba" in line]
    assert len(notes) == 1 and "pip install 'geogait[fast]'" in notes[0]


# -- the compiled net motion per cycle (steering solves) and nearest-segment search (planning) --------------


@needs_numba
@settings(max_examples=10, deadline=None)
@given(links=st.sampled_from([2, 3, 5, 9]), interaction=st.booleans(), order=st.sampled_from([1, 2]),
       resolution=st.sampled_from([8, 64, 128]), jacobian=st.booleans(), seed=st.integers(0, 2**16))
def test_compiled_and_reference_net_motion_agree(links, interaction, order, resolution, jacobian, seed):
    from geogait.models._displacement import ModelTerms, displacement_from_terms

    rng = np.random.default_rng(seed)
    gait = seed_gait(links - 1)
    run = simulate(PurcellSwimmer(links), gait, 2, seed=seed, sensor_noise=0.1,
                   perturbation=Perturbation.from_std(0.1))
    model = AdaptiveGaitModel(gait=gait, interaction=interaction).fit(*fit_args(run))
    candidate = gait.with_order(order)
    candidate = candidate.with_params(candidate.params + 0.1 * rng.standard_normal(candidate.params.size))
    assert _kernels.displacement_kernel() is not None
    terms = ModelTerms.of(model, resolution)
    fast = displacement_from_terms(terms, candidate, jacobian, compiled=True)
    slow = displacement_from_terms(terms, candidate, jacobian)
    for a, b in zip(*((fast, slow) if jacobian else ((fast,), (slow,))), strict=True):
        assert_close(a, b)


def test_a_batched_model_takes_the_reference_net_motion():
    """The kernel serves one model; a batch of trials gives one answer per trial through NumPy."""
    from geogait.models._displacement import ModelTerms, displacement_from_terms

    runs = [simulate(SWIMMER, GAIT, 2, seed=seed, sensor_noise=0.1) for seed in (0, 1)]
    stacked = [np.stack([a for a in arrays]) for arrays in zip(*(fit_args(run) for run in runs), strict=True)]
    batched = AdaptiveGaitModel(gait=GAIT).fit(*stacked)
    single = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(runs[1]))
    pose = displacement_from_terms(ModelTerms.of(batched, 64), GAIT, compiled=True)
    assert pose.shape == (2, 3)
    assert_close(pose[1], displacement_from_terms(ModelTerms.of(single, 64), GAIT))


def test_the_optimiser_keeps_the_reference_net_motion(monkeypatch):
    """predicted_displacement (the optimiser's and the paper figures' path) never runs compiled, so their
    published numbers do not move by rounding."""
    from geogait.models import predicted_displacement

    monkeypatch.setattr(_kernels, "displacement_kernel", lambda: pytest.fail("the kernel was used"))
    model = AdaptiveGaitModel(gait=GAIT).fit(*fit_args(simulate(SWIMMER, GAIT, 2, seed=0, sensor_noise=0.1)))
    assert predicted_displacement(model, GAIT, jacobian=True)[1].shape == (3, GAIT.params.size)


@needs_numba
@settings(max_examples=15, deadline=None)
@given(kind=st.sampled_from(["circle", "figure8", "square"]), near=st.one_of(st.none(), st.floats(-5, 30)),
       window=st.floats(0.05, 3.0), spread=st.floats(0.01, 3.0), seed=st.integers(0, 2**16))
def test_compiled_nearest_segment_gives_the_reference_bits(kind, near, window, spread, seed):
    from geogait.control import ReferencePath

    path = {"circle": ReferencePath.circle(2.0), "figure8": ReferencePath.figure8(3.0),
            "square": ReferencePath.waypoints([[0, 0], [3, 0], [3, 2], [0, 2], [0, 0]])}[kind]
    positions = path.point(np.random.default_rng(seed).uniform(0, path.length, (3, 7)))[..., None, :] + \
        spread * np.random.default_rng(seed + 1).standard_normal((3, 7, 5, 2))
    assert _kernels.nearest_segment_kernel() is not None
    fast = path.project(positions, near=near, window=window)
    enabled, _kernels.ENABLED = _kernels.ENABLED, False
    try:
        slow = path.project(positions, near=near, window=window)
    finally:
        _kernels.ENABLED = enabled
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a, b)


@needs_numba
@settings(max_examples=10, deadline=None)
@given(links=st.sampled_from([3, 5, 9]), degree=st.integers(1, 3), symmetry=st.sampled_from([None, "mirror"]),
       order=st.sampled_from([1, 2]), jacobian=st.booleans(), seed=st.integers(0, 2**16))
def test_compiled_and_reference_shape_space_net_motion_agree(links, degree, symmetry, order, jacobian, seed):
    """(Not 2 links: one joint's loop encloses no area, both paths give rounding noise around zero.)"""
    from geogait.models import ShapeSpaceModel

    rng = np.random.default_rng(seed)
    gait = seed_gait(links - 1)
    run = simulate(PurcellSwimmer(links), gait, 2, seed=seed, sensor_noise=0.1, perturbation=Perturbation.from_std(0.1))
    model = ShapeSpaceModel(degree=degree, symmetry=symmetry, shape_scale=float(rng.uniform(0.5, 2.0)))
    model.fit(*fit_args(run))
    candidate = gait.with_order(order)
    candidate = candidate.with_params(candidate.params + 0.1 * rng.standard_normal(candidate.params.size))
    assert _kernels.shape_space_kernel() is not None
    fast = model.predict_displacement(candidate, jacobian=jacobian, compiled=True)
    slow = model.predict_displacement(candidate, jacobian=jacobian)
    for a, b in zip(*((fast, slow) if jacobian else ((fast,), (slow,))), strict=True):
        assert_close(a, b)


def test_the_shape_space_model_predicts_through_numpy_unless_asked(monkeypatch):
    """The optimiser's path (compiled=False, the default) and batched models never run the kernel."""
    from geogait.models import ShapeSpaceModel

    run = simulate(SWIMMER, GAIT, 2, seed=0, sensor_noise=0.1)
    monkeypatch.setattr(_kernels, "shape_space_kernel", lambda: pytest.fail("the kernel was used"))
    ShapeSpaceModel().fit(*fit_args(run)).predict_displacement(GAIT, jacobian=True)
    runs = [simulate(SWIMMER, GAIT, 2, seed=seed, sensor_noise=0.1) for seed in (0, 1)]
    stacked = [np.stack(arrays) for arrays in zip(*(fit_args(r) for r in runs), strict=True)]
    monkeypatch.setattr(_kernels, "shape_space_kernel", lambda: None)  # (what a missing numba gives)
    assert ShapeSpaceModel().fit(*stacked).predict_displacement(GAIT, compiled=True).shape == (2, 3)
