"""Steering gaits, reference paths and the path-following controller against independent facts; paths and their
plots bounded (issue 21)."""

import time

import numpy as np
import pytest
from _cli import invoke, one_error_line
from _robots import BareRobot
from sklearn.base import clone

from geogait import se2
from geogait._validation import GeogaitError
from geogait.control import (
    ModelMotion,
    PathTracker,
    ReferencePath,
    TrueMotion,
    end_pose,
    max_feasible_turn,
    max_step_family,
    solve_steering_gait,
    steering_family,
)
from geogait.experiments.tracking import plot_reference
from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.optimize import cached_ceiling
from geogait.plotting import plt
from geogait.simulate import DragRatioSchedule, SwimmerStream, cycle_displacement, simulate
from geogait.systems import PurcellSwimmer

FREE = np.nan


@pytest.fixture(scope="module")
def three_link():
    system = PurcellSwimmer(3)
    return system, cached_ceiling(system).gait


# -- paths ------------------------------------------------------------------------------------
def test_line_cross_track_is_the_signed_distance(rng):
    path = ReferencePath.line(50.0)
    points = rng.uniform([1, -2], [40, 2], size=(200, 2))
    s, error, heading = path.project(points)
    np.testing.assert_allclose(error, points[:, 1], atol=1e-12)  # left of travel (+x) is +y
    np.testing.assert_allclose(s, points[:, 0], atol=1e-12)
    np.testing.assert_allclose(heading, 0.0, atol=1e-12)
    s_near, error_near, _ = path.project(points, near=points[:, 0] + 0.3, window=1.0)
    np.testing.assert_allclose(error_near, points[:, 1], atol=1e-12)


def test_circle_cross_track_and_tangent_match_the_closed_form(rng):
    radius = 1.7
    path = ReferencePath.circle(radius)
    centre = np.array([0.0, radius])
    angle, distance = rng.uniform(0, 2 * np.pi, 300), rng.uniform(0.3, 3.0, 300)
    points = centre + distance[:, None] * np.column_stack([np.sin(angle), -np.cos(angle)])
    s, error, heading = path.project(points)
    sagitta = (2 * np.pi * radius / len(path.points)) ** 2 / (8 * radius) * 3.0 / radius * 2
    np.testing.assert_allclose(error, radius - distance, atol=sagitta + 1e-12)  # inside the CCW circle: left
    np.testing.assert_allclose(np.mod(s / radius, 2 * np.pi), np.mod(angle, 2 * np.pi), atol=0.02 / radius)
    np.testing.assert_allclose(se2.wrap_angle(heading - angle), 0.0, atol=0.02 / radius)


def test_closed_path_arc_length_keeps_growing_lap_after_lap():
    path = ReferencePath.circle(1.0)
    s = 0.0
    for angle in np.linspace(0.1, 4 * np.pi, 80):  # two laps in small steps
        s, _, _ = path.project(np.array([np.sin(angle), 1 - np.cos(angle)]), near=s, window=0.5)
    assert s == pytest.approx(4 * np.pi, abs=0.02)


def test_figure_eight_is_followed_branch_by_branch():
    path = ReferencePath.figure8(1.0)
    assert path.start_heading == pytest.approx(0.0, abs=1e-12)
    # At the crossing both branches pass the origin; the search near each branch's arc length
    # returns that branch's tangent (they cross at right angles).
    _, _, first = path.project(np.zeros(2), near=0.0, window=0.3)
    _, _, second = path.project(np.zeros(2), near=path.length / 2, window=0.3)
    assert abs(se2.wrap_angle(first - second)) == pytest.approx(np.pi / 2, abs=0.02)


