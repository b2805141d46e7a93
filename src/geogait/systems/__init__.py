"""Simulated principally kinematic locomotors: the Purcell swimmer, the wheeled kinematic snake, user
connections, connections sampled on a grid (from other tools), feasible regions of the user's and linear shape
limits a robot declares."""

from ._base import FeasibleSystem, FunctionSystem, System, height_function
from ._grid import GridSystem
from ._purcell import BODY_FRAMES, PurcellSwimmer
from ._region import LinearRegion, RegionSystem
from ._snake import KinematicSnake

__all__ = [
    "BODY_FRAMES", "FeasibleSystem", "FunctionSystem", "GridSystem", "KinematicSnake", "LinearRegion", "PurcellSwimmer",
    "RegionSystem",
    "System", "height_function",
]
