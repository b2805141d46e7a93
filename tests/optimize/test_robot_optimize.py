"""The in-situ optimiser on robots it did not simulate: measured objective, direction, feasibility,
settling, checkpoint and resume."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
from _robots import BareRobot, SaturatingRobot
from _robots import perturbed_stream as _stream

from geogait.gaits import Perturbation, seed_gait
from geogait.models import BatchGaitModel, ShapeSpaceModel
from geogait.optimize import (
    Climb,
    Exploration,
    Gate,
    InSituOptimizer,
    ModelClassTest,
    ModelStep,
    Objective,
    Safety,
)
from geogait.robots import Robot
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


def test_robots_implement_the_protocol():
    assert isinstance(_stream(), Robot)
    assert isinstance(SaturatingRobot(), Robot)
    assert not isinstance(object(), Robot)
    with pytest.raises(ValueError, match="lacks cycle_period, gait, set_gait, next_cycle"):
        InSituOptimizer().run(type("Half", (), {"n_joints": 2})(), 3)


@pytest.mark.parametrize(("attribute", "value", "match"), [
    ("cycle_period", 0.0, r"'cycle_period' > 0 \(seconds, finite\). Got 0.0"),
    ("cycle_period", float("nan"), r"'cycle_period' > 0 .* Got nan"),
    ("cycle_period", "1", r"'cycle_period' > 0 .* Got '1'"),
    ("n_joints", 2.5, r"integer 'n_joints' >= 1. Got 2.5"),
    ("n_joints", True, r"integer 'n_joints' >= 1. Got True"),
    ("n_joints", 3, r"a gait of its 'n_joints' = 3 joints. Got a gait of 2"),
])
def test_a_robot_declaring_a_bad_period_or_joint_count_is_refused_before_it_runs(attribute, value, match):
    """These were found only after the robot had run (a ZeroDivisionError, or another model's parameter named)."""
    from geogait.control import PathTracker, ReferencePath

    robot = BareRobot(_stream())
    setattr(robot, attribute, value)
    for run in (lambda: InSituOptimizer().run(robot, 2), lambda: PathTracker().run(robot, ReferencePath.circle(1), 1)):
        with pytest.raises(ValueError, match=match):
            run()
    assert robot._stream.cycle == 0


@pytest.mark.parametrize(("options", "match"), [(dict(callback=42), "'callback' parameter of .* a callable"),
                                                (dict(record="yes"), "'record' parameter of .* True or False")])
def test_a_bad_callback_or_record_is_refused_before_the_robot_runs(options, match):
    """A callback that cannot be called failed at the end of the first cycles (3 of a path tracker's)."""
    from geogait.control import PathTracker, ReferencePath

    robot = BareRobot(_stream())
    for run in (lambda: InSituOptimizer().run(robot, 2, **options),
                lambda: PathTracker().run(robot, ReferencePath.circle(1), 1, **options)):
        with pytest.raises(ValueError, match=match):
            run()
    assert robot._stream.cycle == 0


def test_measured_motion_per_cycle_is_the_true_one_without_perturbations():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation(eta=0.0), seed=0,
                           samples_per_cycle=400)
    with pytest.warns(UserWarning, match="carry no exploration"):  # the stream's own exploration: none
        log = InSituOptimizer(exploration=None).run(stream, 4).log
    measured = log[["measured_x", "measured_y", "measured_heading"]].to_numpy()
    true = log[["true_x", "true_y", "true_heading"]].to_numpy()
    np.testing.assert_allclose(measured, true, atol=2e-4)  # zero-order hold at 400 samples vs Magnus
    np.testing.assert_allclose(measured[0], cycle_displacement(PurcellSwimmer(3), seed_gait(2)), atol=2e-4)


def test_a_robot_without_truth_is_judged_by_measurement():
    result = InSituOptimizer(climb=Climb(start="stalled")).run(BareRobot(_stream(seed=1)), 20, ceiling=0.1)
    log = result.log
    assert "true_objective" not in log and result.n_steps >= 3
    on_seed = log["iteration"] == 0
    seed = log.loc[on_seed, "measured_objective"].mean()  # once the seed's cycles are over
    later = ~on_seed
    np.testing.assert_allclose(log.loc[later, "improvement"], log.loc[later, "measured_objective"] / seed - 1)
    np.testing.assert_allclose(log["ceiling_fraction"], log["measured_objective"] / 0.1)
    assert log["measured_objective"].tail(5).mean() > 1.2 * seed


def _interrupted_then_resumed(tmp_path, make_optimizer, stop_after, n_cycles):
    path = tmp_path / "run.npz"

    def stop(row):
        if row["cycle"] == stop_after - 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        make_optimizer().run(_stream(seed=5), n_cycles, checkpoint=path, callback=stop, ceiling=0.1)
    return InSituOptimizer.resume(path, _stream(seed=5))


