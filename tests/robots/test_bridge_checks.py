"""The bridge checks a driver's measurements against each other and its hello against the machine's limits."""

import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from geogait._validation import GeogaitError
from geogait.optimize._measure import measure_cycle
from geogait.robots import ProcessRobot

FAULT_DRIVER = [sys.executable, str(Path(__file__).parents[1] / "_fault_driver.py")]


def fault_robot(**config):
    return ProcessRobot(FAULT_DRIVER + [json.dumps(config)], timeout=20)


def _net_motions(robot, cycles=3):
    return [measure_cycle(robot.next_cycle(), robot.gait, robot.cycle_period, "test").net for _ in range(cycles)]


@pytest.mark.parametrize("sample", [-1, 0, 10])
def test_one_body_velocity_glitch_is_quarantined_wherever_it_is_in_the_cycle(sample):
    """[100, 0, 0] on the last sample set the cycle's end pose: 2.44 per cycle measured, true about 0.07."""
    with fault_robot() as robot:
        clean = _net_motions(robot)
    with pytest.warns(match="quarantined"), fault_robot(fault="velocity_glitch", cycle=1, magnitude=100.0,
                                                        sample=sample) as robot:
        glitched = _net_motions(robot)
    assert len(robot.quarantined) == 1 and f"at sample {sample % 40}" in robot.quarantined[0]
    assert ("it sets the cycle's end pose" in robot.quarantined[0]) == (sample == -1)
    np.testing.assert_allclose(glitched[0], clean[0])  # the glitched cycle was run again, not learned
    assert max(np.hypot(*net[:2]) for net in glitched) < 0.2


def test_body_velocities_in_other_units_than_the_poses_end_the_run_naming_the_factor():
    with warnings.catch_warnings(), fault_robot(fault="velocity_scale", cycles=99, magnitude=1000.0) as robot:
        warnings.simplefilter("ignore")
        with pytest.raises(GeogaitError, match=r"implausible cycles in a row; the last: its body velocities move the "
                                               r"body (99\d|1e\+03)× as far as its poses do .*different units"):
            robot.next_cycle()

