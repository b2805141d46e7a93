"""Robots and simulators geogait did not write: the protocol they implement and adapters for them."""

from ._bridge import PROTOCOL, PROTOCOL_VERSION, ProcessRobot
from ._protocol import ROBOT_EXTRAS, Robot, check_robot

__all__ = ["PROTOCOL", "PROTOCOL_VERSION", "ROBOT_EXTRAS", "ProcessRobot", "Robot", "check_robot"]
