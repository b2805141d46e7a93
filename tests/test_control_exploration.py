"""Exploration sized online: the swimmer stream that changes δ between cycles, the rule, the tracker option."""

import numpy as np
import pytest
from _robots import BareRobot

from geogait._validation import GeogaitError
from geogait.control import (
    AdaptiveExploration,
    PathTracker,
    ReferencePath,
    prediction_surprise,
)
from geogait.gaits import Perturbation
from geogait.optimize import cached_ceiling
from geogait.simulate import DragRatioSchedule, SwimmerStream
from geogait.systems import PurcellSwimmer


@pytest.fixture(scope="module")
def three_link():
    system = PurcellSwimmer(3)
    return system, cached_ceiling(system).gait


def _delta(chunk, gait):
    return chunk.commanded_shape - gait.shape(chunk.phase)


# -- the stream -------------------------------------------------------------------------------
def test_setting_the_size_in_force_changes_nothing_bit_for_bit(three_link):
    system, gait = three_link
    options = dict(perturbation=Perturbation.from_std(0.15), sensor_noise=0.1, seed=4)
    plain, sized = SwimmerStream(system, gait, **options), SwimmerStream(system, gait, **options)
    for _ in range(2):
        a, b = plain.next_cycle(), sized.next_cycle()
        sized.set_perturbation_std(0.15)  # the size in force: nothing is rebuilt
        np.testing.assert_array_equal(a.body_velocity, b.body_velocity)
        np.testing.assert_array_equal(a.pose, b.pose)
    assert sized.perturbation_std == pytest.approx(0.15)


def test_stream_size_follows_the_command_and_delta_stays_continuous(three_link):
    """δ scales with the commanded std over many cycles (same spectrum); switching keeps δ continuous and
    the white noise shared, so 0 makes δ decay to nothing within a cycle."""
    system, gait = three_link
    stream = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.15), seed=5)
    sizes = {}
    for std in (0.15, 0.05, 0.3):
        stream.set_perturbation_std(std)
        stream.next_cycle()  # let the SDE settle to the new size
        delta = np.concatenate([_delta(stream.next_cycle(), gait) for _ in range(40)])
        sizes[std] = delta.std()
    for std, measured in sizes.items():
        assert measured == pytest.approx(std, rel=0.15)
    before = _delta(stream.next_cycle(), gait)
    stream.set_perturbation_std(0.0)
    after = _delta(stream.next_cycle(), gait)
    assert np.abs(after[0] - before[-1]).max() < 0.1  # one sample apart, no jump
    assert np.abs(after[60:]).max() < 0.01 * np.abs(before).max()  # e^{-ζωt}: 0.005 after 0.6 cycles
    assert stream.perturbation.alpha == Perturbation.from_std(0.15).alpha
    with pytest.raises(GeogaitError, match="'std' parameter of SwimmerStream.set_perturbation_std"):
        stream.set_perturbation_std(-0.1)


def test_the_size_is_part_of_the_robot_state(three_link):
    """A stream restored from another's state (a checkpoint) continues with the δ std in force and the same
    samples; a state saved before sizes could change (no size) keeps the size the stream has."""
    system, gait = three_link
    stream = SwimmerStream(system, gait, seed=7, n_trials=2)
    stream.next_cycle()
    stream.set_perturbation_std(0.05)
    state = stream.robot_state()
    copy = SwimmerStream(system, gait, seed=0, n_trials=2)
    copy.restore_robot_state(state)
    assert copy.perturbation_std == pytest.approx(0.05)
    np.testing.assert_array_equal(copy.next_cycle().commanded_shape, stream.next_cycle().commanded_shape)
    old = SwimmerStream(system, gait, seed=0, n_trials=2)
    old.restore_robot_state({k: v for k, v in state.items() if k != "perturbation_std"})
    assert old.perturbation_std == pytest.approx(0.15)
    with pytest.raises(GeogaitError, match="'std' parameter of SwimmerStream.set_perturbation_std"):
        old.restore_robot_state(state | {"perturbation_std": -1.0, "pose": np.ones((2, 3))})
    np.testing.assert_array_equal(old.pose, state["pose"])  # refused before anything changed


def test_same_schedule_gives_the_same_perturbations(three_link):
    """Paired runs: two streams with one seed and one schedule of sizes see identical δ, whatever gaits
    they command."""
    system, gait = three_link
    streams = [SwimmerStream(system, gait, seed=6) for _ in range(2)]
    streams[1].set_gait(gait.with_params(gait.params * 0.9))
    for std in (0.15, 0.05, 0.1):
        chunks = []
        for stream in streams:
            stream.set_perturbation_std(std)
            chunks.append(stream.next_cycle())
        np.testing.assert_allclose(_delta(chunks[0], gait), _delta(chunks[1], streams[1].gait), atol=1e-12)


# -- the rule ---------------------------------------------------------------------------------
def test_surprise_is_the_prediction_error_in_steps_per_radian_of_delta():
    assert prediction_surprise([0.2, 0.0, 0.1], [0.2, 0.0, 0.1], 0.1) == 0.0
    assert prediction_surprise([0.2, 0.0, 0.0], [0.3, 0.0, 0.0], 0.1) == pytest.approx(5.0)  # half a step
    assert prediction_surprise([0.2, 0.0, 0.0], [0.2, 0.0, 0.05], 0.05) == pytest.approx(1.0)


