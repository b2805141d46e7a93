"""What a robot declares, read in one place: :class:`RobotSpec` and :func:`read_robot_spec`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._defaults import FEASIBILITY_TOLERANCE
from .._validation import fail
from ..gaits import FourierGait, Perturbation
from ..systems import PurcellSwimmer
from ._protocol import check_robot_members

__all__ = ["RobotSpec", "check_within_joint_ranges", "perturbation_std", "read_robot_spec"]


@dataclass(frozen=True)
class RobotSpec:
    """What a robot declares beyond the :class:`~geogait.robots.Robot` protocol (its optional extras).

    Parameters
    ----------
    kind : str
        The robot's class name (named in messages).
    n_joints : int
        Shape dimension d.
    cycle_period : float
        Seconds per cycle.
    joint_ranges : ndarray of shape (d, 2) or None
        Declared joint limits (low < 0 < high), shape units.
    front_back_symmetric, mirror_symmetric : bool
        The chain reads the same from both ends (the symmetric gait family applies); the body and its medium
        read the same in a mirror along the body's axis (the half-wave family applies). A simulated
        :class:`~geogait.systems.PurcellSwimmer` declares them from its links.
    resistive_chain : dict or None
        The chain's geometry (``ResistanceModel(**resistive_chain)``) when the robot declares a chain in a
        resistive medium (``resistive_medium`` and ``chain_geometry()``).
    period_control : bool
        The robot offers ``set_cycle_period``.
    excitation : bool
        The robot takes the optimiser's exploration (``set_excitation``, unless ``accepts_excitation`` is false).
    saves_state : bool
        The robot offers ``robot_state`` and ``restore_robot_state`` (bit-identical resumes).
    system : System or None
        A simulator's system at the start (``current_system()``), else None.
    region : callable or None
        The shapes the robot may take, as it declares them: ``feasibility(shapes, jacobian=False)``, a signed margin
        ≥ 0 inside (a simulated system's singular set is read from ``system`` instead).
    symmetry_declared : bool
        The robot declares its symmetries (``front_back_symmetric`` or ``mirror_symmetric``), or is a simulated
        :class:`~geogait.systems.PurcellSwimmer`; else the optimiser may measure them.
    settle_cycles : int or None
        Cycles a gait change takes to settle, as the robot declares them (``settle_cycles``); 0 for a simulator of
        a principally kinematic system (``current_system()``: its motion follows the shape at once); None when
        not declared (``Safety(settle_cycles="auto")`` then measures them).
    perturbation_control : bool
        The robot offers ``set_perturbation_std`` (the path follower's exploration plans set it).
    """

    kind: str
    n_joints: int
    cycle_period: float
    joint_ranges: np.ndarray | None = None
    front_back_symmetric: bool = False
    mirror_symmetric: bool = False
    resistive_chain: dict | None = None
    period_control: bool = False
    excitation: bool = False
    saves_state: bool = False
    system: object = None
    region: object = None
    symmetry_declared: bool = True
    settle_cycles: int | None = None
    perturbation_control: bool = False

    @property
    def simulated(self) -> bool:
        """The robot offers ``current_system()`` (a simulator's truth)."""
        return self.system is not None


def read_robot_spec(robot, owner: str = "read_robot_spec") -> RobotSpec:
    """Read what ``robot`` declares (its optional extras, :data:`~geogait.robots.ROBOT_EXTRAS`), checked.

    Parameters
    ----------
    robot : Robot
    owner : str
        Who asks (named in error messages).

    Returns
    -------
    RobotSpec

    Raises
    ------
    GeogaitError
        The robot lacks a member of the protocol, or declares an extra malformed (e.g. ``joint_ranges`` of the
        wrong shape).
    """
    check_robot_members(robot, owner)
    system = robot.current_system() if callable(getattr(robot, "current_system", None)) else None
    swimmer = isinstance(system, PurcellSwimmer)
    lengths = np.asarray(system.link_lengths) if swimmer else None
    chain = None
    if getattr(robot, "resistive_medium", False) and callable(getattr(robot, "chain_geometry", None)):
        chain = robot.chain_geometry()
    return RobotSpec(
        kind=type(robot).__name__, n_joints=int(robot.n_joints), cycle_period=float(robot.cycle_period),
        joint_ranges=_joint_ranges(robot, owner),
        front_back_symmetric=_declared(robot, "front_back_symmetric",
                                       swimmer and bool(np.allclose(lengths, lengths[::-1]))),
        mirror_symmetric=_declared(robot, "mirror_symmetric", swimmer),
        resistive_chain=chain,
        period_control=callable(getattr(robot, "set_cycle_period", None)),
        excitation=callable(getattr(robot, "set_excitation", None))
        and bool(getattr(robot, "accepts_excitation", True)),
        saves_state=callable(getattr(robot, "robot_state", None))
        and callable(getattr(robot, "restore_robot_state", None)),
        system=system, region=robot.feasibility if callable(getattr(robot, "feasibility", None)) else None,
        symmetry_declared=swimmer or any(getattr(robot, name, None) is not None
                                         for name in ("front_back_symmetric", "mirror_symmetric")),
        settle_cycles=_settle_cycles(robot, system, owner),
        perturbation_control=callable(getattr(robot, "set_perturbation_std", None)))


def perturbation_std(robot) -> float:
    """The std of the perturbation δ a robot runs now, where it says (``perturbation_std``, or a
    :class:`~geogait.gaits.Perturbation` as ``perturbation``), else NaN: read at every cycle, since a robot with
    ``set_perturbation_std`` changes it."""
    std = getattr(robot, "perturbation_std", None)
    if std is None and isinstance(getattr(robot, "perturbation", None), Perturbation):
        std = robot.perturbation.stationary_std[0]
    return float(std) if std is not None else np.nan


def _settle_cycles(robot, system, owner: str) -> int | None:
    declared = getattr(robot, "settle_cycles", None)
    if declared is None:
        return 0 if system is not None else None
    if isinstance(declared, bool) or not isinstance(declared, int | np.integer) or declared < 0:
        raise fail("robot.settle_cycles", owner, "a count of cycles (an int >= 0)", declared)
    return int(declared)


def _declared(robot, name: str, otherwise: bool) -> bool:
    declared = getattr(robot, name, None)
    return bool(otherwise) if declared is None else bool(declared)


def _joint_ranges(robot, owner: str) -> np.ndarray | None:
    ranges = getattr(robot, "joint_ranges", None)
    if ranges is None:
        return None
    try:
        array = np.asarray(ranges, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != (robot.n_joints, 2) or np.any(np.isnan(array)) \
            or np.any(array[:, 0] >= 0) or np.any(array[:, 1] <= 0):
        raise fail("robot.joint_ranges", owner, f"an array of shape ({robot.n_joints}, 2) of (low < 0 < high) "
                   "joint ranges (rad)", ranges)
    return array


def check_within_joint_ranges(gait: FourierGait, spec: RobotSpec, name: str, owner: str, what: str = "gait") -> None:
    """Refuse a gait that leaves the joint ranges a robot declares, naming the first joint that does.

    Exact over the whole cycle: each joint's largest distance from its range's centre (refined by
    :meth:`~geogait.gaits.FourierGait.joint_limit`) against the range's half width.

    Parameters
    ----------
    gait : FourierGait
        The gait to check.
    spec : RobotSpec
        What the robot declares (:func:`read_robot_spec`); no ``joint_ranges``: nothing to check.
    name, owner : str
        The parameter and the function the error names (``"robot"`` of ``"InSituOptimizer.run"``).
    what : str, default "gait"
        What the gait is, in the message ("seed gait").

    Raises
    ------
    GeogaitError
        The gait leaves a declared range.
    """
    if spec.joint_ranges is None:
        return
    reach = float(gait.joint_limit().max()) + 1  # (a side beyond it cannot be left: clipped, it stays finite)
    ranges = np.clip(spec.joint_ranges, -reach, reach)
    centre, half = ranges.mean(axis=1), np.diff(ranges, axis=1)[:, 0] / 2
    centred = FourierGait(gait.coefficients - np.column_stack([centre, np.zeros((gait.n_joints, 2 * gait.order))]))
    outside = np.flatnonzero(centred.joint_limit() > half + FEASIBILITY_TOLERANCE)
    if outside.size:
        j = int(outside[0])
        shapes = gait.shape(np.linspace(0, 2 * np.pi, 1024, endpoint=False))[:, j]
        raise fail(name, owner, f"a {what} within the joint_ranges the robot declares (joint {j}: "
                   f"[{spec.joint_ranges[j, 0]:.4g}, {spec.joint_ranges[j, 1]:.4g}] rad)",
                   f"a gait moving joint {j} over [{shapes.min():.4g}, {shapes.max():.4g}] rad")
