"""Run a robot's first cycle and check what it returns, as Gymnasium's ``check_env`` runs an environment."""

from __future__ import annotations

import numpy as np

from .. import se2
from .._validation import GeogaitError, fail
from ..simulate import Trajectory
from ._spec import RobotSpec, read_robot_spec

__all__ = ["check_cycle", "check_robot"]

#: Fewest samples a cycle may hold (a cycle's net motion needs more than a handful).
MIN_SAMPLES = 4
#: A cycle's measured body velocities, integrated, may miss its poses by this share of how far the poses moved (or
#: turned) within the cycle, plus :data:`POSE_SLACK`: beyond it the two disagree (a unit, frame or sign mismatch).
POSE_AGREEMENT = 0.5
#: Body lengths and radians: motions this small are within any pose sensor's noise.
POSE_SLACK = 1e-3


def check_cycle(chunk, n_joints: int, owner: str) -> None:
    """Raise a clear error naming what is wrong with one cycle of a robot (``next_cycle()``'s return).

    Parameters
    ----------
    chunk : Trajectory
        One cycle, without a trial axis.
    n_joints : int
        The robot's shape dimension d.
    owner : str
        Who asks (named in the error).
    """
    if not isinstance(chunk, Trajectory):
        raise fail("robot", owner, "a next_cycle() returning a geogait.simulate.Trajectory", type(chunk).__name__)
    n = chunk.time.shape[-1]
    if chunk.time.ndim != 1 or n < MIN_SAMPLES:
        raise fail("robot", owner, f"cycles of at least {MIN_SAMPLES} samples without a trial axis",
                   f"time of shape {chunk.time.shape}")
    expected = {"phase": (n,), "shape": (n, n_joints), "shape_velocity": (n, n_joints), "body_velocity": (n, 3),
                "pose": (n, 3)}
    for name, shape in expected.items():
        value = np.asarray(getattr(chunk, name))
        if value.shape != shape:
            raise fail(f"cycle.{name}", owner, f"an array of shape {shape}", f"shape {value.shape}")
        if not np.all(np.isfinite(value)):
            raise fail(f"cycle.{name}", owner, "finite values", "NaN or inf")
    if not np.all(np.isfinite(chunk.time)) or np.any(np.diff(chunk.time) <= 0):
        raise fail("cycle.time", owner, "strictly increasing finite time stamps (seconds)", chunk.time[:5])


def check_robot(robot) -> RobotSpec:
    """Check that ``robot`` implements the :class:`~geogait.robots.Robot` protocol by running it.

    It reads what the robot declares (:func:`~geogait.robots.read_robot_spec`), runs one cycle of its current gait
    and checks the :class:`~geogait.simulate.Trajectory` it returns: array shapes and finite values, strictly
    increasing time, phases in [0, 2π), and its poses against its body velocities (the measured ξ, integrated
    over the cycle, must follow the poses within half of how far they moved and turned: a unit or sign mismatch
    does not). A
    robot that can save its state (``robot_state`` / ``restore_robot_state``) is put back where it was and runs
    the cycle again, which must repeat it exactly. The robot is left one cycle on.

    Parameters
    ----------
    robot : Robot
        The robot to check, before an optimiser or tracker drives it.

    Returns
    -------
    RobotSpec
        What the robot declares.

    Raises
    ------
    GeogaitError
        Naming the first thing that is wrong.

    Examples
    --------
    >>> from geogait import gaits, robots, simulate, systems
    >>> robot = simulate.SwimmerStream(systems.PurcellSwimmer(3), gaits.seed_gait(2), seed=0)
    >>> robots.check_robot(robot).mirror_symmetric
    True
    """
    owner = "check_robot"
    spec = read_robot_spec(robot, owner)
    saved = robot.robot_state() if spec.saves_state else None
    chunk = robot.next_cycle()
    check_cycle(chunk, spec.n_joints, owner)
    phase = np.asarray(chunk.phase)
    if np.any(phase < 0) or np.any(phase >= 2 * np.pi):
        raise fail("cycle.phase", owner, "phases in [0, 2π) (radians of the commanded gait)",
                   f"values from {phase.min():.4g} to {phase.max():.4g}")
    _check_poses(chunk, owner)
    if saved is not None:
        robot.restore_robot_state(saved)
        again = robot.next_cycle()
        if not (np.array_equal(again.time, chunk.time) and np.array_equal(again.body_velocity, chunk.body_velocity)
                and np.array_equal(again.shape, chunk.shape)):
            raise GeogaitError("check_robot: restore_robot_state(robot_state()) must put the robot back exactly "
                               "(the same cycle must repeat); it ran another cycle instead.")
    return spec


def _check_poses(chunk: Trajectory, owner: str) -> None:
    """The cycle's body velocities, integrated from its first pose, follow its poses at every sample within a share
    of how far the poses moved and turned over the cycle."""
    dt = np.diff(chunk.time)
    integrated = se2.integrate_body_velocity(chunk.body_velocity[:-1], dt, initial_pose=chunk.pose[0])
    measured = se2.between(chunk.pose[0], chunk.pose)  # every sample's pose in the cycle's start frame
    predicted = se2.between(chunk.pose[0], integrated)
    reach = max(float(np.hypot(*measured[:, :2].T).max()), float(np.hypot(*predicted[:, :2].T).max()))
    gaps = np.hypot(*(predicted[:, :2] - measured[:, :2]).T)
    worst = int(np.argmax(gaps))
    if gaps[worst] > POSE_AGREEMENT * reach + POSE_SLACK:
        raise fail("cycle.body_velocity", owner, "body velocities (body frame, per second) whose integral over the "
                   "cycle follows the poses", f"{np.round(predicted[worst, :2], 4).tolist()} at sample {worst} "
                   f"against the poses' {np.round(measured[worst, :2], 4).tolist()}")
    swing = max(float(np.abs(measured[:, 2]).max()), float(np.abs(predicted[:, 2]).max()))
    turns = np.abs(se2.wrap_angle(predicted[:, 2] - measured[:, 2]))
    worst = int(np.argmax(turns))
    if turns[worst] > POSE_AGREEMENT * swing + POSE_SLACK:
        raise fail("cycle.body_velocity", owner, "an angular velocity whose integral over the cycle follows the "
                   "poses' heading", f"{predicted[worst, 2]:.4g} rad at sample {worst} against the poses' "
                   f"{measured[worst, 2]:.4g} rad")
