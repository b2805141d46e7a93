"""Net displacement per cycle and its gradient: chain rule against central finite differences."""

import numpy as np
import pytest

from geogait import se2
from geogait.gaits import FourierGait, seed_gait
from geogait.models import AdaptiveGaitModel, BatchGaitModel, predicted_displacement
from geogait.simulate import cycle_displacement, simulate
from geogait.systems import PurcellSwimmer


def central_differences(function, params, h=1e-6):
    columns = []
    for k in range(params.size):
        step = np.zeros(params.size)
        step[k] = h
        columns.append((function(params + step) - function(params - step)) / (2 * h))
    return np.stack(columns, axis=-1)


def test_product_of_exponentials_jacobian(rng):
    base, direction = rng.normal(size=(2, 30, 3)) * 0.3
    coefficients = rng.normal(size=(30, 3, 4))

    def steps(p):
        return base + coefficients @ p

    p0 = rng.normal(size=4) * 0.1
    pose, jacobian = se2.product_of_exponentials(steps(p0), coefficients)
    np.testing.assert_allclose(pose, se2.displacement(steps(p0), 1.0), atol=1e-14)
    fd = central_differences(lambda p: se2.product_of_exponentials(steps(p)), p0)
    np.testing.assert_allclose(jacobian, fd, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("n_links", [3, 5])
def test_oracle_jacobian_matches_finite_differences(rng, n_links):
    swimmer = PurcellSwimmer(n_links)
    gait = FourierGait(rng.normal(scale=0.5, size=(n_links - 1, 5)))
    _, jacobian = cycle_displacement(swimmer, gait, jacobian=True)
    fd = central_differences(lambda p: cycle_displacement(swimmer, gait.with_params(p)), gait.params)
    assert np.abs(jacobian - fd).max() < 1e-6 * np.abs(fd).max()


@pytest.fixture(scope="module")
def fitted():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    run = simulate(swimmer, gait, 20, seed=0)
    args = (run.phase, run.shape, run.shape_velocity, run.body_velocity)
    return swimmer, gait, AdaptiveGaitModel(gait=gait).fit(*args), BatchGaitModel(gait=gait).fit(*args)


@pytest.mark.parametrize("which", [2, 3])
def test_model_gradient_matches_finite_differences(fitted, which):
    swimmer, gait, *models = fitted
    model = models[which - 2]
    candidate = FourierGait(gait.coefficients + np.array([[0.05, -0.04, 0.03], [0.02, 0.06, -0.05]]))
    _, jacobian = predicted_displacement(model, candidate, jacobian=True)
    fd = central_differences(lambda p: predicted_displacement(model, candidate.with_params(p)), candidate.params)
    assert np.abs(jacobian - fd).max() < 1e-6 * np.abs(fd).max()


def test_model_prediction_agrees_with_the_oracle_near_the_gait(fitted):
    swimmer, gait, model, _ = fitted
    for candidate in (gait, FourierGait(gait.coefficients + 0.05)):
        truth = cycle_displacement(swimmer, candidate)
        predicted = predicted_displacement(model, candidate)
        assert np.abs(predicted - truth).max() < 0.05 * np.linalg.norm(truth[:2])
    _, model_gradient = predicted_displacement(model, gait, jacobian=True)
    _, true_gradient = cycle_displacement(swimmer, gait, jacobian=True)
    cosine = np.sum(model_gradient * true_gradient) / np.linalg.norm(model_gradient) / np.linalg.norm(true_gradient)
    assert cosine > 0.95


def test_batched_model_gives_one_displacement_per_trial():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    run = simulate(swimmer, gait, 5, seed=1, n_trials=3)
    model = AdaptiveGaitModel(gait=gait).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    pose, jacobian = predicted_displacement(model, jacobian=True)
    assert pose.shape == (3, 3) and jacobian.shape == (3, 3, 6)
    single = AdaptiveGaitModel(gait=gait).fit(run.phase[1], run.shape[1], run.shape_velocity[1], run.body_velocity[1])
    np.testing.assert_allclose(pose[1], predicted_displacement(single), atol=1e-12)
    with pytest.raises(ValueError, match="'gait'"):
        predicted_displacement(model, seed_gait(3))
