"""check_robot(robot): runs a robot's first cycle and names what is wrong, for a broken robot of each kind."""

import dataclasses

import numpy as np
import pytest

from geogait import GeogaitError
from geogait.gaits import seed_gait
from geogait.robots import RobotSpec, check_robot
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def _stream(**options):
    return SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0, sensor_noise=0.1, **options)


class Faulty:
    """A working robot whose cycles ``fault`` changes (a Trajectory in, a Trajectory or anything out)."""

    def __init__(self, fault, **declared):
        self.stream, self.fault = _stream(), fault
        self.n_joints, self.cycle_period = 2, self.stream.cycle_period
        for name, value in declared.items():
            setattr(self, name, value)

    @property
    def gait(self):
        return self.stream.gait

    def set_gait(self, gait):
        self.stream.set_gait(gait)

    def next_cycle(self):
        return self.fault(self.stream.next_cycle())


def test_a_robot_that_implements_the_protocol_passes_and_its_spec_is_returned():
    spec = check_robot(_stream())
    assert isinstance(spec, RobotSpec)
    assert spec.front_back_symmetric and spec.mirror_symmetric and spec.excitation and spec.saves_state
    assert spec.joint_ranges is None and spec.resistive_chain is None and spec.n_joints == 2


def test_what_a_robot_lacks_is_named_in_the_error():
    class HalfRobot:
        n_joints = 2
        cycle_period = 1.0
        gait = seed_gait(2)

    with pytest.raises(GeogaitError, match=r"of check_robot must implement .*HalfRobot lacks set_gait, next_cycle"):
        check_robot(HalfRobot())


def _replace(**changes):
    return lambda cycle: dataclasses.replace(cycle, **{k: f(cycle) for k, f in changes.items()})


@pytest.mark.parametrize(("fault", "match"), [
    (lambda cycle: cycle.body_velocity, "next_cycle\\(\\) returning a geogait.simulate.Trajectory"),
    (_replace(shape=lambda c: c.shape[:, :1]), "'cycle.shape'.*shape \\(100, 2\\)"),
    (_replace(body_velocity=lambda c: np.where(np.arange(100)[:, None] == 5, np.nan, c.body_velocity)),
     "'cycle.body_velocity'.*finite values"),
    (_replace(time=lambda c: c.time[::-1].copy()), "'cycle.time'.*strictly increasing"),
    (_replace(phase=lambda c: c.phase + 2 * np.pi), "'cycle.phase'.*\\[0, 2π\\)"),
    (_replace(body_velocity=lambda c: 1000 * c.body_velocity), "'cycle.body_velocity'.*follows the poses"),
    (_replace(body_velocity=lambda c: c.body_velocity * [1, 1, -1]), "'cycle.body_velocity'.*follows the poses"),
])
def test_a_broken_cycle_is_named(fault, match):
    with pytest.raises(GeogaitError, match=match):
        check_robot(Faulty(fault))


def test_a_malformed_declaration_is_named_before_any_cycle_runs():
    robot = Faulty(lambda cycle: cycle, joint_ranges=[[0.5, 1.0], [-1.0, 1.0]])
    with pytest.raises(GeogaitError, match="'robot.joint_ranges' parameter of check_robot"):
        check_robot(robot)
    assert robot.stream.cycle == 0


def test_a_state_round_trip_that_does_not_restore_is_named():
    class Forgetful(Faulty):
        def robot_state(self):
            return {}

        def restore_robot_state(self, state):
            pass  # the robot stays where it is: the next cycle is another

    with pytest.raises(GeogaitError, match="restore_robot_state\\(robot_state\\(\\)\\) must put the robot back"):
        check_robot(Forgetful(lambda cycle: cycle))
    robot = _stream()
    check_robot(robot)
    assert robot.cycle == 1  # the checked cycle ran twice, the second from the restored state