def test_rule_decays_to_low_and_jumps_to_high_on_a_surprise(rng):
    """Residuals of the size δ causes keep the std falling from σ_high to σ_low; a residual far beyond
    them (a model that no longer fits) sends it back to σ_high; it never leaves [σ_low, σ_high]."""
    rule = AdaptiveExploration(low=0.05, high=0.15, alarm=5.0, decay=0.8, window=10)
    assert rule.start() == 0.15
    predicted = np.array([0.2, 0.0, 0.0])
    stds = []
    for cycle in range(40):
        noise = rng.normal(0, 1.0, 3) * np.array([0.02, 0.02, 0.1]) * rule.std_ / 0.15  # ∝ the size in force
        measured = predicted + noise + (np.array([0.18, 0.0, 0.0]) if cycle == 25 else 0.0)  # step 1.9×
        stds.append(rule.update(predicted, measured))
    stds = np.array(stds)
    assert np.all((stds >= 0.05 - 1e-12) & (stds <= 0.15 + 1e-12))
    assert np.all(np.diff(stds[:25]) < 0) and stds[24] < 0.06  # calm: down to σ_low
    assert stds[25] == pytest.approx(0.15)  # the change: back up at once
    assert np.all(np.diff(stds[26:]) < 0) and stds[-1] < 0.06
    assert rule.level_ == pytest.approx(0.8 ** 14)


def test_residuals_in_proportion_to_delta_raise_no_alarm(rng):
    """Residuals ∝ δ std: raising δ alone (no change of the model's fit) raises no alarm."""
    rule = AdaptiveExploration(decay=0.5)
    rule.start()
    predicted = np.array([0.2, 0.0, 0.0])
    alarms = 0
    for _ in range(60):
        before = rule.level_
        measured = predicted + rng.normal(0, 1.0, 3) * np.array([0.02, 0.02, 0.1]) * rule.std_ / 0.15
        rule.update(predicted, measured)
        alarms += rule.level_ == 1.0 and before < 1.0
    assert alarms == 0


@pytest.mark.parametrize("name, value, message", [
    ("low", 0.0, "'low' parameter of AdaptiveExploration"),
    ("high", 0.01, "'high' parameter of AdaptiveExploration"),
    ("alarm", 1.0, "'alarm' parameter of AdaptiveExploration"),
    ("decay", 1.0, "'decay' parameter of AdaptiveExploration"),
    ("window", 2, "'window' parameter of AdaptiveExploration"),
])
def test_rule_rejects_bad_settings(name, value, message):
    with pytest.raises(GeogaitError, match=message):
        AdaptiveExploration(**{name: value}).start()


def test_rule_must_be_started():
    with pytest.raises(GeogaitError, match="start"):
        AdaptiveExploration().update([0.2, 0, 0], [0.2, 0, 0])


# -- the tracker option -----------------------------------------------------------------------
def test_tracker_sizes_exploration_and_responds_to_a_drag_change(three_link):
    """Adaptive exploration on the 3-link circle through k = 2 → 4: σ_high through the warm-up, down
    towards σ_low while the model predicts, back to σ_high right after the unannounced change; a replay
    of the schedule gives another controller the same sizes cycle by cycle."""
    system, gait = three_link
    warmup, change = 6, 10

    def robot():
        schedule = DragRatioSchedule(system, (2.0, 4.0), warmup + change)
        return SwimmerStream(system, gait, sensor_noise=0.1, environment=schedule, seed=1)

    path = ReferencePath.circle(1.0)
    adaptive = PathTracker(controller="adaptive", warmup_cycles=warmup, exploration="adaptive")
    result = adaptive.run(robot(), path, 18)
    stds = result.perturbation_std
    assert stds.shape == (warmup + 18,)
    np.testing.assert_allclose(stds[:warmup + 1], 0.15)
    np.testing.assert_allclose(result.log["perturbation_std"], stds[warmup:])
    assert np.all((stds >= 0.05 - 1e-12) & (stds <= 0.15 + 1e-12))
    tracking = stds[warmup:]
    assert tracking[change] < 0.08  # calm before the change
    assert tracking[change + 1] == pytest.approx(0.15)  # the first cycle at k = 4 raised the alarm
    replay = PathTracker(controller="frozen", warmup_cycles=warmup, exploration=stds).run(robot(), path, 18)
    np.testing.assert_array_equal(replay.perturbation_std, stds)
    fixed = PathTracker(controller="frozen", warmup_cycles=warmup).run(robot(), path, 2)
    assert fixed.perturbation_std is None and np.allclose(fixed.log["perturbation_std"], 0.15)


def test_tracker_exploration_errors(three_link):
    system, gait = three_link
    path = ReferencePath.line()
    with pytest.raises(GeogaitError, match="'exploration' parameter of PathTracker"):
        PathTracker(exploration="greedy").run(SwimmerStream(system, gait, seed=0), path, 1)
    for bad in ([], [0.1, -0.1], [[0.1]], [np.nan]):
        with pytest.raises(GeogaitError, match="'exploration' parameter of PathTracker"):
            PathTracker(exploration=bad).run(SwimmerStream(system, gait, seed=0), path, 1)
    with pytest.raises(GeogaitError, match="set_perturbation_std"):
        PathTracker(exploration="adaptive").run(BareRobot(SwimmerStream(system, gait, seed=0)), path, 1)
    with pytest.raises(GeogaitError, match="'low' parameter of AdaptiveExploration"):
        PathTracker(exploration=AdaptiveExploration(low=-1)).run(SwimmerStream(system, gait, seed=0), path, 1)
