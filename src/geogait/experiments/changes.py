r"""Robots whose body or medium changes mid-run, at a cycle nobody announces.

:class:`ChangingRobot` wraps any :class:`~geogait.robots.Robot` and applies a change to the robot it wraps just
before that robot's cycle ``at_cycle`` runs: the optimiser driving it is not told, it only measures the change.
The changes below switch a parameter of the underlying physics in place, so the body keeps its pose and state
across the change:

* :func:`swimmer_link_drag` — a :class:`~geogait.simulate.SwimmerStream` of a
  :class:`~geogait.systems.PurcellSwimmer`: per-link drag multipliers (a fouled or lost fin);
* :func:`mujoco_link_drag` — a :class:`~geogait.robots.MujocoRobot` on
  :func:`~geogait.robots.purcell_swimmer_xml`'s resistive chain: one link's drag (a damaged link);
* :func:`mujoco_joint_gear` — a :class:`~geogait.robots.MujocoRobot`: one joint's actuator gear (a weakened
  joint: its torque for the same control, and its largest torque, scale together);
* :func:`elastica_friction` — an :class:`~geogait.robots.ElasticaSnake`: the ground's kinetic friction
  coefficients (a new floor).

Examples
--------
>>> from geogait.gaits import seed_gait
>>> from geogait.simulate import SwimmerStream
>>> from geogait.systems import PurcellSwimmer
>>> fouled = swimmer_link_drag([(1, 0.3), (1, 1), (1, 1), (1, 1), (1, 0.3)])
>>> robot = ChangingRobot(SwimmerStream(PurcellSwimmer(5), seed_gait(4)), at_cycle=60, change=fouled)
>>> robot.changed
False
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from .._validation import GeogaitError, check_array, check_float, check_int, fail
from ..robots import RobotWrapper
from ..simulate import Trajectory

__all__ = ["ChangingRobot", "swimmer_link_drag", "mujoco_link_drag", "mujoco_joint_gear", "elastica_friction"]


class ChangingRobot(RobotWrapper):
    """A robot whose body or medium changes, unannounced, before its cycle ``at_cycle``.

    Every member of the wrapped robot is the wrapper's (its declarations, ``set_cycle_period``,
    ``set_excitation``...); cycles are counted as :meth:`next_cycle` and :meth:`next_cycles` run them.

    Parameters
    ----------
    robot : Robot
        The robot before the change.
    at_cycle : int >= 0
        Cycles the robot runs unchanged (0: changed from its first cycle).
    change : callable
        ``change(robot)``: switches the wrapped robot's physics in place (e.g. :func:`swimmer_link_drag`).

    Attributes
    ----------
    cycles_run : int
        Cycles run so far.
    changed : bool
        Whether the change has been applied.
    """

    def __init__(self, robot, at_cycle: int, change: Callable):
        owner = "ChangingRobot"
        self.at_cycle = check_int(at_cycle, "at_cycle", owner, minimum=0)
        if not callable(change):
            raise fail("change", owner, "a callable change(robot)", type(change).__name__)
        super().__init__(robot)
        self.change = change
        self.cycles_run, self.changed = 0, False

    def next_cycle(self) -> Trajectory:
        """Run one cycle, the change applied first when this is cycle ``at_cycle``."""
        if not self.changed and self.cycles_run >= self.at_cycle:
            self.change(self.robot)
            self.changed = True
        self.cycles_run += 1
        return self.robot.next_cycle()

    def next_cycles(self, n_cycles: int) -> Trajectory:
        """``n_cycles`` whole cycles, joined along time."""
        n_cycles = check_int(n_cycles, "n_cycles", "ChangingRobot.next_cycles", minimum=1)
        return Trajectory.concatenate([self.next_cycle() for _ in range(n_cycles)])


def _positive_scale(value, name: str, owner: str) -> float:
    return check_float(value, name, owner, low=0, low_open=True)


def swimmer_link_drag(scale) -> Callable:
    """Change: the swimmer's per-link drag multipliers become ``scale``.

    Parameters
    ----------
    scale : array-like of shape (n_links, 2)
        Multipliers of each link's longitudinal and lateral drag (tail first), as
        :class:`~geogait.systems.PurcellSwimmer`'s ``link_drag_scale`` (the rotational drag follows the lateral).

    Returns
    -------
    callable
        ``change(stream)`` for a :class:`~geogait.simulate.SwimmerStream` of a ``PurcellSwimmer``.
    """
    scale = check_array(scale, "scale", "swimmer_link_drag", ndim=2)

    def change(stream) -> None:
        from ..systems import PurcellSwimmer

        system = getattr(stream, "system", None)
        if not isinstance(system, PurcellSwimmer):
            raise GeogaitError(f"swimmer_link_drag: the robot's system is a {type(system).__name__}, not a "
                               "PurcellSwimmer of a SwimmerStream.")
        stream.system = dataclasses.replace(system, link_drag_scale=tuple(map(tuple, scale)))

    return change


def _actuator(model, name: str, owner: str) -> int:
    import mujoco

    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
    if index < 0:
        raise GeogaitError(f"{owner}: the robot's model has no actuator {name!r}.")
    return index


def mujoco_link_drag(link: int, *, longitudinal: float = 1.0, lateral: float = 1.0) -> Callable:
    """Change: link ``link``'s resistive drag of :func:`~geogait.robots.purcell_swimmer_xml` (its passive
    actuators ``drag{link}_x``, ``_y`` and ``_rz``) scaled by ``longitudinal`` along the link and ``lateral``
    across it (the rotational drag with the lateral, as :class:`~geogait.systems.PurcellSwimmer` scales it).

    Returns
    -------
    callable
        ``change(robot)`` for a :class:`~geogait.robots.MujocoRobot`.
    """
    owner = "mujoco_link_drag"
    link = check_int(link, "link", owner, minimum=0)
    factors = {"x": _positive_scale(longitudinal, "longitudinal", owner),
               "y": _positive_scale(lateral, "lateral", owner), "rz": lateral}

    def change(robot) -> None:
        model = robot.model
        for axis, factor in factors.items():
            model.actuator_biasprm[_actuator(model, f"drag{link}_{axis}", owner), 2] *= factor

    return change


def mujoco_joint_gear(joint: str, factor: float) -> Callable:
    """Change: the gear of the actuator on ``joint`` (a joint name of the model) scaled by ``factor``.

    The robot's controls are unchanged, so the joint's torque for each control, and its largest torque, scale by
    ``factor`` (< 1: a weakened joint).

    Returns
    -------
    callable
        ``change(robot)`` for a :class:`~geogait.robots.MujocoRobot`.
    """
    owner = "mujoco_joint_gear"
    factor = _positive_scale(factor, "factor", owner)

    def change(robot) -> None:
        import mujoco

        model = robot.model
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        actuators = [a for a in range(model.nu) if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
                     and int(model.actuator_trnid[a, 0]) == index]
        if index < 0 or not actuators:
            raise GeogaitError(f"{owner}: the robot's model has no actuator on a joint {joint!r}.")
        for a in actuators:
            model.actuator_gear[a] *= factor

    return change


def elastica_friction(friction) -> Callable:
    """Change: the ground's kinetic friction coefficients (forward, backward, lateral) under an
    :class:`~geogait.robots.ElasticaSnake` become ``friction``.

    Returns
    -------
    callable
        ``change(snake)`` for an ``ElasticaSnake``.
    """
    owner = "elastica_friction"
    friction = check_array(friction, "friction", owner, ndim=1)
    if friction.shape != (3,) or np.any(friction < 0):
        raise fail("friction", owner, "3 non-negative coefficients (forward, backward, lateral)", friction)

    def change(snake) -> None:
        from elastica.contact_forces import RodPlaneContactWithAnisotropicFriction

        contacts = [operator.func.__self__ for operator in snake.simulator._feature_group_synchronize
                    if isinstance(getattr(getattr(operator, "func", None), "__self__", None),
                                  RodPlaneContactWithAnisotropicFriction)]
        if not contacts:
            raise GeogaitError(f"{owner}: the snake's simulator has no anisotropic ground friction.")
        for contact in contacts:
            contact.kinetic_mu_forward, contact.kinetic_mu_backward, contact.kinetic_mu_sideways = map(float, friction)
        snake.friction = friction.copy()

    return change
