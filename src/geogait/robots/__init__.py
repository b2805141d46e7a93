"""Robots and simulators geogait did not write: the protocol they implement and adapters for them.

:class:`ProcessRobot` drives a robot in any language over the JSON-lines bridge
(``python -m geogait.robots.driver`` is the reference driver). :class:`MujocoRobot` turns any MuJoCo
model with hinge joints into a :class:`Robot`; it needs the optional extra
``pip install 'geogait[mujoco]'`` (imported only when a MuJoCo model is loaded).
"""

from ._bridge import PROTOCOL, PROTOCOL_VERSION, ProcessRobot
from ._mujoco import (
    MODELS_DIRECTORY,
    MujocoRobot,
    gymnasium_swimmer,
    load_mujoco_model,
    mujoco_swimmer,
    purcell_swimmer_xml,
)
from ._protocol import ROBOT_EXTRAS, Robot, check_robot

__all__ = ["MODELS_DIRECTORY", "PROTOCOL", "PROTOCOL_VERSION", "ROBOT_EXTRAS", "MujocoRobot", "ProcessRobot", "Robot",
           "check_robot", "gymnasium_swimmer", "load_mujoco_model", "mujoco_swimmer", "purcell_swimmer_xml"]
