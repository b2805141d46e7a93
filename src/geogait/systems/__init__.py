"""Simulated principally kinematic locomotors: the Purcell swimmer, the wheeled kinematic snake, user
connections and connections sampled on a grid (from other tools)."""

from ._base import FeasibleSystem, FunctionSystem, System, height_function
from ._grid import GridSystem
from ._purcell import BODY_FRAMES, PurcellSwimmer
from ._snake import KinematicSnake

__all__ = [
    "BODY_FRAMES", "FeasibleSystem", "FunctionSystem", "GridSystem", "KinematicSnake", "PurcellSwimmer", "System",
    "height_function",
]
