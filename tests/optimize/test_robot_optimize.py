"""The in-situ optimiser on robots it did not simulate: measured objective, direction, feasibility,
settling, checkpoint and resume."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
from _robots import BareRobot, LaggingRobot, SaturatingRobot
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
    read_checkpoint_metadata,
)
from geogait.optimize._climb import MeasuredClimb
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


def test_saturated_actuators_are_detected_and_their_steps_rejected():
    # the model's steps alone (climb=False): what the tracking check does to them
    options = dict(step=ModelStep(trust_radius=0.15, max_trust_radius=0.3), gate=Gate(prediction_tolerance=None),
                   climb=False)
    result = InSituOptimizer(**options).run(SaturatingRobot(limit=1.1), 40)
    log = result.log
    limit = max(0.05, 2 * log.loc[log["iteration"] == 0, "tracking_error"].mean())  # "auto": twice the seed's
    assert result.n_rejected >= 1
    assert np.all(log.loc[log["rejected"], "tracking_error"] > limit)
    # each rejection commands the gait from before the rejected step again
    reverts = sum(result.gaits[k + 2] == result.gaits[k] for k in range(len(result.gaits) - 2))
    assert reverts >= result.n_rejected
    assert log.loc[~log["rejected"], "tracking_error"].max() <= 1.1 * limit
    # without the check the optimiser drives the joints far past what they can follow
    unchecked = InSituOptimizer(**options, safety=Safety(max_tracking_error=None)).run(SaturatingRobot(limit=1.1),
                                                                                       40).log
    assert not unchecked["rejected"].any() and unchecked["tracking_error"].max() > 2 * limit


def test_the_climb_judges_gaits_the_actuators_follow_badly_by_their_measured_outcome(tmp_path):
    """With the automatic tracking limit the climb's gaits are judged by what they measure, not refused for their
    tracking error (twice the seed's would have refused 17 of this run's candidates); the run ends well above the
    seed, and the limit for the model's steps follows the gait the climb kept last: twice what its cycles track."""
    result = InSituOptimizer(safety=Safety(settle_cycles=1)).run(SaturatingRobot(limit=1.05), 60,
                                                                 checkpoint=tmp_path / "run.npz")
    log = result.log
    measured = ~log["settling"]
    seed = log.loc[measured & (log["iteration"] == 0), ["tracking_error", "measured_objective"]].mean()
    seed_limit = max(0.05, 2 * seed["tracking_error"])
    assert not log["rejected"].any()
    assert (log["candidate"] & (log["tracking_error"] > seed_limit)).sum() >= 5
    assert log.loc[measured, "measured_objective"].tail(4).mean() > 1.3 * seed["measured_objective"]
    params = log.filter(like="param_").to_numpy()
    kept = np.flatnonzero(np.all(params == result.final_gait.params, axis=1) & measured)
    its_cycles = log.loc[kept, "iteration"] == log.loc[kept[0], "iteration"]
    limit = read_checkpoint_metadata(tmp_path / "run.npz")["state"]["tracking_limit"]
    assert limit == pytest.approx(2 * log.loc[kept[its_cycles], "tracking_error"].mean(), rel=1e-12)
    assert limit > 2 * seed_limit


def test_a_climb_handing_back_holds_the_models_steps_to_what_its_base_tracks(monkeypatch):
    """When the climb hands the steps back to the model without having kept a candidate, its base is a gait the
    model's steps reached, whose tracking error the automatic limit never followed: the limit must now follow the
    base's cycles, or every model step from it would be refused against twice what the seed tracked. (On this lagging
    robot the second climb's base tracks 0.196 rad against the seed's 0.101.)"""
    trusted = MeasuredClimb.model_trusted_again.fget
    rows, handed_back = [], []

    def spy(climb):
        if trusted(climb):
            handed_back.append((len(rows), climb.base[0].params.copy()))
        return trusted(climb)

    monkeypatch.setattr(MeasuredClimb, "model_trusted_again", property(spy))
    # (the mechanism alone: no settling probe, no Adaptation's checks, which move this run's hand-back)
    log = InSituOptimizer(climb=Climb(rule="es"), safety=Safety(settle_cycles=0), checks=[],
                          random_state=7).run(LaggingRobot(), 80, callback=rows.append).log
    assert handed_back
    params = log.filter(like="param_").to_numpy()
    seed_limit = max(0.05, 2 * log.loc[log["iteration"] == 0, "tracking_error"].mean())
    for cycle, base in handed_back:
        runs = np.flatnonzero(np.all(params == base, axis=1) & ~log["settling"].to_numpy())
        first = runs[runs > cycle][0]  # the base's first measured cycle after the hand-back
        assert log["tracking_limit"].iloc[first] == pytest.approx(
            max(0.05, 2 * log["tracking_error"].iloc[first]), rel=1e-12)
    assert log["tracking_limit"].iloc[-1] > 1.5 * seed_limit  # (the old limit would have stayed at the seed's)


@pytest.mark.parametrize("climb_rule", ["cobyqa", "bayes"])
def test_a_climb_candidate_the_actuators_cannot_follow_falls_back_to_the_climbs_base(climb_rule):
    """Under a tracking limit of one's own (a number: what the robot must not exceed), a climb candidate beyond it is
    rejected and goes back to the climb's base, a gait the climb kept, never to the candidate commanded before it
    (which may itself have failed): after every rejection the next gait is one the run kept before (a row that was
    not an unjudged candidate)."""
    result = InSituOptimizer(climb=Climb(rule=climb_rule), safety=Safety(settle_cycles=1, max_tracking_error=0.25)).run(
        SaturatingRobot(limit=1.05), 60)
    log = result.log
    params = log.filter(like="param_").to_numpy()
    rejected = np.flatnonzero(log["rejected"].to_numpy())
    assert len(rejected) >= 1 and log.loc[log["rejected"], "candidate"].all()
    for k in rejected:
        kept_before = [params[j] for j in range(k) if not log["candidate"].iloc[j] and not log["settling"].iloc[j]]
        assert any(np.array_equal(params[k + 1], p) for p in kept_before)


def test_settle_cycles_are_run_but_not_learned_from():
    result = InSituOptimizer(safety=Safety(settle_cycles=1)).run(_stream(seed=4), 16)
    log = result.log
    steps = log.index[log["step"]]
    assert len(steps) >= 2
    settling = log.index[log["settling"]]
    expected = [0] + [s + 1 for s in steps if s + 1 < len(log)]  # the start counts as a change too
    np.testing.assert_array_equal(settling, expected)
    assert log.loc[settling, ["gamma", "measured_objective"]].isna().all().all()
    assert not log.loc[settling, "step"].any()


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


@pytest.mark.parametrize("start", ["stalled", "contradicted"])
def test_model_steps_the_robot_cannot_follow_hand_the_steps_to_the_measured_climb(start):
    """Joints that stop at 1.1 rad: the model (kinematic, no actuator limits) keeps proposing larger gaits, which
    the robot cannot follow and which do not gain what the model promised. Two such rejections without a kept
    promise between them are two broken promises: the climb takes over (before they counted, none had by cycle
    30)."""
    log = InSituOptimizer(climb=Climb(start=start), safety=Safety(settle_cycles=0)).run(  # (no settling probe)
        LaggingRobot(cycle_period=20.0, joint_stop=1.1, seed=1), 30).log
    assert log["climb"].any()
    first = int(np.flatnonzero(log["climb"])[0])
    assert log["rejected"][:first].sum() >= 2
