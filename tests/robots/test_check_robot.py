"""check_robot(robot): the one-argument check a user runs before a robot's first cycle."""

import pytest

from geogait import GeogaitError
from geogait.gaits import seed_gait
from geogait.robots import check_robot
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def test_a_robot_that_implements_the_protocol_passes():
    check_robot(SwimmerStream(PurcellSwimmer(3), seed_gait(2), seed=0))


def test_what_a_robot_lacks_is_named_in_the_error():
    class HalfRobot:
        n_joints = 2
        cycle_period = 1.0
        gait = seed_gait(2)

    with pytest.raises(GeogaitError, match=r"of check_robot must implement .*HalfRobot lacks set_gait, next_cycle"):
        check_robot(HalfRobot())
