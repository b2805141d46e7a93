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


HELLO = {"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": 2, "cycle_period": 1.0,
         "gait": {"order": 1, "params": [0, 1, 0, 0, 0, 1]}}
CHAIN = {"link_lengths": [0.3, 0.4, 0.3], "body_frame": 1}


def hello_driver(tmp_path, hello):
    script = tmp_path / "driver.py"
    script.write_text(f"import json, sys\nprint(json.dumps({hello!r}), flush=True)\nsys.stdin.readline()\n")
    return [sys.executable, str(script)]


@pytest.mark.parametrize(("fields", "name"), [
    ({"chain": dict(CHAIN, frame_offset=[1e300, 0, 0])}, "chain"),
    ({"chain": dict(CHAIN, frame_offset=[0, 0, -2e12])}, "chain"),
    ({"chain": dict(CHAIN, link_lengths=[0.3, 1e300, 0.3])}, "chain"),
    ({"chain": {"link_lengths": [0.25] * 4, "shape_map": [[1, 0], [0.5, 1e300], [0, 1]]}}, "chain"),
    ({"joint_ranges": [[-1e300, 1], [-1, 1]]}, "joint_ranges"),
    ({"joint_ranges": [[-1, 1], [-1, 2e12]]}, "joint_ranges"),
    ({"shape_constraints": [[1, -1, 1e300]]}, "shape_constraints"),
    ({"shape_constraints": [[1e300, -1, 1]]}, "shape_constraints"),
])
def test_hello_numbers_beyond_the_documented_bound_are_refused_naming_the_field(tmp_path, fields, name):
    """1e300 in chain.frame_offset, shape_map or joint_ranges gave Γ NaN every cycle, no step, exit 0."""
    with pytest.raises(GeogaitError, match=rf"robot driver .*'{name}' must be .*within ±1e\+12"):
        ProcessRobot(hello_driver(tmp_path, dict(HELLO, **fields)))
    bounded = json.loads(json.dumps(fields).replace("1e+300", "1e12").replace("2000000000000.0", "1e12"))
    ProcessRobot(hello_driver(tmp_path, dict(HELLO, **bounded))).close()  # the bound itself is accepted


@pytest.mark.parametrize(("fields", "fragment"), [
    ({"n_joints": 300, "gait": {"order": 1, "params": [0.0, 1, 0] * 300}}, "at most 37 joints, even at order 1"),
    ({"gait": {"order": 1000, "params": [0.0] * 2 * 2001}}, "at most order 21 with 2 joints"),
])
def test_a_hello_whose_gait_no_optimisation_could_hold_is_refused(tmp_path, fields, fragment):
    """Before: the bridge accepted 10,000 joints and order 1000 (30 GiB of joint-limit rows at 2 joints)."""
    with pytest.raises(GeogaitError, match=r"robot driver .*the hello's 'gait'.*(4 GiB|SIGTERM)") as error:
        ProcessRobot(hello_driver(tmp_path, dict(HELLO, **fields)))
    assert fragment in str(error.value)
