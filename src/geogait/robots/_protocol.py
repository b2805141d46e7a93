r"""What a robot or simulator must offer to be modelled, optimised and steered in situ.

geogait never needs to know the robot's physics: it commands a nominal gait θ(φ) and receives,
cycle by cycle, the samples the robot measured while running it. Time is in **seconds** at the
robot; the cycle period says how long one gait cycle takes and sets the phase rate φ̇ = 2π / T
that every model uses (θ̇ = θ'(φ) φ̇).

The contract of one cycle (a :class:`~geogait.simulate.Trajectory` without a trial axis):

* ``time`` (n,) seconds, increasing; ``phase`` (n,) commanded phase in [0, 2π); ``cycle`` (n,);
* ``shape``, ``shape_velocity`` (n, d): measured (realised) joint angles and rates (rad, rad/s);
* ``body_velocity`` (n, 3): measured ξ = (v_x, v_y, ω) in the body frame (per second);
* ``pose`` (n, 3): world pose (x, y, heading) of the same body frame at each sample;
* ``commanded_shape`` (n, d), optional: the shape the robot was told to take at each sample
  (nominal gait plus any exploration perturbation), so that tracking error = realised − commanded.
"""

from __future__ import annotations

import math
import numbers
from typing import Protocol, runtime_checkable

from .._validation import GeogaitError
from ..gaits import FourierGait
from ..simulate import Trajectory

__all__ = ["Robot", "check_robot_members", "ROBOT_EXTRAS"]

#: Optional members, detected by name: a simulator's truth (``current_system() -> System``, the
#: oracle column of the optimiser's log), bit-identical checkpoints (``robot_state() -> dict`` of
#: JSON values and arrays, ``restore_robot_state(state)``), ``close()`` to release resources,
#: ``set_excitation(shape, shape_velocity)`` (run this exploration — δ and δ̇ on M uniform phases —
#: for the next cycle instead of the robot's own: the optimiser's ``exploration``),
#: ``set_cycle_period(seconds)`` (run the following cycles at that period, or the nearest the robot
#: can time, read back from ``cycle_period``: the optimiser's ``optimize_period``), ``joint_ranges``
#: ((d, 2) array of joint limits in shape units: the optimiser's automatic limit), ``feasibility(shapes,
#: jacobian=False)`` (a signed margin ≥ 0 inside the shapes the robot may take, e.g. a
#: :class:`~geogait.systems.LinearRegion`: every commanded gait keeps it) and
#: ``front_back_symmetric`` (bool: the symmetric gait family applies), ``mirror_symmetric`` (bool:
#: the body and its medium read the same in a mirror along the body's axis, so the half-wave
#: symmetric gait family applies) and ``settle_cycles`` (int: cycles a gait change takes to settle;
#: undeclared, the optimiser measures them).
ROBOT_EXTRAS = ("current_system", "robot_state", "restore_robot_state", "close", "set_excitation",
                "set_cycle_period", "joint_ranges", "feasibility", "front_back_symmetric", "mirror_symmetric",
                "settle_cycles")


@runtime_checkable
class Robot(Protocol):
    """A robot (or simulator) geogait can drive cycle by cycle.

    Attributes
    ----------
    n_joints : int
        Shape dimension d.
    cycle_period : float
        Seconds per gait cycle (φ̇ = 2π / ``cycle_period``).
    gait : FourierGait
        Nominal gait of the cycle that :meth:`next_cycle` runs next.

    Notes
    -----
    :class:`~geogait.simulate.SwimmerStream`, :class:`~geogait.robots.MujocoRobot` and
    :class:`~geogait.robots.ProcessRobot` (any program speaking the JSON-lines bridge) implement it.
    The optional extras are listed in :data:`ROBOT_EXTRAS`.
    """

    n_joints: int
    cycle_period: float

    @property
    def gait(self) -> FourierGait:
        """Nominal gait of the next cycle."""
        ...

    def set_gait(self, gait: FourierGait) -> None:
        """Command ``gait`` from the next cycle boundary on."""
        ...

    def next_cycle(self) -> Trajectory:
        """Run one whole gait cycle and return its samples (module docstring)."""
        ...


def check_robot_members(robot, owner: str) -> None:
    """Raise a clear error naming what ``robot`` lacks of the :class:`Robot` protocol.

    Parameters
    ----------
    robot : object
        The robot to check.
    owner : str
        Who asks (the function or method named in the error message); ``check_robot`` by default, as
        before a first run: ``check_robot(MyRobot())``.
    """
    required = ("n_joints", "cycle_period", "gait", "set_gait", "next_cycle")
    missing = [name for name in required if not hasattr(robot, name)]
    if missing:
        raise GeogaitError(
            f"The 'robot' parameter of {owner} must implement geogait.robots.Robot "
            f"(n_joints, cycle_period, gait, set_gait, next_cycle). {type(robot).__name__} lacks {', '.join(missing)}.")
    if not callable(robot.set_gait) or not callable(robot.next_cycle):
        raise GeogaitError(f"The 'robot' parameter of {owner} must have callable set_gait and next_cycle.")
    if not isinstance(robot.gait, FourierGait):
        raise GeogaitError(f"The 'robot' parameter of {owner} must have a FourierGait 'gait'. "
                           f"Got {type(robot.gait).__name__} instead.")
    n_joints, period = robot.n_joints, robot.cycle_period
    if isinstance(n_joints, bool) or not isinstance(n_joints, numbers.Integral) or n_joints < 1:
        raise GeogaitError(f"The 'robot' parameter of {owner} must have an integer 'n_joints' >= 1. "
                           f"Got {n_joints!r} instead.")
    if n_joints != robot.gait.n_joints:
        raise GeogaitError(f"The 'robot' parameter of {owner} must have a gait of its 'n_joints' = {n_joints} "
                           f"joints. Got a gait of {robot.gait.n_joints} instead.")
    if isinstance(period, bool) or not isinstance(period, numbers.Real) or not 0 < period < math.inf:
        raise GeogaitError(f"The 'robot' parameter of {owner} must have a 'cycle_period' > 0 (seconds, finite). "
                           f"Got {period!r} instead.")