def test_waypoints_csv_round_trip_and_errors(tmp_path):
    good = tmp_path / "w.csv"
    good.write_text("x,y\n0,0\n1,0\n1,1\n")
    path = ReferencePath.from_csv(good)
    assert path.length == pytest.approx(2.0) and not path.closed and path.name == "w"
    assert path.at_end(2.0) and not path.at_end(1.9)
    _, error, _ = path.project(np.array([0.5, -0.2]))
    assert error == pytest.approx(-0.2)
    cases = {"x,z\n0,0\n1,0\n": "columns 'x' and 'y'", "x,y\n0,0\n1,a\n": "data row 2",
             "x,y\n0,0\n": "at least 2", "x,y\n0,0\n0,0\n1,1\n": "zero-length"}
    for text, message in cases.items():
        bad = tmp_path / "bad.csv"
        bad.write_text(text)
        with pytest.raises(GeogaitError, match=message):
            ReferencePath.from_csv(bad)
    with pytest.raises(GeogaitError, match="does not exist"):
        ReferencePath.from_csv(tmp_path / "missing.csv")


# -- steering gaits ---------------------------------------------------------------------------
def test_zero_turn_gait_has_zero_predicted_and_true_rotation(three_link):
    system, straight = three_link
    turning = straight.with_params(straight.params + np.r_[0.1, 0, 0, 0.05, 0, 0])  # offsets turn the swimmer
    before = abs(cycle_displacement(system, turning)[2])
    assert before > 0.05
    truth = TrueMotion(system)
    solution = solve_steering_gait(truth, turning, [FREE, FREE, 0.0])
    assert solution.converged and abs(cycle_displacement(system, solution.gait)[2]) < 1e-7
    # The same with a model learned from noise-free perturbed cycles of the straight gait.
    run = simulate(system, straight, 10, perturbation=Perturbation.from_std(0.15), seed=1)
    model = AdaptiveGaitModel(gait=straight).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    solution = solve_steering_gait(ModelMotion(model), turning, [FREE, FREE, 0.0])
    assert solution.converged and abs(solution.pose[2]) < 1e-7
    assert abs(cycle_displacement(system, solution.gait)[2]) < 0.1 * before  # within the model's accuracy


def test_steering_gait_is_the_nearest_one(three_link):
    """KKT: p − p* is normal to the turn constraint surface, and nearby feasible gaits are farther."""
    system, straight = three_link
    truth = TrueMotion(system)
    solution = solve_steering_gait(truth, straight, [FREE, FREE, 0.12])
    assert solution.converged and solution.pose[2] == pytest.approx(0.12, abs=1e-7)
    _, jacobian = truth(solution.gait, jacobian=True)
    difference = solution.gait.params - straight.params
    row = jacobian[2] / np.linalg.norm(jacobian[2])
    np.testing.assert_allclose(difference, (difference @ row) * row, atol=1e-6)


def test_mirror_symmetry_of_steering(three_link):
    """Negating every joint angle mirrors the motion: −ω from −p* is the mirror of +ω from p*."""
    system, straight = three_link
    truth = TrueMotion(system)
    left = solve_steering_gait(truth, straight, [FREE, FREE, 0.1])
    mirror = straight.with_params(-straight.params)
    right = solve_steering_gait(truth, mirror, [FREE, FREE, -0.1])
    np.testing.assert_allclose(right.gait.params, -left.gait.params, atol=1e-7)
    np.testing.assert_allclose(cycle_displacement(system, right.gait),
                               cycle_displacement(system, left.gait) * [1, -1, -1], atol=1e-9)


def test_full_command_and_joint_limits():
    system = PurcellSwimmer(5)
    straight = cached_ceiling(system).gait  # one joint sits on the limit 2π/3
    truth = TrueMotion(system)
    pose = truth(straight)
    direction = np.arctan2(pose[1], pose[0])
    solution = solve_steering_gait(truth, straight, [0.9 * np.hypot(*pose[:2]), 0.0, 0.15], direction=direction)
    assert solution.converged
    assert solution.gait.joint_limit().max() <= 2 * np.pi / 3 + 1e-9
    motion = cycle_displacement(system, solution.gait)
    rotation = np.array([[np.cos(direction), np.sin(direction)], [-np.sin(direction), np.cos(direction)]])
    np.testing.assert_allclose(rotation @ motion[:2], [0.9 * np.hypot(*pose[:2]), 0.0], atol=1e-6)
    assert motion[2] == pytest.approx(0.15, abs=1e-6)
    impossible = solve_steering_gait(truth, straight, [FREE, FREE, 3.0], max_iterations=5)
    assert not impossible.converged
    with pytest.raises(GeogaitError, match="'target' parameter"):
        solve_steering_gait(truth, straight, [FREE, FREE, FREE])


