"""A robot that wraps another (as Gymnasium's ``Wrapper`` wraps an environment)."""

from __future__ import annotations

from ..gaits import FourierGait

__all__ = ["RobotWrapper"]


class RobotWrapper:
    """A robot that is another robot, but for the members it defines itself.

    Every member of the wrapped robot (its declarations, ``set_excitation``, ``robot_state`` ...) is the
    wrapper's; a subclass overrides the ones it changes (e.g. :meth:`next_cycle` to count or alter cycles).

    Parameters
    ----------
    robot : Robot
        The robot wrapped.

    Examples
    --------
    >>> from geogait.gaits import seed_gait
    >>> from geogait.simulate import SwimmerStream
    >>> from geogait.systems import PurcellSwimmer
    >>> class Counting(RobotWrapper):
    ...     cycles = 0
    ...     def next_cycle(self):
    ...         self.cycles += 1
    ...         return self.robot.next_cycle()
    >>> robot = Counting(SwimmerStream(PurcellSwimmer(3), seed_gait(2)))
    >>> _ = robot.next_cycle()
    >>> robot.cycles, robot.n_joints
    (1, 2)
    """

    def __init__(self, robot):
        self.robot = robot

    def __getattr__(self, name):
        if name == "robot":  # (not set yet: unpickling)
            raise AttributeError(name)
        return getattr(self.robot, name)

    @property
    def gait(self) -> FourierGait:
        """The wrapped robot's gait."""
        return self.robot.gait

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` on the wrapped robot.

        Parameters
        ----------
        gait : FourierGait
        """
        self.robot.set_gait(gait)

    def next_cycle(self):
        """The wrapped robot's next cycle."""
        return self.robot.next_cycle()
