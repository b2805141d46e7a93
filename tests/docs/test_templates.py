"""The tutorial's templates run as the tutorial says: examples/template_robot.py and examples/template_driver.py."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from geogait import se2
from geogait.gaits import FourierGait
from geogait.optimize import InSituOptimizer
from geogait.robots import ProcessRobot, check_robot

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # (template_driver imports template_robot by name)
    spec.loader.exec_module(module)
    return module


template_robot = _load("template_robot")
template_driver = _load("template_driver")


def test_the_template_robot_passes_check_robot_and_returns_whole_cycles():
    robot = template_robot.MyRobot(samples_per_cycle=40)
    assert check_robot(robot).excitation  # (it runs the robot's first cycle)
    first, second = robot.next_cycle(), robot.next_cycle()
    assert first.shape.shape == first.commanded_shape.shape == (40, 2)
    assert first.body_velocity.shape == first.pose.shape == (40, 3)
    assert second.time[0] > first.time[-1]  # one clock for the whole run
    assert (first.cycle == 1).all() and (second.cycle == 2).all()
    np.testing.assert_allclose(np.ptp(first.phase), 2 * np.pi * 39 / 40)


def test_the_template_robots_body_velocity_from_poses_carries_it_where_the_poses_go():
    robot = template_robot.MyRobot(samples_per_cycle=200)
    robot._stand_in.pose_noise = 0.0
    cycle = robot.next_cycle()
    integrated = se2.integrate_body_velocity(cycle.body_velocity[:-1], cycle.time[1] - cycle.time[0],
                                             initial_pose=cycle.pose[0])
    moved = np.hypot(*(cycle.pose[-1, :2] - cycle.pose[0, :2]))
    assert moved > 0.04  # (0.049 body lengths)
    assert np.abs(integrated[-1] - cycle.pose[-1]).max() < 0.1 * moved  # (0.003: the central scheme's error)


def test_the_template_robot_is_optimised_end_to_end(capsys):
    result = template_robot.main(["--cycles", "6"])
    assert len(result.log) == 6
    assert np.isfinite(result.log["measured_progress"]).all()
    assert result.log["measured_progress"].iloc[0] > 0.03  # the seed gait swims (0.05 body lengths a cycle)
    assert "net motion per cycle" in capsys.readouterr().out


def test_the_drivers_gait_evaluation_is_geogaits_fourier_gait():
    params = np.random.default_rng(0).normal(size=10)  # order 2, two joints
    gait = FourierGait.from_params(params, 2)
    for phase in (0.0, 1.3, 4.0):
        np.testing.assert_allclose(template_driver.joint_angles(list(params), 2, phase), gait.shape(phase))
        np.testing.assert_allclose(template_driver.joint_rates(list(params), 2, phase),
                                   gait.velocity(phase) * 2 * np.pi / template_driver.CYCLE_PERIOD)


def test_the_drivers_excitation_is_interpolated_periodically():
    grid = {"shape": [[0.0, 1.0], [1.0, 0.0], [2.0, 1.0], [3.0, 0.0]], "shape_velocity": [[0.0, 0.0]] * 4}
    delta, _ = template_driver.excitation_at(grid, 2 * np.pi * 3.5 / 4)  # halfway from the last point to the first
    np.testing.assert_allclose(delta, [1.5, 0.5])


@pytest.mark.slow  # (a process bridge: the driver imports geogait)
def test_the_template_driver_runs_behind_the_bridge():
    with ProcessRobot([sys.executable, str(EXAMPLES / "template_driver.py")], timeout=60) as robot:
        assert robot.accepts_excitation and robot.n_joints == 2
        result = InSituOptimizer(random_state=0).run(robot, 4)
        assert robot.quarantined == []
    assert len(result.log) == 4 and np.isfinite(result.log["measured_progress"]).all()
