"""The cycle period as a decision variable: the line search, robots that change their period, and
the in-situ optimiser finding the best period of a robot whose actuators lag."""

import numpy as np
import pandas as pd
import pytest
from _robots import LaggingRobot, lagging_gain

from geogait.gaits import FourierGait, seed_gait
from geogait.optimize import Climb, InSituOptimizer, PeriodSearch, Safety
from geogait.optimize._period import PeriodLineSearch
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer


def _true_speed(gait, period):
    scaled = FourierGait(gait.coefficients * lagging_gain(period))
    return np.hypot(*cycle_displacement(PurcellSwimmer(3), scaled, resolution=128)[:2]) / period


def test_period_search_steps_shrinks_and_stops():
    search = PeriodLineSearch(0.5, 2.0)
    first = search.propose(1.0)
    assert first == pytest.approx(np.exp(-0.2))  # shorter first
    assert not search.judge(1.0, 2.0)  # worse: the other side, half the step
    assert search.direction == 1 and search.step == pytest.approx(0.1)
    assert search.propose(1.0) == pytest.approx(np.exp(0.1))
    assert search.judge(3.0, 2.0) and search.step == pytest.approx(0.15)
    assert search.propose(2.0) == pytest.approx(2.0 * np.exp(-0.15))  # at the top bound: back down
    search.step = 0.01
    assert search.propose(1.0) is None  # below 2 %: the search has ended
    search.gait_changed()
    assert search.step == pytest.approx(search.restart_step)
    assert PeriodLineSearch(0.9, 1.1).propose(1.0, shortest=0.995) == pytest.approx(1.1)  # boxed by the speed limit
    assert PeriodLineSearch.from_json(search.to_json()) == search


def test_optimiser_finds_the_period_a_lagging_robot_runs_fastest_at():
    robot = LaggingRobot(seed=3)
    # the model steps first (Climb(start="stalled")), so the period moves by its line search, not as a climb coordinate
    result = InSituOptimizer(climb=Climb(start="stalled"), period=PeriodSearch(period_range=(0.25, 2.0))).run(robot, 60)
    periods = np.linspace(0.25, 2.0, 71)
    final = result.final_gait
    speeds = [_true_speed(final, period) for period in periods]
    best = periods[int(np.argmax(speeds))]
    chosen = result.cycle_period
    assert chosen in set(robot.periods)
    assert abs(np.log(chosen / best)) < 0.25
    assert _true_speed(final, chosen) >= 0.9 * max(speeds)
    assert _true_speed(final, chosen) >= 1.1 * _true_speed(seed_gait(2), 1.0)
    summary = result.summary()
    assert summary["seed_cycle_period"] == 1.0 and summary["final_cycle_period"] == pytest.approx(result.cycle_period)
    assert summary["final_measured_improvement"] > 0.1  # per second: the period counts


def test_fixed_period_is_the_default_and_never_commanded():
    robot = LaggingRobot(seed=1)
    result = InSituOptimizer().run(robot, 12)
    assert set(robot.periods) == {1.0} and set(result.log["cycle_period"]) == {1.0}


def test_period_options_are_checked_before_the_robot_moves():
    class FixedPeriod(LaggingRobot):
        set_cycle_period = None

    robot = FixedPeriod()
    with pytest.raises(ValueError, match="set_cycle_period"):
        InSituOptimizer(period=PeriodSearch()).run(robot, 3)
    for bad in [(1.0,), (2.0, 1.0), (0.0, 1.0), (1.0, np.nan), "fast"]:
        with pytest.raises(ValueError, match="'period_range'"):
            InSituOptimizer(period=PeriodSearch(period_range=bad)).run(robot, 3)
    with pytest.raises(ValueError, match="'period_range'.*robot's period"):
        InSituOptimizer(period=PeriodSearch(period_range=(0.1, 0.5))).run(LaggingRobot(), 3)
    assert robot.periods == []


def test_resume_with_a_period_search_is_bit_identical(tmp_path):
    path = tmp_path / "run.npz"

    def make():  # model steps first (Climb(start="stalled")): period trials between them
        return InSituOptimizer(climb=Climb(start="stalled"), safety=Safety(settle_cycles=1),
                               period=PeriodSearch(period_range=(0.25, 2.0)))

    whole = make().run(LaggingRobot(seed=4), 24)

    def stop(row):
        if row["cycle"] == 13:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        make().run(LaggingRobot(seed=4), 24, checkpoint=path, callback=stop)
    resumed = InSituOptimizer.resume(path, LaggingRobot(seed=4))
    assert len(set(whole.log["cycle_period"])) >= 2
    pd.testing.assert_frame_equal(resumed.log, whole.log, check_dtype=False)


def test_a_gait_change_before_the_fresh_model_learned_anything_starts_a_new_model():
    """After a period change the model starts afresh; if its first cycles are settling or rejected, the
    next gait change cannot rebase it (nothing learned): it starts a new one."""
    from geogait.models import AdaptiveGaitModel
    from geogait.optimize._loop import CycleLoop
    from geogait.optimize._state import RunState
    from geogait.robots import read_robot_spec

    optimizer = InSituOptimizer()
    gait = seed_gait(2)
    fresh = AdaptiveGaitModel(gait=gait, phase_rate=2 * np.pi)
    state = RunState(gait=gait, radius=0.1, model=fresh, n_cycles=10, ceiling=None, period=1.0)
    other = FourierGait(0.9 * gait.coefficients)
    robot = SwimmerStream(PurcellSwimmer(3), gait, seed=0)
    loop = CycleLoop(optimizer, optimizer.composition(), robot, read_robot_spec(robot), state, checkpoint=None,
                     checkpoint_every=1)
    loop._change_gait(other)
    assert state.model is not fresh and state.gait == other and state.previous_gait == gait


def test_a_first_climb_searches_the_period_as_its_coordinate_without_a_trial_before_it():
    """With Climb(start="first") the period is one of the climb's coordinates from its start: no period trial (a
    change of period on the same gait) comes before the climb's first candidate, and its candidates move the
    period."""
    settings = dict(period=PeriodSearch(period_range=(0.25, 2.0)))
    result = InSituOptimizer(**settings, climb=Climb(start="first")).run(LaggingRobot(seed=3), 40)
    log = result.log
    first_climb = int(np.flatnonzero(log["climb"].to_numpy(dtype=bool))[0])
    assert (log["cycle_period"].iloc[:first_climb + 1] == 1.0).all()
    assert not log["period_change"].iloc[:first_climb + 1].any()
    assert log["cycle_period"].nunique() >= 3
    with_trial = InSituOptimizer(**settings, climb=Climb(start="stalled")).run(LaggingRobot(seed=3), 12)
    assert with_trial.log["period_change"].any()  # model steps first: the line search's trials
