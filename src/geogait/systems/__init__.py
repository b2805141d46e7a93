"""Simulated principally kinematic locomotors: the Purcell swimmer, the wheeled kinematic snake, user
connections, connections sampled on a grid (from other tools) and feasible regions of the user's."""

from ._base import FeasibleSystem, FunctionSystem, System, height_function
from ._grid import GridSystem
from ._purcell import BODY_FRAMES, PurcellSwimmer
from ._region import RegionSystem
from ._snake import KinematicSnake

__all__ = [
    "BODY_FRAMES", "FeasibleSystem", "FunctionSystem", "GridSystem", "KinematicSnake", "PurcellSwimmer", "RegionSystem",
    "System", "height_function",
]
