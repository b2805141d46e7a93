"""Robots that change mid-run, unannounced: the wrapper and the changes it applies."""

from __future__ import annotations

import numpy as np
import pytest

from geogait import GeogaitError
from geogait.experiments.changes import (
    ChangingRobot,
    elastica_friction,
    mujoco_joint_gear,
    mujoco_link_drag,
    swimmer_link_drag,
)
from geogait.gaits import Perturbation, seed_gait
from geogait.optimize import measure_cycle
from geogait.simulate import SwimmerStream, cycle_displacement
from geogait.systems import PurcellSwimmer

HEAD = [(1, 1), (1, 1), (1, 1), (1, 1), (1, 0.3)]


def _stream(seed=3):
    return SwimmerStream(PurcellSwimmer(5), seed_gait(4), seed=seed, sensor_noise=0.1)


def test_before_its_cycle_the_robot_is_unchanged_and_after_it_is_the_changed_one():
    """Cycles before ``at_cycle`` are the wrapped robot's own, sample for sample (same seed, same noise); from
    ``at_cycle`` on, the robot moves as the changed swimmer does (its exact net motion per cycle)."""
    plain, changing = _stream(), ChangingRobot(_stream(), at_cycle=3, change=swimmer_link_drag(HEAD))
    for _ in range(3):
        np.testing.assert_array_equal(changing.next_cycle().body_velocity, plain.next_cycle().body_velocity)
    assert not changing.changed and changing.cycles_run == 3
    assert not np.allclose(changing.next_cycle().body_velocity, plain.next_cycle().body_velocity)
    assert changing.changed and changing.system.link_drag_scale[-1] == (1.0, 0.3)
    clean = ChangingRobot(SwimmerStream(PurcellSwimmer(5), seed_gait(4), perturbation=Perturbation(eta=0)), 2,
                          swimmer_link_drag(HEAD))
    nets = [_net(clean) for _ in range(4)]
    before = cycle_displacement(PurcellSwimmer(5), seed_gait(4))
    after = cycle_displacement(PurcellSwimmer(5, link_drag_scale=HEAD), seed_gait(4))
    assert np.hypot(*(after - before)[:2]) > 0.1 * np.hypot(*before[:2])
    hold = 0.03 * np.hypot(*before[:2])  # (the simulator's zero-order hold)
    np.testing.assert_allclose(nets[1], before, atol=hold)
    np.testing.assert_allclose(nets[3], after, atol=hold)


def _net(robot):
    return measure_cycle(robot.next_cycle(), robot.gait, robot.cycle_period, "test").net


def test_a_change_from_the_first_cycle_and_next_cycles_count_every_cycle():
    robot = ChangingRobot(_stream(), at_cycle=0, change=swimmer_link_drag(HEAD))
    assert robot.next_cycles(3).time.shape[-1] == 300 and robot.changed and robot.cycles_run == 3


def test_bad_changes_are_refused_with_the_field_named():
    with pytest.raises(GeogaitError, match="'at_cycle' parameter of ChangingRobot"):
        ChangingRobot(_stream(), at_cycle=-1, change=swimmer_link_drag(HEAD))
    with pytest.raises(GeogaitError, match="'change' parameter of ChangingRobot must be a callable"):
        ChangingRobot(_stream(), at_cycle=1, change="drag")
    with pytest.raises(GeogaitError, match="'friction' parameter of elastica_friction"):
        elastica_friction([1.0, -1.0, 2.0])
    with pytest.raises(GeogaitError, match="'lateral' parameter of mujoco_link_drag"):
        mujoco_link_drag(0, lateral=0.0)
    with pytest.raises(GeogaitError, match="'factor' parameter of mujoco_joint_gear"):
        mujoco_joint_gear("joint0", -0.5)
    with pytest.raises(GeogaitError, match="not a PurcellSwimmer"):
        swimmer_link_drag(HEAD)(object())


def test_mujoco_changes_scale_one_links_drag_and_one_joints_gear():
    pytest.importorskip("mujoco")
    from geogait.robots import MujocoRobot, purcell_swimmer_xml

    robot = MujocoRobot(purcell_swimmer_xml(5))
    before = robot.model.actuator_biasprm[:, 2].copy()
    gear = robot.model.actuator_gear.copy()
    mujoco_link_drag(1, lateral=0.3)(robot)
    mujoco_joint_gear("joint2", 0.5)(robot)
    names = [robot.model.actuator(a).name for a in range(robot.model.nu)]
    ratio = dict(zip(names, np.divide(robot.model.actuator_biasprm[:, 2], before, out=np.ones_like(before),
                                      where=before != 0), strict=True))
    assert ratio["drag1_y"] == ratio["drag1_rz"] == pytest.approx(0.3) and ratio["drag1_x"] == 1.0
    assert all(v == 1.0 for k, v in ratio.items() if not k.startswith("drag1_") or k == "drag1_x")
    gear[names.index("motor2")] *= 0.5
    np.testing.assert_array_equal(robot.model.actuator_gear, gear)
    with pytest.raises(GeogaitError, match="no actuator 'drag7_x'"):
        mujoco_link_drag(7)(robot)
    with pytest.raises(GeogaitError, match="no actuator on a joint 'elbow'"):
        mujoco_joint_gear("elbow", 0.5)(robot)


def test_the_new_floor_sets_the_snakes_ground_friction():
    pytest.importorskip("elastica")
    from elastica.contact_forces import RodPlaneContactWithAnisotropicFriction

    from geogait.robots import ElasticaSnake

    snake = ElasticaSnake(seed=0, n_elements=8, warmup_cycles=0)
    elastica_friction([1.0, 1.5, 1.0])(snake)
    contact, = [op.func.__self__ for op in snake.simulator._feature_group_synchronize
                if isinstance(getattr(getattr(op, "func", None), "__self__", None),
                              RodPlaneContactWithAnisotropicFriction)]
    assert (contact.kinetic_mu_forward, contact.kinetic_mu_backward, contact.kinetic_mu_sideways) == (1.0, 1.5, 1.0)
    np.testing.assert_array_equal(snake.friction, [1.0, 1.5, 1.0])
