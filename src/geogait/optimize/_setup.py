"""What a run fixes before its first cycle, from the optimiser's parts and what the robot declares: the gait family,
the joint limit, the unit of shape, the settling cycles, the period range, the model-class test, the budget."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .._defaults import MAX_JOINT_ANGLE
from .._validation import check_int, fail
from ..gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily
from ..robots import RobotSpec
from ._adaptation import Adaptation
from ._measure import peak_phase_speed
from ._model_class import PERIOD_RATIO, ModelClassCheck, second_period, smallest_budget
from ._parts import Limits, PeriodSearch, Safety

#: r_max of a robot that declares no joint ranges (the design's 2π/3).
DEFAULT_MAX_JOINT_ANGLE = MAX_JOINT_ANGLE


def gait_family(optimizer, spec: RobotSpec, gait: FourierGait):
    """The family ``optimizer`` searches from the seed ``gait`` (its ``family`` parameter): SymmetricGaitFamily
    about the seed, MirrorGaitFamily or FreeGaitFamily."""
    owner = "InSituOptimizer.run"
    kind, order, checks = optimizer.family, optimizer.order, optimizer.checks
    if kind == "free":
        return FreeGaitFamily(gait.n_joints, order)
    if kind in ("auto", "symmetric") and gait.n_joints >= 2:
        symmetric = SymmetricGaitFamily.from_gait(gait, order)
        member = symmetric.residual(gait) <= 1e-9
        if kind == "symmetric" and not member:
            raise fail("robot", owner, "a seed gait with front-back symmetry for family 'symmetric'",
                       f"a gait at distance {symmetric.residual(gait):.3g} from the family")
        if kind == "symmetric" or (member and spec.front_back_symmetric):
            return symmetric
    elif kind == "symmetric":
        raise fail("family", owner, "'free' or 'mirror' for a robot with one joint", kind)
    mirror = MirrorGaitFamily(gait.n_joints, order)
    member = mirror.residual(gait) <= 1e-9
    if kind == "mirror" and not member:
        raise fail("robot", owner, "a half-wave symmetric seed gait (no offsets or even harmonics) for family "
                   "'mirror'", f"a gait at distance {mirror.residual(gait):.3g} from the family")
    if kind == "mirror" or (member and spec.mirror_symmetric):
        return mirror
    # a robot that declares no symmetry: the half-wave family, on trial (the Adaptation widens it to the free
    # family once a gait of it turns the body beyond noise)
    adapts = checks is None or any(isinstance(c, Adaptation) and c.widen_family for c in checks)
    if kind == "auto" and member and not spec.symmetry_declared and adapts:
        return mirror
    return FreeGaitFamily(gait.n_joints, order)




def settle_at_start(safety: Safety, spec: RobotSpec) -> int:
    """The settling cycles a run starts with: the Safety's count, or for ``"auto"`` what the robot declares (0 where it
    declares nothing: they are measured at the first gait change)."""
    if safety.settle_cycles != "auto":
        return int(safety.settle_cycles)
    return spec.settle_cycles or 0


def stop_rule(stop, owner: str) -> Callable[[], bool] | None:
    """The ``stop`` argument as a callable: itself, or whether a file exists (None: never)."""
    if stop is None or callable(stop):
        return stop
    if isinstance(stop, str | os.PathLike):
        path = Path(stop)
        return path.exists
    raise fail("stop", owner, "None, a callable stop() -> bool or the path of a stop file", type(stop).__name__)


def check_budget(n_cycles, parts, owner: str) -> int | None:
    """A cycle budget that holds at least one measured cycle (:func:`smallest_budget`); None: no budget."""
    if n_cycles is None:
        return None
    test = 0 if parts.model_class is None else parts.model_class.cycles
    smallest = smallest_budget(parts.safety.declared_settle_cycles, test)
    return check_int(n_cycles, "n_cycles", owner, minimum=smallest)


# -- what the robot declares ---------------------------------------------------------------------
def commands_excitation(exploration, spec: RobotSpec, owner: str) -> bool:
    """Whether the optimiser commands the excitation (``exploration``) to this robot."""
    if exploration is None:
        return False
    if exploration != "auto" and not spec.excitation:
        raise fail("robot", owner, "a robot with set_excitation(shape, shape_velocity) for an Exploration "
                   "(or exploration='auto' / None)", spec.kind)
    return spec.excitation


def period_range(search: PeriodSearch | None, spec: RobotSpec, period: float, owner: str):
    """(shortest, longest) period of the period search (None when the period is fixed)."""
    if search is None:
        return None
    if not spec.period_control:
        raise fail("robot", owner, "a robot with set_cycle_period(seconds) for a PeriodSearch "
                   "(e.g. geogait.robots.MujocoRobot)", spec.kind)
    low, high = search.bounds(period)
    if not low <= period <= high:
        raise fail("period_range", owner, f"a range holding the robot's period ({period:g} s)", (low, high))
    return low, high


def model_class_check(parts, spec: RobotSpec, gait: FourierGait, period: float, period_range,
                       owner: str):
    """The run's model-class test (a ModelClassTest among the checks), or None."""
    test = parts.model_class
    if test is None:
        return None
    if not spec.period_control:
        raise fail("robot", owner, "a robot with set_cycle_period(seconds) for a ModelClassTest (the test runs the "
                   "seed gait at two periods)", spec.kind)
    low, high = period_range if period_range is not None else (0.0, np.inf)
    speed_limit = parts.limits.max_joint_velocity
    shortest = 0.0 if speed_limit is None else peak_phase_speed(gait) * 2 * np.pi / speed_limit
    other = second_period(period, low, high, shortest)
    if other is None:
        raise fail("checks", owner, f"no ModelClassTest, or a period range and joint-velocity limit that allow "
                   f"{PERIOD_RATIO:g} x or 1/{PERIOD_RATIO:g} x the robot's period ({period:g} s)", test)
    return ModelClassCheck(period, other, test.cycles, settle_cycles=parts.safety.declared_settle_cycles)


def joint_limit(limits: Limits, spec: RobotSpec) -> float:
    """r_max: the parameter, or (``"auto"``) from the robot's declared joint ranges."""
    if not isinstance(limits.max_joint_angle, str):
        return float(limits.max_joint_angle)
    if spec.joint_ranges is None:
        return DEFAULT_MAX_JOINT_ANGLE
    ranges = spec.joint_ranges
    limit = float(np.min(np.minimum(-ranges[:, 0], ranges[:, 1])))
    return limit if np.isfinite(limit) else DEFAULT_MAX_JOINT_ANGLE


def shape_scale(limits: Limits, seed: FourierGait) -> float:
    """The unit of shape (``shape_scale``): the parameter, or the seed gait's largest amplitude."""
    if not isinstance(limits.shape_scale, str):
        return float(limits.shape_scale)
    amplitude = float(np.sqrt((seed.coefficients[:, 1:] ** 2).sum(axis=1)).max())
    if not amplitude > 0:
        raise fail("robot", "InSituOptimizer.run", "a seed gait that moves its joints (shape_scale='auto' "
                   "is its amplitude)", "a constant gait")
    return amplitude
