"""Steering and path following with the adaptive gait model (motion tracking to precision).

* :class:`ReferencePath`: lines, circles, figure-eights and waypoint polylines; cross-track and
  heading errors.
* Steering gaits (:func:`solve_steering_gait`, :func:`steering_family`, :func:`max_step_family`):
  the gait nearest the straight optimum whose predicted net motion per cycle matches a commanded
  step and turn, from a gait model (:class:`ModelMotion`) or the true connection
  (:class:`TrueMotion`).
* :class:`PathTracker`: a receding-horizon controller that follows a path cycle by cycle on any
  :class:`geogait.robots.Robot` while the adaptive model keeps learning.
* Exploration sized online (:class:`AdaptiveExploration`): the perturbation δ std of each cycle from the
  controller's prediction residual, set on robots with ``set_perturbation_std`` (the simulated swimmers).
"""

from ..simulate import TrueMotion, end_pose
from ._exploration import AdaptiveExploration, prediction_surprise, surprise_alarm
from ._paths import PATH_KINDS, ReferencePath
from ._steering import (
    TURN_SPACING,
    ModelMotion,
    SteeringFamily,
    SteeringSolution,
    max_feasible_turn,
    max_step_family,
    solve_steering_gait,
    steering_family,
    travel_rows,
)
from ._tracker import CONTROLLERS, DEFAULT_TURN_LIMIT, EXPLORATION, PathTracker, TrackingResult, check_plan_size

__all__ = [
    "AdaptiveExploration",
    "CONTROLLERS",
    "DEFAULT_TURN_LIMIT",
    "EXPLORATION",
    "PATH_KINDS",
    "ModelMotion",
    "PathTracker",
    "ReferencePath",
    "SteeringFamily",
    "SteeringSolution",
    "TURN_SPACING",
    "TrackingResult",
    "TrueMotion",
    "check_plan_size",
    "end_pose",
    "max_feasible_turn",
    "max_step_family",
    "prediction_surprise",
    "surprise_alarm",
    "solve_steering_gait",
    "steering_family",
    "travel_rows",
]