def test_steering_family_and_its_ceiling(three_link):
    system, straight = three_link
    truth = TrueMotion(system)
    turns = np.linspace(-0.2, 0.2, 3)
    pose = truth(straight)
    family = steering_family(truth, straight, turns, direction=np.arctan2(pose[1], pose[0]))
    assert family.feasible.all()
    np.testing.assert_allclose(family.poses[:, 2], turns, atol=1e-7)
    np.testing.assert_allclose(family.interpolate(turns)[:, :2], family.poses[:, :2], atol=1e-12)
    front = max_step_family(truth, straight, turns, direction=family.direction)
    # The zero-turn member of the optimal steering family is the ceiling (largest straight step).
    assert front.steps[1] == pytest.approx(cached_ceiling(system).value, rel=1e-4)
    assert np.all(front.steps >= family.steps - 1e-6)  # nothing turns as much with a larger step


def test_contiguous_family_stops_at_the_joint_limits(three_link):
    """The 3-link swimmer turns at most ≈ 0.55 rad per cycle within the joint limits 2π/3: the
    contiguous family solves outwards only to the first failing member and agrees with the full one
    wherever the tracker uses it."""
    system, straight = three_link
    truth = TrueMotion(system)
    pose = truth(straight)
    turns = np.linspace(-1.0, 1.0, 9)
    full = steering_family(truth, straight, turns, direction=np.arctan2(pose[1], pose[0]))
    short = steering_family(truth, straight, turns, direction=full.direction, contiguous=True)
    np.testing.assert_allclose([full.turn_range, short.turn_range], [[-0.5, 0.5]] * 2, atol=1e-7)
    used = np.abs(turns) <= 0.5
    assert short.feasible[used].all() and not short.feasible[~used].any()
    np.testing.assert_allclose(short.poses[used], full.poses[used], atol=1e-9)
    np.testing.assert_allclose(short.interpolate(turns), full.interpolate(turns), atol=1e-9)
    assert short.gaits[0] is short.gaits[1]  # beyond the first failure: a copy of it, never solved


def test_max_feasible_turn_is_the_joint_limited_multiple_of_the_spacing(three_link):
    """The 3-link swimmer turns ≈ 0.55 rad per cycle at most within the joint limits: 0.5 on the 0.1 grid."""
    system, straight = three_link
    truth = TrueMotion(system)
    pose = truth(straight)
    direction = float(np.arctan2(pose[1], pose[0]))
    assert max_feasible_turn(truth, straight, direction=direction) == pytest.approx(0.5)
    assert max_feasible_turn(truth, straight, direction=direction, upper=0.3) == pytest.approx(0.3)
    assert max_feasible_turn(truth, straight, direction=direction, upper=0.35) == pytest.approx(0.3)
    with pytest.raises(GeogaitError, match="'upper' parameter of max_feasible_turn"):
        max_feasible_turn(truth, straight, upper=0.05)
    with pytest.raises(GeogaitError, match="'spacing' parameter of max_feasible_turn"):
        max_feasible_turn(truth, straight, spacing=0.0)


# -- the controller ---------------------------------------------------------------------------
def test_end_pose_matches_the_simulated_boundary(three_link):
    system, straight = three_link
    stream = SwimmerStream(system, straight, seed=0)  # perturbations on, no sensor noise: exact
    np.testing.assert_allclose(end_pose(stream.next_cycle()), stream.pose[0], atol=1e-12)
    noisy = SwimmerStream(system, straight, sensor_noise=0.1, seed=0)  # off by noise × Δt: ω noise ≈ 0.27 rad/s
    np.testing.assert_allclose(end_pose(noisy.next_cycle()), noisy.pose[0], atol=0.012)


