"""The Gate part: when the model may step. The ``"cycles"`` gate of a batch model decides every ``cycles`` cycles
and no sooner, and the prediction check (``prediction_tolerance``) closes the gate when the model's prediction of
the current gait overstates what was measured, here on a robot whose actuators saturate."""

import numpy as np
from _robots import SaturatingRobot

from geogait.gaits import seed_gait
from geogait.models import BatchGaitModel
from geogait.optimize import Climb, Gate, InSituOptimizer, ModelStep, Safety
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def test_batch_baseline_steps_every_cycles_per_iteration():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=1)
    result = InSituOptimizer(model=BatchGaitModel(), gate=Gate(cycles=5), climb=Climb(start="stalled")).run(stream, 20)
    steps = result.log.loc[result.log["step"], "cycle"].to_numpy()
    assert len(steps) >= 2 and np.all(np.diff(steps) % 5 == 0) and steps[0] == 4
    assert result.log["true_objective"].iloc[-1] > result.log["true_objective"].iloc[0]


def test_the_prediction_check_closes_the_gate_when_the_model_overpredicts():
    log = InSituOptimizer(step=ModelStep(trust_radius=0.15, max_trust_radius=0.3), climb=False,
                          safety=Safety(max_tracking_error=None)).run(
        SaturatingRobot(limit=1.1), 25).log
    checked = log.dropna(subset=["prediction_ok"])
    failed = checked[checked["prediction_ok"] == 0]
    assert len(failed) >= 1 and not failed["step"].any()
    assert np.all(log.loc[log["step"], "prediction_ok"] == 1)
