"""Exploration sized online: the swimmer stream that changes δ between cycles, the rule, the tracker option."""

import numpy as np
import pytest
from _robots import BareRobot

from geogait._validation import GeogaitError
from geogait.control import (
    AdaptiveExploration,
    ModelMotion,
    PathTracker,
    ReferencePath,
    prediction_surprise,
    surprise_alarm,
)
from geogait.gaits import Perturbation
from geogait.models import ShapeSpaceModel
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


# -- the model and covariance resetting at a change ------------------------------------------
def test_surprise_alarm_needs_three_references_and_compares_with_their_median():
    assert not surprise_alarm(100.0, [1.0, 1.0])
    assert surprise_alarm(5.1, [1.0, 1.0, 1.0]) and not surprise_alarm(4.9, [1.0, 1.0, 1.0])
    assert not surprise_alarm(5.1, [1.0, 9.0, 1.0, 9.0, 9.0], alarm=5.0, window=3)  # only the last 3 count
    assert surprise_alarm(2.1, [1.0, 1.0, 1.0], alarm=2.0)


def test_change_forgetting_relearns_the_new_drag_faster_and_fires_once(three_link):
    """3-link circle through k = 2 → 4 with the shape-space model and δ 0.05: the first cycle at k = 4
    raises the alarm (and no cycle before it); forgetting by 100 there makes the predicted step of the
    next cycles closer to the truth than without it (same seed, same perturbations)."""
    system, gait = three_link
    warmup, change, cycles = 6, 8, 16

    def run(factor):
        schedule = DragRatioSchedule(system, (2.0, 4.0), warmup + change)
        robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.05), sensor_noise=0.1,
                              environment=schedule, seed=2)
        tracker = PathTracker(warmup_cycles=warmup, change_forgetting=factor,
                              model=ShapeSpaceModel(degree=3, symmetry="mirror+reversal"))
        return tracker.run(robot, ReferencePath.circle(1.0), cycles).log

    forgetting, plain = run(100.0), run(1.0)
    assert forgetting["alarm"].to_numpy().nonzero()[0].tolist()[:1] == [change]
    assert forgetting["alarm"].sum() <= 2

    def step_error(log):
        part = log[(log.cycle > change) & (log.cycle <= change + 4)]
        return float(np.mean(np.hypot(part.predicted_x - part.true_x, part.predicted_y - part.true_y)))

    assert step_error(forgetting) < 0.5 * step_error(plain)
    np.testing.assert_array_equal(forgetting["cross_track"][:change + 1], plain["cross_track"][:change + 1])


def test_model_motion_of_a_shape_space_model_is_its_own_prediction(three_link):
    system, gait = three_link
    robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.1), seed=0)
    chunk = robot.next_cycle()
    model = ShapeSpaceModel(degree=2).fit(chunk.phase, chunk.shape, chunk.shape_velocity, chunk.body_velocity)
    pose, jacobian = ModelMotion(model)(gait, jacobian=True)
    expected, expected_jacobian = model.predict_displacement(gait, jacobian=True)  # NumPy (the kernel: rounding)
    np.testing.assert_allclose(pose, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(jacobian, expected_jacobian, rtol=0, atol=1e-12 * np.abs(expected_jacobian).max())


class _NoForget:
    def get_params(self, deep=False):
        return {}

    def partial_fit(self, *arrays):
        return self

    def predict_displacement(self, gait, jacobian=False):
        return np.zeros(3)


def test_tracker_model_and_change_forgetting_errors(three_link):
    system, gait = three_link
    path = ReferencePath.line()
    with pytest.raises(GeogaitError, match=r"'model' parameter of PathTracker.*'a object without get_params\(\)'"):
        PathTracker(model=object()).run(SwimmerStream(system, gait, seed=0), path, 1)
    with pytest.raises(GeogaitError, match="'model' parameter of PathTracker.*without forget"):
        PathTracker(model=_NoForget(), change_forgetting=10.0).run(SwimmerStream(system, gait, seed=0), path, 1)
    for bad in (0.5, np.nan, "x"):
        with pytest.raises(GeogaitError, match="'change_forgetting' parameter of PathTracker"):
            PathTracker(change_forgetting=bad).run(SwimmerStream(system, gait, seed=0), path, 1)


def test_a_nan_or_impossible_surprise_input_is_refused_and_the_rule_unchanged():
    """A NaN measurement once stored a NaN surprise, after which a real change raised no alarm; std 0 gave inf,
    a negative std a negative surprise, window 0 the whole history."""
    from geogait.control import AdaptiveExploration, prediction_surprise, surprise_alarm

    rule = AdaptiveExploration()
    rule.start()
    for _ in range(4):
        rule.update([0.1, 0.0, 0.0], [0.1, 0.001, 0.0])
    before = (list(rule.surprises_), rule.std_, rule.level_)
    with pytest.raises(GeogaitError, match="'measured' parameter of prediction_surprise must be finite"):
        rule.update([0.1, 0.0, 0.0], [np.nan, 0.0, 0.0])
    assert (rule.surprises_, rule.std_, rule.level_) == before
    rule.update([0.1, 0.0, 0.0], [0.3, 0.2, 0.5])
    assert rule.alarm_
    for std in (0.0, -1.0):
        with pytest.raises(GeogaitError, match="'std' parameter of prediction_surprise"):
            prediction_surprise([0.1, 0, 0], [0.1, 0, 0], std)
    with pytest.raises(GeogaitError, match=r"'predicted' parameter of prediction_surprise must be an array of shape"):
        prediction_surprise([0.1, 0], [0.1, 0, 0], 0.1)
    with pytest.raises(GeogaitError, match="'window' parameter of surprise_alarm must be an int >= 3"):
        surprise_alarm(10.0, [1.0] * 5, window=0)