def test_true_controller_converges_to_a_line_without_noise(three_link):
    """From 0.3 body lengths off, onto the line. The simulator holds ξ constant over each sample (zero-order
    hold), so its motion per cycle differs from the exact one the controller predicts by O(1/samples) —
    0.01 rad of course at 100 samples per cycle, which leaves a 0.005 offset; 1000 samples leave 0.0003."""
    system, straight = three_link
    robot = SwimmerStream(system, straight, perturbation=Perturbation(eta=0.0), samples_per_cycle=1000, seed=0)
    result = PathTracker(controller="true", warmup_cycles=1).run(robot, ReferencePath.line(), 40, start_offset=0.3)
    log = result.log
    assert abs(log["cross_track"].iloc[0]) > 0.15
    assert np.abs(log["cross_track"].iloc[-5:]).max() < 1e-3
    assert np.abs(log["heading_error"].iloc[-5:]).max() < 1e-3
    assert log["solved"].all()
    np.testing.assert_allclose(log["predicted_turn"], log["true_turn"], atol=1e-7)


def _line_run(system, straight, drag_ratios, offset_steps):
    """True controller, no perturbations or noise, 1000 samples per cycle; the drag ratio switches
    after the first tracking cycle. Returns the log and the step after the switch."""
    schedule = DragRatioSchedule(system, drag_ratios, 2)  # 1 warm-up cycle, 1 tracking cycle, then the second
    step = float(np.hypot(*cycle_displacement(schedule(2), straight)[:2]))
    robot = SwimmerStream(system, straight, perturbation=Perturbation(eta=0.0), samples_per_cycle=1000,
                          environment=schedule, seed=0)
    # the same turns in every environment (the default limit is cut by the joint limits of the first one)
    tracker = PathTracker(controller="true", warmup_cycles=1, turn_limit=0.5)
    log = tracker.run(robot, ReferencePath.line(), 25, start_offset=offset_steps * step).log
    return log, step


def test_true_controller_corrects_in_steps_at_any_speed(three_link):
    """The cost scales with the step predicted now: from 3 steps off a line the swimmer at drag ratio 2
    (0.10 body lengths per cycle) and at 4 (0.23) follow the same course in units of their step and
    both converge; switched 2 → 4 after the first cycle, the controller uses the new step at once."""
    system, straight = three_link
    curves = {}
    for ratios in ((2.0, 2.0), (4.0, 4.0), (2.0, 4.0)):
        log, step = _line_run(system, straight, ratios, 3.0)
        curves[ratios] = log["cross_track"].to_numpy() / step
        assert np.abs(curves[ratios][-5:]).max() < 0.02  # on the line (ZOH offset ≈ 0.006 steps)
        assert curves[ratios].min() > -0.4  # no large overshoot
    np.testing.assert_allclose(curves[(2.0, 2.0)], curves[(4.0, 4.0)], atol=0.3)
    assert abs(curves[(2.0, 2.0)][2:8] - curves[(4.0, 4.0)][2:8]).mean() < 0.15
    # After the switch the path in steps settles like the one at drag ratio 4 throughout (a cost still
    # scaled by the old step overshoots to -0.20 steps and is still 0.075 steps off at cycle 6).
    assert curves[(2.0, 4.0)].min() > -0.15
    np.testing.assert_allclose(curves[(2.0, 4.0)][6:], curves[(4.0, 4.0)][6:], atol=0.03)


