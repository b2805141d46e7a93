"""The Safety part: what protects the robot from the model. Settling cycles after a gait change are run but not
learned from; gaits whose tracking error exceeds the limit are rejected and the gait from before commanded again
(a climb candidate falls back to the climb's base); the automatic tracking limit judges the climb's gaits by what
they measure and follows the gait the climb keeps or hands back from; and the revert brings back the best gait
measured when the model leads downhill."""

import numpy as np
import pytest
from _robots import LaggingRobot, SaturatingRobot
from _robots import MisleadingPoses as _MisleadingPoses
from _robots import perturbed_stream as _stream

from geogait.gaits import seed_gait
from geogait.optimize import Climb, Gate, InSituOptimizer, ModelStep, Safety, read_checkpoint_metadata
from geogait.optimize._climb import MeasuredClimb
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def test_measured_outcomes_bring_back_the_best_gait_when_the_model_leads_downhill():
    def run(**options):
        stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.05, seed=6)
        # the stream explores on its own (exploration=None): the run this test was measured on
        result = InSituOptimizer(family="free", exploration=None, **options).run(
            _MisleadingPoses(stream, seed_gait(2)), 30)
        measured = result.log[~result.log["settling"]].groupby("iteration")["measured_objective"].mean()
        return result, measured

    guarded, measured = run(climb=False)
    assert guarded.log["reverted"].any()
    assert guarded.summary()["reverted_to_best"] == int(guarded.log["reverted"].sum())
    assert measured.iloc[-1] >= 0.8 * measured.max()  # it ends on (or back near) the best gait measured
    # the reverts count as broken promises: the climb takes over, and hands over its best
    climbing, _ = run(climb=Climb(start="stalled"))
    log = climbing.log
    final = np.all(np.isclose(log.filter(like="param_").to_numpy(), climbing.final_gait.params), axis=1)
    assert log["reverted"].any() and log["climb"].any()
    assert log.loc[final & ~log["settling"], "measured_objective"].mean() >= 0.8 * measured.max()
    unguarded, measured_off = run(safety=Safety(revert_tolerance=None), climb=False)
    assert not unguarded.log["reverted"].any()
    assert measured_off.iloc[-1] < 0.6 * measured_off.max()  # without it, the model walks the robot downhill


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