@pytest.mark.parametrize("make_optimizer", [
    lambda: InSituOptimizer(safety=Safety(settle_cycles=1)),
    lambda: InSituOptimizer(model=BatchGaitModel(), gate=Gate(cycles=3), objective=Objective(kind="forward")),
    lambda: InSituOptimizer(model=ShapeSpaceModel(degree=2), step=ModelStep(rule="sqp"), family="free"),
    lambda: InSituOptimizer(climb=Climb(rule="cobyqa"), safety=Safety(settle_cycles=1), family="free"),
    lambda: InSituOptimizer(climb=Climb(rule="bayes"), safety=Safety(settle_cycles=1), family="free"),
], ids=["adaptive", "batch-forward", "shape-space-sqp", "cobyqa-climb", "bayes-climb"])
def test_resume_is_bit_identical_to_an_uninterrupted_run(tmp_path, make_optimizer):
    whole = make_optimizer().run(_stream(seed=5), 14, ceiling=0.1)
    resumed = _interrupted_then_resumed(tmp_path, make_optimizer, stop_after=8, n_cycles=14)
    assert whole.n_steps >= 2
    np.testing.assert_array_equal(resumed.final_gait.params, whole.final_gait.params)
    pd.testing.assert_frame_equal(resumed.log, whole.log, check_dtype=False)
    assert resumed.gaits == whole.gaits


def test_resume_refuses_a_corrupt_checkpoint(tmp_path):
    path = tmp_path / "run.npz"
    path.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="corrupt or truncated"):
        InSituOptimizer.resume(path, _stream())


def test_checkpoint_options_are_validated_before_the_robot_moves(tmp_path):
    stream = _stream()
    with pytest.raises(ValueError, match="'checkpoint'"):
        InSituOptimizer().run(stream, 3, checkpoint=tmp_path / "missing" / "run.npz")
    with pytest.raises(ValueError, match="'checkpoint_every'"):
        InSituOptimizer().run(stream, 3, checkpoint=tmp_path / "run.npz", checkpoint_every=0)
    assert stream.cycle == 0


def test_cycles_from_a_robot_are_checked():
    class Broken(BareRobot):
        def next_cycle(self):
            chunk = super().next_cycle()
            return dataclasses.replace(chunk, body_velocity=np.full_like(chunk.body_velocity, np.nan))

    with pytest.raises(ValueError, match="'cycle.body_velocity'.*finite"):
        InSituOptimizer().run(Broken(_stream()), 2)


def test_a_run_that_cannot_be_checkpointed_is_refused_before_the_robot_moves(tmp_path):
    from geogait.models import PerfectInformationModel

    stream = _stream(seed=1)
    optimizer = InSituOptimizer(model=PerfectInformationModel(system=stream.current_system()))
    with pytest.raises(ValueError, match="'checkpoint' parameter of InSituOptimizer.run must be None for a "
                                         "PerfectInformationModel"):
        optimizer.run(stream, 4, checkpoint=tmp_path / "run.npz")
    assert stream.cycle == 0 and not (tmp_path / "run.npz").exists()
    assert optimizer.run(stream, 4).log.shape[0] == 4  # without a checkpoint it runs


def test_a_checkpoint_of_flat_parameters_resumes_as_the_same_composed_run():
    """Checkpoints written before the parts hold the optimiser's flat parameters: they are read as the same run,
    composed (a climb rule missing from them is the evolution strategy they ran)."""
    from geogait.optimize._presets import from_flat_params
    from geogait.optimize._state import params_from_json, params_to_json

    composed = params_from_json({"trust_radius": 0.05, "climb": True, "climb_rule": "cobyqa", "settle_cycles": 2,
                                 "model_class_cycles": 3, "exploration": 0.2})
    assert composed["step"] == ModelStep(trust_radius=0.05)
    assert composed["climb"] == Climb(start="stalled", rule="cobyqa")  # the radii the trust region gave it then
    assert composed["safety"] == Safety(settle_cycles=2) and composed["checks"] == [ModelClassTest(cycles=3)]
    assert composed["exploration"] == Exploration(std=0.2)
    assert from_flat_params({"climb": "first"})["climb"].rule == "es"
    assert params_from_json({"trust_radius": 0.1, "climb": False})["climb"] is False
    with pytest.raises(ValueError, match="unknown optimiser parameters"):
        from_flat_params({"trust_radius": 0.1, "bogus": 1})
    optimizer = InSituOptimizer(**composed)
    assert InSituOptimizer(**params_from_json(params_to_json(optimizer))).describe() == optimizer.describe()
