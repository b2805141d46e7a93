"""Robots and simulators geogait did not write: the protocol they implement and adapters for them."""

from ._protocol import ROBOT_EXTRAS, Robot, check_robot

__all__ = ["ROBOT_EXTRAS", "Robot", "check_robot"]
