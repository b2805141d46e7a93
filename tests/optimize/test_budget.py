"""smallest_budget against the optimiser itself: the cycles a run spends before it measures one."""

import pytest

from geogait.gaits import seed_gait
from geogait.optimize import InSituOptimizer, ModelClassTest, Safety, smallest_budget
from geogait.optimize._model_class import ModelClassCheck
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


@pytest.mark.parametrize(("settle", "test"), [(0, 0), (3, 0), (0, 3), (2, 3)])
def test_the_smallest_budget_holds_exactly_one_measured_cycle(settle, test):
    system = PurcellSwimmer(3)
    budget = smallest_budget(settle, test)
    robot = SwimmerStream(system, seed_gait(2), seed=0)
    checks = [ModelClassTest(cycles=test)] if test else []
    result = InSituOptimizer(safety=Safety(settle_cycles=settle), checks=checks).run(robot, budget)
    assert len(result.log) == budget and (~result.log["settling"]).sum() == 1
    assert not result.log["settling"].iloc[-1]
    if test:
        assert budget == len(ModelClassCheck(1.0, 2.0, test, settle_cycles=settle).plan) + 1
    with pytest.raises(ValueError, match=f"'n_cycles' parameter of InSituOptimizer.run must be an int >= {budget}"):
        InSituOptimizer(safety=Safety(settle_cycles=settle), checks=checks).run(robot, budget - 1)


def test_a_gait_family_or_model_the_machine_cannot_hold_is_refused_before_the_robot_moves():
    robot = SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0)
    with pytest.raises(ValueError, match="order 1000000 would take .* GiB.*at most order 21 with 2 joints"):
        InSituOptimizer(order=10**6).run(robot, 3)
    assert robot.cycle == 0