def test_adaptive_controller_runs_on_a_robot_that_is_not_simulated(three_link):
    system, straight = three_link
    robot = BareRobot(SwimmerStream(system, straight, sensor_noise=0.1, seed=2))
    tracker = PathTracker(controller="adaptive", warmup_cycles=5)
    result = tracker.run(robot, ReferencePath.circle(1.0), 8)
    log = result.log
    assert len(log) == 8 and log["true_turn"].isna().all() and log["gamma"].between(0, 1).all()
    assert np.abs(log["cross_track"]).max() < 0.2
    # the run set its learned turn limit; a clone (scikit-learn's) has the settings and none of it
    copied = clone(tracker)
    assert tracker.__sklearn_is_fitted__() and tracker.turn_limit_ > 0 and not copied.__sklearn_is_fitted__()
    assert copied.get_params() == tracker.get_params()
    with pytest.raises(GeogaitError, match="current_system"):
        PathTracker(controller="true").run(robot, ReferencePath.circle(1.0), 2)


@pytest.mark.parametrize(("controller", "warmup_turns", "limit"),
                         [("true", 4, 0.5), ("adaptive", 4, 0.6), ("adaptive", 0, 1.0)])
def test_default_turn_limit_is_one_radian_cut_to_the_joint_limits(three_link, controller, warmup_turns, limit):
    """Like the experiment and the CLI (1 rad cut by the joint limits), from the controller's own motion
    source: 0.5 rad for the 3-link swimmer's true connection. The model after 10 noisy straight cycles
    alone, extrapolating far from the straight gait, reaches the full 1 rad within the joint limits (its
    own verdict, solved to convergence); after the 4 turning warm-up cycles it has run its steering gaits
    and comes within 0.1 rad of the truth. An explicit limit is kept."""
    system, straight = three_link
    robot = SwimmerStream(system, straight, sensor_noise=0.1, seed=0)
    tracker = PathTracker(controller=controller, warmup_turns=warmup_turns)
    result = tracker.run(robot, ReferencePath.circle(1.0), 2)
    assert tracker.turn_limit_ == pytest.approx(limit)
    np.testing.assert_allclose(result.family.turns, np.linspace(-limit, limit, 2 * round(limit / 0.1) + 1),
                               atol=1e-12)
    assert all(gait.joint_limit().max() <= 2 * np.pi / 3 + 1e-9 for gait in result.family.gaits)
    assert np.abs(result.log["turn_command"]).max() <= limit + 1e-9
    explicit = PathTracker(controller=controller, warmup_cycles=3, turn_limit=0.3)
    family = explicit.run(SwimmerStream(system, straight, seed=0), ReferencePath.circle(1.0), 1).family
    assert explicit.turn_limit_ == 0.3
    np.testing.assert_allclose(family.turns, np.linspace(-0.3, 0.3, 7), atol=1e-12)


class _Recording:
    """A robot that records the gait of every cycle it runs."""

    def __init__(self, robot):
        self.robot, self.ran = robot, []

    def __getattr__(self, name):
        return getattr(self.robot, name)

    def set_gait(self, gait):
        self.robot.set_gait(gait)

    def next_cycle(self):
        self.ran.append(self.robot.gait)
        return self.robot.next_cycle()


def test_turning_warmup_runs_the_models_steering_gaits_before_tracking(three_link):
    """After the straight warm-up cycles, ``warmup_turns`` cycles run the learned model's steering gaits for
    +½, −½, +1, −1 × its turn limit (then again): on the swimmer they turn that way (signs, and the full
    turns farther than the half ones, to the model's accuracy), the travel direction comes from the straight
    cycles alone (the same as without the turns), and the δ schedule counts every warm-up cycle."""
    system, straight = three_link
    logs = {}
    for turns in (0, 6):
        robot = _Recording(SwimmerStream(system, straight, sensor_noise=0.1, seed=3))
        tracker = PathTracker(controller="frozen", warmup_cycles=8, warmup_turns=turns, exploration=[0.05])
        result = tracker.run(robot, ReferencePath.circle(1.0), 3)
        assert len(robot.ran) == 8 + turns + 3 and result.perturbation_std.shape == (8 + turns + 3,)
        assert all(gait == straight for gait in robot.ran[:8])
        logs[turns] = (result, robot.ran[8:8 + turns])
    assert logs[6][0].direction == logs[0][0].direction
    true_turns = np.array([cycle_displacement(system, gait)[2] for gait in logs[6][1]])
    np.testing.assert_array_equal(np.sign(true_turns), [1, -1, 1, -1, 1, -1])
    assert np.all(np.abs(true_turns[2:4]) > 1.3 * np.abs(true_turns[:2]))
    assert np.all(np.abs(true_turns) <= 0.5 + 0.05)  # within the swimmer's reach (the true limit is 0.5 rad)


