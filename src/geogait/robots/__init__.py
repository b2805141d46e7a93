"""Robots: the protocol they implement, the built-in swimmer's stream (:class:`SwimmerStream`, defined in
:mod:`geogait.simulate`, where ``simulate`` is built on it) and adapters for robots and simulators geogait did
not write.

:class:`ProcessRobot` drives a robot in any language over the JSON-lines bridge
(``python -m geogait.robots.driver`` is the reference driver). :class:`MujocoRobot` turns any MuJoCo
model with hinge joints into a :class:`Robot`; it needs the optional extra
``pip install 'geogait[mujoco]'`` (imported only when a MuJoCo model is loaded).
:class:`ElasticaSnake` is PyElastica's continuum snake on rest-curvature control
(``pip install 'geogait[elastica]'``, imported only when a snake is built), built on the numpy-only
helpers of :mod:`geogait.robots.continuum` (body frame, curvature, modal shape coordinates).
"""

from ..simulate import SwimmerStream
from ._bridge import PERIOD_RANGE, PROTOCOL, PROTOCOL_VERSION, ProcessRobot
from ._check import check_cycle, check_robot
from ._elastica import ElasticaSnake, elastica_snake, snake_seed_gait
from ._mujoco import (
    MODELS_DIRECTORY,
    MujocoRobot,
    dm_control_swimmer,
    gymnasium_swimmer,
    load_mujoco_model,
    mujoco_swimmer,
    purcell_swimmer_xml,
)
from ._protocol import ROBOT_EXTRAS, Robot, check_robot_members
from ._spec import RobotSpec, check_within_joint_ranges, perturbation_std, read_robot_spec
from ._wrapper import RobotWrapper
from .continuum import (
    CurvatureModes,
    body_pose,
    body_velocity,
    curvature_profile,
    curvature_rate,
    rod_from_curvature,
    tangent_angles,
)

__all__ = [
    "MODELS_DIRECTORY",
    "PERIOD_RANGE",
    "PROTOCOL",
    "PROTOCOL_VERSION",
    "ROBOT_EXTRAS",
    "CurvatureModes",
    "ElasticaSnake",
    "MujocoRobot",
    "ProcessRobot",
    "Robot",
    "RobotSpec",
    "RobotWrapper",
    "SwimmerStream",
    "body_pose",
    "body_velocity",
    "check_cycle",
    "check_robot",
    "check_robot_members",
    "curvature_profile",
    "curvature_rate",
    "dm_control_swimmer",
    "elastica_snake",
    "gymnasium_swimmer",
    "load_mujoco_model",
    "mujoco_swimmer",
    "purcell_swimmer_xml",
    "perturbation_std",
    "check_within_joint_ranges",
    "read_robot_spec",
    "rod_from_curvature",
    "snake_seed_gait",
    "tangent_angles",
]
