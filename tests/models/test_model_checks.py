"""Models check what they learn from and what they save (issue 11): values that would overflow, malformed arrays,
rebase's arguments, a failed fit that changes nothing, variances and phases that would come back as NaN, a
non-finite state never saved, PhaseModel files."""

import numpy as np
import pytest
from _noisy_run import run as run
from _reference import GAIT

from geogait import GeogaitError
from geogait.gaits import seed_gait
from geogait.models import AdaptiveGaitModel, PhaseModel, load_model


def test_models_refuse_values_that_would_overflow(run):
    model = AdaptiveGaitModel(gait=GAIT)
    body = run.body_velocity[:10].copy()
    body[3, 0] = 1e200
    with pytest.raises(GeogaitError, match=r"'body_velocity' parameter of AdaptiveGaitModel.partial_fit must be "
                                           r"plausible values, within ±1e\+12. Got '1e\+200 at index \(3, 0\)'"):
        model.partial_fit(run.phase[:10], run.shape[:10], run.shape_velocity[:10], body)
    assert not hasattr(model, "batch_shape_")  # nothing learned


def test_a_non_finite_model_is_never_saved(run, tmp_path):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    path = model.save(tmp_path / "m.npz")
    before = path.read_bytes()
    model.bank_.weights[0, 0, 0] = np.nan
    with pytest.raises(GeogaitError, match=r"Refusing to save .*m.npz: the state went non-finite \(NaN or inf in "
                                           r"weights\)"):
        model.save(path)
    assert path.read_bytes() == before and list(tmp_path.iterdir()) == [path]


def test_phase_model_saves_and_loads(run, tmp_path):
    model = PhaseModel(n_windows=12).fit(run.phase, run.body_velocity)
    loaded = load_model(model.save(tmp_path / "phase.npz"))
    assert isinstance(loaded, PhaseModel) and loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.predict(run.phase), model.predict(run.phase))
    assert PhaseModel.load(tmp_path / "phase.npz").n_samples_seen_ == run.n_samples


def test_rebase_validates_every_argument_before_changing_anything(run):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    weights, covariance = model.window_weights_.copy(), model.covariance_.copy()
    new_gait = seed_gait(2, 1.2)
    for kwargs, name in (({"baseline": "bogus"}, "baseline"), ({"covariance_inflation": 0.5}, "covariance_inflation"),
                         ({"constant_variance": -1.0}, "constant_variance"), ({"terms": "x"}, "terms")):
        with pytest.raises(GeogaitError, match=f"'{name}' parameter of AdaptiveGaitModel.rebase"):
            model.rebase(new_gait, **kwargs)
        np.testing.assert_array_equal(model.window_weights_, weights)
        np.testing.assert_array_equal(model.covariance_, covariance)
        assert model.gait_ == GAIT


@pytest.mark.parametrize("arrays, message", [
    (lambda r: (None, r.shape, r.shape_velocity, r.body_velocity), r"'phase' .* an array of real numbers. Got None"),
    (lambda r: (r.phase[:0], r.shape[:0], r.shape_velocity[:0], r.body_velocity[:0]), r"at least one sample"),
    (lambda r: (r.phase, r.shape.T, r.shape_velocity, r.body_velocity), r"'shape' .*\(transposed\?"),
    (lambda r: (r.phase, r.shape, r.shape_velocity, r.body_velocity.T), r"'body_velocity' .*\(transposed\?"),
    (lambda r: (r.phase, r.shape + 1j, r.shape_velocity, r.body_velocity), r"'shape' .* real numbers. Got 'complex"),
    (lambda r: (r.phase.astype(str), r.shape, r.shape_velocity, r.body_velocity), r"'phase' .* Got 'text \(<U"),
    (lambda r: (r.phase, r.shape, r.shape_velocity.astype(object).astype(str).astype(object), r.body_velocity),
     r"'shape_velocity' .* Got 'text, booleans or complex numbers among"),
    (lambda r: (r.phase[None, :0], r.shape[None, :0], r.shape_velocity[None, :0], r.body_velocity[None, :0]),
     r"at least one sample"),
    (lambda r: (r.phase[None][:0], r.shape[None][:0], r.shape_velocity[None][:0], r.body_velocity[None][:0]),
     r"'phase' .* at least one trial along each leading axis"),
    (lambda r: (r.phase, r.shape[:, :0], r.shape_velocity[:, :0], r.body_velocity), r"'shape' .* at least one column"),
])
def test_partial_fit_bad_arrays_have_clear_errors(run, arrays, message):
    with pytest.raises(GeogaitError, match=message):
        AdaptiveGaitModel(gait=GAIT).partial_fit(*arrays(run))


def test_a_failed_fit_leaves_the_fitted_model_unchanged(run):
    model = AdaptiveGaitModel(gait=GAIT).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    weights, seen = model.window_weights_.copy(), model.n_samples_seen_
    with pytest.raises(GeogaitError, match="'shape_velocity' parameter"):
        model.fit(run.phase, run.shape, run.shape_velocity[:, :1], run.body_velocity)
    np.testing.assert_array_equal(model.window_weights_, weights)
    assert model.n_samples_seen_ == seen
    phase_model = PhaseModel().fit(run.phase, run.body_velocity)
    with pytest.raises(GeogaitError, match="'body_velocity' parameter"):
        phase_model.fit(run.phase, run.body_velocity[:, :2])
    assert phase_model.n_samples_seen_ == run.n_samples


def test_helpers_refuse_what_would_come_back_as_nan(run):
    """A negative or NaN residual variance, a NaN phase, a negative derivative order: each a clear error, where
    each once returned NaN (or a silent answer) for the caller to carry on with."""
    from geogait.gaits import fourier_basis
    from geogait.models import ResistanceModel, ShapeSpaceModel
    from geogait.systems import PurcellSwimmer

    arrays = (run.phase, run.shape, run.shape_velocity, run.body_velocity)
    for model in (AdaptiveGaitModel(gait=GAIT).fit(*arrays), ShapeSpaceModel().fit(*arrays),
                  ResistanceModel.from_swimmer(PurcellSwimmer(3)).fit(*arrays)):
        for variance in (-1.0, np.nan, "x"):
            with pytest.raises(GeogaitError, match=r"'residual_variance' parameter .* a variance >= 0"):
                model.rotation_std(GAIT, variance)
        assert np.isfinite(model.rotation_std(GAIT, 0.01))
    with pytest.raises(GeogaitError, match=r"'phase' parameter of fourier_basis must be finite"):
        GAIT.shape(np.array([0.0, np.nan]))
    with pytest.raises(GeogaitError, match=r"'derivative' parameter of fourier_basis must be an int >= 0"):
        fourier_basis(0.0, 2, derivative=-1)
    np.testing.assert_allclose(fourier_basis(0.3, 1, derivative=1), [0.0, -np.sin(0.3), np.cos(0.3)])