def test_turning_warmup_runs_the_straight_gait_where_the_model_has_no_steering_gait(three_link, monkeypatch):
    """A turn the model's steering solve does not reach (not converged) runs the straight gait instead, so the
    warm-up keeps its length and a drag schedule its timing."""
    import dataclasses

    from geogait.control import _tracker

    solve = _tracker.solve_steering_gait
    monkeypatch.setattr(_tracker, "solve_steering_gait",
                        lambda *a, **k: dataclasses.replace(solve(*a, **k), converged=False))
    system, straight = three_link
    robot = _Recording(SwimmerStream(system, straight, sensor_noise=0.1, seed=3))
    PathTracker(controller="true", warmup_cycles=4, warmup_turns=2).run(robot, ReferencePath.line(), 1)
    assert len(robot.ran) == 4 + 2 + 1 and all(gait == straight for gait in robot.ran[:6])


def test_tracker_rejects_bad_settings(three_link):
    system, straight = three_link
    robot = SwimmerStream(system, straight, seed=0)
    with pytest.raises(GeogaitError, match="'controller' parameter of PathTracker"):
        PathTracker(controller="magic").run(robot, ReferencePath.line(), 2)
    with pytest.raises(GeogaitError, match="'n_turns' parameter"):
        PathTracker(n_turns=4).run(robot, ReferencePath.line(), 2)
    with pytest.raises(GeogaitError, match="'turn_limit' parameter of PathTracker"):
        PathTracker(turn_limit=0.0).run(robot, ReferencePath.line(), 2)
    with pytest.raises(GeogaitError, match="'gait' parameter"):
        PathTracker().run(robot, ReferencePath.line(), 2, gait=seed_gait(2, amplitude=2.5))
    with pytest.raises(GeogaitError, match="'path' parameter"):
        PathTracker().run(robot, "circle", 2)
    with pytest.raises(GeogaitError, match="'robot' parameter"):
        PathTracker().run(object(), ReferencePath.line(), 2)
    with pytest.raises(GeogaitError, match="'warmup_turns' parameter of PathTracker"):
        PathTracker(warmup_turns=-1).run(robot, ReferencePath.line(), 2)
    with pytest.raises(GeogaitError, match=r"'start_offset' parameter of PathTracker.run must be a finite float in "
                                           r"\[-1e\+12, 1e\+12\]. Got 1e\+300"):  # (issue 58, finding 7)
        PathTracker().run(robot, ReferencePath.line(), 2, start_offset=1e300)
    assert isinstance(FourierGait, type)


def test_model_motion_reuses_the_model_terms_with_the_same_arithmetic():
    """ModelMotion computes the model's own terms once per model state: the same as predicted_displacement
    (to rounding: it runs the compiled kernel where numba is installed), and recomputed when the model
    learns or is rebased (any order of candidate gait)."""
    from geogait.models import predicted_displacement

    gait = seed_gait(4)
    run = simulate(PurcellSwimmer(5), gait, 6, seed=0, sensor_noise=0.1)
    model = AdaptiveGaitModel(gait=gait).fit(run.phase[:300], run.shape[:300], run.shape_velocity[:300],
                                             run.body_velocity[:300])
    motion = ModelMotion(model)
    candidates = [gait.with_params(gait.params * 1.05), gait.with_order(2), seed_gait(4, amplitude=0.8)]

    def check():
        for candidate in candidates:
            expected = predicted_displacement(model, candidate, resolution=64, jacobian=True)
            for actual, wanted in zip(motion(candidate, jacobian=True), expected, strict=True):
                np.testing.assert_allclose(actual, wanted, rtol=0, atol=1e-12 * np.abs(wanted).max())
            np.testing.assert_allclose(motion(candidate), expected[0], rtol=0, atol=1e-12 * np.abs(expected[0]).max())

    check()
    terms = motion._terms
    check()
    assert motion._terms is terms  # reused
    model.partial_fit(run.phase[300:400], run.shape[300:400], run.shape_velocity[300:400], run.body_velocity[300:400])
    check()
    assert motion._terms is not terms  # the model learned: recomputed
    model.rebase(candidates[0])
    check()
    with pytest.raises(GeogaitError, match="gait"):
        motion(seed_gait(2))


