"""The composed in-situ optimiser's run as a whole (``InSituOptimizer.run``), not any one part: on a noise-free
swimmer it improves the seed gait, logs every cycle and leaves a result that carries the model it learned; its own
parameters (model, family, order, the robot, the callback, the checkpoint, the parts it is given) are checked before
the robot moves; each cycle a robot returns is checked and measured; a run without truth is judged by measurement;
and a checkpointed run resumes bit-identically to the uninterrupted one, from checkpoints old and new."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
from _robots import BareRobot, SaturatingRobot
from _robots import perturbed_stream as _stream

from geogait._validation import GeogaitError
from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel, BatchGaitModel, ShapeSpaceModel
from geogait.optimize import Climb, Exploration, Gate, InSituOptimizer, ModelClassTest, ModelStep, Objective, Safety
from geogait.robots import Robot
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def noise_free_run():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=0)
    # the model steps first: the paper's loop
    return InSituOptimizer(climb=Climb(start="stalled")).run(stream, 25, record=True)


def test_optimiser_improves_the_seed_gait_on_a_noise_free_swimmer(noise_free_run):
    log = noise_free_run.log
    assert noise_free_run.n_steps >= 5
    assert log["improvement"].iloc[-1] > 0.5  # the ceiling is +97 %; the paper reports ≈ +50 % in 40 cycles
    assert log["true_objective"].iloc[-1] > log["true_objective"].iloc[0]
    assert noise_free_run.trajectory.n_samples == 25 * 100


def test_log_columns_and_gaits(noise_free_run):
    log = noise_free_run.log
    assert {"cycle", "gamma", "step", "trust_radius", "true_progress", "true_heading", "improvement",
            "param_0", "param_5"} <= set(log.columns)
    assert len(noise_free_run.gaits) == noise_free_run.n_steps + 1
    # the last gait commanded, unless the run ends on a climb candidate not yet judged: then its base
    final = noise_free_run.final_gait
    last_run = log.filter(like="param_").to_numpy()[-1]
    assert final == noise_free_run.gaits[-1] or (final in noise_free_run.gaits and not log["candidate"].iloc[-1]
                                                 and np.allclose(final.params, last_run))
    # A model step is only taken when the online Γ over the iteration reached Γ* (the climb's are not).
    model_steps = log["step"] & ~log["climb"] & ~log["period_change"]
    assert model_steps.any() and np.all(log.loc[model_steps, "gamma"] >= 0.5)


def test_result_carries_the_model_the_run_learned(noise_free_run):
    """In the symmetric family the default model is the symmetric shape-space model, and the model
    the run leaves predicts the final gait's motion."""
    model = noise_free_run.model
    assert isinstance(model, ShapeSpaceModel) and model.symmetry == "mirror+reversal"
    truth = cycle_displacement(PurcellSwimmer(3), noise_free_run.final_gait)[:2]
    seed = cycle_displacement(PurcellSwimmer(3), noise_free_run.initial_gait)[:2]
    predicted = model.predict_displacement(noise_free_run.final_gait)[:2]
    assert np.linalg.norm(truth) > 1.5 * np.linalg.norm(seed)  # the run moved far from the seed ...
    assert np.linalg.norm(predicted - truth) < 0.05 * np.linalg.norm(truth)  # ... and the model followed


def test_free_family_default_model_is_the_window_model_recentred_on_the_last_gait():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=0)
    result = InSituOptimizer(climb=Climb(start="stalled"), family="free").run(stream, 12)
    assert isinstance(result.model, AdaptiveGaitModel)
    assert result.model.forgetting_factor == pytest.approx(0.95)  # 1 − 0.1 / d for d = 2
    assert result.n_steps >= 1 and result.model.gait_ == result.final_gait  # re-centred on the last gait


def test_a_higher_order_family_starts_from_the_embedded_seed():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.0, seed=2)
    result = InSituOptimizer(order=2).run(stream, 6)
    assert result.initial_gait.order == 2
    phase = np.linspace(0, 6, 7)
    np.testing.assert_allclose(result.initial_gait.shape(phase), seed_gait(2).shape(phase))


def test_a_seed_of_higher_order_than_the_family_is_refused_and_the_robot_left_as_it_was():
    """Cutting the seed's second harmonics (stored at order 3) would optimise another gait than the robot's; and a
    run refused by any check (here: a seed that does not move, which has no shape scale) commands nothing."""
    coefficients = np.zeros((2, 7))
    coefficients[0, 1], coefficients[1, 2], coefficients[0, 5] = 1.0, 1.0, 0.3
    seed = FourierGait(coefficients)
    stream = SwimmerStream(PurcellSwimmer(3), seed, seed=0)
    with pytest.raises(GeogaitError, match=r"'order' parameter .* highest harmonic of the robot's seed gait \(2\)"):
        InSituOptimizer().run(stream, 2)
    assert stream.gait == seed
    still = FourierGait(np.zeros((2, 3)))
    lifted = SwimmerStream(PurcellSwimmer(3), still, seed=0)
    with pytest.raises(GeogaitError, match="a seed gait that moves its joints"):
        InSituOptimizer(family="free", order=2).run(lifted, 2)
    assert lifted.gait == still and lifted.gait.order == 1
    assert InSituOptimizer(order=3).run(SwimmerStream(PurcellSwimmer(3), seed, seed=0), 2).initial_gait == seed


@pytest.mark.parametrize(
    ("params", "match"),
    [
        (dict(gate="newton"), "'gate'"),
        (dict(gate=Gate(kind="newton")), "'kind'"),
        (dict(model="adaptive"), "'model'"),
        (dict(objective=Objective(kind="forward", direction=[0, 0])), "'direction'"),
        (dict(safety=Safety(max_tracking_error=-1.0)), "'max_tracking_error'"),
        (dict(safety=Safety(settle_cycles=-1)), "'settle_cycles'"),
        (dict(gate=Gate(gamma_threshold=1.5)), "'gamma_threshold'"),
        (dict(objective="speedy"), "'objective'"),
        (dict(order=0), "'order'"),
        (dict(step=ModelStep(trust_radius=5.0)), "'trust_radius'"),
        (dict(step=ModelStep(rebase="first")), "'rebase'"),
        (dict(climb="first"), "'climb'"),
        (dict(climb=Climb(min_sigma=1.0, max_sigma=0.5)), "'max_sigma'"),
        (dict(exploration=0.2), "'exploration'"),
        (dict(checks=[ModelClassTest(), ModelClassTest()]), "'checks'"),
        (dict(checks=[Gate()]), "'checks'"),
    ],
)
def test_bad_optimizer_parameters(params, match):
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    with pytest.raises(ValueError, match=match):
        InSituOptimizer(**params).run(stream, 2)


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
