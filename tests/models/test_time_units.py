"""Time in seconds at any cycle period: models and the optimiser give the same answer as in cycles."""

from pathlib import Path

import numpy as np
import pytest

from geogait.gaits import Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel, BatchGaitModel, load_model
from geogait.optimize import InSituOptimizer
from geogait.simulate import SwimmerStream, simulate
from geogait.systems import PurcellSwimmer

DATA = Path(__file__).resolve().parents[1] / "data"


def _stream(period, seed=4):
    # eq. 8 rescaled to the period: the same perturbation path in phase, so the same experiment.
    perturbation = Perturbation.from_std(0.15, frequency=2.0 / period)
    return SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=perturbation, sensor_noise=0.1, seed=seed,
                         cycle_period=period)


@pytest.mark.parametrize("model_class", [AdaptiveGaitModel, BatchGaitModel])
def test_models_predict_the_same_motion_at_any_period(model_class):
    predictions = {}
    for period in (1.0, 3.7):
        run = _stream(period).next_cycles(6)
        model = model_class(gait=seed_gait(2), phase_rate=2 * np.pi / period).fit(
            run.phase, run.shape, run.shape_velocity, run.body_velocity)
        # ξ per second scales as 1 / period; the net motion per cycle does not depend on it.
        predictions[period] = (model.predict(run.phase, run.shape, run.shape_velocity) * period,
                               model.predict_displacement())
    np.testing.assert_allclose(predictions[1.0][0], predictions[3.7][0], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(predictions[1.0][1], predictions[3.7][1], rtol=1e-7, atol=1e-10)


def test_optimiser_takes_the_same_steps_in_seconds_at_any_period():
    # the window model works in cycle time; the shape-space model (the symmetric family's default) regresses
    # ξ on ṙ in seconds, so its fixed prior weighs differently at another period: free family here
    results = {period: InSituOptimizer(family="free").run(_stream(period), 10) for period in (1.0, 2.5, 0.2)}
    reference = results[1.0]
    assert reference.n_steps >= 3
    for period, result in results.items():
        assert result.n_steps == reference.n_steps
        np.testing.assert_allclose(result.final_gait.params, reference.final_gait.params, atol=1e-8)
        # measured motion per cycle is period-free; speed per second is progress / period
        np.testing.assert_allclose(result.log["measured_progress"], reference.log["measured_progress"], rtol=1e-7)
        np.testing.assert_allclose(result.log["measured_speed"] * period, reference.log["measured_progress"],
                                   rtol=1e-7)


@pytest.mark.parametrize("name", ["adaptive", "batch"])
def test_version_1_model_files_load_with_the_same_predictions(name):
    # Written by geogait 0.1 (format version 1: regression in the data's own time, period 2 s).
    expected = np.load(DATA / "model_v1_period2_expected.npz")
    model = load_model(DATA / f"{name}_model_v1_period2.npz")
    assert model.phase_rate == pytest.approx(np.pi)
    prediction = model.predict(expected["phase"], expected["shape"], expected["shape_velocity"])
    np.testing.assert_allclose(prediction, expected[name], rtol=1e-9, atol=1e-12)


def test_a_model_in_seconds_matches_one_fitted_on_cycle_time_data():
    period = 0.5
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=5, seed=0, cycle_period=period)
    seconds = AdaptiveGaitModel(gait=seed_gait(2), phase_rate=2 * np.pi / period).fit(
        run.phase, run.shape, run.shape_velocity, run.body_velocity)
    cycles = AdaptiveGaitModel(gait=seed_gait(2)).fit(
        run.phase, run.shape, run.shape_velocity * period, run.body_velocity * period)
    np.testing.assert_allclose(seconds.coefficients(run.phase[:7])["A"], cycles.coefficients(run.phase[:7])["A"],
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(seconds.coefficients(run.phase[:7])["C"] * period,
                               cycles.coefficients(run.phase[:7])["C"], rtol=1e-9, atol=1e-12)
    assert seconds.gamma_ == pytest.approx(cycles.gamma_, rel=1e-9)