def test_the_horizon_is_short_on_straight_stretches_and_long_before_a_bend():
    """Where the path's tangent turns by less than STRAIGHT_BEND within the long horizon's reach, the controller
    predicts straight_horizon cycles; a corner or a curve within reach restores the long horizon."""
    tracker = PathTracker(horizon=4, straight_horizon=2)
    corner = ReferencePath.waypoints([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    assert tracker._horizon_at(ReferencePath.line(), 1.0, 0.2) == 2
    assert tracker._horizon_at(corner, 0.1, 0.2) == 2  # the corner lies beyond 4 steps of 0.2
    assert tracker._horizon_at(corner, 0.5, 0.2) == 4  # and within them from here
    assert tracker._horizon_at(ReferencePath.circle(1.0), 0.0, 0.2) == 4  # 0.8 rad of bend in reach
    assert tracker._horizon_at(ReferencePath.circle(100.0), 0.0, 0.2) == 2  # 0.008 rad: straight enough
    assert PathTracker(straight_horizon=None)._horizon_at(ReferencePath.line(), 1.0, 0.2) == 4
    with pytest.raises(GeogaitError, match="'straight_horizon' parameter of PathTracker"):
        PathTracker(horizon=3, straight_horizon=4).validate()


def test_reference_paths_refuse_what_they_would_carry_as_inf_or_nan():
    """A 1e300 line had an infinite length, 'no' made a closed path, a NaN arc length a NaN point."""
    from geogait.control import ReferencePath

    for make, match in ((lambda: ReferencePath.line(1e300), "'length' parameter of ReferencePath.line"),
                        (lambda: ReferencePath(np.array([[0.0, 0.0], [1e300, 0.0]])), "within ±1e\\+12"),
                        (lambda: ReferencePath.waypoints([[0, 0], [1, 0], [1, 1]], closed="no"),
                         "'closed' parameter of ReferencePath must be True or False"),
                        (lambda: ReferencePath.line(5).point(np.nan), "'s' parameter of ReferencePath.point"),
                        (lambda: ReferencePath.line(5).heading("a"), "'s' parameter of ReferencePath.heading")):
        with pytest.raises(GeogaitError, match=match):
            make()
    np.testing.assert_allclose(ReferencePath.line(5).point([1.0, 7.0]), [[1.0, 0.0], [5.0, 0.0]])


def test_paths_and_plots_are_bounded(tmp_path):
    far = ReferencePath.waypoints([[0, 0], [1e6, 0]])
    fig, ax = plt.subplots()
    started = time.perf_counter()
    plot_reference(ax, far, np.array([[0.0, 0.0], [0.5, 0.1]]))
    plt.close(fig)
    assert time.perf_counter() - started < 5
    assert ReferencePath.circle(1e6).points.shape[0] <= 200_000
    with pytest.raises(GeogaitError, match="'radius' parameter"):
        ReferencePath.circle(1e9)
    with pytest.raises(GeogaitError, match="'points' parameter"):
        ReferencePath.waypoints([[0, 0], [1e13, 0]])
    one_error_line(invoke("track", "--scale", "1e9", "--out", tmp_path / "x"), "--scale")
